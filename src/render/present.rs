//! Display of the HDR target on the GPU, for windows: the tone map of
//! [`super::tone_map`] as a full-screen pass (`shaders/tonemap.wgsl`,
//! `vs_fullscreen`/`fs_tonemap`) into any 8-bit colour target, a swap-chain
//! image included, so a frame reaches the screen without a read-back.
//!
//! `c = ACES(L * exposure)`, then the sRGB curve: in the shader for linear
//! formats (`Bgra8Unorm`, `Rgba8Unorm`), by the hardware on store for the
//! `*Srgb` ones. `L` is linear radiance, W/(m^2 sr); the output is display
//! colour in [0, 1]. The CPU [`super::tone_map`] is the oracle: both agree
//! within one 8-bit step (`tests/render.rs`).

use super::gpu::GpuRenderer;
use super::{Frame, RenderParams, RenderStats};
use crate::error::{Error, Result};
use crate::gpu::buffers::{map_staging, uniform_init};
use crate::gpu::layout::{ToneMapUniforms, TONEMAP_WGSL};
use crate::gpu::GpuDevice;
use std::time::Instant;

/// The display pipeline for one target format.
pub struct ToneMapPass {
    pipeline: wgpu::RenderPipeline,
    format: wgpu::TextureFormat,
}

impl ToneMapPass {
    /// Builds the pipeline writing `format` (an 8-bit RGBA or BGRA format).
    pub fn new(dev: &GpuDevice, format: wgpu::TextureFormat) -> Result<ToneMapPass> {
        let d = &dev.device;
        let scope = d.push_error_scope(wgpu::ErrorFilter::Validation);
        let module = d.create_shader_module(wgpu::ShaderModuleDescriptor {
            label: Some("tonemap.wgsl"),
            source: wgpu::ShaderSource::Wgsl(TONEMAP_WGSL.into()),
        });
        let pipeline = d.create_render_pipeline(&wgpu::RenderPipelineDescriptor {
            label: Some("tone map pipeline"),
            layout: None,
            vertex: wgpu::VertexState {
                module: &module,
                entry_point: Some("vs_fullscreen"),
                compilation_options: Default::default(),
                buffers: &[],
            },
            primitive: Default::default(),
            depth_stencil: None,
            multisample: Default::default(),
            fragment: Some(wgpu::FragmentState {
                module: &module,
                entry_point: Some("fs_tonemap"),
                compilation_options: Default::default(),
                targets: &[Some(format.into())],
            }),
            multiview_mask: None,
            cache: None,
        });
        if let Some(e) = pollster::block_on(scope.pop()) {
            return Err(Error::Gpu(format!("tone map pipeline for {format:?}: {e}")));
        }
        Ok(ToneMapPass { pipeline, format })
    }

    /// The target format the pipeline writes.
    pub fn format(&self) -> wgpu::TextureFormat {
        self.format
    }

    /// Records the pass: `hdr` (linear radiance) tone-mapped into `target`,
    /// which must have this pass's format and the same size.
    pub fn encode(
        &self,
        dev: &GpuDevice,
        enc: &mut wgpu::CommandEncoder,
        hdr: &wgpu::Texture,
        target: &wgpu::TextureView,
        exposure: f32,
    ) {
        let d = &dev.device;
        let uniforms = ToneMapUniforms { exposure, encode_srgb: (!self.format.is_srgb()) as u32, ..Default::default() };
        let ubuf = uniform_init(d, "tone map uniforms", &uniforms);
        let hdr_view =
            hdr.create_view(&wgpu::TextureViewDescriptor { label: Some("tone map input view"), ..Default::default() });
        let group = d.create_bind_group(&wgpu::BindGroupDescriptor {
            label: Some("tone map bind group"),
            layout: &self.pipeline.get_bind_group_layout(0),
            entries: &[
                wgpu::BindGroupEntry { binding: 0, resource: ubuf.as_entire_binding() },
                wgpu::BindGroupEntry { binding: 1, resource: wgpu::BindingResource::TextureView(&hdr_view) },
            ],
        });
        let mut pass = enc.begin_render_pass(&wgpu::RenderPassDescriptor {
            label: Some("tone map pass"),
            color_attachments: &[Some(wgpu::RenderPassColorAttachment {
                view: target,
                depth_slice: None,
                resolve_target: None,
                ops: wgpu::Operations { load: wgpu::LoadOp::Clear(wgpu::Color::BLACK), store: wgpu::StoreOp::Store },
            })],
            depth_stencil_attachment: None,
            timestamp_writes: None,
            occlusion_query_set: None,
            multiview_mask: None,
        });
        pass.set_pipeline(&self.pipeline);
        pass.set_bind_group(0, &group, &[]);
        pass.draw(0..3, 0..1);
    }
}

