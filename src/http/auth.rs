//! API keys: who may do what.
//!
//! Keys are given as lines `NAME SCOPE SHA256` (the key's SHA-256 in hex, so a key file holds
//! no key), in a file (`--api-keys FILE`, `CAUSTICA_API_KEYS_FILE`) or the environment
//! (`CAUSTICA_API_KEYS`, lines or `;`-separated); `caustica key new NAME` makes a key and its
//! line. `SCOPE` is `user` or `admin`. A client sends `Authorization: Bearer KEY`.
//!
//! With keys configured, every `/v1` route needs one (401 without), and `/metrics` needs an
//! admin key (403 for a user's). Each scene, job and idempotency key belongs to the keys that
//! created or asked for it ([`Principal::owner`]): another user's id answers 404, a bake asked
//! for by two users is one job they both hold, and a user's `DELETE` drops only that user's
//! hold (the job is canceled once nobody holds it). Admin keys see and cancel everything.
//! Without keys (the loopback default), every client is the one anonymous admin.

use super::{AppError, AppState};
use axum::extract::{Request, State};
use axum::http::{HeaderValue, StatusCode, header};
use axum::middleware::Next;
use axum::response::{IntoResponse, Response};
use std::collections::HashMap;

/// Who is asking.
#[derive(Clone, Debug, PartialEq)]
pub struct Principal {
    /// The key's name; empty for the anonymous client of a server without keys.
    pub owner: String,
    pub admin: bool,
}

impl Principal {
    pub fn anonymous() -> Principal {
        Principal {
            owner: String::new(),
            admin: true,
        }
    }
}

/// Holds job `id` for `p`, refusing it past [`super::HttpConfig::max_jobs_per_key`] queued
/// or running jobs of theirs (users only: admins and the anonymous client of a keyless server
/// have no quota), so that one client cannot fill the queues the others share. The count and
/// the hold are one step in the store, so submissions at once cannot pass the quota together.
pub fn hold_within_quota(st: &AppState, p: &Principal, id: &str) -> Result<(), AppError> {
    match st.jobs.hold_job(id, &p.owner)? {
        Ok(()) => Ok(()),
        Err(n) => Err(AppError::new(
            StatusCode::TOO_MANY_REQUESTS,
            "quota",
            "Quota reached",
            format!(
                "key '{}' has {n} queued or running jobs, the most one key may have; retry \
                 when some have finished",
                p.owner
            ),
        )
        .retry_after(5)),
    }
}

/// Refuses a request of `p` that would store `adding` bytes more (0: a job, whose result's
/// size is not known yet) past [`super::HttpConfig::max_bytes_per_key`] of scenes and results
/// (users only, as the job quota). A check before the write, not one step with it: keys may
/// pass it by what they write at once (at most their uploads in flight and running jobs).
/// The count walks the key's holds (40 ms for 10,000 jobs at a million rows), so a key whose
/// count, with what it adds, is under half its quota is trusted for [`HELD_FOR`] — adding
/// what its scenes add meanwhile — and counted again otherwise.
pub fn within_storage(st: &AppState, p: &Principal, adding: u64) -> Result<(), AppError> {
    let cap = st.cfg.max_bytes_per_key;
    if cap == 0 || p.admin || p.owner.is_empty() {
        return Ok(());
    }
    let lock = || st.limits.held.lock().unwrap_or_else(|e| e.into_inner());
    let far = lock()
        .get(&p.owner)
        .filter(|(b, at)| at.elapsed() < HELD_FOR && b.saturating_add(adding) <= cap / 2)
        .map(|(b, _)| *b);
    let held = match far {
        Some(b) => b,
        None => st.jobs.store.held_bytes(&p.owner)?,
    };
    let over = match adding {
        0 => held >= cap,
        n => held.saturating_add(n) > cap,
    };
    if !over {
        let mut m = lock();
        if m.len() >= 10_000 {
            m.clear();
        }
        let at = match far {
            Some(_) => m
                .get(&p.owner)
                .map_or_else(std::time::Instant::now, |e| e.1),
            None => std::time::Instant::now(),
        };
        m.insert(p.owner.clone(), (held + adding, at));
        return Ok(());
    }
    let mib = |b: u64| format!("{:.1} MiB", b as f64 / (1 << 20) as f64);
    Err(AppError::new(
        StatusCode::TOO_MANY_REQUESTS,
        "quota",
        "Quota reached",
        format!(
            "key '{}' holds {} of scenes and results{}, and may hold {} \
             (CAUSTICA_MAX_BYTES_PER_KEY); delete renders, bakes or scenes it no longer needs",
            p.owner,
            mib(held),
            if adding > 0 {
                format!(" and sends {}", mib(adding))
            } else {
                String::new()
            },
            mib(cap)
        ),
    )
    .retry_after(60))
}

