// The web viewer served at `/` by `caustica serve`: pick the example or upload a scene, render
// it with a method, orbit the camera and turn the scene's directional light (small `direct`
// previews while dragging, the full frame on release), bake its caustic spot lights with live
// progress. Every call goes through the TypeScript client (clients/typescript), compiled with
// this file into web/dist (web/build.sh) and served from the binary.
// "caustica" is the client: mapped to its source for tsc (tsconfig paths), and to its compiled
// module for the browser (index.html's import map).
import { Caustica, CausticaError, } from "caustica";
const $ = (id) => document.getElementById(id);
const status = $("status");
const method = $("method");
const width = $("width");
const height = $("height");
const photons = $("photons");
const azimuth = $("azimuth");
const elevation = $("elevation");
const frame = $("frame");
const objectSel = $("object");
const bakeBtn = $("bake");
const cancelBtn = $("cancel");
const progress = $("bake-progress");
const bakeStage = $("bake-stage");
const keyInput = $("key");
const orbit = $("orbit");
const tilt = $("tilt");
const preset = $("preset");
keyInput.value = sessionStorage.getItem("caustica-key") ?? "";
let client = new Caustica(location.origin, { apiKey: keyInput.value || undefined });
keyInput.addEventListener("change", () => {
    sessionStorage.setItem("caustica-key", keyInput.value);
    client = new Caustica(location.origin, { apiKey: keyInput.value || undefined });
});
let scene;
/** The scene's first directional light, turned by the sliders (undefined: the scene has none). */
let light;
/** The scene's camera; `distance` from its target, turned by the orbit and tilt sliders. */
let camera;
let frameUrl = "";
let rendering = 0;
let previews = 0;
let previewBusy = false;
function say(text) {
    status.textContent = text;
}
function problem(e) {
    return e instanceof CausticaError ? `${e.status}: ${e.problem.detail}` : String(e);
}
/** Light direction (towards where the light travels) from the sliders. */
function direction() {
    const az = (Number(azimuth.value) * Math.PI) / 180;
    const el = (Number(elevation.value) * Math.PI) / 180;
    return [Math.cos(el) * Math.cos(az), -Math.sin(el), Math.cos(el) * Math.sin(az)];
}
function showSliders() {
    for (const s of [azimuth, elevation, orbit, tilt]) {
        $(`${s.id}-value`).value = s.value;
    }
}
/** The camera's eye from the orbit and tilt sliders, at its distance from its target. */
function eye() {
    const c = camera;
    const az = (Number(orbit.value) * Math.PI) / 180;
    const el = (Number(tilt.value) * Math.PI) / 180;
    const d = c.distance;
    return [
        c.target[0] + d * Math.cos(el) * Math.sin(az),
        c.target[1] + d * Math.sin(el),
        c.target[2] + d * Math.cos(el) * Math.cos(az),
    ];
}
/** Sets the sliders from a light direction. */
function slidersFrom(d) {
    const [x, y, z] = d;
    const h = Math.hypot(x, z);
    azimuth.value = String(Math.round((Math.atan2(z, x) * 180) / Math.PI));
    elevation.value = String(Math.round((Math.atan2(-y, h) * 180) / Math.PI));
    showSliders();
}
async function useScene(info) {
    scene = info;
    const lights = (info.scene.lights ?? []);
    const dir = lights.find((l) => l.type === "directional");
    light = dir ? { ...dir } : undefined;
    if (light)
        slidersFrom(light.direction);
    azimuth.disabled = elevation.disabled = !light;
    const cam = info.scene.camera;
    const [ex, ey, ez] = cam.eye.map((v, i) => v - cam.target[i]);
    const distance = Math.hypot(ex, ey, ez);
    camera = { ...cam, distance };
    orbit.value = String(Math.round((Math.atan2(ex, ez) * 180) / Math.PI));
    tilt.value = String(Math.round((Math.asin(ey / distance) * 180) / Math.PI));
    showSliders();
    objectSel.replaceChildren(...info.objects
        .filter((o) => o.specular)
        .map((o) => new Option(`${o.name} (${o.triangles} triangles)`, o.name)));
    bakeBtn.disabled = objectSel.options.length === 0;
    $("warnings").replaceChildren(...info.warnings.map((w) => Object.assign(document.createElement("li"), { textContent: w })));
    await render();
}
/** The render request for what the controls say; a preview is a small `direct` frame. */
function request(preview = false) {
    const req = {
        scene: scene.id,
        method: (preview ? "direct" : method.value),
        width: Number(width.value),
        height: Number(height.value),
    };
    if (preview) {
        const s = Math.min(1, 128 / Math.max(req.width, req.height));
        req.width = Math.max(16, Math.round(req.width * s));
        req.height = Math.max(16, Math.round(req.height * s));
    }
    else if (method.value === "reference" || method.value === "photons") {
        req.photons = Number(photons.value);
    }
    if (!preview && method.value === "reference")
        req.spp = 4;
    if (light)
        req.lights = [{ ...light, direction: direction() }];
    if (camera) {
        const { distance: _, ...cam } = camera;
        req.camera = { ...cam, eye: eye() };
    }
    return req;
}
/** Puts frame `f` on screen (its image as the frame element's object URL). */
function show(f) {
    URL.revokeObjectURL(frameUrl);
    frameUrl = URL.createObjectURL(new Blob([f.image], { type: f.contentType }));
    frame.src = frameUrl;
}
/** A small `direct` frame for the controls as they are now, unless one is on its way. */
async function preview() {
    if (!scene || previewBusy)
        return;
    previewBusy = true;
    const asked = rendering;
    const t0 = performance.now();
    try {
        const f = await client.render(request(true));
        if (asked !== rendering)
            return; // a full frame was asked for meanwhile
        show(f);
        frame.classList.add("preview");
        frame.dataset.preview = String(++previews);
        frame.dataset.previewMs = (performance.now() - t0).toFixed(0);
    }
    catch (e) {
        say(`Preview failed: ${problem(e)}`);
    }
    finally {
        previewBusy = false;
    }
}
async function render() {
    if (!scene)
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
        const loaded = new Promise((res) => (frame.onload = res));
        show(f);
        await loaded;
        frame.classList.remove("preview");
        const dl = $("download");
        dl.href = frameUrl;
        dl.hidden = false;
        const max = Math.max(...f.timings.filter((t) => t.name !== "request").map((t) => t.ms), 1);
        $("timings").replaceChildren(...f.timings.map((t) => {
            const li = document.createElement("li");
            const bar = Object.assign(document.createElement("span"), { className: "bar" });
            bar.style.width = `${Math.min(100, (100 * t.ms) / max)}%`;
            li.append(t.name, bar, `${t.ms.toFixed(1)} ms`);
            return li;
        }));
        $("curl").value =
            `curl -s ${location.origin}/v1/renders -H 'Content-Type: application/json' ` +
                `-d '${JSON.stringify(req)}' -o frame.png`;
        $("python").value =
            `import json\nfrom caustica import Caustica\n` +
                `Caustica("${location.origin}").render(**json.loads('${JSON.stringify(req)}'), out="frame.png")`;
        say(`Rendered with ${req.method} in ${(performance.now() - t0).toFixed(0)} ms`);
        frame.dataset.frame = String(mine);
    }
    catch (e) {
        if (mine === rendering)
            say(`Render failed: ${problem(e)}`);
    }
}
/** The chosen method and the reference rendered as EXR for the controls as they are, and
 *  measured against each other on the scene's first receiver (a non-glass object). */
