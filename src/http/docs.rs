//! `GET /docs`: the API description as one HTML page, rendered by the server from the same
//! OpenAPI document it serves at `/openapi.json` (no scripts, nothing fetched: works offline).

use super::problems::escape as esc;
use axum::http::header;
use axum::response::{IntoResponse, Response};
use serde_json::Value;
use std::fmt::Write;

fn text(v: &Value) -> &str {
    v.as_str().unwrap_or("")
}

/// A schema in one line: its `$ref` name, type (and item type), enum or format.
fn schema_line(s: &Value) -> String {
    if let Some(r) = s.get("$ref").and_then(Value::as_str) {
        let name = r.rsplit('/').next().unwrap_or(r);
        return format!("<a href=\"#schema-{0}\">{0}</a>", esc(name));
    }
    if let Some(one) = s.get("oneOf").and_then(Value::as_array) {
        return one.iter().map(schema_line).collect::<Vec<_>>().join(" | ");
    }
    let mut out = match s.get("type") {
        Some(Value::String(t)) => esc(t),
        Some(Value::Array(ts)) => esc(&ts.iter().map(text).collect::<Vec<_>>().join(" | ")),
        _ => String::new(),
    };
    if let Some(items) = s.get("items") {
        out = format!("{out} of {}", schema_line(items));
    }
    if let Some(e) = s.get("enum").and_then(Value::as_array) {
        let vals: Vec<String> = e.iter().map(|v| esc(&v.to_string())).collect();
        let _ = write!(out, " ({})", vals.join(", "));
    }
    if let Some(f) = s.get("format").and_then(Value::as_str) {
        let _ = write!(out, ", {}", esc(f));
    }
    out
}

/// The page for OpenAPI document `doc`.
pub fn render(doc: &Value) -> String {
    let mut h = String::new();
    let info = &doc["info"];
    let title = esc(text(&info["title"]));
    let _ = write!(
        h,
        "<!doctype html>\n<html lang=\"en\"><head><meta charset=\"utf-8\">\
         <meta name=\"viewport\" content=\"width=device-width\"><title>{title}</title>\
         <style>body{{font-family:sans-serif;max-width:60rem;margin:auto;padding:1rem}}\
         pre{{white-space:pre-wrap;background:#f4f4f4;padding:.5rem}}\
         table{{border-collapse:collapse}}td,th{{border:1px solid #ccc;padding:.2rem .4rem;\
         text-align:left;vertical-align:top}}</style></head>\n<body>\n<h1>{title}</h1>\n\
         <p>{}</p>\n<pre>{}</pre>\n<p>The same as JSON: <a href=\"/openapi.json\">\
         /openapi.json</a>. Problem types: <a href=\"/problems\">/problems</a>.</p>\n",
        esc(text(&info["summary"])),
        esc(text(&info["description"])),
    );
    h.push_str("<h2>Operations</h2>\n<ul>\n");
    let paths = doc["paths"].as_object().cloned().unwrap_or_default();
    let methods = ["get", "post", "delete"];
    for (path, item) in &paths {
        for m in methods {
            if let Some(op) = item.get(m) {
                let id = esc(text(&op["operationId"]));
                let _ = writeln!(
                    h,
                    "<li><a href=\"#{id}\"><code>{} {}</code></a> — {}</li>",
                    m.to_uppercase(),
                    esc(path),
                    esc(text(&op["summary"]))
                );
            }
        }
    }
    h.push_str("</ul>\n");
    for (path, item) in &paths {
        for m in methods {
            let Some(op) = item.get(m) else { continue };
            let id = esc(text(&op["operationId"]));
            let _ = writeln!(
                h,
                "<h3 id=\"{id}\"><code>{} {}</code></h3>\n<p>{}</p>",
                m.to_uppercase(),
                esc(path),
                esc(text(&op["summary"]))
            );
            if let Some(d) = op.get("description").and_then(Value::as_str) {
                let _ = writeln!(h, "<pre>{}</pre>", esc(d));
            }
            // Path-level parameters, then the operation's ($refs resolved to components).
            let params: Vec<Value> = item
                .get("parameters")
                .and_then(Value::as_array)
                .into_iter()
                .chain(op.get("parameters").and_then(Value::as_array))
                .flatten()
                .map(|p| resolve(doc, p))
                .collect();
            if !params.is_empty() {
                h.push_str(
                    "<table><tr><th>parameter</th><th>in</th><th>schema</th><th>what</th></tr>\n",
                );
                for p in &params {
                    let req = if p["required"].as_bool() == Some(true) {
                        " (required)"
                    } else {
                        ""
                    };
                    let _ = writeln!(
                        h,
                        "<tr><td><code>{}</code>{req}</td><td>{}</td><td>{}</td><td>{}</td></tr>",
                        esc(text(&p["name"])),
                        esc(text(&p["in"])),
                        schema_line(&p["schema"]),
                        esc(text(&p["description"]))
                    );
                }
                h.push_str("</table>\n");
            }
            if let Some(body) = op.get("requestBody").and_then(|b| b["content"].as_object()) {
                h.push_str("<p>Body: ");
                let kinds: Vec<String> = body
                    .iter()
                    .map(|(ty, c)| {
                        format!("<code>{}</code> {}", esc(ty), schema_line(&c["schema"]))
                    })
                    .collect();
                h.push_str(&kinds.join("; "));
                h.push_str("</p>\n");
            }
            if let Some(resps) = op.get("responses").and_then(Value::as_object) {
                h.push_str("<table><tr><th>status</th><th>answer</th></tr>\n");
                for (status, r) in resps {
                    let r = resolve(doc, r);
                    let types: Vec<String> = r["content"]
                        .as_object()
                        .map(|c| {
                            c.keys()
                                .map(|k| format!("<code>{}</code>", esc(k)))
                                .collect()
                        })
                        .unwrap_or_default();
                    let _ = writeln!(
                        h,
                        "<tr><td>{}</td><td>{} {}</td></tr>",
                        esc(status),
                        esc(text(&r["description"])),
                        types.join(", ")
                    );
                }
                h.push_str("</table>\n");
            }
        }
    }
    h.push_str("<h2>Schemas</h2>\n");
    if let Some(schemas) = doc["components"]["schemas"].as_object() {
        for (name, s) in schemas {
            let json = serde_json::to_string_pretty(s).unwrap_or_default();
            let _ = writeln!(
                h,
                "<h3 id=\"schema-{0}\">{0}</h3>\n<pre>{1}</pre>",
                esc(name),
                esc(&json)
            );
        }
    }
    h.push_str("</body></html>\n");
    h
}

