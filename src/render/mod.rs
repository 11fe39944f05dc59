//! The GPU renderer. [`Renderer::render`] produces one layer per component of the frame, in
//! linear radiance W/(m²·sr), comparable pixel for pixel with the CPU reference:
//!
//! - `direct`: receivers lit by every light, with shadows ([`shadow`], [`direct`]);
//! - `specular`: the specular objects themselves and the visible environment ([`direct`]);
//! - `caustics`: the caustics methods' layer (`None` when none ran); method `csl` evaluates
//!   its caustic spot lights per pixel in compute passes after a G-buffer ([`csl`],
//!   [`Renderer::render_csl`]);
//!   method `transport` draws the illumination volumes of its light transport tables over a
//!   G-buffer of the receivers in a pass after it ([`transport`],
//!   [`Renderer::render_transport`]); method `pinhole` projects the light its reflector points
//!   receive onto the same G-buffer ([`pinhole`], [`Renderer::render_pinhole`]); method
//!   `beams` draws its beams over it and adds the `volume_caustics` and `volume` layers
//!   ([`beams`], [`Renderer::render_beams`]); method `photons` traces photons in a compute
//!   pass and splats them over it, frame after frame, after the frame's other passes
//!   ([`photons`], [`Renderer::render_photons`]).
//!
//! The frame is `direct + specular + caustics + volume + volume_caustics`
//! ([`RenderOutput::total`]). A frame is first a
//! [`FramePlan`] (every check and limit, no device), then passes encoded into one command
//! buffer with their GPU times ([`timestamps`]), the copies of the layers read back at its end.
//! The pipelines are built once per device; the targets and the staging buffers are kept per
//! image size, the scene's buffers and the occluders per scene ([`scene::SceneCache`]), the
//! shadow maps per scene and light views (a frame that moved only the camera draws no shadow
//! pass), a CSL layer's images per [`CslLayer::images_key`]. Each pass module has its shader of
//! the same name in `shaders/`.

pub mod beams;
pub mod blockers;
pub mod csl;
pub mod direct;
pub mod gbuffer;
pub mod lights;
pub mod photons;
pub mod pinhole;
pub mod plan;
mod resources;
pub mod scene;
pub mod shaders;
pub mod shadow;
pub mod sky;
mod staging;
pub mod timestamps;
pub mod transport;
pub mod water;

use resources::{
    STORAGE_BINDING, UNIFORM_BINDING, caustics_pass, caustics_pass_timed, caustics_pass_to,
    cleared_attachment, layout_entry, texture_2d, texture_binding,
};
use staging::{KEEP_STAGING_BYTES, Staging};

pub use csl::CslLayer;
pub use pinhole::PinholeLayer;
pub use plan::{DeviceLimits, FramePlan, SHADOW_BUDGET_BYTES};
pub use transport::TransportLayer;

use crate::frame::Component;
use crate::frame::Frame;
use crate::gpu::{GpuContext, GpuError};
use crate::scene::World;
use glam::Vec3;
use std::sync::Arc;
use std::time::{Duration, Instant};
use wgpu::util::DeviceExt;

/// The caustics method of a frame.
#[derive(Clone, Copy, Debug, Default)]
pub enum Caustics<'a> {
    #[default]
    None,
    Csl(&'a CslLayer),
    Transport(&'a TransportLayer),
    Pinhole(&'a PinholeLayer),
    /// The water passes (method `water`, variants `shader` and `shader_texture`).
    Water(&'a water::gpu::WaterGpuLayer),
    /// The projected light beams (method `beams`).
    Beams(&'a beams::BeamsLayer),
    /// Progressive GPU photon tracing (method `photons`), and whether to go on between its
    /// frames.
    Photons(&'a photons::PhotonsLayer, KeepGoing<'a>),
}

/// Asked between the frames of a progressive render: false stops it (the frames so far are
/// returned).
#[derive(Clone, Copy)]
pub struct KeepGoing<'a>(pub &'a (dyn Fn() -> bool + Sync));

impl std::fmt::Debug for KeepGoing<'_> {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.write_str("KeepGoing")
    }
}

/// Which layers to compute and read back.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct Components {
    pub direct: bool,
    pub specular: bool,
}

impl Components {
    pub const ALL: Components = Components {
        direct: true,
        specular: true,
    };
}

impl Default for Components {
    fn default() -> Self {
        Components::ALL
    }
}

