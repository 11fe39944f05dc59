//! `caustica`: the command line. Thin: parses arguments and calls the library; every method's
//! work goes through [`caustica::methods`], as the service's does.

use anyhow::{Context, Result, bail};
use caustica::encode::{self, PngSettings, ToneMap};
use caustica::frame::Component;
use caustica::frame::Frame;
use caustica::methods::local::LocalGpu;
use caustica::methods::{
    ArtifactStore, BakeRequest, Env, Method, MethodArgs, MethodError, ParamError,
};
use caustica::reference::compare;
use caustica::scene::{self, World};
use clap::{Parser, Subcommand};
use indicatif::{ProgressBar, ProgressStyle};
use std::path::{Path, PathBuf};
use std::time::{Duration, Instant};

#[derive(Parser)]
#[command(
    name = "caustica",
    version,
    about = "Caustics renderer: CPU ground truth and GPU methods"
)]
struct Cli {
    #[command(subcommand)]
    cmd: Cmd,
}

// Parsed once per process: the size of the render variant's flags costs nothing.
#[allow(clippy::large_enum_variant)]
#[derive(Subcommand)]
enum Cmd {
    /// Render a scene to PNG or EXR (format from the extension).
    Render {
        scene: PathBuf,
        /// The method (`auto` picks one from the scene: see the README).
        #[arg(long, value_enum, default_value = "auto")]
        method: Method,
        /// Add a diffuse ground plane under the scene's objects (for a glass or mirror object
        /// alone, whose shadow and caustic otherwise fall on nothing).
        #[arg(long)]
        ground: bool,
        /// Run the self-check (a short reference of the caustics compared with the frame on
        /// the receivers; docs/accuracy.md) whatever the method's default (on for csl and
        /// transport).
        #[arg(long, conflicts_with = "no_check")]
        check: bool,
        /// Skip the self-check.
        #[arg(long)]
        no_check: bool,
        #[arg(long)]
        width: Option<u32>,
        #[arg(long)]
        height: Option<u32>,
        /// Replaces the scene's camera: its JSON, as in a scene (`{"eye": [0, 1, 2],
        /// "target": [0, 0, 0], "fov_y": 40}`), as the API's `camera`.
        #[arg(long)]
        camera: Option<String>,
        #[arg(long, value_enum, default_value = "total")]
        component: Component,
        /// Output file: .png (tone-mapped sRGB) or .exr (linear radiance).
        #[arg(long)]
        out: PathBuf,
        /// Every component too: EXR gets one layer per component (the chosen one first); PNG
        /// gets one file per component next to it (NAME.COMPONENT.png).
        #[arg(long)]
        layers: bool,
        /// PNG exposure in stops.
        #[arg(long, default_value_t = 0.0)]
        exposure: f32,
        /// Render the frame this many times on the same renderer (1..=1000) and print each
        /// stage's median over all but the first (a warm-up that may bake, build pipelines and
        /// fill caches), with the adapter: for benchmarking (`benches/gpu.sh`).
        #[arg(long, value_parser = clap::value_parser!(u32).range(1..=1000))]
        repeat: Option<u32>,
        #[arg(long, value_enum, default_value = "clamp")]
        tone_map: ToneMap,
        /// Reference, photons: photons (light paths) to trace in all (default 4,000,000 for the
        /// reference, 1,048,576 for photons).
        #[arg(long)]
        photons: Option<u64>,
        /// Reference: camera samples per pixel.
        #[arg(long, default_value_t = 16)]
        spp: u32,
        #[arg(long, default_value_t = 1)]
        seed: u64,
        /// Reference, photons: stop tracing photons after this many seconds.
        #[arg(long)]
        time_budget: Option<f64>,
        /// Photons: photons traced per frame, 1024..=4194240 (default 524288).
        #[arg(long)]
        photons_per_frame: Option<u32>,
        /// Photons: stop once the estimated noise (relative L1 per pixel) is at most this.
        #[arg(long)]
        error_target: Option<f32>,
        /// Photons: the first frame's kernel half-size in photon spacings, 0.5..=8 (default 3).
        #[arg(long)]
        footprint: Option<f32>,
        /// Reference: scatterings in the scene's medium a light path may have (1: single
        /// scattering; default: unlimited).
        #[arg(long)]
        volume_bounces: Option<u32>,
        /// CSL: a baked CSL set (`caustica bake csl`; a `--dynamic` one gives the set for the
        /// scene's light direction by interpolation) for the scene's caustic object; without
        /// it every caustic object is baked (kept by content hash in CAUSTICA_CACHE or the
        /// temp directory). Transport: a table (`caustica bake transport`) for one glass
        /// object, found by its content hash; every other glass object is baked first.
        #[arg(long)]
        bake: Option<PathBuf>,
        /// Transport, pinhole: point lights a line light is split into (Iwasaki et al. 2005
        /// §5.1).
        #[arg(long, default_value_t = caustica::render::transport::volumes::DEFAULT_LINE_POINTS)]
        line_points: u32,
        /// Pinhole: sample points over all reflectors, 1..=100000 (default 2000).
        #[arg(long)]
        samples: Option<u32>,
        /// Pinhole: how the points are chosen (Wand and Straßer 2003 §3.2).
        #[arg(long, value_enum)]
        sampling: Option<caustica::render::pinhole::Strategy>,
        /// Pinhole: no curvature-based anti-aliasing (shows the aliasing of §3.3).
        #[arg(long)]
        no_filter: bool,
        /// Pinhole: occlusion of the reflected light by the scene's objects (off by default:
        /// 12–19× the time on lavapipe; use it where a mirror faces the table or itself).
        #[arg(long)]
        shadows: bool,
        /// Pinhole: open glass surfaces (a water surface, a sheet) also transmit, as one
        /// refracting interface (paper §5).
        #[arg(long)]
        transmit: bool,
        /// Pinhole: points per cluster, 1..=64 (default 16; 1: every pixel takes every point).
        /// A receiver farther than 6 cluster radii takes a cluster as one pinhole.
        #[arg(long)]
        cluster: Option<u32>,
        /// Pinhole: angular radius in degrees of the disc a directional, point or spot light
        /// appears as (default 0.27, the sun's).
        #[arg(long)]
        sun_radius: Option<f32>,
        /// Water: physical (default: refracted grid of sun rays, converges to the reference)
        /// or article (Sánchez-Crespo 2003's sun-map lookup).
        #[arg(long, value_enum)]
        water_mode: Option<caustica::render::water::Mode>,
        /// Water: where the caustics are computed: on the GPU, shader (per pixel; the default
        /// for one water shape under one sun) or shader_texture (a mipmapped light map); on the
        /// CPU, pixel (the default otherwise, or with --pixel-samples), texture (a mipmapped
        /// light map) or vertex (a coarse grid, the article's first version).
        #[arg(long, value_enum)]
        water_variant: Option<caustica::render::water::Variant>,
        /// Water, physical: sun rays per side of the water's rectangle (default 512).
        #[arg(long)]
        water_grid: Option<u32>,
        /// Water, physical: directions over the sun's disc (default 4).
        #[arg(long)]
        sun_samples: Option<u32>,
        /// Water, texture, shader, shader_texture: texels per side of the light map (default
        /// 1024).
        #[arg(long)]
        map_resolution: Option<u32>,
        /// Water, vertex: quads per side of the receiver grid (default 128).
        #[arg(long)]
        mesh_resolution: Option<u32>,
        /// Water, article: the sun map's width in degrees (default 4).
        #[arg(long)]
        sun_map_width: Option<f32>,
        /// Water: receiver points per pixel side (default 3: 9 a pixel).
        #[arg(long)]
        pixel_samples: Option<u32>,
        /// Beams: grid cells a side, 32, 64, 128 (default) or 256.
        #[arg(long)]
        grid: Option<u32>,
        /// Beams: samples along a view ray per beam, 1..=16 (default 1).
        #[arg(long)]
        beam_samples: Option<u32>,
        /// Beams: the paper's unshadowed beams, which run through every object.
        #[arg(long)]
        no_beam_shadows: bool,
        /// Beams: the paper's one-sided refraction (beams leave the glass's entry surface).
        #[arg(long)]
        one_sided: bool,
        /// Beams: no surface caustics, only the volume.
        #[arg(long)]
        no_surface: bool,
        /// Beams: the volume at 1/2 or 1/4 of the resolution, upsampled edge-aware.
        #[arg(long)]
        downsample: Option<u32>,
        /// Beams: grid cells across a silhouette are split N × N, 1..=8 (default 4; 1: the
        /// paper's uniform grid).
        #[arg(long)]
        refine: Option<u32>,
        /// Beams: the bounding volume each beam is drawn with: hull (default: the convex hull
        /// of its corners) or touching-planes (the paper's prism).
        #[arg(long, value_enum)]
        beam_bounds: Option<caustica::render::beams::Bounds>,
        /// Scenes with water: the waves' time in seconds (every method).
        #[arg(long, allow_negative_numbers = true)]
        time: Option<f32>,
        /// Scenes with water: render a sequence of this many frames from --time, written as an
        /// animated PNG (--out X.png) or as numbered PNGs in a folder (--out DIR).
        #[arg(long)]
        frames: Option<u32>,
        /// A sequence's frames per second (default 24).
        #[arg(long)]
        fps: Option<f32>,
    },
    /// Precompute a method's data for a scene.
    Bake {
        #[command(subcommand)]
        what: BakeCmd,
    },
    /// Compare two images (EXR) on the pixels where the camera sees OBJECT, after a 3×3 blur:
    /// relative L1 and flux ratio of A against the reference B.
    Compare {
        a: PathBuf,
        b: PathBuf,
        #[arg(long)]
        scene: PathBuf,
        #[arg(long, default_value = "floor")]
        object: String,
        /// The camera the images were rendered with, when not the scene's (`render --camera`).
        #[arg(long)]
        camera: Option<String>,
    },
    /// Print the OpenAPI document the service serves (YAML, as committed in api/openapi.yaml).
    Openapi,
    /// Run the HTTP service (API v1; see api/openapi.yaml).
    Serve {
        /// Address to listen on [env: CAUSTICA_ADDR] (default 127.0.0.1:8080; port 0 picks a
        /// free one). The bound address is printed on stdout.
        #[arg(long)]
        addr: Option<String>,
        /// Where scenes, job records and artifacts live [env: CAUSTICA_DATA_DIR] (default
        /// ./caustica-data).
        #[arg(long)]
        data_dir: Option<PathBuf>,
        /// API keys, one `NAME SCOPE SHA256` line each [env: CAUSTICA_API_KEYS_FILE; also
        /// CAUSTICA_API_KEYS]: required on any address but loopback (`caustica key new`).
        #[arg(long)]
        api_keys: Option<PathBuf>,
        /// JSON logs (also CAUSTICA_LOG_FORMAT=json). Limits and timeouts come from the
        /// environment (docs/service.md): CAUSTICA_CPU_WORKERS, CAUSTICA_GPU_WORKERS,
        /// CAUSTICA_GPU_JOBS_PER_KEY, CAUSTICA_BAKE_AFTER_S, CAUSTICA_MAX_QUEUED,
        /// CAUSTICA_MAX_QUEUED_BAKES, CAUSTICA_MAX_PHOTONS, CAUSTICA_MAX_SPP,
        /// CAUSTICA_BAKE_TIMEOUT_S, CAUSTICA_RENDER_TIMEOUT_S, CAUSTICA_MAX_IMAGE_SIDE,
        /// CAUSTICA_MAX_TRIANGLES, CAUSTICA_MAX_BODY, CAUSTICA_MAX_JSON_BODY,
        /// CAUSTICA_BODY_TIMEOUT_S, CAUSTICA_HEADER_TIMEOUT_S, CAUSTICA_MAX_CONNECTIONS,
        /// CAUSTICA_MAX_CONNECTIONS_PER_CLIENT, CAUSTICA_MAX_UPLOADS_PER_CLIENT,
        /// CAUSTICA_MAX_STREAMS_PER_CLIENT, CAUSTICA_STREAM_LIFETIME_S,
        /// CAUSTICA_MAX_BODY_BYTES_IN_FLIGHT, CAUSTICA_MAX_JOBS_PER_KEY,
        /// CAUSTICA_MAX_BYTES_PER_KEY, CAUSTICA_REQUESTS_PER_CLIENT, CAUSTICA_RENDER_TTL_S,
        /// CAUSTICA_BAKE_TTL_S, CAUSTICA_IDEMPOTENCY_TTL_S, CAUSTICA_MAX_RENDER_BYTES,
        /// CAUSTICA_JOB_MEMORY, CAUSTICA_SCENE_CACHE_BYTES,
        /// CAUSTICA_RENDER_WAIT_S, CAUSTICA_SHUTDOWN_GRACE_S, CAUSTICA_CORS_ORIGINS.
        #[arg(long)]
        log_json: bool,
        /// The shared job store, `postgres://USER@HOST:PORT/DB` [env: CAUSTICA_DATABASE_URL]:
        /// API and worker processes (`caustica worker`) share it and the data directory
        /// (a shared volume). Default: SQLite in the data directory, this process alone.
        #[arg(long)]
        database: Option<String>,
        /// Run no workers here: `caustica worker` processes run the jobs (needs --database).
        #[arg(long)]
        no_workers: bool,
        /// Keep artifacts in S3-compatible object storage, `s3://BUCKET/PREFIX` [env:
        /// CAUSTICA_ARTIFACTS; endpoint and credentials from AWS_*]; the data directory is
        /// then a local cache. Default: the data directory alone (a shared volume).
        #[arg(long)]
        artifacts: Option<String>,
    },
    /// Run jobs from a shared job store (no HTTP): claims them, keeps their leases, stores
    /// artifacts in the shared data directory. Stops gracefully on SIGTERM (running jobs get
    /// CAUSTICA_SHUTDOWN_GRACE_S, then go back to the queue).
    Worker {
        /// The shared job store, `postgres://…` [env: CAUSTICA_DATABASE_URL].
        #[arg(long)]
        database: Option<String>,
        /// The data directory the API processes use (a shared volume) [env:
        /// CAUSTICA_DATA_DIR] (default ./caustica-data).
        #[arg(long)]
        data_dir: Option<PathBuf>,
        /// Which lanes to take jobs from: `cpu`, `gpu` or `cpu,gpu` (one process per GPU).
        #[arg(long, default_value = "cpu,gpu")]
        lanes: String,
        /// Artifacts in S3-compatible object storage, `s3://BUCKET/PREFIX` [env:
        /// CAUSTICA_ARTIFACTS], as the API processes use.
        #[arg(long)]
        artifacts: Option<String>,
        /// JSON logs (also CAUSTICA_LOG_FORMAT=json).
        #[arg(long)]
        log_json: bool,
    },
    /// API keys for `serve`.
    #[command(subcommand)]
    Key(KeyCmd),
}

