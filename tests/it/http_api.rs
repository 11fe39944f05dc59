//! What integrators expect of the API beyond single jobs (issue: the API): lists with pages and
//! filters, live progress as server-sent events, `Retry-After` and an ETA on accepted jobs,
//! and results served with `ETag`, `If-None-Match` and byte ranges.

use crate::support::scenes::{long_bake, scene_sized};
use crate::support::server::*;
use futures_util::StreamExt;
use std::time::Duration;

fn render(seed: u64) -> serde_json::Value {
    serde_json::json!({"scene": scene_sized(8, 8), "method": "reference", "photons": 2000,
                       "spp": 1, "seed": seed})
}

fn ids(v: &serde_json::Value) -> Vec<String> {
    v["items"]
        .as_array()
        .unwrap_or_else(|| panic!("no items: {v}"))
        .iter()
        .map(|i| i["id"].as_str().unwrap().to_string())
        .collect()
}

#[tokio::test(flavor = "multi_thread", worker_threads = 2)]
async fn lists_page_newest_first_and_filter() {
    let srv = Server::start("api-lists", |_, _| {}).await;
    let mut made = Vec::new();
    for seed in 0..3 {
        let r = srv.post_json("/v1/renders", &render(seed)).await;
        assert_eq!(r.status(), 200);
        let loc = r.headers()["location"].to_str().unwrap().to_string();
        made.push(loc.trim_start_matches("/v1/renders/").to_string());
    }
    // A bake, to be canceled below.
    let r = srv.post_json("/v1/bakes", &long_bake(7)).await;
    assert_eq!(r.status(), 202);
    let bake = r.headers()["location"].to_str().unwrap().to_string();

    // Newest first, two a page, then the rest without a next token.
    let (s, p1) = srv.get_json("/v1/renders?page_size=2").await;
    assert_eq!(s, 200, "{p1}");
    assert_eq!(ids(&p1), vec![made[2].clone(), made[1].clone()]);
    assert_eq!(p1["items"][0]["state"], "succeeded");
    assert_eq!(p1["items"][0]["kind"], "render");
    let token = p1["next_page_token"].as_str().unwrap();
    let (_, p2) = srv
        .get_json(&format!("/v1/renders?page_size=2&page_token={token}"))
        .await;
    assert_eq!(ids(&p2), vec![made[0].clone()]);
    assert!(p2["next_page_token"].is_null(), "{p2}");
    // The default page holds all three.
    let (_, all) = srv.get_json("/v1/renders").await;
    assert_eq!(ids(&all).len(), 3);

    // Filters: state, method, creation time.
    let (_, v) = srv.get_json("/v1/renders?state=failed").await;
    assert!(ids(&v).is_empty(), "{v}");
    let (_, v) = srv
        .get_json("/v1/renders?state=succeeded&method=reference")
        .await;
    assert_eq!(ids(&v).len(), 3);
    let (_, v) = srv.get_json("/v1/renders?method=direct").await;
    assert!(ids(&v).is_empty(), "{v}");
    // Since the middle one's creation: it and the ones after it (the same millisecond too).
    let since = all["items"][1]["created_at"].as_i64().unwrap();
    let want: Vec<String> = all["items"]
        .as_array()
        .unwrap()
        .iter()
        .filter(|i| i["created_at"].as_i64().unwrap() >= since)
        .map(|i| i["id"].as_str().unwrap().to_string())
        .collect();
    assert!(want.len() >= 2 && want[..2] == made[1..].iter().rev().cloned().collect::<Vec<_>>());
    let (_, v) = srv
        .get_json(&format!("/v1/renders?created_since={since}"))
        .await;
    assert_eq!(ids(&v), want);
    let newest = all["items"][0]["created_at"].as_i64().unwrap();
    let (_, v) = srv
        .get_json(&format!("/v1/renders?created_since={}", newest + 1))
        .await;
    assert!(ids(&v).is_empty(), "{v}");

    // Bakes are listed apart from renders.
    let (_, v) = srv.get_json("/v1/bakes").await;
    assert_eq!(
        ids(&v),
        vec![bake.trim_start_matches("/v1/bakes/").to_string()]
    );
    let (_, v) = srv.get_json("/v1/bakes?state=succeeded").await;
    assert!(ids(&v).is_empty(), "{v}");
    let r = srv.client.delete(srv.url(&bake)).send().await.unwrap();
    assert_eq!(r.status(), 200);
    let (_, v) = srv.get_json("/v1/bakes?state=canceled").await;
    assert_eq!(ids(&v).len(), 1, "{v}");

    // Scenes: the one scene every job used, with its name.
    let (_, v) = srv.get_json("/v1/scenes").await;
    assert_eq!(ids(&v).len(), 1, "{v}");
    assert_eq!(v["items"][0]["name"], scene_sized(8, 8)["name"]);
    assert!(v["items"][0]["created_at"].as_i64().unwrap() > 0);

    // Bad queries name the parameter.
    for (q, field) in [
        ("/v1/renders?page_size=0", "page_size"),
        ("/v1/renders?page_size=101", "page_size"),
        ("/v1/renders?page_token=xyz", "page_token"),
        ("/v1/renders?state=done", "state"),
        ("/v1/bakes?method=fastest", "method"),
        ("/v1/renders?created_since=-1", "created_since"),
        ("/v1/renders?sort=asc", "sort"),
        ("/v1/scenes?state=queued", "state"),
    ] {
        let r = srv.client.get(srv.url(q)).send().await.unwrap();
        let p = problem(r, 422).await;
        assert_eq!(p["field"], field, "{q}: {p}");
    }
    srv.stop().await;
}

