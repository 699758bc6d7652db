//! The bounce loop on the GPU (`shaders/gather.wgsl`): links, albedo and
//! the running sums stay on the device; a fixed bounce count is one
//! submission with no read-back between bounces. `auto` reads back only
//! the per-workgroup sums of each bounce (16 bytes per 256 vertices) to
//! decide whether to stop. With the radiosity correction
//! ([`crate::exchange::bounce::reconstruct`]) a `reconstruct_radiosity` dispatch
//! before every bounce after the first writes the radiosity the gather
//! reads. Irradiance in W/m^2.
//!
//! The links are uploaded as the CPU gather reads them ([`crate::links::packed`]:
//! the target stream as u32 words, the row starts, f16 weight pairs).
//! Links larger than one storage binding (lavapipe: 128 MiB) are cut into
//! segments of whole rows (at most a binding's quarter of links, and of
//! stream bytes at most a binding), each with its own buffers, gathered by
//! one dispatch each.

use super::buffers::{checked, compute_pipelines, dispatch_size, read_back, storage_init, uniform_init};
use super::context::GpuDevice;
use super::layout::{GatherUniforms, GATHER_WGSL};
use crate::error::Result;
use crate::exchange::bounce::gather::BounceKernel;
#[cfg(any(test, feature = "internals"))]
use crate::exchange::bounce::gather::source_radiosity;
use crate::exchange::bounce::operator::radiosity;
use crate::links::packed::PAD;
use crate::links::Links;
use glam::Vec3;
use std::sync::Arc;

pub use super::layout::GATHER_WORKGROUP as WORKGROUP;

/// Rows `first..first + count` of the link matrix on the device.
struct Segment {
    uniforms: wgpu::Buffer,
    offsets: wgpu::Buffer,
    stream: wgpu::Buffer,
    starts: wgpu::Buffer,
    weights: wgpu::Buffer,
    groups: (u32, u32),
    /// Links of the segment.
    // Read only by the decode oracle (`GpuLinks::decode_targets`, a test's).
    #[cfg_attr(not(any(test, feature = "internals")), allow(dead_code))]
    links: usize,
}

/// A radiosity correction's CSR on the device: offsets and
/// (neighbour, weight bits) entries.
type UploadedCorrection = (Arc<crate::exchange::Reconstruction>, wgpu::Buffer, wgpu::Buffer);

/// Links and albedo resident on one device.
pub struct GpuLinks {
    /// The device the links live on.
    pub dev: Arc<GpuDevice>,
    gather: wgpu::ComputePipeline,
    update: wgpu::ComputePipeline,
    // Read only by the decode oracle (`GpuLinks::decode_targets`, a test's).
    #[cfg_attr(not(any(test, feature = "internals")), allow(dead_code))]
    decode: wgpu::ComputePipeline,
    reconstruct: wgpu::ComputePipeline,
    /// The radiosity correction's weights last uploaded, with the `Arc`
    /// they came from (held, so a new correction never shares its address):
    /// a light move uploads nothing, a deformation (a new correction) anew.
    corrections: std::sync::Mutex<Option<UploadedCorrection>>,
    /// Corrections uploaded so far ([`GpuLinks::correction_uploads`]).
    correction_uploads: std::sync::atomic::AtomicU32,
    uniforms: wgpu::Buffer,
    segments: Vec<Segment>,
    albedo: wgpu::Buffer,
    n: u32,
    groups: (u32, u32),
}

/// Row ranges `(first, end)` whose links number at most `max_links` each
/// (a row with more links than that gets a segment of its own).
pub fn segments(offsets: &[u32], max_links: usize) -> Vec<(usize, usize)> {
    let n = offsets.len().saturating_sub(1);
    let mut out = Vec::new();
    let mut first = 0;
    for v in 0..n {
        if v > first && (offsets[v + 1] - offsets[first]) as usize > max_links {
            out.push((first, v));
            first = v;
        }
    }
    if first < n || n == 0 {
        out.push((first, n));
    }
    out
}