#[derive(Subcommand)]
enum KeyCmd {
    /// Makes a key: prints it (give it to the client; it is not stored) and the line for the
    /// key file (`--api-keys`), which holds only its SHA-256.
    New {
        /// The key's name: its jobs and scenes belong to it (letters, digits, -_.@).
        name: String,
        /// An admin key: sees and cancels every job, reads /metrics.
        #[arg(long)]
        admin: bool,
    },
}

#[derive(Subcommand)]
enum BakeCmd {
    /// Caustic spot lights of one object for the scene's (first) directional light.
    Csl {
        scene: PathBuf,
        /// The caustic object (default: the first object with a glass or mirror material).
        #[arg(long)]
        object: Option<String>,
        #[arg(long)]
        out: PathBuf,
        /// `paper` (the paper's settings) or `fast` (coarser, for previews).
        #[arg(long)]
        preset: Option<String>,
        /// Rays per side of the ray grid (default 1280, the paper's).
        #[arg(long)]
        grid: Option<u32>,
        /// Dynamic lighting (Liu et al. 2008 §4): a set for every direction of a subdivided
        /// icosahedron, matched into triples, from which a render interpolates the set for any
        /// directional light.
        #[arg(long)]
        dynamic: bool,
        /// Dynamic: icosahedron subdivisions, 0..=3 (default 2: 162 directions, the paper's).
        #[arg(long, requires = "dynamic")]
        subdivisions: Option<u32>,
        /// Dynamic: rays per side of the grid traced at each tracking step, 16..=1024 (default
        /// 96).
        #[arg(long, requires = "dynamic")]
        track_grid: Option<u32>,
        /// Dynamic: tracking steps along each icosahedron edge, 1..=100 (default 20, the
        /// paper's).
        #[arg(long, requires = "dynamic")]
        steps: Option<u32>,
        /// Dynamic: largest axis distance of a match, in bounding-sphere radii (default 0.5).
        #[arg(long, requires = "dynamic")]
        match_threshold: Option<f32>,
    },
    /// Light transport table (Iwasaki et al. 2005 §4) of one refractive object: per vertex and
    /// sampling direction, where the light finally leaves the object. No light needed: one
    /// table serves every light.
    Transport {
        scene: PathBuf,
        /// The refractive object (default: the first object with a glass material).
        #[arg(long)]
        object: Option<String>,
        #[arg(long)]
        out: PathBuf,
        /// Rings of sampling directions between the pole and the horizon (default 12; the
        /// paper's 8).
        #[arg(long)]
        rings: Option<u32>,
        /// Sampling directions per ring (default 24: 12 × 24 + 1 = 289; the paper's 16, with 8
        /// rings 129).
        #[arg(long)]
        azimuths: Option<u32>,
    },
}

