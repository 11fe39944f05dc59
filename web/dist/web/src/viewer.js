// The web viewer served at `/` by `caustica serve`: pick the example or upload a scene, render
// it with a method, turn the scene's directional light, bake its caustic spot lights with live
// progress. Every call goes through the TypeScript client (clients/typescript), compiled with
// this file into web/dist (web/build.sh) and served from the binary.
// "caustica" is the client: mapped to its source for tsc (tsconfig paths), and to its compiled
// module for the browser (index.html's import map).
import { Caustica, CausticaError } from "caustica";
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
keyInput.value = sessionStorage.getItem("caustica-key") ?? "";
let client = new Caustica(location.origin, { apiKey: keyInput.value || undefined });
keyInput.addEventListener("change", () => {
    sessionStorage.setItem("caustica-key", keyInput.value);
    client = new Caustica(location.origin, { apiKey: keyInput.value || undefined });
});
let scene;
/** The scene's first directional light, turned by the sliders (undefined: the scene has none). */
let light;
let frameUrl = "";
let rendering = 0;
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
    $("azimuth-value").value = azimuth.value;
    $("elevation-value").value = elevation.value;
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
    objectSel.replaceChildren(...info.objects
        .filter((o) => o.specular)
        .map((o) => new Option(`${o.name} (${o.triangles} triangles)`, o.name)));
    bakeBtn.disabled = objectSel.options.length === 0;
    $("warnings").replaceChildren(...info.warnings.map((w) => Object.assign(document.createElement("li"), { textContent: w })));
    await render();
}
function request() {
    const req = {
        scene: scene.id,
        method: method.value,
        width: Number(width.value),
        height: Number(height.value),
    };
    if (method.value === "reference" || method.value === "photons")
        req.photons = Number(photons.value);
    if (method.value === "reference")
        req.spp = 4;
    if (light)
        req.lights = [{ ...light, direction: direction() }];
    return req;
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
        URL.revokeObjectURL(frameUrl);
        frameUrl = URL.createObjectURL(new Blob([f.image], { type: f.contentType }));
        const loaded = new Promise((res) => (frame.onload = res));
        frame.src = frameUrl;
        await loaded;
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
        say(`Rendered with ${req.method} in ${(performance.now() - t0).toFixed(0)} ms`);
        frame.dataset.frame = String(mine);
    }
    catch (e) {
        if (mine === rendering)
            say(`Render failed: ${problem(e)}`);
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
        const job = await client.bake({ scene: scene.id, object: objectSel.value, method: "csl", params: { preset: "fast" } }, { wait: false });
        cancelBtn.disabled = false;
        cancelBtn.onclick = () => void client.cancelBake(job.id).catch((e) => say(problem(e)));
        const done = await client.wait(job.id, (e) => {
            progress.value = e.progress;
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
for (const s of [azimuth, elevation]) {
    s.addEventListener("input", showSliders);
    // The full frame once the slider is released (keyboard changes too).
    s.addEventListener("change", () => void render());
}
bakeBtn.addEventListener("click", () => void bake());
showSliders();
void example();
