//! `GET /v1/bakes`, `GET /v1/renders`, `GET /v1/scenes`: what the caller holds (an admin:
//! everything), newest first, a page at a time. Query parameters: `page_size` (1..=100,
//! default 20), `page_token` (the previous page's `next_page_token`), `created_since` (ms
//! since the epoch, inclusive), and for jobs `state` and `method`. An unknown parameter, or one
//! that does not apply, is a 422 naming it, as is a bad value.

use super::jobs::{JobView, view};
use super::{blocking, principal};
use crate::http::auth::Principal;
use crate::http::{AppError, AppState};
use crate::jobs::store::JobFilter;
use crate::jobs::{JobKind, JobState};
use crate::methods::Method;
use axum::Json;
use axum::extract::{Request, State};
use serde::Serialize;

pub const DEFAULT_PAGE_SIZE: usize = 20;
pub const MAX_PAGE_SIZE: usize = 100;

/// A page of a list: its items and, when more follow, the token of the next page.
#[derive(Serialize, schemars::JsonSchema)]
#[schemars(rename = "{T}Page")]
pub struct Page<T> {
    pub items: Vec<T>,
    /// The `page_token` of the next page; null on the last page.
    pub next_page_token: Option<String>,
}

/// A scene as a list shows it (`GET /v1/scenes/{id}` has the rest).
#[derive(Serialize, schemars::JsonSchema)]
pub struct SceneSummary {
    pub id: String,
    /// The scene's name ('' when it has none).
    pub name: String,
    /// Milliseconds since the Unix epoch.
    pub created_at: i64,
}

/// The parsed query of a list.
#[derive(Default)]
struct ListQuery {
    page_size: Option<usize>,
    after: Option<i64>,
    created_since: Option<i64>,
    state: Option<JobState>,
    method: Option<Method>,
}

/// Page tokens: opaque to clients; versioned so that their form may change.
fn page_token(cursor: i64) -> String {
    format!("p1.{cursor:x}")
}

fn parse_token(t: &str) -> Option<i64> {
    let hex = t.strip_prefix("p1.")?;
    if hex.is_empty() || hex.len() > 16 {
        return None;
    }
    i64::from_str_radix(hex, 16).ok().filter(|&c| c > 0)
}

fn parse_query(raw: Option<&str>, jobs: bool) -> Result<ListQuery, AppError> {
    let mut q = ListQuery::default();
    let pairs: Vec<(String, String)> = serde_urlencoded::from_str(raw.unwrap_or(""))
        .map_err(|e| AppError::bad_request(format!("the query string is malformed: {e}")))?;
    let mut seen = std::collections::HashSet::new();
    for (k, v) in pairs {
        let bad = |what: &str| AppError::invalid(&k, format!("{k}: {what}, not '{v}'"));
        if !seen.insert(k.clone()) {
            return Err(AppError::invalid(&k, format!("{k}: given more than once")));
        }
        match k.as_str() {
            "page_size" => {
                let n = v
                    .parse::<usize>()
                    .ok()
                    .filter(|n| (1..=MAX_PAGE_SIZE).contains(n))
                    .ok_or_else(|| bad(&format!("an integer in 1..={MAX_PAGE_SIZE}")))?;
                q.page_size = Some(n);
            }
            "page_token" => {
                q.after = Some(
                    parse_token(&v).ok_or_else(|| bad("the next_page_token of an earlier page"))?,
                );
            }
            "created_since" => {
                q.created_since = Some(
                    v.parse::<i64>()
                        .ok()
                        .filter(|&t| t >= 0)
                        .ok_or_else(|| bad("milliseconds since the Unix epoch"))?,
                );
            }
            "state" if jobs => {
                let names: Vec<&str> = JobState::ALL.iter().map(|s| s.as_str()).collect();
                q.state = Some(
                    JobState::parse(&v)
                        .ok_or_else(|| bad(&format!("one of {}", names.join(", "))))?,
                );
            }
            "method" if jobs => {
                q.method = Some(
                    Method::parse(&v).map_err(|e| AppError::invalid(&k, format!("{k}: {e}")))?,
                );
            }
            _ => {
                let known = if jobs {
                    "page_size, page_token, created_since, state, method"
                } else {
                    "page_size, page_token, created_since"
                };
                return Err(AppError::invalid(
                    &k,
                    format!("{k}: no such query parameter here (known: {known})"),
                ));
            }
        }
    }
    Ok(q)
}

