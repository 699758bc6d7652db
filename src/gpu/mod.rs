//! The GPU path (docs/DESIGN.md §5), wgpu compute, headless:
//! - [`context`]: adapters and devices for the `backend` setting
//!   ([`Backend`], defined in `crate::scene`);
//! - [`tracer`]: one structure on a device ([`GpuWalk`]: the 8-wide BVH,
//!   the rope kd-tree or hardware ray queries) and the entry points of
//!   `shaders/trace.wgsl`, serving the whole [`Tracer`] interface;
//! - [`rayquery`]: the driver's acceleration structures for ray queries;
//! - [`schedule`]: batches over several (logical) devices, sized from each
//!   one's measured speed, merged on the CPU while the next batch traces;
//! - [`gather`]: the bounce loop as sparse matrix-vector products on the
//!   device (`shaders/gather.wgsl`);
//! - [`layout`]: the `repr(C)` structs shared with WGSL.
//!
//! Every stage has a CPU twin that gives the same results for the same
//! rays and is the GPU's test oracle. Deviation: the shader's triangle test
//! has no f64 fallback for edge functions that round to exactly zero, and a
//! GPU may fuse multiplies and adds, so a ray through a shared edge or
//! vertex may pick the neighbouring triangle (measured: well under 0.1% of
//! rays). Smoothing stays on the CPU: it touches each one-ring once and
//! costs less than a read-back of the result would.

pub mod buffers;
pub mod context;
pub mod gather;
pub mod layout;
pub mod rayquery;
pub mod schedule;
pub mod tracer;

pub use crate::scene::Backend;
pub use context::{devices_for, open_all, GpuDevice};
pub use gather::GpuLinks;
pub use schedule::{shoot_links_gpu, DeviceShare, LogicalDevice, ScheduleParams};
pub use tracer::{GpuTracer, GpuWalk};

use crate::trace::ray::{Hit, Ray};
use crate::links::HitRecord;
use crate::trace::{OriginRays, Tracer};
use layout::ShadowRay;

/// Every query runs on the device: origin rays through `shoot_rays`,
/// closest hits through `closest_hits`, shadow rays through
/// `light_visibility`, each in batches of at most
/// [`GpuTracer::max_batch_rays`].
impl Tracer for GpuTracer {
    #[cfg(any(test, feature = "internals"))]
    fn name(&self) -> &'static str {
        self.walk().name()
    }

    fn origin_rays(&self, batch: &OriginRays) -> crate::Result<Vec<Option<Hit>>> {
        if batch.is_empty() {
            return Ok(vec![None; batch.len()]);
        }
        let dirs = tracer::direction_buffer(&self.dev.device, &batch.directions);
        let verts = tracer::ray_vertices_of(batch);
        let per_batch = (self.max_batch_rays() / batch.per_origin).max(1);
        let mut out = Vec::with_capacity(batch.len());
        for chunk in verts.chunks(per_batch) {
            let records = self.shoot_with(chunk, &dirs, batch.per_origin as u32)?;
            out.extend(records.into_iter().map(HitRecord::hit));
        }
        Ok(out)
    }

    fn closest_hits(&self, rays: &[Ray]) -> crate::Result<Vec<Option<Hit>>> {
        let mut out = Vec::with_capacity(rays.len());
        for chunk in rays.chunks(self.max_batch_rays().max(1)) {
            let gpu: Vec<ShadowRay> = chunk.iter().map(shadow_ray).collect();
            out.extend(self.closest(&gpu)?.into_iter().map(HitRecord::hit));
        }
        Ok(out)
    }

    fn visible(&self, rays: &[Ray]) -> crate::Result<Vec<bool>> {
        let mut out = Vec::with_capacity(rays.len());
        for chunk in rays.chunks(self.max_batch_rays().max(1)) {
            let gpu: Vec<ShadowRay> = chunk.iter().map(shadow_ray).collect();
            out.extend(self.visibility(&gpu)?.into_iter().map(|v| v != 0));
        }
        Ok(out)
    }
}

/// A ray as the shader reads it (`tmax` clamped to a finite 3e38: a GPU
/// need not keep infinities).
fn shadow_ray(r: &Ray) -> ShadowRay {
    ShadowRay {
        origin: r.origin.into(),
        skip: r.skip,
        dir: r.dir.into(),
        tmin: r.tmin,
        tmax: r.tmax.min(3.0e38),
        ..Default::default()
    }
}
