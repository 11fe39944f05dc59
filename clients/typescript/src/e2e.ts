// End-to-end check of the TypeScript client against a running server (the tests compile this
// folder with tsc and run `node dist/e2e.js BASE_URL GLB SCENE_JSON`): uploads a GLB and a scene
// JSON, renders PNG and EXR, runs a csl bake to completion following its events, cancels a
// bake, lists jobs, and checks a bad request throws the server's problem. One line a step.

import { readFileSync } from "node:fs";
import { Caustica, CausticaError, type ProgressEvent, type Scene } from "./index.js";

function check(cond: unknown, what: string): void {
  if (!cond) throw new Error(`FAILED: ${what}`);
  console.log(`ok: ${what}`);
}

async function main(): Promise<void> {
  const [base, glbPath, scenePath] = process.argv.slice(2);
  const c = new Caustica(base);

  const glb = await c.uploadGlb(readFileSync(glbPath));
  check(glb.id.length === 64 && glb.triangles > 0, `GLB uploaded: ${glb.id.slice(0, 12)}, ${glb.triangles} triangles`);
  const scene = JSON.parse(readFileSync(scenePath, "utf8")) as Scene;
  const sphere = await c.uploadScene(scene);
  const glass = sphere.objects.filter((o) => o.specular).map((o) => o.name);
  check(glass.length > 0, `scene JSON uploaded with glass objects ${glass}`);

  const png = await c.render({ scene: glb.id, method: "direct", width: 64, height: 48 });
  check(png.contentType === "image/png" && png.image[1] === 0x50, `PNG render of the GLB (${png.image.length} bytes)`);
  check(png.timings.some((t) => t.name === "encode"), `its Server-Timing names the stages: ${png.timings.map((t) => t.name)}`);
  const exr = await c.render({ scene: sphere.id, method: "direct", width: 64, height: 48, format: "exr" });
  check(exr.contentType === "image/x-exr" && exr.image[0] === 0x76, `EXR render of the scene (${exr.image.length} bytes)`);

  const seen: ProgressEvent[] = [];
  const job = await c.bake(
    { scene: sphere.id, object: glass[0], method: "csl", params: { preset: "fast", grid: 64 } },
    { wait: true, onProgress: (e) => seen.push(e) },
  );
  check(job.state === "succeeded" && job.method === "csl", `csl bake ${job.id} succeeded`);
  const art = await c.bakeArtifact(job.id);
  check(art.length > 0, `bake artifact downloaded (${art.length} bytes, ${seen.length} progress events)`);

  const slow = await c.bake({
    scene: sphere.id,
    object: glass[0],
    method: "reference",
    params: { photons: 50_000_000, spp: 64, width: 256, height: 256, seed: 11 },
  });
  const canceled = await c.cancelBake(slow.id);
  check(canceled.state === "canceled", `bake ${slow.id} canceled`);
  check((await c.wait(slow.id)).state === "canceled", "the canceled bake stays canceled");

  const bakes: string[] = [];
  for await (const b of c.bakes()) bakes.push(b.id);
  check(bakes.includes(job.id) && bakes.includes(slow.id), `bakes listed (${bakes.length})`);
  const canceledOnly: string[] = [];
  for await (const b of c.bakes({ state: "canceled" })) canceledOnly.push(b.id);
  check(canceledOnly.length === 1 && canceledOnly[0] === slow.id, "bakes filtered by state");
  let renders = 0;
  for await (const _ of c.renders({ page_size: 1 })) renders++;
  check(renders >= 2, `renders listed a page of one at a time (${renders})`);

  try {
    await c.render({ scene: sphere.id, method: "direct", width: 100000 });
    check(false, "an impossible width is refused");
  } catch (e) {
    check(e instanceof CausticaError && e.status === 422 && e.field === "width", `an impossible width throws the problem: ${e}`);
  }
  console.log("e2e: all passed");
}

main().catch((e) => {
  console.error(e);
  process.exitCode = 1;
});
