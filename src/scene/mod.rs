//! Scene model: the JSON description users write ([`types`]), its validation and resolution
//! into a [`World`] ([`load`]), procedural shapes, glTF import and the bounded decoding of input
//! images ([`image`]). No GPU, no HTTP.

pub mod curvature;
pub mod gltf;
pub mod ground;
pub mod image;
pub mod load;
pub mod medium;
pub mod random;
pub mod shape;
pub mod shapes;
pub mod types;
pub mod water;
pub mod world;

pub use load::{
    AssetSource, DirSource, Limits, MapSource, SceneError, load_scene_file, load_scene_json,
    parse_scene, resolve,
};
pub use medium::Medium;
pub use types::SceneDesc;
pub use water::{WaterBody, WaterSurface, Waves};
pub use world::{Camera, EnvMap, EnvSampler, Light, Material, Mesh, Object, Part, World};