/// Reads server-sent events (name, JSON data) from a response until `until` says stop or the
/// stream ends; at most `limit` for the lot.
pub(crate) async fn read_events(
    r: reqwest::Response,
    limit: Duration,
    mut until: impl FnMut(&str, &serde_json::Value) -> bool,
) -> (Vec<(String, serde_json::Value)>, bool) {
    let mut stream = r.bytes_stream();
    let mut buf = String::new();
    let mut out = Vec::new();
    let read = async {
        while let Some(chunk) = stream.next().await {
            buf.push_str(std::str::from_utf8(&chunk.unwrap()).unwrap());
            while let Some(end) = buf.find("\n\n") {
                let block: String = buf.drain(..end + 2).collect();
                let mut name = String::new();
                let mut data = String::new();
                for line in block.lines() {
                    if let Some(v) = line.strip_prefix("event:") {
                        name = v.trim().to_string();
                    } else if let Some(v) = line.strip_prefix("data:") {
                        data.push_str(v.trim());
                    }
                }
                if name.is_empty() {
                    continue; // a keep-alive comment
                }
                let v: serde_json::Value = serde_json::from_str(&data).unwrap();
                let stop = until(&name, &v);
                out.push((name, v));
                if stop {
                    return false;
                }
            }
        }
        true
    };
    let ended = tokio::time::timeout(limit, read)
        .await
        .expect("events within the limit");
    (out, ended)
}