/// Errors are the user's to read: the message and its causes, no backtrace (even with
/// `RUST_BACKTRACE=1`; a panic still prints one).
fn main() -> std::process::ExitCode {
    match run() {
        Ok(()) => std::process::ExitCode::SUCCESS,
        Err(e) => {
            eprintln!("error: {e:#}");
            std::process::ExitCode::FAILURE
        }
    }
}

fn run() -> Result<()> {
    let cli = Cli::parse();
    let json_logs = matches!(
        cli.cmd,
        Cmd::Serve { log_json: true, .. } | Cmd::Worker { log_json: true, .. }
    ) || std::env::var("CAUSTICA_LOG_FORMAT")
        .is_ok_and(|v| v.eq_ignore_ascii_case("json"));
    init_logging(json_logs);
    match cli.cmd {
        Cmd::Openapi => {
            print!("{}", caustica::http::spec::yaml());
            Ok(())
        }
        Cmd::Serve {
            addr,
            data_dir,
            api_keys,
            database,
            no_workers,
            artifacts,
            ..
        } => serve(addr, data_dir, api_keys, database, no_workers, artifacts),
        Cmd::Worker {
            database,
            data_dir,
            lanes,
            artifacts,
            ..
        } => worker(database, data_dir, &lanes, artifacts),
        Cmd::Key(KeyCmd::New { name, admin }) => {
            use caustica::http::auth::{Keys, hash_key, new_key};
            let key = new_key()?;
            let line = format!(
                "{name} {} {}",
                if admin { "admin" } else { "user" },
                hash_key(&key)
            );
            Keys::default()
                .parse(&line, "the name")
                .map_err(anyhow::Error::msg)?;
            println!("key:  {key}");
            println!("line: {line}");
            Ok(())
        }
        Cmd::Render {
            scene,
            method,
            ground,
            check,
            no_check,
            width,
            height,
            camera,
            component,
            out,
            layers,
            exposure,
            repeat,
            tone_map,
            photons,
            spp,
            seed,
            time_budget,
            volume_bounces,
            bake,
            line_points,
            samples,
            sampling,
            no_filter,
            shadows,
            transmit,
            cluster,
            sun_radius,
            water_mode,
            water_variant,
            water_grid,
            sun_samples,
            map_resolution,
            mesh_resolution,
            sun_map_width,
            pixel_samples,
            grid,
            beam_samples,
            no_beam_shadows,
            one_sided,
            no_surface,
            downsample,
            refine,
            beam_bounds,
            time,
            frames,
            fps,
            photons_per_frame,
            error_target,
            footprint,
        } => {
            let progressive_args = caustica::methods::photons::ProgressiveArgs {
                photons_per_frame,
                time_budget_ms: None,
                error_target,
                footprint,
            };
            let progressive = (progressive_args != Default::default()).then(|| {
                serde_json::to_value(progressive_args).expect("progressive arguments serialise")
            });
            let beams_args = caustica::methods::beams::BeamsArgs {
                grid,
                samples: beam_samples,
                shadows: no_beam_shadows.then_some(false),
                two_sided: one_sided.then_some(false),
                surface: no_surface.then_some(false),
                downsample,
                refine,
                bounds: beam_bounds,
            };
            let beams = (beams_args != Default::default())
                .then(|| serde_json::to_value(beams_args).expect("beams arguments serialise"));
            let water_args = caustica::methods::water::WaterArgs {
                mode: water_mode,
                variant: water_variant,
                grid: water_grid,
                sun_samples,
                map_resolution,
                mesh_resolution,
                sun_map_width,
                pixel_samples,
            };
            let water = (water_args != Default::default())
                .then(|| serde_json::to_value(water_args).expect("water arguments serialise"));
            let pinhole_given = samples.is_some()
                || sampling.is_some()
                || no_filter
                || shadows
                || transmit
                || cluster.is_some()
                || sun_radius.is_some();
            let pinhole = pinhole_given.then(|| {
                serde_json::to_value(caustica::methods::pinhole::PinholeArgs {
                    samples,
                    sampling,
                    filter: no_filter.then_some(false),
                    shadows: shadows.then_some(true),
                    transmit: transmit.then_some(true),
                    cluster,
                    sun_radius,
                })
                .expect("pinhole arguments serialise")
            });
            let args = MethodArgs {
                photons,
                spp: Some(spp),
                seed: Some(seed),
                time_budget,
                volume_bounces,
                csl: None,
                line_points: Some(line_points),
                pinhole,
                water,
                beams,
                progressive,
                check: (check || no_check).then_some(check),
                bake,
            };
            let png = PngSettings { exposure, tone_map };
            render(
                &scene,
                method,
                Edits {
                    size: (width, height),
                    camera: camera.as_deref(),
                    ground,
                },
                &args,
                Output {
                    component,
                    out: &out,
                    layers,
                    png,
                },
                Animation {
                    time,
                    frames,
                    fps,
                    repeat,
                },
            )
        }
        Cmd::Bake { what } => {
            let (method, scene, object, out, params) = match what {
                BakeCmd::Csl {
                    scene,
                    object,
                    out,
                    preset,
                    grid,
                    dynamic,
                    subdivisions,
                    track_grid,
                    steps,
                    match_threshold,
                } => {
                    let mut p = serde_json::json!({});
                    let mut set = |k: &str, v: serde_json::Value| {
                        if !v.is_null() {
                            p[k] = v;
                        }
                    };
                    set("preset", preset.into());
                    set("grid", grid.into());
                    if dynamic {
                        set("dynamic", true.into());
                    }
                    set("subdivisions", subdivisions.into());
                    set("track_grid", track_grid.into());
                    set("steps", steps.into());
                    set("match_threshold", match_threshold.into());
                    (Method::Csl, scene, object, out, p)
                }
                BakeCmd::Transport {
                    scene,
                    object,
                    out,
                    rings,
                    azimuths,
                } => {
                    let mut p = serde_json::json!({});
                    if let Some(r) = rings {
                        p["rings"] = r.into();
                    }
                    if let Some(a) = azimuths {
                        p["azimuths"] = a.into();
                    }
                    (Method::Transport, scene, object, out, p)
                }
            };
            bake(method, &scene, object.as_deref(), &params, &out)
        }
        Cmd::Compare {
            a,
            b,
            scene,
            object,
            camera,
        } => {
            let mut world = load(&scene)?;
            if let Some(c) = parse_camera(camera.as_deref())? {
                world.camera = scene::load::resolve_camera(&c, &scene::Limits::default())
                    .map_err(|e| anyhow::anyhow!("--camera: {e}"))?;
            }
            let read = |p: &Path| -> Result<Frame> {
                let bytes = std::fs::read(p).with_context(|| p.display().to_string())?;
                // OpenEXR's magic number: only linear radiance compares meaningfully (a PNG
                // is exposed, tone-mapped and quantised).
                if !bytes.starts_with(&[0x76, 0x2f, 0x31, 0x01]) {
                    bail!(
                        "{}: not an OpenEXR image; compare needs linear radiance (render with \
                         --out NAME.exr)",
                        p.display()
                    );
                }
                encode::decode_frame(&bytes).map_err(|e| anyhow::anyhow!("{}: {e}", p.display()))
            };
            let (fa, fb) = (read(&a)?, read(&b)?);
            let c = compare::compare_on(world, &object, &fa, &fb);
            println!(
                "relative L1 {:.4}  flux ratio {:.4}  over {} pixels of '{object}'",
                c.rel_l1, c.flux_ratio, c.pixels
            );
            Ok(())
        }
    }
}

