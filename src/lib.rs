//! Caustica: a caustics rendering service.
//!
//! Data flows one way: `http` → `jobs` → (`bake` | `render`) → `encode` → `http`.
//!
//! - [`scene`]: the scene model, JSON schema, glTF import, validation. No GPU, no HTTP.
//! - [`trace`]: CPU ray tracing on obvhs (BVH, closest hit, occlusion, Fresnel/Snell paths).
//! - [`bake`]: deterministic CPU precomputation per method (CSL sets), cached by content hash.
//! - [`reference`]: photon tracing + camera paths, the ground truth other methods are judged by.
//! - [`gpu`]: headless wgpu device, adapter choice, error scopes, device-loss recovery, readback.
//! - [`render`]: the GPU renderer: pipelines, passes per method, composition, tone mapping.
//! - [`encode`]: PNG and EXR.

pub mod bake;
pub mod encode;
pub mod gpu;
pub mod reference;
pub mod render;
pub mod scene;
pub mod trace;
