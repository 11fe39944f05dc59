//! The methods: one module each, and the one registry every caller uses (the CLI, the job
//! system, the HTTP API).
//!
//! A method is a way of making the frames of a scene: [`direct`] (GPU direct lighting, no
//! caustics), [`reference`](mod@reference) (the CPU ground truth), [`csl`] (caustic spot lights, Liu et al.
//! 2008), [`transport`] (light transport tables, Iwasaki et al. 2005), [`pinhole`] (pinhole
//! caustics, Wand and Straßer 2003), [`water`] (underwater caustics, Sánchez-Crespo 2003),
//! [`beams`] (volumetric caustics with projected light beams, Liktor and Dachsbacher 2010), and
//! [`auto`], which picks one of them from the scene. Each module implements [`MethodImpl`]:
//!
//! - its [`MethodInfo`] (name, lane, whether it needs the GPU, whether it bakes, its fields);
//! - [`MethodImpl::plan`]: parse and check its render parameters against the scene (one parser,
//!   one error for the CLI and the API) into a [`RenderPlan`], whose
//!   [`RenderPlan::frames`] makes every [`Component`] of the frame, finding or baking what it
//!   needs through the [`ArtifactStore`];
//! - for a method with a bake, [`MethodImpl::bake_params`] (the canonical parameters a bake id
//!   is computed from) and [`MethodImpl::plan_bake`] (a [`BakePlan`] that makes the artifact).
//!
//! Adding a method: its module here, its render pass and shader (`render/`), its bake module
//! (`bake/`) if it has one, a variant of [`Method`] and one line in [`Method::imp`].

pub mod auto;
pub mod beams;
pub mod check;
pub mod csl;
pub mod direct;
mod finish;
pub mod fuzz;
pub mod local;
pub mod photons;
pub mod pinhole;
pub mod reference;
pub mod transport;
pub mod water;

pub use crate::bake::store::{ArtifactKind, ArtifactStore};
pub use crate::frame::Component;
pub use finish::{POOR_CHECK, note_check, render, self_check};

use crate::frame::Frame;
use crate::render::{RenderError, RenderOutput, Renderer};
use crate::scene::{Limits, World};
use serde::de::DeserializeOwned;
use serde::{Deserialize, Serialize};
use std::path::PathBuf;
use std::sync::Arc;
use std::time::{Duration, Instant};

/// A method as a request names it.
#[derive(
    Clone,
    Copy,
    Debug,
    PartialEq,
    Eq,
    Hash,
    Serialize,
    Deserialize,
    clap::ValueEnum,
    schemars::JsonSchema,
)]
#[serde(rename_all = "snake_case")]
pub enum Method {
    /// Picks one of the others from the scene (the rule is in `methods::auto`).
    Auto,
    /// GPU direct lighting with shadow maps; glass and mirrors drawn from the environment (no
    /// caustics).
    Direct,
    /// CPU ground truth: photon tracing + camera paths.
    Reference,
    /// Caustic spot lights (Liu et al. 2008): CPU bake, caustics evaluated per pixel on the GPU;
    /// directional lights.
    Csl,
    /// Light transport tables (Iwasaki et al. 2005): CPU bake, illumination volumes drawn on the
    /// GPU; directional, point, spot and line lights. Needs a float-blendable adapter.
    Transport,
    /// Pinhole caustics (Wand and Straßer 2003): no bake, points on the reflectors project the
    /// environment and the lights onto the receivers every frame.
    Pinhole,
    /// Underwater caustics (Sánchez-Crespo 2003): sunlight refracted by a procedural water
    /// surface onto what lies below it; the article's mode or a physical one.
    Water,
    /// Volumetric caustics with projected light beams (Liktor and Dachsbacher 2010): beams
    /// from a grid projected onto the glass and mirrors, intersected per pixel in the scene's
    /// medium; they also give the surface caustics.
    Beams,
    /// Progressive GPU photon tracing with photon differentials: no bake, any glass or mirror
    /// object, every light type; converges to the reference's caustics frame by frame.
    Photons,
}

