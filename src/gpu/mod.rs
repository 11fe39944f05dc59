//! Headless wgpu device: adapter choice (hardware first, then the software fallback), error
//! scopes instead of panics, device-loss detection and recreation, and texture readback with
//! the 256-byte row padding wgpu requires.
//!
//! One [`GpuContext`] is meant to be shared behind an `Arc` by the GPU workers; the device it
//! holds can be replaced (after a loss) without the owner noticing, except through
//! [`GpuContext::generation`], which tells caches (pipelines, textures) to rebuild.

use std::sync::atomic::{AtomicBool, Ordering};
use std::sync::{Arc, Mutex, RwLock};

/// Which adapter to use. `None` fields fall back to the environment (`CAUSTICA_BACKEND`,
/// `CAUSTICA_ADAPTER`), then to "any backend, best adapter".
#[derive(Clone, Debug, Default, PartialEq, Eq)]
pub struct GpuConfig {
    /// "vulkan", "gl" or "any" (case-insensitive).
    pub backend: Option<String>,
    /// Case-insensitive substring of the adapter name, e.g. "llvmpipe" or "nvidia".
    pub adapter: Option<String>,
}

impl GpuConfig {
    /// Only the environment: `CAUSTICA_BACKEND`, `CAUSTICA_ADAPTER`.
    pub fn from_env() -> Self {
        GpuConfig::default().with_env()
    }

    /// Fills the fields left `None` from the environment; explicit values win.
    pub fn with_env(mut self) -> Self {
        let var = |k: &str| std::env::var(k).ok().filter(|v| !v.trim().is_empty());
        if self.backend.is_none() {
            self.backend = var("CAUSTICA_BACKEND");
        }
        if self.adapter.is_none() {
            self.adapter = var("CAUSTICA_ADAPTER");
        }
        self
    }

    /// The wgpu backends this configuration allows.
    pub fn backends(&self) -> Result<wgpu::Backends, GpuError> {
        match self
            .backend
            .as_deref()
            .map(str::to_ascii_lowercase)
            .as_deref()
        {
            None | Some("any") | Some("") => Ok(wgpu::Backends::VULKAN | wgpu::Backends::GL),
            Some("vulkan") | Some("vk") => Ok(wgpu::Backends::VULKAN),
            Some("gl") | Some("gles") | Some("opengl") => Ok(wgpu::Backends::GL),
            Some(other) => Err(GpuError::Config(format!(
                "unknown backend {other:?}: expected \"vulkan\", \"gl\" or \"any\""
            ))),
        }
    }
}

/// Errors of the GPU layer. Validation errors carry wgpu's message.
#[derive(Debug, thiserror::Error)]
pub enum GpuError {
    #[error("invalid GPU configuration: {0}")]
    Config(String),
    #[error("no GPU adapter found ({0})")]
    NoAdapter(String),
    #[error("could not create a device on {adapter}: {message}")]
    RequestDevice { adapter: String, message: String },
    #[error("GPU validation error: {0}")]
    Validation(String),
    #[error("GPU out of memory")]
    OutOfMemory,
    #[error("GPU internal error: {0}")]
    Internal(String),
    #[error("GPU device lost: {0}")]
    Lost(String),
    #[error("buffer mapping failed: {0}")]
    Map(String),
    #[error("unsupported: {0}")]
    Unsupported(String),
}

/// Mesa's `LP_MAX_TGSI_LOOP_ITERATIONS`: see [`GpuContext::loop_budget`].
pub const LLVMPIPE_LOOP_ITERATIONS: u32 = 65535;

/// What the service reports about the adapter in use.
#[derive(Clone, Debug, PartialEq, Eq)]
pub struct AdapterSummary {
    pub name: String,
    /// "vulkan", "gl", ...
    pub backend: String,
    pub driver: String,
    pub driver_info: String,
    /// "DiscreteGpu", "Cpu", ...
    pub device_type: String,
}

impl std::fmt::Display for AdapterSummary {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        write!(
            f,
            "{} ({}, {} {})",
            self.name, self.backend, self.driver, self.driver_info
        )
    }
}

/// A device and its queue at one point in time; `generation` changes when the device is
/// recreated after a loss.
#[derive(Clone, Debug)]
pub struct DeviceHandle {
    pub device: wgpu::Device,
    pub queue: wgpu::Queue,
    pub generation: u64,
}

