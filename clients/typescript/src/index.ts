// Caustica from TypeScript (browsers and Node 18+): every type comes from `schema.ts`, generated
// from api/openapi.yaml by openapi-typescript (`./generate.sh`); this file is the thin layer
// over `fetch` that the generator does not write: one typed method per operation, uploads of
// each scene format, a job's server-sent events, waiting for a render answered with 202, and
// errors thrown as CausticaError carrying the problem.

import type { components, operations } from "./schema";

type Schemas = components["schemas"];
export type Scene = Schemas["Scene"];
export type SceneInfo = Schemas["SceneInfo"];
export type SceneSummary = Schemas["SceneSummary"];
export type Job = Schemas["Job"];
export type JobState = Schemas["JobState"];
export type Method = Schemas["Method"];
export type RenderRequest = Schemas["RenderRequest"];
export type BakeRequest = Schemas["BakeRequest"];
export type Problem = Schemas["Problem"];
export type ProgressEvent = Schemas["ProgressEvent"];
export type LightDesc = Schemas["LightDesc"];
/** The light of one `type` (`LightDescOf<"directional">`...). */
export type LightDescOf<T extends LightDesc["type"]> = Extract<LightDesc, { type: T }>;
export type Comparison = operations["compare"]["responses"]["200"]["content"]["application/json"];
export type ListJobsQuery = NonNullable<operations["listBakes"]["parameters"]["query"]>;
export type ListScenesQuery = NonNullable<operations["listScenes"]["parameters"]["query"]>;

/** An answer that was not a success, with its RFC 9457 problem. */
export class CausticaError extends Error {
  readonly status: number;
  readonly problem: Problem;
  constructor(status: number, problem: Problem) {
    super(`${status} ${problem.title}: ${problem.detail}`);
    this.status = status;
    this.problem = problem;
  }
  /** The request field at fault, when there is one. */
  get field(): string | undefined {
    return this.problem.field ?? undefined;
  }
}

/** One stage of a `Server-Timing` header. */
export interface Timing {
  name: string;
  ms: number;
}

/** A rendered frame: its bytes, media type, stages, its render's id, and what the render
 *  warns of (why its caustics are black, a poor self-check...). */
export interface Frame {
  image: Uint8Array;
  contentType: string;
  timings: Timing[];
  renderId?: string;
  warnings: string[];
}

/** A server-sent event of a job: `progress` events, then one `done` (the job) or `gone`. */
export type JobEvent =
  | { event: "progress"; data: ProgressEvent }
  | { event: "done"; data: Job }
  | { event: "gone"; data: { id: string } };

const TERMINAL: JobState[] = ["succeeded", "failed", "canceled"];

/** A job's warnings (`info.warnings`), where it has any. */
function warningsOf(job: Job): string[] {
  const w = (job.info as { warnings?: unknown }).warnings;
  return Array.isArray(w) ? w.map(String) : [];
}

/** Parses `Server-Timing` (`name;dur=ms, ...`). */
export function parseServerTiming(h: string | null): Timing[] {
  if (!h) return [];
  return h.split(",").flatMap((part) => {
    const [name, ...params] = part.trim().split(";");
    const dur = params.map((p) => p.trim()).find((p) => p.startsWith("dur="));
    return name && dur ? [{ name: name.trim(), ms: Number(dur.slice(4)) }] : [];
  });
}

export interface Options {
  /** An API key, where the server has keys. */
  apiKey?: string;
  /** The fetch to use (the global one by default). */
  fetch?: typeof fetch;
}

export class Caustica {
  private readonly base: string;
  private readonly key?: string;
  private readonly fetch: typeof fetch;

  constructor(baseUrl: string, opts: Options = {}) {
    this.base = baseUrl.replace(/\/$/, "");
    this.key = opts.apiKey;
    this.fetch = opts.fetch ?? globalThis.fetch.bind(globalThis);
  }

  private async call(path: string, init: RequestInit = {}): Promise<Response> {
    const headers = new Headers(init.headers);
    if (this.key) headers.set("Authorization", `Bearer ${this.key}`);
    const r = await this.fetch(this.base + path, { ...init, headers });
    if (!r.ok && r.status !== 304) {
      const text = await r.text();
      let problem: Problem;
      try {
        problem = JSON.parse(text) as Problem;
      } catch {
        problem = { type: "about:blank", title: r.statusText, status: r.status, detail: text.slice(0, 200) };
      }
      throw new CausticaError(r.status, problem);
    }
    return r;
  }

