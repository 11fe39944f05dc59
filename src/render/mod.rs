//! The GPU renderer. [`Renderer`] owns the pipelines (built once per device) and the textures
//! reused between frames; [`Renderer::render`] produces one layer per component of the frame,
//! in linear radiance W/(m²·sr), comparable pixel for pixel with the CPU reference:
//!
//! - `direct`: receivers lit by every light, with shadows ([`direct`]);
//! - `specular`: the specular objects themselves and the visible environment;
//! - `caustics`: the caustics methods' layer (`None` when none ran); method `csl` evaluates
//!   its caustic spot lights per pixel in the same pass ([`CslLayer`], [`Renderer::render_csl`]);
//!   method `transport` draws the illumination volumes of its light transport tables over a
//!   G-buffer of the receivers in a pass after it ([`TransportLayer`],
//!   [`Renderer::render_transport`]).
//!
//! The frame is `direct + caustics + specular` ([`RenderOutput::total`]).

pub mod blockers;
pub mod csl;
pub mod direct;
pub mod lights;
pub mod scene;
pub mod shaders;
pub mod transport;

pub use transport::TransportLayer;

use crate::encode::Frame;
use crate::frame::Component;
use crate::gpu::{GpuContext, GpuError};
use crate::scene::World;
use glam::Vec3;
use std::sync::Arc;
use std::time::{Duration, Instant};

/// The caustic spot lights of a frame (method `csl`), already placed in the world
/// ([`crate::bake::csl::CslSet::to_world`]).
#[derive(Clone, Debug, Default)]
pub struct CslLayer {
    pub csls: Vec<crate::bake::csl::Csl>,
    /// Irradiance (W/m²) of the directional light the CSLs were baked for.
    pub irradiance: Vec3,
    /// Indices into `World::objects` of the caustic objects: they do not occlude their own
    /// caustic light; every other object does.
    pub caustic_objects: Vec<usize>,
}

impl CslLayer {
    /// The layer of a render: every (object index, its set) placed where the object is now, lit
    /// by a directional light of `irradiance` (W/m²).
    pub fn new(
        world: &World,
        sets: &[(usize, &crate::bake::csl::CslSet)],
        irradiance: Vec3,
    ) -> CslLayer {
        use crate::bake::csl::CslSet;
        let mut csls = Vec::new();
        let mut caustic_objects = Vec::new();
        for &(oi, set) in sets {
            csls.extend(set.to_world(CslSet::rigid_transform(&world.objects[oi])));
            caustic_objects.push(oi);
        }
        CslLayer {
            csls,
            irradiance,
            caustic_objects,
        }
    }
}

