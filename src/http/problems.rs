//! The problem types the API answers with, each documented by a page the server serves at
//! `/problems/{type}` (the `type` of every problem answer points there), and the index at
//! `/problems`. [`AppError::new`](super::AppError::new) refuses (in debug builds) a type not
//! listed here, so the list cannot fall behind the code that raises them.

use axum::extract::Path;
use axum::http::{StatusCode, header};
use axum::response::{IntoResponse, Response};

/// One problem type: its slug, title, the statuses it comes with, what it means and what to do.
pub struct ProblemDoc {
    pub slug: &'static str,
    pub title: &'static str,
    pub status: &'static [u16],
    pub meaning: &'static str,
    pub remedy: &'static str,
}

const fn doc(
    slug: &'static str,
    title: &'static str,
    status: &'static [u16],
    meaning: &'static str,
    remedy: &'static str,
) -> ProblemDoc {
    ProblemDoc {
        slug,
        title,
        status,
        meaning,
        remedy,
    }
}

/// Every problem type, by slug.
pub const PROBLEMS: &[ProblemDoc] = &[
    doc(
        "already-finished",
        "Already finished",
        &[409],
        "The bake has already succeeded, so there is nothing to cancel.",
        "Fetch its artifact; delete nothing.",
    ),
    doc(
        "artifact-lost",
        "Artifact lost",
        &[500],
        "The stored result failed its check when it was served (missing, a link, truncated or altered). The job has been queued again from its recorded inputs, and its record shows it running.",
        "Retry after the seconds in Retry-After, or follow the job's events until it is done.",
    ),
    doc(
        "bad-request",
        "Malformed request",
        &[400],
        "The request could not be read: a body that is not JSON, a query string that does not decode, a multipart body that does not parse.",
        "Fix the request as the detail says.",
    ),
    doc(
        "busy",
        "Busy",
        &[503],
        "The server holds as many request bytes as it accepts at once, or had no room to decode an upload's images in time.",
        "Retry after the seconds in Retry-After.",
    ),
    doc(
        "canceled",
        "Canceled",
        &[409],
        "The render was canceled before it finished.",
        "Ask again if you still want it.",
    ),
    doc(
        "forbidden",
        "Forbidden",
        &[403],
        "The key is valid but may not do this (/metrics needs an admin key).",
        "Use an admin key.",
    ),
    doc(
        "headers-too-large",
        "Request header fields too large",
        &[431],
        "The request had over 100 header fields or 32 KiB of headers.",
        "Send fewer or shorter headers.",
    ),
    doc(
        "idempotency-key-reused",
        "Idempotency key reused",
        &[422],
        "The Idempotency-Key was first used with a different request.",
        "Use a new key for a new request.",
    ),
    doc(
        "internal",
        "Internal error",
        &[500],
        "The server failed in a way that is not the request's fault (the detail says where).",
        "Retry; if it persists, report it with the detail and the server's logs.",
    ),
    doc(
        "invalid-render",
        "Render input cannot be rendered",
        &[422],
        "The render's parameters do not fit its method or scene (the detail and field name the parameter).",
        "Change the named parameter, or pick another method.",
    ),
    doc(
        "invalid-request",
        "Invalid request",
        &[422],
        "A field of the request, or a query parameter, has a value the API does not take; `field` names it.",
        "Fix the named field.",
    ),
    doc(
        "invalid-scene",
        "Invalid scene",
        &[422],
        "The scene (JSON or glTF) is not valid: the detail and field name the part at fault.",
        "Fix the named part of the scene (see api/scene.schema.json).",
    ),
    doc(
        "job-timeout",
        "Job time limit",
        &[504],
        "The job ran past the server's run-time limit (renders 300 s, bakes 3600 s by default).",
        "Ask for less work (fewer photons, a smaller image, a coarser bake).",
    ),
    doc(
        "limit-exceeded",
        "A limit was exceeded",
        &[422],
        "The request or scene passes one of the server's limits (image side, triangles, lights, textures, JSON depth or size); the detail names the limit.",
        "Stay within the limit the detail names.",
    ),
    doc(
        "malformed-request",
        "Malformed request",
        &[400],
        "A request line or header that is not HTTP/1.1.",
        "Send valid HTTP.",
    ),
    doc(
        "method-not-allowed",
        "Method not allowed",
        &[405],
        "The route exists but not with this HTTP method; Allow lists the methods it has.",
        "Use one of the methods in Allow.",
    ),
    doc(
        "no-gpu",
        "No GPU",
        &[503],
        "The method needs a GPU adapter (or a float-blendable one) and the server has none.",
        "Use a CPU method (reference), or a server with a GPU.",
    ),
    doc(
        "no-memory",
        "Job memory full",
        &[503],
        "The job's memory estimate does not fit beside the queued and running jobs'.",
        "Retry after the seconds in Retry-After.",
    ),
    doc(
        "not-acceptable",
        "Not acceptable",
        &[406],
        "The Accept header rules out every format the answer could have (a render: image/png or image/x-exr), or the format the request names.",
        "Accept image/png or image/x-exr, or leave Accept out.",
    ),
    doc(
        "not-found",
        "Not found",
        &[404],
        "No such route, or no such scene or job for your key (another key's ids are unknown to you).",
        "Check the path and the id.",
    ),
    doc(
        "not-ready",
        "Result not available",
        &[409, 503],
        "409: the job has not succeeded (yet), so it has no result. 503 from /readyz: the server is still probing its GPU adapter.",
        "Wait: poll the job or follow its events; ask /readyz again shortly.",
    ),
    doc(
        "overloaded",
        "Too many connections",
        &[503],
        "The server holds as many connections as it accepts.",
        "Retry after the seconds in Retry-After.",
    ),
    doc(
        "payload-too-large",
        "Request body too large",
        &[413],
        "The request body is over the server's limit (64 MiB, a JSON body 8 MiB by default).",
        "Send a smaller body.",
    ),
    doc(
        "queue-full",
        "Queue full",
        &[429],
        "As many jobs of this kind are queued as the server takes.",
        "Retry after the seconds in Retry-After.",
    ),
    doc(
        "quota",
        "Quota reached",
        &[429],
        "Your key holds as many queued or running jobs as it may (32 by default), or as many \
         bytes of scenes and results (4 GiB by default).",
        "Wait for some jobs to finish, or cancel some; delete results and scenes you no longer \
         need.",
    ),
    doc(
        "range-not-satisfiable",
        "Range not satisfiable",
        &[416],
        "The byte range asked for lies wholly past the end of the result; Content-Range gives its length.",
        "Ask for a range within the length.",
    ),
    doc(
        "render-failed",
        "Render failed",
        &[500],
        "The render ran and failed; the detail says why.",
        "Read the detail; retry if it names a passing cause.",
    ),
    doc(
        "request-timeout",
        "Request body too slow",
        &[408],
        "The request body did not arrive within the time allowed (60 s by default).",
        "Send the body faster, or a smaller one.",
    ),
    doc(
        "scene-in-use",
        "Scene in use",
        &[409],
        "A queued or running job uses the scene, so it cannot be deleted.",
        "Cancel the job first, or delete the scene once it has finished.",
    ),
    doc(
        "shutting-down",
        "Shutting down",
        &[503],
        "The server is shutting down and takes no new jobs.",
        "Retry after the seconds in Retry-After, against the restarted server.",
    ),
    doc(
        "storage-full",
        "Storage full",
        &[507],
        "The server's disk (or its database's) is full: nothing new can be stored.",
        "Retry after the seconds in Retry-After; an operator frees room or deletes old results.",
    ),
    doc(
        "store-unavailable",
        "Job store unavailable",
        &[503],
        "The shared job store (PostgreSQL) cannot be reached: a request waits at most 2 s for it, and while it is known to be down requests are answered at once. /readyz answers this too, until the store is back.",
        "Retry after the seconds in Retry-After; the jobs already accepted are kept.",
    ),
    doc(
        "too-big",
        "Job too big",
        &[422],
        "The job alone needs more memory than the server gives all jobs together.",
        "Ask for less (fewer photons, a smaller image or grid).",
    ),
    doc(
        "too-many",
        "Too many at once",
        &[429],
        "Your client (API key, or address on a server without keys) holds as many connections, uploads or event streams at once as one client may; the detail names the limit and its setting.",
        "Retry after the seconds in Retry-After, once one of yours has ended.",
    ),
    doc(
        "unauthorized",
        "Unauthorized",
        &[401],
        "The server has API keys and the request has none, or an unknown one.",
        "Send Authorization: Bearer KEY.",
    ),
    doc(
        "unsupported-media-type",
        "Unsupported media type",
        &[415],
        "The Content-Type is not one the route takes.",
        "Send one of the media types the API description lists for the route.",
    ),
    doc(
        "uri-too-long",
        "URI too long",
        &[414],
        "The request URI is over 8 KiB.",
        "Send a shorter URI.",
    ),
];