/// Where and how `caustica render` writes.
struct Output<'a> {
    component: Component,
    out: &'a Path,
    layers: bool,
    png: PngSettings,
}

/// `--time`, `--frames`, `--fps`.
struct Animation {
    time: Option<f32>,
    frames: Option<u32>,
    fps: Option<f32>,
    /// `--repeat`: frames rendered in all to time one (not with `frames`).
    repeat: Option<u32>,
}

/// `--width`, `--height`, `--camera`, `--ground`: what a render changes of its scene.
struct Edits<'a> {
    size: (Option<u32>, Option<u32>),
    camera: Option<&'a str>,
    ground: bool,
}

/// `caustica render`: the method's frames for the scene, the chosen component (and with
/// `layers` every component) written to `out`; with `--frames`, a sequence.
fn render(
    scene: &Path,
    method: Method,
    edits: Edits,
    args: &MethodArgs,
    o: Output,
    anim: Animation,
) -> Result<()> {
    let Output {
        component,
        out,
        layers,
        png,
    } = o;
    let sequence_dir = anim.frames.is_some() && ext(out).is_none();
    let is_exr = match ext(out).as_deref() {
        Some("exr") => true,
        Some("png") => false,
        None if sequence_dir => false,
        _ => bail!("--out must end in .png or .exr: {}", out.display()),
    };
    // A sequence's folder is made when its frames come; the folder it lies in must take it.
    check_writable(out)?;
    let mut timings: Vec<(String, Duration)> = Vec::new();
    let t = Instant::now();
    let mut world = load(scene)?;
    let params_error = |e: caustica::jobs::JobError| match e {
        caustica::jobs::JobError::Params(p) => flag_error(&p),
        e => anyhow::anyhow!("{e}"),
    };
    let camera = parse_camera(edits.camera)?;
    caustica::jobs::render::apply_overrides(
        &mut world,
        camera.as_ref(),
        edits.size,
        None,
        anim.time,
        edits.ground,
        &scene::Limits::default(),
    )
    .map_err(params_error)?;
    let t0 = world.water.first().map_or(0.0, |w| w.surface.time());
    let times = caustica::jobs::render::sequence_times(&world, anim.frames, anim.fps, t0)
        .map_err(|e| flag_error(&e))?;
    if times.is_some() && is_exr {
        bail!("--frames: a sequence is written as an animated PNG (--out X.png) or a folder");
    }
    if times.is_some() && anim.repeat.is_some() {
        bail!("--repeat times one frame; it cannot be given with --frames");
    }
    timings.push(("load".into(), t.elapsed()));
    let plan = method
        .imp()
        .plan(&world, args)
        .map_err(|e| flag_error(&e))?;
    if let Some(why) = plan.reason() {
        eprintln!("method {} ({why})", plan.method());
    }
    let gpu = LocalGpu::default();
    if plan.method().info().gpu {
        let t = Instant::now();
        gpu.init()?;
        timings.push(("gpu init".into(), t.elapsed()));
    }
    let store = ArtifactStore::from_env();
    if let Some(times) = times {
        let t = Instant::now();
        if sequence_dir {
            std::fs::create_dir_all(out).with_context(|| out.display().to_string())?;
        }
        // A folder gets each frame as it is made; an animation keeps 8-bit frames to the end.
        let mut images = Vec::new();
        with_bar(plan.method().name(), |progress| {
            caustica::methods::sequence(
                plan.as_ref(),
                &world,
                &Env {
                    progress,
                    keep_going: &|| true,
                    gpu: &gpu,
                    store: &store,
                },
                &times,
                &mut |i, f| {
                    let frame = f.get(component);
                    if sequence_dir {
                        write_frame(&out.join(format!("{i:04}.png")), frame, png)
                            .map_err(|e| MethodError::Render(format!("{e:#}")))?;
                    } else {
                        images.push(encode::srgb8(frame, png));
                    }
                    Ok(())
                },
            )
        })?;
        let per_frame = t.elapsed().as_secs_f64() * 1e3 / times.len() as f64;
        if !sequence_dir {
            let size = (world.camera.width, world.camera.height);
            let bytes = encode::encode_apng(&images, size, anim.fps.unwrap_or(24.0))?;
            std::fs::write(out, bytes).with_context(|| format!("writing {}", out.display()))?;
        }
        eprintln!(
            "wrote {} ({} frames, {per_frame:.1} ms a frame)",
            out.display(),
            times.len()
        );
        return Ok(());
    }
    let frames = with_bar(plan.method().name(), |progress| {
        caustica::methods::render(
            plan.as_ref(),
            &world,
            &Env {
                progress,
                keep_going: &|| true,
                gpu: &gpu,
                store: &store,
            },
            args.check,
        )
    })?;
    for n in &frames.notes {
        eprintln!("{n}");
    }
    timings.extend(frames.timings.iter().cloned());
    let frames = match anim.repeat {
        Some(n) if n > 1 => {
            let mut runs = Vec::new();
            let mut last = frames;
            for _ in 1..n {
                let t = Instant::now();
                last = plan.frames(
                    &world,
                    &Env {
                        progress: &|_, _| {},
                        keep_going: &|| true,
                        gpu: &gpu,
                        store: &store,
                    },
                )?;
                let mut stages = last.timings.clone();
                stages.push(("frame".into(), t.elapsed()));
                runs.push(stages);
            }
            print_medians(plan.method().name(), &last.adapter, &world, &runs);
            last
        }
        _ => frames,
    };
    let t = Instant::now();
    if layers && is_exr {
        std::fs::write(
            out,
            encode::encode_exr_layers(&frames.named_first(component))?,
        )
        .with_context(|| format!("writing {}", out.display()))?;
    } else {
        write_frame(out, frames.get(component), png)?;
        if layers {
            for (c, f) in &frames.layers {
                write_frame(&layer_path(out, c.name()), f, png)?;
            }
        }
    }
    timings.push(("encode".into(), t.elapsed()));
    eprintln!("wrote {}", out.display());
    for (stage, d) in &timings {
        eprintln!("  {stage:<12} {:>10.1} ms", d.as_secs_f64() * 1e3);
    }
    Ok(())
}

