//! The kd-tree on one device and the `shoot_rays` / `light_visibility`
//! pipelines of `shaders/shoot.wgsl`. The tree is uploaded once; each call
//! traces one batch and reads its results back.

use super::buffers::{checked, compute_pipelines, dispatch_size, read_back, storage_init, uniform_init};
use super::context::GpuDevice;
use super::layout::{RayVertex, ShadowRay, TraceParams, SHOOT_WGSL};
use crate::error::Result;
use crate::kdtree::KdTree;
use crate::links::HitRecord;
use glam::Vec3;
use std::sync::Arc;

const WORKGROUP: u32 = 64;

/// A kd-tree resident on one device, ready to trace batches.
pub struct GpuTracer {
    /// The device the tree lives on.
    pub dev: Arc<GpuDevice>,
    shoot: wgpu::ComputePipeline,
    visibility: wgpu::ComputePipeline,
    nodes: wgpu::Buffer,
    leaves: wgpu::Buffer,
    leaf_triangles: wgpu::Buffer,
    triangles: wgpu::Buffer,
    directions: Option<(wgpu::Buffer, u32)>,
    leaf_count: u32,
    root: (Vec3, Vec3),
}

impl GpuTracer {
    /// Uploads `kd` and builds the pipelines.
    pub fn new(dev: Arc<GpuDevice>, kd: &KdTree) -> Result<GpuTracer> {
        let limit = dev.limits.max_storage_buffer_binding_size as usize;
        let biggest = (kd.triangles.len() * std::mem::size_of::<crate::kdtree::KdTriangle>())
            .max(kd.leaves.len() * std::mem::size_of::<crate::kdtree::KdLeaf>())
            .max(kd.leaf_triangles.len() * 4);
        if biggest > limit {
            return Err(crate::Error::Gpu(format!(
                "{}: the kd-tree needs a {biggest}-byte storage binding, the adapter allows {limit}",
                dev.info.name
            )));
        }
        checked(&dev.clone(), "uploading the kd-tree", || Self::upload(dev, kd))?
    }

    fn upload(dev: Arc<GpuDevice>, kd: &KdTree) -> Result<GpuTracer> {
        let device = dev.device.clone();
        let d = &device;
        let pipelines = compute_pipelines(d, "shoot.wgsl", SHOOT_WGSL);
        let pipeline = |entry: &str| pipelines(entry);
        let shoot = pipeline("shoot_rays");
        let visibility = pipeline("light_visibility");
        Ok(GpuTracer {
            nodes: storage_init(d, "kd nodes", &kd.nodes),
            leaves: storage_init(d, "kd leaves", &kd.leaves),
            leaf_triangles: storage_init(d, "kd leaf triangles", &kd.leaf_triangles),
            triangles: storage_init(d, "kd triangles", &kd.triangles),
            directions: None,
            leaf_count: kd.leaves.len() as u32,
            root: (kd.min, kd.max),
            shoot,
            visibility,
            dev,
        })
    }

    /// Uploads the shared direction sets (local frame, +z = normal, block
    /// order, one set after the other; a vertex picks its set with
    /// [`RayVertex::direction_set`]).
    pub fn set_directions(&mut self, dirs: &crate::sampling::DirectionSet) {
        let v: Vec<[f32; 4]> = dirs.dirs.iter().map(|d| [d.x, d.y, d.z, 0.0]).collect();
        self.directions = Some((storage_init(&self.dev.device, "ray directions", &v), dirs.len() as u32));
    }

    /// The most rays one batch may trace: the hit buffer (16 bytes a ray)
    /// must fit the device's storage-binding and buffer limits, and stays
    /// under 128 MiB so several logical devices fit together.
    pub fn max_batch_rays(&self) -> usize {
        let limit = self.dev.limits.max_storage_buffer_binding_size.min(self.dev.limits.max_buffer_size);
        (limit.min(128 << 20) / std::mem::size_of::<HitRecord>() as u64) as usize
    }

    fn params(&self, count: u32, rays_per_vertex: u32, groups_x: u32) -> TraceParams {
        TraceParams {
            count,
            rays_per_vertex,
            groups_x,
            leaf_count: self.leaf_count,
            root_min: self.root.0.into(),
            root_max: self.root.1.into(),
            ..Default::default()
        }
    }

    /// Traces every direction from every vertex of the batch; one hit
    /// record per ray, vertex-major.
    pub fn shoot(&self, vertices: &[RayVertex]) -> Result<Vec<HitRecord>> {
        checked(&self.dev, "shooting rays", || self.shoot_unchecked(vertices))?
    }

