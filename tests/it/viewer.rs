//! The web viewer at `/` in a real browser: headless Chromium driven through chromedriver
//! (Debian: chromium, chromium-driver; `.ci/run` installs them) over the WebDriver protocol.
//! The page loads the example, renders it with the reference as an EXR and shows the API's PNG
//! of the same request (its own EXR decoding and tone map), lists the methods that fit, changes
//! exposure and tone map without a render, moves the caustic the right way when the light turns
//! (slider, dial) and when a point light moves, orbits the camera by dragging the frame
//! (previews while dragging, the full frame on release), bakes with its progress shown (a
//! dynamic csl bake and a transport bake then serve the previews), cancels a bake, compares
//! with the reference (the CLI's figures, an error map), takes a GLB, and fits a phone's
//! width. Also: the committed compiled viewer is the compiler's output.

use crate::support::server::*;
use crate::support::{Cleanup, repo_path, temp_dir};
use serde_json::{Value, json};
use std::time::Duration;

/// A WebDriver session on a chromedriver child.
struct Browser {
    _driver: ChildGuard,
    url: String,
    http: reqwest::Client,
}

impl Browser {
    async fn start() -> Browser {
        let port = std::net::TcpListener::bind("127.0.0.1:0")
            .unwrap()
            .local_addr()
            .unwrap()
            .port();
        let driver = std::process::Command::new("chromedriver")
            .arg(format!("--port={port}"))
            .stdout(std::process::Stdio::null())
            .stderr(std::process::Stdio::null())
            .spawn()
            .expect("chromedriver runs (Debian: chromium-driver)");
        let driver = ChildGuard(driver, None);
        let http = reqwest::Client::new();
        let base = format!("http://127.0.0.1:{port}");
        poll("chromedriver to start", Duration::from_secs(30), || async {
            let r = http.get(format!("{base}/status")).send().await.ok()?;
            let v: Value = r.json().await.ok()?;
            v["value"]["ready"].as_bool().filter(|r| *r)
        })
        .await;
        let caps = json!({"capabilities": {"alwaysMatch": {
            "browserName": "chrome",
            "goog:chromeOptions": {"args": ["--headless=new", "--no-sandbox", "--disable-gpu",
                "--disable-dev-shm-usage", "--window-size=1200,900"]}
        }}});
        let v: Value = http
            .post(format!("{base}/session"))
            .json(&caps)
            .send()
            .await
            .unwrap()
            .json()
            .await
            .unwrap();
        let id = v["value"]["sessionId"]
            .as_str()
            .unwrap_or_else(|| panic!("no session: {v}"));
        Browser {
            _driver: driver,
            url: format!("{base}/session/{id}"),
            http,
        }
    }

    async fn post(&self, path: &str, body: Value) -> Value {
        let v: Value = self
            .http
            .post(format!("{}{path}", self.url))
            .json(&body)
            .send()
            .await
            .unwrap()
            .json()
            .await
            .unwrap();
        assert!(v["value"].get("error").is_none(), "{path}: {v}");
        v["value"].clone()
    }

    async fn goto(&self, url: &str) {
        self.post("/url", json!({ "url": url })).await;
    }

    /// Runs `script` (a function body; `arguments` as given) in the page.
    async fn exec(&self, script: &str) -> Value {
        self.post("/execute/sync", json!({"script": script, "args": []}))
            .await
    }

    /// Runs `script`, whose last argument is the callback it calls with its result.
    async fn exec_async(&self, script: &str, args: Value) -> Value {
        self.post("/execute/async", json!({"script": script, "args": args}))
            .await
    }

    /// The number of the frame shown, once the page has shown one past `after`.
    async fn frame_after(&self, after: u64) -> u64 {
        poll("a frame in the page", Duration::from_secs(180), || async {
            let v = self
                .exec("return [document.getElementById('frame').dataset.frame || '0', document.getElementById('status').textContent]")
                .await;
            let n: u64 = v[0].as_str().unwrap().parse().unwrap();
            let status = v[1].as_str().unwrap();
            assert!(!status.contains("failed"), "{status}");
            (n > after).then_some(n)
        })
        .await
    }

    /// The frame's pixels as the page shows them (RGBA) and its size.
    async fn pixels(&self) -> (Vec<u8>, u32, u32) {
        let v = self
            .exec(
                "const c = document.getElementById('frame');
                 const g = c.getContext('2d');
                 return [c.width, c.height, Array.from(g.getImageData(0, 0, c.width, c.height).data)];",
            )
            .await;
        let px = v[2]
            .as_array()
            .unwrap()
            .iter()
            .map(|x| x.as_u64().unwrap() as u8)
            .collect();
        (
            px,
            v[0].as_u64().unwrap() as u32,
            v[1].as_u64().unwrap() as u32,
        )
    }

    /// Saves a screenshot of the page as `name`.png in the tests' artifact folder
    /// (`target/tmp/viewer/`), and returns its path.
    async fn screenshot(&self, name: &str) -> std::path::PathBuf {
        use base64::Engine;
        // The frame at the top of the window (the dial and slider drags scroll the page).
        self.exec("document.getElementById('view').scrollIntoView()")
            .await;
        let v: Value = self
            .http
            .get(format!("{}/screenshot", self.url))
            .send()
            .await
            .unwrap()
            .json()
            .await
            .unwrap();
        let png = base64::engine::general_purpose::STANDARD
            .decode(v["value"].as_str().unwrap())
            .unwrap();
        let dir = std::path::Path::new(env!("CARGO_TARGET_TMPDIR")).join("viewer");
        std::fs::create_dir_all(&dir).unwrap();
        let p = dir.join(format!("{name}.png"));
        std::fs::write(&p, png).unwrap();
        p
    }