impl Method {
    /// Every method, in the order of the registry's listings.
    pub const ALL: [Method; 9] = [
        Method::Auto,
        Method::Direct,
        Method::Reference,
        Method::Csl,
        Method::Transport,
        Method::Pinhole,
        Method::Water,
        Method::Beams,
        Method::Photons,
    ];

    /// The registry: the implementation of each method.
    pub fn imp(self) -> &'static dyn MethodImpl {
        match self {
            Method::Auto => &auto::Auto,
            Method::Direct => &direct::Direct,
            Method::Reference => &reference::Reference,
            Method::Csl => &csl::Csl,
            Method::Transport => &transport::Transport,
            Method::Pinhole => &pinhole::Pinhole,
            Method::Water => &water::Water,
            Method::Beams => &beams::Beams,
            Method::Photons => &photons::Photons,
        }
    }

    pub fn info(self) -> &'static MethodInfo {
        self.imp().info()
    }

    pub fn name(self) -> &'static str {
        self.info().name
    }

    /// The method named `s` (field `method` of a request).
    pub fn parse(s: &str) -> Result<Method, ParamError> {
        Method::ALL
            .into_iter()
            .find(|m| m.name() == s)
            .ok_or_else(|| {
                ParamError::new(
                    "method",
                    format!("unknown method '{s}' (available: {})", names(|_| true)),
                )
            })
    }
}

impl std::fmt::Display for Method {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.write_str(self.name())
    }
}

/// The names of the methods `keep` accepts, comma-separated.
fn names(keep: impl Fn(&MethodInfo) -> bool) -> String {
    Method::ALL
        .iter()
        .map(|m| m.info())
        .filter(|i| keep(i))
        .map(|i| i.name)
        .collect::<Vec<_>>()
        .join(", ")
}

/// Where a job's work runs.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Hash, serde::Serialize, serde::Deserialize)]
#[serde(rename_all = "snake_case")]
pub enum Lane {
    /// The CPU pool (bakes, reference renders, a baked method's preparation before it borrows
    /// the GPU for its frame).
    Cpu,
    /// The GPU workers (one device).
    Gpu,
}

/// What the registry knows of a method without running it.
#[derive(Debug)]
pub struct MethodInfo {
    pub method: Method,
    pub name: &'static str,
    /// Where a render of it runs (an `auto` render runs where the chosen method does).
    pub lane: Lane,
    /// Whether its frames need the GPU.
    pub gpu: bool,
    /// Whether it has a bake (`caustica bake`, `POST /v1/bakes`).
    pub bake: bool,
    /// The method-specific render fields it takes (see [`MethodArgs`]); `csl` and `bake` given
    /// to a method that does not take them are refused.
    pub args: &'static [&'static str],
    /// Whether its renders run the self-check ([`check`]) unless asked not to: the baked
    /// methods, whose fit to an object is the least certain. Any method's render runs it when
    /// asked (`check: true`).
    pub check: bool,
}

/// A request's parameter at fault: the field (a path such as `params.grid` or `scene.lights`)
/// and what is wrong with it.
#[derive(Clone, Debug, PartialEq, Eq, thiserror::Error)]
#[error("{field}: {message}")]
pub struct ParamError {
    pub field: String,
    pub message: String,
}

impl ParamError {
    pub fn new(field: impl Into<String>, message: impl Into<String>) -> ParamError {
        ParamError {
            field: field.into(),
            message: message.into(),
        }
    }

    /// `value` out of `lo..=hi` at `field`.
    pub fn range<T: PartialOrd + std::fmt::Display>(
        field: &str,
        value: T,
        lo: T,
        hi: T,
    ) -> Result<(), ParamError> {
        if value >= lo && value <= hi {
            Ok(())
        } else {
            Err(ParamError::new(field, format!("must lie in {lo}..={hi}")))
        }
    }
}