#[tokio::test(flavor = "multi_thread", worker_threads = 2)]
async fn progress_streams_live_and_the_stream_ends_with_the_job() {
    let srv = Server::start("api-events", |j, _| j.cpu_workers = 1).await;
    let r = srv.post_json("/v1/bakes", &long_bake(3)).await;
    assert_eq!(r.status(), 202);
    let retry: u64 = r.headers()["retry-after"]
        .to_str()
        .unwrap()
        .parse()
        .unwrap();
    assert!((1..=10).contains(&retry), "{retry}");
    let loc = r.headers()["location"].to_str().unwrap().to_string();

    let ev = srv
        .client
        .get(srv.url(&format!("{loc}/events")))
        .send()
        .await
        .unwrap();
    assert_eq!(ev.status(), 200);
    assert_eq!(ev.headers()["content-type"], "text/event-stream");
    // Until the progress has risen twice while running.
    let mut rises = 0;
    let mut last = -1.0;
    let (seen, ended) = read_events(ev, Duration::from_secs(120), |name, v| {
        assert_eq!(name, "progress", "{v}");
        let p = v["progress"].as_f64().unwrap();
        if v["state"] == "running" && p > last && last >= 0.0 {
            rises += 1;
        }
        if v["state"] == "running" {
            last = p;
        }
        rises >= 2
    })
    .await;
    assert!(!ended);
    let first = &seen[0].1;
    assert_eq!(first["id"], loc.trim_start_matches("/v1/bakes/"), "{first}");
    let running = seen.last().unwrap();
    assert!(running.1["stage"].as_str().is_some_and(|s| !s.is_empty()));
    // The job says the same, with an ETA once it got far enough.
    let (_, job) = srv.get_json(&loc).await;
    assert_eq!(job["state"], "running");
    if job["progress"].as_f64().unwrap() >= 0.01 {
        assert!(job["eta_ms"].as_i64().unwrap() >= 0, "{job}");
    }

    // A second stream sees the cancel and ends with the canceled job.
    let ev = srv
        .client
        .get(srv.url(&format!("{loc}/events")))
        .send()
        .await
        .unwrap();
    let r = srv.client.delete(srv.url(&loc)).send().await.unwrap();
    assert_eq!(r.status(), 200);
    let (seen, ended) = read_events(ev, Duration::from_secs(60), |_, _| false).await;
    assert!(ended, "the stream ends after `done`");
    let (name, last) = seen.last().unwrap();
    assert_eq!(name, "done");
    assert_eq!(last["state"], "canceled", "{last}");
    assert!(seen[..seen.len() - 1].iter().all(|(n, _)| n == "progress"));

    // A finished job's stream is its `done` event alone.
    let r = srv.post_json("/v1/renders", &render(1)).await;
    assert_eq!(r.status(), 200);
    let render_loc = r.headers()["location"].to_str().unwrap().to_string();
    let ev = srv
        .client
        .get(srv.url(&format!("{render_loc}/events")))
        .send()
        .await
        .unwrap();
    let (seen, ended) = read_events(ev, Duration::from_secs(30), |_, _| false).await;
    assert!(ended);
    assert_eq!(seen.len(), 1, "{seen:?}");
    assert_eq!(seen[0].0, "done");
    assert_eq!(seen[0].1["state"], "succeeded");
    assert_eq!(seen[0].1["artifact"], format!("{render_loc}/image"));
    // Unknown jobs are 404 problems, as for the job itself.
    let r = srv
        .client
        .get(srv.url("/v1/renders/rn_0123456789abcdef0123456789abcdef/events"))
        .send()
        .await
        .unwrap();
    problem(r, 404).await;
    srv.stop().await;
}

#[tokio::test(flavor = "multi_thread", worker_threads = 2)]
async fn results_are_served_with_etags_and_byte_ranges() {
    let srv = Server::start("api-ranges", |_, _| {}).await;
    let r = srv.post_json("/v1/renders", &render(5)).await;
    assert_eq!(r.status(), 200);
    let etag = r.headers()["etag"].to_str().unwrap().to_string();
    let loc = r.headers()["location"].to_str().unwrap().to_string();
    let whole = r.bytes().await.unwrap();
    let image = format!("{loc}/image");
    let get = |headers: Vec<(&'static str, String)>| {
        let mut b = srv.client.get(srv.url(&image));
        for (k, v) in headers {
            b = b.header(k, v);
        }
        b.send()
    };

    // The ETag is the image's SHA-256, the same on the POST and the GET.
    let r = get(vec![]).await.unwrap();
    assert_eq!(r.status(), 200);
    assert_eq!(r.headers()["etag"].to_str().unwrap(), etag);
    assert_eq!(r.headers()["accept-ranges"], "bytes");
    assert!(
        r.headers().get("server-timing").is_none(),
        "only the POST did the work"
    );
    let body = r.bytes().await.unwrap();
    assert_eq!(body, whole);
    let sha = caustica::jobs::scenes::sha256_hex(&body);
    assert_eq!(etag, format!("\"{sha}\""));

    // If-None-Match: 304 without a body; another tag: the image.
    let r = get(vec![("if-none-match", format!("\"x\", {etag}"))])
        .await
        .unwrap();
    assert_eq!(r.status(), 304);
    assert_eq!(r.headers()["etag"].to_str().unwrap(), etag);
    assert!(r.bytes().await.unwrap().is_empty());
    let r = get(vec![("if-none-match", "\"other\"".into())])
        .await
        .unwrap();
    assert_eq!(r.status(), 200);

    // Ranges.
    let len = whole.len();
    let r = get(vec![("range", "bytes=0-7".into())]).await.unwrap();
    assert_eq!(r.status(), 206);
    assert_eq!(
        r.headers()["content-range"].to_str().unwrap(),
        format!("bytes 0-7/{len}")
    );
    assert_eq!(r.headers()["content-type"], "image/png");
    assert_eq!(r.bytes().await.unwrap(), whole.slice(0..8));
    let r = get(vec![("range", "bytes=-5".into())]).await.unwrap();
    assert_eq!(r.status(), 206);
    assert_eq!(r.bytes().await.unwrap(), whole.slice(len - 5..));
    let r = get(vec![("range", format!("bytes={}-", len - 3))])
        .await
        .unwrap();
    assert_eq!(r.bytes().await.unwrap(), whole.slice(len - 3..));
    let r = get(vec![("range", format!("bytes={len}-"))]).await.unwrap();
    assert_eq!(
        r.headers()["content-range"].to_str().unwrap(),
        format!("bytes */{len}")
    );
    problem(r, 416).await;
    // Several ranges, or an If-Range that no longer matches: the whole image.
    let r = get(vec![("range", "bytes=0-1,4-5".into())]).await.unwrap();
    assert_eq!(r.status(), 200);
    assert_eq!(r.bytes().await.unwrap(), whole);
    let r = get(vec![
        ("range", "bytes=0-1".into()),
        ("if-range", "\"stale\"".into()),
    ])
    .await
    .unwrap();
    assert_eq!(r.status(), 200);
    let r = get(vec![
        ("range", "bytes=0-1".into()),
        ("if-range", etag.clone()),
    ])
    .await
    .unwrap();
    assert_eq!(r.status(), 206);
    srv.stop().await;
}