    /// Types `text` into element `css` (for a file input: the paths of the files to choose, one
    /// a line).
    async fn type_into(&self, css: &str, text: &str) {
        // A file input keeps what was chosen before: empty it first.
        self.exec(&format!("document.querySelector('{css}').value = ''"))
            .await;
        let el = self
            .post("/element", json!({"using": "css selector", "value": css}))
            .await;
        let id = el
            .as_object()
            .unwrap()
            .values()
            .next()
            .unwrap()
            .as_str()
            .unwrap()
            .to_string();
        self.post(&format!("/element/{id}/value"), json!({ "text": text }))
            .await;
    }

    /// Drags the mouse from the centre of element `css` by (dx, dy) pixels over `ms`
    /// milliseconds.
    async fn drag(&self, css: &str, dx: i64, dy: i64, ms: u64) {
        let c = self
            .exec(&format!(
                "const e = document.querySelector('{css}');
                 e.scrollIntoView({{block: 'center'}});
                 const r = e.getBoundingClientRect();
                 return [Math.round(r.x + r.width / 2), Math.round(r.y + r.height / 2)]"
            ))
            .await;
        let (x, y) = (c[0].as_i64().unwrap(), c[1].as_i64().unwrap());
        self.post(
            "/actions",
            json!({"actions": [{"type": "pointer", "id": "mouse",
                "parameters": {"pointerType": "mouse"}, "actions": [
                {"type": "pointerMove", "duration": 0, "origin": "viewport", "x": x, "y": y},
                {"type": "pointerDown", "button": 0},
                {"type": "pointerMove", "duration": ms / 2, "origin": "pointer", "x": dx / 2, "y": dy / 2},
                {"type": "pause", "duration": ms / 2},
                {"type": "pointerMove", "duration": ms / 2, "origin": "pointer", "x": dx - dx / 2, "y": dy - dy / 2},
                {"type": "pointerUp", "button": 0}]}]}),
        )
        .await;
    }

    async fn quit(&self) {
        let _ = self.http.delete(&self.url).send().await;
    }
}

/// The centroid (x, y) of the brightest 0.5 % of the pixels' luminance: the caustic's focus in
/// the canonical scene (the glass itself renders dark in the reference).
fn focus(rgba: &[u8], w: u32) -> (f64, f64) {
    let lum: Vec<f64> = rgba
        .chunks(4)
        .map(|p| 0.2126 * p[0] as f64 + 0.7152 * p[1] as f64 + 0.0722 * p[2] as f64)
        .collect();
    brightest(lum, w, 5)
}

/// The centroid (x, y) of the brightest `per_mille` ‰ of `lum`, a `w` pixels wide image.
fn brightest(lum: Vec<f64>, w: u32, per_mille: usize) -> (f64, f64) {
    let mut sorted = lum.clone();
    sorted.sort_by(f64::total_cmp);
    let cut = sorted[sorted.len() * (1000 - per_mille) / 1000];
    let (mut sx, mut sy, mut n) = (0.0, 0.0, 0.0);
    for (i, l) in lum.iter().enumerate() {
        if *l >= cut {
            sx += (i as u32 % w) as f64;
            sy += (i as u32 / w) as f64;
            n += 1.0;
        }
    }
    (sx / n, sy / n)
}

/// The request the page shows as its curl line (the frame on screen as a PNG).
async fn shown_request(b: &Browser) -> Value {
    let curl = b.exec("return document.getElementById('curl').value").await;
    let curl = curl.as_str().unwrap();
    let body = &curl[curl.find("-d '").unwrap() + 4..curl.rfind("' -o").unwrap()];
    serde_json::from_str(body).unwrap()
}

/// The centroid (x, y) of the brightest 0.1 % of the luminance of the radiance the page
/// decoded from the frame's EXR: a caustic's focus where the floor under a point light is
/// bright too (noise-free frames only).
async fn radiance_focus(b: &Browser) -> (f64, f64) {
    let w = page_state(b, "frame.width").await.as_u64().unwrap() as u32;
    let lum = page_radiance(b)
        .await
        .chunks(3)
        .map(|p| 0.2126 * p[0] as f64 + 0.7152 * p[1] as f64 + 0.0722 * p[2] as f64)
        .collect();
    brightest(lum, w, 1)
}

/// The radiance the page decoded from the frame's EXR (RGB triples, top row first), as the
/// page holds it (single precision).
async fn page_radiance(b: &Browser) -> Vec<f32> {
    page_state(b, "frame.rgb.join(',')")
        .await
        .as_str()
        .unwrap()
        .split(',')
        .map(|x| x.parse::<f64>().unwrap() as f32)
        .collect()
}

/// The stored scene of the frame the page shows, as `GET /v1/scenes/{id}` gives it.
async fn shown_scene(srv: &Server, b: &Browser) -> Value {
    let req = shown_request(b).await;
    let id = req["scene"].as_str().unwrap();
    srv.get_json(&format!("/v1/scenes/{id}")).await.1
}

/// The frame the API renders for the request the page shows as its curl line.
async fn api_frame(srv: &Server, b: &Browser) -> Vec<u8> {
    let req = shown_request(b).await;
    let r = srv.post_json("/v1/renders", &req).await;
    assert_eq!(r.status(), 200);
    let png = r.bytes().await.unwrap();
    image::load_from_memory(&png).unwrap().to_rgba8().into_raw()
}