/// The `--camera` flag's JSON.
fn parse_camera(camera: Option<&str>) -> Result<Option<scene::types::CameraDesc>> {
    camera
        .map(|c| {
            let mut d = serde_json::Deserializer::from_str(c);
            serde_path_to_error::deserialize(&mut d)
                .map_err(|e| anyhow::anyhow!("--camera: {} at {}", e.inner(), e.path()))
        })
        .transpose()
}

/// `caustica bake`: the method's bake of `object` (default: the method's first object of the
/// scene) with `params` as the API takes them, written to `out`.
fn bake(
    method: Method,
    scene: &Path,
    object: Option<&str>,
    params: &serde_json::Value,
    out: &Path,
) -> Result<()> {
    check_writable(out)?;
    let world = std::sync::Arc::new(load(scene)?);
    let imp = method.imp();
    let params = imp
        .bake_params(params, "params")
        .map_err(|e| flag_error(&e))?;
    let plan = imp
        .plan_bake(BakeRequest {
            world,
            object,
            params: &params,
            limits: &scene::Limits::default(),
        })
        .map_err(cli_error)?;
    let store = ArtifactStore::from_env();
    let label = format!("bake {method} {}", plan.object());
    let baked = with_bar(&label, |progress| {
        plan.run(&Env {
            progress,
            keep_going: &|| true,
            gpu: &LocalGpu::default(),
            store: &store,
        })
    })?;
    std::fs::write(out, &baked.bytes).with_context(|| format!("writing {}", out.display()))?;
    for n in &baked.notes {
        eprintln!("{n}");
    }
    eprintln!("wrote {}", out.display());
    Ok(())
}

