//! `caustica`: the command line. Thin: parses arguments and calls the library.

use anyhow::{Context, Result, bail};
use caustica::bake::Progress;
use caustica::bake::csl::cache as csl_cache;
use caustica::bake::csl::dynamic::{
    self, DynamicParams, DynamicProgress, DynamicSet, bake_dynamic,
};
use caustica::bake::csl::{CslParams, CslSet, bake_csl};
use caustica::bake::transport::{TransportParams, TransportTable, bake_transport};
use caustica::encode::{self, Frame, PngSettings, ToneMap};
use caustica::gpu::{GpuConfig, GpuContext};
use caustica::reference::{self, ReferenceParams, compare};
use caustica::render::{CslLayer, RenderOptions, Renderer, TransportLayer};
use caustica::scene::{self, World};
use caustica::trace::Accel;
use clap::{Parser, Subcommand, ValueEnum};
use glam::Vec3;
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

#[derive(Clone, Copy, Debug, ValueEnum, PartialEq)]
enum Method {
    /// GPU direct lighting with shadow maps; glass and mirrors drawn from the environment
    /// (no caustics).
    Direct,
    /// CPU ground truth: photon tracing + camera paths.
    Reference,
    /// Caustic spot lights (Liu et al. 2008): direct lighting and the caustics component (Eqs. 2-4 per
    /// pixel and CSL) on the GPU, from baked CSL sets: a static set for the scene's light, or
    /// the set a dynamic bake interpolates for it (`--bake`).
    Csl,
    /// Light transport tables (Iwasaki et al. 2005): direct lighting on the GPU, the caustics component
    /// from illumination volumes of per-vertex tables, for directional, point, spot and line
    /// lights. Needs a Vulkan (float-blendable) adapter.
    Transport,
}

#[derive(Clone, Copy, Debug, ValueEnum, PartialEq)]
enum Component {
    Total,
    Direct,
    Caustics,
    Specular,
    Indirect,
}

impl Component {
    fn name(self) -> &'static str {
        match self {
            Component::Total => "total",
            Component::Direct => "direct",
            Component::Caustics => "caustics",
            Component::Specular => "specular",
            Component::Indirect => "indirect",
        }
    }
}

