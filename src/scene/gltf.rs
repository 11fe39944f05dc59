//! glTF 2.0 import from bytes (GLB or embedded JSON). Placeholder interface; the hardened
//! importer replaces the body.

use super::world::{Light, Material, Mesh};

/// Caps applied while importing untrusted glTF.
#[derive(Clone, Debug)]
pub struct GltfLimits {
    pub max_nodes: usize,
    pub max_depth: usize,
    pub max_triangles: usize,
    pub max_vertices: usize,
    /// Largest texture width or height decoded, pixels.
    pub max_texture_side: u32,
}

impl Default for GltfLimits {
    fn default() -> Self {
        GltfLimits {
            max_nodes: 100_000,
            max_depth: 64,
            max_triangles: 4_000_000,
            max_vertices: 8_000_000,
            max_texture_side: 8192,
        }
    }
}

/// What a glTF file contributes to a scene.
#[derive(Debug, Default)]
pub struct GltfImport {
    /// Meshes in the file's scene space (node transforms applied) with their materials.
    pub parts: Vec<(Mesh, Material)>,
    pub lights: Vec<Light>,
    pub cameras: Vec<super::world::Camera>,
    pub warnings: Vec<String>,
}

#[derive(Debug, thiserror::Error)]
pub enum GltfError {
    #[error("{0}")]
    Invalid(String),
}

/// Import a glTF from bytes. Relative URIs are read through `assets` (None: only embedded
/// data is allowed); absolute, `file:` and network URIs are refused.
pub fn import_gltf(
    _bytes: &[u8],
    _limits: &GltfLimits,
    _assets: Option<&dyn super::AssetSource>,
) -> Result<GltfImport, GltfError> {
    Err(GltfError::Invalid("glTF import is not built yet".into()))
}
