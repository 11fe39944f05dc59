// The web viewer served at `/` by `caustica serve`: pick the example or upload a scene, see
// which methods fit it, render it with one, change exposure and tone map on the client from
// the frame's EXR, orbit the camera and move a light (small previews while dragging, from the
// bake when one serves the change, else `direct`; the full frame on release), bake with live
// progress, compare with the reference (side by side, an error map, the figures of `caustica
// compare`). Every call goes through the TypeScript client (clients/typescript), compiled with
// this file into web/dist (web/build.sh) and served from the binary.
// "caustica" is the client: mapped to its source for tsc (tsconfig paths), and to its compiled
// module for the browser (index.html's import map).
import { Caustica, CausticaError, } from "caustica";
import { decodeExr, errorMap, toneMapped } from "./pixels.js";
const $ = (id) => document.getElementById(id);
const status = $("status");
const method = $("method");
const width = $("width");
const height = $("height");
const photons = $("photons");
const ground = $("ground");
const exposure = $("exposure");
const toneMap = $("tone-map");
const lightSel = $("light");
const dial = $("dial");
const azimuth = $("azimuth");
const elevation = $("elevation");
const distance = $("distance");
const frame = $("frame");
const objectSel = $("object");
const bakeKind = $("bake-kind");
const bakeBtn = $("bake");
const cancelBtn = $("cancel");
const progress = $("bake-progress");
const bakeStage = $("bake-stage");
const keyInput = $("key");
const orbit = $("orbit");
const tilt = $("tilt");
const sliders = [azimuth, elevation, distance, orbit, tilt, exposure];
keyInput.value = sessionStorage.getItem("caustica-key") ?? "";
let client = new Caustica(location.origin, { apiKey: keyInput.value || undefined });
keyInput.addEventListener("change", () => {
    sessionStorage.setItem("caustica-key", keyInput.value);
    client = new Caustica(location.origin, { apiKey: keyInput.value || undefined });
});
/** What the page shows, also on `window.caustica` for the browser's console (and tests). */
const state = { lights: [], moving: -1, centre: [0, 0, 0], baked: new Set() };
window.caustica = state;
let rendering = 0;
let previews = 0;
let previewBusy = false;
let pngUrl = "";
let exrUrl = "";
function say(text) {
    status.textContent = text;
}
function problem(e) {
    return e instanceof CausticaError ? `${e.status}: ${e.problem.detail}` : String(e);
}
const rad = (deg) => (deg * Math.PI) / 180;
const deg = (r) => (r * 180) / Math.PI;
/** The direction light travels in, from the heading and elevation sliders. */
function direction() {
    const az = rad(Number(azimuth.value));
    const el = rad(Number(elevation.value));
    return [Math.cos(el) * Math.cos(az), -Math.sin(el), Math.cos(el) * Math.sin(az)];
}
/** Sets the heading and elevation sliders from a direction light travels in. */
function slidersFrom(d) {
    const [x, y, z] = d;
    azimuth.value = String(Math.round(deg(Math.atan2(z, x))));
    elevation.value = String(Math.round(deg(Math.atan2(-y, Math.hypot(x, z)))));
}
function showSliders() {
    for (const s of sliders)
        $(`${s.id}-value`).value = s.value;
    drawDial();
}
/** The light being moved, as the sliders place it: a directional light travels along
 *  `direction()`; a point or spot light sits `distance` back along it from its centre (a
 *  spot keeps its target, so it stays aimed). */
