//! Content negotiation of a render's image: `Accept` picks `png` or `exr` when the request
//! names no `format`, and a request whose `Accept` lists image types but allows neither the
//! named format nor any we make is a 406. An `Accept` that names no image type (`*/*`, or
//! `application/json` alone, as generated clients send) leaves the choice to the request.

use crate::http::AppError;
use axum::http::{HeaderMap, StatusCode, header};

/// The formats a render answers with: name in the request, its media type, and others a client
/// may name for it (a sequence is `image/apng`, still a PNG).
const FORMATS: [(&str, &[&str]); 2] = [
    ("png", &["image/png", "image/apng"]),
    ("exr", &["image/x-exr"]),
];

/// The quality `accept` gives to a response of media type `ty`: that of its most specific
/// matching range (type/subtype over type/* over */*), 0 when none matches.
fn quality(accept: &[(String, f32)], ty: &str) -> f32 {
    let major = ty.split('/').next().unwrap_or("");
    let mut best: Option<(u8, f32)> = None;
    for (range, q) in accept {
        let rank = if range == ty {
            3
        } else if range.strip_suffix("/*") == Some(major) {
            2
        } else if range == "*/*" {
            1
        } else {
            continue;
        };
        if best.is_none_or(|(r, _)| rank > r) {
            best = Some((rank, *q));
        }
    }
    best.map_or(0.0, |(_, q)| q)
}

/// `Accept` as (media range, q), lowercased; a malformed q counts as 1.
fn parse_accept(v: &str) -> Vec<(String, f32)> {
    v.split(',')
        .filter_map(|item| {
            let mut parts = item.split(';');
            let range = parts.next()?.trim().to_ascii_lowercase();
            if range.is_empty() {
                return None;
            }
            let q = parts
                .filter_map(|p| p.trim().strip_prefix("q=").map(str::to_string))
                .filter_map(|q| q.trim().parse::<f32>().ok())
                .map(|q| q.clamp(0.0, 1.0))
                .next()
                .unwrap_or(1.0);
            Some((range, q))
        })
        .collect()
}

/// The format to put in the request (`Some`) when it named none and `Accept` prefers one;
/// `None` to leave the request as it is; 406 when `Accept` rules out what it asked for.
pub(super) fn render_format(
    headers: &HeaderMap,
    asked: Option<&serde_json::Value>,
) -> Result<Option<&'static str>, AppError> {
    let Some(v) = headers.get(header::ACCEPT).and_then(|v| v.to_str().ok()) else {
        return Ok(None);
    };
    let accept = parse_accept(v);
    // Only an Accept that speaks of images expresses a preference among them.
    if !accept.iter().any(|(r, _)| r.starts_with("image/")) {
        return Ok(None);
    }
    let q: Vec<(&'static str, f32)> = FORMATS
        .iter()
        .map(|(name, types)| {
            // The main type by the usual rules; the others (image/apng) only when named.
            let named = |t: &str| {
                accept
                    .iter()
                    .filter(|(r, _)| r == t)
                    .map(|(_, q)| *q)
                    .fold(0.0, f32::max)
            };
            let q = types[1..]
                .iter()
                .map(|t| named(t))
                .fold(quality(&accept, types[0]), f32::max);
            (*name, q)
        })
        .collect();
    let refuse = |what: String| {
        AppError::new(
            StatusCode::NOT_ACCEPTABLE,
            "not-acceptable",
            "Not acceptable",
            format!("Accept: '{v}' {what}"),
        )
    };
    match asked {
        Some(serde_json::Value::String(f)) => match q.iter().find(|(n, _)| n == f) {
            Some((_, q)) if *q <= 0.0 => Err(refuse(format!(
                "rules out format '{f}' that the request asks for"
            ))),
            // An unknown format is the parameter check's to refuse (422 naming it).
            _ => Ok(None),
        },
        Some(_) => Ok(None),
        None => {
            // The best; PNG (the default) on a tie.
            let (name, best) =
                q.iter().copied().fold(
                    ("png", -1.0),
                    |acc, (n, q)| if q > acc.1 { (n, q) } else { acc },
                );
            if best <= 0.0 {
                Err(refuse(
                    "allows neither image/png nor image/x-exr, the formats a render answers with"
                        .into(),
                ))
            } else {
                Ok(Some(name))
            }
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn pick(accept: Option<&str>, asked: Option<&str>) -> Result<Option<&'static str>, u16> {
        let mut h = HeaderMap::new();
        if let Some(a) = accept {
            h.insert(header::ACCEPT, a.parse().unwrap());
        }
        let asked = asked.map(|a| serde_json::Value::String(a.into()));
        render_format(&h, asked.as_ref()).map_err(|e| e.status.as_u16())
    }

    #[test]
    fn accept_picks_the_format_when_none_is_named() {
        assert_eq!(pick(None, None), Ok(None));
        assert_eq!(pick(Some("*/*"), None), Ok(None));
        assert_eq!(pick(Some("application/json"), None), Ok(None));
        assert_eq!(pick(Some("image/x-exr"), None), Ok(Some("exr")));
        assert_eq!(pick(Some("image/png"), None), Ok(Some("png")));
        assert_eq!(pick(Some("IMAGE/X-EXR"), None), Ok(Some("exr")));
        assert_eq!(pick(Some("image/*"), None), Ok(Some("png")));
        assert_eq!(
            pick(Some("image/png;q=0.5, image/x-exr"), None),
            Ok(Some("exr"))
        );
        assert_eq!(
            pick(Some("image/*;q=0.9, image/png;q=0.1"), None),
            Ok(Some("exr"))
        );
        assert_eq!(pick(Some("image/apng"), None), Ok(Some("png")));
        assert_eq!(pick(Some("image/webp"), None), Err(406));
        assert_eq!(
            pick(Some("image/*, image/png;q=0, image/x-exr;q=0"), None),
            Err(406)
        );
    }

    #[test]
    fn a_named_format_stands_unless_accept_rules_it_out() {
        assert_eq!(pick(Some("image/x-exr"), Some("exr")), Ok(None));
        assert_eq!(pick(Some("image/*"), Some("exr")), Ok(None));
        assert_eq!(pick(Some("image/png"), Some("exr")), Err(406));
        assert_eq!(pick(Some("*/*"), Some("exr")), Ok(None));
        assert_eq!(pick(Some("image/png"), Some("tiff")), Ok(None));
    }
}