/// Per-render settings.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct RenderOptions {
    /// Image size; `None` keeps the camera's.
    pub width: Option<u32>,
    pub height: Option<u32>,
    pub components: Components,
    /// Side of each shadow map in texels (≥ 2048 recommended; 256..=8192).
    pub shadow_resolution: u32,
}

impl Default for RenderOptions {
    fn default() -> Self {
        RenderOptions {
            width: None,
            height: None,
            components: Components::ALL,
            shadow_resolution: 2048,
        }
    }
}

/// One rendered frame, per component. A layer not asked for is black.
#[derive(Clone, Debug)]
pub struct RenderOutput {
    pub direct: Frame,
    pub specular: Frame,
    /// Added by the caustics methods; `None` when none ran.
    pub caustics: Option<Frame>,
    /// The volumetric caustics (method `beams`); `None` when no pass made them.
    pub volume_caustics: Option<Frame>,
    /// The fog lit directly by the lights (method `beams` in a scene with a medium).
    pub volume: Option<Frame>,
    /// CPU stages ("prepare", "submit", "gpu_wait", "readback", "total") and GPU passes from
    /// timestamp queries ("gpu:shadow_maps", "gpu:direct") when the adapter has them.
    pub timings: Vec<(String, Duration)>,
    /// Adapter the frame was rendered on.
    pub adapter: String,
    /// What method photons' progressive loop did.
    pub photons: Option<photons::gpu::PhotonsRun>,
}

impl RenderOutput {
    /// Every component, in [`Component::ALL`]'s order (`indirect`, which no GPU pass computes,
    /// and the others when no pass made them, are black).
    pub fn components(&self) -> Vec<(Component, Frame)> {
        self.clone().into_components()
    }

    /// [`Self::components`], the layers moved into it instead of copied.
    pub fn into_components(self) -> Vec<(Component, Frame)> {
        let (w, h) = (self.direct.width, self.direct.height);
        let mut total = Some(self.total());
        let mut direct = Some(self.direct);
        let mut specular = Some(self.specular);
        let (mut caustics, mut volume_caustics, mut volume) =
            (self.caustics, self.volume_caustics, self.volume);
        Component::ALL
            .into_iter()
            .map(|c| {
                let f = match c {
                    Component::Total => total.take(),
                    Component::Direct => direct.take(),
                    Component::Caustics => caustics.take(),
                    Component::Specular => specular.take(),
                    Component::VolumeCaustics => volume_caustics.take(),
                    Component::Volume => volume.take(),
                    Component::Indirect => None,
                };
                (c, f.unwrap_or_else(|| Frame::new(w, h)))
            })
            .collect()
    }

    /// direct + specular + caustics + volume + volume_caustics, summed in that order.
    pub fn total(&self) -> Frame {
        let mut t = self.direct.clone();
        t.add_assign(&self.specular);
        for c in [&self.caustics, &self.volume, &self.volume_caustics]
            .into_iter()
            .flatten()
        {
            t.add_assign(c);
        }
        t
    }
}