/// Checks the page shows the API's PNG for the request of its curl line: the page tone-maps
/// the EXR itself, in single precision as the server does, so bytes may differ by one step of
/// rounding (a different `powf`) and no more.
async fn shows_the_api_frame(srv: &Server, b: &Browser) -> Vec<u8> {
    let (px, _, _) = b.pixels().await;
    let api = api_frame(srv, b).await;
    assert_eq!(px.len(), api.len());
    let worst = px.iter().zip(&api).map(|(a, b)| a.abs_diff(*b)).max();
    let off = px.iter().zip(&api).filter(|(a, b)| a != b).count();
    assert!(
        worst <= Some(1),
        "page and API differ by up to {worst:?} ({off} of {} bytes)",
        px.len()
    );
    px
}

/// Chooses `kind` in the page's bake menu and presses Bake.
async fn start_bake(b: &Browser, kind: &str) {
    b.exec(&format!(
        "document.getElementById('bake-kind').value = '{kind}';
         document.getElementById('bake').click()"
    ))
    .await;
}

/// The record of the render whose frame the page shows.
async fn shown_render(srv: &Server, b: &Browser) -> Value {
    let id = b
        .exec("return document.getElementById('frame').dataset.render")
        .await;
    srv.get_json(&format!("/v1/renders/{}", id.as_str().unwrap()))
        .await
        .1
}

/// The page's state as its script keeps it (`window.caustica`): field `path` of it.
async fn page_state(b: &Browser, path: &str) -> Value {
    b.exec(&format!("return window.caustica.{path}")).await
}

/// The frame's counters: full frames shown, previews shown, the last preview's method and
/// milliseconds (request to screen), and the last full frame's milliseconds.
async fn counters(b: &Browser) -> (u64, u64, String, String, String) {
    let v = b
        .exec("const d = document.getElementById('frame').dataset; return [d.frame || '0', d.preview || '0', d.previewMethod || '', d.previewMs || '', d.frameMs || '']")
        .await;
    let s = |i: usize| v[i].as_str().unwrap().to_string();
    (
        s(0).parse().unwrap(),
        s(1).parse().unwrap(),
        s(2),
        s(3),
        s(4),
    )
}

/// The number of requests the page has made to `path`.
async fn requests_to(b: &Browser, path: &str) -> usize {
    let v = b
        .exec(&format!(
            "return performance.getEntriesByType('resource').filter(e => new URL(e.name).pathname === '{path}').length"
        ))
        .await;
    v.as_u64().unwrap() as usize
}