impl GpuRenderer {
    /// Renders `frame`, tone-maps it into each of `targets` (views of
    /// `pass.format()` textures of the frame's size) and calls `overlay` with
    /// each target's index after its tone map (egui, markers), then submits. No read-back.
    pub fn present(
        &self,
        frame: &Frame,
        params: &RenderParams,
        pass: &ToneMapPass,
        targets: &[&wgpu::TextureView],
        mut overlay: impl FnMut(&mut wgpu::CommandEncoder, usize, &wgpu::TextureView) -> Result<()>,
    ) -> Result<RenderStats> {
        let t0 = Instant::now();
        let scope = self.dev.device.push_error_scope(wgpu::ErrorFilter::Validation);
        let (mut enc, hdr, mut stats) = self.encode(frame, params)?;
        for (i, target) in targets.iter().enumerate() {
            pass.encode(&self.dev, &mut enc, &hdr, target, params.exposure);
            overlay(&mut enc, i, target)?;
        }
        self.dev.queue.submit([enc.finish()]);
        if let Some(e) = pollster::block_on(scope.pop()) {
            return Err(Error::Gpu(format!("presenting a frame: {e}")));
        }
        stats.ms = t0.elapsed().as_secs_f64() * 1e3;
        Ok(stats)
    }
}

/// An offscreen 8-bit target for [`GpuRenderer::present`] that can be read
/// back (screenshots of a window's content, tests).
pub fn offscreen_target(dev: &GpuDevice, width: u32, height: u32, format: wgpu::TextureFormat) -> wgpu::Texture {
    dev.device.create_texture(&wgpu::TextureDescriptor {
        label: Some("offscreen display target"),
        size: wgpu::Extent3d { width: width.max(1), height: height.max(1), depth_or_array_layers: 1 },
        mip_level_count: 1,
        sample_count: 1,
        dimension: wgpu::TextureDimension::D2,
        format,
        usage: wgpu::TextureUsages::RENDER_ATTACHMENT | wgpu::TextureUsages::COPY_SRC,
        view_formats: &[],
    })
}

/// Reads an 8-bit RGBA or BGRA texture back as RGB rows, top to bottom.
pub fn read_back_rgb8(dev: &GpuDevice, tex: &wgpu::Texture) -> Result<image::RgbImage> {
    let bgra = match tex.format() {
        wgpu::TextureFormat::Rgba8Unorm | wgpu::TextureFormat::Rgba8UnormSrgb => false,
        wgpu::TextureFormat::Bgra8Unorm | wgpu::TextureFormat::Bgra8UnormSrgb => true,
        f => return Err(Error::Gpu(format!("read-back of {f:?} textures is not supported"))),
    };
    let (w, h) = (tex.width(), tex.height());
    let d = &dev.device;
    let row = (w as u64 * 4).next_multiple_of(256);
    let staging = d.create_buffer(&wgpu::BufferDescriptor {
        label: Some("display read-back"),
        size: row * h as u64,
        usage: wgpu::BufferUsages::MAP_READ | wgpu::BufferUsages::COPY_DST,
        mapped_at_creation: false,
    });
    let mut enc = d.create_command_encoder(&wgpu::CommandEncoderDescriptor { label: Some("display read-back") });
    enc.copy_texture_to_buffer(
        wgpu::TexelCopyTextureInfo {
            texture: tex,
            mip_level: 0,
            origin: wgpu::Origin3d::ZERO,
            aspect: wgpu::TextureAspect::All,
        },
        wgpu::TexelCopyBufferInfo {
            buffer: &staging,
            layout: wgpu::TexelCopyBufferLayout { offset: 0, bytes_per_row: Some(row as u32), rows_per_image: None },
        },
        wgpu::Extent3d { width: w, height: h, depth_or_array_layers: 1 },
    );
    dev.queue.submit([enc.finish()]);
    map_staging(dev, &staging, "display read-back", |data| {
        let mut out = image::RgbImage::new(w, h);
        for y in 0..h {
            let r = &data[(y as u64 * row) as usize..];
            for x in 0..w {
                let p = &r[x as usize * 4..x as usize * 4 + 4];
                let rgb = if bgra { [p[2], p[1], p[0]] } else { [p[0], p[1], p[2]] };
                out.put_pixel(x, y, image::Rgb(rgb));
            }
        }
        out
    })
}