function movedLight() {
    const l = state.lights[state.moving];
    if (!l)
        return undefined;
    const d = direction();
    if (l.type === "directional")
        return { ...l, direction: d };
    const r = Number(distance.value);
    const c = state.centre;
    return { ...l, position: [c[0] - r * d[0], c[1] - r * d[1], c[2] - r * d[2]] };
}
/** Picks the light the dial moves and sets the sliders from it. */
function chooseLight(i) {
    state.moving = i;
    const l = state.lights[i];
    for (const el of document.querySelectorAll(".positional")) {
        el.hidden = !l || l.type === "directional";
    }
    for (const s of [azimuth, elevation, distance])
        s.disabled = !l;
    if (!l)
        return showSliders();
    if (l.type === "directional") {
        slidersFrom(l.direction);
    }
    else {
        const c = l.type === "spot" ? l.target : state.camera ? state.camera.target : [0, 0, 0];
        state.centre = [c[0], c[1], c[2]];
        const v = state.centre.map((c, k) => c - l.position[k]);
        const r = Math.hypot(...v) || 1;
        slidersFrom(v.map((x) => x / r));
        distance.max = String(Math.max(10, Math.ceil(r * 3)));
        distance.min = String(Math.min(0.2, r / 2));
        distance.step = String(Number(distance.max) / 400);
        distance.value = String(r);
    }
    showSliders();
}
/** Pixels between the dial's canvas edge and its horizon circle. */
const DIAL_MARGIN = 12;
/** The dial: the sky seen from above, the light's dot where light comes from (or where a
 *  point or spot light sits), the camera's side marked on the rim. */
function drawDial() {
    const g = dial.getContext("2d");
    if (!g)
        return;
    const { width: w, height: h } = dial;
    const R = w / 2 - DIAL_MARGIN;
    g.clearRect(0, 0, w, h);
    g.strokeStyle = "#888";
    g.lineWidth = 1;
    for (const f of [1, Math.cos(rad(30)), Math.cos(rad(60))]) {
        g.beginPath();
        g.arc(w / 2, h / 2, R * f, 0, 2 * Math.PI);
        g.stroke();
    }
    if (state.camera) {
        // Where the camera is now (the orbit slider's), not where the scene put it.
        const c = state.camera;
        const e = eye();
        const [ex, ez] = [e[0] - c.target[0], e[2] - c.target[2]];
        const n = Math.hypot(ex, ez) || 1;
        g.fillStyle = "#48c";
        g.fillRect(w / 2 + (R + 6) * (ex / n) - 4, h / 2 + (R + 6) * (ez / n) - 4, 8, 8);
    }
    if (state.moving < 0)
        return;
    const d = direction();
    g.fillStyle = "#fc3";
    g.strokeStyle = "#000";
    g.beginPath();
    g.arc(w / 2 - R * d[0], h / 2 - R * d[2], 7, 0, 2 * Math.PI);
    g.fill();
    g.stroke();
}
/** Moves the light to where the pointer is on the dial. */
function dialTo(e) {
    const r = dial.getBoundingClientRect();
    const R = (r.width / 2) * (1 - (2 * DIAL_MARGIN) / dial.width);
    let x = (e.clientX - r.left - r.width / 2) / R;
    let z = (e.clientY - r.top - r.height / 2) / R;
    const n = Math.hypot(x, z);
    const most = Math.cos(rad(Number(elevation.min)));
    if (n > most)
        [x, z] = [(x / n) * most, (z / n) * most];
    // The dot is where light comes from: light travels the other way.
    azimuth.value = String(Math.round(deg(Math.atan2(-z, -x))));
    elevation.value = String(Math.round(deg(Math.acos(Math.min(1, Math.hypot(x, z))))));
    showSliders();
}
/** The camera's eye from the orbit and tilt sliders, at its distance from its target. */
function eye() {
    const c = state.camera;
    const az = rad(Number(orbit.value));
    const el = rad(Number(tilt.value));
    return [
        c.target[0] + c.distance * Math.cos(el) * Math.sin(az),
        c.target[1] + c.distance * Math.sin(el),
        c.target[2] + c.distance * Math.cos(el) * Math.cos(az),
    ];
}
async function useScene(info) {
    state.scene = info;
    const desc = info.scene;
    const cam = desc.camera;
    const [ex, ey, ez] = cam.eye.map((v, i) => v - cam.target[i]);
    const dist = Math.hypot(ex, ey, ez);
    state.camera = { ...cam, distance: dist };
    orbit.value = String(Math.round(deg(Math.atan2(ex, ez))));
    tilt.value = String(Math.round(deg(Math.asin(ey / dist))));
    state.lights = (desc.lights ?? []).map((l) => ({ ...l }));
    const movable = state.lights.flatMap((l, i) => ["directional", "point", "spot"].includes(l.type) ? [new Option(`${i + 1}: ${l.type}`, String(i))] : []);
    lightSel.replaceChildren(...movable);
    lightSel.disabled = movable.length === 0;
    chooseLight(movable.length ? Number(movable[0].value) : -1);
    objectSel.replaceChildren(...info.objects
        .filter((o) => o.specular)
        .map((o) => new Option(`${o.name} (${o.triangles} triangles)`, o.name)));
    bakeBtn.disabled = objectSel.options.length === 0;
    $("warnings").replaceChildren(...info.warnings.map((w) => Object.assign(document.createElement("li"), { textContent: w })));
    showFits();
    $("compare-view").hidden = true;
    await render();
}
/** Lists each method's verdict for the scene, and offers only those that fit (and that this
 *  server can run: the GPU methods need its adapter). */
