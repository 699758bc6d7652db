//! The GPU tracers: one structure on one device and the three entry points
//! of `shaders/trace.wgsl`, which every structure's walk serves:
//! - `shoot_rays`: every direction of a shared table from every vertex of a
//!   batch, turned into the vertex's frame (link shooting, the noise check);
//! - `closest_hits`: the nearest hit of each ray of an arbitrary batch;
//! - `light_visibility`: any-hit tests of segments.
//!
//! The structures ([`GpuWalk`]): the CPU's 8-wide BVH uploaded as it is
//! (`walk_bvh.wgsl`; a refit on the CPU is a copy), the rope kd-tree
//! (`walk_kd.wgsl`), and hardware ray queries, where the adapter has them
//! (`walk_rq.wgsl`, [`super::rayquery`]). Each answers exactly what the
//! CPU tracers answer (the same watertight triangle test, ties by triangle
//! id), so the CPU's structures are their oracle. A call uploads its rays,
//! traces one dispatch and reads the results back.

use super::buffers::{checked, compute_pipelines, dispatch_size, read_back, storage_init, uniform_init};
use super::context::GpuDevice;
pub use super::layout::BVH_STACK;
use super::layout::{RayVertex, ShadowRay, TraceParams, TRACE_WGSL, WALK_BVH_WGSL, WALK_KD_WGSL, WALK_RQ_WGSL};
use crate::bvh::Bvh;
use crate::error::{Error, Result};
use crate::kdtree::KdTree;
use crate::links::HitRecord;
use glam::Vec3;
use std::sync::Arc;

const WORKGROUP: u32 = 64;

/// Which structure a GPU tracer walks (the `tracer` setting on the GPU path).
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum GpuWalk {
    /// The CPU's 8-wide BVH, walked with a short stack (`walk_bvh.wgsl`).
    Bvh,
    /// The kd-tree with ropes (`walk_kd.wgsl`).
    Kd,
    /// The driver's acceleration structure through ray queries (`walk_rq.wgsl`).
    RayQuery,
}

impl GpuWalk {
    /// The walk the `tracer` setting names on `dev`: `auto` takes ray
    /// queries where the device has them, else the BVH; `rq` on a device
    /// without them is an error.
    pub fn choose(kind: crate::scene::TracerKind, dev: &GpuDevice) -> Result<GpuWalk> {
        use crate::scene::TracerKind as K;
        Ok(match kind {
            K::Bvh => GpuWalk::Bvh,
            K::Kd => GpuWalk::Kd,
            K::Auto if dev.ray_query() => GpuWalk::RayQuery,
            K::Auto => GpuWalk::Bvh,
            K::RayQuery if dev.ray_query() => GpuWalk::RayQuery,
            K::RayQuery => {
                return Err(Error::Gpu(format!(
                    "tracer = \"rq\": {} has no hardware ray queries (EXPERIMENTAL_RAY_QUERY)",
                    dev.info.name
                )))
            }
        })
    }

    /// Why the `tracer` setting `kind` gave this walk, for the output.
    #[cfg(any(feature = "cli", feature = "internals"))]
    pub fn reason(self, kind: crate::scene::TracerKind) -> &'static str {
        use crate::scene::TracerKind as K;
        match (kind, self) {
            (K::Auto, GpuWalk::RayQuery) => "auto: the adapter has hardware ray queries",
            (K::Auto, _) => "auto: the adapter has no hardware ray queries, so the BVH walk",
            _ => "the tracer setting",
        }
    }

    /// The tracer's name in figures.
    pub fn name(self) -> &'static str {
        match self {
            GpuWalk::Bvh => "gpu-bvh",
            GpuWalk::Kd => "gpu-kd",
            GpuWalk::RayQuery => "gpu-rq",
        }
    }
}

/// The device buffers of one structure, bound in group 0 from binding 1
/// in this order (the kd walk also reads its leaf count and root box from
/// the dispatch's parameters).
pub(super) enum Structure {
    Bvh {
        nodes: wgpu::Buffer,
        blocks: wgpu::Buffer,
    },
    Kd {
        nodes: wgpu::Buffer,
        leaves: wgpu::Buffer,
        leaf_triangles: wgpu::Buffer,
        triangles: wgpu::Buffer,
        leaf_count: u32,
        root: (Vec3, Vec3),
    },
    RayQuery(super::rayquery::RqScene),
}

