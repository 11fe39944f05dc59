//! `GET /v1/bakes/{id}/events`, `GET /v1/renders/{id}/events`: a job's live progress as
//! server-sent events. Each `progress` event carries `{id, state, progress, stage, eta_ms}`
//! when one of them changed visibly (at most ten a second); the stream ends with one `done`
//! event carrying the whole job (as `GET` of the job answers it) once the job is finished, or
//! with `gone` when it was deleted meanwhile. A finished job's stream is that one `done`
//! event. Comments keep an idle connection alive; server shutdown ends the stream.
//!
//! One client follows at most [`HttpConfig::max_streams_per_client`] streams at once (`429`
//! past it), and a stream lasts at most [`HttpConfig::stream_lifetime`]: then it ends without
//! `done`, and the `retry:` field of its first event (1 s) tells the client when to connect
//! again; an `EventSource` does so by itself, sending `Last-Event-ID`, and gets the job's
//! present state first.
//!
//! [`HttpConfig::max_streams_per_client`]: crate::http::HttpConfig::max_streams_per_client
//! [`HttpConfig::stream_lifetime`]: crate::http::HttpConfig::stream_lifetime

use super::jobs::{JobView, load_job, view};
use crate::http::auth::Principal;
use crate::http::limits::{Client, too_many};
use crate::http::{AppError, AppState};
use crate::jobs::{JobHandle, JobKind, JobState};
use axum::Extension;
use axum::extract::{Path, State};
use axum::response::sse::{Event, KeepAlive, Sse};
use axum::response::{IntoResponse, Response};
use serde::Serialize;
use std::sync::Arc;
use std::time::Duration;

/// The data of a `progress` event (a job's `events` stream).
#[derive(Serialize, PartialEq, Clone, schemars::JsonSchema)]
#[schemars(rename = "ProgressEvent")]
pub(crate) struct Progress {
    id: String,
    state: JobState,
    progress: f32,
    stage: String,
    #[serde(skip_serializing_if = "Option::is_none")]
    eta_ms: Option<i64>,
}

impl Progress {
    fn of(v: &JobView) -> Progress {
        Progress {
            id: v.id.clone(),
            state: v.state,
            progress: v.progress,
            stage: v.stage.clone(),
            eta_ms: v.eta_ms,
        }
    }

    /// Whether a client would see a difference from `o` (the ETA alone does not count).
    fn differs(&self, o: &Progress) -> bool {
        self.state != o.state
            || self.stage != o.stage
            || (self.progress - o.progress).abs() >= 0.005
    }
}

/// Shortest time between two `progress` events.
const MIN_GAP: Duration = Duration::from_millis(100);
/// How often a job with no live handle here (left queued by another process) is looked at.
const POLL: Duration = Duration::from_secs(1);

struct Stream {
    st: AppState,
    id: String,
    handle: Option<Arc<JobHandle>>,
    state_rx: Option<tokio::sync::watch::Receiver<JobState>>,
    progress_rx: Option<tokio::sync::watch::Receiver<()>>,
    last: Option<Progress>,
    seq: u64,
    ended: bool,
    /// When the stream ends even if the job has not ([`HttpConfig::stream_lifetime`]).
    ///
    /// [`HttpConfig::stream_lifetime`]: crate::http::HttpConfig::stream_lifetime
    until: tokio::time::Instant,
    /// The client's hold on one of its streams ([`crate::http::limits`]).
    _slot: crate::http::limits::Held,
}

/// What a client is told to wait before it connects again after a stream ends.
const RETRY: Duration = Duration::from_secs(1);

impl Stream {
    fn event(&mut self, name: &str, data: &impl Serialize) -> Event {
        self.seq += 1;
        let e = Event::default()
            .event(name)
            .id(self.seq.to_string())
            .json_data(data)
            .unwrap_or_else(|_| Event::default().event(name).data("{}"));
        if self.seq == 1 { e.retry(RETRY) } else { e }
    }