impl GpuLinks {
    /// Uploads the link matrix and the albedo.
    pub fn new(dev: Arc<GpuDevice>, links: &Links, albedo: &[Vec3]) -> Result<GpuLinks> {
        let limit = dev.limits.max_storage_buffer_binding_size.min(dev.limits.max_buffer_size) as usize;
        Self::with_segment_links(dev, links, albedo, limit / 4)
    }

    /// As [`GpuLinks::new`], with at most `max_links` links per segment.
    pub fn with_segment_links(
        dev: Arc<GpuDevice>,
        links: &Links,
        albedo: &[Vec3],
        max_links: usize,
    ) -> Result<GpuLinks> {
        if links.packed.rows() != links.vertex_count() {
            return Err(crate::Error::Gpu("uploading links: the links have no packed targets".into()));
        }
        checked(&dev.clone(), "uploading links", || Self::upload(dev, links, albedo, max_links.max(2)))
    }

    /// The number of link segments.
    #[cfg(any(test, feature = "internals"))]
    pub fn segment_count(&self) -> usize {
        self.segments.len()
    }

    fn upload(dev: Arc<GpuDevice>, links: &Links, albedo: &[Vec3], max_links: usize) -> GpuLinks {
        let device = dev.device.clone();
        let d = &device;
        let pipelines = compute_pipelines(d, "gather.wgsl", GATHER_WGSL);
        let pipeline = |entry: &str| pipelines(entry);
        let n = links.vertex_count() as u32;
        let groups = dispatch_size(n, WORKGROUP, dev.limits.max_compute_workgroups_per_dimension);
        let max_dim = dev.limits.max_compute_workgroups_per_dimension;
        let limit = dev.limits.max_storage_buffer_binding_size.min(dev.limits.max_buffer_size) as usize;
        let starts = &links.packed.starts;
        // Whole rows, at most `max_links` links and a binding of stream bytes each.
        let rows: Vec<(usize, usize)> = segments(&links.offsets, max_links)
            .into_iter()
            .flat_map(|(a, b)| {
                let rebased: Vec<u32> = starts[a..=b].iter().map(|s| s - starts[a]).collect();
                segments(&rebased, limit - PAD - 4).into_iter().map(move |(x, y)| (a + x, a + y))
            })
            .collect();
        let segments = rows
            .into_iter()
            .enumerate()
            .map(|(i, (a, b))| {
                let (l0, l1) = (links.offsets[a] as usize, links.offsets[b] as usize);
                let offsets: Vec<u32> = links.offsets[a..=b].iter().map(|o| o - l0 as u32).collect();
                let (s0, s1) = (starts[a] as usize, starts[b] as usize);
                let row_starts: Vec<u32> = starts[a..b].iter().map(|s| s - s0 as u32).collect();
                let mut packed: Vec<u16> = links.weights[l0..l1].iter().map(|w| w.to_bits()).collect();
                if packed.len() % 2 == 1 {
                    packed.push(0);
                }
                let groups = dispatch_size((b - a) as u32, WORKGROUP, max_dim);
                let u = GatherUniforms {
                    vertex_count: (b - a) as u32,
                    groups_x: groups.0,
                    first_vertex: a as u32,
                    ..Default::default()
                };
                Segment {
                    uniforms: uniform_init(d, &format!("gather uniforms, segment {i}"), &u),
                    offsets: storage_init(d, &format!("link offsets, segment {i}"), &offsets),
                    stream: storage_init(d, &format!("link target stream, segment {i}"), &links.packed.words(s0, s1)),
                    starts: storage_init(d, &format!("link row starts, segment {i}"), &row_starts),
                    weights: storage_init(d, &format!("link weights (f16 pairs), segment {i}"), &packed),
                    groups,
                    links: l1 - l0,
                }
            })
            .collect();
        let uniforms = GatherUniforms { vertex_count: n, groups_x: groups.0, ..Default::default() };
        GpuLinks {
            gather: pipeline("gather_bounce"),
            update: pipeline("update_bounce"),
            decode: pipeline("decode_targets"),
            reconstruct: pipeline("reconstruct_radiosity"),
            corrections: Default::default(),
            correction_uploads: Default::default(),
            uniforms: uniform_init(d, "update uniforms", &uniforms),
            segments,
            albedo: storage_init(d, "albedo", &vec4s(albedo)),
            n,
            groups,
            dev,
        }
    }