  private async json<T>(path: string, init: RequestInit = {}): Promise<T> {
    return (await (await this.call(path, init)).json()) as T;
  }

  private post<T>(path: string, body: unknown, headers: Record<string, string> = {}): Promise<T> {
    return this.json<T>(path, {
      method: "POST",
      headers: { "Content-Type": "application/json", ...headers },
      body: JSON.stringify(body),
    });
  }

  // Scenes

  /** Stores a scene given as our scene JSON. */
  uploadScene(scene: Scene): Promise<SceneInfo> {
    return this.post<SceneInfo>("/v1/scenes", scene);
  }

  /** Stores a GLB (`model/gltf-binary`) as a whole scene. */
  uploadGlb(glb: Uint8Array | ArrayBuffer | Blob): Promise<SceneInfo> {
    return this.json<SceneInfo>("/v1/scenes", {
      method: "POST",
      headers: { "Content-Type": "model/gltf-binary" },
      body: glb as BodyInit,
    });
  }

  /** Stores a glTF JSON file with embedded data (`model/gltf+json`) as a whole scene. */
  uploadGltf(gltf: string): Promise<SceneInfo> {
    return this.json<SceneInfo>("/v1/scenes", {
      method: "POST",
      headers: { "Content-Type": "model/gltf+json" },
      body: gltf,
    });
  }

  /** Stores a scene JSON with the files it names (multipart: part `scene` and one per file). */
  uploadSceneWithFiles(scene: Scene, files: Record<string, Blob | Uint8Array>): Promise<SceneInfo> {
    const form = new FormData();
    form.append("scene", new Blob([JSON.stringify(scene)], { type: "application/json" }));
    for (const [name, data] of Object.entries(files)) {
      form.append(name, data instanceof Blob ? data : new Blob([data]), name);
    }
    return this.json<SceneInfo>("/v1/scenes", { method: "POST", body: form });
  }

  scene(id: string): Promise<SceneInfo> {
    return this.json<SceneInfo>(`/v1/scenes/${encodeURIComponent(id)}`);
  }

  async deleteScene(id: string): Promise<void> {
    await this.call(`/v1/scenes/${encodeURIComponent(id)}`, { method: "DELETE" });
  }

  /** Every stored scene the key holds, newest first, fetched a page at a time. */
  scenes(query: ListScenesQuery = {}): AsyncGenerator<SceneSummary> {
    return this.pages<SceneSummary>("/v1/scenes", query);
  }

  // Renders

  /** Renders a frame; a render that outlasts the server's wait is followed to its end. */
  async render(req: RenderRequest, opts: { idempotencyKey?: string; signal?: AbortSignal } = {}): Promise<Frame> {
    const headers: Record<string, string> = { "Content-Type": "application/json" };
    if (opts.idempotencyKey) headers["Idempotency-Key"] = opts.idempotencyKey;
    const r = await this.call("/v1/renders", {
      method: "POST",
      headers,
      body: JSON.stringify(req),
      signal: opts.signal,
    });
    const timings = parseServerTiming(r.headers.get("Server-Timing"));
    const location = r.headers.get("Location") ?? "";
    if (r.status === 202) {
      const job = (await r.json()) as Job;
      const done = await this.wait(job.id);
      if (done.state !== "succeeded") {
        throw new CausticaError(500, {
          type: "about:blank",
          title: `render ${done.state}`,
          status: 500,
          detail: done.error ?? "",
        });
      }
      const img = await this.call(`/v1/renders/${done.id}/image`);
      return {
        image: new Uint8Array(await img.arrayBuffer()),
        contentType: img.headers.get("Content-Type") ?? "",
        timings: done.timings.map((t) => ({ name: t.stage, ms: t.ms })),
        renderId: done.id,
        warnings: warningsOf(done),
      };
    }
    const image = new Uint8Array(await r.arrayBuffer());
    const renderId = location.split("/").pop() || undefined;
    // `Caustica-Warning` headers say there are warnings (fetch joins repeated headers with
    // commas, which warnings contain): the record has them, one string each.
    const warned = r.headers.get("Caustica-Warning") !== null && renderId;
    return {
      image,
      contentType: r.headers.get("Content-Type") ?? "",
      timings,
      renderId,
      warnings: warned ? warningsOf(await this.job(renderId)) : [],
    };
  }

