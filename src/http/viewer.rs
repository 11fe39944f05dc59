//! The web viewer (`web/`): its page at `/` and its modules, styles and example scene under
//! `/viewer/`, embedded in the binary (no network at run time). The TypeScript is compiled
//! ahead of time into `web/dist` (`web/build.sh`); a test checks the committed output is the
//! compiler's.

use axum::http::header;
use axum::response::{IntoResponse, Response};

fn asset(ty: &'static str, body: &'static str) -> Response {
    (
        [
            (header::CONTENT_TYPE, ty),
            // Revalidated: a new binary may serve a new viewer under the same name.
            (header::CACHE_CONTROL, "no-cache"),
            (header::X_CONTENT_TYPE_OPTIONS, "nosniff"),
        ],
        body,
    )
        .into_response()
}

pub async fn page() -> Response {
    asset(
        "text/html; charset=utf-8",
        include_str!("../../web/index.html"),
    )
}

pub async fn script() -> Response {
    asset(
        "text/javascript; charset=utf-8",
        include_str!("../../web/dist/web/src/viewer.js"),
    )
}

pub async fn pixels() -> Response {
    asset(
        "text/javascript; charset=utf-8",
        include_str!("../../web/dist/web/src/pixels.js"),
    )
}

pub async fn client() -> Response {
    asset(
        "text/javascript; charset=utf-8",
        include_str!("../../web/dist/clients/typescript/src/index.js"),
    )
}

pub async fn styles() -> Response {
    asset(
        "text/css; charset=utf-8",
        include_str!("../../web/viewer.css"),
    )
}

/// The example the page loads first: the canonical glass sphere.
pub async fn example() -> Response {
    asset(
        "application/json",
        include_str!("../../scenes/glass-sphere-directional.json"),
    )
}
