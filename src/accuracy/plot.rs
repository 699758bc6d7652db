//! `errors.png`: error of the total irradiance `E_d + E_i` (relative RMSE,
//! reference noise removed) against run time (ms), both on log axes. Every
//! link-solver setting is a dot, one colour per smoothing setting, with a
//! line along that setting's Pareto front (the lowest error reached by any
//! faster-or-equal setting); the paper's default (256 rays, 3 bounces,
//! smoothing on) is ringed. The path tracer's ladder is a black line with
//! squares, labelled with its samples per vertex; the ratio of the path
//! tracer's error to the link solver's at equal time is printed for the
//! auto-bounce, smoothed settings. Text uses the bundled DejaVu Sans
//! (assets/fonts), so no system font library is needed.

use super::path::{error_at, PathRow};
use super::SweepRow;
use crate::Error;
use plotters::prelude::*;
use std::path::Path;
use std::sync::Once;

static FONT: Once = Once::new();

fn register_font() {
    FONT.call_once(|| {
        let bytes: &'static [u8] = include_bytes!("../../assets/fonts/DejaVuSans.ttf");
        // The font is bundled and valid; a failure would only lose the text.
        let _ = plotters::style::register_font("sans-serif", FontStyle::Normal, bytes);
    });
}

/// Smallest error drawn (log axis).
const FLOOR: f64 = 1e-4;

fn err(r: &SweepRow) -> f64 {
    r.e_total.rel_rmse_corrected.max(FLOOR)
}

fn path_err(p: &PathRow) -> f64 {
    p.e_total.rel_rmse_corrected.max(FLOOR)
}

/// Lower envelope of `(time, error)` points: sorted by time, each kept if it beats every faster one.
pub fn pareto(points: &[(f64, f64)]) -> Vec<(f64, f64)> {
    let mut p = points.to_vec();
    p.sort_by(|a, b| a.0.total_cmp(&b.0).then(a.1.total_cmp(&b.1)));
    let mut out: Vec<(f64, f64)> = Vec::new();
    for q in p {
        if out.last().is_none_or(|l| q.1 < l.1) {
            out.push(q);
        }
    }
    out
}

fn plot_err<E: std::fmt::Debug>(e: E) -> Error {
    Error::Plot(format!("{e:?}"))
}

