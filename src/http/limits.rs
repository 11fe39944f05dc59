//! Per-client limits, so that one client cannot take from the others what they share: how many
//! connections one address holds ([`HttpConfig::max_connections_per_client`], at accept), how
//! many uploads one client sends at once ([`HttpConfig::max_uploads_per_client`]), how many
//! event streams one client follows ([`HttpConfig::max_streams_per_client`]), and the bytes of
//! request bodies held process-wide, charged as they arrive ([`ChargedBody`]), not as they are
//! announced: a client that declares 64 MiB and sends a byte a second holds a byte.
//!
//! A client is its API key, or its address on a server without keys ([`client_of`]). Each
//! refusal is a `429 too-many` with `Retry-After`, naming the limit and its setting — the
//! shape of nginx's `limit_conn`, keyed as nginx keys it.
//!
//! Requests of one client are paced ([`Pace`], nginx's `limit_req` with a burst, a token bucket
//! of the `governor` crate): past its rate a request waits for its turn, up to a second, so a
//! client that sends requests one after another is slowed to the rate; past that second, `429`.
//!
//! [`HttpConfig::max_connections_per_client`]: super::HttpConfig::max_connections_per_client
//! [`HttpConfig::max_uploads_per_client`]: super::HttpConfig::max_uploads_per_client
//! [`HttpConfig::max_streams_per_client`]: super::HttpConfig::max_streams_per_client

use super::AppError;
use super::auth::Principal;
use axum::body::{Body, Bytes};
use axum::extract::{ConnectInfo, Request};
use axum::http::StatusCode;
use http_body::{Frame, SizeHint};
use std::collections::HashMap;
use std::net::{IpAddr, SocketAddr};
use std::pin::Pin;
use std::sync::atomic::{AtomicBool, Ordering};
use std::sync::{Arc, Mutex};
use std::task::{Context, Poll};
use tokio::sync::{OwnedSemaphorePermit, Semaphore};

/// Counts of something each client holds (uploads, streams, connections), by client.
#[derive(Default)]
pub struct PerClient(Mutex<HashMap<String, usize>>);

/// One held unit of a [`PerClient`] count; dropping it gives it back.
pub struct Held {
    of: Arc<PerClient>,
    client: String,
}

impl PerClient {
    /// Takes one unit for `client` if it holds fewer than `cap`; its count otherwise.
    pub fn take(self: &Arc<Self>, client: &str, cap: usize) -> Result<Held, usize> {
        let mut m = self.0.lock().unwrap_or_else(|e| e.into_inner());
        let n = m.entry(client.to_string()).or_insert(0);
        if *n >= cap {
            return Err(*n);
        }
        *n += 1;
        Ok(Held {
            of: self.clone(),
            client: client.to_string(),
        })
    }

    /// How many units `client` holds.
    pub fn count(&self, client: &str) -> usize {
        let m = self.0.lock().unwrap_or_else(|e| e.into_inner());
        m.get(client).copied().unwrap_or(0)
    }
}

impl Drop for Held {
    fn drop(&mut self) {
        let mut m = self.of.0.lock().unwrap_or_else(|e| e.into_inner());
        if let Some(n) = m.get_mut(&self.client) {
            *n -= 1;
            if *n == 0 {
                m.remove(&self.client);
            }
        }
    }
}

/// The address a connection came from (put in each request's extensions by
/// [`super::server::run`]).
pub fn peer(req: &Request) -> Option<IpAddr> {
    req.extensions()
        .get::<ConnectInfo<SocketAddr>>()
        .map(|c| c.0.ip())
}

/// The client a request counts against: its key's name, or `ip:ADDRESS` for a server without
/// keys (or a request that carries none).
pub fn client_of(req: &Request) -> String {
    match req.extensions().get::<Principal>() {
        Some(p) if !p.owner.is_empty() => format!("key:{}", p.owner),
        _ => match peer(req) {
            Some(ip) => format!("ip:{ip}"),
            None => "ip:unknown".into(),
        },
    }
}

/// The client of a request, as [`client_of`] names it (an extension every handler may take:
/// [`super::server::admit_body`] puts it there).
#[derive(Clone, Debug)]
pub struct Client(pub String);