    /// Stops waiting on the job's live handle: its record is read every [`POLL`] instead.
    fn detach(&mut self) {
        self.handle = None;
        self.state_rx = None;
        self.progress_rx = None;
    }

    /// The next event, or `None` when the stream is over.
    async fn next(&mut self) -> Option<Event> {
        if self.ended {
            return None;
        }
        let mut stop = self.st.shutdown.clone();
        loop {
            if *stop.borrow() || tokio::time::Instant::now() >= self.until {
                return None;
            }
            let rec = match self.st.jobs.store.get_job(&self.id) {
                Ok(Some(r)) => r,
                Ok(None) => {
                    self.ended = true;
                    let id = self.id.clone();
                    return Some(self.event("gone", &serde_json::json!({ "id": id })));
                }
                Err(e) => {
                    tracing::warn!(job = %self.id, error = %e, "events: job not readable");
                    return None;
                }
            };
            let v = view(rec, self.handle.as_deref());
            if !v.state.is_terminal()
                && self
                    .handle
                    .as_ref()
                    .is_some_and(|h| h.state().is_terminal())
            {
                // The job ended but its record does not say so (yet, or its write failed):
                // no further change will wake us, so read the record from now on.
                self.detach();
            }
            if v.state.is_terminal() {
                self.ended = true;
                return Some(self.event("done", &v));
            }
            let now = Progress::of(&v);
            if self.last.as_ref().is_none_or(|l| now.differs(l)) {
                self.last = Some(now.clone());
                return Some(self.event("progress", &now));
            }
            // Nothing new: wait for a change (or, without a live handle, a while).
            let changed = async {
                match (&mut self.state_rx, &mut self.progress_rx) {
                    (Some(s), Some(p)) => {
                        tokio::select! {
                            r = s.changed() => r.is_ok(),
                            r = p.changed() => r.is_ok(),
                        }
                    }
                    _ => {
                        tokio::time::sleep(POLL).await;
                        true
                    }
                }
            };
            let alive = tokio::select! {
                a = changed => a,
                _ = stop.wait_for(|s| *s) => return None,
                _ = tokio::time::sleep_until(self.until) => return None,
            };
            if !alive {
                // The handle's senders are gone (the job left this process); read the record.
                self.detach();
            }
            tokio::time::sleep(MIN_GAP).await;
        }
    }
}

async fn job_events(
    st: AppState,
    id: String,
    kind: JobKind,
    p: &Principal,
    client: String,
) -> Result<Response, AppError> {
    load_job(&st, &id, kind, p)?;
    let slot = st
        .limits
        .streams
        .take(&client, st.cfg.max_streams_per_client)
        .map_err(|n| too_many("event streams", n, "CAUSTICA_MAX_STREAMS_PER_CLIENT"))?;
    let handle = st.jobs.handle(&id);
    let s = Stream {
        until: tokio::time::Instant::now() + st.cfg.stream_lifetime,
        _slot: slot,
        state_rx: handle.as_ref().map(|h| h.subscribe()),
        progress_rx: handle.as_ref().map(|h| h.subscribe_progress()),
        handle,
        st,
        id,
        last: None,
        seq: 0,
        ended: false,
    };
    let stream = futures_util::stream::unfold(s, |mut s| async move {
        let e = s.next().await?;
        Some((Ok::<_, std::convert::Infallible>(e), s))
    });
    Ok(Sse::new(stream)
        .keep_alive(KeepAlive::default())
        .into_response())
}

pub async fn bake_events(
    State(st): State<AppState>,
    Extension(p): Extension<Principal>,
    Extension(client): Extension<Client>,
    Path(id): Path<String>,
) -> Result<Response, AppError> {
    job_events(st, id, JobKind::Bake, &p, client.0).await
}

pub async fn render_events(
    State(st): State<AppState>,
    Extension(p): Extension<Principal>,
    Extension(client): Extension<Client>,
    Path(id): Path<String>,
) -> Result<Response, AppError> {
    job_events(st, id, JobKind::Render, &p, client.0).await
}