    /// A bounce kernel starting from direct irradiance `e_direct` (no emission).
    #[cfg(any(test, feature = "internals"))]
    pub fn kernel(&self, e_direct: &[Vec3], albedo: &[Vec3]) -> Result<GpuBounces<'_>> {
        self.kernel_from_radiosity(&source_radiosity(e_direct, albedo, &[]), albedo)
    }

    /// A bounce kernel starting from radiosity `b0`
    /// ([`crate::exchange::bounce::gather::source_radiosity`]), as the CPU's
    /// [`crate::exchange::bounce::gather::CpuBounces::from_radiosity`].
    pub fn kernel_from_radiosity(&self, b0: &[Vec3], albedo: &[Vec3]) -> Result<GpuBounces<'_>> {
        checked(&self.dev, "gather setup", || self.make_kernel(b0, albedo))
    }

    fn make_kernel(&self, b0: &[Vec3], albedo: &[Vec3]) -> GpuBounces<'_> {
        let d = &self.dev.device;
        let zeros = vec![[0f32; 4]; self.n as usize];
        let radiosity = storage_init(d, "radiosity", &vec4s(b0));
        let bounce = storage_init(d, "bounce irradiance", &zeros);
        let total = storage_init(d, "indirect irradiance", &zeros);
        let group_count = (self.groups.0 * self.groups.1) as usize;
        let partials = storage_init(d, "bounce partial sums", &vec![[0f32; 4]; group_count]);
        let bind = |p: &wgpu::ComputePipeline, label: &str, slots: &[(u32, &wgpu::Buffer)]| {
            d.create_bind_group(&wgpu::BindGroupDescriptor {
                label: Some(label),
                layout: &p.get_bind_group_layout(0),
                entries: &slots
                    .iter()
                    .map(|(i, b)| wgpu::BindGroupEntry { binding: *i, resource: b.as_entire_binding() })
                    .collect::<Vec<_>>(),
            })
        };
        let gather_groups = self.gather_groups(&radiosity, &bounce);
        let update_group = bind(
            &self.update,
            "update_bounce bind group",
            &[(0, &self.uniforms), (4, &radiosity), (5, &bounce), (6, &self.albedo), (7, &total), (8, &partials)],
        );
        GpuBounces {
            links: self,
            reconstruction: None,
            bounces_run: 0,
            radiosity,
            bounce,
            total,
            partials,
            gather_groups,
            update_group,
            group_count,
            stand_ins: Vec::new(),
            albedo: albedo.to_vec(),
        }
    }
}

impl GpuLinks {
    /// The device buffers of correction `r`, uploaded unless they are the
    /// last ones uploaded.
    fn upload_correction(&self, r: &Arc<crate::exchange::Reconstruction>) -> (wgpu::Buffer, wgpu::Buffer) {
        let mut cache = self.corrections.lock().unwrap_or_else(|p| p.into_inner());
        if let Some((a, offsets, entries)) = &*cache {
            if Arc::ptr_eq(a, r) {
                return (offsets.clone(), entries.clone());
            }
        }
        let d = &self.dev.device;
        let entries: Vec<[u32; 2]> = r.rows.items.iter().map(|(t, w)| [*t, w.to_bits()]).collect();
        let offsets = storage_init(d, "radiosity correction offsets", &r.rows.offsets);
        let entries = storage_init(d, "radiosity correction entries", &entries);
        *cache = Some((r.clone(), offsets.clone(), entries.clone()));
        self.correction_uploads.fetch_add(1, std::sync::atomic::Ordering::Relaxed);
        (offsets, entries)
    }

