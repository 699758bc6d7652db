//! The path tracer beside the link solver: the reference solver
//! ([`crate::reference`]) run at a ladder of samples per vertex (16, 64,
//! 256, ...) with another seed than the high-sample reference, each run
//! timed (BVH build + tracing, ms) and scored against that reference; and
//! the error of the path tracer at the link solver's run time.
//!
//! Equal time: the path tracer's total relative RMSE at time `t` is
//! interpolated linearly in `log t`, `log error` between the two ladder
//! steps around `t`; outside the ladder it is extrapolated from the nearest
//! step with the Monte Carlo rate `error ~ t^-1/2` (the path tracer's error
//! is its noise, whose variance falls as 1/samples and whose time grows as
//! samples). The ratio at equal time is that error over the link solver's.

use super::metrics::{error_stats, ErrorStats};
use crate::reference::{self, Reference, ReferenceParams};
use crate::scene::prep::PreparedScene;
use serde::Serialize;
use std::time::Instant;

/// One step of the ladder.
#[derive(Clone, Debug, PartialEq, Serialize)]
pub struct PathRow {
    /// Paths per vertex.
    pub samples: u32,
    /// Wall time of the run (BVH build and tracing), ms.
    pub ms: f64,
    /// Errors of the indirect irradiance against the reference.
    pub e_indirect: ErrorStats,
    /// Errors of the direct irradiance against the reference.
    pub e_direct: ErrorStats,
    /// Errors of the total irradiance against the reference.
    pub e_total: ErrorStats,
}

/// The default ladder under a reference of `ref_samples` paths: 16, 64,
/// 256, ... up to a quarter of the reference's samples.
pub fn default_ladder(ref_samples: u32) -> Vec<u32> {
    std::iter::successors(Some(16u32), |&s| s.checked_mul(4))
        .take_while(|&s| s.saturating_mul(4) <= ref_samples)
        .collect()
}

/// Runs the path tracer at every count of `samples` with the reference's
/// parameters but seed `reference.params.seed + 1`, scored against `reference`.
/// `progress(done, total)` after each step.
pub fn ladder(
    scene: &PreparedScene,
    reference: &Reference,
    samples: &[u32],
    progress: &dyn Fn(usize, usize),
) -> Vec<PathRow> {
    let total_ref = reference.total();
    let se = &reference.e_indirect_stderr;
    let mut rows = Vec::new();
    for (k, &s) in samples.iter().enumerate() {
        let params =
            ReferenceParams { samples_per_vertex: s, seed: reference.params.seed.wrapping_add(1), ..reference.params };
        let t = Instant::now();
        let r = reference::compute(scene, &params);
        let ms = t.elapsed().as_secs_f64() * 1e3;
        let total = r.total();
        rows.push(PathRow {
            samples: s,
            ms,
            e_indirect: error_stats(&r.e_indirect, &reference.e_indirect, se),
            e_direct: error_stats(&r.e_direct, &reference.e_direct, &[]),
            e_total: error_stats(&total, &total_ref, &reference.e_total_stderr),
        });
        progress(k + 1, samples.len());
    }
    rows
}

/// The path tracer's error (total relative RMSE, reference noise removed)
/// at run time `ms`, from `rows` (see the module doc); None without rows.
pub fn error_at(rows: &[PathRow], ms: f64) -> Option<f64> {
    let mut pts: Vec<(f64, f64)> = rows
        .iter()
        .map(|r| (r.ms, r.e_total.rel_rmse_corrected))
        .filter(|(t, e)| *t > 0.0 && *e > 0.0 && t.is_finite() && e.is_finite())
        .collect();
    pts.sort_by(|a, b| a.0.total_cmp(&b.0));
    let (first, last) = (*pts.first()?, *pts.last()?);
    if ms <= first.0 {
        return Some(first.1 * (first.0 / ms).sqrt());
    }
    if ms >= last.0 {
        return Some(last.1 * (last.0 / ms).sqrt());
    }
    let i = pts.iter().position(|p| p.0 >= ms)?;
    let ((t0, e0), (t1, e1)) = (pts[i - 1], pts[i]);
    let f = (ms.ln() - t0.ln()) / (t1.ln() - t0.ln());
    Some((e0.ln() + f * (e1.ln() - e0.ln())).exp())
}

#[cfg(test)]
mod tests {
    use super::*;

    fn row(samples: u32, ms: f64, err: f64) -> PathRow {
        let e = ErrorStats { rel_rmse_corrected: err, ..Default::default() };
        PathRow { samples, ms, e_indirect: e, e_direct: ErrorStats::default(), e_total: e }
    }

    #[test]
    fn ladder_stops_at_a_quarter_of_the_reference() {
        assert_eq!(default_ladder(4096), vec![16, 64, 256, 1024]);
        assert_eq!(default_ladder(65536), vec![16, 64, 256, 1024, 4096, 16384]);
        assert!(default_ladder(16).is_empty());
    }

    #[test]
    fn error_at_interpolates_in_log_log_and_extrapolates_with_the_monte_carlo_rate() {
        let rows = [row(16, 10.0, 0.4), row(64, 40.0, 0.2)];
        assert!((error_at(&rows, 10.0).unwrap() - 0.4).abs() < 1e-12);
        assert!((error_at(&rows, 20.0).unwrap() - 0.4 / 2f64.sqrt()).abs() < 1e-9);
        assert!((error_at(&rows, 160.0).unwrap() - 0.1).abs() < 1e-9);
        assert!((error_at(&rows, 2.5).unwrap() - 0.8).abs() < 1e-9);
        assert_eq!(error_at(&[], 1.0), None);
    }
}