impl Structure {
    fn resources(&self) -> Vec<wgpu::BindingResource<'_>> {
        match self {
            Structure::Bvh { nodes, blocks } => vec![nodes.as_entire_binding(), blocks.as_entire_binding()],
            Structure::Kd { nodes, leaves, leaf_triangles, triangles, .. } => vec![
                nodes.as_entire_binding(),
                leaves.as_entire_binding(),
                leaf_triangles.as_entire_binding(),
                triangles.as_entire_binding(),
            ],
            Structure::RayQuery(s) => s.resources(),
        }
    }
}

/// One entry point of `trace.wgsl`.
#[derive(Clone, Copy)]
enum Entry {
    Shoot = 0,
    Closest = 1,
    Visibility = 2,
}

/// A structure resident on one device, ready to trace batches.
pub struct GpuTracer {
    /// The device the structure lives on.
    pub dev: Arc<GpuDevice>,
    walk: GpuWalk,
    pipelines: [wgpu::ComputePipeline; 3],
    structure: Structure,
    directions: Option<(wgpu::Buffer, u32)>,
}

/// The most stack entries a walk of `bvh` can hold: at each node it
/// pushes the entered children but one and descends into that one.
pub fn stack_need(bvh: &Bvh) -> usize {
    fn need(bvh: &Bvh, node: usize, depth: usize) -> usize {
        let n = &bvh.nodes[node];
        let kids: Vec<u32> = n.child.iter().copied().filter(|&c| c != crate::bvh::EMPTY).collect();
        let here = kids.len().saturating_sub(1);
        // A tree deeper than any builder makes is refused, not walked.
        if depth > 64 {
            return usize::MAX / 2;
        }
        here + kids
            .iter()
            .filter(|&&c| !crate::bvh::is_leaf(c))
            .map(|&c| need(bvh, c as usize, depth + 1))
            .max()
            .unwrap_or(0)
    }
    if bvh.nodes.is_empty() {
        0
    } else {
        need(bvh, 0, 0)
    }
}

impl GpuTracer {
    /// The tracer walking `walk` over the CPU structure `accel` (the same
    /// tree for `Bvh` and `Kd`; the driver's, built over `positions` and
    /// `triangles`, for `RayQuery`).
    pub fn of(
        dev: Arc<GpuDevice>,
        walk: GpuWalk,
        accel: &crate::trace::Accel,
        positions: &[Vec3],
        triangles: &[[u32; 3]],
    ) -> Result<GpuTracer> {
        use crate::trace::Accel;
        match (walk, accel) {
            (GpuWalk::Bvh, Accel::Bvh(b)) => GpuTracer::bvh(dev, b),
            (GpuWalk::Kd, Accel::Kd(k)) => GpuTracer::kd(dev, k),
            (GpuWalk::RayQuery, _) => GpuTracer::ray_query(dev, positions, triangles),
            (w, a) => Err(Error::Gpu(format!("{} cannot walk the CPU's {}", w.name(), a.kind().name()))),
        }
    }

    /// Uploads the rope kd-tree `kd`.
    pub fn kd(dev: Arc<GpuDevice>, kd: &KdTree) -> Result<GpuTracer> {
        fits(
            &dev,
            "the kd-tree",
            &[
                std::mem::size_of_val(kd.triangles.as_slice()),
                std::mem::size_of_val(kd.leaves.as_slice()),
                std::mem::size_of_val(kd.nodes.as_slice()),
                kd.leaf_triangles.len() * 4,
            ],
        )?;
        checked(&dev.clone(), "uploading the kd-tree", || {
            let d = &dev.device;
            let structure = Structure::Kd {
                nodes: storage_init(d, "kd nodes", &kd.nodes),
                leaves: storage_init(d, "kd leaves", &kd.leaves),
                leaf_triangles: storage_init(d, "kd leaf triangles", &kd.leaf_triangles),
                triangles: storage_init(d, "kd triangles", &kd.triangles),
                leaf_count: kd.leaves.len() as u32,
                root: (kd.min, kd.max),
            };
            Self::with(dev.clone(), GpuWalk::Kd, structure)
        })
    }

