//! The GPU path (docs/DESIGN.md §5), wgpu compute, headless:
//! - [`context`]: adapters and devices for the `backend` setting
//!   ([`Backend`], defined in `crate::scene`);
//! - [`tracer`]: the kd-tree on a device, `shoot_rays` and `light_visibility`
//!   (`shaders/shoot.wgsl`);
//! - [`schedule`]: batches over several (logical) devices, sized from each
//!   one's measured speed, merged on the CPU while the next batch traces;
//! - [`gather`]: the bounce loop as sparse matrix-vector products on the
//!   device (`shaders/gather.wgsl`);
//! - [`layout`]: the `repr(C)` structs shared with WGSL.
//!
//! Every stage has a CPU twin that gives the same results for the same
//! rays and is the GPU's test oracle. Deviation: the shader's triangle test
//! has no f64 fallback for edge functions that round to exactly zero, so a
//! ray through a shared edge or vertex may pick the neighbouring triangle
//! (measured: well under 0.1% of rays). Smoothing stays on the CPU: it
//! touches each one-ring once and costs less than a read-back of the
//! result would.

pub mod buffers;
pub mod context;
pub mod gather;
pub mod layout;
pub mod schedule;
pub mod tracer;

pub use crate::scene::Backend;
pub use context::{devices_for, open_all, GpuDevice};
pub use gather::GpuLinks;
pub use schedule::{shoot_links_gpu, DeviceShare, LogicalDevice, ScheduleParams};
pub use tracer::GpuTracer;

use crate::kdtree::{Hit, Ray};
use crate::trace::Tracer;
use layout::ShadowRay;

/// Shadow rays go through the `light_visibility` pipeline; link rays
/// through `shoot_rays` batches of vertices ([`shoot_links_gpu`]).
impl Tracer for GpuTracer {
    fn name(&self) -> &'static str {
        "gpu-kd"
    }

    /// The rope shader traces closest hits only as whole vertices' ray
    /// sets (`shoot_rays`, [`shoot_links_gpu`]); a batch of arbitrary rays
    /// is refused with an error, and callers fall back to a CPU tracer.
    fn closest_hits(&self, rays: &[Ray]) -> crate::Result<Vec<Option<Hit>>> {
        Err(crate::Error::Gpu(format!(
            "{}: closest hits of {} arbitrary rays: the GPU tracer shoots whole vertices' ray sets only",
            self.dev.info.name,
            rays.len()
        )))
    }

    fn visible(&self, rays: &[Ray]) -> crate::Result<Vec<bool>> {
        let gpu: Vec<ShadowRay> = rays
            .iter()
            .map(|r| ShadowRay {
                origin: r.origin.into(),
                skip: r.skip,
                dir: r.dir.into(),
                tmin: r.tmin,
                tmax: r.tmax.min(3.0e38),
                ..Default::default()
            })
            .collect();
        Ok(self.visibility(&gpu)?.into_iter().map(|v| v != 0).collect())
    }
}