#[derive(Debug, thiserror::Error)]
pub enum RenderError {
    #[error(transparent)]
    Gpu(#[from] GpuError),
    #[error("invalid render options: {0}")]
    Options(String),
    #[error("over a device limit: {0}")]
    Limit(String),
}

/// Resources tied to one device generation.
struct DeviceCache {
    generation: u64,
    pipelines: direct::DirectPipelines,
    shadow: shadow::ShadowPipeline,
    /// Built on the first transport frame.
    transport: Option<transport::TransportPipelines>,
    /// Built on the first pinhole frame, with the environment pyramid of its map.
    pinhole: Option<pinhole::PinholePipeline>,
    /// Built on the first water frame.
    water: Option<water::gpu::WaterPipeline>,
    /// Built on the first beams frame.
    beams: Option<beams::gpu::BeamsPipeline>,
    /// Built on the first photons frame.
    photons: Option<photons::gpu::PhotonsPipeline>,
    /// Built on the first csl frame; the scratch kept per size and CSL word count.
    csl: Option<csl::pass::CslPipelines>,
    csl_scratch: Option<csl::pass::CslScratch>,
    /// The CSLs' packed intensity images and the [`csl::CslLayer::images_key`] they were
    /// uploaded under (None: the last frame's, uploaded for it alone).
    csl_images: Option<(Option<u64>, wgpu::Buffer)>,
    /// Built on the first frame that needs a G-buffer (transport, pinhole, water, beams,
    /// photons).
    gbuffer_pipeline: Option<gbuffer::GBufferPipeline>,
    /// Kept per image size.
    targets: Option<direct::Targets>,
    staging: Option<Staging>,
    gbuffer: Option<gbuffer::GBuffer>,
    /// Grown as needed.
    atlas: Option<shadow::ShadowAtlas>,
    env: Option<direct::EnvTexture>,
    /// Kept per scene.
    scene: scene::SceneCache,
    occluders: scene::OccluderCache,
}

impl DeviceCache {
    /// The resources kept between frames, made or remade to fit `plan`: the targets of its
    /// size, a shadow map array that holds its layers, the environment texture of its map, the
    /// transport or pinhole pipelines and the G-buffer when it gathers caustics per pixel.
    fn fit(
        &mut self,
        dev: &wgpu::Device,
        queue: &wgpu::Queue,
        plan: &FramePlan,
        transport_list: u64,
    ) {
        let size = (plan.width, plan.height);
        self.pipelines.prepare(dev, plan.direct_variant());
        if self
            .targets
            .as_ref()
            .is_none_or(|t| (t.width, t.height) != size)
        {
            self.targets = Some(direct::Targets::new(dev, size.0, size.1));
        }
        if self
            .staging
            .as_ref()
            .is_none_or(|s| (s.width, s.height) != size)
        {
            drop(self.staging.take());
            self.staging = Some(Staging::new(dev, size.0, size.1));
        }
        let n_layers = plan.lights.layers.len() as u32;
        let n_sky = plan.lights.sky_layers.len() as u32;
        if !self
            .atlas
            .as_ref()
            .is_some_and(|a| a.fits(plan.shadow_resolution, n_layers, n_sky))
        {
            drop(self.atlas.take()); // free the old one first
            self.atlas = Some(shadow::ShadowAtlas::new(
                dev,
                plan.shadow_resolution,
                n_layers,
                n_sky,
            ));
        }
        let env = &plan.lights.env;
        let key = env.map.as_ref().map_or(0, |(m, _)| Arc::as_ptr(m) as usize);
        if self.env.as_ref().is_none_or(|e| e.key != key) {
            let map = env.map.as_ref().map(|(m, _)| m.as_ref());
            self.env = Some(direct::EnvTexture::new(dev, queue, map, key));
        }
        if let Some(l) = plan.transport {
            self.transport
                .get_or_insert_with(|| transport::TransportPipelines::new(dev))
                .fit(
                    dev,
                    size,
                    transport_list,
                    l.volumes.len() as u64,
                    dev.limits().max_storage_buffer_binding_size,
                );
        }
        if let Some(layer) = plan.pinhole {
            self.pinhole
                .get_or_insert_with(|| pinhole::PinholePipeline::new(dev))
                .fit(dev, queue, layer);
        }
        if plan.water.is_some() && self.water.is_none() {
            self.water = Some(water::gpu::WaterPipeline::new(dev));
        }
        if let Some(l) = plan.beams {
            self.beams
                .get_or_insert_with(|| beams::gpu::BeamsPipeline::new(dev))
                .fit(dev, size, l.params.downsample.max(1));
        }
        if plan.photons.is_some() {
            self.photons
                .get_or_insert_with(|| photons::gpu::PhotonsPipeline::new(dev))
                .fit(dev, size);
        }
        if let Some(c) = &plan.csl {
            self.csl
                .get_or_insert_with(|| csl::pass::CslPipelines::new(dev))
                .prepare(dev, plan.glossy);
            let pixels = u64::from(size.0) * u64::from(size.1);
            if !self
                .csl_scratch
                .as_ref()
                .is_some_and(|s| s.fits(pixels, c.csls.len()))
            {
                drop(self.csl_scratch.take());
                self.csl_scratch = Some(csl::pass::CslScratch::new(dev, pixels, c.csls.len()));
            }
            let key = c.images_key();
            if key.is_none() || self.csl_images.as_ref().is_none_or(|(k, _)| *k != key) {
                drop(self.csl_images.take());
                let words = csl::pack_texels(&c.csls);
                let buffer = dev.create_buffer_init(&wgpu::util::BufferInitDescriptor {
                    label: Some("csl images"),
                    contents: bytemuck::cast_slice(&words),
                    usage: wgpu::BufferUsages::STORAGE,
                });
                self.csl_images = Some((key, buffer));
            }
        }
        if plan.needs_gbuffer() {
            if !plan.gbuffer_in_direct && self.gbuffer_pipeline.is_none() {
                self.gbuffer_pipeline = Some(gbuffer::GBufferPipeline::new(dev));
            }
            if self
                .gbuffer
                .as_ref()
                .is_none_or(|g| (g.width, g.height) != size)
            {
                self.gbuffer = Some(gbuffer::GBuffer::new(dev, size.0, size.1));
            }
        }
    }
}

/// The GPU renderer. Not `Sync`: one GPU worker owns it (the context may be shared).
pub struct Renderer {
    ctx: Arc<GpuContext>,
    cache: DeviceCache,
    /// Replaces the adapter's loop budget ([`GpuContext::loop_budget`]) when set.
    loop_budget: Option<u32>,
    /// Entries a pixel of the transport pass's list ([`transport::LIST_ENTRIES_PER_PIXEL`]
    /// unless a test sets it).
    transport_list: u64,
    /// Whether the transport pass culls its volumes' outlines by depth (see
    /// [`Renderer::set_transport_cull`]).
    transport_cull: bool,
    /// Whether the direct pass culls the back faces of closed objects seen from outside (see
    /// [`Renderer::set_back_face_cull`]).
    back_face_cull: bool,
    /// False: the G-buffer in a pass of its own even where the direct pass could write it (a
    /// test checks the two agree).
    gbuffer_in_direct: bool,
}

/// How a frame is drawn: the pinhole pass's clusters a draw, and whether the transport
/// volumes are blended fragment by fragment instead of gathered from per-pixel lists.
#[derive(Clone, Copy, Debug)]
struct Attempt {
    cap: u32,
    transport_blended: bool,
}

/// What a frame reports for [`Renderer::render_with`] to draw it again: the pinhole pass's
/// draws, and the pixels whose list of transport volumes overflowed.
#[derive(Clone, Copy, Debug)]
struct FrameReport {
    pinhole: Option<PinholeDraws>,
    transport_overflow: usize,
}

/// How many clusters of points a pinhole pass drew at a time, and how many pixels report a
/// draw whose loop over them the adapter ended early.
#[derive(Clone, Copy, Debug)]
struct PinholeDraws {
    per_draw: u32,
    cut_pixels: usize,
}

impl Renderer {
    /// Builds the pipelines on the context's device.
    pub fn new(ctx: Arc<GpuContext>) -> Result<Renderer, RenderError> {
        let h = ctx.ensure_device()?;
        let cache = Self::build(&ctx, &h)?;
        Ok(Renderer {
            ctx,
            cache,
            loop_budget: None,
            transport_list: transport::LIST_ENTRIES_PER_PIXEL,
            transport_cull: true,
            back_face_cull: true,
            gbuffer_in_direct: true,
        })
    }