function showFits() {
    const fits = state.scene?.methods ?? [];
    $("fits").replaceChildren(...fits.map((f) => {
        const ok = f.fits && (!f.gpu || state.gpu !== false);
        const why = f.fits && !ok ? "needs a GPU adapter; this server has none" : f.why;
        const li = document.createElement("li");
        Object.assign(li.dataset, { method: f.method, fits: String(ok) });
        li.append(Object.assign(document.createElement("strong"), { textContent: f.method }));
        li.append(` ${ok ? "✓" : "✗"} ${why}${f.bake && ok ? " (bakes)" : ""}`);
        const opt = Array.from(method.options).find((o) => o.value === f.method);
        if (opt) {
            opt.disabled = !ok;
            opt.title = why;
        }
        return li;
    }));
    if (method.selectedOptions[0]?.disabled)
        method.value = "auto";
}
const BAKES = {
    "csl-fast": { method: "csl", params: { preset: "fast" }, serves: "camera" },
    "csl-paper": { method: "csl", params: { preset: "paper" }, serves: "camera" },
    "csl-dynamic-quick": {
        method: "csl",
        params: { preset: "fast", dynamic: true, subdivisions: 0, steps: 4, track_grid: 32 },
        serves: "light",
    },
    "csl-dynamic": { method: "csl", params: { preset: "paper", dynamic: true }, serves: "light" },
    transport: { method: "transport", params: {}, serves: "light" },
};
/** The csl parameters a `csl` render sends: the chosen bake's, so it uses that bake. */
function cslParams() {
    const k = BAKES[bakeKind.value];
    return k.method === "csl" ? k.params : { preset: "fast" };
}
/** The method a preview uses while `what` moves: the chosen method when a bake of this
 *  session serves the change quickly, else `direct`. */
function previewMethod(what) {
    const m = method.value;
    if (!state.scene || (m !== "csl" && m !== "transport"))
        return "direct";
    const params = m === "csl" ? cslParams() : {};
    for (const [name, k] of Object.entries(BAKES)) {
        if (k.method === m &&
            JSON.stringify(k.params) === JSON.stringify(params) &&
            state.baked.has(`${state.scene.id} ${name}`) &&
            (k.serves === "light" || what === "camera")) {
            return m;
        }
    }
    return "direct";
}
/** The render request for what the controls say; with `preview`, a small frame of that method. */
function request(preview) {
    const m = preview ?? method.value;
    const req = {
        scene: state.scene.id,
        method: m,
        width: Number(width.value),
        height: Number(height.value),
        format: "exr",
    };
    if (ground.checked)
        req.ground = true;
    if (preview) {
        // A preview is for the eye while dragging: no second of self-check on each.
        req.check = false;
        const s = Math.min(1, 128 / Math.max(req.width, req.height));
        req.width = Math.max(16, Math.round(req.width * s));
        req.height = Math.max(16, Math.round(req.height * s));
    }
    if (m === "reference" || m === "photons")
        req.photons = Number(photons.value);
    if (m === "reference")
        req.spp = 4;
    if (m === "csl")
        req.csl = cslParams();
    // A preview from a dynamic bake does not queue the static bake of its light direction (the
    // full frame on release does: the next frame there is exact).
    if (preview && m === "csl" && req.csl?.dynamic)
        req.refine = false;
    if (state.moving >= 0) {
        const moved = movedLight();
        req.lights = state.lights.map((l, i) => (i === state.moving ? moved : l));
    }
    if (state.camera) {
        const { distance: _, ...cam } = state.camera;
        req.camera = { ...cam, eye: eye() };
    }
    return req;
}
function paint(canvas, f) {
    canvas.width = f.width;
    canvas.height = f.height;
    canvas.getContext("2d").putImageData(toneMapped(f, Number(exposure.value), toneMap.value), 0, 0);
}
/** The request that gives, as a PNG, the frame shown: the render's with the page's exposure
 *  and tone map. */