    /// Uploads the 8-wide BVH `bvh` as it is. Refused where a walk could
    /// need more than [`BVH_STACK`] stack entries ([`stack_need`]).
    pub fn bvh(dev: Arc<GpuDevice>, bvh: &Bvh) -> Result<GpuTracer> {
        fits_stack(bvh)?;
        fits(
            &dev,
            "the BVH",
            &[std::mem::size_of_val(bvh.nodes.as_slice()), std::mem::size_of_val(bvh.blocks.as_slice())],
        )?;
        checked(&dev.clone(), "uploading the BVH", || {
            let d = &dev.device;
            let structure = Structure::Bvh {
                nodes: storage_init(d, "bvh nodes", &bvh.nodes),
                blocks: storage_init(d, "bvh blocks", &bvh.blocks),
            };
            Self::with(dev.clone(), GpuWalk::Bvh, structure)
        })
    }

    /// Builds the driver's acceleration structure over `triangles` (vertex
    /// ids into `positions`) and traces with ray queries; an error where the
    /// device was not opened with them ([`GpuDevice::ray_query`]).
    pub fn ray_query(dev: Arc<GpuDevice>, positions: &[Vec3], triangles: &[[u32; 3]]) -> Result<GpuTracer> {
        let scene = super::rayquery::RqScene::new(&dev, positions, triangles)?;
        checked(&dev.clone(), "ray-query pipelines", || {
            Self::with(dev.clone(), GpuWalk::RayQuery, Structure::RayQuery(scene))
        })
    }

    fn with(dev: Arc<GpuDevice>, walk: GpuWalk, structure: Structure) -> GpuTracer {
        let pipelines = {
            let pipeline = compute_pipelines(&dev.device, walk.name(), tracer_wgsl(walk));
            [pipeline("shoot_rays"), pipeline("closest_hits"), pipeline("light_visibility")]
        };
        GpuTracer { pipelines, structure, directions: None, walk, dev }
    }

    /// Which structure this tracer walks.
    pub fn walk(&self) -> GpuWalk {
        self.walk
    }

    /// Brings the structure to new vertex positions of the same triangles:
    /// the BVH's refitted (or rebuilt) nodes and blocks are uploaded, the
    /// driver's structure is refitted, the kd-tree is uploaded anew
    /// (`kd`, built over the new positions by the caller).
    pub fn update(&mut self, bvh: Option<&Bvh>, kd: Option<&KdTree>, positions: &[Vec3]) -> Result<()> {
        match (self.walk, bvh, kd) {
            (GpuWalk::Bvh, Some(b), _) => {
                fits_stack(b)?;
                let Structure::Bvh { nodes, blocks } = &mut self.structure else { unreachable!("a BVH tracer") };
                // A refit keeps the sizes: the buffers are overwritten; a rebuild replaces them.
                let dev = &self.dev;
                checked(dev, "uploading the BVH", || {
                    rewrite(dev, nodes, "bvh nodes", &b.nodes);
                    rewrite(dev, blocks, "bvh blocks", &b.blocks);
                })?;
            }
            (GpuWalk::Kd, _, Some(k)) => {
                let Structure::Kd { nodes, leaves, leaf_triangles, triangles, leaf_count, root } = &mut self.structure
                else {
                    unreachable!("a kd tracer")
                };
                let dev = &self.dev;
                checked(dev, "uploading the kd-tree", || {
                    rewrite(dev, nodes, "kd nodes", &k.nodes);
                    rewrite(dev, leaves, "kd leaves", &k.leaves);
                    rewrite(dev, leaf_triangles, "kd leaf triangles", &k.leaf_triangles);
                    rewrite(dev, triangles, "kd triangles", &k.triangles);
                })?;
                *leaf_count = k.leaves.len() as u32;
                *root = (k.min, k.max);
            }
            (GpuWalk::RayQuery, _, _) => {
                let Structure::RayQuery(s) = &mut self.structure else { unreachable!("a ray-query tracer") };
                s.refit(&self.dev, positions)?;
            }
            (w, _, _) => return Err(Error::Gpu(format!("{}: no structure given to update", w.name()))),
        }
        Ok(())
    }

    /// Uploads the shared direction sets of [`GpuTracer::shoot`] (local
    /// frame, +z = normal, block order, one set after the other; a vertex
    /// picks its set with [`RayVertex::direction_set`]).
    pub fn set_directions(&mut self, dirs: &crate::sampling::DirectionSet) {
        self.directions = Some((direction_buffer(&self.dev.device, &dirs.dirs), dirs.len() as u32));
    }