    fn build(ctx: &GpuContext, h: &crate::gpu::DeviceHandle) -> Result<DeviceCache, RenderError> {
        let (pipelines, shadow) = ctx.scoped(&h.device, || {
            (
                direct::DirectPipelines::new(&h.device),
                shadow::ShadowPipeline::new(&h.device),
            )
        })?;
        Ok(DeviceCache {
            generation: h.generation,
            pipelines,
            shadow,
            transport: None,
            pinhole: None,
            water: None,
            beams: None,
            photons: None,
            csl: None,
            csl_scratch: None,
            csl_images: None,
            gbuffer_pipeline: None,
            targets: None,
            staging: None,
            gbuffer: None,
            atlas: None,
            env: None,
            scene: Default::default(),
            occluders: Default::default(),
        })
    }

    pub fn context(&self) -> &Arc<GpuContext> {
        &self.ctx
    }

    /// Renders `world`. A lost device is recreated (and the pipelines rebuilt) before the
    /// frame, and once more if the loss happens during it.
    pub fn render(
        &mut self,
        world: &World,
        opts: &RenderOptions,
    ) -> Result<RenderOutput, RenderError> {
        self.render_csl(world, opts, None)
    }

    /// Renders `world` and, with `csl`, its caustics layer from caustic spot lights evaluated
    /// per pixel (`RenderOutput::caustics` is then `Some`).
    pub fn render_csl(
        &mut self,
        world: &World,
        opts: &RenderOptions,
        csl: Option<&CslLayer>,
    ) -> Result<RenderOutput, RenderError> {
        self.render_with(world, opts, csl.map_or(Caustics::None, Caustics::Csl))
    }

    /// Why this adapter cannot render method `transport` (None when it can): the volume pass
    /// blends into a 32-bit float layer.
    pub fn transport_unsupported(&self) -> Option<String> {
        DeviceLimits::of(&self.ctx, &self.ctx.device()).transport_unsupported()
    }