    fn shoot_unchecked(&self, vertices: &[RayVertex]) -> Result<Vec<HitRecord>> {
        let Some((dirs, rays_per_vertex)) = self.directions.as_ref() else {
            return Err(crate::Error::Gpu("no direction set: GpuTracer::set_directions before shoot".into()));
        };
        let count = vertices.len() as u64 * *rays_per_vertex as u64;
        if count == 0 {
            return Ok(Vec::new());
        }
        let d = &self.dev.device;
        let (gx, gy) = dispatch_size(count as u32, WORKGROUP, self.dev.limits.max_compute_workgroups_per_dimension);
        let params = uniform_init(d, "shoot params", &self.params(count as u32, *rays_per_vertex, gx));
        let verts = storage_init(d, "ray vertices", vertices);
        let hits = d.create_buffer(&wgpu::BufferDescriptor {
            label: Some("hits"),
            size: count * std::mem::size_of::<HitRecord>() as u64,
            usage: wgpu::BufferUsages::STORAGE | wgpu::BufferUsages::COPY_SRC,
            mapped_at_creation: false,
        });
        let entries = [&params, &self.nodes, &self.leaves, &self.leaf_triangles, &self.triangles, dirs, &verts, &hits];
        let group = d.create_bind_group(&wgpu::BindGroupDescriptor {
            label: Some("shoot bind group"),
            layout: &self.shoot.get_bind_group_layout(0),
            entries: &entries
                .iter()
                .enumerate()
                .map(|(i, b)| wgpu::BindGroupEntry { binding: i as u32, resource: b.as_entire_binding() })
                .collect::<Vec<_>>(),
        });
        let mut enc = d.create_command_encoder(&wgpu::CommandEncoderDescriptor { label: Some("shoot") });
        {
            let mut pass = enc
                .begin_compute_pass(&wgpu::ComputePassDescriptor { label: Some("shoot_rays"), timestamp_writes: None });
            pass.set_pipeline(&self.shoot);
            pass.set_bind_group(0, &group, &[]);
            pass.dispatch_workgroups(gx, gy, 1);
        }
        read_back(&self.dev, enc, &hits, "hits")
    }

    /// Any-hit test of shadow-ray segments: 1 where the segment is free.
    pub fn visibility(&self, rays: &[ShadowRay]) -> Result<Vec<u32>> {
        checked(&self.dev, "shadow rays", || self.visibility_unchecked(rays))?
    }

    fn visibility_unchecked(&self, rays: &[ShadowRay]) -> Result<Vec<u32>> {
        if rays.is_empty() {
            return Ok(Vec::new());
        }
        let d = &self.dev.device;
        let count = rays.len() as u32;
        let (gx, gy) = dispatch_size(count, WORKGROUP, self.dev.limits.max_compute_workgroups_per_dimension);
        let params = uniform_init(d, "visibility params", &self.params(count, 1, gx));
        let ray_buf = storage_init(d, "shadow rays", rays);
        let visible = d.create_buffer(&wgpu::BufferDescriptor {
            label: Some("visibility"),
            size: rays.len() as u64 * 4,
            usage: wgpu::BufferUsages::STORAGE | wgpu::BufferUsages::COPY_SRC,
            mapped_at_creation: false,
        });
        let layout0 = self.visibility.get_bind_group_layout(0);
        let g0 = d.create_bind_group(&wgpu::BindGroupDescriptor {
            label: Some("visibility tree bind group"),
            layout: &layout0,
            entries: &[
                wgpu::BindGroupEntry { binding: 0, resource: params.as_entire_binding() },
                wgpu::BindGroupEntry { binding: 1, resource: self.nodes.as_entire_binding() },
                wgpu::BindGroupEntry { binding: 2, resource: self.leaves.as_entire_binding() },
                wgpu::BindGroupEntry { binding: 3, resource: self.leaf_triangles.as_entire_binding() },
                wgpu::BindGroupEntry { binding: 4, resource: self.triangles.as_entire_binding() },
            ],
        });
        let g1 = d.create_bind_group(&wgpu::BindGroupDescriptor {
            label: Some("visibility rays bind group"),
            layout: &self.visibility.get_bind_group_layout(1),
            entries: &[
                wgpu::BindGroupEntry { binding: 0, resource: ray_buf.as_entire_binding() },
                wgpu::BindGroupEntry { binding: 1, resource: visible.as_entire_binding() },
            ],
        });
        let mut enc = d.create_command_encoder(&wgpu::CommandEncoderDescriptor { label: Some("visibility") });
        {
            let mut pass = enc.begin_compute_pass(&wgpu::ComputePassDescriptor {
                label: Some("light_visibility"),
                timestamp_writes: None,
            });
            pass.set_pipeline(&self.visibility);
            pass.set_bind_group(0, &g0, &[]);
            pass.set_bind_group(1, &g1, &[]);
            pass.dispatch_workgroups(gx, gy, 1);
        }
        read_back(&self.dev, enc, &visible, "visibility")
    }
}