/// The documentation of problem type `slug`.
pub fn find(slug: &str) -> Option<&'static ProblemDoc> {
    PROBLEMS.iter().find(|p| p.slug == slug)
}

/// `s` as HTML text or attribute value.
pub(super) fn escape(s: &str) -> String {
    s.replace('&', "&amp;")
        .replace('<', "&lt;")
        .replace('>', "&gt;")
        .replace('"', "&quot;")
}

fn page(title: &str, body: &str) -> Response {
    let html = format!(
        "<!doctype html>\n<html lang=\"en\"><head><meta charset=\"utf-8\">\
         <meta name=\"viewport\" content=\"width=device-width\">\
         <title>{} — Caustica API</title></head>\n<body>\n{body}</body></html>\n",
        escape(title)
    );
    (
        [
            (header::CONTENT_TYPE, "text/html; charset=utf-8"),
            (header::CACHE_CONTROL, "public, max-age=3600"),
        ],
        html,
    )
        .into_response()
}

/// `GET /problems`: every problem type.
pub async fn index() -> Response {
    let mut body = String::from(
        "<h1>Problem types</h1>\n<p>Every error of the Caustica API is an RFC 9457 \
         <code>application/problem+json</code> answer whose <code>type</code> is one of \
         these pages.</p>\n<ul>\n",
    );
    for p in PROBLEMS {
        body.push_str(&format!(
            "<li><a href=\"/problems/{0}\"><code>{0}</code></a>: {1}</li>\n",
            p.slug,
            escape(p.title)
        ));
    }
    body.push_str("</ul>\n");
    page("Problem types", &body)
}

