//! The web viewer at `/` in a real browser: headless Chromium driven through chromedriver
//! (Debian: chromium, chromium-driver; `.ci/run` installs them) over the WebDriver protocol.
//! The page loads the example, renders it with the reference, shows exactly the frame the API
//! gives for the same request, moves the caustic the right way when the light turns, orbits the
//! camera by dragging the frame (previews while dragging, the full frame on release), bakes
//! with its progress shown and cancels a bake. Also: the committed compiled viewer is the
//! compiler's output.

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
    async fn exec_async(&self, script: &str) -> Value {
        self.post("/execute/async", json!({"script": script, "args": []}))
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
            .exec_async(
                "const done = arguments[arguments.length - 1];
                 const img = document.getElementById('frame');
                 const c = document.createElement('canvas');
                 c.width = img.naturalWidth; c.height = img.naturalHeight;
                 const g = c.getContext('2d');
                 g.drawImage(img, 0, 0);
                 done([c.width, c.height, Array.from(g.getImageData(0, 0, c.width, c.height).data)]);",
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

    /// Types `text` into element `css` (for a file input: the path of the file to choose).
    async fn type_into(&self, css: &str, text: &str) {
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
                "const r = document.querySelector('{css}').getBoundingClientRect();
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
    let mut sorted = lum.clone();
    sorted.sort_by(f64::total_cmp);
    let cut = sorted[sorted.len() * 995 / 1000];
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

/// The frame the API renders for the request the page shows as its curl line.
async fn api_frame(srv: &Server, b: &Browser) -> Vec<u8> {
    let curl = b.exec("return document.getElementById('curl').value").await;
    let curl = curl.as_str().unwrap();
    let body = &curl[curl.find("-d '").unwrap() + 4..curl.rfind("' -o").unwrap()];
    let req: Value = serde_json::from_str(body).unwrap();
    let r = srv.post_json("/v1/renders", &req).await;
    assert_eq!(r.status(), 200);
    let png = r.bytes().await.unwrap();
    image::load_from_memory(&png).unwrap().to_rgba8().into_raw()
}

#[tokio::test(flavor = "multi_thread", worker_threads = 2)]
async fn the_viewer_renders_turns_the_light_and_bakes_in_a_browser() {
    // One CPU worker: a long bake queued ahead keeps the viewer's bake queued, to cancel it.
    let srv = Server::start("viewer", |j, _| j.cpu_workers = 1).await;
    let b = Browser::start().await;
    b.goto(&srv.url("/")).await;

    // The example, rendered with the reference on load: the page shows the API's frame.
    let first = b.frame_after(0).await;
    let (px, w, h) = b.pixels().await;
    assert_eq!((w, h), (192, 144));
    let api = api_frame(&srv, &b).await;
    assert_eq!(px.len(), api.len());
    let differ = px.iter().zip(&api).filter(|(a, b)| a != b).count();
    assert!(differ == 0, "{differ} of {} bytes differ", px.len());
    let (x0, y0) = focus(&px, w);
    b.screenshot("example-reference").await;

    // Turn the light from travelling along +x (azimuth 0) to +z, towards the camera: the
    // caustic beyond the sphere moves towards the camera (down the frame) and left.
    b.exec(
        "const s = document.getElementById('azimuth'); s.value = '60';
         s.dispatchEvent(new Event('input')); s.dispatchEvent(new Event('change'));",
    )
    .await;
    let t0 = std::time::Instant::now();
    b.frame_after(first).await;
    let turned = t0.elapsed();
    let (px2, _, _) = b.pixels().await;
    assert_eq!(px2, api_frame(&srv, &b).await);
    let (x1, y1) = focus(&px2, w);
    b.screenshot("light-turned").await;
    assert!(
        y1 > y0 + 3.0 && x1 < x0 - 3.0,
        "the focus went from ({x0:.1}, {y0:.1}) to ({x1:.1}, {y1:.1})"
    );
    let status = b
        .exec("return document.getElementById('status').textContent")
        .await;
    println!(
        "light turned -> full frame in {turned:?} ({status}); focus ({x0:.1}, {y0:.1}) -> ({x1:.1}, {y1:.1})"
    );

    // Dragging the frame orbits the camera: small direct previews while dragging, then the
    // full frame for the new camera, again the API's frame for the request shown.
    let before = b
        .exec("return [document.getElementById('orbit').value, document.getElementById('frame').dataset.frame]")
        .await;
    let frames: u64 = before[1].as_str().unwrap().parse().unwrap();
    let t0 = std::time::Instant::now();
    b.drag("#frame", -80, 20, 1200).await;
    b.frame_after(frames).await;
    let released = t0.elapsed();
    let after = b
        .exec("const f = document.getElementById('frame'); return [document.getElementById('orbit').value, document.getElementById('tilt').value, f.dataset.preview || '0', f.dataset.previewMs || '']")
        .await;
    let orbit = |v: &Value| v.as_str().unwrap().parse::<i64>().unwrap();
    assert_eq!(orbit(&after[0]), orbit(&before[0]) + 40, "{after}");
    let previews: u64 = after[2].as_str().unwrap().parse().unwrap();
    assert!(previews >= 1, "no preview while dragging: {after}");
    let (px3, _, _) = b.pixels().await;
    assert_eq!(px3, api_frame(&srv, &b).await);
    assert_ne!(px3, px2, "the orbit changed nothing");
    b.screenshot("orbited").await;
    println!(
        "drag: {previews} previews, the last {} ms after its input; release -> full frame {:?} after the drag began (1.2 s of dragging)",
        after[3].as_str().unwrap(),
        released
    );

    // A bake of the glass at the paper's settings: its progress shown as it comes, then
    // succeeded.
    b.exec(
        "document.getElementById('preset').value = 'paper';
         document.getElementById('bake').click()",
    )
    .await;
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
    b.screenshot("baked").await;
    let (_, list) = srv.get_json("/v1/bakes?state=succeeded&method=csl").await;
    assert_eq!(list["items"].as_array().unwrap().len(), 1, "{list}");

    // Cancel: a long reference bake holds the one CPU worker, so the viewer's next bake waits
    // in the queue; its Cancel button cancels it.
    let scene_id = b
        .exec("return JSON.parse(document.getElementById('curl').value.split(\"-d '\")[1].split(\"' -o\")[0]).scene")
        .await;
    let long = srv
        .submit_bake(
            &json!({"scene": scene_id, "object": "glass", "method": "reference",
            "params": {"photons": 200_000_000, "spp": 64, "width": 256, "height": 256}}),
        )
        .await;
    b.exec(
        "document.getElementById('preset').value = 'fast';
         document.getElementById('bake').click()",
    )
    .await;
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

    // Compare: photons against the reference, the figures the page shows are the CLI's for
    // the same two EXR images.
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
    for (i, name) in [(2, "a.exr"), (3, "b.exr")] {
        let id = shown[i].as_str().unwrap();
        let r = srv
            .client
            .get(srv.url(&format!("/v1/renders/{id}/image")))
            .send()
            .await
            .unwrap();
        assert_eq!(r.headers()["content-type"], "image/x-exr");
        std::fs::write(dir.join(name), r.bytes().await.unwrap()).unwrap();
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
    b.screenshot("compared").await;

    // A GLB chosen in the file field (the mirror-lined cup): uploaded, its mirror listed for
    // bakes, rendered (the API's frame again, and not a blank one).
    let shown = b
        .exec("return document.getElementById('frame').dataset.frame")
        .await;
    let shown: u64 = shown.as_str().unwrap().parse().unwrap();
    let glb = repo_path("scenes/assets/cup.glb");
    b.type_into("#upload", glb.to_str().unwrap()).await;
    b.frame_after(shown).await;
    let objects = b
        .exec("return Array.from(document.getElementById('object').options).map(o => o.value)")
        .await;
    assert!(!objects.as_array().unwrap().is_empty(), "{objects}");
    let (px4, _, _) = b.pixels().await;
    assert_eq!(px4, api_frame(&srv, &b).await);
    let lit = px4.chunks(4).filter(|p| p[0] > 40 || p[1] > 40).count();
    assert!(lit > px4.len() / 4 / 20, "{lit} lit pixels");
    b.screenshot("uploaded-glb").await;
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
    for f in ["web/src/viewer.js", "clients/typescript/src/index.js"] {
        let built = std::fs::read_to_string(out.join(f)).unwrap();
        let committed = std::fs::read_to_string(repo_path(format!("web/dist/{f}"))).unwrap();
        assert!(
            built == committed,
            "web/dist/{f} is stale: run web/build.sh"
        );
    }
}