#[tokio::test(flavor = "multi_thread", worker_threads = 2)]
async fn cors_is_off_by_default_and_follows_the_allow_list() {
    use caustica::http::auth::{Keys, hash_key};
    const VIEWER: &str = "https://viewer.example";
    let preflight = |srv: &Server, origin: &str| {
        srv.client
            .request(reqwest::Method::OPTIONS, srv.url("/v1/renders"))
            .header("origin", origin)
            .header("access-control-request-method", "POST")
            .header(
                "access-control-request-headers",
                "content-type,authorization",
            )
            .send()
    };
    let acao = |r: &reqwest::Response| {
        r.headers()
            .get("access-control-allow-origin")
            .map(|v| v.to_str().unwrap().to_string())
    };

    // Off: no CORS headers, and a preflight is a method the route does not have.
    let srv = Server::start("api-cors-off", |_, _| {}).await;
    let r = preflight(&srv, VIEWER).await.unwrap();
    assert_eq!(acao(&r), None);
    problem(r, 405).await;
    let r = srv
        .client
        .get(srv.url("/healthz"))
        .header("origin", VIEWER)
        .send()
        .await
        .unwrap();
    assert_eq!(acao(&r), None);
    srv.stop().await;

    // On, with keys: the preflight needs no key; the real request still does.
    let srv = Server::start("api-cors-on", |_, h| {
        let mut k = Keys::default();
        k.parse(&format!("alice user {}", hash_key("ck_alice")), "test")
            .unwrap();
        h.keys = k;
        h.cors_origins = vec![VIEWER.into()];
    })
    .await;
    let r = preflight(&srv, VIEWER).await.unwrap();
    assert!(r.status().is_success(), "{}", r.status());
    assert_eq!(acao(&r).as_deref(), Some(VIEWER));
    let methods = r.headers()["access-control-allow-methods"]
        .to_str()
        .unwrap();
    assert!(
        methods.contains("POST") && methods.contains("DELETE"),
        "{methods}"
    );
    let allowed = r.headers()["access-control-allow-headers"]
        .to_str()
        .unwrap()
        .to_ascii_lowercase();
    assert!(
        allowed.contains("authorization") && allowed.contains("range"),
        "{allowed}"
    );
    let r = srv
        .client
        .get(srv.url("/v1/renders"))
        .header("origin", VIEWER)
        .bearer_auth("ck_alice")
        .send()
        .await
        .unwrap();
    assert_eq!(r.status(), 200);
    assert_eq!(acao(&r).as_deref(), Some(VIEWER));
    let exposed = r.headers()["access-control-expose-headers"]
        .to_str()
        .unwrap()
        .to_ascii_lowercase();
    for h in [
        "etag",
        "location",
        "retry-after",
        "server-timing",
        "content-range",
    ] {
        assert!(exposed.contains(h), "{exposed}");
    }
    let r = srv
        .client
        .get(srv.url("/v1/renders"))
        .header("origin", VIEWER)
        .send()
        .await
        .unwrap();
    problem(r, 401).await;
    // Another origin: no CORS headers (the browser refuses to hand over the answer).
    let r = preflight(&srv, "https://elsewhere.example").await.unwrap();
    assert_eq!(acao(&r), None);
    srv.stop().await;
}

