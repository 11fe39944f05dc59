//! The GPU of a process that renders for itself (the CLI, the examples, the tests): one
//! renderer, made on first use on the adapter `CAUSTICA_BACKEND` / `CAUSTICA_ADAPTER` choose.

use super::{Gpu, MethodError};
use crate::gpu::{GpuConfig, GpuContext};
use crate::render::Renderer;
use std::sync::Mutex;

/// A [`Gpu`] whose renderer is made on first use (or by [`LocalGpu::init`]).
#[derive(Default)]
pub struct LocalGpu(Mutex<Option<Renderer>>);

impl LocalGpu {
    /// Makes the renderer now, where it is not made yet.
    pub fn init(&self) -> anyhow::Result<()> {
        let mut r = self.0.lock().unwrap_or_else(|e| e.into_inner());
        if r.is_none() {
            let ctx = std::sync::Arc::new(GpuContext::new(&GpuConfig::from_env())?);
            *r = Some(Renderer::new(ctx)?);
        }
        Ok(())
    }
}

impl Gpu for LocalGpu {
    fn with_renderer(
        &self,
        f: &mut dyn FnMut(&mut Renderer) -> Result<(), MethodError>,
    ) -> Result<(), MethodError> {
        self.init()
            .map_err(|e| MethodError::NoGpu(format!("{e:#}")))?;
        let mut r = self.0.lock().unwrap_or_else(|e| e.into_inner());
        f(r.as_mut().expect("made by init"))
    }
}