/// How long [`within_storage`] trusts a key's count of bytes while it is under half its quota.
pub const HELD_FOR: std::time::Duration = std::time::Duration::from_secs(10);

/// The job quota [`hold_within_quota`] holds to: `cap` for a user key, none for an admin key
/// or the anonymous client.
pub fn quota(keys: &Keys, cap: usize) -> crate::jobs::Quota {
    let admins: std::collections::HashSet<String> = keys
        .by_hash
        .values()
        .filter(|p| p.admin)
        .map(|p| p.owner.clone())
        .collect();
    Box::new(move |owner| (!owner.is_empty() && !admins.contains(owner)).then_some(cap))
}

/// The configured keys, by the SHA-256 of the key.
#[derive(Clone, Debug, Default)]
pub struct Keys {
    by_hash: HashMap<String, Principal>,
}

/// SHA-256 of a key, hex.
pub fn hash_key(key: &str) -> String {
    crate::jobs::scenes::sha256_hex(key.as_bytes())
}

/// A fresh key: `ck_` and 32 random bytes in hex (from the operating system's generator).
pub fn new_key() -> std::io::Result<String> {
    use std::io::Read;
    let mut b = [0u8; 32];
    std::fs::File::open("/dev/urandom")?.read_exact(&mut b)?;
    Ok(format!(
        "ck_{}",
        b.iter().map(|x| format!("{x:02x}")).collect::<String>()
    ))
}

impl Keys {
    /// Parses key lines (`NAME SCOPE SHA256`; blank lines and `#` comments skipped); errors
    /// name `source` and the line.
    pub fn parse(&mut self, text: &str, source: &str) -> Result<(), String> {
        for (i, raw) in text.split(['\n', ';']).enumerate() {
            let line = raw.trim();
            if line.is_empty() || line.starts_with('#') {
                continue;
            }
            let at = format!("{source}, entry {}", i + 1);
            let parts: Vec<&str> = line.split_whitespace().collect();
            let [name, scope, hash] = parts[..] else {
                return Err(format!("{at}: expected `NAME SCOPE SHA256`, got {line:?}"));
            };
            let admin = match scope {
                "user" => false,
                "admin" => true,
                s => return Err(format!("{at}: scope {s:?} is neither `user` nor `admin`")),
            };
            let valid_name = name.len() <= 64
                && name
                    .bytes()
                    .all(|b| b.is_ascii_alphanumeric() || b"-_.@".contains(&b));
            if !valid_name {
                return Err(format!(
                    "{at}: name {name:?} must be 1..=64 letters, digits or -_.@"
                ));
            }
            let hash = hash.to_ascii_lowercase();
            if hash.len() != 64 || !hash.bytes().all(|b| b.is_ascii_hexdigit()) {
                return Err(format!(
                    "{at}: {hash:?} is not a SHA-256 in hex (store the key's hash, not the key: \
                     `caustica key new NAME` prints the line)"
                ));
            }
            if self.by_hash.values().any(|p| p.owner == name) {
                return Err(format!("{at}: the name {name:?} is given twice"));
            }
            let p = Principal {
                owner: name.to_string(),
                admin,
            };
            if self.by_hash.insert(hash, p).is_some() {
                return Err(format!("{at}: the same key is given twice"));
            }
        }
        Ok(())
    }