/// `GET /problems/{type}`: what the problem means and what to do.
pub async fn show(Path(slug): Path<String>) -> Result<Response, super::AppError> {
    let Some(p) = find(&slug) else {
        return Err(super::AppError::not_found("problem type", &slug));
    };
    let statuses: Vec<String> = p
        .status
        .iter()
        .map(|s| {
            let reason = StatusCode::from_u16(*s)
                .ok()
                .and_then(|c| c.canonical_reason())
                .unwrap_or("");
            format!("{s} {reason}")
        })
        .collect();
    let body = format!(
        "<h1>{title}</h1>\n<p><code>type</code>: <code>/problems/{slug}</code> · status \
         {statuses}</p>\n<h2>What it means</h2>\n<p>{meaning}</p>\n<h2>What to do</h2>\n\
         <p>{remedy}</p>\n<p>The answer's <code>detail</code> names the field, file or limit \
         at fault; <code>field</code> repeats the field's path when there is one. \
         <a href=\"/problems\">All problem types</a>.</p>\n",
        title = escape(p.title),
        slug = p.slug,
        statuses = statuses.join(", "),
        meaning = escape(p.meaning),
        remedy = escape(p.remedy),
    );
    Ok(page(p.title, &body))
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn every_problem_type_is_listed_once_with_its_statuses() {
        let mut slugs: Vec<&str> = PROBLEMS.iter().map(|p| p.slug).collect();
        slugs.sort_unstable();
        let n = slugs.len();
        slugs.dedup();
        assert_eq!(slugs.len(), n, "a slug listed twice");
        for p in PROBLEMS {
            assert!(!p.status.is_empty(), "{}", p.slug);
            for s in p.status {
                assert!((400..600).contains(s), "{}: {s}", p.slug);
            }
            assert!(p.slug.bytes().all(|b| b.is_ascii_lowercase() || b == b'-'));
        }
    }
}