#[derive(Subcommand)]
enum Cmd {
    /// Render a scene to PNG or EXR (format from the extension).
    Render {
        scene: PathBuf,
        #[arg(long, value_enum, default_value = "direct")]
        method: Method,
        #[arg(long)]
        width: Option<u32>,
        #[arg(long)]
        height: Option<u32>,
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
        #[arg(long, value_enum, default_value = "clamp")]
        tone_map: ToneMapArg,
        /// Reference: photons (light paths) to trace.
        #[arg(long, default_value_t = 4_000_000)]
        photons: u64,
        /// Reference: camera samples per pixel.
        #[arg(long, default_value_t = 16)]
        spp: u32,
        #[arg(long, default_value_t = 1)]
        seed: u64,
        /// Reference: stop tracing photons after this many seconds.
        #[arg(long)]
        time_budget: Option<f64>,
        /// CSL: a baked CSL set (`caustica bake csl`; a `--dynamic` one gives the set for the
        /// scene's light direction by interpolation) for the scene's caustic object; without
        /// it every caustic object is baked (cached by content hash in CAUSTICA_CACHE or the
        /// temp directory). Transport: a table (`caustica bake transport`) for one glass
        /// object, found by its content hash; every other glass object is baked first.
        #[arg(long)]
        bake: Option<PathBuf>,
        /// Transport: point lights a line light is split into (§5.1).
        #[arg(long, default_value_t = caustica::bake::transport::eval::DEFAULT_LINE_POINTS)]
        line_points: u32,
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
    },
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
        /// JSON logs (also CAUSTICA_LOG_FORMAT=json). Limits and timeouts come from the
        /// environment: CAUSTICA_CPU_WORKERS, CAUSTICA_MAX_QUEUED, CAUSTICA_BAKE_TIMEOUT_S,
        /// CAUSTICA_RENDER_TIMEOUT_S, CAUSTICA_MAX_IMAGE_SIDE, CAUSTICA_MAX_TRIANGLES,
        /// CAUSTICA_MAX_BODY, CAUSTICA_RENDER_WAIT_S, CAUSTICA_SHUTDOWN_GRACE_S.
        #[arg(long)]
        log_json: bool,
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
        /// Rays per side of the ray grid (default 1280, the paper's).
        #[arg(long)]
        grid: Option<u32>,
        /// Dynamic lighting (Liu et al. 2008 §4): a set for every direction of a subdivided
        /// icosahedron, matched into triples, from which a render interpolates the set for any
        /// directional light.
        #[arg(long)]
        dynamic: bool,
        /// Dynamic: icosahedron subdivisions (default 2: 162 directions, the paper's).
        #[arg(long, requires = "dynamic")]
        subdivisions: Option<u32>,
        /// Dynamic: rays per side of the grid traced at each tracking step (default 128).
        #[arg(long, requires = "dynamic")]
        track_grid: Option<u32>,
        /// Dynamic: tracking steps along each icosahedron edge (default 20, the paper's).
        #[arg(long, requires = "dynamic")]
        steps: Option<u32>,
        /// Dynamic: largest axis distance of a match, in bounding-sphere radii (default 0.5).
        #[arg(long, requires = "dynamic")]
        match_threshold: Option<f32>,
    },
    /// Light transport table (Iwasaki et al. 2005 §4) of one refractive object: per vertex and sampling
    /// direction, where the light finally leaves the object. No light needed: one table
    /// serves every light.
    Transport {
        scene: PathBuf,
        /// The refractive object (default: the first object with a glass material).
        #[arg(long)]
        object: Option<String>,
        #[arg(long)]
        out: PathBuf,
        /// Rings of sampling directions between the pole and the horizon (default 8).
        #[arg(long)]
        rings: Option<u32>,
        /// Sampling directions per ring (default 16: 8 × 16 + 1 = 129, the paper's).
        #[arg(long)]
        azimuths: Option<u32>,
    },
}

#[derive(Clone, Copy, Debug, ValueEnum)]
enum ToneMapArg {
    Clamp,
    Aces,
    Reinhard,
}

