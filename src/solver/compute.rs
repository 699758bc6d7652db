//! Where a solve runs: the CPU or GPU devices ([`Compute`]), the GPU
//! state a solver keeps ([`GpuState`]), and the one "GPU, else the CPU"
//! rule ([`Tracers::any`]): a stage traced on the GPU that fails falls back to
//! the CPU structure with one warning; stages the GPU tracer cannot serve
//! (arbitrary closest-hit batches, single-origin CPU walks) go to the CPU
//! structure directly ([`Tracers::cpu`]).

use crate::gpu::{self, Backend, DeviceShare, GpuDevice, GpuLinks, GpuTracer, ScheduleParams};
use crate::trace::{Accel, Tracer};
use std::sync::Arc;
use std::time::Duration;

/// `--backend auto` with a hardware GPU runs the GPU path only on machines
/// with fewer CPU threads than this. Measured (docs/GPU.md, 2026-11-26): on
/// an NVIDIA H200 beside 16 threads of a Xeon the GPU path's first solution
/// took 1.07-1.7x the CPU path's (tearoom, sculpture, conference, dancer),
/// its link shooting 0.4-0.75x; the CPU's link stage scales with its
/// threads (2 Zen 4 threads: 6.3-6.8 M rays/s, 16 Xeon threads: 26-35 M), so
/// the GPU's kd-tree path (40-65 M rays/s with merging) wins the first
/// solution below about 16 / 1.7 ~ 9-15 threads; 12 is the middle.
pub const AUTO_GPU_BELOW_THREADS: usize = 12;

/// Whether `--backend auto` runs GI on a hardware GPU, given the CPU's
/// worker threads (see [`AUTO_GPU_BELOW_THREADS`]).
pub fn auto_prefers_gpu(cpu_threads: usize) -> bool {
    cpu_threads < AUTO_GPU_BELOW_THREADS
}

/// Where links, light links and bounces are computed.
#[derive(Clone, Debug, Default)]
pub enum Compute {
    /// On the CPU.
    #[default]
    Cpu,
    /// On the GPU devices of a [`GpuCompute`].
    Gpu(GpuCompute),
}

internal_fields! {
    /// The GPU devices of a solve and how to split them (built with
    /// [`GpuCompute::new`] and its `with_` methods, which keep at least one
    /// logical device an adapter).
    #[derive(Clone, Debug)]
    pub struct GpuCompute {
        /// The opened adapters.
        pub devices: Vec<Arc<GpuDevice>>,
        /// Logical devices per adapter (`--devices N`: the scheduler splits work between them).
        pub logical_per_device: usize,
        /// Artificial extra time per vertex for each logical device, in order
        /// (the scheduler's tests: `GpuCompute::with_delays`).
        pub delays: Vec<Duration>,
        /// How vertex batches are split between the logical devices.
        pub schedule: ScheduleParams,
    }
}

impl GpuCompute {
    /// The GPU path on `devices` (from `gpu::open_all` or a caller's own
    /// device, [`GpuDevice::from_wgpu`]), one logical device each, default schedule.
    pub fn new(devices: Vec<Arc<GpuDevice>>) -> GpuCompute {
        GpuCompute { devices, logical_per_device: 1, delays: Vec::new(), schedule: ScheduleParams::default() }
    }

    /// `logical` logical devices per adapter (`--devices N`; at least 1).
    pub fn with_logical(mut self, logical: usize) -> GpuCompute {
        self.logical_per_device = logical.max(1);
        self
    }

    /// Vertex batches split between the logical devices by `schedule`.
    pub fn with_schedule(mut self, schedule: ScheduleParams) -> GpuCompute {
        self.schedule = schedule;
        self
    }

    /// The adapters it runs on.
    pub fn devices(&self) -> &[Arc<GpuDevice>] {
        &self.devices
    }

    /// Test hook (feature `internals`): extra time per vertex for each
    /// logical device, in order, so the scheduler meets devices of unequal speed.
    #[cfg(feature = "internals")]
    #[doc(hidden)]
    pub fn with_delays(mut self, delays: Vec<Duration>) -> GpuCompute {
        self.delays = delays;
        self
    }

    pub(crate) fn delays(&self) -> &[Duration] {
        &self.delays
    }
}

impl Compute {
    /// Resolves a backend setting. `Auto` picks by `auto_prefers_gpu`
    /// and says which path runs and why in a one-line note; `Gpu` with no
    /// adapter is an error.
    pub fn from_backend(backend: Backend, logical_per_device: usize) -> crate::Result<(Compute, Option<String>)> {
        let devices = gpu::devices_for(backend)?;
        if devices.is_empty() {
            let note = (backend == Backend::Auto).then(|| {
                "no hardware GPU adapter found: using the CPU path (--backend gpu uses software adapters too)"
                    .to_string()
            });
            return Ok((Compute::Cpu, note));
        }
        let threads = rayon::current_num_threads();
        let mut note = None;
        if backend == Backend::Auto {
            let name = &devices[0].info.name;
            if !auto_prefers_gpu(threads) {
                let note = format!(
                    "using the CPU path ({threads} threads) rather than {name}: with {AUTO_GPU_BELOW_THREADS} or more \
                     threads it reaches the first solution sooner than the GPU path (measured on an H200 against 16 \
                     threads, docs/GPU.md); --backend gpu uses the GPU"
                );
                return Ok((Compute::Cpu, Some(note)));
            }
            note = Some(format!(
                "using the GPU path on {name}: with fewer than {AUTO_GPU_BELOW_THREADS} CPU threads ({threads} here) \
                 it reaches the first solution sooner (docs/GPU.md); --backend cpu uses the CPU"
            ));
        }
        Ok((Compute::Gpu(GpuCompute::new(devices).with_logical(logical_per_device)), note))
    }

