//! Caustica: a caustics rendering service.
//!
//! Data flows one way: `http` → `jobs` → (`bake` | `render`) → `encode` → `http`.
//!
//! - [`scene`]: the scene model, JSON schema, glTF import, validation. No GPU, no HTTP.
//! - [`trace`]: CPU ray tracing (an obvhs-built BVH walked eight children at a time, closest
//!   hit, occlusion, Fresnel/Snell paths).
//! - [`bake`]: deterministic CPU precomputation per method (CSL sets), cached by content hash.
//! - [`reference`](mod@reference): photon tracing + camera paths, the ground truth other methods are judged by.
//! - [`gpu`]: headless wgpu device, adapter choice, error scopes, device-loss recovery, readback.
//! - [`render`]: the GPU renderer: pipelines, passes per method, composition, tone mapping.
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
pub mod encode;
pub mod frame;
pub mod gpu;
pub mod http;
pub mod jobs;
pub mod methods;
pub mod reference;
pub mod render;
pub mod scene;
pub mod trace;
