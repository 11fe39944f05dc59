//! The integration tests, as one binary: each module was a file of its own under `tests/`, and
//! so a binary of its own linking wgpu, axum and rusqlite; `support` holds what several of them
//! share. One module alone: `cargo test --test it cli::`.

mod support;

mod beams;
mod cli;
mod clients;
mod cluster;
mod csl_bake;
mod csl_cli;
mod csl_dynamic;
mod csl_gpu;
mod csl_quality;
mod deploy;
mod env_shadows;
mod fuzz_fidelity;
mod glass_accuracy;
mod gltf_import;
mod gpu_direct;
mod gpu_vs_reference;
mod http_api;
mod http_bad_input;
mod http_bakes;
mod http_concurrency;
mod http_fairness;
mod http_hostile;
mod http_keys;
mod http_limits;
mod http_memory;
mod http_no_gpu;
mod http_openapi;
mod http_props;
mod http_render;
mod http_restart;
mod http_storage;
mod photons;
mod pinhole;
mod reference;
mod schema;
mod self_check;
mod shaders_naga;
mod store_suite;
mod transport_bake;
mod transport_render;
mod viewer;
mod water;
