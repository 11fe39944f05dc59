//! glTF 2.0 import from untrusted bytes (GLB or JSON).
//!
//! The `gltf` crate (1.4.1) is used only to deserialize the JSON document. Everything it would
//! otherwise do on bad input is done here by hand, because on malformed files it panics (bad
//! percent-encoding, image views past their buffer, odd accessor counts), follows `../` and
//! `file://` URIs, allocates whatever a GLB header declares and loops forever on node cycles:
//!
//! * GLB framing (magic, version, lengths, chunk order and alignment) is checked before
//!   anything is allocated; the JSON chunk alone is handed to the crate.
//! * Every call into the crate runs under `catch_unwind`; a panic becomes [`GltfError::Panic`].
//! * Buffers come from the GLB BIN chunk, base64 `data:` URIs (size-checked before decoding) or
//!   relative paths read through an [`AssetSource`]; schemes, absolute paths, `..` and bad
//!   percent-encoding are refused.
//! * All buffer views and accessors are bounds-checked up front; vertex data is read by hand.
//! * The node graph is walked iteratively with a depth cap and a visited set, so loops end
//!   with an error; triangle and vertex caps are applied after instancing.
//! * Material values are clamped into range with a warning naming the material.
//!
//! This file holds the public types and [`import_gltf`], which runs the stages in order, each in
//! a file of its own: `container` (GLB or JSON, required extensions, URIs, buffers and buffer
//! views), `accessors` (checked accessor reads), `mesh` (primitives to triangles), `materials`
//! (materials, their extensions and textures) and `nodes` (the node walk, transforms, cameras
//! and lights).

use super::AssetSource;
use super::world::{Light, Material, Mesh};
use gltf::json;
use std::borrow::Cow;
use std::panic::{AssertUnwindSafe, catch_unwind};

mod accessors;
mod container;
mod materials;
mod mesh;
mod nodes;

use accessors::check_accessor;
use container::{check_extensions, check_views, load_buffers, split_container};
use materials::convert_materials;
use nodes::walk_scene;

pub use materials::{DEFAULT_MATERIAL, MaterialInfo};
pub use nodes::LUMENS_PER_WATT;

/// Most warnings kept; further ones are counted in one final line.
const MAX_WARNINGS: usize = 100;

/// Caps applied while importing untrusted glTF.
#[derive(Clone, Debug)]
pub struct GltfLimits {
    /// Most nodes in the file (and most nodes visited in the scene walk).
    pub max_nodes: usize,
    /// Deepest node nesting (a root node is at depth 1).
    pub max_depth: usize,
    /// Most triangles after instancing, over the whole file.
    pub max_triangles: usize,
    /// Most vertices after instancing, over the whole file; also caps the vertex data decoded.
    pub max_vertices: usize,
    /// Largest texture width or height decoded, pixels.
    pub max_texture_side: u32,
    /// Most bytes of buffer data (all buffers together) and of any one image.
    pub max_buffer_bytes: usize,
    /// Most bytes of decoded images (with their working copies) in one file; an image past
    /// it is not decoded (its material keeps its factor, with a warning).
    pub max_image_bytes: u64,
}

impl Default for GltfLimits {
    fn default() -> Self {
        GltfLimits {
            max_nodes: 100_000,
            max_depth: 64,
            max_triangles: 4_000_000,
            max_vertices: 8_000_000,
            max_texture_side: 8192,
            max_buffer_bytes: 256 << 20,
            max_image_bytes: 128 << 20,
        }
    }
}

/// What a glTF file contributes to a scene.
#[derive(Debug, Default)]
pub struct GltfImport {
    /// Meshes in the file's scene space (node transforms applied) with their materials.
    pub parts: Vec<(Mesh, Material)>,
    /// `KHR_lights_punctual` lights in the file's scene space, radiometric: glTF's candela
    /// (point, spot) and lux (directional) divided by [`LUMENS_PER_WATT`].
    pub lights: Vec<Light>,
    /// Perspective cameras (height 256, width from the aspect ratio).
    pub cameras: Vec<super::world::Camera>,
    pub warnings: Vec<String>,
    /// Every material of the file, in file order, whether used or not.
    pub materials: Vec<MaterialInfo>,
}

#[derive(Debug, thiserror::Error)]
pub enum GltfError {
    /// The document is malformed or refers to something missing or out of bounds.
    #[error("{0}")]
    Invalid(String),
    /// The GLB container (header or chunks) is malformed, or the input is neither GLB nor JSON.
    #[error("invalid GLB: {0}")]
    Glb(String),
    /// A buffer or image URI was refused or could not be read.
    #[error("{what}: URI '{uri}' refused: {reason}")]
    Uri {
        what: String,
        uri: String,
        reason: String,
    },
    /// A [`GltfLimits`] cap was exceeded.
    #[error("limit exceeded: {0}")]
    Limit(String),
    /// The process had no room to decode an image in time (try again later).
    #[error("busy: {0}")]
    Busy(String),
    /// The `gltf` crate (or a decoder) panicked on this input.
    #[error("glTF import panicked (malformed input): {0}")]
    Panic(String),
}

fn invalid(m: impl Into<String>) -> GltfError {
    GltfError::Invalid(m.into())
}

