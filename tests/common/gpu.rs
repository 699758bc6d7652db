//! The GPU tests' device: the first adapter wgpu finds, opened once.
//! With none, tests fail when `CI` is set (CI installs lavapipe) and skip
//! with a message otherwise.

use linkgi::gpu::{self, GpuDevice};
use std::sync::{Arc, OnceLock};

/// The device, or `None` (skip) outside CI when there is none.
pub fn device() -> Option<Arc<GpuDevice>> {
    static DEV: OnceLock<Option<Arc<GpuDevice>>> = OnceLock::new();
    DEV.get_or_init(|| {
        let d = gpu::open_all().into_iter().next();
        match &d {
            Some(d) => eprintln!("GPU tests on {} (ray queries: {})", d.describe(), d.ray_query()),
            None if std::env::var_os("CI").is_some() => {
                panic!("no graphics adapter in CI: install mesa-vulkan-drivers (lavapipe)")
            }
            None => eprintln!("SKIPPED: no graphics adapter (install mesa-vulkan-drivers for lavapipe)"),
        }
        d
    })
    .clone()
}