function shownAsPng() {
    const req = { ...state.shown, format: "png" };
    req.exposure = Number(exposure.value);
    req.tone_map = toneMap.value;
    return req;
}
/** Redraws what is on screen with the picture settings (no new render). */
function repaint() {
    if (state.frame)
        paint(frame, state.frame);
    if (state.compared)
        showCompared();
    showLinks();
}
/** The download link and the curl and Python lines for the full frame on screen, as a PNG
 *  with the picture settings. */
function showLinks() {
    if (!state.shown || frame.classList.contains("preview"))
        return;
    frame.toBlob((b) => {
        if (!b)
            return;
        URL.revokeObjectURL(pngUrl);
        pngUrl = URL.createObjectURL(b);
        const dl = $("download");
        dl.href = pngUrl;
        dl.hidden = false;
    });
    const json = JSON.stringify(shownAsPng());
    $("curl").value =
        `curl -s ${location.origin}/v1/renders -H 'Content-Type: application/json' -d '${json}' -o frame.png`;
    $("python").value =
        `import json\nfrom caustica import Caustica\n` +
            `Caustica("${location.origin}").render(**json.loads('${json}'), out="frame.png")`;
}
/** Puts frame `f` on screen: its EXR decoded, tone-mapped here. */
async function show(f) {
    state.frame = await decodeExr(f.image);
    paint(frame, state.frame);
}
/** A small frame for the controls as they are now, unless one is on its way: `direct`, or
 *  the chosen method where a bake serves the change (`what` moved). */