async function compareWithReference() {
    if (!scene)
        return;
    const receiver = scene.objects.find((o) => !o.specular)?.name;
    if (!receiver) {
        say("Compare needs an object that is not glass or a mirror to measure on");
        return;
    }
    const req = request();
    const box = $("compare-result");
    say(`Comparing ${req.method} with the reference…`);
    try {
        const a = await client.render({ ...req, format: "exr" });
        const ref = { ...req, method: "reference", format: "exr" };
        ref.photons = Number(photons.value);
        ref.spp = 4;
        const b = await client.render(ref);
        const m = await client.compare(a.renderId, b.renderId, receiver);
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
async function upload(file) {
    say(`Uploading ${file.name}…`);
    try {
        const bytes = new Uint8Array(await file.arrayBuffer());
        let info;
        if (file.name.endsWith(".glb"))
            info = await client.uploadGlb(bytes);
        else if (file.name.endsWith(".gltf"))
            info = await client.uploadGltf(new TextDecoder().decode(bytes));
        else
            info = await client.uploadScene(JSON.parse(new TextDecoder().decode(bytes)));
        await useScene(info);
    }
    catch (e) {
        say(`Upload failed: ${problem(e)}`);
    }
}
async function example() {
    say("Loading the example…");
    try {
        const r = await fetch("/viewer/example.json");
        await useScene(await client.uploadScene(await r.json()));
    }
    catch (e) {
        say(`The example did not load: ${problem(e)}`);
    }
}
async function bake() {
    if (!scene)
        return;
    bakeBtn.disabled = true;
    progress.value = 0;
    bakeStage.textContent = "";
    try {
        const job = await client.bake({
            scene: scene.id,
            object: objectSel.value,
            method: "csl",
            params: { preset: preset.value },
        }, { wait: false });
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
        say(`Bake ${done.id} ${done.state}`);
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
    const f = e.target.files?.[0];
    if (f)
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
    const f = e.dataTransfer?.files[0];
    if (f)
        void upload(f);
});
for (const s of [azimuth, elevation, orbit, tilt]) {
    // Previews while a slider moves; the full frame once it is released (keyboard changes too).
    s.addEventListener("input", () => {
        showSliders();
        void preview();
    });
    s.addEventListener("change", () => void render());
}
// Dragging the frame orbits the camera (horizontal) and tilts it (vertical).
let drag;
// Not the browser's own image drag (which would drop the frame on the page as an upload).
frame.draggable = false;
frame.addEventListener("dragstart", (e) => e.preventDefault());
frame.addEventListener("pointerdown", (e) => {
    if (!camera)
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
    void preview();
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