  /** Render `a` against render `b` (both finished EXRs), as `caustica compare` does, over
   *  the pixels that see `object` (default floor). */
  compare(a: string, b: string, object?: string): Promise<Comparison> {
    return this.post<Comparison>("/v1/compare", object ? { a, b, object } : { a, b });
  }

  renders(query: ListJobsQuery = {}): AsyncGenerator<Job> {
    return this.pages<Job>("/v1/renders", query);
  }

  cancelRender(id: string): Promise<Job> {
    return this.json<Job>(`/v1/renders/${encodeURIComponent(id)}`, { method: "DELETE" });
  }

  // Bakes

  /** Starts (or finds) a bake; with `wait`, follows its events to the end. */
  async bake(
    req: BakeRequest,
    opts: { wait?: boolean; onProgress?: (e: ProgressEvent) => void; idempotencyKey?: string } = {},
  ): Promise<Job> {
    const headers: Record<string, string> = {};
    if (opts.idempotencyKey) headers["Idempotency-Key"] = opts.idempotencyKey;
    const job = await this.post<Job>("/v1/bakes", req, headers);
    if (!opts.wait || TERMINAL.includes(job.state)) return job;
    return this.wait(job.id, opts.onProgress);
  }

  async bakeArtifact(id: string): Promise<Uint8Array> {
    const r = await this.call(`/v1/bakes/${encodeURIComponent(id)}/artifact`);
    return new Uint8Array(await r.arrayBuffer());
  }

  bakes(query: ListJobsQuery = {}): AsyncGenerator<Job> {
    return this.pages<Job>("/v1/bakes", query);
  }

  cancelBake(id: string): Promise<Job> {
    return this.json<Job>(`/v1/bakes/${encodeURIComponent(id)}`, { method: "DELETE" });
  }

  // Jobs

  job(id: string): Promise<Job> {
    return this.json<Job>(`/v1/${kind(id)}/${encodeURIComponent(id)}`);
  }

  /** The job's server-sent events until the stream ends. */
  async *events(id: string, signal?: AbortSignal): AsyncGenerator<JobEvent> {
    const r = await this.call(`/v1/${kind(id)}/${encodeURIComponent(id)}/events`, {
      headers: { Accept: "text/event-stream" },
      signal,
    });
    if (!r.body) return;
    const reader = r.body.getReader();
    const text = new TextDecoder();
    let buf = "";
    let event = "message";
    let data: string[] = [];
    for (;;) {
      const { value, done } = await reader.read();
      if (done) return;
      buf += text.decode(value, { stream: true });
      let nl: number;
      while ((nl = buf.indexOf("\n")) >= 0) {
        const line = buf.slice(0, nl).replace(/\r$/, "");
        buf = buf.slice(nl + 1);
        if (line === "") {
          if (data.length) yield { event, data: JSON.parse(data.join("\n")) } as JobEvent;
          event = "message";
          data = [];
        } else if (line.startsWith("event:")) {
          event = line.slice(6).trim();
        } else if (line.startsWith("data:")) {
          data.push(line.slice(5).trimStart());
        }
      }
    }
  }

  /** The job once finished, following its events (polling when the stream breaks). */
  async wait(id: string, onProgress?: (e: ProgressEvent) => void): Promise<Job> {
    try {
      for await (const e of this.events(id)) {
        if (e.event === "progress") onProgress?.(e.data);
        else if (e.event === "done") return e.data;
        else if (e.event === "gone") {
          throw new CausticaError(404, { type: "about:blank", title: "Not found", status: 404, detail: `job ${id} was deleted` });
        }
      }
    } catch (e) {
      if (e instanceof CausticaError) throw e;
    }
    for (;;) {
      const job = await this.job(id);
      if (TERMINAL.includes(job.state)) return job;
      await new Promise((res) => setTimeout(res, 1000));
    }
  }

  private async *pages<T>(path: string, query: Record<string, unknown>): AsyncGenerator<T> {
    let token: string | null | undefined;
    do {
      const q = new URLSearchParams();
      for (const [k, v] of Object.entries(query)) if (v !== undefined && v !== null) q.set(k, String(v));
      if (token) q.set("page_token", token);
      const page = await this.json<{ items: T[]; next_page_token: string | null }>(`${path}?${q}`);
      for (const item of page.items) yield item;
      token = page.next_page_token;
    } while (token);
  }
}

function kind(id: string): "bakes" | "renders" {
  return id.startsWith("bk_") ? "bakes" : "renders";
}
