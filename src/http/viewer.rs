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

const PAGE: &str = include_str!("../../web/index.html");

/// The page's Content-Security-Policy: its own scripts, styles and API alone (the one inline
/// script, the import map, by its hash), images also from the blobs it makes, no plugins, and
/// no page may frame it (it keeps the API key in the browser's storage).
pub fn content_security_policy() -> &'static str {
    static CSP: std::sync::OnceLock<String> = std::sync::OnceLock::new();
    CSP.get_or_init(|| {
        use base64::Engine;
        use sha2::Digest;
        let open = r#"<script type="importmap">"#;
        let start = PAGE.find(open).map(|i| i + open.len());
        let map = start.and_then(|s| PAGE[s..].find("</script>").map(|e| &PAGE[s..s + e]));
        let hash = map.map(|m| {
            let h = sha2::Sha256::digest(m.as_bytes());
            format!(
                " 'sha256-{}'",
                base64::engine::general_purpose::STANDARD.encode(h)
            )
        });
        format!(
            "default-src 'self'; script-src 'self'{}; style-src 'self'; img-src 'self' blob: \
             data:; connect-src 'self'; object-src 'none'; base-uri 'none'; form-action 'self'; \
             frame-ancestors 'none'",
            hash.unwrap_or_default()
        )
    })
}

pub async fn page() -> Response {
    let mut r = asset("text/html; charset=utf-8", PAGE);
    let h = r.headers_mut();
    h.insert(
        header::CONTENT_SECURITY_POLICY,
        header::HeaderValue::from_static(content_security_policy()),
    );
    h.insert(
        header::X_FRAME_OPTIONS,
        header::HeaderValue::from_static("DENY"),
    );
    h.insert(
        header::REFERRER_POLICY,
        header::HeaderValue::from_static("no-referrer"),
    );
    r
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

#[cfg(test)]
mod tests {
    #[test]
    fn the_policy_admits_the_import_map_by_its_hash() {
        let csp = super::content_security_policy();
        assert!(csp.contains("script-src 'self' 'sha256-"), "{csp}");
        assert!(csp.contains("frame-ancestors 'none'"), "{csp}");
    }
}