fn panic_message(p: Box<dyn std::any::Any + Send>) -> String {
    if let Some(s) = p.downcast_ref::<&str>() {
        (*s).to_string()
    } else if let Some(s) = p.downcast_ref::<String>() {
        s.clone()
    } else {
        "unknown panic".into()
    }
}

/// An [`AssetSource`] that resolves names relative to a folder of another source, so that a
/// `.gltf` in `assets/model/` finds its `model.bin` as `assets/model/model.bin`.
pub struct PrefixedSource<'a> {
    pub inner: &'a dyn AssetSource,
    /// Folder prefix ending in `/`, or empty.
    pub prefix: String,
}

impl<'a> PrefixedSource<'a> {
    /// A source for the files next to `file` (a relative path as written in a scene).
    pub fn beside(inner: &'a dyn AssetSource, file: &str) -> Self {
        let prefix = match file.rfind('/') {
            Some(i) => file[..=i].to_string(),
            None => String::new(),
        };
        PrefixedSource { inner, prefix }
    }
}

impl AssetSource for PrefixedSource<'_> {
    fn read(&self, name: &str, max_bytes: usize) -> Result<Vec<u8>, String> {
        self.inner
            .read(&format!("{}{name}", self.prefix), max_bytes)
    }
}

/// Import a glTF from bytes. Relative URIs are read through `assets` (None: only embedded
/// data is allowed); absolute, `file:` and network URIs are refused.
pub fn import_gltf(
    bytes: &[u8],
    limits: &GltfLimits,
    assets: Option<&dyn AssetSource>,
) -> Result<GltfImport, GltfError> {
    catch_unwind(AssertUnwindSafe(|| import_inner(bytes, limits, assets)))
        .unwrap_or_else(|p| Err(GltfError::Panic(panic_message(p))))
}

/// Mutable state of one import: warnings and the decode budget.
struct State<'a> {
    limits: &'a GltfLimits,
    assets: Option<&'a dyn AssetSource>,
    warnings: Vec<String>,
    suppressed: usize,
    /// Vertex attribute / index elements decoded so far.
    decoded: usize,
    /// What is left of [`GltfLimits::max_image_bytes`].
    image_bytes_left: u64,
}

impl State<'_> {
    fn warn(&mut self, w: String) {
        if self.warnings.len() < MAX_WARNINGS {
            self.warnings.push(w);
        } else {
            self.suppressed += 1;
        }
    }

    /// Account for `n` elements about to be decoded.
    fn decode_budget(&mut self, n: usize, what: &str) -> Result<(), GltfError> {
        let cap = self
            .limits
            .max_vertices
            .saturating_mul(2)
            .saturating_add(self.limits.max_triangles.saturating_mul(6));
        self.decoded = self.decoded.saturating_add(n);
        if self.decoded > cap {
            return Err(GltfError::Limit(format!(
                "{what}: more than {cap} vertex and index elements decoded in total"
            )));
        }
        Ok(())
    }
}

/// The parsed document and its buffers' bytes.
struct Doc<'a> {
    root: &'a json::Root,
    buffers: Vec<Cow<'a, [u8]>>,
}

fn import_inner(
    bytes: &[u8],
    limits: &GltfLimits,
    assets: Option<&dyn AssetSource>,
) -> Result<GltfImport, GltfError> {
    let mut st = State {
        limits,
        assets,
        warnings: Vec::new(),
        suppressed: 0,
        decoded: 0,
        image_bytes_left: limits.max_image_bytes,
    };
    let (json_bytes, bin) = split_container(bytes, &mut st)?;
    let gltf = catch_unwind(AssertUnwindSafe(|| {
        gltf::Gltf::from_slice_without_validation(json_bytes)
    }))
    .map_err(|p| GltfError::Panic(panic_message(p)))?
    .map_err(|e| invalid(format!("invalid glTF JSON: {e}")))?;
    let root = gltf.document.into_json();
    if !root.asset.version.starts_with("2.") {
        return Err(invalid(format!(
            "asset.version is '{}'; only glTF 2.x is supported",
            root.asset.version
        )));
    }
    check_extensions(&root, &mut st)?;
    if root.nodes.len() > limits.max_nodes {
        return Err(GltfError::Limit(format!(
            "{} nodes, the limit is {}",
            root.nodes.len(),
            limits.max_nodes
        )));
    }
    let buffers = load_buffers(&root, bin, &mut st)?;
    let doc = Doc {
        root: &root,
        buffers,
    };
    check_views(&doc)?;
    for i in 0..root.accessors.len() {
        check_accessor(&doc, i, &mut st)?;
    }
    let materials = convert_materials(&doc, &mut st)?;
    let mut out = walk_scene(&doc, &materials, &mut st)?;
    out.materials = materials;
    if !root.animations.is_empty() {
        st.warn(format!("{} animation(s) ignored", root.animations.len()));
    }
    if !root.skins.is_empty() {
        st.warn(format!(
            "{} skin(s) ignored (meshes are left in bind pose)",
            root.skins.len()
        ));
    }
    if st.suppressed > 0 {
        let n = st.suppressed;
        st.warnings.push(format!("... and {n} more warnings"));
    }
    out.warnings = st.warnings;
    Ok(out)
}