#[tokio::test(flavor = "multi_thread", worker_threads = 2)]
async fn accept_picks_the_image_format() {
    let srv = Server::start("api-accept", |_, _| {}).await;
    let post = |accept: &'static str, format: Option<&'static str>| {
        let mut body = render(9);
        if let Some(f) = format {
            body["format"] = f.into();
        }
        srv.client
            .post(srv.url("/v1/renders"))
            .header("accept", accept)
            .json(&body)
            .send()
    };
    let r = post("image/x-exr", None).await.unwrap();
    assert_eq!(r.status(), 200);
    assert_eq!(r.headers()["content-type"], "image/x-exr");
    let f = caustica::encode::decode_frame(&r.bytes().await.unwrap()).unwrap();
    assert_eq!((f.width, f.height), (8, 8));
    let r = post("image/png;q=0.2, image/x-exr;q=0.1", None)
        .await
        .unwrap();
    assert_eq!(r.headers()["content-type"], "image/png");
    // No image type in Accept: the request decides (PNG by default).
    let r = post("application/json, */*", None).await.unwrap();
    assert_eq!(r.headers()["content-type"], "image/png");
    // Impossible: 406 naming the Accept.
    let p = problem(post("image/webp", None).await.unwrap(), 406).await;
    assert!(p["detail"].as_str().unwrap().contains("image/webp"), "{p}");
    let p = problem(post("image/png", Some("exr")).await.unwrap(), 406).await;
    assert!(p["detail"].as_str().unwrap().contains("'exr'"), "{p}");
    srv.stop().await;
}

#[tokio::test(flavor = "multi_thread", worker_threads = 2)]
async fn problem_types_resolve_to_pages_the_server_serves() {
    use caustica::http::problems::PROBLEMS;
    let srv = Server::start("api-problems", |_, _| {}).await;
    // A real problem's type, resolved against the request's URL, is a page about it.
    let r = srv
        .client
        .get(srv.url("/v1/renders?page_size=0"))
        .send()
        .await
        .unwrap();
    let p = problem(r, 422).await;
    let ty = p["type"].as_str().unwrap();
    assert_eq!(ty, "/problems/invalid-request");
    let page = srv.client.get(srv.url(ty)).send().await.unwrap();
    assert_eq!(page.status(), 200);
    assert_eq!(page.headers()["content-type"], "text/html; charset=utf-8");
    let html = page.text().await.unwrap();
    assert!(
        html.contains("<h1>Invalid request</h1>") && html.contains("422"),
        "{html}"
    );
    // The index links every type, and the spec lists every one.
    let index = srv
        .client
        .get(srv.url("/problems"))
        .send()
        .await
        .unwrap()
        .text()
        .await
        .unwrap();
    let spec = std::fs::read_to_string(crate::support::repo_path("api/openapi.yaml")).unwrap();
    for d in PROBLEMS {
        assert!(
            index.contains(&format!("href=\"/problems/{}\"", d.slug)),
            "{}",
            d.slug
        );
        assert!(
            spec.contains(d.slug),
            "api/openapi.yaml does not name {}",
            d.slug
        );
        let r = srv
            .client
            .get(srv.url(&format!("/problems/{}", d.slug)))
            .send()
            .await
            .unwrap();
        assert_eq!(r.status(), 200, "{}", d.slug);
    }
    problem(
        srv.client
            .get(srv.url("/problems/no-such-problem"))
            .send()
            .await
            .unwrap(),
        404,
    )
    .await;
    srv.stop().await;
}