/// The refusal of a per-client limit: what is limited, how many the client holds, the setting.
pub fn too_many(what: &str, held: usize, setting: &str) -> AppError {
    AppError::new(
        StatusCode::TOO_MANY_REQUESTS,
        "too-many",
        "Too many at once",
        format!(
            "this client already has {held} {what} open, the most one client may ({setting}); \
             retry when one has ended"
        ),
    )
    .retry_after(1)
}

/// What a [`ChargedBody`] has taken from the process-wide budget of body bytes: held until the
/// request is answered, and whether the budget ran out while the body arrived.
#[derive(Default)]
pub struct Charge {
    permit: Mutex<Option<OwnedSemaphorePermit>>,
    pub exhausted: AtomicBool,
}

/// The error a [`ChargedBody`] ends with when the budget has no room for its next bytes.
#[derive(Debug)]
pub struct BudgetFull;

impl std::fmt::Display for BudgetFull {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.write_str("the server holds as many request bytes as it accepts at once")
    }
}

impl std::error::Error for BudgetFull {}

/// A request body that takes a permit (one per KiB) from `budget` for each chunk as it
/// arrives, and ends with [`BudgetFull`] when there is none.
pub struct ChargedBody {
    inner: Body,
    budget: Arc<Semaphore>,
    charge: Arc<Charge>,
    bytes: usize,
    kib: usize,
    /// The client's upload slot, given back once the body has been read (or dropped).
    slot: Option<Held>,
}

impl ChargedBody {
    pub fn new(
        inner: Body,
        budget: Arc<Semaphore>,
        charge: Arc<Charge>,
        slot: Option<Held>,
    ) -> ChargedBody {
        ChargedBody {
            inner,
            budget,
            charge,
            bytes: 0,
            kib: 0,
            slot,
        }
    }

    /// Takes permits for `n` more bytes; false when the budget is out of them.
    fn take(&mut self, n: usize) -> bool {
        self.bytes += n;
        let want = self.bytes.div_ceil(1024);
        let more = want - self.kib;
        if more == 0 {
            return true;
        }
        let Ok(p) = u32::try_from(more)
            .ok()
            .and_then(|m| self.budget.clone().try_acquire_many_owned(m).ok())
            .ok_or(())
        else {
            return false;
        };
        self.kib = want;
        let mut held = self.charge.permit.lock().unwrap_or_else(|e| e.into_inner());
        match held.as_mut() {
            Some(h) => h.merge(p),
            None => *held = Some(p),
        }
        true
    }
}

impl http_body::Body for ChargedBody {
    type Data = Bytes;
    type Error = axum::BoxError;

    fn poll_frame(
        mut self: Pin<&mut Self>,
        cx: &mut Context<'_>,
    ) -> Poll<Option<Result<Frame<Bytes>, Self::Error>>> {
        let this = &mut *self;
        match Pin::new(&mut this.inner).poll_frame(cx) {
            Poll::Ready(Some(Ok(f))) => {
                let n = f.data_ref().map_or(0, |d| d.len());
                if this.take(n) {
                    Poll::Ready(Some(Ok(f)))
                } else {
                    this.charge.exhausted.store(true, Ordering::SeqCst);
                    Poll::Ready(Some(Err(Box::new(BudgetFull))))
                }
            }
            Poll::Ready(Some(Err(e))) => Poll::Ready(Some(Err(e.into()))),
            Poll::Ready(None) => {
                this.slot = None;
                Poll::Ready(None)
            }
            Poll::Pending => Poll::Pending,
        }
    }

    fn is_end_stream(&self) -> bool {
        self.inner.is_end_stream()
    }

    fn size_hint(&self) -> SizeHint {
        self.inner.size_hint()
    }
}

/// Requests a second of each client ([`super::HttpConfig::requests_per_client`]), a second's
/// worth of them at once: a request past them waits for its turn, up to [`Pace::MAX_WAIT`],
/// then gets `429 too-many`. `/healthz`, `/readyz` and `/metrics` are not paced.
pub struct Pace {
    limiter: governor::DefaultKeyedRateLimiter<String>,
    /// Requests paced, for forgetting idle clients now and then.
    seen: std::sync::atomic::AtomicU64,
}

