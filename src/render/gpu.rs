//! wgpu rasterizer (`shaders/render.wgsl`): one depth-only pass per shadow
//! layer (`shadow_vs`; six per point light with 90-degree-plus-margin
//! perspective views along +-x, +-y, +-z, one per directional light with an
//! orthographic view over the frame's bounding sphere), then the main pass
//! (`vs_main`/`fs_main`) into an `Rgba16Float` target with a `Depth32Float`
//! buffer, read back as linear radiance. Shadow layers are only allocated
//! for the lights present: a frame without point lights has no cube maps.
//! They are kept between frames and redrawn only when the lights, the
//! geometry or the shadow-map size change (orbiting the camera, switching
//! views or a new indirect result reuse them). Albedo textures are drawn per
//! pixel from storage buffers ([`super::gpu_data`]), uploaded once while
//! the frame's maps stay the same.

pub use super::gpu_data::RenderVertex;
use super::gpu_data::{mesh_data, GpuTextures};
use super::{camera_matrices, up_for, Frame, HdrImage, RenderParams, RenderStats, MAX_LIGHTS};
use crate::error::{Error, Result};
use crate::gpu::buffers::{map_staging, uniform_init};
use crate::gpu::layout::{FrameUniforms, LightGpu, RENDER_WGSL};
use crate::gpu::GpuDevice;
use crate::scene::Light;
use glam::{Mat4, Vec3};
use std::hash::Hasher;
use std::sync::{Arc, Mutex};
use std::time::Instant;
use wgpu::util::DeviceExt;

/// Shadow layers the shader's matrix array holds (8 point lights x 6).
pub const MAX_SHADOW_LAYERS: usize = 56;
const HDR_FORMAT: wgpu::TextureFormat = wgpu::TextureFormat::Rgba16Float;
const DEPTH_FORMAT: wgpu::TextureFormat = wgpu::TextureFormat::Depth32Float;

/// Pipelines on one device, reused for every frame.
pub struct GpuRenderer {
    /// The device the renderer draws on.
    pub dev: Arc<GpuDevice>,
    main: wgpu::RenderPipeline,
    shadow: wgpu::RenderPipeline,
    sampler: wgpu::Sampler,
    /// The last frame's shadow maps and a hash of what they depend on
    /// (shadow matrices and size, positions, triangles): a frame where only
    /// the camera, the view or the indirect light changed reuses them.
    shadow_cache: Mutex<Option<(u64, wgpu::Texture)>>,
    /// The background pass: the sky along every pixel's view ray.
    sky: wgpu::RenderPipeline,
    sky_sampler: wgpu::Sampler,
    /// The last frame's sky image and its key (the sky's description).
    sky_cache: Mutex<Option<(String, wgpu::Texture)>>,
    /// The last frame's albedo textures (reused while the maps are the same).
    texture_cache: Mutex<Option<Arc<GpuTextures>>>,
}

/// Size of the equirectangular image the sky pass samples (the sky baked
/// with rotation and intensity; bilinear, `Rgba16Float`).
const SKY_MAP_SIZE: (u32, u32) = (512, 256);

/// The sky (or black) as an equirectangular radiance texture.
fn sky_texture(d: &wgpu::Device, q: &wgpu::Queue, sky: Option<&crate::sky::Sky>) -> wgpu::Texture {
    let (w, h) = if sky.is_some() { SKY_MAP_SIZE } else { (1, 1) };
    let mut texels = Vec::with_capacity((w * h) as usize);
    let radiance = sky.map(|s| s.radiance_fn());
    for j in 0..h as usize {
        for i in 0..w as usize {
            let l = radiance
                .as_ref()
                .map_or(Vec3::ZERO, |f| f(crate::sky::envmap::pixel_direction(i, j, w as usize, h as usize)));
            texels.push([l.x, l.y, l.z, 1.0].map(half::f16::from_f32));
        }
    }
    let tex = d.create_texture(&wgpu::TextureDescriptor {
        label: Some("sky map"),
        size: wgpu::Extent3d { width: w, height: h, depth_or_array_layers: 1 },
        mip_level_count: 1,
        sample_count: 1,
        dimension: wgpu::TextureDimension::D2,
        format: wgpu::TextureFormat::Rgba16Float,
        usage: wgpu::TextureUsages::TEXTURE_BINDING | wgpu::TextureUsages::COPY_DST,
        view_formats: &[],
    });
    q.write_texture(
        wgpu::TexelCopyTextureInfo {
            texture: &tex,
            mip_level: 0,
            origin: wgpu::Origin3d::ZERO,
            aspect: wgpu::TextureAspect::All,
        },
        bytemuck::cast_slice(&texels),
        wgpu::TexelCopyBufferLayout { offset: 0, bytes_per_row: Some(w * 8), rows_per_image: None },
        wgpu::Extent3d { width: w, height: h, depth_or_array_layers: 1 },
    );
    tex
}

