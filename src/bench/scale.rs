//! The scaling table (`linkgi bench --scale`, issue 45): one scene at
//! several densities (midpoint subdivision, [`crate::scene::dense`]: the
//! same geometry, 4^k times the triangles), each solved as `linkgi solve`
//! would (a-priori refinement, preparation with the lighting mesh's
//! simplification and transfer, the refinement rounds), with its input
//! triangles, lighting mesh, time per stage, first solution, peak memory
//! and its picture's difference to the coarsest level's at the same
//! camera; and the growth exponents of time and memory in the input's
//! triangles, fitted by least squares on log-log over the levels above
//! the lighting budget ([`fit_exponent`]). Times in seconds, memory in MB.

use super::memory;
use crate::reference::image::score;
use crate::render::cpu::render_cpu;
use crate::render::{Frame, HdrImage, RenderParams};
use crate::scene::{dense, prep, refine, SceneDesc};
use crate::solver::adaptive::{solve_planned, Plan};
use crate::solver::Compute;
use serde::Serialize;
use std::time::Instant;

/// One density of the table.
#[derive(Clone, Debug, Serialize)]
pub struct ScaleRow {
    /// Subdivision level (4^level times the input's triangles).
    pub level: u32,
    /// Triangles of the input at this level.
    pub input_triangles: usize,
    /// Vertices of the lighting mesh solved.
    pub lighting_vertices: usize,
    /// Triangles of the lighting mesh solved.
    pub lighting_triangles: usize,
    /// Preparation: welding, simplification and the transfer, s.
    pub prepare_s: f64,
    /// Link shooting over all rounds, s.
    pub links_s: f64,
    /// Everything else of the rounds (traced parts, bounces, smoothing), s.
    pub rest_s: f64,
    /// From the input to the first solution (preparation and rounds), s.
    pub first_solution_s: f64,
    /// Peak resident memory of the level (the input included), MB.
    pub peak_mb: f64,
    /// Mean luminance of the picture over the coarsest level's.
    pub mean_ratio: f64,
    /// Mean relative error of its 8x8 blocks against the coarsest level's.
    pub block_error: f64,
}

/// Runs `levels` of `desc` on `compute`, rendering each picture at
/// `size` through `desc`'s camera (framed where it has none), handing each
/// to `picture(level, image)`; `progress(level)` before each level.
pub fn run(
    desc: &SceneDesc,
    levels: &[u32],
    compute: &Compute,
    size: (u32, u32),
    progress: &dyn Fn(u32),
    picture: &mut dyn FnMut(u32, &HdrImage),
) -> crate::Result<Vec<ScaleRow>> {
    let mut rows = Vec::new();
    let mut first: Option<HdrImage> = None;
    for &level in levels {
        progress(level);
        let input = dense::dense_copy(desc, level);
        let input_triangles = input.meshes.iter().map(|m| m.triangles.len()).sum();
        let resets = memory::reset_peak();
        let start = Instant::now();
        let plan = Plan::of(&input);
        let current = if plan.apriori { refine::apriori(&input, &input.settings.refine).0 } else { input.clone() };
        let prepared = prep::prepare(&current)?;
        let prepare_s = start.elapsed().as_secs_f64();
        let refined = solve_planned(current, prepared, &plan, compute, &|_, _| {})?;
        let first_solution_s = start.elapsed().as_secs_f64();
        let peak_mb = memory::peak_bytes().filter(|_| resets).map_or(f64::NAN, |b| b as f64 / 1e6);
        let links_s = refined.rounds.iter().map(|r| r.links_ms).sum::<f64>() / 1e3;
        let scene = refined.solver.scene();
        let camera = crate::render::framing::camera_or_framed(desc.camera, scene, None).0;
        let accel = refined.solver.accel();
        let p = RenderParams { width: size.0, height: size.1, ..Default::default() };
        let (img, _) = render_cpu(&Frame::of(scene, &refined.solution.e_indirect, camera), &p, Some(accel))?;
        picture(level, &img);
        let s = first.as_ref().and_then(|f| score(&img, f));
        if first.is_none() {
            first = Some(img);
        }
        rows.push(ScaleRow {
            level,
            input_triangles,
            lighting_vertices: scene.vertex_count(),
            lighting_triangles: scene.triangles.len(),
            prepare_s,
            links_s,
            rest_s: (first_solution_s - prepare_s - links_s).max(0.0),
            first_solution_s,
            peak_mb,
            mean_ratio: s.map_or(1.0, |s| s.mean_ratio),
            block_error: s.map_or(0.0, |s| s.block_error),
        });
    }
    Ok(rows)
}