#[tokio::test(flavor = "multi_thread", worker_threads = 2)]
async fn the_viewer_renders_turns_the_light_and_bakes_in_a_browser() {
    // One CPU worker: a long bake queued ahead keeps the viewer's bake queued, to cancel it.
    let srv = Server::start("viewer", |j, _| j.cpu_workers = 1).await;
    let b = Browser::start().await;
    b.goto(&srv.url("/")).await;
    b.exec("performance.setResourceTimingBufferSize(100000)")
        .await;

    // The example, rendered with the reference on load as an EXR, tone-mapped by the page:
    // the API's PNG of the same request, and the radiance the page decoded is the EXR's.
    let first = b.frame_after(0).await;
    let (px, w, h) = b.pixels().await;
    assert_eq!((w, h), (192, 144));
    shows_the_api_frame(&srv, &b).await;
    let id = b
        .exec("return document.getElementById('frame').dataset.render")
        .await;
    let exr = srv
        .client
        .get(srv.url(&format!("/v1/renders/{}/image", id.as_str().unwrap())))
        .send()
        .await
        .unwrap()
        .bytes()
        .await
        .unwrap();
    let want = image::load_from_memory(&exr)
        .unwrap()
        .to_rgb32f()
        .into_raw();
    let decoded = page_radiance(&b).await;
    assert!(
        decoded == want,
        "the page's EXR decoding differs from image's"
    );
    let (x0, y0) = focus(&px, w);
    b.screenshot("example-reference").await;

    // The methods that fit the example, and why not the others: the server's verdicts shown,
    // the ones that do not fit not offered.
    let fits = b
        .exec("return Array.from(document.querySelectorAll('#fits li')).map(li => [li.dataset.method, li.dataset.fits, li.textContent])")
        .await;
    let fits = fits.as_array().unwrap();
    let info = shown_scene(&srv, &b).await;
    assert_eq!(fits.len(), info["methods"].as_array().unwrap().len());
    for (li, m) in fits.iter().zip(info["methods"].as_array().unwrap()) {
        assert_eq!(li[0], m["method"]);
        assert_eq!(li[1].as_str().unwrap(), m["fits"].to_string());
        assert!(li[2].as_str().unwrap().contains(m["why"].as_str().unwrap()));
    }
    let water = fits.iter().find(|li| li[0] == "water").unwrap();
    assert!(water[1] == "false" && water[2].as_str().unwrap().contains("water shape"));
    let offered = b
        .exec("return Array.from(document.getElementById('method').options).filter(o => !o.disabled).map(o => o.value)")
        .await;
    assert!(!offered.as_array().unwrap().contains(&json!("water")));
    assert!(offered.as_array().unwrap().contains(&json!("reference")));

    // Exposure and tone map change the frame on screen without a render: the page shows the
    // API's PNG for that exposure and tone map.
    let renders = requests_to(&b, "/v1/renders").await;
    b.exec(
        "const e = document.getElementById('exposure'); e.value = '1.5'; e.dispatchEvent(new Event('input'));
         const t = document.getElementById('tone-map'); t.value = 'reinhard'; t.dispatchEvent(new Event('input'));",
    )
    .await;
    let req = shown_request(&b).await;
    assert_eq!(
        (req["exposure"].as_f64(), req["tone_map"].as_str()),
        (Some(1.5), Some("reinhard"))
    );
    let bright = shows_the_api_frame(&srv, &b).await;
    assert_ne!(bright, px);
    assert_eq!(
        requests_to(&b, "/v1/renders").await,
        renders,
        "a render was asked for"
    );
    assert_eq!(counters(&b).await.0, first);
    b.screenshot("exposure").await;
    b.exec(
        "const e = document.getElementById('exposure'); e.value = '0'; e.dispatchEvent(new Event('input'));
         const t = document.getElementById('tone-map'); t.value = 'clamp'; t.dispatchEvent(new Event('input'));",
    )
    .await;

    // Turn the light from travelling along +x (heading 0) to +z, towards the camera: the
    // caustic beyond the sphere moves towards the camera (down the frame) and left.
    b.exec(
        "const s = document.getElementById('azimuth'); s.value = '60';
         s.dispatchEvent(new Event('input')); s.dispatchEvent(new Event('change'));",
    )
    .await;
    let turned = b.frame_after(first).await;
    let px2 = shows_the_api_frame(&srv, &b).await;
    let (x1, y1) = focus(&px2, w);
    b.screenshot("light-turned").await;
    assert!(
        y1 > y0 + 3.0 && x1 < x0 - 3.0,
        "the focus went from ({x0:.1}, {y0:.1}) to ({x1:.1}, {y1:.1})"
    );
    println!("light slider: focus ({x0:.1}, {y0:.1}) -> ({x1:.1}, {y1:.1})");

    // Dragging the light's dot on the dial to the east (+x): the light comes from +x, so it
    // travels along -x and the caustic goes to the other side of the sphere (left of where
    // it was with the light from -x). Previews while dragging, the full frame on release.
    b.drag("#dial", 40, 0, 1200).await;
    let last = b.frame_after(turned).await;
    let (az, el) = {
        let v = b
            .exec("return [document.getElementById('azimuth').value, document.getElementById('elevation').value]")
            .await;
        let n = |i: usize| v[i].as_str().unwrap().parse::<i64>().unwrap();
        (n(0), n(1))
    };
    // The drag starts at the dial's centre rounded to a whole pixel: up to half a pixel off
    // over a 40 px drag is under a degree of heading.
    assert!(180 - az.abs() <= 1, "heading {az}");
    assert!((50..=58).contains(&el), "elevation {el}");
    let (_, previews, pm, preview_ms, frame_ms) = counters(&b).await;
    assert!(previews >= 1, "no preview while dragging the light");
    assert_eq!(pm, "direct");
    let px_dial = shows_the_api_frame(&srv, &b).await;
    let (x2, _) = focus(&px_dial, w);
    assert!(x2 < x0 - 10.0, "the focus went from x {x0:.1} to {x2:.1}");
    b.screenshot("light-dial").await;
    println!(
        "light dial (reference frames): {previews} direct previews, the last {preview_ms} ms request to screen; release -> full frame {frame_ms} ms; focus x {x0:.1} -> {x2:.1}"
    );

    // Dragging the frame orbits the camera: small direct previews while dragging, then the
    // full frame for the new camera, again the API's frame for the request shown.
    let orbit0 = b
        .exec("return document.getElementById('orbit').value")
        .await;
    let previews0 = counters(&b).await.1;
    b.drag("#frame", -80, 20, 1200).await;
    let orbited = b.frame_after(last).await;
    let orbit1 = b
        .exec("return document.getElementById('orbit').value")
        .await;
    let orbit = |v: &Value| v.as_str().unwrap().parse::<i64>().unwrap();
    assert_eq!(orbit(&orbit1), orbit(&orbit0) + 40);
    let (_, previews, _, preview_ms, frame_ms) = counters(&b).await;
    assert!(previews > previews0, "no preview while dragging");
    let px3 = shows_the_api_frame(&srv, &b).await;
    assert_ne!(px3, px_dial, "the orbit changed nothing");
    b.screenshot("orbited").await;
    println!(
        "orbit drag (reference frames): {} direct previews, the last {preview_ms} ms request to screen; release -> full frame {frame_ms} ms",
        previews - previews0
    );

    // A dynamic csl bake (12 directions): its progress shown as it comes, then succeeded; the
    // page renders csl from then on, and dragging the light previews csl frames interpolated
    // from the bake (any direction), the full frame on release again the API's.
    start_bake(&b, "csl-dynamic-quick").await;
    let stage = poll("the bake to finish", Duration::from_secs(300), || async {
        let v = b
            .exec("const p = document.getElementById('bake-progress'); return [document.getElementById('bake-stage').textContent, p.value, p.dataset.events || '0']")
            .await;
        let stage = v[0].as_str().unwrap().to_string();
        ["succeeded", "failed", "canceled"]
            .contains(&stage.as_str())
            .then_some((stage, v[1].as_f64().unwrap(), v[2].as_str().unwrap().to_string()))
    })
    .await;
    assert_eq!((stage.0.as_str(), stage.1), ("succeeded", 1.0));
    let events: u32 = stage.2.parse().unwrap();
    assert!(events >= 2, "{events} progress events shown");
    let (_, list) = srv.get_json("/v1/bakes?state=succeeded&method=csl").await;
    let items = list["items"].as_array().unwrap();
    assert!(
        items.iter().any(|j| j["params"]["dynamic"] == true),
        "{list}"
    );
    let baked = b.frame_after(orbited).await;
    assert_eq!(shown_request(&b).await["method"], "csl");
    // That frame queued the static bake of its light direction. This server's one CPU worker
    // runs bakes and csl renders alike: the previews would wait behind that bake (and its
    // check), so it ends first.
    let rec = shown_render(&srv, &b).await;
    if let Some(refine) = rec["info"]["refine"]["bakes"][0].as_str() {
        srv.bake_succeeded(refine, Duration::from_secs(120)).await;
    }
    let previews0 = counters(&b).await.1;
    b.drag("#dial", 0, -30, 1500).await;
    b.frame_after(baked).await;
    let (_, previews, pm, preview_ms, frame_ms) = counters(&b).await;
    assert!(previews > previews0, "no preview while dragging the light");
    assert_eq!(pm, "csl", "previews from the dynamic bake");
    let req = shown_request(&b).await;
    assert_eq!(req["csl"]["dynamic"], true, "{req}");
    b.screenshot("dynamic-csl").await;
    println!(
        "light dial after a dynamic csl bake: {} csl previews, the last {preview_ms} ms request to screen; release -> full csl frame {frame_ms} ms",
        previews - previews0
    );
    // That full frame was interpolated, and queued the static bake of its light direction
    // (the previews did not); rendered again once that is done, the frame is served by it:
    // the API's frame for the request shown.
    let rec = shown_render(&srv, &b).await;
    let set = |rec: &Value| rec["info"]["statistics"]["bakes"][0]["set"].clone();
    assert_eq!(set(&rec), "interpolated", "{rec}");
    let refine = rec["info"]["refine"]["bakes"][0]
        .as_str()
        .expect("a bake queued");
    srv.bake_succeeded(refine, Duration::from_secs(120)).await;
    let shown = counters(&b).await.0;
    b.exec("document.getElementById('render').click()").await;
    b.frame_after(shown).await;
    let rec = shown_render(&srv, &b).await;
    assert_eq!(set(&rec), "exact", "{rec}");
    shows_the_api_frame(&srv, &b).await;

    // Cancel: a long reference bake holds the one CPU worker, so the viewer's next bake waits
    // in the queue; its Cancel button cancels it.
    let scene_id = shown_request(&b).await["scene"].clone();
    let long = srv
        .submit_bake(
            &json!({"scene": scene_id, "object": "glass", "method": "reference",
            "params": {"photons": 200_000_000, "spp": 64, "width": 256, "height": 256}}),
        )
        .await;
    start_bake(&b, "csl-fast").await;
    poll("the cancel button", Duration::from_secs(30), || async {
        let v = b
            .exec("return !document.getElementById('cancel').disabled")
            .await;
        v.as_bool().unwrap().then_some(())
    })
    .await;
    // The status line shows the queue: the long bake running, the viewer's waiting.
    poll(
        "the status line to show the queue",
        Duration::from_secs(30),
        || async {
            let v = b
                .exec("return document.getElementById('server').textContent")
                .await;
            let line = v.as_str().unwrap().to_string();
            (line.contains("queued: 0 renders, 1 bakes")
                && line.contains("running: 0 renders, 1 bakes"))
            .then_some(())
        },
    )
    .await;
    b.exec("document.getElementById('cancel').click()").await;
    poll(
        "the bake to be canceled",
        Duration::from_secs(60),
        || async {
            let v = b
                .exec("return document.getElementById('bake-stage').textContent")
                .await;
            (v == "canceled").then_some(())
        },
    )
    .await;
    let r = srv
        .client
        .delete(srv.url(&format!("/v1/bakes/{long}")))
        .send()
        .await
        .unwrap();
    assert_eq!(r.status(), 200);

    // Compare: photons against the reference side by side with an error map; the figures
    // the page shows are the CLI's for the same two EXR images.
    b.exec(
        "document.getElementById('method').value = 'photons';
         document.getElementById('compare').click()",
    )
    .await;
    let shown = poll("the comparison", Duration::from_secs(180), || async {
        let v = b
            .exec("const d = document.getElementById('compare-result'); return [document.getElementById('rel-l1').textContent, document.getElementById('flux-ratio').textContent, d.dataset.a || '', d.dataset.b || '', d.dataset.camera || '', document.getElementById('status').textContent]")
            .await;
        assert!(!v[5].as_str().unwrap().contains("failed"), "{v}");
        (v[0] != "–").then_some(v)
    })
    .await;
    let dir = temp_dir("viewer-compare");
    let _cleanup_compare = Cleanup(dir.clone());
    let mut exrs = vec![];
    for (i, name) in [(2, "a.exr"), (3, "b.exr")] {
        let id = shown[i].as_str().unwrap();
        let r = srv
            .client
            .get(srv.url(&format!("/v1/renders/{id}/image")))
            .send()
            .await
            .unwrap();
        assert_eq!(r.headers()["content-type"], "image/x-exr");
        let bytes = r.bytes().await.unwrap();
        exrs.push(image::load_from_memory(&bytes).unwrap().to_rgb32f());
        std::fs::write(dir.join(name), bytes).unwrap();
    }
    let out = crate::support::caustica_command()
        .arg("compare")
        .arg(dir.join("a.exr"))
        .arg(dir.join("b.exr"))
        .arg("--scene")
        .arg(repo_path("scenes/glass-sphere-directional.json"))
        .args(["--object", "floor", "--camera", shown[4].as_str().unwrap()])
        .output()
        .unwrap();
    let cli = String::from_utf8_lossy(&out.stdout).into_owned();
    assert!(
        out.status.success(),
        "{cli}{}",
        String::from_utf8_lossy(&out.stderr)
    );
    let want = format!(
        "relative L1 {}  flux ratio {}",
        shown[0].as_str().unwrap(),
        shown[1].as_str().unwrap()
    );
    assert!(cli.starts_with(&want), "page: {want}; CLI: {cli}");
    println!("compare (photons against the reference): {cli}");
    // The error map's mean is the mean of |L(a) - L(b)| / mean L(b) over the two images.
    let lum = |p: &[f32]| 0.2126 * p[0] as f64 + 0.7152 * p[1] as f64 + 0.0722 * p[2] as f64;
    let (a, r) = (exrs[0].as_raw(), exrs[1].as_raw());
    let scale = r.chunks(3).map(lum).sum::<f64>() / (r.len() / 3) as f64;
    let mean = a
        .chunks(3)
        .zip(r.chunks(3))
        .map(|(p, q)| (lum(p) - lum(q)).abs() / scale)
        .sum::<f64>()
        / (r.len() / 3) as f64;
    let v = b
        .exec("return [document.getElementById('compare-view').hidden, document.getElementById('cmp-error').dataset.mean, document.getElementById('cmp-reference').width]")
        .await;
    assert_eq!(v[0], false);
    assert_eq!(v[1].as_str().unwrap(), format!("{mean:.4}"));
    assert_eq!(v[2], 192);
    // A tall window, for the whole view (frame, timings, the comparison) in one picture.
    b.post("/window/rect", json!({"width": 1200, "height": 1500}))
        .await;
    b.screenshot("compared").await;
    b.post("/window/rect", json!({"width": 1200, "height": 900}))
        .await;

    // A point light (a scene JSON chosen in the file field): csl is not offered (directional
    // lights only); a transport bake, then dragging the dial moves the light around its
    // target with transport previews from the bake, and the caustic goes to the side away
    // from the light.
    let shown = counters(&b).await.0;
    b.type_into(
        "#upload",
        repo_path("scenes/glass-sphere-point.json")
            .to_str()
            .unwrap(),
    )
    .await;
    let loaded = b.frame_after(shown).await;
    let v = b
        .exec("return [document.getElementById('light').selectedOptions[0].textContent, document.getElementById('distance').hidden, document.querySelector('#method option[value=csl]').disabled]")
        .await;
    assert_eq!(v, json!(["1: point", false, true]));
    start_bake(&b, "transport").await;
    poll("the transport bake", Duration::from_secs(300), || async {
        let v = b
            .exec("return document.getElementById('bake-stage').textContent")
            .await;
        assert!(v != "failed" && v != "canceled", "{v}");
        (v == "succeeded").then_some(())
    })
    .await;
    let baked = b.frame_after(loaded).await;
    assert_eq!(shown_request(&b).await["method"], "transport");
    // In radiance (the floor under the light saturates the 8-bit frame as the caustic does).
    let (x5, _) = radiance_focus(&b).await;
    b.screenshot("point-light").await;
    let previews0 = counters(&b).await.1;
    // The light starts on the -x side of its target; the dot goes to the +x side.
    b.drag("#dial", 40, 0, 1500).await;
    b.frame_after(baked).await;
    let (_, previews, pm, preview_ms, frame_ms) = counters(&b).await;
    assert!(previews > previews0, "no preview while dragging the light");
    assert_eq!(pm, "transport", "previews from the transport bake");
    let req = shown_request(&b).await;
    assert!(
        req["lights"][0]["position"][0].as_f64().unwrap() > 0.35,
        "{req}"
    );
    shows_the_api_frame(&srv, &b).await;
    let (x6, _) = radiance_focus(&b).await;
    assert!(x6 < x5 - 10.0, "the focus went from x {x5:.1} to {x6:.1}");
    b.screenshot("point-light-transport").await;
    println!(
        "point light dial after a transport bake: {} transport previews, the last {preview_ms} ms request to screen; release -> full transport frame {frame_ms} ms; focus x {x5:.1} -> {x6:.1}",
        previews - previews0
    );

    // A spot light moves around its target and stays aimed at it: dragging the dot to the
    // +x side moves its position there, its target unchanged (direct frames).
    b.exec("document.getElementById('method').value = 'direct'")
        .await;
    let shown = counters(&b).await.0;
    b.type_into(
        "#upload",
        repo_path("scenes/glass-sphere-spot.json").to_str().unwrap(),
    )
    .await;
    let loaded = b.frame_after(shown).await;
    let before = shown_request(&b).await["lights"][0].clone();
    b.drag("#dial", 40, 0, 600).await;
    b.frame_after(loaded).await;
    let after = shown_request(&b).await["lights"][0].clone();
    assert_eq!(after["type"], "spot");
    assert_eq!(after["target"], json!([0.25, 0, 0]), "{after}");
    assert!(before["position"][0].as_f64().unwrap() < 0.0, "{before}");
    assert!(after["position"][0].as_f64().unwrap() > 0.25, "{after}");
    let r = |l: &Value| {
        let p: Vec<f64> = (0..3).map(|k| l["position"][k].as_f64().unwrap()).collect();
        ((p[0] - 0.25).powi(2) + p[1].powi(2) + p[2].powi(2)).sqrt()
    };
    assert!((r(&after) - r(&before)).abs() < 0.05, "{before} {after}");
    shows_the_api_frame(&srv, &b).await;
    b.screenshot("spot-light").await;

    // A GLB chosen in the file field (the mirror-lined cup): uploaded, its mirror listed for
    // bakes, rendered on a ground plane (the API's frame again, and not a blank one).
    b.exec("document.getElementById('method').value = 'photons'")
        .await;
    let shown = counters(&b).await.0;
    let glb = repo_path("scenes/assets/cup.glb");
    b.type_into("#upload", glb.to_str().unwrap()).await;
    b.frame_after(shown).await;
    // A lone GLB is rendered on a ground plane (the page's box, on for a glTF upload).
    let req = shown_request(&b).await;
    assert_eq!(req["ground"], true, "{req}");
    let objects = b
        .exec("return Array.from(document.getElementById('object').options).map(o => o.value)")
        .await;
    assert!(!objects.as_array().unwrap().is_empty(), "{objects}");
    let px4 = shows_the_api_frame(&srv, &b).await;
    let lit = px4.chunks(4).filter(|p| p[0] > 40 || p[1] > 40).count();
    assert!(lit > px4.len() / 4 / 20, "{lit} lit pixels");
    b.screenshot("uploaded-glb").await;

    // A glTF with its files (Blender's Suzanne: .gltf, .bin and two PNG textures) chosen
    // together: the page embeds the files in the glTF and uploads it. No glass or mirror: the
    // methods with caustics are not offered and the page falls back to auto; the frame is
    // the API's. (It is black: the file's material is metallic, the metallic-roughness texture
    // is not read, so the importer takes it as a rough metal of albedo 0.)
    let shown = counters(&b).await.0;
    let dir = repo_path("scenes/assets/Suzanne-glTF");
    let paths = [
        "Suzanne.gltf",
        "Suzanne.bin",
        "Suzanne_BaseColor.png",
        "Suzanne_MetallicRoughness.png",
    ]
    .map(|f| dir.join(f).to_string_lossy().into_owned())
    .join("\n");
    b.type_into("#upload", &paths).await;
    b.frame_after(shown).await;
    let v = b
        .exec("return [document.getElementById('method').value, document.querySelector('#fits li[data-method=photons]').dataset.fits, document.querySelectorAll('#warnings li').length, document.getElementById('object').options.length]")
        .await;
    assert_eq!(
        (&v[0], &v[1], &v[3]),
        (&json!("auto"), &json!("false"), &json!(0)),
        "{v}"
    );
    assert!(v[2].as_u64().unwrap() > 0, "no warnings listed: {v}");
    shows_the_api_frame(&srv, &b).await;
    b.screenshot("uploaded-gltf").await;
    // The mesh came from the .bin and the base colour from its texture: the server warns of
    // neither missing.
    let info = shown_scene(&srv, &b).await;
    assert_eq!(info["triangles"], 3936, "{}", info["objects"]);
    let warnings = info["warnings"].to_string();
    assert!(!warnings.contains("texture"), "{warnings}");

    // A phone's width: one column, the frame first, nothing wider than the screen (the
    // example again, with auto).
    let shown = counters(&b).await.0;
    b.exec("document.getElementById('example').click()").await;
    b.frame_after(shown).await;
    b.post("/window/rect", json!({"width": 390, "height": 844}))
        .await;
    b.exec("window.scrollTo(0, 0)").await;
    let v = b
        .exec("const f = document.getElementById('frame').getBoundingClientRect(); const c = document.getElementById('controls').getBoundingClientRect(); return [document.documentElement.scrollWidth, window.innerWidth, f.width > 0 && f.right <= window.innerWidth, f.bottom <= c.top]")
        .await;
    assert!(
        v[0].as_u64() <= v[1].as_u64() && v[2] == true && v[3] == true,
        "{v}"
    );
    b.screenshot("phone").await;
    b.quit().await;
    srv.stop().await;
}

