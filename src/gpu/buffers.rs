//! Buffer creation, 2D dispatch sizing and read-back shared by the GPU stages.

use super::context::GpuDevice;
use crate::error::{Error, Result};
use bytemuck::Pod;
use wgpu::util::DeviceExt;

/// A labelled storage buffer holding `data` (at least 16 bytes, so empty
/// arrays still bind).
pub fn storage_init<T: Pod>(d: &wgpu::Device, label: &str, data: &[T]) -> wgpu::Buffer {
    let mut bytes = bytemuck::cast_slice::<T, u8>(data).to_vec();
    bytes.resize(bytes.len().max(16).next_multiple_of(4), 0);
    d.create_buffer_init(&wgpu::util::BufferInitDescriptor {
        label: Some(label),
        contents: &bytes,
        usage: wgpu::BufferUsages::STORAGE | wgpu::BufferUsages::COPY_DST | wgpu::BufferUsages::COPY_SRC,
    })
}

/// A labelled uniform buffer holding `value`.
pub fn uniform_init<T: Pod>(d: &wgpu::Device, label: &str, value: &T) -> wgpu::Buffer {
    d.create_buffer_init(&wgpu::util::BufferInitDescriptor {
        label: Some(label),
        contents: bytemuck::bytes_of(value),
        usage: wgpu::BufferUsages::UNIFORM | wgpu::BufferUsages::COPY_DST,
    })
}

/// Workgroups `(x, y)` covering `count` invocations of `workgroup` threads
/// with at most `max_per_dim` along each axis (shaders linearize `x + y * x_count`).
pub fn dispatch_size(count: u32, workgroup: u32, max_per_dim: u32) -> (u32, u32) {
    let groups = count.div_ceil(workgroup).max(1);
    let gx = groups.min(max_per_dim.max(1));
    (gx, groups.div_ceil(gx))
}

/// Submits `enc` plus a copy of `src` into a mapped buffer, waits, and
/// returns the contents as `T`s.
pub fn read_back<T: Pod>(
    dev: &GpuDevice,
    mut enc: wgpu::CommandEncoder,
    src: &wgpu::Buffer,
    label: &str,
) -> Result<Vec<T>> {
    let size = src.size();
    let staging = dev.device.create_buffer(&wgpu::BufferDescriptor {
        label: Some(&format!("{label} read-back")),
        size,
        usage: wgpu::BufferUsages::MAP_READ | wgpu::BufferUsages::COPY_DST,
        mapped_at_creation: false,
    });
    enc.copy_buffer_to_buffer(src, 0, &staging, 0, size);
    dev.queue.submit([enc.finish()]);
    map_staging(dev, &staging, label, |bytes| bytemuck::pod_collect_to_vec::<u8, T>(bytes))
}

/// Maps a `MAP_READ` buffer whose copies are already submitted, waits for
/// the device and hands its bytes to `read` (no intermediate copy); the
/// buffer is unmapped again.
pub fn map_staging<R>(
    dev: &GpuDevice,
    staging: &wgpu::Buffer,
    label: &str,
    read: impl FnOnce(&[u8]) -> R,
) -> Result<R> {
    let (tx, rx) = crossbeam_channel::bounded(1);
    staging.map_async(wgpu::MapMode::Read, .., move |r| {
        let _ = tx.send(r);
    });
    dev.wait()?;
    rx.recv()
        .map_err(|_| Error::Gpu(format!("{label}: mapping never completed")))?
        .map_err(|e| Error::Gpu(format!("{label}: mapping failed: {e}")))?;
    let view = staging.get_mapped_range(..).map_err(|e| Error::Gpu(format!("{label}: {e}")))?;
    let out = read(&view);
    drop(view);
    staging.unmap();
    Ok(out)
}

/// Runs `f` inside validation and out-of-memory error scopes of `dev`, so
/// a failed buffer allocation or binding becomes an [`Error::Gpu`] naming
/// `what` instead of a panic.
pub fn checked<T>(dev: &GpuDevice, what: &str, f: impl FnOnce() -> T) -> Result<T> {
    let oom = dev.device.push_error_scope(wgpu::ErrorFilter::OutOfMemory);
    let validation = dev.device.push_error_scope(wgpu::ErrorFilter::Validation);
    let out = f();
    let v = pollster::block_on(validation.pop());
    let o = pollster::block_on(oom.pop());
    match v.or(o) {
        Some(e) => Err(Error::Gpu(format!("{what} on {}: {e}", dev.info.name))),
        None => Ok(out),
    }
}

/// Compiles `source` once; the returned function builds the compute
/// pipeline of one entry point (labelled with its name, layout from the shader).
pub fn compute_pipelines<'a>(
    d: &'a wgpu::Device,
    label: &str,
    source: impl Into<std::borrow::Cow<'static, str>>,
) -> impl Fn(&str) -> wgpu::ComputePipeline + 'a {
    let module = d.create_shader_module(wgpu::ShaderModuleDescriptor {
        label: Some(label),
        source: wgpu::ShaderSource::Wgsl(source.into()),
    });
    move |entry: &str| {
        d.create_compute_pipeline(&wgpu::ComputePipelineDescriptor {
            label: Some(entry),
            layout: None,
            module: &module,
            entry_point: Some(entry),
            compilation_options: Default::default(),
            cache: None,
        })
    }
}