/// Deserialises `v` as `T`, an error naming the field's path under `at` (`at` itself for the
/// whole value; `body` when `at` is empty).
pub fn from_value<T: DeserializeOwned>(v: &serde_json::Value, at: &str) -> Result<T, ParamError> {
    serde_path_to_error::deserialize(v).map_err(|e| {
        let path = e.path().to_string();
        let field = match (path.as_str(), at) {
            (".", "") => "body".to_string(),
            (".", at) => at.to_string(),
            (p, "") => p.to_string(),
            (p, at) => format!("{at}.{p}"),
        };
        ParamError::new(field, e.into_inner().to_string())
    })
}

/// The method-specific render parameters of a request, as the CLI's flags and the API's fields
/// give them (absent: the method's default). Each method checks the ones it takes.
#[derive(Clone, Debug, Default, PartialEq)]
pub struct MethodArgs {
    /// Reference: photons (light paths), 1..=1e9.
    pub photons: Option<u64>,
    /// Reference: camera samples per pixel, 1..=1024.
    pub spp: Option<u32>,
    /// Reference: the random seed.
    pub seed: Option<u64>,
    /// Reference: stop tracing photons after this many seconds (CLI).
    pub time_budget: Option<f64>,
    /// Reference: scatterings in the scene's medium a light path may have, 1..=1000.
    pub volume_bounces: Option<u32>,
    /// CSL: the bake's parameters, as for a `csl` bake.
    pub csl: Option<serde_json::Value>,
    /// Transport, pinhole: point lights a line light is split into, 1..=256 (CLI).
    pub line_points: Option<u32>,
    /// Pinhole: its parameters (`methods::pinhole::PinholeArgs`).
    pub pinhole: Option<serde_json::Value>,
    /// Water: its parameters (`methods::water::WaterArgs`).
    pub water: Option<serde_json::Value>,
    /// Beams: its parameters (`methods::beams::BeamsArgs`).
    pub beams: Option<serde_json::Value>,
    /// Photons: its frames (`methods::photons::ProgressiveArgs`).
    pub progressive: Option<serde_json::Value>,
    /// Any method: run the self-check ([`check`]) or not (None: the method's default).
    pub check: Option<bool>,
    /// CSL, transport: a bake made beforehand (CLI: `--bake FILE`).
    pub bake: Option<PathBuf>,
}

impl MethodArgs {
    /// Checks what holds whatever the method: the ranges of the fields given, and no `csl` or
    /// `bake` for a method that does not take them.
    pub fn check(&self, info: &MethodInfo) -> Result<(), ParamError> {
        if self
            .photons
            .is_some_and(|n| !(1..=1_000_000_000).contains(&n))
        {
            return Err(ParamError::new("photons", "must lie in 1..=1e9"));
        }
        if let Some(n) = self.spp {
            ParamError::range("spp", n, 1, 1024)?;
        }
        if let Some(n) = self.volume_bounces {
            ParamError::range("volume_bounces", n, 1, 1000)?;
        }
        if let Some(t) = self.time_budget
            && !(t.is_finite() && t > 0.0)
        {
            return Err(ParamError::new(
                "time_budget",
                "must be a number of seconds > 0",
            ));
        }
        if let Some(n) = self.line_points {
            ParamError::range("line_points", n, 1, 256)?;
        }
        for (field, given) in [
            ("csl", self.csl.is_some()),
            ("bake", self.bake.is_some()),
            ("pinhole", self.pinhole.is_some()),
            ("water", self.water.is_some()),
            ("beams", self.beams.is_some()),
            ("progressive", self.progressive.is_some()),
        ] {
            if given && !info.args.contains(&field) {
                let takers = names(|i| i.args.contains(&field));
                return Err(ParamError::new(
                    field,
                    format!("only with method {takers}, not {}", info.name),
                ));
            }
        }
        Ok(())
    }
}