impl Pace {
    /// The longest a request waits for its turn.
    pub const MAX_WAIT: std::time::Duration = std::time::Duration::from_secs(1);

    /// `per_second` requests a second a client (None for 0: no pacing).
    pub fn new(per_second: u32) -> Option<Pace> {
        let rate = std::num::NonZeroU32::new(per_second)?;
        Some(Pace {
            limiter: governor::RateLimiter::keyed(governor::Quota::per_second(rate)),
            seen: Default::default(),
        })
    }

    /// Waits for `client`'s turn; `Err` (how long it would have waited) past [`Self::MAX_WAIT`].
    pub async fn turn(&self, client: &str) -> Result<(), std::time::Duration> {
        use governor::clock::{Clock, DefaultClock};
        if self.seen.fetch_add(1, Ordering::Relaxed) % 4096 == 4095 {
            // Clients whose bucket is full again are forgotten.
            self.limiter.retain_recent();
            self.limiter.shrink_to_fit();
        }
        let key = client.to_string();
        let start = std::time::Instant::now();
        loop {
            let Err(not_until) = self.limiter.check_key(&key) else {
                return Ok(());
            };
            let wait = not_until.wait_time_from(DefaultClock::default().now());
            if start.elapsed() + wait > Self::MAX_WAIT {
                return Err(start.elapsed() + wait);
            }
            // Pacing, not synchronisation: the client's next token is due then.
            tokio::time::sleep(wait).await;
        }
    }
}

/// Middleware: paces each client's requests ([`Pace`]).
pub async fn pace(
    axum::extract::State(st): axum::extract::State<super::AppState>,
    req: Request,
    next: axum::middleware::Next,
) -> axum::response::Response {
    use axum::response::IntoResponse;
    let exempt = matches!(req.uri().path(), "/healthz" | "/readyz" | "/metrics");
    if let (Some(p), false) = (st.limits.pace.as_ref(), exempt)
        && let Err(wait) = p.turn(&client_of(&req)).await
    {
        let rate = st.cfg.requests_per_client;
        return AppError::new(
            StatusCode::TOO_MANY_REQUESTS,
            "too-many",
            "Too many at once",
            format!(
                "this client sends more than {rate} requests a second, the most one client may \
                 (CAUSTICA_REQUESTS_PER_CLIENT); its next turn is in {:.1} s",
                wait.as_secs_f64()
            ),
        )
        .retry_after(wait.as_secs().max(1))
        .into_response();
    }
    next.run(req).await
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn per_client_counts_are_given_back() {
        let c = Arc::new(PerClient::default());
        let a = c.take("a", 2).unwrap();
        let _b = c.take("a", 2).unwrap();
        assert_eq!(c.take("a", 2).err(), Some(2));
        assert!(c.take("other", 2).is_ok(), "another client is not counted");
        drop(a);
        assert_eq!(c.count("a"), 1);
        assert!(c.take("a", 2).is_ok());
    }

    #[tokio::test]
    async fn a_body_is_charged_as_it_arrives() {
        let budget = Arc::new(Semaphore::new(4));
        let charge = Arc::new(Charge::default());
        let body = Body::from(vec![0u8; 3000]);
        let charged = Body::new(ChargedBody::new(body, budget.clone(), charge.clone(), None));
        let got = axum::body::to_bytes(charged, usize::MAX).await.unwrap();
        assert_eq!(got.len(), 3000);
        assert_eq!(budget.available_permits(), 1, "3 KiB held until answered");
        drop(charge);
        assert_eq!(budget.available_permits(), 4);
        let charge = Arc::new(Charge::default());
        let body = Body::from(vec![0u8; 5000]);
        let charged = Body::new(ChargedBody::new(body, budget.clone(), charge.clone(), None));
        let e = axum::body::to_bytes(charged, usize::MAX).await.unwrap_err();
        assert!(charge.exhausted.load(Ordering::SeqCst), "{e}");
    }
}