/// A parameter error in the words of the command line: a field the CLI sets from a flag is
/// named by the flag (`params.grid` → `--grid`); others (`scene.lights`) as they are.
fn flag_error(e: &ParamError) -> anyhow::Error {
    let field = e.field.strip_prefix("params.").unwrap_or(&e.field);
    if field.contains('.') || matches!(field, "params" | "body" | "method") {
        anyhow::anyhow!("{e}")
    } else {
        anyhow::anyhow!("--{}: {}", field.replace('_', "-"), e.message)
    }
}

fn cli_error(e: MethodError) -> anyhow::Error {
    match e {
        MethodError::Params(p) => flag_error(&p),
        e => anyhow::anyhow!("{e}"),
    }
}

/// `render --repeat`: each stage's median over `runs` (stages in the order of the first run;
/// `frame` is the whole frame's wall time), one line each, after a line naming the method, the
/// size, the adapter and the count. `benches/gpu.sh` reads these lines.
fn print_medians(method: &str, adapter: &str, world: &World, runs: &[Vec<(String, Duration)>]) {
    println!(
        "repeat method={method} size={}x{} adapter=\"{adapter}\" frames={}",
        world.camera.width,
        world.camera.height,
        runs.len()
    );
    let Some(first) = runs.first() else {
        return;
    };
    for (stage, _) in first {
        let mut ms: Vec<f64> = runs
            .iter()
            .filter_map(|r| r.iter().find(|(n, _)| n == stage))
            .map(|(_, d)| d.as_secs_f64() * 1e3)
            .collect();
        ms.sort_by(f64::total_cmp);
        let median = ms[ms.len() / 2];
        println!("repeat stage={stage} median_ms={median:.3}");
    }
}

