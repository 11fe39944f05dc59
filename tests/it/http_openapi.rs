//! `api/openapi.yaml` against the code and the running server: the committed file is the
//! document generated from `src/http/operations.yaml` and the Rust types (regenerate it with
//! `CAUSTICA_BLESS=1 cargo test --test it http_openapi::`), every route the router serves is
//! in the spec (and the other way round), every such route answers (not 404/405),
//! `/openapi.json` is the same document, and the spec's request examples are accepted.

use crate::support::repo_path;
use crate::support::server::*;
use caustica::http::ROUTES;
use std::collections::BTreeSet;

fn spec() -> serde_json::Value {
    let yaml = std::fs::read_to_string(repo_path("api/openapi.yaml")).unwrap();
    serde_yaml_ng::from_str(&yaml).unwrap()
}

#[test]
fn the_committed_spec_is_the_generated_one() {
    let generated = caustica::http::spec::yaml();
    let path = repo_path("api/openapi.yaml");
    if std::env::var_os("CAUSTICA_BLESS").is_some() {
        std::fs::write(&path, &generated).unwrap();
    }
    let committed = std::fs::read_to_string(&path).expect("api/openapi.yaml exists");
    assert!(
        committed == generated,
        "api/openapi.yaml is stale: run CAUSTICA_BLESS=1 cargo test --test it http_openapi::"
    );
}

#[tokio::test(flavor = "multi_thread", worker_threads = 2)]
async fn the_spec_matches_the_router_and_its_examples_are_accepted() {
    let spec = spec();
    assert_eq!(spec["openapi"], "3.1.0");
    let mut in_spec = BTreeSet::new();
    for (path, item) in spec["paths"].as_object().unwrap() {
        for m in ["get", "post", "put", "delete", "patch"] {
            if item.get(m).is_some() {
                in_spec.insert((m.to_uppercase(), path.clone()));
            }
        }
    }
    let served: BTreeSet<(String, String)> = ROUTES
        .iter()
        .map(|(m, p)| (m.to_string(), p.to_string()))
        .collect();
    assert_eq!(
        served, in_spec,
        "routes served vs routes in api/openapi.yaml"
    );

    let srv = Server::start("openapi", |_, _| {}).await;
    // Every route is really served.
    for (m, p) in ROUTES {
        let url = srv.url(&p.replace("{id}", "x"));
        let r = srv
            .client
            .request(m.parse().unwrap(), url)
            .send()
            .await
            .unwrap();
        let s = r.status().as_u16();
        let body = r.text().await.unwrap();
        let routed = s != 405 && !(s == 404 && body.contains("no route"));
        assert!(routed, "{m} {p}: {s} {body}");
    }
    let (s, served_doc) = srv.get_json("/openapi.json").await;
    assert_eq!(s, 200);
    assert_eq!(served_doc, spec);

    // Request examples.
    let mut n = 0;
    for (path, item) in spec["paths"].as_object().unwrap() {
        let Some(post) = item.get("post") else {
            continue;
        };
        let Some(ex) = post["requestBody"]["content"]["application/json"].get("example") else {
            continue;
        };
        let r = srv.post_json(path, ex).await;
        let s = r.status().as_u16();
        assert!(
            (200..300).contains(&s),
            "example of POST {path}: {s} {}",
            r.text().await.unwrap()
        );
        n += 1;
    }
    assert_eq!(n, 3, "examples for scenes, bakes and renders");
    // The error example has the documented shape.
    let p = &spec["components"]["responses"]["Problem"]["content"]["application/problem+json"]["example"];
    assert_eq!(p["status"], 422);
    srv.stop().await;
}

/// The check every test server's answers go through catches what the spec does not allow.
#[test]
fn the_contract_check_catches_answers_the_spec_does_not_allow() {
    use caustica::http::Observed;
    let c = crate::support::contract::Contract::default();
    let answer =
        |method: &str, route: Option<&str>, status: u16, ty: &str, body: Option<&str>| Observed {
            method: method.parse().unwrap(),
            route: route.map(str::to_string),
            status,
            content_type: Some(ty.to_string()),
            body: body.map(|b| axum::body::Bytes::from(b.as_bytes().to_vec())),
        };
    let problem = r#"{"type": "/problems/not-found", "title": "Not found", "status": 404,
                      "detail": "no bake x"}"#;
    // Allowed: a documented problem, and an image the operation lists.
    c.check(answer(
        "GET",
        Some("/v1/bakes/{id}"),
        404,
        "application/problem+json",
        Some(problem),
    ));
    c.check(answer(
        "GET",
        Some("/v1/renders/{id}/image"),
        200,
        "image/png",
        None,
    ));
    assert!(c.violations().is_empty(), "{:?}", c.violations());
    // A status the operation does not list.
    c.check(answer(
        "GET",
        Some("/healthz"),
        418,
        "application/json",
        Some("{}"),
    ));
    // A job without its required fields.
    c.check(answer(
        "GET",
        Some("/v1/bakes/{id}"),
        200,
        "application/json",
        Some(r#"{"id": "bk_x"}"#),
    ));
    // A media type the status does not list.
    c.check(answer(
        "GET",
        Some("/v1/bakes/{id}"),
        200,
        "image/png",
        None,
    ));
    // A problem without its detail.
    c.check(answer(
        "GET",
        Some("/v1/bakes/{id}"),
        404,
        "application/problem+json",
        Some(r#"{"type": "/problems/not-found", "title": "Not found", "status": 404}"#),
    ));
    let v = c.violations();
    assert_eq!(v.len(), 4, "{v:#?}");
    assert!(v[0].contains("status 418"), "{}", v[0]);
    assert!(v[1].contains("required"), "{}", v[1]);
    assert!(v[2].contains("image/png is not among"), "{}", v[2]);
    assert!(v[3].contains("detail"), "{}", v[3]);
}
