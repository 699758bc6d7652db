//! Error statistics of per-vertex irradiance against a reference (see the
//! module doc of [`crate::accuracy`] for the definitions). Unitless.

use glam::Vec3;
use serde::Serialize;

/// Errors of one quantity.
#[derive(Clone, Copy, Debug, Default, PartialEq, Serialize)]
pub struct ErrorStats {
    /// RMSE / reference mean.
    pub rel_rmse: f64,
    /// The same with the reference's noise variance removed.
    pub rel_rmse_corrected: f64,
    /// (mean - reference mean) / reference mean.
    pub bias: f64,
    /// 95th percentile of per-vertex relative error.
    pub p95: f64,
}

/// Errors of `x` against reference `r` with per-vertex standard errors
/// `stderr` (empty: a noise-free reference).
pub fn error_stats(x: &[Vec3], r: &[Vec3], stderr: &[Vec3]) -> ErrorStats {
    let n = x.len().min(r.len());
    if n == 0 {
        return ErrorStats::default();
    }
    let mut se = 0f64;
    let mut noise = 0f64;
    let (mut sx, mut sr) = (0f64, 0f64);
    for v in 0..n {
        for c in 0..3 {
            let d = x[v][c] as f64 - r[v][c] as f64;
            se += d * d;
            sx += x[v][c] as f64;
            sr += r[v][c] as f64;
            if let Some(s) = stderr.get(v) {
                noise += (s[c] as f64).powi(2);
            }
        }
    }
    let m = (3 * n) as f64;
    let mean_r = sr / m;
    if mean_r.is_nan() || mean_r <= 0.0 {
        // Nothing to be relative to: report absolute figures as zero error when x is zero too.
        let zero = if sx == 0.0 { 0.0 } else { f64::INFINITY };
        return ErrorStats { rel_rmse: zero, rel_rmse_corrected: zero, bias: zero, p95: zero };
    }
    let mse = se / m;
    let mut rel: Vec<f64> = (0..n)
        .map(|v| {
            let xv = x[v].element_sum() as f64 / 3.0;
            let rv = r[v].element_sum() as f64 / 3.0;
            (xv - rv).abs() / rv.max(0.01 * mean_r)
        })
        .collect();
    rel.sort_by(f64::total_cmp);
    let p95 = rel[((0.95 * n as f64).ceil() as usize).clamp(1, n) - 1];
    ErrorStats {
        rel_rmse: mse.sqrt() / mean_r,
        rel_rmse_corrected: (mse - noise / m).max(0.0).sqrt() / mean_r,
        bias: (sx / m - mean_r) / mean_r,
        p95,
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn known_errors() {
        let r = vec![Vec3::splat(1.0), Vec3::splat(3.0)];
        // +10% everywhere: RMSE sqrt((0.01 + 0.09) / 2) / 2, bias 0.1, p95 0.1.
        let x: Vec<Vec3> = r.iter().map(|v| *v * 1.1).collect();
        let e = error_stats(&x, &r, &[]);
        assert!((e.rel_rmse - (0.05f64).sqrt() / 2.0).abs() < 1e-6);
        assert!((e.bias - 0.1).abs() < 1e-6 && (e.p95 - 0.1).abs() < 1e-6);
        assert_eq!(e.rel_rmse, e.rel_rmse_corrected);
        // Reference noise as large as the error removes it.
        let noise = vec![Vec3::splat(0.1), Vec3::splat(0.3)];
        assert!(error_stats(&x, &r, &noise).rel_rmse_corrected < 1e-3); // f32 rounding of x
        assert_eq!(error_stats(&r, &r, &[]), ErrorStats::default());
    }
}