    /// Renders `world` and its caustics layer from the illumination volumes of `layer`
    /// (`RenderOutput::caustics` is then `Some`).
    pub fn render_transport(
        &mut self,
        world: &World,
        opts: &RenderOptions,
        layer: &TransportLayer,
    ) -> Result<RenderOutput, RenderError> {
        self.render_with(world, opts, Caustics::Transport(layer))
    }

    /// Renders `world` and its caustics layer by pinhole projection from the points of
    /// `layer` (`RenderOutput::caustics` is then `Some`).
    pub fn render_pinhole(
        &mut self,
        world: &World,
        opts: &RenderOptions,
        layer: &PinholeLayer,
    ) -> Result<RenderOutput, RenderError> {
        self.render_with(world, opts, Caustics::Pinhole(layer))
    }

    /// Renders `world` and its caustics layer by the water passes (`RenderOutput::caustics` is
    /// then `Some`; what the camera sees through the waves is added to `specular`).
    pub fn render_water(
        &mut self,
        world: &World,
        opts: &RenderOptions,
        layer: &water::gpu::WaterGpuLayer,
    ) -> Result<RenderOutput, RenderError> {
        self.render_with(world, opts, Caustics::Water(layer))
    }

    /// Renders `world`, its volumetric caustics and, with `layer.params.surface`, its caustics
    /// layer from the beams of `layer` (`RenderOutput::volume_caustics` and `caustics` are
    /// then `Some`), and with a medium the fog the lights light directly (`volume`).
    pub fn render_beams(
        &mut self,
        world: &World,
        opts: &RenderOptions,
        layer: &beams::BeamsLayer,
    ) -> Result<RenderOutput, RenderError> {
        self.render_with(world, opts, Caustics::Beams(layer))
    }

    /// Renders `world` and its caustics layer by progressive photon tracing (`RenderOutput::caustics`
    /// and `photons` are then `Some`).
    pub fn render_photons(
        &mut self,
        world: &World,
        opts: &RenderOptions,
        layer: &photons::PhotonsLayer,
    ) -> Result<RenderOutput, RenderError> {
        self.render_photons_while(world, opts, layer, &|| true)
    }

    /// [`Self::render_photons`], asking `keep_going` before every frame after the first: false
    /// stops the progression (`PhotonsRun::stopped_by` is then "canceled").
    pub fn render_photons_while(
        &mut self,
        world: &World,
        opts: &RenderOptions,
        layer: &photons::PhotonsLayer,
        keep_going: &(dyn Fn() -> bool + Sync),
    ) -> Result<RenderOutput, RenderError> {
        self.render_with(world, opts, Caustics::Photons(layer, KeepGoing(keep_going)))
    }

    /// Replaces the loop iterations one shader invocation is taken to be allowed
    /// ([`GpuContext::loop_budget`]; `None`: the adapter's). Tests use it to make llvmpipe end
    /// a pinhole pass's loops early and check that the frame is redrawn.
    pub fn set_loop_budget(&mut self, budget: Option<u32>) {
        self.loop_budget = budget;
    }

    /// Replaces the entries a pixel the transport pass's list holds (`None`:
    /// [`transport::LIST_ENTRIES_PER_PIXEL`]). Tests make it overflow with 0 to check the
    /// frame drawn again by blending.
    pub fn set_transport_list(&mut self, per_pixel: Option<u64>) {
        self.transport_list = per_pixel.unwrap_or(transport::LIST_ENTRIES_PER_PIXEL);
    }

    /// With false, the transport pass draws its volumes without the culling depth (every pixel
    /// of their outlines runs the select or blend shader), as before the cull; tests check
    /// that the cull drops no light.
    pub fn set_transport_cull(&mut self, cull: bool) {
        self.transport_cull = cull;
    }

    /// With false, the direct pass draws every object's back faces, as before the cull of the
    /// closed objects' (hidden behind their front faces when seen from outside); tests check
    /// that the cull changes no pixel.
    pub fn set_back_face_cull(&mut self, cull: bool) {
        self.back_face_cull = cull;
    }

    /// With false, frames draw the G-buffer in a pass of its own, as on an adapter whose render
    /// passes cannot take it beside the direct pass's layers (true: where they can, the direct
    /// pass writes it). Tests compare the two.
    pub fn set_gbuffer_in_direct(&mut self, allowed: bool) {
        self.gbuffer_in_direct = allowed;
    }