struct DeviceState {
    handle: DeviceHandle,
    lost: Arc<AtomicBool>,
}

/// The headless GPU: adapter, device, queue, error and loss handling.
pub struct GpuContext {
    adapter: wgpu::Adapter,
    summary: AdapterSummary,
    features: wgpu::Features,
    state: RwLock<DeviceState>,
    /// Errors no scope caught (reported by the uncaptured-error handler instead of a panic).
    uncaptured: Arc<Mutex<Vec<String>>>,
}

/// Features used when the adapter has them.
const WANTED_FEATURES: wgpu::Features = wgpu::Features::TIMESTAMP_QUERY
    .union(wgpu::Features::TIMESTAMP_QUERY_INSIDE_ENCODERS)
    .union(wgpu::Features::FLOAT32_BLENDABLE)
    .union(wgpu::Features::SHADER_EARLY_DEPTH_TEST);

fn type_rank(t: wgpu::DeviceType) -> u32 {
    match t {
        wgpu::DeviceType::DiscreteGpu => 0,
        wgpu::DeviceType::IntegratedGpu => 1,
        wgpu::DeviceType::VirtualGpu => 2,
        wgpu::DeviceType::Other => 3,
        wgpu::DeviceType::Cpu => 4,
    }
}

fn summarize(info: &wgpu::AdapterInfo) -> AdapterSummary {
    AdapterSummary {
        name: info.name.clone(),
        backend: info.backend.to_string(),
        driver: info.driver.clone(),
        driver_info: info.driver_info.clone(),
        device_type: format!("{:?}", info.device_type),
    }
}

impl GpuContext {
    /// Picks an adapter (hardware before software, Vulkan before GL, filtered by the
    /// configured name) and creates a device on it.
    pub fn new(config: &GpuConfig) -> Result<GpuContext, GpuError> {
        let config = config.clone().with_env();
        let backends = config.backends()?;
        let mut desc = wgpu::InstanceDescriptor::new_without_display_handle();
        desc.backends = backends;
        let instance = wgpu::Instance::new(desc);

        let mut adapters = pollster::block_on(instance.enumerate_adapters(backends));
        if adapters.is_empty() {
            // Some loaders only hand out the software adapter when asked for the fallback.
            if let Ok(a) =
                pollster::block_on(instance.request_adapter(&wgpu::RequestAdapterOptions {
                    power_preference: wgpu::PowerPreference::HighPerformance,
                    force_fallback_adapter: true,
                    compatible_surface: None,
                    apply_limit_buckets: false,
                }))
            {
                adapters.push(a);
            }
        }
        let found: Vec<String> = adapters
            .iter()
            .map(|a| summarize(&a.get_info()).to_string())
            .collect();
        if let Some(want) = config.adapter.as_deref() {
            let want = want.to_lowercase();
            adapters.retain(|a| a.get_info().name.to_lowercase().contains(&want));
            if adapters.is_empty() {
                return Err(GpuError::NoAdapter(format!(
                    "none matches {want:?}; available: [{}]",
                    found.join("; ")
                )));
            }
        }
        if adapters.is_empty() {
            return Err(GpuError::NoAdapter(format!(
                "backends {backends:?}: none available"
            )));
        }
        adapters.sort_by_key(|a| {
            let info = a.get_info();
            let backend_rank = u32::from(info.backend != wgpu::Backend::Vulkan);
            (type_rank(info.device_type), backend_rank)
        });

        let mut last_err = None;
        for adapter in adapters {
            match Self::create_device(&adapter, 0) {
                Ok((state, features)) => {
                    let summary = summarize(&adapter.get_info());
                    tracing::info!(adapter = %summary, "GPU device created");
                    let ctx = GpuContext {
                        adapter,
                        summary,
                        features,
                        state: RwLock::new(state),
                        uncaptured: Arc::new(Mutex::new(Vec::new())),
                    };
                    ctx.install_error_handler();
                    return Ok(ctx);
                }
                Err(e) => last_err = Some(e),
            }
        }
        Err(last_err
            .unwrap_or_else(|| GpuError::NoAdapter("no adapter could create a device".into())))
    }