/// Runs `f` with a progress bar labelled `label` (stage names appended as they come).
fn with_bar<T>(
    label: &str,
    f: impl FnOnce(&(dyn Fn(f32, &str) + Sync)) -> Result<T, MethodError>,
) -> Result<T> {
    use std::io::IsTerminal;
    if !std::io::stderr().is_terminal() {
        // Logs and CI: a line when the stage changes or every tenth of the way.
        let last = std::sync::Mutex::new((String::new(), -1i32));
        let t = Instant::now();
        let progress = |f: f32, stage: &str| {
            let tenth = (f.clamp(0.0, 1.0) * 10.0).floor() as i32;
            let mut l = last.lock().unwrap_or_else(|e| e.into_inner());
            if l.0 != stage || tenth > l.1 {
                *l = (stage.to_string(), tenth);
                eprintln!(
                    "{label}: {stage} {:.0}% ({:.1} s)",
                    f.clamp(0.0, 1.0) * 100.0,
                    t.elapsed().as_secs_f64()
                );
            }
        };
        return f(&progress).map_err(cli_error);
    }
    let bar = ProgressBar::new(1000);
    bar.set_style(
        ProgressStyle::with_template("{msg} [{bar:40}] {percent}% {elapsed_precise} eta {eta}")
            .expect("valid template"),
    );
    bar.set_message(label.to_string());
    let progress = |f: f32, stage: &str| {
        bar.set_message(format!("{label}: {stage}"));
        bar.set_position((f.clamp(0.0, 1.0) * 1000.0) as u64);
    };
    let r = f(&progress);
    bar.finish_and_clear();
    r.map_err(cli_error)
}

fn load(path: &Path) -> Result<World> {
    let world = scene::load_scene_file(path, &scene::Limits::default())
        .with_context(|| format!("loading scene {}", path.display()))?;
    for w in &world.warnings {
        tracing::warn!("{w}");
    }
    Ok(world)
}

fn ext(p: &Path) -> Option<String> {
    p.extension()
        .and_then(|e| e.to_str())
        .map(str::to_ascii_lowercase)
}

/// Refuses, before any work, an `--out` whose folder does not exist or cannot be written in
/// (a file made and removed there says so), or that names a folder where a file is meant.
fn check_writable(out: &Path) -> Result<()> {
    let dir = match out.parent() {
        Some(d) if !d.as_os_str().is_empty() => d,
        _ => Path::new("."),
    };
    if !dir.is_dir() {
        bail!(
            "--out {}: the folder {} does not exist",
            out.display(),
            dir.display()
        );
    }
    if out.extension().is_some() && out.is_dir() {
        bail!("--out {}: is a folder", out.display());
    }
    let probe = dir.join(format!(".caustica-write-check-{}", std::process::id()));
    std::fs::File::create(&probe)
        .with_context(|| format!("--out {}: cannot write in {}", out.display(), dir.display()))?;
    let _ = std::fs::remove_file(&probe);
    Ok(())
}

fn layer_path(out: &Path, name: &str) -> PathBuf {
    let stem = out.file_stem().and_then(|s| s.to_str()).unwrap_or("out");
    let ext = out.extension().and_then(|s| s.to_str()).unwrap_or("exr");
    out.with_file_name(format!("{stem}.{name}.{ext}"))
}

fn write_frame(out: &Path, f: &Frame, png: PngSettings) -> Result<()> {
    let bytes = match ext(out).as_deref() {
        Some("png") => encode::encode_png(f, png)?,
        Some("exr") => encode::encode_exr(f)?,
        _ => bail!("--out must end in .png or .exr: {}", out.display()),
    };
    std::fs::write(out, bytes).with_context(|| format!("writing {}", out.display()))
}

fn init_logging(json: bool) {
    use tracing_subscriber::EnvFilter;
    let filter = EnvFilter::try_from_env("CAUSTICA_LOG").unwrap_or_else(|_| {
        EnvFilter::new("info,wgpu_hal::gles::egl=off,wgpu_core=warn,naga=warn")
    });
    let b = tracing_subscriber::fmt()
        .with_env_filter(filter)
        .with_writer(std::io::stderr);
    if json {
        b.json().init();
    } else {
        b.init();
    }
}