/// Why a method could not make its frames or its bake.
#[derive(Debug, thiserror::Error)]
pub enum MethodError {
    /// A parameter (or the scene, for this method) is at fault; the field is named.
    #[error(transparent)]
    Params(#[from] ParamError),
    #[error("no object named '{0}' in the scene")]
    UnknownObject(String),
    /// A bake given to the render (`--bake`) cannot serve it.
    #[error("{0}")]
    GivenBake(String),
    #[error("no usable GPU: {0}")]
    NoGpu(String),
    #[error("render failed: {0}")]
    Render(String),
    /// `keep_going` returned false.
    #[error("canceled")]
    Canceled,
}

impl From<crate::bake::BakeError> for MethodError {
    fn from(e: crate::bake::BakeError) -> Self {
        use crate::bake::BakeError as B;
        let field = match &e {
            B::Canceled => return MethodError::Canceled,
            B::UnknownObject(o) => return MethodError::UnknownObject(o.clone()),
            B::NotSpecular(_) | B::NotRefractive(_) | B::EmptyObject(_) => "object",
            B::InvalidParams(_) => "params",
            B::InvalidLight(_) => "scene.lights",
        };
        MethodError::Params(ParamError::new(field, e.to_string()))
    }
}

impl From<RenderError> for MethodError {
    fn from(e: RenderError) -> Self {
        MethodError::Render(e.to_string())
    }
}

/// Access to the GPU renderer, one frame at a time: the job system's GPU slot, or the CLI's
/// renderer.
pub trait Gpu: Sync {
    /// Runs `f` on the renderer (created on first use), which no one else uses meanwhile.
    fn with_renderer(
        &self,
        f: &mut dyn FnMut(&mut Renderer) -> Result<(), MethodError>,
    ) -> Result<(), MethodError>;
}

/// What a method's work sees of its caller.
pub struct Env<'a> {
    /// Progress 0..1 and the name of the running stage.
    pub progress: &'a (dyn Fn(f32, &str) + Sync),
    /// False once the work should stop (cancelled, timed out, shutting down).
    pub keep_going: &'a (dyn Fn() -> bool + Sync),
    pub gpu: &'a dyn Gpu,
    /// Where bakes are found and kept.
    pub store: &'a ArtifactStore,
}

impl Env<'_> {
    /// `f` on the renderer (see [`Gpu::with_renderer`]).
    pub fn with_renderer<T>(
        &self,
        f: impl FnOnce(&mut Renderer) -> Result<T, MethodError>,
    ) -> Result<T, MethodError> {
        let mut f = Some(f);
        let mut out = None;
        self.gpu.with_renderer(&mut |r| {
            let f = f.take().expect("with_renderer calls f once");
            out = Some(f(r)?);
            Ok(())
        })?;
        Ok(out.expect("with_renderer ran f"))
    }

    /// Renders a frame on the renderer borrowed from a CPU job: the wait for it shows as the
    /// `gpu_lock` stage of `timings`, followed by the frame's own stages.
    pub fn render(
        &self,
        timings: &mut Vec<(String, Duration)>,
        f: impl FnOnce(&mut Renderer) -> Result<RenderOutput, RenderError>,
    ) -> Result<RenderOutput, MethodError> {
        let t = Instant::now();
        let out = self.with_renderer(|r| Ok(f(r)?))?;
        let total = out
            .timings
            .iter()
            .find(|(n, _)| n == "total")
            .map_or(Duration::ZERO, |(_, d)| *d);
        timings.push(("gpu_lock".into(), t.elapsed().saturating_sub(total)));
        timings.extend(out.timings.iter().cloned());
        Ok(out)
    }

    /// Err(Canceled) once the work should stop.
    pub fn check(&self) -> Result<(), MethodError> {
        if (self.keep_going)() {
            Ok(())
        } else {
            Err(MethodError::Canceled)
        }
    }
}