fn main() -> Result<()> {
    let cli = Cli::parse();
    let json_logs = matches!(cli.cmd, Cmd::Serve { log_json: true, .. })
        || std::env::var("CAUSTICA_LOG_FORMAT").is_ok_and(|v| v.eq_ignore_ascii_case("json"));
    init_logging(json_logs);
    match cli.cmd {
        Cmd::Serve { addr, data_dir, .. } => serve(addr, data_dir),
        Cmd::Render {
            scene,
            method,
            width,
            height,
            component,
            out,
            layers,
            exposure,
            tone_map,
            photons,
            spp,
            seed,
            time_budget,
            bake,
            line_points,
        } => {
            let mut timings: Vec<(String, Duration)> = Vec::new();
            let t = Instant::now();
            let mut world = load(&scene)?;
            if let Some(w) = width {
                world.camera.width = w;
            }
            if let Some(h) = height {
                world.camera.height = h;
            }
            scene::load::resolve_camera(&camera_desc(&world), &scene::Limits::default())
                .context("--width/--height")?;
            timings.push(("load".into(), t.elapsed()));
            if bake.is_some() && !matches!(method, Method::Csl | Method::Transport) {
                bail!("--bake is only for --method csl and --method transport");
            }
            if !(1..=256).contains(&line_points) {
                bail!("--line-points must be in 1..=256");
            }
            let frames: Vec<(&str, Frame)> = match method {
                Method::Reference => {
                    let t = Instant::now();
                    let accel = Accel::build(&world);
                    timings.push(("bvh".into(), t.elapsed()));
                    let params = ReferenceParams {
                        seed,
                        photons,
                        spp,
                        time_budget: time_budget.map(Duration::from_secs_f64),
                        ..Default::default()
                    };
                    let bar = progress_bar("reference");
                    let (c, stats) = reference::render(&world, &accel, &params, &|f| {
                        bar.set_position((f * 1000.0) as u64);
                        true
                    })?;
                    bar.finish_and_clear();
                    timings.extend(stats.stages.iter().cloned());
                    eprintln!(
                        "photons traced: {}, caustic photons stored: {}, camera samples: {}",
                        stats.photons_traced, stats.caustic_photons_stored, stats.camera_samples
                    );
                    ["total", "direct", "caustics", "specular", "indirect"]
                        .into_iter()
                        .map(|n| (n, c.get(n).expect("known component")))
                        .collect()
                }
                Method::Direct | Method::Csl => {
                    let t = Instant::now();
                    let ctx = std::sync::Arc::new(GpuContext::new(&GpuConfig::from_env())?);
                    let mut renderer = Renderer::new(ctx)?;
                    timings.push(("gpu init".into(), t.elapsed()));
                    let layer = if method == Method::Csl {
                        let sets = csl_sets(&world, bake.as_deref(), &mut timings)?;
                        Some(CslLayer::from_sets(&world, &sets))
                    } else {
                        None
                    };
                    let out =
                        renderer.render_csl(&world, &RenderOptions::default(), layer.as_ref())?;
                    eprintln!("adapter: {}", out.adapter);
                    timings.extend(out.timings.iter().cloned());
                    out.components()
                }
                Method::Transport => {
                    let tables = transport_tables(&world, bake.as_deref(), &mut timings)?;
                    let t = Instant::now();
                    let refs: Vec<(usize, &TransportTable)> =
                        tables.iter().map(|(i, t)| (*i, t)).collect();
                    let layer = TransportLayer::build(&world, &refs, line_points)?;
                    timings.push(("volumes".into(), t.elapsed()));
                    eprintln!(
                        "{} illumination volumes ({} of reflected light) from {} lit vertices, \
                         {:.3} W leaving the glass, {:.3} W reflected",
                        layer.stats.volumes,
                        layer.stats.reflection_volumes,
                        layer.stats.lit_vertices,
                        layer.stats.flux.element_sum() / 3.0,
                        layer.stats.reflected_flux.element_sum() / 3.0
                    );
                    let t = Instant::now();
                    let ctx = std::sync::Arc::new(GpuContext::new(&GpuConfig::from_env())?);
                    let mut renderer = Renderer::new(ctx)?;
                    timings.push(("gpu init".into(), t.elapsed()));
                    let out =
                        renderer.render_transport(&world, &RenderOptions::default(), &layer)?;
                    eprintln!("adapter: {}", out.adapter);
                    timings.extend(out.timings.iter().cloned());
                    out.components()
                }
            };
            let main = frames
                .iter()
                .find(|(n, _)| *n == component.name())
                .map(|(_, f)| f.clone())
                .with_context(|| format!("method has no component '{}'", component.name()))?;
            let t = Instant::now();
            let is_exr = out
                .extension()
                .is_some_and(|e| e.eq_ignore_ascii_case("exr"));
            if layers && is_exr {
                let mut list = vec![(component.name(), &main)];
                list.extend(
                    frames
                        .iter()
                        .filter(|(n, _)| *n != component.name())
                        .map(|(n, f)| (*n, f)),
                );
                std::fs::write(&out, encode::encode_exr_layers(&list)?)
                    .with_context(|| format!("writing {}", out.display()))?;
            } else {
                write_frame(&out, &main, exposure, tone_map)?;
                if layers {
                    for (n, f) in &frames {
                        write_frame(&layer_path(&out, n), f, exposure, tone_map)?;
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
        Cmd::Bake {
            what:
                BakeCmd::Csl {
                    scene,
                    object,
                    out,
                    grid,
                    dynamic: true,
                    subdivisions,
                    track_grid,
                    steps,
                    match_threshold,
                },
        } => {
            let world = load(&scene)?;
            let name = csl_object(&world, object.as_deref())?;
            let mut params = DynamicParams::paper();
            params.csl.grid = grid.unwrap_or(params.csl.grid);
            params.subdivisions = subdivisions.unwrap_or(params.subdivisions);
            params.track_grid = track_grid.unwrap_or(params.track_grid);
            params.steps = steps.unwrap_or(params.steps);
            params.match_threshold = match_threshold.unwrap_or(params.match_threshold);
            let bar = progress_bar(&format!("bake csl --dynamic {name}"));
            let set = bake_dynamic(&world, &name, &params, &|p: DynamicProgress| {
                let what = match p.stage {
                    "directions" => format!("directions {}/{}", p.done, p.total),
                    "tracking" => format!("edges tracked {}/{}", p.done, p.total),
                    s => s.to_string(),
                };
                bar.set_message(format!("bake csl --dynamic {name}: {what}"));
                bar.set_position((p.fraction * 1000.0) as u64);
                true
            })?;
            bar.finish_and_clear();
            let bytes = set.to_bytes();
            std::fs::write(&out, &bytes).with_context(|| format!("writing {}", out.display()))?;
            let s = &set.stats;
            eprintln!(
                "{name}: {} directions, {} CSLs ({:.1} per direction), {} edges: {} pairs matched, \
                 {} black partners; {} triples ({:.2} per face, {} matched on all three edges); \
                 {} tracking rays; bakes {:.1} s, tracking {:.1} s, total {:.1} s; {:.1} MB",
                s.directions,
                s.csls,
                s.csls as f64 / s.directions.max(1) as f64,
                s.edges,
                s.matched,
                s.blacks,
                s.triples,
                s.triples as f64 / set.triples.len().max(1) as f64,
                s.consistent_triples,
                s.tracking_rays,
                s.time_bakes.as_secs_f64(),
                s.time_tracking.as_secs_f64(),
                s.time_total.as_secs_f64(),
                bytes.len() as f64 / 1e6,
            );
            eprintln!("wrote {}", out.display());
            Ok(())
        }
        Cmd::Bake {
            what:
                BakeCmd::Csl {
                    scene,
                    object,
                    out,
                    grid,
                    ..
                },
        } => {
            let world = load(&scene)?;
            let (name, light) = csl_target(&world, object.as_deref())?;
            let mut params = CslParams::paper();
            if let Some(g) = grid {
                params.grid = g;
            }
            let set = bake_with_bar(&world, &name, light, &params)?;
            std::fs::write(&out, set.to_bytes())
                .with_context(|| format!("writing {}", out.display()))?;
            print_bake(&name, &set);
            eprintln!("wrote {}", out.display());
            Ok(())
        }
        Cmd::Bake {
            what:
                BakeCmd::Transport {
                    scene,
                    object,
                    out,
                    rings,
                    azimuths,
                },
        } => {
            let world = load(&scene)?;
            let name = match object {
                Some(n) => n,
                None => caustica::bake::transport::refractive_objects(&world)
                    .first()
                    .map(|&i| world.objects[i].name.clone())
                    .context("the scene has no glass object to bake")?,
            };
            let mut params = TransportParams::paper();
            params.rings = rings.unwrap_or(params.rings);
            params.azimuths = azimuths.unwrap_or(params.azimuths);
            let bar = progress_bar(&format!("bake transport {name}"));
            let table = bake_transport(&world, &name, &params, &|p: Progress| {
                bar.set_message(format!("bake transport {name}: {}", p.stage));
                bar.set_position((p.fraction * 1000.0) as u64);
                true
            })?;
            bar.finish_and_clear();
            let bytes = table.to_bytes();
            std::fs::write(&out, &bytes).with_context(|| format!("writing {}", out.display()))?;
            let (s, e) = (&table.stats, &table.errors);
            eprintln!(
                "{name}: {} vertices × {} directions = {} samples ({} self-occluded, {} trapped), \
                 {} rays, trace {:.0} ms, total {:.0} ms",
                s.vertices,
                params.directions(),
                s.samples,
                s.occluded,
                s.trapped,
                s.rays,
                s.time_trace.as_secs_f64() * 1e3,
                s.time_total.as_secs_f64() * 1e3,
            );
            eprintln!(
                "size {:.2} MB ({} bytes a sample; {:.2} MB unquantised, {:.0} %); largest \
                 quantisation errors: position {:.4} % of the box diagonal, direction {:.4} %, \
                 transmittance {:.1e}",
                bytes.len() as f64 / 1e6,
                table.bytes_per_sample(),
                table.uncompressed_bytes() as f64 / 1e6,
                100.0 * bytes.len() as f64 / table.uncompressed_bytes() as f64,
                100.0 * e.position,
                100.0 * e.direction,
                e.transmittance,
            );
            eprintln!("wrote {}", out.display());
            Ok(())
        }
        Cmd::Compare {
            a,
            b,
            scene,
            object,
        } => {
            let world = load(&scene)?;
            let read = |p: &Path| -> Result<Frame> {
                encode::decode_frame(&std::fs::read(p).with_context(|| p.display().to_string())?)
                    .map_err(|e| anyhow::anyhow!("{}: {e}", p.display()))
            };
            let (fa, fb) = (read(&a)?, read(&b)?);
            let mut w = world.clone();
            w.camera.width = fb.width;
            w.camera.height = fb.height;
            let accel = Accel::build(&w);
            let mask = compare::object_mask(&w, &accel, &object);
            let c = compare::compare(&fa, &fb, &mask);
            println!(
                "relative L1 {:.4}  flux ratio {:.4}  over {} pixels of '{object}'",
                c.rel_l1, c.flux_ratio, c.pixels
            );
            Ok(())
        }
    }
}

/// The transport tables of a render: the one in `bake` (for the glass object whose content
/// hash it carries), or a fresh bake of every glass object.
fn transport_tables(
    world: &World,
    bake: Option<&Path>,
    timings: &mut Vec<(String, Duration)>,
) -> Result<Vec<(usize, TransportTable)>> {
    let t = Instant::now();
    let objects = caustica::bake::transport::refractive_objects(world);
    if objects.is_empty() {
        bail!("method transport needs a glass (dielectric) object; the scene has none");
    }
    // A given table serves the glass object it was baked for (found by content hash); every
    // other glass object is baked here, so that all of them cast caustics.
    let mut given = match bake {
        Some(path) => {
            let bytes = std::fs::read(path).with_context(|| path.display().to_string())?;
            let table = TransportTable::from_bytes(&bytes)
                .map_err(|e| anyhow::anyhow!("{}: {e}", path.display()))?;
            let Some(&oi) = objects.iter().find(|&&i| {
                caustica::bake::transport::source_hash(world, &world.objects[i], &table.params)
                    == table.source_hash
            }) else {
                bail!(
                    "{}: the table fits no glass object of this scene (baked for another mesh, \
                     material or scale)",
                    path.display()
                );
            };
            Some((oi, table))
        }
        None => None,
    };
    let mut out = Vec::new();
    for oi in objects {
        if given.as_ref().is_some_and(|g| g.0 == oi) {
            out.extend(given.take());
            continue;
        }
        let name = world.objects[oi].name.clone();
        let bar = progress_bar(&format!("bake transport {name}"));
        let table = bake_transport(world, &name, &TransportParams::paper(), &|p| {
            bar.set_message(format!("bake transport {name}: {}", p.stage));
            bar.set_position((p.fraction * 1000.0) as u64);
            true
        })?;
        bar.finish_and_clear();
        out.push((oi, table));
    }
    timings.push(("transport bake".into(), t.elapsed()));
    Ok(out)
}

/// The caustic object (named, or the first glass/mirror object) and the scene's first
/// directional light as (world travel direction, irradiance).
fn csl_target(world: &World, object: Option<&str>) -> Result<(String, (Vec3, Vec3))> {
    let light = caustica::bake::csl::scene_directional_light(world)
        .context("CSLs need a directional light; the scene has none")?;
    Ok((csl_object(world, object)?, light))
}

/// The caustic object: named, or the first glass/mirror object.
fn csl_object(world: &World, object: Option<&str>) -> Result<String> {
    let name = match object {
        Some(n) => n.to_string(),
        None => world
            .objects
            .iter()
            .find(|o| {
                o.parts
                    .iter()
                    .any(|p| world.materials[p.material as usize].is_specular())
            })
            .map(|o| o.name.clone())
            .context("the scene has no glass or mirror object to bake")?,
    };
    Ok(name)
}

fn bake_with_bar(
    world: &World,
    name: &str,
    (dir, _): (Vec3, Vec3),
    params: &CslParams,
) -> Result<CslSet> {
    let obj = world
        .object(name)
        .with_context(|| format!("no object named {name:?}"))?;
    let light = CslSet::light_in_object_frame(obj, dir);
    let bar = progress_bar(&format!("bake csl {name}"));
    let set = bake_csl(world, name, light, params, &|p: Progress| {
        bar.set_message(format!("bake csl {name}: {}", p.stage));
        bar.set_position((p.fraction * 1000.0) as u64);
        true
    })?;
    bar.finish_and_clear();
    Ok(set)
}

fn print_bake(name: &str, set: &CslSet) {
    let s = &set.stats;
    eprintln!(
        "{name}: {} rays traced, {} hit, {} caustic rays, {} CSLs covering {:.1}% of the energy \
         (trace {:.0} ms, raster {:.0} ms, bundles {:.0} ms, fit {:.0} ms, images {:.0} ms, \
         total {:.0} ms)",
        s.rays_traced,
        s.rays_hit,
        s.caustic_rays,
        set.csls.len(),
        100.0 * s.coverage(),
        s.time_trace.as_secs_f64() * 1e3,
        s.time_raster.as_secs_f64() * 1e3,
        s.time_bundles.as_secs_f64() * 1e3,
        s.time_fit.as_secs_f64() * 1e3,
        s.time_image.as_secs_f64() * 1e3,
        s.time_total.as_secs_f64() * 1e3,
    );
}

/// The CSL sets of the render: the given artifact for the scene's caustic object, or the set of
/// every caustic object from the bake cache (`$CAUSTICA_CACHE`, else a folder under the
/// system's temporary directory), baking what is missing.
fn csl_sets(
    world: &World,
    bake: Option<&Path>,
    timings: &mut Vec<(String, Duration)>,
) -> Result<csl_cache::RenderSets> {
    let t = Instant::now();
    let sets = if let Some(path) = bake {
        let (first, light) = csl_target(world, None)?;
        let bytes = std::fs::read(path).with_context(|| format!("reading {}", path.display()))?;
        let object = world
            .objects
            .iter()
            .position(|o| o.name == first)
            .context("caustic object")?;
        let set = if bytes.starts_with(&dynamic::MAGIC) {
            // A dynamic bake: the set for this light direction, interpolated (§4.1).
            let dynset =
                DynamicSet::from_bytes(&bytes).with_context(|| path.display().to_string())?;
            let o = &world.objects[object];
            if !dynset.is_for(world, o) {
                bail!(
                    "{} is a dynamic bake of another object than {first:?} (meshes, materials \
                     or scale differ)",
                    path.display()
                );
            }
            timings.push(("csl load".into(), t.elapsed()));
            let t = Instant::now();
            let set = dynset.interpolate(CslSet::light_in_object_frame(o, light.0));
            timings.push(("csl interpolate".into(), t.elapsed()));
            set
        } else {
            let set = CslSet::from_bytes(&bytes).with_context(|| path.display().to_string())?;
            timings.push(("csl load".into(), t.elapsed()));
            set
        };
        csl_cache::RenderSets {
            sets: vec![csl_cache::ObjectSet {
                object,
                set,
                cached: true,
            }],
            light,
        }
    } else {
        let dir = std::env::var_os("CAUSTICA_CACHE")
            .map(PathBuf::from)
            .unwrap_or_else(|| std::env::temp_dir().join("caustica-bakes"));
        let store = csl_cache::DirStore(dir);
        let bar = progress_bar("bake csl");
        let r = csl_cache::sets_for_render(world, &CslParams::paper(), &store, &|name, p| {
            bar.set_message(format!("bake csl {name}: {}", p.stage));
            bar.set_position((p.fraction * 1000.0) as u64);
            true
        });
        bar.finish_and_clear();
        let r = r?;
        for s in &r.sets {
            let name = &world.objects[s.object].name;
            if s.cached {
                eprintln!(
                    "{name}: cached bake {}",
                    store.path(s.set.source_hash).display()
                );
            } else {
                print_bake(name, &s.set);
            }
        }
        timings.push(("csl bake".into(), t.elapsed()));
        r
    };
    Ok(sets)
}

fn camera_desc(w: &World) -> scene::types::CameraDesc {
    let c = &w.camera;
    scene::types::CameraDesc {
        eye: c.eye.to_array(),
        target: c.target.to_array(),
        up: c.up.to_array(),
        fov_y: c.fov_y,
        width: c.width,
        height: c.height,
    }
}

fn load(path: &Path) -> Result<World> {
    let world = scene::load_scene_file(path, &scene::Limits::default())
        .with_context(|| format!("loading scene {}", path.display()))?;
    for w in &world.warnings {
        tracing::warn!("{w}");
    }
    Ok(world)
}

fn layer_path(out: &Path, name: &str) -> PathBuf {
    let stem = out.file_stem().and_then(|s| s.to_str()).unwrap_or("out");
    let ext = out.extension().and_then(|s| s.to_str()).unwrap_or("exr");
    out.with_file_name(format!("{stem}.{name}.{ext}"))
}

fn write_frame(out: &Path, f: &Frame, exposure: f32, tone_map: ToneMapArg) -> Result<()> {
    let ext = out
        .extension()
        .and_then(|e| e.to_str())
        .map(str::to_ascii_lowercase);
    let bytes = match ext.as_deref() {
        Some("png") => encode::encode_png(
            f,
            PngSettings {
                exposure,
                tone_map: match tone_map {
                    ToneMapArg::Clamp => ToneMap::Clamp,
                    ToneMapArg::Aces => ToneMap::Aces,
                    ToneMapArg::Reinhard => ToneMap::Reinhard,
                },
            },
        )?,
        Some("exr") => encode::encode_exr(f)?,
        _ => bail!("--out must end in .png or .exr: {}", out.display()),
    };
    std::fs::write(out, bytes).with_context(|| format!("writing {}", out.display()))
}

fn progress_bar(what: &str) -> ProgressBar {
    let bar = ProgressBar::new(1000);
    bar.set_style(
        ProgressStyle::with_template("{msg} [{bar:40}] {percent}% {elapsed_precise} eta {eta}")
            .expect("valid template"),
    );
    bar.set_message(what.to_string());
    bar
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
fn serve(addr: Option<String>, data_dir: Option<PathBuf>) -> Result<()> {
    use caustica::http::{AppState, HttpConfig};
    use caustica::jobs::JobConfig;
    let env = |k: &str| std::env::var(k).ok().filter(|v| !v.trim().is_empty());
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
        let mut hc = HttpConfig::default();
        hc.apply_env(&get).map_err(anyhow::Error::msg)?;
        let state = AppState::start(jc, hc)
            .with_context(|| format!("starting the job system in {}", data_dir.display()))?;
        let listener = tokio::net::TcpListener::bind(&addr)
            .await
            .with_context(|| format!("binding {addr}"))?;
        let bound = listener.local_addr()?;
        // Tests and scripts read this line to find the port.
        println!("caustica listening on http://{bound}");
        use std::io::Write;
        std::io::stdout().flush()?;
        tracing::info!(%bound, data_dir = %data_dir.display(), "serving");
        caustica::http::serve(listener, state, shutdown_signal()).await?;
        Ok(())
    })
}

async fn shutdown_signal() {
    let ctrl_c = async {
        let _ = tokio::signal::ctrl_c().await;
    };
    #[cfg(unix)]
    let term = async {
        match tokio::signal::unix::signal(tokio::signal::unix::SignalKind::terminate()) {
            Ok(mut s) => {
                s.recv().await;
            }
            Err(_) => std::future::pending::<()>().await,
        }
    };
    #[cfg(not(unix))]
    let term = std::future::pending::<()>();
    tokio::select! {
        _ = ctrl_c => tracing::info!("ctrl-c"),
        _ = term => tracing::info!("SIGTERM"),
    }
}