/// The page's EXR decoder (`/viewer/pixels.js`) reads the encodings it claims besides the
/// server's own tiled RLE (checked by the test above): scanline files uncompressed, RLE, ZIP
/// (16 lines a block) and ZIPS (one line), of float and of half channels, with alpha, as the
/// `exr` crate writes them; its values are the written ones, exactly.
#[tokio::test(flavor = "multi_thread", worker_threads = 2)]
async fn the_pages_exr_decoder_reads_what_the_exr_crate_writes() {
    use base64::Engine;
    use exr::prelude::*;
    let srv = Server::start("viewer-exr", |_, _| {}).await;
    let b = Browser::start().await;
    b.goto(&srv.url("/viewer/example.json")).await;
    let (w, h) = (37usize, 23usize);
    // Mostly zeros, so that each compression shrinks the file: blocks are stored compressed
    // (one that would not shrink is stored as it is, and its decompression goes untested).
    let value = |x: usize, y: usize, c: usize| match x % 5 {
        0 => ((x * 7 + y * 13 + c * 5) % 17) as f32 * 0.37 - 1.5,
        _ => 0.0,
    };
    let mut plain = [0usize; 2];
    for (compression, name) in [
        (Compression::Uncompressed, "none"),
        (Compression::RLE, "rle"),
        (Compression::ZIP16, "zip"),
        (Compression::ZIP1, "zips"),
    ] {
        for half in [false, true] {
            let enc = Encoding {
                compression,
                blocks: Blocks::ScanLines,
                line_order: LineOrder::Increasing,
            };
            let mut out = std::io::Cursor::new(Vec::new());
            if half {
                let px = SpecificChannels::rgba(|p: Vec2<usize>| {
                    let f = |c| ::half::f16::from_f32(value(p.0, p.1, c));
                    (f(0), f(1), f(2), f(3))
                });
                Image::from_layer(Layer::new((w, h), LayerAttributes::default(), enc, px))
                    .write()
                    .to_buffered(&mut out)
                    .unwrap();
            } else {
                let px = SpecificChannels::rgb(|p: Vec2<usize>| {
                    (value(p.0, p.1, 0), value(p.0, p.1, 1), value(p.0, p.1, 2))
                });
                Image::from_layer(Layer::new((w, h), LayerAttributes::default(), enc, px))
                    .write()
                    .to_buffered(&mut out)
                    .unwrap();
            }
            let bytes = out.into_inner();
            if name == "none" {
                plain[half as usize] = bytes.len();
            } else {
                assert!(
                    bytes.len() < plain[half as usize],
                    "{name} half {half}: {} bytes, uncompressed {}",
                    bytes.len(),
                    plain[half as usize]
                );
            }
            let b64 = base64::engine::general_purpose::STANDARD.encode(bytes);
            let v = b
                .exec_async(
                    "const done = arguments[arguments.length - 1];
                     const bytes = Uint8Array.from(atob(arguments[0]), c => c.charCodeAt(0));
                     import('/viewer/pixels.js').then(m => m.decodeExr(bytes))
                       .then(f => done([f.width, f.height, Array.from(f.rgb)]), e => done(String(e)));",
                    json!([b64]),
                )
                .await;
            assert!(v.is_array(), "{name} half {half}: {v}");
            assert_eq!(
                (v[0].as_u64(), v[1].as_u64()),
                (Some(w as u64), Some(h as u64))
            );
            let got: Vec<f32> = v[2]
                .as_array()
                .unwrap()
                .iter()
                .map(|x| x.as_f64().unwrap() as f32)
                .collect();
            let want: Vec<f32> = (0..w * h * 3)
                .map(|i| {
                    let f = value(i / 3 % w, i / 3 / w, i % 3);
                    if half {
                        ::half::f16::from_f32(f).to_f32()
                    } else {
                        f
                    }
                })
                .collect();
            assert!(got == want, "{name} half {half}: the decoded values differ");
        }
    }
    b.quit().await;
    srv.stop().await;
}

