//! Caustica: a caustics rendering service.
//!
//! Data flows one way: `http` → `jobs` → `methods` → (`bake` | `reference` | `render`) →
//! `encode` → `http`; the CLI (`main.rs`) calls `methods` as the jobs do.
//!
//! - [`scene`]: the scene model, JSON schema, glTF import, validation. No GPU, no HTTP.
//! - [`frame`]: frames and their components (`total`, `direct`, `caustics`, ...).
//! - [`sampling`]: deterministic random numbers (PCG) and warps, for every layer that samples.
//! - [`trace`]: CPU ray tracing (an obvhs-built BVH walked eight children at a time, packets,
//!   closest hit, occlusion, Fresnel/Snell paths, SIMD dispatch).
//! - [`reference`](mod@reference): photon tracing + camera paths, the ground truth other
//!   methods are judged by; `compare`.
//! - [`bake`]: deterministic CPU precomputation per method (CSL sets, transport tables) and the
//!   artifact store that keeps them by content hash. Nothing here runs per frame.
//! - [`cancel`]: how long CPU loops ask a job's keep-going predicate and stop ([`cancel::Stop`]).
//! - [`gpu`]: headless wgpu device, adapter choice, error scopes, device-loss recovery, readback.
//! - [`render`]: the GPU renderer: a frame plan, one module per pass (shadow, direct, csl,
//!   transport) with its shader, and beside each pass the per-frame CPU work of its method.
//! - [`methods`]: one module per method and the registry every caller uses: parameters, lane,
//!   bake-or-find, frames; `auto`.
//! - [`encode`]: PNG and EXR.
//! - [`jobs`]: queue, workers, progress, cancellation, persistence (SQLite + artifact files).
//! - [`http`]: the axum API v1; errors as RFC 9457 problem+json.
//!
//! ```
//! use caustica::scene::{self, MapSource};
//! use caustica::trace::Accel;
//! use glam::Vec3;
//!
//! let json = r#"{
//!     "camera": {"eye": [0, 2, 2], "target": [0, 0, 0]},
//!     "lights": [{"type": "point", "position": [0, 2, 0], "intensity": 10}],
//!     "materials": {"glass": {"type": "dielectric", "ior": 1.5}},
//!     "objects": [{"name": "ball", "shape": {"type": "sphere", "radius": 0.5},
//!                  "material": "glass"}]
//! }"#;
//! let desc = scene::parse_scene(json.as_bytes()).unwrap();
//! let world = scene::resolve(&desc, &MapSource::default(), &Default::default()).unwrap();
//! let hit = Accel::build(&world)
//!     .intersect(Vec3::new(0.0, 2.0, 0.0), Vec3::NEG_Y, f32::INFINITY)
//!     .unwrap();
//! assert!((hit.t - 1.5).abs() < 1e-3);
//!
//! // Errors name the field at fault.
//! let bad = scene::parse_scene(json.replace("1.5", "0.5").as_bytes()).unwrap();
//! let err = scene::resolve(&bad, &MapSource::default(), &Default::default()).unwrap_err();
//! assert_eq!(err.field(), "materials.glass.ior");
//! ```

pub mod bake;
pub mod cancel;
pub mod encode;
pub mod frame;
pub mod gpu;
pub mod http;
pub mod jobs;
pub mod methods;
pub mod reference;
pub mod render;
pub mod sampling;
pub mod scene;
pub mod trace;
