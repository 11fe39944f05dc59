//! The frame plan: every check and limit of a frame decided on the CPU, before any GPU work,
//! against the adapter's limits ([`DeviceLimits`]), so that it can be tested without a device:
//! the image size, the shadow maps (their layers halved in resolution until they fit
//! [`SHADOW_BUDGET_BYTES`]), the lights and environment as the direct pass reads them, the
//! camera uniforms, and the caustics method's data (CSL images made coarser where they exceed
//! a storage binding; the count of illumination volumes checked against it).

use super::csl::CslLayer;
use super::direct::{Globals, globals};
use super::lights::LightPlan;
use super::pinhole::PinholeLayer;
use super::transport::{GpuVolume, TransportLayer};
use super::{Caustics, RenderError, RenderOptions};
use crate::bake::csl::Csl;
use crate::scene::World;
use std::borrow::Cow;

/// Most memory all shadow maps of one frame may take (32-bit depth texels).
pub const SHADOW_BUDGET_BYTES: u64 = 256 << 20;

/// What a frame plan needs to know of the adapter.
#[derive(Clone, Debug, PartialEq)]
pub struct DeviceLimits {
    /// The adapter, as errors name it.
    pub adapter: String,
    pub max_texture_2d: u32,
    pub max_texture_array_layers: u32,
    pub max_storage_binding: u64,
    /// Whether a 32-bit float target can be blended into (method `transport`'s volume pass).
    pub float32_blendable: bool,
    /// Bytes a sample of a render pass's colour attachments may take.
    pub max_color_attachment_bytes: u32,
}

impl DeviceLimits {
    pub fn of(ctx: &crate::gpu::GpuContext, device: &wgpu::Device) -> DeviceLimits {
        let l = device.limits();
        DeviceLimits {
            adapter: ctx.adapter_info().to_string(),
            max_texture_2d: l.max_texture_dimension_2d,
            max_texture_array_layers: l.max_texture_array_layers,
            max_storage_binding: l.max_storage_buffer_binding_size,
            float32_blendable: ctx.features().contains(wgpu::Features::FLOAT32_BLENDABLE),
            max_color_attachment_bytes: l
                .max_color_attachment_bytes_per_sample
                .min(l.max_color_attachments * 16),
        }
    }

    /// Why this adapter cannot render method `transport` (None when it can).
    pub fn transport_unsupported(&self) -> Option<String> {
        (!self.float32_blendable).then(|| {
            format!(
                "methods transport, beams and photons blend into 32-bit float layers, which adapter {} cannot \
                 (no FLOAT32_BLENDABLE; use a Vulkan adapter, e.g. CAUSTICA_BACKEND=vulkan)",
                self.adapter
            )
        })
    }
}

/// The caustic spot lights a frame evaluates.
pub struct CslFrame<'a> {
    /// The layer's CSLs, or copies with coarser images where they would not fit a binding.
    pub csls: Cow<'a, [Csl]>,
    pub layer: &'a CslLayer,
}

impl CslFrame<'_> {
    /// The layer's [`CslLayer::images_key`] where the frame evaluates the layer's own images
    /// (None where they were made coarser to fit: those are uploaded every frame).
    pub fn images_key(&self) -> Option<u64> {
        match self.csls {
            Cow::Borrowed(_) => self.layer.images_key,
            Cow::Owned(_) => None,
        }
    }
}

/// Everything decided about a frame before the GPU sees it.
pub struct FramePlan<'a> {
    pub width: u32,
    pub height: u32,
    /// Side of each shadow map, after the budget.
    pub shadow_resolution: u32,
    pub lights: LightPlan,
    /// The camera and lights' uniforms.
    pub globals: Globals,
    pub csl: Option<CslFrame<'a>>,
    pub transport: Option<&'a TransportLayer>,
    pub pinhole: Option<&'a PinholeLayer>,
    pub water: Option<&'a super::water::gpu::WaterGpuLayer>,
    pub beams: Option<&'a super::beams::BeamsLayer>,
    pub photons: Option<&'a super::photons::PhotonsLayer>,
    /// The objects whose own caustic light nothing else occludes (the caustic objects of the
    /// method), when the frame has caustics.
    pub caustic_objects: Option<&'a [usize]>,
    /// Whether the scene has a glossy material (the CSL passes are compiled without the glossy
    /// BRDF otherwise).
    pub glossy: bool,
    /// Whether the direct pass writes the G-buffer, where the frame needs one and the adapter's
    /// attachments take it ([`super::direct::GBUFFER_IN_DIRECT_BYTES`]); else a pass of its own.
    pub gbuffer_in_direct: bool,
}