/// Draws the plot of `rows` and the path tracer's `ladder` (scene `scene`) into the PNG file `path`.
pub fn plot(scene: &str, rows: &[SweepRow], ladder: &[PathRow], path: &Path) -> crate::Result<()> {
    register_font();
    let finite: Vec<&SweepRow> = rows.iter().filter(|r| r.total_ms.is_finite() && err(r).is_finite()).collect();
    let ladder: Vec<&PathRow> = ladder.iter().filter(|p| p.ms.is_finite() && path_err(p).is_finite()).collect();
    if finite.is_empty() {
        return Err(Error::Plot("no finite errors to plot".into()));
    }
    let (mut x0, mut x1, mut y0, mut y1) = (f64::MAX, f64::MIN, f64::MAX, f64::MIN);
    let points = finite.iter().map(|r| (r.total_ms, err(r))).chain(ladder.iter().map(|p| (p.ms, path_err(p))));
    for (t, e) in points {
        let t = t.max(1e-3);
        x0 = x0.min(t);
        x1 = x1.max(t);
        y0 = y0.min(e);
        y1 = y1.max(e);
    }
    let (x0, x1, y0, y1) = (x0 / 1.5, x1 * 1.5, y0 / 1.5, y1 * 1.5);
    // Drawn into memory and written with the project's `image` (plotters'
    // own PNG encoder would pull in a second version of that crate).
    const SIZE: (u32, u32) = (1000, 700);
    let mut pixels = vec![0u8; SIZE.0 as usize * SIZE.1 as usize * 3];
    let root = BitMapBackend::with_buffer(&mut pixels, SIZE).into_drawing_area();
    root.fill(&WHITE).map_err(plot_err)?;
    let mut chart = ChartBuilder::on(&root)
        .caption(format!("{scene}: error of E_d + E_i vs time to solution"), ("sans-serif", 26))
        .margin(20)
        .x_label_area_size(55)
        .y_label_area_size(80)
        .build_cartesian_2d((x0..x1).log_scale(), (y0..y1).log_scale())
        .map_err(plot_err)?;
    chart
        .configure_mesh()
        .x_labels(6)
        .y_labels(6)
        .x_label_formatter(&|x| format!("{x:.0}"))
        .y_label_formatter(&|y| format!("{y}"))
        .x_desc("run time (ms): links: kd + links + light links + gather + smoothing; path tracer: BVH + paths")
        .y_desc("relative RMSE of E_d + E_i vs reference")
        .label_style(("sans-serif", 16))
        .axis_desc_style(("sans-serif", 18))
        .draw()
        .map_err(plot_err)?;
    let smoothings: Vec<f32> = {
        let mut s: Vec<f32> = finite.iter().map(|r| r.smoothing_deg).collect();
        s.sort_by(|a, b| b.total_cmp(a));
        s.dedup();
        s
    };
    let colours = [RGBColor(31, 119, 180), RGBColor(214, 39, 40), RGBColor(44, 160, 44)];
    for (i, &s) in smoothings.iter().enumerate() {
        let c = colours[i % colours.len()];
        let pts: Vec<(f64, f64)> =
            finite.iter().filter(|r| r.smoothing_deg == s).map(|r| (r.total_ms.max(1e-3), err(r))).collect();
        let name = if s > 0.0 { format!("smoothing on ({s:.0} deg)") } else { "smoothing off".to_string() };
        chart
            .draw_series(LineSeries::new(pareto(&pts), c.stroke_width(2)))
            .map_err(plot_err)?
            .label(name)
            .legend(move |(x, y)| PathElement::new(vec![(x, y), (x + 24, y)], c.stroke_width(2)));
        chart.draw_series(pts.iter().map(|p| Circle::new(*p, 4, c.filled()))).map_err(plot_err)?;
        // Ray counts along the front.
        for r in finite.iter().filter(|r| r.smoothing_deg == s && r.bounces == "auto") {
            chart
                .draw_series(std::iter::once(Text::new(
                    format!("{}", r.rays),
                    (r.total_ms.max(1e-3) * 1.05, err(r) * 1.08),
                    ("sans-serif", 14).into_font().color(&c),
                )))
                .map_err(plot_err)?;
        }
    }
    if !ladder.is_empty() {
        let pts: Vec<(f64, f64)> = ladder.iter().map(|p| (p.ms.max(1e-3), path_err(p))).collect();
        chart
            .draw_series(LineSeries::new(pts.clone(), BLACK.stroke_width(2)))
            .map_err(plot_err)?
            .label("path tracer (samples per vertex)")
            .legend(|(x, y)| PathElement::new(vec![(x, y), (x + 24, y)], BLACK.stroke_width(2)));
        chart
            .draw_series(
                pts.iter().map(|&(x, y)| Rectangle::new([(x / 1.04, y / 1.04), (x * 1.04, y * 1.04)], BLACK.filled())),
            )
            .map_err(plot_err)?;
        for (p, at) in ladder.iter().zip(&pts) {
            chart
                .draw_series(std::iter::once(Text::new(
                    format!("{}", p.samples),
                    (at.0 * 1.06, at.1 * 1.1),
                    ("sans-serif", 14).into_font().color(&BLACK),
                )))
                .map_err(plot_err)?;
        }
        // The ratio at equal time of the auto-bounce, smoothed settings, as text in the lower left.
        let owned: Vec<PathRow> = ladder.iter().map(|p| (*p).clone()).collect();
        let mut lines = vec!["path tracer error / link error at equal time:".to_string()];
        for r in finite.iter().filter(|r| r.bounces == "auto" && r.smoothing_deg > 0.0) {
            if let Some(e) = error_at(&owned, r.total_ms) {
                lines.push(format!("  {} rays: {:.1}x", r.rays, e / err(r)));
            }
        }
        for (i, l) in lines.iter().enumerate() {
            let y = y0 * (y1 / y0).powf(0.03 + 0.05 * (lines.len() - 1 - i) as f64);
            chart
                .draw_series(std::iter::once(Text::new(l.clone(), (x0 * 1.05, y), ("sans-serif", 15))))
                .map_err(plot_err)?;
        }
    }
    if let Some(p) = finite.iter().find(|r| r.is_paper_default()) {
        let at = (p.total_ms.max(1e-3), err(p));
        chart.draw_series(std::iter::once(Circle::new(at, 11, BLACK.stroke_width(2)))).map_err(plot_err)?;
        chart
            .draw_series(std::iter::once(Text::new(
                "paper default: 256 rays, 3 bounces, smoothing",
                (at.0 * 1.12, at.1 * 1.25),
                ("sans-serif", 15),
            )))
            .map_err(plot_err)?;
    }
    chart
        .configure_series_labels()
        .position(SeriesLabelPosition::UpperRight)
        .label_font(("sans-serif", 16))
        .border_style(BLACK)
        .background_style(WHITE.mix(0.9))
        .draw()
        .map_err(plot_err)?;
    root.present().map_err(plot_err)?;
    // The drawing borrows the pixels until it is dropped.
    drop(chart);
    drop(root);
    let img =
        image::RgbImage::from_raw(SIZE.0, SIZE.1, pixels).ok_or_else(|| Error::Plot("plot buffer size".into()))?;
    img.save_with_format(path, image::ImageFormat::Png)
        .map_err(|e| Error::Io { path: path.to_path_buf(), source: std::io::Error::other(e.to_string()) })
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::accuracy::metrics::ErrorStats;

    #[test]
    fn pareto_keeps_the_lower_envelope() {
        let p = pareto(&[(3.0, 0.5), (1.0, 1.0), (2.0, 2.0), (4.0, 0.1), (5.0, 0.2)]);
        assert_eq!(p, vec![(1.0, 1.0), (3.0, 0.5), (4.0, 0.1)]);
    }

    /// The PNG holds the plot: its size, a white background, and both
    /// smoothing settings' lines in their colours.
    #[test]
    fn plot_writes_a_png_with_the_series() {
        let stats = |e: f64| ErrorStats { rel_rmse: e, rel_rmse_corrected: e, ..Default::default() };
        let row = |rays: u32, smoothing_deg: f32, ms: f64, e: f64| SweepRow {
            rays,
            bounces: "auto".into(),
            bounces_used: 3,
            smoothing_deg,
            kd_ms: 0.0,
            links_ms: ms,
            light_links_ms: 0.0,
            gather_ms: 0.0,
            smooth_ms: 0.0,
            total_ms: ms,
            e_indirect: stats(e),
            e_direct: stats(0.0),
            e_total: stats(e),
        };
        let rows: Vec<SweepRow> = [(16, 10.0, 0.2), (64, 40.0, 0.1), (256, 160.0, 0.05), (1024, 640.0, 0.025)]
            .iter()
            .flat_map(|&(r, ms, e)| [row(r, 30.0, ms, e), row(r, 0.0, ms, 2.0 * e)])
            .collect();
        let ladder: Vec<PathRow> = [(16, 30.0, 0.5), (64, 120.0, 0.25)]
            .iter()
            .map(|&(samples, ms, e)| PathRow {
                samples,
                ms,
                e_indirect: stats(e),
                e_direct: stats(e),
                e_total: stats(e),
            })
            .collect();
        let path = std::env::temp_dir().join(format!("linkgi-plot-{}.png", std::process::id()));
        plot("test", &rows, &ladder, &path).expect("plot");
        let img = image::open(&path).expect("a PNG").to_rgb8();
        std::fs::remove_file(&path).ok();
        assert_eq!(img.dimensions(), (1000, 700));
        let count = |c: [u8; 3]| img.pixels().filter(|p| p.0 == c).count();
        assert!(count([255, 255, 255]) > 1000 * 700 / 2, "mostly white");
        assert!(count([31, 119, 180]) > 200, "the smoothed line: {}", count([31, 119, 180]));
        assert!(count([214, 39, 40]) > 200, "the unsmoothed line: {}", count([214, 39, 40]));
    }
}