    /// The keys of `CAUSTICA_API_KEYS_FILE` (or `file`) and `CAUSTICA_API_KEYS`.
    pub fn from_env(
        file: Option<&std::path::Path>,
        get: &dyn Fn(&str) -> Option<String>,
    ) -> Result<Keys, String> {
        let mut keys = Keys::default();
        let file = file
            .map(std::path::Path::to_path_buf)
            .or_else(|| get("CAUSTICA_API_KEYS_FILE").map(Into::into));
        if let Some(f) = file {
            let text = std::fs::read_to_string(&f)
                .map_err(|e| format!("reading the API key file {}: {e}", f.display()))?;
            keys.parse(&text, &f.display().to_string())?;
        }
        if let Some(v) = get("CAUSTICA_API_KEYS") {
            keys.parse(&v, "CAUSTICA_API_KEYS")?;
        }
        Ok(keys)
    }

    pub fn is_empty(&self) -> bool {
        self.by_hash.is_empty()
    }

    pub fn len(&self) -> usize {
        self.by_hash.len()
    }

    /// The principal of a presented key.
    pub fn check(&self, key: &str) -> Option<&Principal> {
        self.by_hash.get(&hash_key(key))
    }
}

fn unauthorized(detail: &str) -> Response {
    let mut r = AppError::new(
        StatusCode::UNAUTHORIZED,
        "unauthorized",
        "Unauthorized",
        detail,
    )
    .into_response();
    r.headers_mut().insert(
        header::WWW_AUTHENTICATE,
        HeaderValue::from_static("Bearer realm=\"caustica\""),
    );
    r
}

/// Finds the request's [`Principal`] and puts it in its extensions; refuses `/v1` without a
/// valid key and `/metrics` without an admin key when keys are configured.
pub async fn authenticate(State(st): State<AppState>, mut req: Request, next: Next) -> Response {
    let path = req.uri().path();
    let guarded = path.starts_with("/v1/") || path == "/v1";
    let admin_only = path == "/metrics";
    let p = if st.cfg.keys.is_empty() {
        Principal::anonymous()
    } else if guarded || admin_only {
        let given = req
            .headers()
            .get(header::AUTHORIZATION)
            .and_then(|v| v.to_str().ok())
            .and_then(|v| {
                let (scheme, key) = v.trim().split_once(' ')?;
                scheme.eq_ignore_ascii_case("bearer").then(|| key.trim())
            });
        let Some(key) = given else {
            return unauthorized("this server needs an API key: send `Authorization: Bearer KEY`");
        };
        let Some(p) = st.cfg.keys.check(key) else {
            return unauthorized("the API key is not known to this server");
        };
        if admin_only && !p.admin {
            return AppError::new(
                StatusCode::FORBIDDEN,
                "forbidden",
                "Forbidden",
                format!("{path} needs an admin key"),
            )
            .into_response();
        }
        p.clone()
    } else {
        Principal {
            owner: String::new(),
            admin: false,
        }
    };
    req.extensions_mut().insert(p);
    next.run(req).await
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn key_lines_parse_and_bad_ones_are_named() {
        let k = new_key().unwrap();
        assert!(k.starts_with("ck_") && k.len() == 67);
        let mut keys = Keys::default();
        keys.parse(
            &format!(
                "# ops\nalice user {}\n\nroot admin {}",
                hash_key(&k),
                hash_key("r")
            ),
            "keys.txt",
        )
        .unwrap();
        assert_eq!(keys.len(), 2);
        assert_eq!(keys.check(&k).unwrap().owner, "alice");
        assert!(!keys.check(&k).unwrap().admin);
        assert!(keys.check("r").unwrap().admin);
        assert!(keys.check("nope").is_none());
        let err = |t: &str| Keys::default().parse(t, "env").unwrap_err();
        assert!(err("bob user ck_plaintext").contains("not a SHA-256"));
        assert!(err(&format!("bob owner {}", hash_key("x"))).contains("scope \"owner\""));
        assert!(err("bob user").contains("entry 1"));
        let twice = format!("a user {0};b user {0}", hash_key("x"));
        assert!(err(&twice).contains("entry 2: the same key"));
    }
}