/// Hash of everything the shadow maps depend on.
fn shadow_key(mats: &[[f32; 16]], size: u32, frame: &Frame) -> u64 {
    let mut h = std::collections::hash_map::DefaultHasher::new();
    h.write(bytemuck::cast_slice(mats));
    h.write_u32(size);
    h.write(bytemuck::cast_slice(frame.positions));
    h.write(bytemuck::cast_slice(frame.triangles));
    h.finish()
}

fn vertex_layout(attributes: &[wgpu::VertexAttribute]) -> wgpu::VertexBufferLayout<'_> {
    wgpu::VertexBufferLayout {
        array_stride: std::mem::size_of::<RenderVertex>() as u64,
        step_mode: wgpu::VertexStepMode::Vertex,
        attributes,
    }
}

impl GpuRenderer {
    /// Builds the pipelines on `dev`; an error where the device rejects them.
    pub fn new(dev: Arc<GpuDevice>) -> Result<GpuRenderer> {
        let d = &dev.device;
        let scope = d.push_error_scope(wgpu::ErrorFilter::Validation);
        let module = d.create_shader_module(wgpu::ShaderModuleDescriptor {
            label: Some("render.wgsl"),
            source: wgpu::ShaderSource::Wgsl(RENDER_WGSL.into()),
        });
        let all = wgpu::vertex_attr_array![
            0 => Float32x3, 1 => Float32x3, 2 => Float32x3, 3 => Float32x3, 4 => Float32x3, 5 => Float32x3,
            6 => Float32x2, 7 => Uint32
        ];
        let pos_only = wgpu::vertex_attr_array![0 => Float32x3];
        let main = d.create_render_pipeline(&wgpu::RenderPipelineDescriptor {
            label: Some("render main pipeline"),
            layout: None,
            vertex: wgpu::VertexState {
                module: &module,
                entry_point: Some("vs_main"),
                compilation_options: Default::default(),
                buffers: &[Some(vertex_layout(&all))],
            },
            primitive: wgpu::PrimitiveState { cull_mode: None, ..Default::default() },
            depth_stencil: Some(wgpu::DepthStencilState {
                format: DEPTH_FORMAT,
                depth_write_enabled: Some(true),
                depth_compare: Some(wgpu::CompareFunction::Less),
                stencil: Default::default(),
                bias: Default::default(),
            }),
            multisample: Default::default(),
            fragment: Some(wgpu::FragmentState {
                module: &module,
                entry_point: Some("fs_main"),
                compilation_options: Default::default(),
                targets: &[Some(HDR_FORMAT.into())],
            }),
            multiview_mask: None,
            cache: None,
        });
        let shadow = d.create_render_pipeline(&wgpu::RenderPipelineDescriptor {
            label: Some("render shadow pipeline"),
            layout: None,
            vertex: wgpu::VertexState {
                module: &module,
                entry_point: Some("shadow_vs"),
                compilation_options: Default::default(),
                buffers: &[Some(vertex_layout(&pos_only))],
            },
            primitive: wgpu::PrimitiveState { cull_mode: None, ..Default::default() },
            depth_stencil: Some(wgpu::DepthStencilState {
                format: DEPTH_FORMAT,
                depth_write_enabled: Some(true),
                depth_compare: Some(wgpu::CompareFunction::Less),
                stencil: Default::default(),
                bias: wgpu::DepthBiasState { constant: 0, slope_scale: 0.0, clamp: 0.0 },
            }),
            multisample: Default::default(),
            fragment: None,
            multiview_mask: None,
            cache: None,
        });
        let sky = d.create_render_pipeline(&wgpu::RenderPipelineDescriptor {
            label: Some("render sky pipeline"),
            layout: None,
            vertex: wgpu::VertexState {
                module: &module,
                entry_point: Some("sky_vs"),
                compilation_options: Default::default(),
                buffers: &[],
            },
            primitive: wgpu::PrimitiveState { cull_mode: None, ..Default::default() },
            depth_stencil: Some(wgpu::DepthStencilState {
                format: DEPTH_FORMAT,
                depth_write_enabled: Some(false),
                depth_compare: Some(wgpu::CompareFunction::Always),
                stencil: Default::default(),
                bias: Default::default(),
            }),
            multisample: Default::default(),
            fragment: Some(wgpu::FragmentState {
                module: &module,
                entry_point: Some("sky_fs"),
                compilation_options: Default::default(),
                targets: &[Some(HDR_FORMAT.into())],
            }),
            multiview_mask: None,
            cache: None,
        });
        let sky_sampler = d.create_sampler(&wgpu::SamplerDescriptor {
            label: Some("sky sampler"),
            address_mode_u: wgpu::AddressMode::Repeat,
            address_mode_v: wgpu::AddressMode::ClampToEdge,
            mag_filter: wgpu::FilterMode::Linear,
            min_filter: wgpu::FilterMode::Linear,
            ..Default::default()
        });
        let sampler = d.create_sampler(&wgpu::SamplerDescriptor {
            label: Some("shadow comparison sampler"),
            address_mode_u: wgpu::AddressMode::ClampToEdge,
            address_mode_v: wgpu::AddressMode::ClampToEdge,
            mag_filter: wgpu::FilterMode::Linear,
            min_filter: wgpu::FilterMode::Linear,
            compare: Some(wgpu::CompareFunction::LessEqual),
            ..Default::default()
        });
        if let Some(e) = pollster::block_on(scope.pop()) {
            return Err(Error::Gpu(format!("render pipelines: {e}")));
        }
        Ok(GpuRenderer {
            dev,
            main,
            shadow,
            sampler,
            shadow_cache: Mutex::new(None),
            sky,
            sky_sampler,
            sky_cache: Mutex::new(None),
            texture_cache: Mutex::new(None),
        })
    }