    /// "cpu (threads, processor, BVH node tests)" or the adapters used.
    pub fn describe(&self) -> String {
        match self {
            Compute::Cpu => format!(
                "cpu ({} threads; {}; BVH node tests {:?})",
                rayon::current_num_threads(),
                cpu_model(),
                crate::bvh::Isa::detect()
            ),
            Compute::Gpu(g) => {
                let names: Vec<String> = g.devices.iter().map(|d| d.describe()).collect();
                let split = if g.logical_per_device > 1 {
                    format!(" x{} logical", g.logical_per_device)
                } else {
                    String::new()
                };
                format!("gpu: {}{split}", names.join(", "))
            }
        }
    }
}

/// The tracers of one solver: the GPU's (when there is one) and the CPU structure.
#[derive(Clone)]
pub(crate) struct Tracers<'a> {
    pub gpu: Option<&'a GpuTracer>,
    cpu: &'a Accel,
    /// Set whenever the CPU structure is handed out ([`Tracers::take_cpu_used`]).
    cpu_used: std::cell::Cell<bool>,
}

impl<'a> Tracers<'a> {
    /// The tracers of a solver with GPU state `gpu` and CPU structure `cpu`.
    pub fn of(gpu: &'a Option<GpuState>, cpu: &'a Accel) -> Tracers<'a> {
        Tracers { gpu: gpu.as_ref().map(|g| &g.tracer), cpu, cpu_used: std::cell::Cell::new(false) }
    }

    /// `f` run with the GPU tracer when there is one; where it fails (or
    /// without one), with the CPU structure, which cannot fail. `what`
    /// names the stage in the warning.
    pub fn any<T>(&self, what: &str, mut f: impl FnMut(&dyn Tracer) -> crate::Result<T>) -> T {
        let on_gpu = self.gpu.map(|g| f(g));
        gpu_else_cpu(what, on_gpu, || f(self.cpu()).expect("a CPU tracer cannot fail"))
    }

    /// The CPU structure, for stages that walk it ray by ray.
    pub fn cpu(&self) -> &'a Accel {
        self.cpu_used.set(true);
        self.cpu
    }

    /// Whether the CPU structure was handed out since the last call.
    pub fn take_cpu_used(&self) -> bool {
        self.cpu_used.replace(false)
    }
}

/// The one "GPU, else the CPU" rule: the GPU's result where the GPU was
/// tried (`on_gpu` is `Some`) and succeeded; where it failed, a warning
/// naming `what` and the CPU's result; without a GPU, the CPU's.
pub(crate) fn gpu_else_cpu<T>(what: &str, on_gpu: Option<crate::Result<T>>, cpu: impl FnOnce() -> T) -> T {
    match on_gpu {
        Some(Ok(t)) => t,
        Some(Err(e)) => {
            log::warn!("{e}; {what} on the CPU");
            cpu()
        }
        None => cpu(),
    }
}

/// GPU resources a solver keeps between solves.
pub struct GpuState {
    /// Traces shadow rays when lights move.
    pub tracer: GpuTracer,
    /// Links and albedo on the device.
    pub links: GpuLinks,
    /// How link generation was split between devices.
    pub shares: Vec<DeviceShare>,
}

/// The processor's name with its family and model numbers (Linux:
/// `/proc/cpuinfo`; a VM's name alone, "AMD EPYC", does not tell Zen 3 from
/// Zen 4), or the architecture where it cannot be read: figures that set
/// our tracer beside another depend on it (AVX-512 or not, above all).
fn cpu_model() -> String {
    let Ok(info) = std::fs::read_to_string("/proc/cpuinfo") else {
        return std::env::consts::ARCH.to_string();
    };
    // The first processor's value of `key`.
    let field = |key: &str| {
        info.lines()
            .find(|l| l.split(':').next().is_some_and(|k| k.trim() == key))
            .and_then(|l| l.split_once(':'))
            .map(|(_, v)| v.split_whitespace().collect::<Vec<_>>().join(" "))
            .filter(|v| !v.is_empty())
    };
    match (field("model name"), field("cpu family"), field("model")) {
        (Some(name), Some(family), Some(model)) => format!("{name}, family {family} model {model}"),
        (Some(name), _, _) => name,
        _ => std::env::consts::ARCH.to_string(),
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// The measured machine (16 threads beside an H200) runs the CPU path;
    /// the development VM's 2 threads and a 4-core laptop the GPU's.
    #[test]
    fn auto_follows_the_measured_crossover() {
        assert!(!auto_prefers_gpu(16));
        assert!(auto_prefers_gpu(2) && auto_prefers_gpu(8));
    }
}