/// Every component of a frame and what making it reported.
#[derive(Clone, Debug)]
pub struct Frames {
    /// One frame per component, in [`Component::ALL`]'s order (a component the method does
    /// not compute is black).
    pub layers: Vec<(Component, Frame)>,
    /// Stage → duration, in order.
    pub timings: Vec<(String, Duration)>,
    /// The adapter the frame was rendered on (`cpu` for the reference).
    pub adapter: String,
    /// Figures of the work (bakes found or made, photons traced...), for the render record.
    pub statistics: Option<serde_json::Value>,
    /// The same in sentences, for the CLI.
    pub notes: Vec<String>,
    /// What the user should know of the frame: why its caustics are black, a self-check over
    /// [`POOR_CHECK`]… (also among `notes`; the render record's `info.warnings`).
    pub warnings: Vec<String>,
    /// The method that made the layers, where it is not the plan's (`auto` falling back to
    /// the reference).
    pub made_by: Option<Method>,
}

impl Frames {
    /// The frames of a GPU render.
    pub fn from_output(out: RenderOutput, timings: Vec<(String, Duration)>) -> Frames {
        Frames {
            notes: vec![format!("adapter: {}", out.adapter)],
            adapter: out.adapter.clone(),
            layers: out.into_components(),
            timings,
            statistics: None,
            warnings: Vec::new(),
            made_by: None,
        }
    }

    /// Adds a warning (to the notes too).
    pub fn warn(&mut self, w: String) {
        tracing::warn!(warning = %w, "render");
        self.notes.push(format!("warning: {w}"));
        self.warnings.push(w);
    }

    /// Sets `statistics[key]` (making the statistics an object where they were none).
    pub fn record(&mut self, key: &str, v: serde_json::Value) {
        let s = self.statistics.get_or_insert_with(|| serde_json::json!({}));
        if let Some(o) = s.as_object_mut() {
            o.insert(key.into(), v);
        }
    }

    pub fn get(&self, c: Component) -> &Frame {
        &self
            .layers
            .iter()
            .find(|(n, _)| *n == c)
            .expect("every component is made")
            .1
    }

    /// Every layer by name, `first` first (a multi-layer EXR's order).
    pub fn named_first(&self, first: Component) -> Vec<(&'static str, &Frame)> {
        let mut v = vec![(first.name(), self.get(first))];
        v.extend(
            self.layers
                .iter()
                .filter(|(c, _)| *c != first)
                .map(|(c, f)| (c.name(), f)),
        );
        v
    }
}

/// What a method has checked and will render.
pub trait RenderPlan: Send + Sync {
    /// The method that renders (for `auto`, the one it chose).
    fn method(&self) -> Method;
    /// Why `auto` chose this method (None when it was asked for by name).
    fn reason(&self) -> Option<&str> {
        None
    }
    /// Makes every component of `world`'s frame: bakes what is missing (or finds it in the
    /// store), then renders.
    fn frames(&self, world: &World, env: &Env) -> Result<Frames, MethodError>;
}

/// JSON, as requests give parameters.
pub type Json = serde_json::Value;

/// A bake asked for: of `object` (None: the method's default object of the scene) of `world`,
/// with canonical `params` (see [`MethodImpl::bake_params`]), within `limits`.
pub struct BakeRequest<'a> {
    pub world: Arc<World>,
    pub object: Option<&'a str>,
    pub params: &'a Json,
    pub limits: &'a Limits,
}

/// A checked bake, ready to run.
pub trait BakePlan: Send + Sync {
    /// The object baked.
    fn object(&self) -> &str;
    /// A generous estimate of the memory the bake holds while it runs, bytes (for the job
    /// memory budget).
    fn memory(&self) -> u64 {
        128 << 20
    }
    fn run(&self, env: &Env) -> Result<Baked, MethodError>;
}

/// A bake's artifact and what making it reported.
#[derive(Clone, Debug)]
pub struct Baked {
    pub bytes: Vec<u8>,
    /// The artifact's file extension and media type.
    pub ext: &'static str,
    pub content_type: &'static str,
    pub timings: Vec<(String, Duration)>,
    /// Statistics, for the bake record.
    pub info: serde_json::Value,
    /// The same in sentences, for the CLI.
    pub notes: Vec<String>,
}