#[tokio::test(flavor = "multi_thread", worker_threads = 2)]
async fn an_idempotency_key_gives_the_same_render() {
    let srv = Server::start("api-idempotent", |_, _| {}).await;
    let post = |key: &'static str, body: serde_json::Value| {
        srv.client
            .post(srv.url("/v1/renders"))
            .header("idempotency-key", key)
            .json(&body)
            .send()
    };
    let loc = |r: &reqwest::Response| r.headers()["location"].to_str().unwrap().to_string();
    // Without waiting first, then again: the same render, now finished.
    let mut quick = render(11);
    quick["wait"] = false.into();
    let r = post("k1", quick).await.unwrap();
    assert_eq!(r.status(), 202);
    let first = loc(&r);
    let r = post("k1", render(11)).await.unwrap();
    assert_eq!(r.status(), 200);
    assert_eq!(loc(&r), first);
    let image = r.bytes().await.unwrap();
    let r = post("k1", render(11)).await.unwrap();
    assert_eq!(loc(&r), first);
    assert_eq!(r.bytes().await.unwrap(), image);
    let (_, list) = srv.get_json("/v1/renders").await;
    assert_eq!(ids(&list).len(), 1, "{list}");
    // The key with another request: 422 naming the header.
    let p = problem(post("k1", render(12)).await.unwrap(), 422).await;
    assert_eq!(p["field"], "Idempotency-Key");
    // Without the key, or with another: a new render.
    let r = srv.post_json("/v1/renders", &render(11)).await;
    assert_ne!(loc(&r), first);
    let r = post("k2", render(11)).await.unwrap();
    assert_ne!(loc(&r), first);
    // Once the render is deleted, the key makes a new one.
    let d = srv.client.delete(srv.url(&first)).send().await.unwrap();
    assert_eq!(d.status(), 204);
    let r = post("k1", render(11)).await.unwrap();
    assert_eq!(r.status(), 200);
    let again = loc(&r);
    assert_ne!(again, first);
    let r = post("k1", render(11)).await.unwrap();
    assert_eq!(loc(&r), again);
    srv.stop().await;
}

#[tokio::test(flavor = "multi_thread", worker_threads = 2)]
async fn json_is_gzipped_for_clients_that_accept_it_and_scenes_revalidate() {
    use std::io::Read;
    let srv = Server::start("api-gzip", |_, _| {}).await;
    let r = srv.post_json("/v1/scenes", &scene_sized(8, 8)).await;
    assert_eq!(r.status(), 201);
    let loc = r.headers()["location"].to_str().unwrap().to_string();
    let get = |path: String, headers: Vec<(&'static str, String)>| {
        let mut b = srv.client.get(srv.url(&path));
        for (k, v) in headers {
            b = b.header(k, v);
        }
        b.send()
    };

    // The scene's JSON, plain and gzipped: the same document.
    let plain = get(loc.clone(), vec![]).await.unwrap();
    assert_eq!(plain.status(), 200);
    assert!(plain.headers().get("content-encoding").is_none());
    let etag = plain.headers()["etag"].to_str().unwrap().to_string();
    assert_eq!(plain.headers()["cache-control"], "no-cache");
    let plain: serde_json::Value = plain.json().await.unwrap();
    let zipped = get(loc.clone(), vec![("accept-encoding", "gzip".into())])
        .await
        .unwrap();
    assert_eq!(zipped.headers()["content-encoding"], "gzip");
    let bytes = zipped.bytes().await.unwrap();
    let mut text = String::new();
    flate2::read::GzDecoder::new(&bytes[..])
        .read_to_string(&mut text)
        .unwrap();
    assert!(
        bytes.len() < text.len(),
        "{} >= {}",
        bytes.len(),
        text.len()
    );
    assert_eq!(
        serde_json::from_str::<serde_json::Value>(&text).unwrap(),
        plain
    );

    // Images and event streams are never compressed.
    let r = srv.post_json("/v1/renders", &render(3)).await;
    let render_loc = r.headers()["location"].to_str().unwrap().to_string();
    for path in [
        format!("{render_loc}/image"),
        format!("{render_loc}/events"),
    ] {
        let r = get(path.clone(), vec![("accept-encoding", "gzip".into())])
            .await
            .unwrap();
        assert_eq!(r.status(), 200, "{path}");
        assert!(r.headers().get("content-encoding").is_none(), "{path}");
    }

    // Revalidation: 304 while the scene exists, 404 once it is gone.
    let r = get(loc.clone(), vec![("if-none-match", etag.clone())])
        .await
        .unwrap();
    assert_eq!(r.status(), 304);
    assert_eq!(r.headers()["etag"].to_str().unwrap(), etag);
    let r = get(loc.clone(), vec![("if-none-match", "\"other\"".into())])
        .await
        .unwrap();
    assert_eq!(r.status(), 200);
    // Its render is finished, so the scene may go.
    let d = srv.client.delete(srv.url(&loc)).send().await.unwrap();
    assert_eq!(d.status(), 204);
    problem(
        get(loc.clone(), vec![("if-none-match", etag)])
            .await
            .unwrap(),
        404,
    )
    .await;
    srv.stop().await;
}