fn owner(p: &Principal) -> Option<String> {
    (!p.admin).then(|| p.owner.clone())
}

async fn list_jobs(
    st: AppState,
    req: Request,
    kind: JobKind,
) -> Result<Json<Page<JobView>>, AppError> {
    let p = principal(&req);
    let q = parse_query(req.uri().query(), true)?;
    let limit = q.page_size.unwrap_or(DEFAULT_PAGE_SIZE);
    let filter = JobFilter {
        kind,
        owner: owner(&p),
        state: q.state,
        method: q.method,
        created_since: q.created_since,
        before_seq: q.after,
        limit: limit + 1,
    };
    let jobs = st.jobs.clone();
    let mut rows = blocking(move || Ok(jobs.store.list_jobs(&filter)?)).await?;
    let next = (rows.len() > limit).then(|| {
        rows.truncate(limit);
        page_token(rows[limit - 1].0)
    });
    let items = rows
        .into_iter()
        .map(|(_, r)| {
            let h = st.jobs.handle(&r.id);
            view(r, h.as_deref())
        })
        .collect();
    Ok(Json(Page {
        items,
        next_page_token: next,
    }))
}

pub async fn list_bakes(
    State(st): State<AppState>,
    req: Request,
) -> Result<Json<Page<JobView>>, AppError> {
    list_jobs(st, req, JobKind::Bake).await
}

pub async fn list_renders(
    State(st): State<AppState>,
    req: Request,
) -> Result<Json<Page<JobView>>, AppError> {
    list_jobs(st, req, JobKind::Render).await
}

pub async fn list_scenes(
    State(st): State<AppState>,
    req: Request,
) -> Result<Json<Page<SceneSummary>>, AppError> {
    let p = principal(&req);
    let q = parse_query(req.uri().query(), false)?;
    let limit = q.page_size.unwrap_or(DEFAULT_PAGE_SIZE);
    let jobs = st.jobs.clone();
    let mut rows = blocking(move || {
        Ok(jobs
            .store
            .list_scenes(owner(&p).as_deref(), q.created_since, q.after, limit + 1)?)
    })
    .await?;
    let next = (rows.len() > limit).then(|| {
        rows.truncate(limit);
        page_token(rows[limit - 1].0)
    });
    let items = rows
        .into_iter()
        .map(|(_, id, name, created_at)| SceneSummary {
            id,
            name,
            created_at,
        })
        .collect();
    Ok(Json(Page {
        items,
        next_page_token: next,
    }))
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn page_tokens_round_trip_and_junk_is_refused() {
        for c in [1, 42, 0x7fff_ffff_ffff_ffff] {
            assert_eq!(parse_token(&page_token(c)), Some(c));
        }
        for t in [
            "",
            "p1.",
            "p2.10",
            "10",
            "p1.-5",
            "p1.0",
            "p1.zz",
            "p1.10000000000000000",
        ] {
            assert_eq!(parse_token(t), None, "{t}");
        }
    }

    #[test]
    fn the_query_names_what_is_wrong() {
        let err = |raw: &str, jobs: bool| parse_query(Some(raw), jobs).err().unwrap();
        let e = err("page_size=0", true);
        assert_eq!(e.field.as_deref(), Some("page_size"));
        assert!(e.detail.contains("1..=100"), "{}", e.detail);
        assert_eq!(err("state=done", true).field.as_deref(), Some("state"));
        assert_eq!(err("method=fast", true).field.as_deref(), Some("method"));
        assert_eq!(err("state=queued", false).field.as_deref(), Some("state"));
        assert_eq!(err("colour=red", true).field.as_deref(), Some("colour"));
        assert_eq!(
            err("page_size=5&page_size=6", true).field.as_deref(),
            Some("page_size")
        );
        assert_eq!(
            err("created_since=yesterday", true).field.as_deref(),
            Some("created_since")
        );
        let q = parse_query(
            Some("page_size=7&state=running&method=csl&created_since=5"),
            true,
        )
        .unwrap();
        assert_eq!(q.page_size, Some(7));
        assert_eq!(q.state, Some(JobState::Running));
        assert_eq!(q.method, Some(Method::Csl));
        assert_eq!(q.created_since, Some(5));
    }
}