    /// Records the shadow passes and the main pass of `frame` into a new
    /// encoder; returns it with the HDR target (`Rgba16Float`, linear
    /// radiance; usable as a render attachment, copy source and texture).
    pub fn encode(
        &self,
        frame: &Frame,
        params: &RenderParams,
    ) -> Result<(wgpu::CommandEncoder, wgpu::Texture, RenderStats)> {
        frame.validate()?;
        let d = &self.dev.device;
        let (w, h) = (params.width.max(1), params.height.max(1));
        let max_dim = self.dev.limits.max_texture_dimension_2d;
        if w > max_dim || h > max_dim {
            return Err(Error::Setting(format!("render size {w}x{h} exceeds the device limit {max_dim}")));
        }
        let (lo, hi) = frame.bounds();
        let extent = frame.extent();
        let center = (lo + hi) * 0.5;
        let radius = extent * 0.5;

        // Lights and their shadow layers.
        let mut lights = [LightGpu::default(); MAX_LIGHTS];
        let mut mats: Vec<Mat4> = Vec::new();
        let mut stats = RenderStats::default();
        for (i, l) in frame.lights.iter().enumerate() {
            let layer = mats.len() as u32;
            match *l {
                Light::Point { position, intensity } => {
                    lights[i] = LightGpu {
                        position: position.into(),
                        kind: 0,
                        color: intensity.into(),
                        layer,
                        ..Default::default()
                    };
                    let far = (position - center).length() + radius * 1.01;
                    // Slightly wider than 90 degrees so PCF taps at face edges stay inside.
                    let proj = Mat4::perspective_rh(2.0 * 1.05f32.atan(), 1.0, far * 1e-4, far);
                    for dir in [Vec3::X, -Vec3::X, Vec3::Y, -Vec3::Y, Vec3::Z, -Vec3::Z] {
                        mats.push(proj * Mat4::look_to_rh(position, dir, up_for(dir)));
                    }
                    stats.cube_shadow_maps += 1;
                }
                Light::Directional { direction, irradiance } => {
                    lights[i] = LightGpu {
                        position: center.into(),
                        kind: 1,
                        color: irradiance.into(),
                        layer,
                        direction: direction.into(),
                        ..Default::default()
                    };
                    let eye = center - direction * radius * 2.0;
                    let view = Mat4::look_to_rh(eye, direction, up_for(direction));
                    let proj = Mat4::orthographic_rh(-radius, radius, -radius, radius, 0.0, radius * 4.0);
                    mats.push(proj * view);
                    stats.shadow_maps_2d += 1;
                }
            }
        }
        stats.shadow_layers = mats.len() as u32;
        let mut mat_data = [[0f32; 16]; MAX_SHADOW_LAYERS];
        for (m, out) in mats.iter().zip(mat_data.iter_mut()) {
            *out = m.to_cols_array();
        }

        let (view, proj) = camera_matrices(&frame.camera, w as f32 / h as f32, extent * 4.0);
        let shadow_size = params.shadow_size.clamp(16, max_dim);
        let uniforms = FrameUniforms {
            view_proj: (proj * view).to_cols_array(),
            inv_view_proj: (proj * view).inverse().to_cols_array(),
            camera_pos: frame.camera.position.into(),
            light_count: frame.lights.len() as u32,
            view_mode: params.view.mode(),
            normal_offset: params.normal_offset * extent,
            shadow_texel: 1.0 / shadow_size as f32,
            depth_bias: 0.0,
        };

        let (verts, triangles) = mesh_data(frame);
        let vbuf = d.create_buffer_init(&wgpu::util::BufferInitDescriptor {
            label: Some("render vertices"),
            contents: bytemuck::cast_slice(&verts),
            usage: wgpu::BufferUsages::VERTEX,
        });
        let ibuf = d.create_buffer_init(&wgpu::util::BufferInitDescriptor {
            label: Some("render indices"),
            contents: bytemuck::cast_slice(&triangles),
            usage: wgpu::BufferUsages::INDEX,
        });
        let index_count = triangles.len() as u32 * 3;
        let textures = {
            let mut cache = self.texture_cache.lock().unwrap_or_else(|p| p.into_inner());
            match &*cache {
                Some(t) if t.holds(frame.textures) => t.clone(),
                _ => {
                    let limit = self.dev.limits.max_storage_buffer_binding_size.min(self.dev.limits.max_buffer_size);
                    let t = Arc::new(GpuTextures::new(d, frame.textures, limit));
                    *cache = Some(t.clone());
                    t
                }
            }
        };
        let frame_buf = uniform_init(d, "render frame uniforms", &uniforms);
        let light_buf = uniform_init(d, "render lights", &lights);
        let mat_buf = uniform_init(d, "render shadow matrices", &mat_data);

        // Shadow maps: only the layers needed (one placeholder layer when there are none).
        let layers = mats.len().max(1) as u32;
        let size = if mats.is_empty() { 1 } else { shadow_size };
        let key = shadow_key(&mat_data[..mats.len()], size, frame);
        let mut cache = self.shadow_cache.lock().unwrap_or_else(|p| p.into_inner());
        let reuse = matches!(&*cache, Some((k, _)) if *k == key);
        let shadow_tex = match &*cache {
            Some((_, tex)) if reuse => tex.clone(),
            _ => d.create_texture(&wgpu::TextureDescriptor {
                label: Some(if mats.is_empty() { "shadow map placeholder" } else { "shadow maps" }),
                size: wgpu::Extent3d { width: size, height: size, depth_or_array_layers: layers },
                mip_level_count: 1,
                sample_count: 1,
                dimension: wgpu::TextureDimension::D2,
                format: DEPTH_FORMAT,
                usage: wgpu::TextureUsages::RENDER_ATTACHMENT | wgpu::TextureUsages::TEXTURE_BINDING,
                view_formats: &[],
            }),
        };
        *cache = Some((key, shadow_tex.clone()));
        drop(cache);
        stats.shadow_maps_reused = reuse;
        let shadow_array = shadow_tex.create_view(&wgpu::TextureViewDescriptor {
            label: Some("shadow maps array view"),
            dimension: Some(wgpu::TextureViewDimension::D2Array),
            ..Default::default()
        });
        let shadow_group = d.create_bind_group(&wgpu::BindGroupDescriptor {
            label: Some("shadow pass bind group"),
            layout: &self.shadow.get_bind_group_layout(0),
            entries: &[wgpu::BindGroupEntry { binding: 2, resource: mat_buf.as_entire_binding() }],
        });
        let main_group = d.create_bind_group(&wgpu::BindGroupDescriptor {
            label: Some("main pass bind group"),
            layout: &self.main.get_bind_group_layout(0),
            entries: &[
                wgpu::BindGroupEntry { binding: 0, resource: frame_buf.as_entire_binding() },
                wgpu::BindGroupEntry { binding: 1, resource: light_buf.as_entire_binding() },
                wgpu::BindGroupEntry { binding: 2, resource: mat_buf.as_entire_binding() },
                wgpu::BindGroupEntry { binding: 3, resource: wgpu::BindingResource::TextureView(&shadow_array) },
                wgpu::BindGroupEntry { binding: 4, resource: wgpu::BindingResource::Sampler(&self.sampler) },
                wgpu::BindGroupEntry { binding: 7, resource: textures.texels.as_entire_binding() },
                wgpu::BindGroupEntry { binding: 8, resource: textures.infos.as_entire_binding() },
            ],
        });

        let sky_key = frame.sky.map_or(String::new(), |s| s.describe());
        let mut cache = self.sky_cache.lock().unwrap_or_else(|p| p.into_inner());
        let sky_tex = match &*cache {
            Some((k, tex)) if *k == sky_key => tex.clone(),
            _ => sky_texture(d, &self.dev.queue, frame.sky),
        };
        *cache = Some((sky_key, sky_tex.clone()));
        drop(cache);
        let sky_view =
            sky_tex.create_view(&wgpu::TextureViewDescriptor { label: Some("sky map view"), ..Default::default() });
        let sky_group = d.create_bind_group(&wgpu::BindGroupDescriptor {
            label: Some("sky pass bind group"),
            layout: &self.sky.get_bind_group_layout(0),
            entries: &[
                wgpu::BindGroupEntry { binding: 0, resource: frame_buf.as_entire_binding() },
                wgpu::BindGroupEntry { binding: 5, resource: wgpu::BindingResource::TextureView(&sky_view) },
                wgpu::BindGroupEntry { binding: 6, resource: wgpu::BindingResource::Sampler(&self.sky_sampler) },
            ],
        });

        let hdr = d.create_texture(&wgpu::TextureDescriptor {
            label: Some("hdr target"),
            size: wgpu::Extent3d { width: w, height: h, depth_or_array_layers: 1 },
            mip_level_count: 1,
            sample_count: 1,
            dimension: wgpu::TextureDimension::D2,
            format: HDR_FORMAT,
            usage: wgpu::TextureUsages::RENDER_ATTACHMENT
                | wgpu::TextureUsages::COPY_SRC
                | wgpu::TextureUsages::TEXTURE_BINDING,
            view_formats: &[],
        });
        let depth = d.create_texture(&wgpu::TextureDescriptor {
            label: Some("depth buffer"),
            size: wgpu::Extent3d { width: w, height: h, depth_or_array_layers: 1 },
            mip_level_count: 1,
            sample_count: 1,
            dimension: wgpu::TextureDimension::D2,
            format: DEPTH_FORMAT,
            usage: wgpu::TextureUsages::RENDER_ATTACHMENT,
            view_formats: &[],
        });
        let hdr_view =
            hdr.create_view(&wgpu::TextureViewDescriptor { label: Some("hdr target view"), ..Default::default() });
        let depth_view =
            depth.create_view(&wgpu::TextureViewDescriptor { label: Some("depth buffer view"), ..Default::default() });

        let mut enc = d.create_command_encoder(&wgpu::CommandEncoderDescriptor { label: Some("render frame") });
        let drawn_layers = if reuse { 0 } else { mats.len() as u32 };
        for layer in 0..drawn_layers {
            let layer_view = shadow_tex.create_view(&wgpu::TextureViewDescriptor {
                label: Some("shadow layer view"),
                dimension: Some(wgpu::TextureViewDimension::D2),
                base_array_layer: layer,
                array_layer_count: Some(1),
                ..Default::default()
            });
            let mut pass = enc.begin_render_pass(&wgpu::RenderPassDescriptor {
                label: Some("shadow pass"),
                color_attachments: &[],
                depth_stencil_attachment: Some(wgpu::RenderPassDepthStencilAttachment {
                    view: &layer_view,
                    depth_ops: Some(wgpu::Operations { load: wgpu::LoadOp::Clear(1.0), store: wgpu::StoreOp::Store }),
                    stencil_ops: None,
                }),
                timestamp_writes: None,
                occlusion_query_set: None,
                multiview_mask: None,
            });
            draw_mesh(&mut pass, &self.shadow, &shadow_group, &vbuf, &ibuf, index_count, layer..layer + 1);
        }
        {
            let mut pass = enc.begin_render_pass(&wgpu::RenderPassDescriptor {
                label: Some("main pass"),
                color_attachments: &[Some(wgpu::RenderPassColorAttachment {
                    view: &hdr_view,
                    depth_slice: None,
                    resolve_target: None,
                    ops: wgpu::Operations {
                        load: wgpu::LoadOp::Clear(wgpu::Color::BLACK),
                        store: wgpu::StoreOp::Store,
                    },
                })],
                depth_stencil_attachment: Some(wgpu::RenderPassDepthStencilAttachment {
                    view: &depth_view,
                    depth_ops: Some(wgpu::Operations { load: wgpu::LoadOp::Clear(1.0), store: wgpu::StoreOp::Discard }),
                    stencil_ops: None,
                }),
                timestamp_writes: None,
                occlusion_query_set: None,
                multiview_mask: None,
            });
            if frame.sky.is_some() {
                pass.set_pipeline(&self.sky);
                pass.set_bind_group(0, &sky_group, &[]);
                pass.draw(0..3, 0..1);
            }
            draw_mesh(&mut pass, &self.main, &main_group, &vbuf, &ibuf, index_count, 0..1);
        }
        Ok((enc, hdr, stats))
    }

