//! `errors.csv`: one line per link-solver setting (`method = links`), per
//! path-tracer step (`path`) and for the light-move preview (`preview`);
//! times in ms, errors unitless (column names say which quantity and
//! statistic). `against` says what a line is scored against: the
//! high-sample `reference`, or (the preview) the `full` result after the
//! move. Cells that do not apply to a method are empty. The last two
//! columns put each link setting beside the path tracer at the same run
//! time ([`super::path::error_at`]): the path tracer's total relative RMSE
//! there and its ratio to the setting's.

use super::path::{error_at, PathRow};
use super::preview::PreviewRow;
use super::{ErrorStats, SweepRow};
use std::fmt::Write;

/// The CSV header line (no newline).
pub const HEADER: &str = "method,against,scene,rays,bounces,bounces_used,smoothing_deg,\
kd_ms,links_ms,light_links_ms,gather_ms,smooth_ms,total_ms,\
ei_rel_rmse,ei_rel_rmse_corrected,ei_bias,ei_p95,ed_rel_rmse,ed_rel_rmse_corrected,ed_bias,ed_p95,\
total_rel_rmse,total_rel_rmse_corrected,total_bias,total_p95,path_total_rel_rmse_at_equal_time,equal_time_ratio";

fn stats(out: &mut String, e: &ErrorStats) {
    let _ = write!(out, ",{:.6e},{:.6e},{:.6e},{:.6e}", e.rel_rmse, e.rel_rmse_corrected, e.bias, e.p95);
}

/// The path tracer's error at `total_ms` and its ratio to `err` (empty cells without a ladder).
pub fn equal_time(path: &[PathRow], total_ms: f64, err: f64) -> Option<(f64, f64)> {
    error_at(path, total_ms).map(|p| (p, p / err))
}

/// The whole file for scene `scene`.
pub fn to_csv(scene: &str, rows: &[SweepRow], path: &[PathRow], preview: Option<&PreviewRow>) -> String {
    let mut out = String::from(HEADER);
    out.push('\n');
    for r in rows {
        let _ = write!(
            out,
            "links,reference,{scene},{},{},{},{},{:.3},{:.3},{:.3},{:.3},{:.3},{:.3}",
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
        match equal_time(path, r.total_ms, r.e_total.rel_rmse_corrected) {
            Some((p, ratio)) => {
                let _ = write!(out, ",{p:.6e},{ratio:.4}");
            }
            None => out.push_str(",,"),
        }
        out.push('\n');
    }
    for p in path {
        let _ = write!(out, "path,reference,{scene},{},,,0,,,,,,{:.3}", p.samples, p.ms);
        stats(&mut out, &p.e_indirect);
        stats(&mut out, &p.e_direct);
        stats(&mut out, &p.e_total);
        out.push_str(",,\n");
    }
    if let Some(p) = preview {
        let _ = write!(
            out,
            "preview,full,{scene},{},auto,,{},,,{:.3},,,{:.3}",
            p.rays, p.smoothing_deg, p.preview_light_links_ms, p.preview_ms
        );
        stats(&mut out, &p.e_indirect);
        stats(&mut out, &p.e_direct);
        stats(&mut out, &p.e_total);
        out.push_str(",,\n");
    }
    out
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn every_line_has_the_header_s_columns() {
        let e = ErrorStats { rel_rmse: 0.1, rel_rmse_corrected: 0.05, bias: 0.0, p95: 0.2 };
        let row = SweepRow {
            rays: 16,
            bounces: "auto".into(),
            bounces_used: 9,
            smoothing_deg: 30.0,
            kd_ms: 1.0,
            links_ms: 2.0,
            light_links_ms: 3.0,
            gather_ms: 4.0,
            smooth_ms: 5.0,
            total_ms: 15.0,
            e_indirect: e,
            e_direct: e,
            e_total: e,
        };
        let path = PathRow {
            samples: 16,
            ms: 15.0,
            e_indirect: e,
            e_direct: e,
            e_total: ErrorStats { rel_rmse_corrected: 0.5, ..e },
        };
        let preview = PreviewRow {
            rays: 16,
            smoothing_deg: 30.0,
            preview_light_links_ms: 1.0,
            preview_ms: 2.0,
            full_ms: 3.0,
            preview_shadow_rays: 10,
            full_shadow_rays: 100,
            e_indirect: e,
            e_direct: e,
            e_total: e,
        };
        let csv = to_csv("s", &[row], &[path], Some(&preview));
        let columns = HEADER.split(',').count();
        let lines: Vec<&str> = csv.lines().collect();
        assert_eq!(lines.len(), 4);
        for l in &lines {
            assert_eq!(l.split(',').count(), columns, "{l}");
        }
        // Same time as the path tracer's step: ratio 0.5 / 0.05.
        assert!(lines[1].starts_with("links,reference,s,16,auto") && lines[1].ends_with(",10.0000"), "{}", lines[1]);
        assert!(lines[2].starts_with("path,reference,s,16,"));
        assert!(lines[3].starts_with("preview,full,s,16,auto"));
    }
}
