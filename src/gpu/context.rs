//! Headless device acquisition: every adapter wgpu finds (no window, no
//! surface), opened with the largest storage-buffer limits it offers, so
//! batches can be sized from real limits rather than the 128 MiB default.

use crate::error::{Error, Result};
use std::sync::Arc;

use crate::scene::Backend;

/// One opened adapter: device, queue, what it is and the limits it was opened with.
#[derive(Clone, Debug)]
pub struct GpuDevice {
    /// The logical device.
    pub device: wgpu::Device,
    /// Its command queue.
    pub queue: wgpu::Queue,
    /// What the adapter is (name, backend, device type).
    pub info: wgpu::AdapterInfo,
    /// The limits the device was opened with.
    pub limits: wgpu::Limits,
}

impl GpuDevice {
    /// One line describing the adapter: name, backend, device type.
    pub fn describe(&self) -> String {
        format!("{} ({:?}, {:?})", self.info.name, self.info.backend, self.info.device_type)
    }

    /// A device the caller already has (an engine's own), for
    /// [`crate::solver::GpuCompute::new`]: linkgi submits its compute work
    /// to `queue` beside the caller's and uses the limits the device was
    /// opened with (at least 8 storage buffers a shader stage). The
    /// caller's uncaptured-error handler is left as it is.
    pub fn from_wgpu(device: wgpu::Device, queue: wgpu::Queue, info: wgpu::AdapterInfo) -> Result<Arc<GpuDevice>> {
        let limits = device.limits();
        if limits.max_storage_buffers_per_shader_stage < 8 {
            return Err(Error::Gpu(format!(
                "{}: the device allows {} storage buffers a shader stage; linkgi needs 8",
                info.name, limits.max_storage_buffers_per_shader_stage
            )));
        }
        Ok(Arc::new(GpuDevice { device, queue, info, limits }))
    }

    /// True where the device was opened with hardware ray queries
    /// (`EXPERIMENTAL_RAY_QUERY`, the `rq` tracer).
    pub fn ray_query(&self) -> bool {
        self.device.features().contains(wgpu::Features::EXPERIMENTAL_RAY_QUERY)
    }

    /// True for software adapters (lavapipe, llvmpipe, WARP).
    pub fn is_software(&self) -> bool {
        self.info.device_type == wgpu::DeviceType::Cpu
    }

    /// Blocks until all submitted work is done.
    pub fn wait(&self) -> Result<()> {
        self.device
            .poll(wgpu::PollType::wait_indefinitely())
            .map(|_| ())
            .map_err(|e| Error::Gpu(format!("{}: waiting for the device failed: {e}", self.info.name)))
    }
}

/// Opens every adapter found, hardware ones first: Vulkan, Metal and DX12,
/// and OpenGL only when none of those has one (probing GL without a
/// display prints noise). `WGPU_BACKEND` overrides the choice.
/// An empty list means no adapter at all.
pub fn open_all() -> Vec<Arc<GpuDevice>> {
    let from_env = std::env::var_os("WGPU_BACKEND").is_some();
    let mut adapters = Vec::new();
    for backends in [wgpu::Backends::PRIMARY, wgpu::Backends::SECONDARY] {
        if adapters.is_empty() {
            let mut desc = wgpu::InstanceDescriptor::new_without_display_handle_from_env();
            if !from_env {
                desc.backends = backends;
            }
            let instance = wgpu::Instance::new(desc);
            adapters = pollster::block_on(instance.enumerate_adapters(wgpu::Backends::all()));
        }
    }
    // Prefer Vulkan/Metal/DX12 over GL for the same device, hardware first.
    adapters.sort_by_key(|a| {
        let i = a.get_info();
        ((i.device_type == wgpu::DeviceType::Cpu) as u8, (i.backend == wgpu::Backend::Gl) as u8)
    });
    let mut out: Vec<Arc<GpuDevice>> = Vec::new();
    for adapter in adapters {
        let info = adapter.get_info();
        // The same physical device seen through a second API: keep the first.
        if out.iter().any(|d| d.info.name == info.name && d.info.device == info.device) {
            continue;
        }
        if !adapter.get_downlevel_capabilities().flags.contains(wgpu::DownlevelFlags::COMPUTE_SHADERS) {
            continue;
        }
        let offered = adapter.limits();
        let mut limits = wgpu::Limits::default().using_resolution(offered.clone());
        limits.max_storage_buffer_binding_size = offered.max_storage_buffer_binding_size;
        limits.max_buffer_size = offered.max_buffer_size;
        limits.max_storage_buffers_per_shader_stage = offered.max_storage_buffers_per_shader_stage.min(16);
        limits.max_compute_workgroups_per_dimension = offered.max_compute_workgroups_per_dimension;
        if limits.max_storage_buffers_per_shader_stage < 8 {
            continue;
        }
        // Hardware ray queries where the adapter has them (the `rq`
        // tracer); a device that refuses them is opened without.
        let rq = adapter.features().contains(wgpu::Features::EXPERIMENTAL_RAY_QUERY);
        let rq_limits = limits.clone().using_acceleration_structure_values(offered.clone());
        let plain = wgpu::DeviceDescriptor {
            label: Some("linkgi device"),
            required_features: wgpu::Features::empty(),
            required_limits: limits.clone(),
            ..Default::default()
        };
        let with_rq = wgpu::DeviceDescriptor {
            required_features: wgpu::Features::EXPERIMENTAL_RAY_QUERY,
            required_limits: rq_limits.clone(),
            // SAFETY: wgpu asks callers of its experimental features to
            // accept that their implementation may still have bugs; linkgi
            // uses ray queries only through `walk_rq.wgsl`, whose hits the
            // tests check against the CPU's BVH on every run.
            experimental_features: unsafe { wgpu::ExperimentalFeatures::enabled() },
            ..plain.clone()
        };
        let opened =
            if rq { pollster::block_on(adapter.request_device(&with_rq)).map(|d| (d, rq_limits)).ok() } else { None };
        let opened = opened.or_else(|| pollster::block_on(adapter.request_device(&plain)).map(|d| (d, limits)).ok());
        if let Some(((device, queue), limits)) = opened {
            // Errors outside our error scopes are reported, not turned into panics.
            let name = info.name.clone();
            device.on_uncaptured_error(Arc::new(move |e| log::error!("GPU error on {name}: {e}")));
            out.push(Arc::new(GpuDevice { device, queue, info, limits }));
        }
    }
    out
}

/// The devices `backend` asks for: empty for the CPU path. `Auto` drops
/// software adapters; `Gpu` with no adapter is an error naming the problem.
pub fn devices_for(backend: Backend) -> Result<Vec<Arc<GpuDevice>>> {
    match backend {
        Backend::Cpu => Ok(Vec::new()),
        Backend::Auto => Ok(open_all().into_iter().filter(|d| !d.is_software()).collect()),
        Backend::Gpu => {
            let all = open_all();
            if all.is_empty() {
                return Err(Error::Gpu(
                    "no graphics adapter found (install a Vulkan driver, e.g. mesa-vulkan-drivers for lavapipe, \
                     or use --backend cpu)"
                        .into(),
                ));
            }
            Ok(all)
        }
    }
}
