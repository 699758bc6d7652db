//! `errors.csv`: one line per sweep setting, times in ms, errors unitless
//! (column names say which quantity and statistic).

use super::{ErrorStats, SweepRow};
use std::fmt::Write;

/// The CSV header line (no newline).
pub const HEADER: &str =
    "scene,rays,bounces,bounces_used,smoothing_deg,kd_ms,links_ms,light_links_ms,gather_ms,smooth_ms,total_ms,\
ei_rel_rmse,ei_rel_rmse_corrected,ei_bias,ei_p95,ed_rel_rmse,ed_rel_rmse_corrected,ed_bias,ed_p95,\
total_rel_rmse,total_rel_rmse_corrected,total_bias,total_p95";

fn stats(out: &mut String, e: &ErrorStats) {
    let _ = write!(out, ",{:.6e},{:.6e},{:.6e},{:.6e}", e.rel_rmse, e.rel_rmse_corrected, e.bias, e.p95);
}

/// The whole file for `rows` of scene `scene`.
pub fn to_csv(scene: &str, rows: &[SweepRow]) -> String {
    let mut out = String::from(HEADER);
    out.push('\n');
    for r in rows {
        let _ = write!(
            out,
            "{scene},{},{},{},{},{:.3},{:.3},{:.3},{:.3},{:.3},{:.3}",
            r.rays,
            r.bounces,
            r.bounces_used,
            r.smoothing_deg,
            r.kd_ms,
            r.links_ms,
            r.light_links_ms,
            r.gather_ms,
            r.smooth_ms,
            r.total_ms
        );
        stats(&mut out, &r.e_indirect);
        stats(&mut out, &r.e_direct);
        stats(&mut out, &r.e_total);
        out.push('\n');
    }
    out
}
