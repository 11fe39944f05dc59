//! The one way the tests get a GPU: a fresh [`GpuContext`] per call on the adapter
//! `CAUSTICA_BACKEND` / `CAUSTICA_ADAPTER` choose (lavapipe in CI). A test that needs a GPU
//! fails without one, it never skips.

use caustica::gpu::{GpuConfig, GpuContext};
use caustica::render::Renderer;
use std::sync::{Arc, OnceLock};

/// Gives the process an `XDG_RUNTIME_DIR` when it has none (the windowing-system probes of
/// the adapter search complain without one), before anything in this process creates a GPU
/// context: [`context`] and the in-process server ([`super::server::Server::start_in`], whose
/// GPU worker makes its own) call this first. The variable is set at most once per process,
/// behind a `OnceLock`: tests on other threads that get here wait until it is set, and no GPU
/// code (the only reader of the variable) runs before; other readers of the environment in
/// Rust go through `std::env`, which serialises with `set_var`.
pub fn ensure_runtime_dir() {
    static DONE: OnceLock<()> = OnceLock::new();
    DONE.get_or_init(|| {
        if std::env::var_os("XDG_RUNTIME_DIR").is_some() {
            return;
        }
        let dir = std::env::temp_dir().join(format!("caustica-xdg-{}", std::process::id()));
        let _ = std::fs::create_dir_all(&dir);
        #[cfg(unix)]
        {
            use std::os::unix::fs::PermissionsExt;
            let _ = std::fs::set_permissions(&dir, std::fs::Permissions::from_mode(0o700));
        }
        // SAFETY: the only write to the environment in this test binary (children get theirs
        // with `Command::env`), made once, before any GPU code of this process runs (see
        // above).
        unsafe { std::env::set_var("XDG_RUNTIME_DIR", &dir) };
    });
}

/// A fresh context; panics (the test fails) without an adapter.
pub fn context() -> Arc<GpuContext> {
    ensure_runtime_dir();
    let ctx = GpuContext::new(&GpuConfig::default())
        .expect("a GPU adapter is required (CI installs lavapipe: mesa-vulkan-drivers)");
    eprintln!("adapter: {}", ctx.adapter_info());
    Arc::new(ctx)
}

/// A renderer on a fresh [`context`].
pub fn renderer() -> Renderer {
    Renderer::new(context()).expect("renderer")
}