    /// The most rays one batch may trace: the hit buffer (16 bytes a ray)
    /// must fit the device's storage-binding and buffer limits, and stays
    /// under 128 MiB so several logical devices fit together.
    pub fn max_batch_rays(&self) -> usize {
        let limit = self.dev.limits.max_storage_buffer_binding_size.min(self.dev.limits.max_buffer_size);
        (limit.min(128 << 20) / std::mem::size_of::<HitRecord>() as u64) as usize
    }

    /// Traces every direction of [`GpuTracer::set_directions`]' table from
    /// every vertex of the batch; one hit record per ray, vertex-major.
    pub fn shoot(&self, vertices: &[RayVertex]) -> Result<Vec<HitRecord>> {
        let Some((dirs, rays_per_vertex)) = self.directions.as_ref() else {
            return Err(Error::Gpu("no direction set: GpuTracer::set_directions before shoot".into()));
        };
        self.shoot_with(vertices, dirs, *rays_per_vertex)
    }

    /// [`GpuTracer::shoot`] with the direction table `dirs` (`rays_per_vertex` a set).
    pub(super) fn shoot_with(
        &self,
        vertices: &[RayVertex],
        dirs: &wgpu::Buffer,
        rays_per_vertex: u32,
    ) -> Result<Vec<HitRecord>> {
        let count = vertices.len() as u64 * rays_per_vertex as u64;
        if count == 0 {
            return Ok(Vec::new());
        }
        if count > u32::MAX as u64 {
            return Err(Error::Gpu(format!("{count} rays in one batch: at most {} a dispatch", u32::MAX)));
        }
        checked(&self.dev, "shooting rays", || {
            let d = &self.dev.device;
            let verts = storage_init(d, "ray vertices", vertices);
            let hits = output(d, "hits", count * std::mem::size_of::<HitRecord>() as u64);
            self.run(Entry::Shoot, count as u32, rays_per_vertex, &[(0, dirs), (1, &verts), (3, &hits)], &hits)
        })?
    }

    /// The nearest hit of every ray (`shaders/trace.wgsl`'s `closest_hits`).
    pub fn closest(&self, rays: &[ShadowRay]) -> Result<Vec<HitRecord>> {
        self.each_ray(Entry::Closest, rays, "closest hits", 3)
    }

    /// Any-hit test of ray segments: 1 where the segment is free.
    pub fn visibility(&self, rays: &[ShadowRay]) -> Result<Vec<u32>> {
        self.each_ray(Entry::Visibility, rays, "shadow rays", 4)
    }

    /// One result a ray of `rays` from `entry`, which writes them to
    /// group 1's binding `out`.
    fn each_ray<T: bytemuck::Pod>(&self, entry: Entry, rays: &[ShadowRay], what: &str, out: u32) -> Result<Vec<T>> {
        if rays.is_empty() {
            return Ok(Vec::new());
        }
        checked(&self.dev, what, || {
            let d = &self.dev.device;
            let ray_buf = storage_init(d, what, rays);
            let results = output(d, what, (rays.len() * std::mem::size_of::<T>()) as u64);
            self.run(entry, rays.len() as u32, 1, &[(2, &ray_buf), (out, &results)], &results)
        })?
    }

    /// One dispatch of `entry` over `count` rays with the per-call buffers
    /// `inputs` (group 1 bindings), reading `out` back.
    fn run<T: bytemuck::Pod>(
        &self,
        entry: Entry,
        count: u32,
        rays_per_vertex: u32,
        inputs: &[(u32, &wgpu::Buffer)],
        out: &wgpu::Buffer,
    ) -> Result<Vec<T>> {
        let d = &self.dev.device;
        let pipeline = &self.pipelines[entry as usize];
        let (gx, gy) = dispatch_size(count, WORKGROUP, self.dev.limits.max_compute_workgroups_per_dimension);
        let mut p = TraceParams { count, rays_per_vertex, groups_x: gx, ..Default::default() };
        if let Structure::Kd { leaf_count, root, .. } = &self.structure {
            (p.leaf_count, p.root_min, p.root_max) = (*leaf_count, root.0.into(), root.1.into());
        }
        let params = uniform_init(d, "trace params", &p);
        let mut tree = vec![wgpu::BindGroupEntry { binding: 0, resource: params.as_entire_binding() }];
        tree.extend(
            self.structure
                .resources()
                .into_iter()
                .enumerate()
                .map(|(i, resource)| wgpu::BindGroupEntry { binding: i as u32 + 1, resource }),
        );
        let g0 = d.create_bind_group(&wgpu::BindGroupDescriptor {
            label: Some("structure bind group"),
            layout: &pipeline.get_bind_group_layout(0),
            entries: &tree,
        });
        let g1 = d.create_bind_group(&wgpu::BindGroupDescriptor {
            label: Some("rays bind group"),
            layout: &pipeline.get_bind_group_layout(1),
            entries: &inputs
                .iter()
                .map(|(binding, b)| wgpu::BindGroupEntry { binding: *binding, resource: b.as_entire_binding() })
                .collect::<Vec<_>>(),
        });
        let mut enc = d.create_command_encoder(&wgpu::CommandEncoderDescriptor { label: Some(self.walk.name()) });
        {
            let mut pass = enc.begin_compute_pass(&wgpu::ComputePassDescriptor {
                label: Some(self.walk.name()),
                timestamp_writes: None,
            });
            pass.set_pipeline(pipeline);
            pass.set_bind_group(0, &g0, &[]);
            pass.set_bind_group(1, &g1, &[]);
            pass.dispatch_workgroups(gx, gy, 1);
        }
        let mut v: Vec<T> = read_back(&self.dev, enc, out, "trace results")?;
        // One result a ray (the buffer holds at least 16 bytes).
        v.truncate(count as usize);
        Ok(v)
    }
}