/// A method: see the module documentation.
pub trait MethodImpl: Sync {
    fn info(&self) -> &'static MethodInfo;

    /// Checks `args` (and `world`, where the method needs something of it) and plans the
    /// frames. Cheap: no bake, no GPU.
    fn plan(&self, world: &World, args: &MethodArgs) -> Result<Box<dyn RenderPlan>, ParamError>;

    /// Parses and checks the parameters of a bake, found at field `at` of a request, with the
    /// defaults filled in: the canonical form that names the bake.
    fn bake_params(&self, _v: &Json, _at: &str) -> Result<Json, ParamError> {
        Err(no_bake(self.info()))
    }

    /// Checks a bake (see [`BakeRequest`]) against its scene and limits.
    fn plan_bake(&self, _req: BakeRequest) -> Result<Box<dyn BakePlan>, MethodError> {
        Err(no_bake(self.info()).into())
    }
}

fn no_bake(info: &MethodInfo) -> ParamError {
    ParamError::new(
        "method",
        format!(
            "method {} has no bake (methods with a bake: {})",
            info.name,
            names(|i| i.bake)
        ),
    )
}

/// The frames of `plan` for `world` with its water at each of `times` (a sequence), each handed
/// to `each` as it is made (so that a caller keeps only what it needs of it): the plan is made
/// once, the world changes only by its waves between frames, and a method keeps between them
/// what does not change.
pub fn sequence(
    plan: &dyn RenderPlan,
    world: &World,
    env: &Env,
    times: &[f32],
    each: &mut dyn FnMut(usize, Frames) -> Result<(), MethodError>,
) -> Result<(), MethodError> {
    let n = times.len().max(1) as f32;
    for (i, &t) in times.iter().enumerate() {
        env.check()?;
        let mut w = world.clone();
        crate::scene::water::set_time(&mut w, t);
        let k = i as f32;
        let progress = |f: f32, stage: &str| (env.progress)((k + f) / n, stage);
        let sub = Env {
            progress: &progress,
            keep_going: env.keep_going,
            gpu: env.gpu,
            store: env.store,
        };
        each(i, plan.frames(&w, &sub)?)?;
    }
    Ok(())
}

/// Indices of the objects with a glass or mirror part: the objects that cast caustics.
pub fn caustic_objects(world: &World) -> Vec<usize> {
    world.objects_with(crate::scene::Material::is_specular)
}

/// The object a bake is for: `object` by name, or the first of `candidates` (the method's
/// objects of the scene, `what` in the error when there is none); its index.
pub(crate) fn bake_object(
    world: &World,
    object: Option<&str>,
    candidates: &[usize],
    what: &str,
) -> Result<usize, MethodError> {
    match object {
        Some(name) => world
            .object_index(name)
            .ok_or_else(|| MethodError::UnknownObject(name.into())),
        None => candidates.first().copied().ok_or_else(|| {
            ParamError::new("object", format!("the scene has no {what} to bake")).into()
        }),
    }
}

/// The canonical form of checked bake parameters (what a bake id is computed from).
pub(crate) fn canonical(params: impl Serialize) -> serde_json::Value {
    serde_json::to_value(params).expect("bake parameters serialise")
}

/// The progress callback of a bake inside a render: its fraction mapped into `lo..hi` of the
/// render's progress, reported as stage `stage`; false once the work should stop.
pub(crate) fn scaled_progress<'a>(
    env: &'a Env<'a>,
    lo: f32,
    hi: f32,
    stage: &'a str,
) -> impl Fn(f32) -> bool + Sync + 'a {
    move |f| {
        (env.progress)(lo + (hi - lo) * f.clamp(0.0, 1.0), stage);
        (env.keep_going)()
    }
}