    fn create_device(
        adapter: &wgpu::Adapter,
        generation: u64,
    ) -> Result<(DeviceState, wgpu::Features), GpuError> {
        let features = adapter.features() & WANTED_FEATURES;
        let info = adapter.get_info();
        let (device, queue) = pollster::block_on(adapter.request_device(&wgpu::DeviceDescriptor {
            label: Some("caustica"),
            required_features: features,
            required_limits: adapter.limits(),
            experimental_features: wgpu::ExperimentalFeatures::disabled(),
            memory_hints: wgpu::MemoryHints::Performance,
            trace: wgpu::Trace::Off,
        }))
        .map_err(|e| GpuError::RequestDevice {
            adapter: info.name.clone(),
            message: e.to_string(),
        })?;
        let lost = Arc::new(AtomicBool::new(false));
        let flag = lost.clone();
        device.set_device_lost_callback(move |reason, msg| {
            tracing::warn!(?reason, %msg, "GPU device lost");
            flag.store(true, Ordering::SeqCst);
        });
        Ok((
            DeviceState {
                handle: DeviceHandle {
                    device,
                    queue,
                    generation,
                },
                lost,
            },
            features,
        ))
    }

    fn install_error_handler(&self) {
        let sink = self.uncaptured.clone();
        let st = self.state.read().unwrap_or_else(|e| e.into_inner());
        st.handle
            .device
            .on_uncaptured_error(Arc::new(move |e: wgpu::Error| {
                tracing::error!(error = %e, "uncaptured GPU error");
                let mut v = sink.lock().unwrap_or_else(|e| e.into_inner());
                if v.len() < 64 {
                    v.push(e.to_string());
                }
            }));
    }

    pub fn adapter_info(&self) -> &AdapterSummary {
        &self.summary
    }

    /// Optional features the device was created with.
    pub fn features(&self) -> wgpu::Features {
        self.features
    }

    /// The loop iterations one shader invocation may make, all its loops together, before
    /// the driver ends them: llvmpipe (lavapipe) stops every loop of an invocation after 65535
    /// iterations in all (Mesa's `LP_MAX_TGSI_LOOP_ITERATIONS`) and reports nothing; other
    /// adapters have no such limit (`u32::MAX`). Passes with long per-pixel loops split their
    /// work into draws that stay under it.
    pub fn loop_budget(&self) -> u32 {
        let s = &self.summary;
        if s.name.to_lowercase().contains("llvmpipe")
            || s.driver.to_lowercase().contains("llvmpipe")
        {
            LLVMPIPE_LOOP_ITERATIONS
        } else {
            u32::MAX
        }
    }

    pub fn has_timestamps(&self) -> bool {
        self.features.contains(wgpu::Features::TIMESTAMP_QUERY)
    }

    /// The current device (may be a lost one; see [`GpuContext::ensure_device`]).
    pub fn handle(&self) -> DeviceHandle {
        self.state
            .read()
            .unwrap_or_else(|e| e.into_inner())
            .handle
            .clone()
    }

    pub fn device(&self) -> wgpu::Device {
        self.handle().device
    }

    pub fn queue(&self) -> wgpu::Queue {
        self.handle().queue
    }

    /// Increases each time the device is recreated.
    pub fn generation(&self) -> u64 {
        self.handle().generation
    }

    /// True once the current device has reported a loss (its calls then fail silently).
    pub fn is_lost(&self) -> bool {
        let st = self.state.read().unwrap_or_else(|e| e.into_inner());
        // Loss callbacks are delivered while polling.
        let _ = st.handle.device.poll(wgpu::PollType::Poll);
        st.lost.load(Ordering::SeqCst)
    }

    /// Marks the current device as lost, so that the next [`GpuContext::ensure_device`]
    /// recreates it (for failures detected by other means).
    pub fn mark_lost(&self) {
        self.state
            .read()
            .unwrap_or_else(|e| e.into_inner())
            .lost
            .store(true, Ordering::SeqCst);
    }

    /// A usable device: the current one, or a new one if it was lost.
    pub fn ensure_device(&self) -> Result<DeviceHandle, GpuError> {
        if !self.is_lost() {
            return Ok(self.handle());
        }
        let mut st = self.state.write().unwrap_or_else(|e| e.into_inner());
        if !st.lost.load(Ordering::SeqCst) {
            return Ok(st.handle.clone()); // another thread recreated it
        }
        let generation = st.handle.generation + 1;
        tracing::warn!(generation, "recreating lost GPU device");
        let (new_state, _) = Self::create_device(&self.adapter, generation)?;
        *st = new_state;
        drop(st);
        self.install_error_handler();
        Ok(self.handle())
    }