/// `buf` holding `data`: written in place where the size is unchanged, else replaced.
fn rewrite<T: bytemuck::Pod>(dev: &GpuDevice, buf: &mut wgpu::Buffer, label: &str, data: &[T]) {
    let bytes: &[u8] = bytemuck::cast_slice(data);
    if bytes.len() as u64 == buf.size() && !bytes.is_empty() {
        dev.queue.write_buffer(buf, 0, bytes);
    } else {
        *buf = storage_init(&dev.device, label, data);
    }
}

/// The whole source of the tracer walking `walk`: its walk, then
/// `trace.wgsl` (the walk comes first: it may open with an `enable`).
pub fn tracer_wgsl(walk: super::tracer::GpuWalk) -> String {
    let w = match walk {
        GpuWalk::Bvh => WALK_BVH_WGSL,
        GpuWalk::Kd => WALK_KD_WGSL,
        GpuWalk::RayQuery => WALK_RQ_WGSL,
    };
    format!("{w}\n{TRACE_WGSL}")
}

/// An error where a walk of `bvh` could need more than [`BVH_STACK`] entries.
fn fits_stack(bvh: &Bvh) -> Result<()> {
    let need = stack_need(bvh);
    if need > BVH_STACK {
        return Err(Error::Gpu(format!("the BVH's walk can hold {need} stack entries, the GPU walk has {BVH_STACK}")));
    }
    Ok(())
}

/// The origins of `batch` in the shader's layout.
pub fn ray_vertices_of(batch: &crate::trace::OriginRays) -> Vec<RayVertex> {
    (0..batch.origins.len())
        .map(|i| {
            let (t, b, n) = batch.frames[i];
            RayVertex {
                origin: batch.origins[i].into(),
                skip: batch.skip[i],
                tangent: t.into(),
                direction_set: batch.sets[i],
                bitangent: b.into(),
                normal: n.into(),
                ..Default::default()
            }
        })
        .collect()
}

/// A table of local directions as `vec4`s (w unused).
pub(super) fn direction_buffer(d: &wgpu::Device, dirs: &[Vec3]) -> wgpu::Buffer {
    let v: Vec<[f32; 4]> = dirs.iter().map(|d| [d.x, d.y, d.z, 0.0]).collect();
    storage_init(d, "ray directions", &v)
}

fn output(d: &wgpu::Device, label: &str, size: u64) -> wgpu::Buffer {
    d.create_buffer(&wgpu::BufferDescriptor {
        label: Some(label),
        size: size.max(16),
        usage: wgpu::BufferUsages::STORAGE | wgpu::BufferUsages::COPY_SRC,
        mapped_at_creation: false,
    })
}

/// An error naming `what` where one of its arrays (`sizes`, bytes) exceeds
/// the device's storage-binding limit.
fn fits(dev: &GpuDevice, what: &str, sizes: &[usize]) -> Result<()> {
    let limit = dev.limits.max_storage_buffer_binding_size as usize;
    let biggest = sizes.iter().copied().max().unwrap_or(0);
    if biggest > limit {
        return Err(Error::Gpu(format!(
            "{}: {what} needs a {biggest}-byte storage binding, the adapter allows {limit}",
            dev.info.name
        )));
    }
    Ok(())
}