async function preview(what) {
    if (!state.scene || previewBusy)
        return;
    previewBusy = true;
    const asked = rendering;
    const t0 = performance.now();
    const m = previewMethod(what);
    try {
        const f = await client.render(request(m));
        if (asked !== rendering)
            return; // a full frame was asked for meanwhile
        await show(f);
        frame.classList.add("preview");
        Object.assign(frame.dataset, {
            preview: String(++previews),
            previewMs: (performance.now() - t0).toFixed(0),
            previewMethod: m,
        });
    }
    catch (e) {
        say(`Preview failed: ${problem(e)}`);
    }
    finally {
        previewBusy = false;
    }
}
async function render() {
    if (!state.scene)
        return;
    const req = request();
    const mine = ++rendering;
    say(`Rendering with ${req.method}…`);
    $("frame-box").style.setProperty("--aspect", `${req.width} / ${req.height}`);
    try {
        const t0 = performance.now();
        const f = await client.render(req);
        if (mine !== rendering)
            return; // a newer frame was asked for meanwhile
        await show(f);
        if (mine !== rendering)
            return;
        const ms = performance.now() - t0;
        frame.classList.remove("preview");
        state.shown = req;
        state.renderId = f.renderId;
        state.full = state.frame;
        URL.revokeObjectURL(exrUrl);
        exrUrl = URL.createObjectURL(new Blob([f.image], { type: "image/x-exr" }));
        const exr = $("download-exr");
        exr.href = exrUrl;
        exr.hidden = false;
        showLinks();
        const max = Math.max(...f.timings.filter((t) => t.name !== "request").map((t) => t.ms), 1);
        $("timings").replaceChildren(...f.timings.map((t) => {
            const li = document.createElement("li");
            const bar = Object.assign(document.createElement("span"), { className: "bar" });
            bar.style.width = `${Math.min(100, (100 * t.ms) / max)}%`;
            li.append(t.name, bar, `${t.ms.toFixed(1)} ms`);
            return li;
        }));
        $("render-warnings").replaceChildren(...f.warnings.map((w) => Object.assign(document.createElement("li"), { textContent: w })));
        say(`Rendered with ${req.method} in ${ms.toFixed(0)} ms${f.warnings.length ? " (see the warnings)" : ""}`);
        Object.assign(frame.dataset, { frame: String(mine), frameMs: ms.toFixed(0), render: f.renderId ?? "" });
    }
    catch (e) {
        if (mine === rendering)
            say(`Render failed: ${problem(e)}`);
    }
}
function showCompared() {
    const c = state.compared;
    paint($("cmp-method"), c.a);
    paint($("cmp-reference"), c.b);
    const e = $("cmp-error");
    e.width = c.error.width;
    e.height = c.error.height;
    e.getContext("2d").putImageData(c.error, 0, 0);
}
/** The chosen method and the reference rendered as EXR for the controls as they are, shown
 *  side by side with an error map, and measured against each other (`POST /v1/compare`) on
 *  the scene's first receiver (an object that is not glass or a mirror). */
async function compareWithReference() {
    if (!state.scene)
        return;
    const receiver = state.scene.objects.find((o) => !o.specular)?.name;
    if (!receiver) {
        say("Compare needs an object that is not glass or a mirror to measure on");
        return;
    }
    const req = request();
    const box = $("compare-result");
    say(`Comparing ${req.method} with the reference…`);
    try {
        // The frame on screen when it is this request's, else a new one.
        const same = JSON.stringify(state.shown) === JSON.stringify(req) && state.renderId && state.full;
        const a = same ? { renderId: state.renderId, image: undefined } : await client.render(req);
        const ref = { ...req, method: "reference", photons: Number(photons.value), spp: 4 };
        delete ref.csl;
        const b = await client.render(ref);
        const m = await client.compare(a.renderId, b.renderId, receiver);
        const ra = a.image ? await decodeExr(a.image) : state.full;
        const rb = await decodeExr(b.image);
        const error = errorMap(ra, rb);
        state.compared = { a: ra, b: rb, error: error.image };
        $("cmp-error").dataset.mean = error.mean.toFixed(4);
        showCompared();
        $("cmp-method-caption").textContent = req.method ?? "";
        $("compare-view").hidden = false;
        $("rel-l1").textContent = m.relative_l1.toFixed(4);
        $("flux-ratio").textContent = m.flux_ratio.toFixed(4);
        Object.assign(box.dataset, {
            a: a.renderId,
            b: b.renderId,
            object: receiver,
            camera: JSON.stringify(req.camera ?? null),
        });
        say(`${req.method} against the reference: relative L1 ${m.relative_l1.toFixed(4)} over ${m.pixels} pixels of ${receiver}`);
    }
    catch (e) {
        say(`Compare failed: ${problem(e)}`);
    }
}
/** Uploads what was chosen or dropped: a GLB; a glTF with the files it names (their data
 *  embedded here, as the server takes glTF JSON); or a scene JSON with the files it names. */