    /// Renders `world` with the caustics method `caustics`. A pinhole frame in which the
    /// adapter ended the loop over points early (llvmpipe's cap on loop iterations, when a
    /// draw's estimate of its iterations falls short) is drawn again with a quarter of the
    /// clusters of points a draw, down to one.
    pub fn render_with(
        &mut self,
        world: &World,
        opts: &RenderOptions,
        caustics: Caustics,
    ) -> Result<RenderOutput, RenderError> {
        let mut attempt = Attempt {
            cap: u32::MAX,
            transport_blended: false,
        };
        loop {
            let (out, report) = self.render_on_a_live_device(world, opts, caustics, attempt)?;
            match report.pinhole {
                Some(d) if d.cut_pixels > 0 && d.per_draw > 1 => {
                    tracing::warn!(
                        pixels = d.cut_pixels,
                        clusters_per_draw = d.per_draw,
                        "the adapter ended the pinhole pass's loop over points early; \
                         drawing again with fewer clusters a draw"
                    );
                    attempt.cap = (d.per_draw / 4).max(1);
                }
                Some(d) if d.cut_pixels > 0 => {
                    return Err(RenderError::Limit(format!(
                        "the adapter ends the pinhole pass's loops early in {} pixels even with \
                         one cluster of points a draw (llvmpipe's cap of {} loop iterations per \
                         invocation); render with smaller clusters, without shadows, or on \
                         another adapter",
                        d.cut_pixels,
                        crate::gpu::LLVMPIPE_LOOP_ITERATIONS
                    )));
                }
                _ if report.transport_overflow > 0 && !attempt.transport_blended => {
                    tracing::info!(
                        entries_per_pixel = transport::LIST_ENTRIES_PER_PIXEL,
                        "more (pixel, illumination volume) pairs than the list holds; drawing \
                         the volumes again, every fragment evaluated and blended"
                    );
                    attempt.transport_blended = true;
                }
                _ => return Ok(out),
            }
        }
    }

    fn render_on_a_live_device(
        &mut self,
        world: &World,
        opts: &RenderOptions,
        caustics: Caustics,
        attempt: Attempt,
    ) -> Result<(RenderOutput, FrameReport), RenderError> {
        let r = match self.render_once(world, opts, caustics, attempt) {
            Err(RenderError::Gpu(e)) if matches!(e, GpuError::Lost(_)) || self.ctx.is_lost() => {
                tracing::warn!(error = %e, "render failed on a lost device; retrying on a new one");
                self.ctx.mark_lost();
                self.render_once(world, opts, caustics, attempt)
            }
            r => r,
        };
        if r.is_err() {
            // The shadow pass may have been encoded and never run: draw it next frame.
            if let Some(a) = &mut self.cache.atlas {
                a.invalidate();
            }
        }
        r
    }

