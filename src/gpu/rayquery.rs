//! The driver's acceleration structures for the ray-query tracer
//! ([`super::GpuWalk::RayQuery`], `shaders/walk_rq.wgsl`): one bottom-level
//! structure over the scene's triangles (in triangle order, so a
//! candidate's primitive index is the triangle id) under a top-level one
//! with a single identity instance, built with `PREFER_FAST_TRACE` and
//! `ALLOW_UPDATE`, and refitted in place when the vertices move.
//!
//! The triangles are not opaque: the driver's traversal proposes
//! candidates and the shader decides each with the watertight test of the
//! other tracers (`trace.wgsl`), on its own copy of the corners
//! ([`KdTriangle`], by triangle id), and skips the ray's own vertex. The
//! driver's own triangle test is not watertight: a ray through a shared
//! edge or vertex (a vertex lying on another mesh's edge shoots from one at
//! t = 0) may be proposed neither triangle. So the driver is given each
//! triangle slightly enlarged ([`ENLARGE`]: its corners pushed away from
//! the centroid), unshared, and proposes every triangle the ray comes near
//! its edge; the exact test then decides. A hit's triangle, `t` and
//! barycentrics are those of the other tracers, except where a confirmed
//! candidate's `t` culls a tie a few ulps behind it. Measured on window
//! (lavapipe, Mesa 25): 1,180 of 617k vertex rays differed from the CPU
//! BVH with the triangles as they are, 720 with the ray's start moved back
//! (`walk_rq.wgsl`), 28 with both (the kd walk: 13). Lengths in metres.

use super::buffers::checked;
use super::context::GpuDevice;
use crate::error::{Error, Result};
use crate::trace::ray::KdTriangle;
use glam::Vec3;
use wgpu::util::DeviceExt;

/// How much the driver's triangles are enlarged: each corner moves away
/// from the centroid by this fraction of its distance to it plus this
/// fraction of the scene's largest coordinate (the scale of a driver's
/// rounding). Far above f32 rounding, far below any feature: costs a few
/// more candidates along edges.
pub const ENLARGE: f32 = 1e-5;

/// The acceleration structures of one scene and the buffers they read.
pub struct RqScene {
    tlas: wgpu::Tlas,
    blas: wgpu::Blas,
    size: wgpu::BlasTriangleGeometrySizeDescriptor,
    /// The driver's corners: three a triangle, enlarged ([`ENLARGE`]).
    vertices: wgpu::Buffer,
    vertex_count: usize,
    /// Corners and corner ids by triangle id, for the shader's own test.
    triangles: wgpu::Buffer,
    triangle_ids: Vec<[u32; 3]>,
}

impl RqScene {
    /// Builds the structures over `triangles` (vertex ids into `positions`).
    pub fn new(dev: &GpuDevice, positions: &[Vec3], triangles: &[[u32; 3]]) -> Result<RqScene> {
        if !dev.ray_query() {
            return Err(Error::Gpu(format!("{}: no hardware ray queries (EXPERIMENTAL_RAY_QUERY)", dev.info.name)));
        }
        if triangles.is_empty() {
            return Err(Error::Gpu("ray queries over a scene with no triangle".into()));
        }
        checked(dev, "building the acceleration structures", || Self::build(dev, positions, triangles))?
    }

