//! Caustica: a caustics rendering service.
//!
//! Data flows one way: `http` → `jobs` → (`bake` | `render`) → `encode` → `http`.
//!
//! - [`scene`]: the scene model, JSON schema, glTF import, validation. No GPU, no HTTP.
//! - [`trace`]: CPU ray tracing on obvhs (BVH, closest hit, occlusion, Fresnel/Snell paths).
//! - [`reference`]: photon tracing + camera paths, the ground truth other methods are judged by.
//! - [`gpu`]: headless wgpu device, adapter choice, error scopes, device-loss recovery, readback.
//! - [`render`]: the GPU renderer: pipelines, passes per method, composition, tone mapping.
//! - [`encode`]: PNG and EXR.
//! - [`jobs`]: queue, workers, progress, cancellation, persistence (SQLite + artifact files).
//! - [`http`]: the axum API v1; errors as RFC 9457 problem+json.

pub mod encode;
pub mod gpu;
pub mod http;
pub mod jobs;
pub mod reference;
pub mod render;
pub mod scene;
pub mod trace;