/// The caustics method of a frame.
#[derive(Clone, Copy, Debug, Default)]
pub enum Caustics<'a> {
    #[default]
    None,
    Csl(&'a CslLayer),
    Transport(&'a TransportLayer),
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
    /// CPU stages ("prepare", "submit", "gpu_wait", "readback", "total") and GPU passes from
    /// timestamp queries ("gpu:shadow_maps", "gpu:direct") when the adapter has them.
    pub timings: Vec<(String, Duration)>,
    /// Adapter the frame was rendered on.
    pub adapter: String,
}

impl RenderOutput {
    /// Every component, in [`Component::ALL`]'s order (`indirect`, which no GPU pass
    /// computes, and `caustics` when no caustics method ran, are black).
    pub fn components(&self) -> Vec<(Component, Frame)> {
        let black = || Frame::new(self.direct.width, self.direct.height);
        Component::ALL
            .into_iter()
            .map(|c| {
                let f = match c {
                    Component::Total => self.total(),
                    Component::Direct => self.direct.clone(),
                    Component::Caustics => self.caustics.clone().unwrap_or_else(black),
                    Component::Specular => self.specular.clone(),
                    Component::Indirect => black(),
                };
                (c, f)
            })
            .collect()
    }

    /// direct + caustics + specular.
    pub fn total(&self) -> Frame {
        let mut t = self.direct.add(&self.specular);
        if let Some(c) = &self.caustics {
            t = t.add(c);
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

/// Most memory all shadow maps of one frame may take (32-bit depth texels).
pub const SHADOW_BUDGET_BYTES: u64 = 256 << 20;

/// Resources tied to one device generation.
struct DeviceCache {
    generation: u64,
    pipelines: direct::DirectPipelines,
    targets: Option<direct::Targets>,
    atlas: Option<direct::ShadowAtlas>,
    env: Option<direct::EnvTexture>,
    /// Built on the first transport frame.
    transport: Option<transport::TransportPipelines>,
    gbuffer: Option<transport::GBuffer>,
}

/// The GPU renderer. Not `Sync`: one GPU worker owns it (the context may be shared).
pub struct Renderer {
    ctx: Arc<GpuContext>,
    cache: DeviceCache,
}

impl Renderer {
    /// Builds the pipelines on the context's device.
    pub fn new(ctx: Arc<GpuContext>) -> Result<Renderer, RenderError> {
        let h = ctx.ensure_device()?;
        let cache = Self::build(&ctx, &h)?;
        Ok(Renderer { ctx, cache })
    }

    fn build(ctx: &GpuContext, h: &crate::gpu::DeviceHandle) -> Result<DeviceCache, RenderError> {
        let pipelines = ctx.scoped(&h.device, || direct::DirectPipelines::new(&h.device))?;
        Ok(DeviceCache {
            generation: h.generation,
            pipelines,
            targets: None,
            atlas: None,
            env: None,
            transport: None,
            gbuffer: None,
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
        (!self
            .ctx
            .features()
            .contains(wgpu::Features::FLOAT32_BLENDABLE))
        .then(|| {
            format!(
                "method transport blends into a 32-bit float layer, which adapter {} cannot \
                 (no FLOAT32_BLENDABLE; use a Vulkan adapter, e.g. CAUSTICA_BACKEND=vulkan)",
                self.ctx.adapter_info()
            )
        })
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

    /// Renders `world` with the caustics method `caustics`.
    pub fn render_with(
        &mut self,
        world: &World,
        opts: &RenderOptions,
        caustics: Caustics,
    ) -> Result<RenderOutput, RenderError> {
        match self.render_once(world, opts, caustics) {
            Err(RenderError::Gpu(e)) if matches!(e, GpuError::Lost(_)) || self.ctx.is_lost() => {
                tracing::warn!(error = %e, "render failed on a lost device; retrying on a new one");
                self.ctx.mark_lost();
                self.render_once(world, opts, caustics)
            }
            r => r,
        }
    }

    fn render_once(
        &mut self,
        world: &World,
        opts: &RenderOptions,
        caustics: Caustics,
    ) -> Result<RenderOutput, RenderError> {
        let csl = match caustics {
            Caustics::Csl(l) => Some(l),
            _ => None,
        };
        let tl = match caustics {
            Caustics::Transport(l) => Some(l),
            _ => None,
        };
        if tl.is_some()
            && let Some(why) = self.transport_unsupported()
        {
            return Err(RenderError::Limit(why));
        }
        let t0 = Instant::now();
        let mut timings = Vec::new();
        let h = self.ctx.ensure_device()?;
        if h.generation != self.cache.generation {
            self.cache = Self::build(&self.ctx, &h)?;
        }
        let width = opts.width.unwrap_or(world.camera.width);
        let height = opts.height.unwrap_or(world.camera.height);
        let limits = h.device.limits();
        if width == 0 || height == 0 {
            return Err(RenderError::Options(format!("image size {width}×{height}")));
        }
        let max2d = limits.max_texture_dimension_2d;
        if width > max2d || height > max2d {
            return Err(RenderError::Limit(format!(
                "image size {width}×{height} over the adapter's {max2d}"
            )));
        }
        let mut res = opts.shadow_resolution;
        if !(256..=8192).contains(&res) || res > max2d {
            return Err(RenderError::Options(format!(
                "shadow_resolution {res}: expected 256..=8192 (adapter max {max2d})"
            )));
        }

        // Prepare: pack the scene, plan the lights, upload.
        let mut scene = scene::PackedScene::pack(world);
        if let Some(l) = tl {
            l.apply_view(world, &mut scene);
        }
        let mut plan = lights::LightPlan::new(world, res);
        // Every layer shares one depth array: many lights (a line light alone is 48 cube faces)
        // would need gigabytes at full resolution, so halve it until the array fits the budget.
        let bytes = |res: u32, n: usize| u64::from(res) * u64::from(res) * 4 * n as u64;
        if bytes(res, plan.layers.len()) > SHADOW_BUDGET_BYTES {
            while res > 256 && bytes(res, plan.layers.len()) > SHADOW_BUDGET_BYTES {
                res /= 2;
            }
            tracing::debug!(
                res,
                layers = plan.layers.len(),
                "shadow maps scaled to the budget"
            );
            plan = lights::LightPlan::new(world, res);
        }
        if !opts.components.direct {
            // The specular layer needs no shadows.
            plan.layers.clear();
            for l in &mut plan.lights {
                l.n_layers = 0;
            }
        }
        if plan.layers.len() as u32 > limits.max_texture_array_layers {
            return Err(RenderError::Limit(format!(
                "{} shadow map layers over the adapter's {}",
                plan.layers.len(),
                limits.max_texture_array_layers
            )));
        }
        if let Some((m, _)) = &plan.env.map
            && (m.width > max2d || m.height > max2d)
        {
            return Err(RenderError::Limit(format!(
                "environment map {}×{} over the adapter's {max2d}",
                m.width, m.height
            )));
        }
        if plan.env.extra_maps > 0 {
            tracing::warn!(
                extra = plan.env.extra_maps,
                "several environment maps: all light receivers, only the first is reflected"
            );
        }
        let mut globals = direct::globals(world, width, height, &plan);
        let csl_bufs = match csl {
            Some(l) => {
                let max_storage = limits.max_storage_buffer_binding_size;
                // Images over the binding limit (many CSLs, e.g. a set interpolated from a
                // dynamic bake of a complex object) are made coarser, least flux first, rather
                // than refusing the frame.
                let fitted = crate::bake::csl::image::fit_images(&l.csls, max_storage / 8);
                if let Some(f) = &fitted {
                    tracing::warn!(
                        csls = l.csls.len(),
                        halved = f.1,
                        "CSL intensity images over the storage binding limit: some made coarser"
                    );
                }
                let csls: &[crate::bake::csl::Csl] =
                    fitted.as_ref().map_or(&l.csls, |f| f.0.as_slice());
                let texel_bytes: u64 = csls.iter().map(|c| c.texels.len() as u64 * 8).sum();
                if texel_bytes > max_storage {
                    return Err(RenderError::Limit(format!(
                        "{} bytes of CSL intensity images over the adapter's storage binding \
                         limit of {max_storage}",
                        texel_bytes
                    )));
                }
                globals.counts[3] = csls.len() as u32;
                globals.csl_irradiance = l.irradiance.extend(0.0).to_array();
                let blockers =
                    blockers::Blockers::build(world, |i| !l.caustic_objects.contains(&i));
                direct::CslBuffers::new(csls, blockers)
            }
            None => match tl {
                Some(l) => {
                    let bytes =
                        l.volumes.len() as u64 * std::mem::size_of::<transport::GpuVolume>() as u64;
                    let max_storage = limits.max_storage_buffer_binding_size;
                    if bytes > max_storage {
                        return Err(RenderError::Limit(format!(
                            "{} illumination volumes ({bytes} bytes) over the adapter's \
                             storage binding limit of {max_storage}",
                            l.volumes.len()
                        )));
                    }
                    direct::CslBuffers::new(
                        &[],
                        blockers::Blockers::build(world, |i| !l.caustic_objects.contains(&i)),
                    )
                }
                None => direct::CslBuffers::new(&[], blockers::Blockers::from_triangles(&[])),
            },
        };
        let dev = &h.device;
        let c = &mut self.cache;
        let with_ts = self.ctx.has_timestamps();
        let (queries, query_buf, query_read) = self.ctx.scoped(dev, || {
            if !c
                .targets
                .as_ref()
                .is_some_and(|t| t.width == width && t.height == height)
            {
                c.targets = Some(direct::Targets::new(dev, width, height));
            }
            let n_layers = plan.layers.len() as u32;
            if !c.atlas.as_ref().is_some_and(|a| a.fits(res, n_layers)) {
                drop(c.atlas.take()); // free the old one first
                c.atlas = Some(direct::ShadowAtlas::new(dev, res, n_layers));
            }
            let key = plan
                .env
                .map
                .as_ref()
                .map_or(0, |(m, _)| Arc::as_ptr(m) as usize);
            if c.env.as_ref().is_none_or(|e| e.key != key) {
                let map = plan.env.map.as_ref().map(|(m, _)| m.as_ref());
                c.env = Some(direct::EnvTexture::new(dev, &h.queue, map, key));
            }
            if tl.is_some() {
                if c.transport.is_none() {
                    c.transport = Some(transport::TransportPipelines::new(dev));
                }
                if !c
                    .gbuffer
                    .as_ref()
                    .is_some_and(|g| g.width == width && g.height == height)
                {
                    c.gbuffer = Some(transport::GBuffer::new(dev, width, height));
                }
            }
            if with_ts {
                let q = dev.create_query_set(&wgpu::QuerySetDescriptor {
                    label: Some("pass timestamps"),
                    ty: wgpu::QueryType::Timestamp,
                    count: 6,
                });
                let resolve = dev.create_buffer(&wgpu::BufferDescriptor {
                    label: Some("timestamps"),
                    size: 48,
                    usage: wgpu::BufferUsages::QUERY_RESOLVE | wgpu::BufferUsages::COPY_SRC,
                    mapped_at_creation: false,
                });
                let read = dev.create_buffer(&wgpu::BufferDescriptor {
                    label: Some("timestamps read"),
                    size: 48,
                    usage: wgpu::BufferUsages::MAP_READ | wgpu::BufferUsages::COPY_DST,
                    mapped_at_creation: false,
                });
                (Some(q), Some(resolve), Some(read))
            } else {
                (None, None, None)
            }
        })?;
        let (bufs, volumes) = self.ctx.scoped(dev, || {
            (
                direct::FrameBuffers::upload(dev, &scene, &globals, &plan, &csl_bufs),
                tl.map(|l| transport::upload_volumes(dev, &l.volumes)),
            )
        })?;
        let c = &self.cache;
        let (Some(targets), Some(atlas), Some(env)) = (&c.targets, &c.atlas, &c.env) else {
            unreachable!("created above");
        };
        timings.push(("prepare".to_string(), t0.elapsed()));

        // Encode and submit.
        let t1 = Instant::now();
        self.ctx.scoped(dev, || -> Result<(), RenderError> {
            let mut enc = dev.create_command_encoder(&wgpu::CommandEncoderDescriptor {
                label: Some("frame"),
            });
            direct::encode(
                dev,
                &mut enc,
                &c.pipelines,
                &bufs,
                &plan,
                targets,
                atlas,
                env,
                queries.as_ref(),
            )?;
            if let (Some(l), Some(vb), Some(tp), Some(gb)) =
                (tl, &volumes, &c.transport, &c.gbuffer)
            {
                transport::encode(
                    dev,
                    &mut enc,
                    tp,
                    gb,
                    &bufs,
                    vb,
                    l.volumes.len() as u32,
                    targets,
                    queries.as_ref().map(|q| (q, 4)),
                );
            }
            if let (Some(q), Some(rb), Some(read)) = (&queries, &query_buf, &query_read) {
                // Slots 0/1 are only written when there are shadow passes, 4/5 with transport.
                let first = if plan.layers.is_empty() { 2 } else { 0 };
                let last = if tl.is_some() { 6 } else { 4 };
                enc.resolve_query_set(q, first..last, rb, 0);
                enc.copy_buffer_to_buffer(rb, 0, read, 0, 48);
            }
            h.queue.submit([enc.finish()]);
            Ok(())
        })??;
        timings.push(("submit".to_string(), t1.elapsed()));
        let t2 = Instant::now();
        dev.poll(wgpu::PollType::wait_indefinitely())
            .map_err(|e| GpuError::Lost(format!("poll: {e}")))?;
        if self.ctx.is_lost() {
            return Err(GpuError::Lost("device lost during the frame".into()).into());
        }
        timings.push(("gpu_wait".to_string(), t2.elapsed()));

        if let Some(read) = &query_read {
            let bytes = self.ctx.map_read(dev, read)?;
            // Slot k was resolved to index k - first.
            let first = if plan.layers.is_empty() { 2 } else { 0 };
            let all: &[u64] = bytemuck::cast_slice(&bytes);
            let ts = |k: usize| all[k - first];
            let period = h.queue.get_timestamp_period() as f64;
            let span =
                |a: u64, b: u64| Duration::from_nanos((b.saturating_sub(a) as f64 * period) as u64);
            if !plan.layers.is_empty() {
                timings.push(("gpu:shadow_maps".to_string(), span(ts(0), ts(1))));
            }
            let main = if csl.is_some() {
                "gpu:direct+csl"
            } else {
                "gpu:direct"
            };
            timings.push((main.to_string(), span(ts(2), ts(3))));
            if tl.is_some() {
                timings.push(("gpu:transport".to_string(), span(ts(4), ts(5))));
            }
        }

        let t3 = Instant::now();
        let to_frame = |px: Vec<[f32; 4]>| Frame {
            width,
            height,
            pixels: px
                .into_iter()
                .map(|p| Vec3::new(p[0], p[1], p[2]))
                .collect(),
        };
        let direct_frame = if opts.components.direct {
            to_frame(self.ctx.readback_rgba32f(&targets.direct)?)
        } else {
            Frame::new(width, height)
        };
        let specular_frame = if opts.components.specular {
            to_frame(self.ctx.readback_rgba32f(&targets.specular)?)
        } else {
            Frame::new(width, height)
        };
        let caustics_frame = match caustics {
            Caustics::None => None,
            _ => Some(to_frame(self.ctx.readback_rgba32f(&targets.caustics)?)),
        };
        timings.push(("readback".to_string(), t3.elapsed()));
        timings.push(("total".to_string(), t0.elapsed()));
        for e in self.ctx.take_uncaptured_errors() {
            tracing::error!(error = %e, "uncaptured GPU error during the frame");
        }
        Ok(RenderOutput {
            direct: direct_frame,
            specular: specular_frame,
            caustics: caustics_frame,
            timings,
            adapter: self.ctx.adapter_info().to_string(),
        })
    }
}

/// A colour attachment cleared to transparent black and stored: how every pass here starts.
fn cleared_attachment(view: &wgpu::TextureView) -> Option<wgpu::RenderPassColorAttachment<'_>> {
    Some(wgpu::RenderPassColorAttachment {
        view,
        depth_slice: None,
        resolve_target: None,
        ops: wgpu::Operations {
            load: wgpu::LoadOp::Clear(wgpu::Color::TRANSPARENT),
            store: wgpu::StoreOp::Store,
        },
    })
}