/// `p` itself, or the component its `$ref` names.
fn resolve(doc: &Value, p: &Value) -> Value {
    match p.get("$ref").and_then(Value::as_str) {
        Some(r) => {
            let ptr = r.trim_start_matches('#');
            doc.pointer(ptr).cloned().unwrap_or(Value::Null)
        }
        None => p.clone(),
    }
}

/// `GET /docs`.
pub async fn page() -> Response {
    static PAGE: std::sync::OnceLock<String> = std::sync::OnceLock::new();
    let html = PAGE.get_or_init(|| render(super::openapi()));
    (
        [
            (header::CONTENT_TYPE, "text/html; charset=utf-8"),
            (header::CACHE_CONTROL, "public, max-age=3600"),
        ],
        html.as_str(),
    )
        .into_response()
}

#[cfg(test)]
mod tests {
    #[test]
    fn every_operation_of_the_spec_is_on_the_page_and_nothing_is_unescaped() {
        let doc = super::super::openapi();
        let html = super::render(doc);
        for (path, item) in doc["paths"].as_object().unwrap() {
            for (m, op) in item.as_object().unwrap() {
                if m == "parameters" {
                    continue;
                }
                let id = op["operationId"].as_str().unwrap();
                assert!(html.contains(&format!("id=\"{id}\"")), "{m} {path}");
            }
        }
        for name in doc["components"]["schemas"].as_object().unwrap().keys() {
            assert!(html.contains(&format!("id=\"schema-{name}\"")), "{name}");
        }
        // The spec's text holds `<`-free prose but JSON examples with quotes: all escaped.
        assert!(!html.contains("<script"));
        assert!(html.contains("Caustica API"));
    }
}