/// `caustica serve`: flags, then environment, then defaults.
fn serve(
    addr: Option<String>,
    data_dir: Option<PathBuf>,
    api_keys: Option<PathBuf>,
    database: Option<String>,
    no_workers: bool,
    artifacts: Option<String>,
) -> Result<()> {
    use caustica::http::{AppState, HttpConfig};
    use caustica::jobs::JobConfig;
    let env = |k: &str| std::env::var(k).ok().filter(|v| !v.trim().is_empty());
    let database = database.or_else(|| env("CAUSTICA_DATABASE_URL"));
    if no_workers && database.is_none() {
        anyhow::bail!(
            "--no-workers needs a shared job store (--database postgres://…): with the embedded \
             SQLite store no other process can run the jobs"
        );
    }
    let addr = addr
        .or_else(|| env("CAUSTICA_ADDR"))
        .unwrap_or_else(|| "127.0.0.1:8080".into());
    let data_dir = data_dir
        .or_else(|| env("CAUSTICA_DATA_DIR").map(PathBuf::from))
        .unwrap_or_else(|| PathBuf::from("caustica-data"));
    let rt = tokio::runtime::Builder::new_multi_thread()
        .enable_all()
        .build()?;
    rt.block_on(async move {
        let get = |k: &str| std::env::var(k).ok();
        let mut jc = JobConfig::new(&data_dir);
        jc.apply_env(&get).map_err(anyhow::Error::msg)?;
        jc.database = database;
        jc.artifacts = artifacts.or_else(|| env("CAUSTICA_ARTIFACTS"));
        if no_workers {
            jc.lanes = (false, false);
        }
        let mut hc = HttpConfig::default();
        hc.apply_env(&get).map_err(anyhow::Error::msg)?;
        hc.max_connections = caustica::http::server::fit_file_limit(hc.max_connections);
        hc.keys = caustica::http::auth::Keys::from_env(api_keys.as_deref(), &env)
            .map_err(anyhow::Error::msg)?;
        let listener = tokio::net::TcpListener::bind(&addr)
            .await
            .with_context(|| format!("binding {addr}"))?;
        let bound = listener.local_addr()?;
        if hc.keys.is_empty() && !bound.ip().is_loopback() {
            anyhow::bail!(
                "{bound} is not a loopback address: serving there needs API keys (--api-keys \
                 FILE, CAUSTICA_API_KEYS_FILE or CAUSTICA_API_KEYS; `caustica key new NAME` \
                 makes one)"
            );
        }
        let keys = hc.keys.len();
        let state = AppState::start(jc, hc)
            .with_context(|| format!("starting the job system in {}", data_dir.display()))?;
        // Before the line below: a SIGTERM sent as soon as a script has read it is handled.
        let shutdown = shutdown_signal()?;
        // Tests and scripts read this line to find the port.
        println!("caustica listening on http://{bound}");
        use std::io::Write;
        std::io::stdout().flush()?;
        tracing::info!(%bound, data_dir = %data_dir.display(), keys, "serving");
        caustica::http::serve(listener, state, shutdown).await?;
        Ok(())
    })
}

/// `caustica worker`: claims jobs from the shared store until SIGTERM or SIGINT.
fn worker(
    database: Option<String>,
    data_dir: Option<PathBuf>,
    lanes: &str,
    artifacts: Option<String>,
) -> Result<()> {
    use caustica::jobs::{JobConfig, JobSystem};
    let env = |k: &str| std::env::var(k).ok().filter(|v| !v.trim().is_empty());
    let database = database.or_else(|| env("CAUSTICA_DATABASE_URL")).context(
        "a worker needs the shared job store: --database postgres://… or CAUSTICA_DATABASE_URL",
    )?;
    let data_dir = data_dir
        .or_else(|| env("CAUSTICA_DATA_DIR").map(PathBuf::from))
        .unwrap_or_else(|| PathBuf::from("caustica-data"));
    let mut jc = JobConfig::new(&data_dir);
    let get = |k: &str| std::env::var(k).ok();
    jc.apply_env(&get).map_err(anyhow::Error::msg)?;
    jc.database = Some(database);
    jc.artifacts = artifacts.or_else(|| env("CAUSTICA_ARTIFACTS"));
    let mut l = (false, false);
    for lane in lanes.split(',').map(str::trim) {
        match lane {
            "cpu" => l.0 = true,
            "gpu" => l.1 = true,
            other => anyhow::bail!("--lanes: unknown lane {other:?} (cpu, gpu or cpu,gpu)"),
        }
    }
    jc.lanes = l;
    // The server's job grace (CAUSTICA_SHUTDOWN_GRACE_S), read as `serve` reads it.
    let mut hc = caustica::http::HttpConfig::default();
    hc.apply_env(&get).map_err(anyhow::Error::msg)?;
    let grace = hc.shutdown_grace;
    let rt = tokio::runtime::Builder::new_current_thread()
        .enable_all()
        .build()?;
    let shutdown = rt.block_on(async { shutdown_signal() })?;
    let sys = JobSystem::start(jc)
        .with_context(|| format!("starting the worker with {}", data_dir.display()))?;
    // The bakes a csl render queues hold to their key's quota here as in the API (admin keys,
    // known from CAUSTICA_API_KEYS(_FILE), have none).
    let keys = caustica::http::auth::Keys::from_env(None, &env).map_err(anyhow::Error::msg)?;
    sys.set_quota(caustica::http::auth::quota(&keys, hc.max_jobs_per_key));
    // Tests and scripts read this line to know the worker is up.
    println!("caustica worker {} running", sys.worker_id());
    use std::io::Write;
    std::io::stdout().flush()?;
    rt.block_on(shutdown);
    let abandoned = sys.shutdown(grace);
    if abandoned > 0 {
        anyhow::bail!("{abandoned} jobs did not stop; their leases will run out");
    }
    Ok(())
}

/// Resolves on SIGTERM or SIGINT (ctrl-c). The handlers are installed when this is called, not
/// when the future is first polled, so a signal that comes in between is not lost to the
/// default action (which would end the process without the graceful shutdown).
fn shutdown_signal() -> anyhow::Result<impl std::future::Future<Output = ()>> {
    #[cfg(unix)]
    {
        use tokio::signal::unix::{SignalKind, signal};
        let mut term = signal(SignalKind::terminate())?;
        let mut int = signal(SignalKind::interrupt())?;
        Ok(async move {
            tokio::select! {
                _ = int.recv() => tracing::info!("ctrl-c"),
                _ = term.recv() => tracing::info!("SIGTERM"),
            }
        })
    }
    #[cfg(not(unix))]
    Ok(async {
        let _ = tokio::signal::ctrl_c().await;
        tracing::info!("ctrl-c");
    })
}