/// Whether a method can render a scene, and why or why not: listed with every stored scene
/// (its `methods`) so a client can offer the methods that fit.
#[derive(Clone, Debug, Serialize, schemars::JsonSchema)]
pub struct MethodFit {
    pub method: Method,
    /// Whether a render of the scene with this method and its default parameters is accepted.
    pub fits: bool,
    /// For `auto`, the method it picks and why; for a method that fits, what it gives this
    /// scene; otherwise the field at fault and why (the render's 422 message).
    pub why: String,
    /// Whether its frames need a GPU adapter (a server without one answers 503 to them).
    pub gpu: bool,
    /// Whether it bakes first (a render without a bake made beforehand makes it then).
    pub bake: bool,
}

/// What each method (in [`Method::ALL`]'s order) makes of `world` with its default parameters.
pub fn fits(world: &World) -> Vec<MethodFit> {
    Method::ALL
        .into_iter()
        .map(|m| {
            let info = m.info();
            let planned = m.imp().plan(world, &MethodArgs::default());
            let why = match (&planned, m) {
                (Err(e), _) => e.to_string(),
                (Ok(_), Method::Auto) => {
                    let c = auto::choose(world);
                    format!(
                        "picks {}: {} (expected error: {})",
                        c.method, c.reason, c.expected
                    )
                }
                (Ok(_), _) => fit_note(m).to_string(),
            };
            MethodFit {
                method: m,
                fits: planned.is_ok(),
                why,
                gpu: info.gpu,
                bake: info.bake,
            }
        })
        .collect()
}