async function upload(files) {
    const named = (ext) => files.find((f) => f.name.toLowerCase().endsWith(ext));
    const main = named(".glb") ?? named(".gltf") ?? named(".json");
    if (!main) {
        say(`Upload failed: choose a .glb, a .gltf (with its files) or a scene .json, not ${files.map((f) => f.name).join(", ")}`);
        return;
    }
    const others = files.filter((f) => f !== main);
    say(`Uploading ${main.name}${others.length ? ` with ${others.length} files` : ""}…`);
    try {
        const text = async () => new TextDecoder().decode(await main.arrayBuffer());
        let info;
        // A glTF comes alone, as a rule: a floor under it receives its shadow and caustic.
        ground.checked = main !== named(".json");
        if (main === named(".glb"))
            info = await client.uploadGlb(await main.arrayBuffer());
        else if (main === named(".gltf"))
            info = await client.uploadGltf(await embedded(await text(), others));
        else if (others.length) {
            const parts = Object.fromEntries(others.map((f) => [f.name, f]));
            info = await client.uploadSceneWithFiles(JSON.parse(await text()), parts);
        }
        else
            info = await client.uploadScene(JSON.parse(await text()));
        await useScene(info);
    }
    catch (e) {
        say(`Upload failed: ${problem(e)}`);
    }
}
/** A glTF JSON with every buffer and image it names by a relative URI replaced by a data URI
 *  of the file of that name among `files`. */