    /// Renders `frame` and reads back linear radiance.
    pub fn render(&self, frame: &Frame, params: &RenderParams) -> Result<(HdrImage, RenderStats)> {
        let t0 = Instant::now();
        let d = &self.dev.device;
        let scope = d.push_error_scope(wgpu::ErrorFilter::Validation);
        let (mut enc, hdr, mut stats) = self.encode(frame, params)?;
        let (w, h) = (hdr.width(), hdr.height());
        let row = (w as u64 * 8).next_multiple_of(256);
        let staging = d.create_buffer(&wgpu::BufferDescriptor {
            label: Some("hdr read-back"),
            size: row * h as u64,
            usage: wgpu::BufferUsages::MAP_READ | wgpu::BufferUsages::COPY_DST,
            mapped_at_creation: false,
        });
        enc.copy_texture_to_buffer(
            wgpu::TexelCopyTextureInfo {
                texture: &hdr,
                mip_level: 0,
                origin: wgpu::Origin3d::ZERO,
                aspect: wgpu::TextureAspect::All,
            },
            wgpu::TexelCopyBufferInfo {
                buffer: &staging,
                layout: wgpu::TexelCopyBufferLayout {
                    offset: 0,
                    bytes_per_row: Some(row as u32),
                    rows_per_image: None,
                },
            },
            wgpu::Extent3d { width: w, height: h, depth_or_array_layers: 1 },
        );
        self.dev.queue.submit([enc.finish()]);
        if let Some(e) = pollster::block_on(scope.pop()) {
            return Err(Error::Gpu(format!("render: {e}")));
        }
        let pixels = map_staging(&self.dev, &staging, "render read-back", |data| {
            let mut pixels = Vec::with_capacity((w * h) as usize);
            for y in 0..h as usize {
                let r = &data[y * row as usize..y * row as usize + w as usize * 8];
                for px in r.chunks_exact(8) {
                    let c: [half::f16; 4] = bytemuck::pod_read_unaligned(px);
                    pixels.push(Vec3::new(c[0].to_f32(), c[1].to_f32(), c[2].to_f32()));
                }
            }
            pixels
        })?;
        stats.ms = t0.elapsed().as_secs_f64() * 1e3;
        Ok((HdrImage { width: w, height: h, pixels }, stats))
    }
}

/// Draws the scene mesh (`u32` indices) with `pipeline` and bind group 0.
fn draw_mesh(
    pass: &mut wgpu::RenderPass<'_>,
    pipeline: &wgpu::RenderPipeline,
    group: &wgpu::BindGroup,
    vbuf: &wgpu::Buffer,
    ibuf: &wgpu::Buffer,
    index_count: u32,
    instances: std::ops::Range<u32>,
) {
    pass.set_pipeline(pipeline);
    pass.set_bind_group(0, group, &[]);
    pass.set_vertex_buffer(0, vbuf.slice(..));
    pass.set_index_buffer(ibuf.slice(..), wgpu::IndexFormat::Uint32);
    pass.draw_indexed(0..index_count, 0, instances);
}