/// What a method that accepts a scene gives it.
fn fit_note(m: Method) -> &'static str {
    match m {
        Method::Auto => "picks one of the others",
        Method::Direct => "direct light and shadows only: no caustics",
        Method::Reference => "the ground truth on the CPU: exact, slow (seconds to minutes)",
        Method::Csl => {
            "caustic spot lights baked for a glass or mirror object under the directional \
             light, then fast frames; close on convex glass like the sphere, far off on \
             complex meshes (the bake's fit check says so)"
        }
        Method::Transport => {
            "light transport tables baked for a glass or mirror object, then any light \
             position; close on the sphere, far off on complex meshes"
        }
        Method::Pinhole => {
            "no bake: points on the mirrors and glass project the environment and the lights \
             every frame (one bounce)"
        }
        Method::Water => "no bake: sunlight refracted by the water surface",
        Method::Beams => {
            "no bake: light beams projected from the glass and mirrors: the surface caustics, \
             and the volumetric ones in a medium"
        }
        Method::Photons => {
            "no bake: progressive GPU photon tracing, close to the reference on any shape"
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// Each canonical scene gets every method's verdict: auto names what it picks, the methods
    /// a scene cannot have say why (the render's own message), and the verdicts agree with
    /// the plans the renders make.
    #[test]
    fn each_scene_lists_the_methods_that_fit_and_why_not_the_others() {
        let dir = std::path::Path::new(env!("CARGO_MANIFEST_DIR")).join("scenes");
        let load =
            |n: &str| crate::scene::load_scene_file(&dir.join(n), &Default::default()).unwrap();
        let verdicts = |n: &str| {
            fits(&load(n))
                .into_iter()
                .map(|f| (f.method, (f.fits, f.why)))
                .collect::<std::collections::HashMap<_, _>>()
        };
        let sphere = verdicts("glass-sphere-directional.json");
        assert_eq!(sphere.len(), Method::ALL.len());
        assert!(
            sphere[&Method::Auto].1.starts_with("picks photons: "),
            "{sphere:?}"
        );
        for m in [
            Method::Direct,
            Method::Reference,
            Method::Csl,
            Method::Photons,
        ] {
            assert!(sphere[&m].0, "{m}: {:?}", sphere[&m]);
        }
        // No water surface: water says so, naming the field at fault.
        assert!(!sphere[&Method::Water].0);
        assert!(sphere[&Method::Water].1.starts_with("scene"), "{sphere:?}");
        // A point light only: csl (directional lights) does not fit, transport does.
        let point = verdicts("glass-sphere-point.json");
        assert!(!point[&Method::Csl].0, "{point:?}");
        assert!(point[&Method::Csl].1.contains("directional"), "{point:?}");
        assert!(point[&Method::Transport].0, "{point:?}");
        // Water seen from under the surface and from above: the water method.
        let under = verdicts("underwater-view.json");
        assert!(
            under[&Method::Auto].1.starts_with("picks water: "),
            "{under:?}"
        );
        let pool = verdicts("pool-noon.json");
        assert!(
            pool[&Method::Auto].1.starts_with("picks water: "),
            "{pool:?}"
        );
        assert!(pool[&Method::Water].0, "{pool:?}");
        for n in [
            "glass-teapot.json",
            "fog-glass-sphere-spot.json",
            "mirror-ring-env.json",
        ] {
            let w = load(n);
            for f in fits(&w) {
                let plan = f.method.imp().plan(&w, &MethodArgs::default());
                assert_eq!(f.fits, plan.is_ok(), "{n} {}: {}", f.method, f.why);
                assert_eq!((f.gpu, f.bake), (f.method.info().gpu, f.method.info().bake));
            }
        }
    }

    #[test]
    fn every_method_is_named_once_and_parses_back() {
        for m in Method::ALL {
            assert_eq!(m.info().method, m, "{m}: registry entry of another method");
            assert_eq!(Method::parse(m.name()), Ok(m));
            // serde and clap spell it the same way.
            assert_eq!(serde_json::to_value(m).unwrap(), m.name());
            let v = <Method as clap::ValueEnum>::to_possible_value(&m).unwrap();
            assert_eq!(v.get_name(), m.name());
        }
        let e = Method::parse("magic").unwrap_err();
        assert_eq!(e.field, "method");
        assert!(
            e.message
                .contains("auto, direct, reference, csl, transport, pinhole"),
            "{e}"
        );
    }

    #[test]
    fn method_fields_are_refused_for_methods_without_them() {
        let args = MethodArgs {
            csl: Some(serde_json::json!({})),
            ..Default::default()
        };
        assert!(args.check(Method::Csl.info()).is_ok());
        let e = args.check(Method::Direct.info()).unwrap_err();
        assert_eq!(e.field, "csl");
        let args = MethodArgs {
            bake: Some("x.ltt".into()),
            ..Default::default()
        };
        assert!(args.check(Method::Transport.info()).is_ok());
        let e = args.check(Method::Reference.info()).unwrap_err();
        assert_eq!(
            (e.field.as_str(), e.message.as_str()),
            ("bake", "only with method csl, transport, not reference")
        );
        let e = MethodArgs {
            photons: Some(0),
            ..Default::default()
        }
        .check(Method::Reference.info())
        .unwrap_err();
        assert_eq!(e.to_string(), "photons: must lie in 1..=1e9");
        let e = Method::Direct
            .imp()
            .bake_params(&serde_json::json!({}), "params")
            .unwrap_err();
        assert_eq!(e.field, "method");
        assert!(e.message.contains("reference, csl, transport"), "{e}");
    }

    #[test]
    fn field_paths_of_parse_errors() {
        #[derive(Debug, Deserialize)]
        #[serde(deny_unknown_fields)]
        #[allow(dead_code)]
        struct P {
            grid: Option<u32>,
        }
        let e = from_value::<P>(&serde_json::json!({"grid": "x"}), "params").unwrap_err();
        assert_eq!(e.field, "params.grid");
        let e = from_value::<P>(&serde_json::json!({"grid": "x"}), "").unwrap_err();
        assert_eq!(e.field, "grid");
        let e = from_value::<P>(&serde_json::json!(3), "").unwrap_err();
        assert_eq!(e.field, "body");
        let e = from_value::<P>(&serde_json::json!({"gird": 1}), "csl").unwrap_err();
        assert_eq!(e.field, "csl.gird");
    }
}