    fn build(dev: &GpuDevice, positions: &[Vec3], triangles: &[[u32; 3]]) -> Result<RqScene> {
        let d = &dev.device;
        let vertices = d.create_buffer_init(&wgpu::util::BufferInitDescriptor {
            label: Some("rq vertices"),
            contents: bytemuck::cast_slice(&enlarged(positions, triangles)),
            usage: wgpu::BufferUsages::BLAS_INPUT | wgpu::BufferUsages::COPY_DST,
        });
        let size = wgpu::BlasTriangleGeometrySizeDescriptor {
            vertex_format: wgpu::VertexFormat::Float32x3,
            vertex_count: triangles.len() as u32 * 3,
            index_format: None,
            index_count: None,
            flags: wgpu::AccelerationStructureGeometryFlags::empty(),
        };
        let flags =
            wgpu::AccelerationStructureFlags::PREFER_FAST_TRACE | wgpu::AccelerationStructureFlags::ALLOW_UPDATE;
        let blas = d.create_blas(
            &wgpu::CreateBlasDescriptor {
                label: Some("rq blas"),
                flags,
                update_mode: wgpu::AccelerationStructureUpdateMode::PreferUpdate,
            },
            wgpu::BlasGeometrySizeDescriptors::Triangles { descriptors: vec![size.clone()] },
        );
        let mut tlas = d.create_tlas(&wgpu::CreateTlasDescriptor {
            label: Some("rq tlas"),
            max_instances: 1,
            flags: wgpu::AccelerationStructureFlags::PREFER_FAST_TRACE,
            update_mode: wgpu::AccelerationStructureUpdateMode::Build,
        });
        const IDENTITY: [f32; 12] = [1.0, 0.0, 0.0, 0.0, 0.0, 1.0, 0.0, 0.0, 0.0, 0.0, 1.0, 0.0];
        tlas[0] = Some(wgpu::TlasInstance::new(&blas, IDENTITY, 0, 0xff));
        let corners: Vec<KdTriangle> = corners(positions, triangles);
        let triangles_buf = super::buffers::storage_init(d, "rq triangles", &corners);
        let scene = RqScene {
            tlas,
            blas,
            size,
            vertices,
            vertex_count: positions.len(),
            triangles: triangles_buf,
            triangle_ids: triangles.to_vec(),
        };
        scene.encode_build(dev, true);
        dev.wait()?;
        Ok(scene)
    }

    /// Builds (with `with_tlas`, the top level too) on the device.
    fn encode_build(&self, dev: &GpuDevice, with_tlas: bool) {
        let mut enc = dev.device.create_command_encoder(&wgpu::CommandEncoderDescriptor { label: Some("rq build") });
        let geometry = wgpu::BlasTriangleGeometry {
            size: &self.size,
            vertex_buffer: &self.vertices,
            first_vertex: 0,
            vertex_stride: 12,
            index_buffer: None,
            first_index: None,
            transform_buffer: None,
            transform_buffer_offset: None,
        };
        let entry = wgpu::BlasBuildEntry {
            blas: &self.blas,
            geometry: wgpu::BlasGeometries::TriangleGeometries(vec![geometry]),
        };
        let tlas: Vec<&wgpu::Tlas> = if with_tlas { vec![&self.tlas] } else { Vec::new() };
        enc.build_acceleration_structures(std::iter::once(&entry), tlas);
        dev.queue.submit([enc.finish()]);
    }

    /// Refits the structures to new positions of the same vertices.
    pub fn refit(&mut self, dev: &GpuDevice, positions: &[Vec3]) -> Result<()> {
        if positions.len() != self.vertex_count {
            return Err(Error::Gpu(format!(
                "refitting ray-query structures of {} vertices to {}",
                self.vertex_count,
                positions.len()
            )));
        }
        checked(dev, "refitting the acceleration structures", || {
            dev.queue.write_buffer(&self.vertices, 0, bytemuck::cast_slice(&enlarged(positions, &self.triangle_ids)));
            dev.queue.write_buffer(&self.triangles, 0, bytemuck::cast_slice(&corners(positions, &self.triangle_ids)));
            self.encode_build(dev, true);
        })?;
        dev.wait()
    }

    /// The bindings of `walk_rq.wgsl` from binding 1: the top level and the triangles.
    pub(super) fn resources(&self) -> Vec<wgpu::BindingResource<'_>> {
        vec![self.tlas.as_binding(), self.triangles.as_entire_binding()]
    }
}

/// The driver's corners, three a triangle, each moved away from its
/// triangle's centroid ([`ENLARGE`]).
fn enlarged(positions: &[Vec3], triangles: &[[u32; 3]]) -> Vec<[f32; 3]> {
    let scale = positions.iter().fold(1f32, |m, p| m.max(p.abs().max_element()));
    let pad = ENLARGE * scale;
    let mut out = Vec::with_capacity(triangles.len() * 3);
    for t in triangles {
        let c = t.map(|i| positions[i as usize]);
        let centroid = (c[0] + c[1] + c[2]) / 3.0;
        for p in c {
            let away = p - centroid;
            out.push((p + away * ENLARGE + away.normalize_or_zero() * pad).to_array());
        }
    }
    out
}

fn corners(positions: &[Vec3], triangles: &[[u32; 3]]) -> Vec<KdTriangle> {
    triangles
        .iter()
        .map(|&[a, b, c]| KdTriangle {
            v0: positions[a as usize].into(),
            ia: a,
            v1: positions[b as usize].into(),
            ib: b,
            v2: positions[c as usize].into(),
            ic: c,
        })
        .collect()
}