/// The exponent `a` of `y = c x^a` fitted by least squares on
/// `(ln x, ln y)`; `None` with fewer than two distinct `x` or a value that
/// is not positive.
pub fn fit_exponent(points: &[(f64, f64)]) -> Option<f64> {
    let logs: Vec<(f64, f64)> =
        points.iter().filter(|(x, y)| *x > 0.0 && *y > 0.0).map(|(x, y)| (x.ln(), y.ln())).collect();
    if logs.len() < 2 || logs.len() < points.len() {
        return None;
    }
    let n = logs.len() as f64;
    let (mx, my) = (logs.iter().map(|p| p.0).sum::<f64>() / n, logs.iter().map(|p| p.1).sum::<f64>() / n);
    let sxx: f64 = logs.iter().map(|p| (p.0 - mx).powi(2)).sum();
    let sxy: f64 = logs.iter().map(|p| (p.0 - mx) * (p.1 - my)).sum();
    (sxx > 0.0).then(|| sxy / sxx)
}

/// The table as markdown, with the fitted exponents of first-solution time
/// and peak memory over the levels whose input exceeds `budget` triangles
/// (all levels where fewer than two do).
pub fn markdown(name: &str, rows: &[ScaleRow], budget: u32) -> String {
    let mut s = format!(
        "### Scaling: {name} at {} densities\n\n| level | input triangles | lighting vertices | lighting triangles | \
         prepare s | links s | rest s | first solution s | peak MB | mean luminance vs level {} | block error vs level {} |\n\
         |---|---|---|---|---|---|---|---|---|---|---|\n",
        rows.len(),
        rows.first().map_or(0, |r| r.level),
        rows.first().map_or(0, |r| r.level),
    );
    for r in rows {
        s += &format!(
            "| {} | {} | {} | {} | {:.2} | {:.2} | {:.2} | {:.2} | {:.0} | {:.3} | {:.1}% |\n",
            r.level,
            r.input_triangles,
            r.lighting_vertices,
            r.lighting_triangles,
            r.prepare_s,
            r.links_s,
            r.rest_s,
            r.first_solution_s,
            r.peak_mb,
            r.mean_ratio,
            r.block_error * 100.0
        );
    }
    let above: Vec<&ScaleRow> = rows.iter().filter(|r| r.input_triangles > budget as usize).collect();
    let used: Vec<&ScaleRow> = if above.len() >= 2 { above } else { rows.iter().collect() };
    let fit = |f: &dyn Fn(&ScaleRow) -> f64| {
        fit_exponent(&used.iter().map(|r| (r.input_triangles as f64, f(r))).collect::<Vec<_>>())
            .map_or("-".to_string(), |a| format!("{a:.2}"))
    };
    s += &format!(
        "\nGrowth in the input's triangles (least squares on log-log over {} levels{}): first solution ^{}, peak \
         memory ^{}.\n",
        used.len(),
        if used.len() < rows.len() { format!(" above the budget of {budget} triangles") } else { String::new() },
        fit(&|r| r.first_solution_s),
        fit(&|r| r.peak_mb)
    );
    s
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn the_fit_recovers_a_power_law() {
        let pts: Vec<(f64, f64)> = [1e4, 4e4, 1.6e5, 6.4e5].iter().map(|&x| (x, 3.0 * f64::powf(x, 0.3))).collect();
        assert!((fit_exponent(&pts).unwrap() - 0.3).abs() < 1e-9);
        assert_eq!(fit_exponent(&[(1.0, 2.0)]), None);
        assert_eq!(fit_exponent(&[(1.0, 2.0), (2.0, 0.0)]), None);
    }
}