async function embedded(gltf, files) {
    const doc = JSON.parse(gltf);
    for (const item of [...(doc.buffers ?? []), ...(doc.images ?? [])]) {
        if (!item.uri || item.uri.startsWith("data:"))
            continue;
        const name = decodeURIComponent(item.uri).split("/").pop();
        const f = files.find((x) => x.name === name);
        if (!f)
            throw new Error(`the glTF names ${item.uri}: choose it with the .gltf`);
        const bytes = new Uint8Array(await f.arrayBuffer());
        let bin = "";
        for (let i = 0; i < bytes.length; i += 0x8000) {
            bin += String.fromCharCode(...bytes.subarray(i, i + 0x8000));
        }
        const type = name.endsWith(".png") ? "image/png" : name.endsWith(".jpg") || name.endsWith(".jpeg") ? "image/jpeg" : "application/octet-stream";
        item.uri = `data:${type};base64,${btoa(bin)}`;
    }
    return JSON.stringify(doc);
}
async function example() {
    say("Loading the example…");
    try {
        const r = await fetch("/viewer/example.json");
        ground.checked = false; // the example has its floor
        await useScene(await client.uploadScene(await r.json()));
    }
    catch (e) {
        say(`The example did not load: ${problem(e)}`);
    }
}
async function bake() {
    if (!state.scene)
        return;
    const scene = state.scene.id;
    const name = bakeKind.value;
    const kind = BAKES[name];
    bakeBtn.disabled = true;
    progress.value = 0;
    bakeStage.textContent = "";
    try {
        const job = await client.bake({ scene, object: objectSel.value, method: kind.method, params: kind.params }, { wait: false });
        cancelBtn.disabled = false;
        cancelBtn.onclick = () => void client.cancelBake(job.id).catch((e) => say(problem(e)));
        progress.dataset.events = "0";
        const done = await client.wait(job.id, (e) => {
            progress.value = e.progress;
            progress.dataset.events = String(Number(progress.dataset.events) + 1);
            bakeStage.textContent = e.stage;
        });
        progress.value = done.state === "succeeded" ? 1 : progress.value;
        bakeStage.textContent = done.state;
        if (done.state === "succeeded") {
            state.baked.add(`${scene} ${name}`);
            // Frames of the baked method from now on, previews from the bake where it serves them.
            method.value = kind.method;
            const what = kind.serves === "light" ? "the light and the camera" : "the camera";
            say(`Bake ${done.id} succeeded: ${kind.method} previews as ${what} move`);
            if (state.scene?.id === scene)
                await render();
        }
        else {
            say(`Bake ${done.id} ${done.state}${done.error ? `: ${done.error}` : ""}`);
        }
    }
    catch (e) {
        say(`Bake failed: ${problem(e)}`);
    }
    finally {
        cancelBtn.disabled = true;
        bakeBtn.disabled = false;
    }
}
$("controls").addEventListener("submit", (e) => {
    e.preventDefault();
    void render();
});
$("example").addEventListener("click", () => void example());
$("upload").addEventListener("change", (e) => {
    const f = Array.from(e.target.files ?? []);
    if (f.length)
        void upload(f);
});
document.addEventListener("dragover", (e) => {
    e.preventDefault();
    document.body.classList.add("dragging");
});
document.addEventListener("dragleave", () => document.body.classList.remove("dragging"));
document.addEventListener("drop", (e) => {
    e.preventDefault();
    document.body.classList.remove("dragging");
    const f = Array.from(e.dataTransfer?.files ?? []);
    if (f.length)
        void upload(f);
});
// Previews while a slider moves; the full frame once it is released (keyboard changes too).
for (const [s, what] of [
    [azimuth, "light"],
    [elevation, "light"],
    [distance, "light"],
    [orbit, "camera"],
    [tilt, "camera"],
]) {
    s.addEventListener("input", () => {
        showSliders();
        void preview(what);
    });
    s.addEventListener("change", () => void render());
}
for (const c of [exposure, toneMap]) {
    c.addEventListener("input", () => {
        showSliders();
        repaint();
    });
}
lightSel.addEventListener("change", () => chooseLight(Number(lightSel.value)));
// Dragging the dial moves the light; dragging the frame orbits the camera (horizontal) and
// tilts it (vertical). Previews while dragging, the full frame on release.
let dialDrag = false;
dial.addEventListener("pointerdown", (e) => {
    if (state.moving < 0)
        return;
    e.preventDefault();
    dial.setPointerCapture(e.pointerId);
    dialDrag = true;
    dialTo(e);
    void preview("light");
});
dial.addEventListener("pointermove", (e) => {
    if (!dialDrag)
        return;
    dialTo(e);
    void preview("light");
});
dial.addEventListener("pointerup", () => {
    if (!dialDrag)
        return;
    dialDrag = false;
    void render();
});
dial.addEventListener("keydown", (e) => {
    const step = {
        ArrowLeft: [azimuth, -5],
        ArrowRight: [azimuth, 5],
        ArrowUp: [elevation, 5],
        ArrowDown: [elevation, -5],
    };
    const s = step[e.key];
    if (!s || state.moving < 0)
        return;
    e.preventDefault();
    s[0].value = String(Number(s[0].value) + s[1]);
    showSliders();
    void render();
});
let drag;
frame.addEventListener("pointerdown", (e) => {
    if (!state.camera)
        return;
    e.preventDefault();
    frame.setPointerCapture(e.pointerId);
    drag = { x: e.clientX, y: e.clientY, orbit: Number(orbit.value), tilt: Number(tilt.value) };
});
frame.addEventListener("pointermove", (e) => {
    if (!drag)
        return;
    const wrap = (a) => ((((a + 180) % 360) + 360) % 360) - 180;
    orbit.value = String(Math.round(wrap(drag.orbit - (e.clientX - drag.x) / 2)));
    tilt.value = String(Math.round(Math.min(85, Math.max(5, drag.tilt + (e.clientY - drag.y) / 2))));
    showSliders();
    void preview("camera");
});
frame.addEventListener("pointerup", () => {
    if (!drag)
        return;
    drag = undefined;
    void render();
});
/** The status line: the server's GPU adapter and its queue, every few seconds. */
async function serverLine() {
    try {
        const v = (await (await fetch("/readyz")).json());
        const jobs = (n) => n ? `${n.renders} renders, ${n.bakes} bakes` : "?";
        $("server").textContent = v.adapter
            ? `GPU: ${v.adapter} · queued: ${jobs(v.queued)} · running: ${jobs(v.running)}`
            : `No GPU adapter: ${v.detail ?? "CPU methods only"}`;
        const gpu = Boolean(v.adapter);
        if (gpu !== state.gpu) {
            state.gpu = gpu;
            showFits();
        }
    }
    catch {
        // The line keeps its last value.
    }
}
void serverLine();
setInterval(() => void serverLine(), 3000);
bakeBtn.addEventListener("click", () => void bake());
$("compare").addEventListener("click", () => void compareWithReference());
showSliders();
void example();