    /// How many radiosity corrections were uploaded (a kernel with the
    /// last one uploaded reuses its buffers).
    #[cfg(any(test, feature = "internals"))]
    pub fn correction_uploads(&self) -> u32 {
        self.correction_uploads.load(std::sync::atomic::Ordering::Relaxed)
    }

    /// One bind group a segment for `gather_bounce` reading `radiosity`
    /// and writing `bounce`.
    fn gather_groups(&self, radiosity: &wgpu::Buffer, bounce: &wgpu::Buffer) -> Vec<wgpu::BindGroup> {
        self.segments
            .iter()
            .map(|g| {
                self.dev.device.create_bind_group(&wgpu::BindGroupDescriptor {
                    label: Some("gather_bounce bind group"),
                    layout: &self.gather.get_bind_group_layout(0),
                    entries: &[
                        (0, &g.uniforms),
                        (1, &g.offsets),
                        (2, &g.stream),
                        (3, &g.weights),
                        (4, radiosity),
                        (5, bounce),
                        (9, &g.starts),
                    ]
                    .iter()
                    .map(|(i, b)| wgpu::BindGroupEntry { binding: *i, resource: b.as_entire_binding() })
                    .collect::<Vec<_>>(),
                })
            })
            .collect()
    }

    /// Every link's target as the WGSL decoder reads it from the uploaded
    /// stream (`decode_targets`), in link order: equal to `Links::targets`.
    #[cfg(any(test, feature = "internals"))]
    pub fn decode_targets(&self) -> Result<Vec<u32>> {
        checked(&self.dev, "decoding link targets", || {
            let d = &self.dev.device;
            let mut out = Vec::new();
            for (i, g) in self.segments.iter().enumerate() {
                let decoded =
                    storage_init(d, &format!("decoded targets, segment {i}"), &vec![u32::MAX; g.links.max(1)]);
                let group = d.create_bind_group(&wgpu::BindGroupDescriptor {
                    label: Some("decode_targets bind group"),
                    layout: &self.decode.get_bind_group_layout(0),
                    entries: &[(0, &g.uniforms), (1, &g.offsets), (2, &g.stream), (9, &g.starts), (10, &decoded)]
                        .iter()
                        .map(|(i, b)| wgpu::BindGroupEntry { binding: *i, resource: b.as_entire_binding() })
                        .collect::<Vec<_>>(),
                });
                let mut enc =
                    d.create_command_encoder(&wgpu::CommandEncoderDescriptor { label: Some("decode targets") });
                {
                    let mut pass = enc.begin_compute_pass(&wgpu::ComputePassDescriptor {
                        label: Some("decode targets"),
                        timestamp_writes: None,
                    });
                    pass.set_pipeline(&self.decode);
                    pass.set_bind_group(0, &group, &[]);
                    pass.dispatch_workgroups(g.groups.0, g.groups.1, 1);
                }
                let t: Vec<u32> = read_back(&self.dev, enc, &decoded, "decoded targets")?;
                out.extend_from_slice(&t[..g.links]);
            }
            Ok(out)
        })?
    }
}

fn vec4s(v: &[Vec3]) -> Vec<[f32; 4]> {
    v.iter().map(|e| [e.x, e.y, e.z, 0.0]).collect()
}