    /// Runs `f` inside validation, out-of-memory and internal error scopes and turns what they
    /// caught into a [`GpuError`]. Scopes are per thread: `f` must do its GPU calls on this one.
    pub fn scoped<T>(&self, device: &wgpu::Device, f: impl FnOnce() -> T) -> Result<T, GpuError> {
        let internal = device.push_error_scope(wgpu::ErrorFilter::Internal);
        let oom = device.push_error_scope(wgpu::ErrorFilter::OutOfMemory);
        let validation = device.push_error_scope(wgpu::ErrorFilter::Validation);
        let out = f();
        let v = pollster::block_on(validation.pop());
        let o = pollster::block_on(oom.pop());
        let i = pollster::block_on(internal.pop());
        if let Some(e) = o {
            let _ = e;
            return Err(GpuError::OutOfMemory);
        }
        if let Some(e) = v {
            return Err(if self.is_lost() {
                GpuError::Lost(e.to_string())
            } else {
                GpuError::Validation(e.to_string())
            });
        }
        if let Some(e) = i {
            return Err(GpuError::Internal(e.to_string()));
        }
        if self.is_lost() {
            return Err(GpuError::Lost("device reported lost".into()));
        }
        Ok(out)
    }

    /// Errors that no scope caught since the last call (normally empty).
    pub fn take_uncaptured_errors(&self) -> Vec<String> {
        std::mem::take(&mut *self.uncaptured.lock().unwrap_or_else(|e| e.into_inner()))
    }

    /// Copies an `Rgba32Float` 2D texture (usage COPY_SRC) to the CPU, row 0 first, for any
    /// width: rows are padded to 256 bytes in the staging buffer and unpadded here.
    pub fn readback_rgba32f(&self, texture: &wgpu::Texture) -> Result<Vec<[f32; 4]>, GpuError> {
        if texture.format() != wgpu::TextureFormat::Rgba32Float {
            return Err(GpuError::Unsupported(format!(
                "readback_rgba32f on a {:?} texture",
                texture.format()
            )));
        }
        let h = self.handle();
        let (w, ht) = (texture.width(), texture.height());
        let row = w as u64 * 16;
        let padded = row.div_ceil(wgpu::COPY_BYTES_PER_ROW_ALIGNMENT as u64)
            * wgpu::COPY_BYTES_PER_ROW_ALIGNMENT as u64;
        let size = padded * ht as u64;
        let buffer = self.scoped(&h.device, || {
            let buffer = h.device.create_buffer(&wgpu::BufferDescriptor {
                label: Some("readback"),
                size,
                usage: wgpu::BufferUsages::COPY_DST | wgpu::BufferUsages::MAP_READ,
                mapped_at_creation: false,
            });
            let mut enc = h
                .device
                .create_command_encoder(&wgpu::CommandEncoderDescriptor {
                    label: Some("readback"),
                });
            encode_texture_copy(&mut enc, texture, &buffer, padded as u32);
            h.queue.submit([enc.finish()]);
            buffer
        })?;
        let bytes = self.map_read(&h.device, &buffer)?;
        let mut out = Vec::with_capacity((w * ht) as usize);
        for y in 0..ht as usize {
            let start = y * padded as usize;
            let line: &[f32] = bytemuck::cast_slice(&bytes[start..start + row as usize]);
            out.extend(line.chunks_exact(4).map(|c| [c[0], c[1], c[2], c[3]]));
        }
        Ok(out)
    }