#[tokio::test(flavor = "multi_thread", worker_threads = 2)]
async fn the_api_docs_are_served_from_the_spec() {
    let srv = Server::start("api-docs", |_, _| {}).await;
    let r = srv.client.get(srv.url("/docs")).send().await.unwrap();
    assert_eq!(r.status(), 200);
    assert_eq!(r.headers()["content-type"], "text/html; charset=utf-8");
    let html = r.text().await.unwrap();
    let (_, spec) = srv.get_json("/openapi.json").await;
    for (path, item) in spec["paths"].as_object().unwrap() {
        for (m, op) in item.as_object().unwrap() {
            if m == "parameters" {
                continue;
            }
            let id = op["operationId"].as_str().unwrap();
            assert!(html.contains(&format!("id=\"{id}\"")), "{m} {path} missing");
        }
    }
    // Self-contained: nothing to fetch from elsewhere.
    assert!(
        !html.contains("<script") && !html.contains("src=\"http"),
        "{html}"
    );
    srv.stop().await;
}

/// `POST /v1/compare` measures one finished EXR render against another (the CLI's figures are
/// checked against it in the viewer's browser test); what it cannot compare is refused naming
/// the field.
#[tokio::test(flavor = "multi_thread", worker_threads = 2)]
async fn compare_measures_one_exr_render_against_another() {
    let srv = Server::start("api-compare", |_, _| {}).await;
    let render = |format: &'static str, w: u32, photons: u64| {
        let srv = &srv;
        async move {
            let body = serde_json::json!({"scene": scene_sized(w, 24), "method": "reference",
                "photons": photons, "spp": 1, "format": format});
            let r = srv.post_json("/v1/renders", &body).await;
            assert_eq!(r.status(), 200);
            let loc = r.headers()["location"].to_str().unwrap().to_string();
            loc.rsplit('/').next().unwrap().to_string()
        }
    };
    let (a, b) = (
        render("exr", 32, 20_000).await,
        render("exr", 32, 80_000).await,
    );
    let r = srv
        .post_json("/v1/compare", &serde_json::json!({"a": a, "b": b}))
        .await;
    assert_eq!(r.status(), 200);
    let m: serde_json::Value = r.json().await.unwrap();
    let (l1, flux) = (
        m["relative_l1"].as_f64().unwrap(),
        m["flux_ratio"].as_f64().unwrap(),
    );
    assert!(l1 > 0.0 && l1 < 1.0 && (0.5..2.0).contains(&flux), "{m}");
    assert!(m["pixels"].as_u64().unwrap() > 100, "{m}");
    // Against itself: nothing differs.
    let r = srv
        .post_json("/v1/compare", &serde_json::json!({"a": a, "b": a}))
        .await;
    let m: serde_json::Value = r.json().await.unwrap();
    assert_eq!(
        (m["relative_l1"].as_f64(), m["flux_ratio"].as_f64()),
        (Some(0.0), Some(1.0))
    );
    // A PNG, another size, an object the scene lacks, an unknown render.
    let png = render("png", 32, 20_000).await;
    let p = problem(
        srv.post_json("/v1/compare", &serde_json::json!({"a": png, "b": b}))
            .await,
        422,
    )
    .await;
    assert_eq!(p["field"], "a", "{p}");
    let wide = render("exr", 40, 20_000).await;
    let p = problem(
        srv.post_json("/v1/compare", &serde_json::json!({"a": a, "b": wide}))
            .await,
        422,
    )
    .await;
    assert_eq!(p["field"], "b", "{p}");
    let p = problem(
        srv.post_json(
            "/v1/compare",
            &serde_json::json!({"a": a, "b": b, "object": "teapot"}),
        )
        .await,
        422,
    )
    .await;
    assert_eq!(p["field"], "object", "{p}");
    let unknown = format!("rn_{}", "0".repeat(32));
    problem(
        srv.post_json("/v1/compare", &serde_json::json!({"a": unknown, "b": b}))
            .await,
        404,
    )
    .await;
    srv.stop().await;
}