/// The per-solve state of the GPU bounce loop.
pub struct GpuBounces<'a> {
    links: &'a GpuLinks,
    /// With the radiosity correction ([`crate::exchange::bounce::reconstruct`]):
    /// the corrected radiosity the gather reads and the
    /// `reconstruct_radiosity` bind group that writes it from `radiosity`
    /// before every bounce after the first (the first gathers `b0`, copied).
    reconstruction: Option<(wgpu::Buffer, wgpu::BindGroup)>,
    bounces_run: u32,
    radiosity: wgpu::Buffer,
    bounce: wgpu::Buffer,
    total: wgpu::Buffer,
    partials: wgpu::Buffer,
    gather_groups: Vec<wgpu::BindGroup>,
    update_group: wgpu::BindGroup,
    group_count: usize,
    /// Hidden vertices and their linkers
    /// ([`crate::exchange::bounce::hidden::stand_ins`]); when set, bounces run one
    /// per submission and the host writes each hidden vertex's radiosity
    /// (`rho/pi` times its linkers' irradiance of the bounce)
    /// before the next, as the CPU kernel does.
    stand_ins: Vec<crate::exchange::bounce::hidden::StandIn>,
    albedo: Vec<Vec3>,
}

impl GpuBounces<'_> {
    /// Applies the hidden-vertex substitution in every bounce (see `stand_ins`).
    pub fn with_stand_ins(mut self, stand_ins: Vec<crate::exchange::bounce::hidden::StandIn>) -> Self {
        self.stand_ins = stand_ins;
        self
    }

    /// Gathers, from the second bounce on, the radiosity corrected by `r`
    /// ([`crate::exchange::bounce::reconstruct`], as
    /// [`crate::exchange::bounce::gather::CpuBounces::with_reconstruction`]);
    /// uploads its weights. `None`: unchanged.
    pub fn with_reconstruction(mut self, r: Option<&Arc<crate::exchange::Reconstruction>>) -> Result<Self> {
        let Some(r) = r else { return Ok(self) };
        let l = self.links;
        if r.rows() != l.n as usize {
            return Err(crate::Error::Gpu(format!(
                "radiosity correction for {} vertices, links for {}",
                r.rows(),
                l.n
            )));
        }
        let dev = l.dev.clone();
        let (corrected, group) = checked(&dev, "uploading the radiosity correction", || {
            let d = &dev.device;
            let corrected = storage_init(d, "corrected radiosity", &vec![[0f32; 4]; l.n as usize]);
            let (offsets, entries) = l.upload_correction(r);
            let group = d.create_bind_group(&wgpu::BindGroupDescriptor {
                label: Some("reconstruct_radiosity bind group"),
                layout: &l.reconstruct.get_bind_group_layout(0),
                entries: &[(0, &l.uniforms), (4, &self.radiosity), (11, &corrected), (12, &offsets), (13, &entries)]
                    .iter()
                    .map(|(i, b)| wgpu::BindGroupEntry { binding: *i, resource: b.as_entire_binding() })
                    .collect::<Vec<_>>(),
            });
            (corrected, group)
        })?;
        self.gather_groups = l.gather_groups(&corrected, &self.bounce);
        self.reconstruction = Some((corrected, group));
        Ok(self)
    }
}

impl BounceKernel for GpuBounces<'_> {
    fn run_bounces(&mut self, count: u32) -> Result<Vec<[f64; 3]>> {
        let dev = self.links.dev.clone();
        if self.stand_ins.is_empty() {
            return checked(&dev, "bounces", || self.bounces(count))?;
        }
        let mut totals = Vec::with_capacity(count as usize);
        for _ in 0..count {
            totals.extend(checked(&dev, "bounces", || self.bounces(1))??);
            checked(&dev, "hidden vertices", || self.substitute())??;
        }
        Ok(totals)
    }

    fn finish(&mut self, tail: Vec3) -> Result<Vec<Vec3>> {
        let dev = self.links.dev.clone();
        checked(&dev, "reading E_i", || self.read_total(tail))?
    }
}