    /// Maps every MAP_READ buffer of `buffers` with one wait for the device, hands `f` each
    /// one's bytes (its index and the mapped range, read in place) and unmaps them.
    pub fn map_read_each(
        &self,
        device: &wgpu::Device,
        buffers: &[&wgpu::Buffer],
        mut f: impl FnMut(usize, &[u8]),
    ) -> Result<(), GpuError> {
        let (tx, rx) = std::sync::mpsc::channel();
        for (i, b) in buffers.iter().enumerate() {
            let tx = tx.clone();
            b.slice(..).map_async(wgpu::MapMode::Read, move |r| {
                let _ = tx.send((i, r));
            });
        }
        drop(tx);
        device
            .poll(wgpu::PollType::wait_indefinitely())
            .map_err(|e| GpuError::Lost(format!("poll: {e}")))?;
        let mut mapped = vec![false; buffers.len()];
        let mut failed = None;
        for (i, r) in rx.try_iter() {
            match r {
                Ok(()) => mapped[i] = true,
                Err(e) => failed = Some(e.to_string()),
            }
        }
        let result = match (failed, mapped.iter().all(|m| *m)) {
            (Some(e), _) if self.is_lost() => Err(GpuError::Lost(e)),
            (Some(e), _) => Err(GpuError::Map(e)),
            (None, false) if self.is_lost() => Err(GpuError::Lost("map callback never ran".into())),
            (None, false) => Err(GpuError::Map("map callback never ran".into())),
            (None, true) => {
                let mut r = Ok(());
                for (i, b) in buffers.iter().enumerate() {
                    match b.slice(..).get_mapped_range() {
                        Ok(bytes) => f(i, &bytes),
                        Err(e) => {
                            r = Err(GpuError::Map(e.to_string()));
                            break;
                        }
                    }
                }
                r
            }
        };
        for (b, m) in buffers.iter().zip(&mapped) {
            if *m {
                b.unmap();
            }
        }
        result
    }

    /// Maps a MAP_READ buffer, waits for it and returns a copy of its bytes.
    pub fn map_read(
        &self,
        device: &wgpu::Device,
        buffer: &wgpu::Buffer,
    ) -> Result<Vec<u8>, GpuError> {
        let slice = buffer.slice(..);
        let (tx, rx) = std::sync::mpsc::channel();
        slice.map_async(wgpu::MapMode::Read, move |r| {
            let _ = tx.send(r);
        });
        device
            .poll(wgpu::PollType::wait_indefinitely())
            .map_err(|e| GpuError::Lost(format!("poll: {e}")))?;
        match rx.try_recv() {
            Ok(Ok(())) => {}
            Ok(Err(e)) => {
                return Err(if self.is_lost() {
                    GpuError::Lost(e.to_string())
                } else {
                    GpuError::Map(e.to_string())
                });
            }
            Err(_) => {
                return Err(if self.is_lost() {
                    GpuError::Lost("map callback never ran".into())
                } else {
                    GpuError::Map("map callback never ran".into())
                });
            }
        }
        let bytes = slice
            .get_mapped_range()
            .map_err(|e| GpuError::Map(e.to_string()))?
            .to_vec();
        buffer.unmap();
        Ok(bytes)
    }
}

/// Records a copy of the whole of 2D `texture` (one mip level) into `buffer` from its start,
/// rows `padded` bytes apart (a multiple of 256).
pub fn encode_texture_copy(
    enc: &mut wgpu::CommandEncoder,
    texture: &wgpu::Texture,
    buffer: &wgpu::Buffer,
    padded: u32,
) {
    enc.copy_texture_to_buffer(
        wgpu::TexelCopyTextureInfo {
            texture,
            mip_level: 0,
            origin: wgpu::Origin3d::ZERO,
            aspect: wgpu::TextureAspect::All,
        },
        wgpu::TexelCopyBufferInfo {
            buffer,
            layout: wgpu::TexelCopyBufferLayout {
                offset: 0,
                bytes_per_row: Some(padded),
                rows_per_image: Some(texture.height()),
            },
        },
        wgpu::Extent3d {
            width: texture.width(),
            height: texture.height(),
            depth_or_array_layers: 1,
        },
    );
}

impl std::fmt::Debug for GpuContext {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.debug_struct("GpuContext")
            .field("adapter", &self.summary)
            .field("features", &self.features)
            .field("generation", &self.generation())
            .finish()
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn backend_names() {
        let c = |b: &str| GpuConfig {
            backend: Some(b.into()),
            adapter: None,
        };
        assert_eq!(c("Vulkan").backends().unwrap(), wgpu::Backends::VULKAN);
        assert_eq!(c("gl").backends().unwrap(), wgpu::Backends::GL);
        assert!(c("metal").backends().is_err());
    }

    fn _assert_send_sync() {
        fn is<T: Send + Sync>() {}
        is::<GpuContext>();
    }
}