/// A server with API keys: the page says the example needs one (the server's 401 problem);
/// with the key typed into its field, kept in the tab's session storage and not beyond it,
/// the example loads and renders.
#[tokio::test(flavor = "multi_thread", worker_threads = 2)]
async fn the_viewer_works_with_an_api_key() {
    use caustica::http::auth::{Keys, hash_key};
    const KEY: &str = "ck_viewer-test-key";
    let srv = Server::start("viewer-keys", |_, h| {
        let mut k = Keys::default();
        k.parse(&format!("viewer user {}", hash_key(KEY)), "test")
            .unwrap();
        h.keys = k;
    })
    .await;
    let b = Browser::start().await;
    b.goto(&srv.url("/")).await;
    let said = poll("the page to give up", Duration::from_secs(60), || async {
        let v = b
            .exec("return document.getElementById('status').textContent")
            .await;
        let v = v.as_str().unwrap().to_string();
        v.starts_with("The example did not load").then_some(v)
    })
    .await;
    assert!(said.contains("401"), "{said}");
    b.type_into("#key", KEY).await;
    b.exec(
        "document.getElementById('key').dispatchEvent(new Event('change'));
         document.getElementById('example').click()",
    )
    .await;
    b.frame_after(0).await;
    let stored = b
        .exec(
            "return [sessionStorage.getItem('caustica-key'), localStorage.length, document.cookie]",
        )
        .await;
    assert_eq!(stored, json!([KEY, 0, ""]));
    let (px, _, _) = b.pixels().await;
    let lit = px.chunks(4).filter(|p| p[0] > 40 || p[1] > 40).count();
    assert!(lit > px.len() / 4 / 2, "{lit} lit pixels");
    b.quit().await;
    srv.stop().await;
}

/// The committed `web/dist` is what `web/build.sh` (tsc) makes of the viewer and the client.
#[test]
fn the_committed_viewer_is_the_compilers_output() {
    let out = temp_dir("viewer-build");
    let _cleanup = Cleanup(out.clone());
    let r = std::process::Command::new("tsc")
        .arg("-p")
        .arg(repo_path("web"))
        .arg("--outDir")
        .arg(&out)
        .output()
        .expect("tsc runs (Debian: node-typescript)");
    assert!(
        r.status.success(),
        "tsc:\n{}",
        String::from_utf8_lossy(&r.stdout)
    );
    for f in [
        "web/src/viewer.js",
        "web/src/pixels.js",
        "clients/typescript/src/index.js",
    ] {
        let built = std::fs::read_to_string(out.join(f)).unwrap();
        let committed = std::fs::read_to_string(repo_path(format!("web/dist/{f}"))).unwrap();
        assert!(
            built == committed,
            "web/dist/{f} is stale: run web/build.sh"
        );
    }
}