    fn render_once(
        &mut self,
        world: &World,
        opts: &RenderOptions,
        caustics: Caustics,
        attempt: Attempt,
    ) -> Result<(RenderOutput, FrameReport), RenderError> {
        let cap = attempt.cap;
        let t0 = Instant::now();
        let mut timings = Vec::new();
        let h = self.ctx.ensure_device()?;
        if h.generation != self.cache.generation {
            self.cache = Self::build(&self.ctx, &h)?;
        }
        let mut plan = FramePlan::new(
            world,
            opts,
            caustics,
            &DeviceLimits::of(&self.ctx, &h.device),
        )?;
        plan.gbuffer_in_direct &= self.gbuffer_in_direct;
        let (width, height) = (plan.width, plan.height);
        let csl_params = csl::pack_params(plan.csl.as_ref().map_or(&[], |c| &c.csls[..]));

        // Prepare: the resources kept between frames, then this frame's buffers.
        let dev = &h.device;
        let (transport_list, transport_cull) = (self.transport_list, self.transport_cull);
        let c = &mut self.cache;
        let mut ts = self.ctx.scoped(dev, || {
            c.fit(dev, &h.queue, &plan, transport_list);
            // Shadow maps, direct, transport, pinhole or water (with the water's light map).
            timestamps::Timestamps::new(&self.ctx, dev, 8)
        })?;
        let loop_budget = self.loop_budget.unwrap_or_else(|| self.ctx.loop_budget());
        let (frame, volumes, pinhole_buffers, water_buffers, beams_buffers, generation) =
            self.ctx.scoped(dev, || {
                let (_, generation) = c.scene.prepare(dev, &h.queue, world, plan.transport);
                (
                    direct::FrameBuffers::upload(dev, &plan.globals, &plan.lights, &csl_params),
                    plan.transport
                        .map(|l| transport::upload_volumes(dev, &l.volumes)),
                    plan.pinhole.zip(c.pinhole.as_ref()).map(|(l, p)| {
                        let env = p.env.as_ref().expect("fitted");
                        pinhole::PinholeBuffers::upload(dev, l, env, loop_budget, cap)
                    }),
                    plan.water.map(|l| water::gpu::WaterBuffers::upload(dev, l)),
                    plan.beams.map(|l| beams::gpu::BeamsBuffers::upload(dev, l)),
                    generation,
                )
            })?;
        let blockers = self.ctx.scoped(dev, || {
            c.occluders
                .prepare(dev, world, generation, plan.caustic_objects)
        })?;
        let (Some(scene), Some(targets), Some(staging), Some(atlas), Some(env)) = (
            c.scene.buffers(),
            &c.targets,
            &c.staging,
            &mut c.atlas,
            &c.env,
        ) else {
            unreachable!("made above");
        };
        timings.push(("prepare".to_string(), t0.elapsed()));

        // Encode and submit. The layers read back: direct, specular, caustics.
        let layers = [
            opts.components.direct,
            opts.components.specular,
            plan.has_caustics(),
        ];
        let t1 = Instant::now();
        self.ctx.scoped(dev, || {
            let mut enc = dev.create_command_encoder(&wgpu::CommandEncoderDescriptor {
                label: Some("frame"),
            });
            // Skipped when the array holds this scene's depths for these light views already.
            shadow::encode(
                dev,
                &mut enc,
                &c.shadow,
                scene,
                generation,
                &plan.lights,
                atlas,
                ts.as_mut(),
            );
            let atlas = &*atlas;
            direct::encode(
                dev,
                &mut enc,
                &c.pipelines,
                scene,
                &frame,
                plan.direct_variant(),
                targets,
                atlas,
                env,
                c.gbuffer.as_ref(),
                (
                    glam::Mat4::from_cols_array(&plan.globals.view_proj),
                    self.back_face_cull,
                ),
                ts.as_mut(),
            );
            // The G-buffer in a pass of its own where the direct pass could not write it.
            if let (true, false, Some(gp), Some(gb)) = (
                plan.needs_gbuffer(),
                plan.gbuffer_in_direct,
                &c.gbuffer_pipeline,
                &c.gbuffer,
            ) {
                gbuffer::encode(dev, &mut enc, gp, gb, scene, &frame.globals, ts.as_mut());
            }
            if let (true, Some(cp), Some(cs), Some((_, images)), Some(gb)) = (
                frame.csl_count > 0,
                &c.csl,
                &c.csl_scratch,
                &c.csl_images,
                &c.gbuffer,
            ) {
                let inputs = csl::pass::CslInputs {
                    globals: &frame.globals,
                    materials: &scene.materials,
                    csls: &frame.csls,
                    texels: images,
                    blockers,
                    glossy: plan.glossy,
                };
                csl::pass::encode(
                    dev,
                    &mut enc,
                    cp,
                    gb,
                    &inputs,
                    cs,
                    &targets.caustics,
                    ts.as_mut(),
                );
            }
            if let (Some(pb), Some(pp), Some(gb)) = (&pinhole_buffers, &c.pinhole, &c.gbuffer) {
                pinhole::encode(
                    dev,
                    &mut enc,
                    pp,
                    gb,
                    scene,
                    &frame.globals,
                    blockers,
                    pb,
                    targets,
                    ts.as_mut(),
                );
            }
            if let (Some(wl), Some(wb), Some(wp), Some(gb)) =
                (plan.water, &water_buffers, &c.water, &c.gbuffer)
            {
                water::gpu::encode(
                    dev,
                    &mut enc,
                    wp,
                    wl,
                    gb,
                    scene,
                    &frame.globals,
                    blockers,
                    wb,
                    targets,
                    ts.as_mut(),
                );
            }
            if let (Some(l), Some(vb), Some(tp), Some(gb)) =
                (plan.transport, &volumes, &c.transport, &c.gbuffer)
            {
                transport::encode(
                    dev,
                    &mut enc,
                    tp,
                    gb,
                    scene,
                    &frame.globals,
                    blockers,
                    vb,
                    l.volumes.len() as u32,
                    attempt.transport_blended,
                    transport_cull,
                    targets,
                    ts.as_mut(),
                );
            }
            if let (Some(bb), Some(bp), Some(gb)) = (&beams_buffers, &c.beams, &c.gbuffer) {
                beams::gpu::encode(
                    dev,
                    &mut enc,
                    bp,
                    gb,
                    scene,
                    &frame.globals,
                    bb,
                    targets,
                    &beams::gpu::Lights {
                        buffer: &frame.lights,
                        shadow_maps: &atlas.view(),
                        sampler: &c.pipelines.shadow_sampler,
                    },
                    ts.as_mut(),
                );
            }
            // The layers read back, copied at the end of the frame's own commands.
            for (k, t) in [&targets.direct, &targets.specular, &targets.caustics]
                .into_iter()
                .enumerate()
            {
                if layers[k] {
                    staging.copy(&mut enc, k, t);
                }
            }
            if let Some(t) = &ts {
                t.resolve(&mut enc);
            }
            h.queue.submit([enc.finish()]);
        })?;
        timings.push(("submit".to_string(), t1.elapsed()));
        let t2 = Instant::now();
        dev.poll(wgpu::PollType::wait_indefinitely())
            .map_err(|e| GpuError::Lost(format!("poll: {e}")))?;
        if self.ctx.is_lost() {
            return Err(GpuError::Lost("device lost during the frame".into()).into());
        }
        timings.push(("gpu_wait".to_string(), t2.elapsed()));
        if let Some(t) = &ts {
            timings.extend(t.read(&self.ctx, dev, &h.queue)?);
        }

        let t3 = Instant::now();
        // Beams' own layers, read one by one.
        let read = |t: &wgpu::Texture| -> Result<Frame, RenderError> {
            let px = self.ctx.readback_rgba32f(t)?;
            Ok(Frame {
                width,
                height,
                pixels: px
                    .into_iter()
                    .map(|p| Vec3::new(p[0], p[1], p[2]))
                    .collect(),
            })
        };
        let wanted: Vec<usize> = (0..layers.len()).filter(|&k| layers[k]).collect();
        let mut read_back: [Option<(Frame, usize)>; 3] = Default::default();
        self.ctx.map_read_each(
            dev,
            &wanted
                .iter()
                .map(|&k| &staging.buffers[k])
                .collect::<Vec<_>>(),
            |i, bytes| read_back[wanted[i]] = Some(staging.frame(bytes)),
        )?;
        let [direct_read, specular_read, caustics_read] = read_back;
        if staging.bytes() > KEEP_STAGING_BYTES {
            c.staging = None;
        }
        let black = || Frame::new(width, height);
        let direct_frame = direct_read.map_or_else(black, |r| r.0);
        let specular_frame = specular_read.map_or_else(black, |r| r.0);
        let mut report = FrameReport {
            pinhole: None,
            transport_overflow: 0,
        };
        let caustics_frame = if let Some((f, flagged)) = caustics_read {
            // The pinhole pass reports loops ended early in the layer's alpha; the transport
            // gather the pixels whose list of volumes overflowed.
            report.pinhole = pinhole_buffers.as_ref().map(|b| PinholeDraws {
                per_draw: b.per_draw,
                cut_pixels: flagged,
            });
            if plan.transport.is_some() {
                report.transport_overflow = flagged;
            }
            Some(f)
        } else {
            None
        };
        let keep_going = match caustics {
            Caustics::Photons(_, k) => k.0,
            _ => &|| true,
        };
        let (caustics_frame, photons_run) = match (plan.photons, &c.photons, &c.gbuffer) {
            (Some(l), Some(pp), Some(gb)) => {
                let (f, run) = photons::gpu::run(
                    &self.ctx,
                    dev,
                    &h.queue,
                    pp,
                    gb,
                    &frame.globals,
                    &scene.materials,
                    world,
                    l,
                    keep_going,
                )?;
                timings.extend(run.gpu_times.iter().cloned());
                timings.push(("photons".to_string(), run.time));
                (Some(f), Some(run))
            }
            _ => (caustics_frame, None),
        };
        let (volume_caustics, volume) = match (&plan.beams, &c.beams) {
            (Some(l), Some(bp)) => (
                Some(read(bp.volume())?),
                // The in-scattering pass runs where the scene has a medium.
                if l.medium.half[0] > 0.0 {
                    Some(read(bp.inscatter())?)
                } else {
                    None
                },
            ),
            _ => (None, None),
        };
        timings.push(("readback".to_string(), t3.elapsed()));
        timings.push(("total".to_string(), t0.elapsed()));
        for e in self.ctx.take_uncaptured_errors() {
            tracing::error!(error = %e, "uncaptured GPU error during the frame");
        }
        Ok((
            RenderOutput {
                direct: direct_frame,
                specular: specular_frame,
                caustics: caustics_frame,
                volume_caustics,
                volume,
                timings,
                adapter: self.ctx.adapter_info().to_string(),
                photons: photons_run,
            },
            report,
        ))
    }
}