impl GpuBounces<'_> {
    fn bounces(&mut self, count: u32) -> Result<Vec<[f64; 3]>> {
        let l = self.links;
        let d = &l.dev.device;
        let slot = (self.group_count * 16) as u64;
        let all_partials = d.create_buffer(&wgpu::BufferDescriptor {
            label: Some("bounce totals"),
            size: slot * count.max(1) as u64,
            usage: wgpu::BufferUsages::STORAGE | wgpu::BufferUsages::COPY_DST | wgpu::BufferUsages::COPY_SRC,
            mapped_at_creation: false,
        });
        let mut enc = d.create_command_encoder(&wgpu::CommandEncoderDescriptor { label: Some("bounces") });
        for b in 0..count {
            match &self.reconstruction {
                Some((corrected, _)) if self.bounces_run == 0 => {
                    enc.copy_buffer_to_buffer(&self.radiosity, 0, corrected, 0, self.radiosity.size());
                }
                Some((_, group)) => {
                    let mut pass = enc.begin_compute_pass(&wgpu::ComputePassDescriptor {
                        label: Some("reconstruct radiosity"),
                        timestamp_writes: None,
                    });
                    pass.set_pipeline(&l.reconstruct);
                    pass.set_bind_group(0, group, &[]);
                    pass.dispatch_workgroups(l.groups.0, l.groups.1, 1);
                }
                None => {}
            }
            self.bounces_run += 1;
            {
                let mut pass = enc
                    .begin_compute_pass(&wgpu::ComputePassDescriptor { label: Some("bounce"), timestamp_writes: None });
                pass.set_pipeline(&l.gather);
                for (seg, group) in l.segments.iter().zip(&self.gather_groups) {
                    pass.set_bind_group(0, group, &[]);
                    pass.dispatch_workgroups(seg.groups.0, seg.groups.1, 1);
                }
                pass.set_pipeline(&l.update);
                pass.set_bind_group(0, &self.update_group, &[]);
                pass.dispatch_workgroups(l.groups.0, l.groups.1, 1);
            }
            enc.copy_buffer_to_buffer(&self.partials, 0, &all_partials, b as u64 * slot, slot);
        }
        let sums: Vec<[f32; 4]> = read_back(&l.dev, enc, &all_partials, "bounce totals")?;
        Ok(sums
            .chunks(self.group_count)
            .take(count as usize)
            .map(|c| {
                c.iter().fold([0f64; 3], |mut s, p| {
                    s[0] += p[0] as f64;
                    s[1] += p[1] as f64;
                    s[2] += p[2] as f64;
                    s
                })
            })
            .collect())
    }

    /// Writes the hidden vertices' radiosity from the newest bounce.
    fn substitute(&mut self) -> Result<()> {
        let l = self.links;
        let enc = l.dev.device.create_command_encoder(&wgpu::CommandEncoderDescriptor { label: Some("read E^(b)") });
        let e: Vec<[f32; 4]> = read_back(&l.dev, enc, &self.bounce, "bounce irradiance")?;
        for (h, linkers) in &self.stand_ins {
            let mean =
                crate::exchange::bounce::hidden::stand_in_irradiance(linkers, |u| Vec3::new(e[u][0], e[u][1], e[u][2]));
            let b = radiosity(self.albedo[*h], mean, Vec3::ZERO);
            l.dev.queue.write_buffer(&self.radiosity, (*h * 16) as u64, bytemuck::cast_slice(&[b.x, b.y, b.z, 0.0f32]));
        }
        Ok(())
    }

    fn read_total(&mut self, tail: Vec3) -> Result<Vec<Vec3>> {
        let l = self.links;
        let enc = |label| l.dev.device.create_command_encoder(&wgpu::CommandEncoderDescriptor { label: Some(label) });
        let total: Vec<[f32; 4]> = read_back(&l.dev, enc("read E_i"), &self.total, "indirect irradiance")?;
        let mut e_i: Vec<Vec3> = total.iter().take(l.n as usize).map(|t| Vec3::new(t[0], t[1], t[2])).collect();
        if tail != Vec3::ZERO {
            let last: Vec<[f32; 4]> = read_back(&l.dev, enc("read E^(b)"), &self.bounce, "bounce irradiance")?;
            for (e, b) in e_i.iter_mut().zip(&last) {
                *e += Vec3::new(b[0], b[1], b[2]) * tail;
            }
        }
        Ok(e_i)
    }
}