impl<'a> FramePlan<'a> {
    pub fn new(
        world: &World,
        opts: &RenderOptions,
        caustics: Caustics<'a>,
        dev: &DeviceLimits,
    ) -> Result<FramePlan<'a>, RenderError> {
        let (csl, transport, pinhole, water, beams) = match caustics {
            Caustics::Csl(l) => (Some(l), None, None, None, None),
            Caustics::Transport(l) => (None, Some(l), None, None, None),
            Caustics::Pinhole(l) => (None, None, Some(l), None, None),
            Caustics::Water(l) => (None, None, None, Some(l), None),
            Caustics::Beams(l) => (None, None, None, None, Some(l)),
            Caustics::None | Caustics::Photons(..) => (None, None, None, None, None),
        };
        let photons = match caustics {
            Caustics::Photons(l, _) => Some(l),
            _ => None,
        };
        if (transport.is_some() || beams.is_some() || photons.is_some())
            && let Some(why) = dev.transport_unsupported()
        {
            return Err(RenderError::Limit(why));
        }
        let width = opts.width.unwrap_or(world.camera.width);
        let height = opts.height.unwrap_or(world.camera.height);
        if width == 0 || height == 0 {
            return Err(RenderError::Options(format!("image size {width}×{height}")));
        }
        let max2d = dev.max_texture_2d;
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
        let mut lights = LightPlan::new(world, res);
        // Every layer shares one depth array: many lights (a line light alone is 48 cube faces)
        // would need gigabytes at full resolution, so halve it until the array fits the budget.
        let bytes = |res: u32, n: usize| u64::from(res) * u64::from(res) * 4 * n as u64;
        if bytes(res, lights.layers.len()) > SHADOW_BUDGET_BYTES {
            while res > 256 && bytes(res, lights.layers.len()) > SHADOW_BUDGET_BYTES {
                res /= 2;
            }
            tracing::debug!(
                res,
                layers = lights.layers.len(),
                "shadow maps scaled to the budget"
            );
            lights = LightPlan::new(world, res);
        }
        if !opts.components.direct {
            // The specular layer needs no shadows.
            lights.layers.clear();
            lights.sky_layers.clear();
            for l in &mut lights.lights {
                l.n_layers = 0;
            }
        }
        let most = lights.layers.len().max(lights.sky_layers.len()) as u32;
        if most > dev.max_texture_array_layers {
            return Err(RenderError::Limit(format!(
                "{most} shadow map layers over the adapter's {}",
                dev.max_texture_array_layers
            )));
        }
        if let Some((m, _)) = &lights.env.map
            && (m.width > max2d || m.height > max2d)
        {
            return Err(RenderError::Limit(format!(
                "environment map {}×{} over the adapter's {max2d}",
                m.width, m.height
            )));
        }
        if lights.env.extra_maps > 0 {
            tracing::warn!(
                extra = lights.env.extra_maps,
                "several environment maps: all light receivers, only the first is reflected"
            );
        }
        let mut globals = globals(world, width, height, &lights);
        let max_storage = dev.max_storage_binding;
        let csl = match csl {
            Some(l) => {
                // Images over the binding limit (many CSLs, e.g. a set interpolated from a
                // dynamic bake of a complex object) are made coarser, least flux first, rather
                // than refusing the frame.
                let csls = match crate::bake::csl::image::fit_images(&l.csls, max_storage / 8) {
                    Some((fitted, halved)) => {
                        tracing::warn!(
                            csls = l.csls.len(),
                            halved,
                            "CSL intensity images over the storage binding limit: some made \
                             coarser"
                        );
                        Cow::Owned(fitted)
                    }
                    None => Cow::Borrowed(l.csls.as_slice()),
                };
                if csls.len() > super::csl::pass::MAX_FRAME_CSLS {
                    return Err(RenderError::Limit(format!(
                        "{} caustic spot lights in the frame; the CSL pass evaluates at most {}",
                        csls.len(),
                        super::csl::pass::MAX_FRAME_CSLS
                    )));
                }
                let scratch = super::csl::pass::scratch_bytes(
                    u64::from(width) * u64::from(height),
                    csls.len(),
                );
                if scratch > max_storage {
                    return Err(RenderError::Limit(format!(
                        "the CSL pass's list of pixels ({scratch} bytes for {} CSLs at \
                         {width}×{height}) over the adapter's storage binding limit of \
                         {max_storage}",
                        csls.len()
                    )));
                }
                let texel_bytes: u64 = csls.iter().map(|c| c.texels.len() as u64 * 8).sum();
                if texel_bytes > max_storage {
                    return Err(RenderError::Limit(format!(
                        "{texel_bytes} bytes of CSL intensity images over the adapter's storage \
                         binding limit of {max_storage}"
                    )));
                }
                globals.counts[3] = csls.len() as u32;
                globals.csl_irradiance = l.irradiance.extend(0.0).to_array();
                Some(CslFrame { csls, layer: l })
            }
            None => None,
        };
        if let Some(l) = transport {
            let bytes = l.volumes.len() as u64 * std::mem::size_of::<GpuVolume>() as u64;
            if bytes > max_storage {
                return Err(RenderError::Limit(format!(
                    "{} illumination volumes ({bytes} bytes) over the adapter's storage binding \
                     limit of {max_storage}",
                    l.volumes.len()
                )));
            }
            // The pass's per-pixel sums (its list is cut to the limit and falls back when full).
            let sums = u64::from(width) * u64::from(height) * 24;
            if sums > max_storage {
                return Err(RenderError::Limit(format!(
                    "the transport pass's per-pixel sums ({sums} bytes at {width}×{height}) over \
                     the adapter's storage binding limit of {max_storage}"
                )));
            }
        }
        if let Some(l) = pinhole {
            let bytes = l.storage_bytes();
            if bytes > max_storage {
                return Err(RenderError::Limit(format!(
                    "{} pinhole points ({bytes} bytes) over the adapter's storage binding limit \
                     of {max_storage}",
                    l.samples.len()
                )));
            }
        }
        if let Some(m) = water.and_then(|w| w.map.as_ref()) {
            let bytes = m.landing_bytes().max(m.pyramid_bytes());
            if bytes > max_storage {
                return Err(RenderError::Limit(format!(
                    "the water's {bytes} bytes of landed sun rays or light map levels are over \
                     the adapter's storage binding limit of {max_storage}; ask for a smaller \
                     water.grid, fewer water.sun_samples or a smaller water.map_resolution"
                )));
            }
            if m.resolution > dev.max_texture_2d {
                return Err(RenderError::Limit(format!(
                    "the water's light map of {} texels a side is over the adapter's texture \
                     limit of {}; ask for a smaller water.map_resolution",
                    m.resolution, dev.max_texture_2d
                )));
            }
        }
        if let Some(l) = beams {
            // The direct light crosses the fog (the beams pass adds the camera's side).
            let m = &l.medium;
            globals.medium_to_local = m.to_local;
            globals.medium_half = m.half;
            globals.medium_sigma_t = m.sigma_t;
            globals.medium_sigma_s = m.sigma_s;
            let bytes = super::beams::gpu::BeamsBuffers::storage_bytes(l);
            if bytes > max_storage {
                return Err(RenderError::Limit(format!(
                    "{} beams ({bytes} bytes) over the adapter's storage binding limit of \
                     {max_storage}; ask for a smaller beams.grid",
                    l.beams.len()
                )));
            }
        } else if let Some(m) = super::water::gpu::DirectMedium::of(world) {
            // The water's body absorbs the direct light on its way to the receivers in it and on
            // the way back to the camera.
            globals.medium_to_local = m.to_local;
            globals.medium_half = m.half;
            globals.medium_sigma_t = m.sigma_t;
        }
        if let Some(l) = photons {
            let bytes = l.record_bytes().max(l.bvh.triangles.len() as u64 * 48);
            if bytes > max_storage {
                return Err(RenderError::Limit(format!(
                    "{} photons a frame ({bytes} bytes of stored photons or triangles) over the \
                     adapter's storage binding limit of {max_storage}; ask for fewer \
                     progressive.photons_per_frame",
                    l.photons_per_frame
                )));
            }
        }
        // Pinhole points are shadowed by every object, their own included.
        let caustic_objects = csl
            .as_ref()
            .map(|c| c.layer.caustic_objects.as_slice())
            .or(transport.map(|t| t.caustic_objects.as_slice()))
            .or(pinhole.map(|_| &[][..]))
            .or(water.map(|w| w.surfaces.as_slice()))
            .or(beams.map(|b| b.generators.as_slice()));
        Ok(FramePlan {
            width,
            height,
            shadow_resolution: res,
            lights,
            globals,
            csl,
            transport,
            pinhole,
            water,
            beams,
            photons,
            caustic_objects,
            glossy: world
                .materials
                .iter()
                .any(|m| matches!(m, crate::scene::Material::Glossy { .. })),
            gbuffer_in_direct: dev.max_color_attachment_bytes
                >= super::direct::GBUFFER_IN_DIRECT_BYTES,
        })
    }

    /// What the direct pass needs compiled in: an environment map, the sky's shadows, a
    /// medium, glossy receivers.
    pub fn direct_variant(&self) -> super::direct::Variant {
        super::direct::Variant {
            env_map: self.globals.env_map_scale[3] > 0.5,
            sky: self.globals.sky[1] > 0 && !self.lights.sky_layers.is_empty(),
            medium: self.globals.medium_half[0] > 0.0,
            glossy: self.glossy,
            gbuffer: self.gbuffer_in_direct && self.needs_gbuffer(),
        }
    }

    /// Whether the frame has a caustics layer to read back.
    pub fn has_caustics(&self) -> bool {
        self.csl.is_some()
            || self.transport.is_some()
            || self.pinhole.is_some()
            || self.water.is_some()
            || self.beams.is_some()
    }

    /// Whether a pass gathers caustics per pixel over the G-buffer of the receivers.
    pub fn needs_gbuffer(&self) -> bool {
        self.csl.as_ref().is_some_and(|c| !c.csls.is_empty())
            || self.transport.is_some()
            || self.pinhole.is_some()
            || self.water.is_some()
            || self.beams.is_some()
            || self.photons.is_some()
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::render::Components;

    fn limits() -> DeviceLimits {
        DeviceLimits {
            adapter: "test".into(),
            max_texture_2d: 4096,
            max_texture_array_layers: 256,
            max_storage_binding: 128 << 20,
            float32_blendable: true,
            max_color_attachment_bytes: 128,
        }
    }

    fn world(lights: &str) -> World {
        crate::scene::load_scene_json(
            format!(
                r#"{{"camera": {{"eye": [0, 2, 2], "target": [0, 0, 0], "width": 64, "height": 48}},
                    "lights": [{lights}],
                    "materials": {{"m": {{"type": "diffuse", "albedo": 0.5}}}},
                    "objects": [{{"name": "floor", "shape": {{"type": "plane", "size": [4, 4]}},
                                  "material": "m"}}]}}"#
            )
            .as_bytes(),
        )
        .unwrap()
    }

    #[test]
    fn sizes_and_options_are_checked_against_the_adapter() {
        let w = world(r#"{"type": "point", "position": [0, 2, 0], "intensity": 1}"#);
        let p = FramePlan::new(&w, &RenderOptions::default(), Caustics::None, &limits()).unwrap();
        assert_eq!((p.width, p.height), (64, 48));
        assert_eq!(p.lights.layers.len(), 6, "a point light: six cube faces");
        assert!(!p.has_caustics() && p.caustic_objects.is_none());
        let big = RenderOptions {
            width: Some(5000),
            ..Default::default()
        };
        let e = FramePlan::new(&w, &big, Caustics::None, &limits())
            .err()
            .unwrap();
        assert!(matches!(e, RenderError::Limit(_)), "{e}");
        let zero = RenderOptions {
            height: Some(0),
            ..Default::default()
        };
        let e = FramePlan::new(&w, &zero, Caustics::None, &limits())
            .err()
            .unwrap();
        assert!(matches!(e, RenderError::Options(_)), "{e}");
        let shadow = RenderOptions {
            shadow_resolution: 100,
            ..Default::default()
        };
        let e = FramePlan::new(&w, &shadow, Caustics::None, &limits())
            .err()
            .unwrap();
        assert!(e.to_string().contains("shadow_resolution"), "{e}");
        // Without the direct layer no shadow map is drawn.
        let specular = RenderOptions {
            components: Components {
                direct: false,
                specular: true,
            },
            ..Default::default()
        };
        let p = FramePlan::new(&w, &specular, Caustics::None, &limits()).unwrap();
        assert!(p.lights.layers.is_empty());
        assert!(p.lights.lights.iter().all(|l| l.n_layers == 0));
    }

    #[test]
    fn shadow_maps_are_halved_into_the_budget() {
        // A line light is many shadowed points: 48 cube faces at 2048² are 805 MB.
        let w = world(r#"{"type": "line", "start": [-1, 2, 0], "end": [1, 2, 0], "intensity": 1}"#);
        let p = FramePlan::new(&w, &RenderOptions::default(), Caustics::None, &limits()).unwrap();
        let n = p.lights.layers.len() as u64;
        assert!(n > 6, "{n} layers");
        let bytes = u64::from(p.shadow_resolution).pow(2) * 4 * n;
        assert!(
            bytes <= SHADOW_BUDGET_BYTES,
            "{bytes} bytes at {}",
            p.shadow_resolution
        );
        assert!(p.shadow_resolution < 2048 && p.shadow_resolution >= 256);
        // Too many layers for the adapter.
        let few = DeviceLimits {
            max_texture_array_layers: 8,
            ..limits()
        };
        let e = FramePlan::new(&w, &RenderOptions::default(), Caustics::None, &few)
            .err()
            .unwrap();
        assert!(e.to_string().contains("shadow map layers"), "{e}");
    }

    #[test]
    fn caustics_layers_are_checked_against_the_bindings() {
        let w = world(r#"{"type": "directional", "direction": [0, -1, 0], "irradiance": 1}"#);
        let transport = TransportLayer {
            volumes: vec![
                crate::render::transport::volumes::Volume {
                    exits: [glam::Vec3::ZERO; 3],
                    dirs: [glam::Vec3::Y; 3],
                    flux_density: [glam::Vec3::ONE; 3],
                    source_area: 1.0,
                    length: 1.0,
                };
                1000
            ],
            caustic_objects: vec![0],
            ..Default::default()
        };
        let p = FramePlan::new(
            &w,
            &RenderOptions::default(),
            Caustics::Transport(&transport),
            &limits(),
        )
        .unwrap();
        assert_eq!(p.caustic_objects, Some(&[0usize][..]));
        let tiny = DeviceLimits {
            max_storage_binding: 1000,
            ..limits()
        };
        let e = FramePlan::new(
            &w,
            &RenderOptions::default(),
            Caustics::Transport(&transport),
            &tiny,
        )
        .err()
        .unwrap();
        assert!(e.to_string().contains("illumination volumes"), "{e}");
        // One volume fits; the per-pixel sums of the list (24 bytes a pixel) do not.
        let one = TransportLayer {
            volumes: transport.volumes[..1].to_vec(),
            ..transport.clone()
        };
        let small = DeviceLimits {
            max_storage_binding: 10_000,
            ..limits()
        };
        let e = FramePlan::new(
            &w,
            &RenderOptions::default(),
            Caustics::Transport(&one),
            &small,
        )
        .err()
        .unwrap();
        assert!(e.to_string().contains("per-pixel sums"), "{e}");
        let gl = DeviceLimits {
            float32_blendable: false,
            ..limits()
        };
        let e = FramePlan::new(
            &w,
            &RenderOptions::default(),
            Caustics::Transport(&transport),
            &gl,
        )
        .err()
        .unwrap();
        assert!(e.to_string().contains("FLOAT32_BLENDABLE"), "{e}");
        // CSLs: their count and light reach the uniforms.
        let csl = CslLayer {
            csls: vec![],
            irradiance: glam::Vec3::splat(2.0),
            caustic_objects: vec![0],
            images_key: None,
        };
        let p = FramePlan::new(
            &w,
            &RenderOptions::default(),
            Caustics::Csl(&csl),
            &limits(),
        )
        .unwrap();
        assert_eq!(p.globals.counts[3], 0);
        assert_eq!(p.globals.csl_irradiance, [2.0, 2.0, 2.0, 0.0]);
        assert!(p.has_caustics());
    }
}
