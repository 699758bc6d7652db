//! Helpers of the measured checks (`tests/measured.rs`): a built-in scene
//! solved with parameters changed in code, its cached Monte Carlo
//! reference, and the comparison of two solutions' errors against it.
//!
//! Comparison free of the reference's noise: scored against a reference
//! `t = T + e` (truth `T`, noise `e` of standard error `s`), the mean
//! squared errors of two solutions `x`, `y` differ by
//! `MSE(x) - MSE(y) = [|x - T|^2 - |y - T|^2] / n - 2 <x - y, e> / n`:
//! the reference's noise variance cancels, and what is left of it, the
//! cross term, has a spread of `2 sqrt(sum (x - y)^2 s^2) / n`
//! ([`Comparison::noise_sd`]), small beside the differences asserted
//! even for a reference of a few thousand paths (`tests/accuracy.rs` uses
//! the same argument). The errors printed (`error_stats`'
//! `rel_rmse_corrected`, the reference's noise removed) are indicative
//! where the reference has fewer paths than the docs' (16384 on `window`
//! and tearoom, 65536 on cornell): its standard errors are conservative,
//! so small errors print too low; the gain, a difference of mean squared
//! errors, compares with the quoted figures' (`a^2 - b^2`).
#![allow(dead_code)]

use glam::Vec3;
use linkgi::accuracy::metrics::error_stats;
use linkgi::reference::{self, Reference, ReferenceParams};
use linkgi::scene::{builtin, prep, Bounces};
use linkgi::solver::{Solution, SolveParams, Solver};
use std::ops::Range;
use std::time::Instant;

/// The built-in scene `name` prepared with `rays` rays per vertex, auto
/// bounces and `seed` (as every measurement the docs quote).
pub fn scene(name: &str, rays: u32, seed: u64) -> prep::PreparedScene {
    let mut desc = builtin::builtin(name).expect("a built-in scene");
    desc.settings.rays_per_vertex = rays;
    desc.settings.bounces = Bounces::Auto;
    desc.settings.seed = seed;
    prep::prepare(&desc).expect("the scene prepares")
}

/// `scene` solved with its settings' parameters, changed by `change`.
pub fn solve(scene: &prep::PreparedScene, change: impl FnOnce(&mut SolveParams)) -> (Solver, Solution) {
    let mut params = SolveParams::from_settings(&scene.settings);
    change(&mut params);
    let t = Instant::now();
    let solver = Solver::new(scene.clone(), params, &|_, _| {}).unwrap();
    let sol = solver.solve();
    eprintln!(
        "  {} at {} rays, seed {}: built and solved in {:.1} s",
        scene.name,
        params.links.rays_per_vertex,
        params.links.seed,
        t.elapsed().as_secs_f64()
    );
    (solver, sol)
}

/// The reference of `scene` with [`reference_paths`] paths per vertex,
/// from the cache (`$CARGO_TARGET_DIR/reference-cache`) or computed and
/// cached.
pub fn reference(scene: &prep::PreparedScene) -> Reference {
    let samples = reference_paths(&scene.name);
    let t = Instant::now();
    let params = ReferenceParams { samples_per_vertex: samples, ..Default::default() };
    let r = reference::compute_cached(scene, &params, &reference::cache::default_dir());
    eprintln!(
        "{}: {} vertices, reference of {samples} paths {} in {:.1} s",
        scene.name,
        scene.vertex_count(),
        if r.from_cache { "read from the cache" } else { "computed" },
        t.elapsed().as_secs_f64()
    );
    r
}

/// The vertex range of `scene`'s mesh named `name`.
pub fn mesh(scene: &prep::PreparedScene, name: &str) -> Range<usize> {
    let m = scene.meshes.iter().find(|m| m.name == name).unwrap_or_else(|| panic!("no mesh {name}"));
    m.vertices.start as usize..m.vertices.end as usize
}

/// Paths per vertex of the reference of the built-in scene `name`: 16384
/// on `window` (2.4k vertices, about 30 s here), as the docs' figures;
/// 4096 elsewhere (cornell about 15 s, tearoom 90 s). The comparisons
/// need far fewer (see the module doc); more make the errors printed
/// comparable with the quoted ones.
pub fn reference_paths(name: &str) -> u32 {
    match name {
        "window" => 16384,
        _ => 4096,
    }
}

/// What solutions are scored on: reference values, the standard errors
/// taken out of the errors printed, and a bound of the standard errors
/// for the spread of the cross term.
pub struct Truth {
    pub values: Vec<Vec3>,
    pub stderr: Vec<Vec3>,
    pub stderr_bound: Vec<Vec3>,
}

impl Truth {
    /// The total irradiance `E_d + E_sky + E_i` and its standard errors.
    pub fn total(r: &Reference) -> Truth {
        Truth { values: r.total(), stderr: r.e_total_stderr.clone(), stderr_bound: r.e_total_stderr.clone() }
    }

    /// The sky's irradiance `E_sky`: the reference has no standard error
    /// of its own for it (errors printed with the reference's noise in
    /// them); the total's, which holds its noise, bounds it.
    pub fn sky(r: &Reference) -> Truth {
        Truth { values: r.e_sky.clone(), stderr: Vec::new(), stderr_bound: r.e_total_stderr.clone() }
    }

    /// Every vertex.
    pub fn all(&self) -> Range<usize> {
        0..self.values.len()
    }
}

/// Two solutions' errors against a reference quantity.
#[derive(Clone, Copy, Debug)]
pub struct Comparison {
    /// Relative RMSE of each (the reference's noise removed where
    /// [`Truth::stderr`] is given; indicative).
    pub better_rel: f64,
    pub worse_rel: f64,
    /// `MSE(worse) - MSE(better)`, relative to the squared reference mean:
    /// free of the reference's noise but for the cross term.
    pub gain: f64,
    /// Spread (one standard deviation) of that cross term, same unit.
    pub noise_sd: f64,
}

/// Compares `better` and `worse` against `truth` over the vertices `range`.
pub fn compare(better: &[Vec3], worse: &[Vec3], truth: &Truth, range: Range<usize>) -> Comparison {
    let pick = |v: &[Vec3]| if v.is_empty() { Vec::new() } else { v[range.clone()].to_vec() };
    let (b, w, t) = (&better[range.clone()], &worse[range.clone()], &truth.values[range.clone()]);
    let (s, bound) = (pick(&truth.stderr), pick(&truth.stderr_bound));
    let n = (3 * t.len()) as f64;
    let mean = t.iter().map(|x| x.element_sum() as f64).sum::<f64>() / n;
    let (mut diff, mut cross) = (0f64, 0f64);
    for v in 0..t.len() {
        diff += ((w[v] - t[v]).length_squared() - (b[v] - t[v]).length_squared()) as f64;
        if let Some(sv) = bound.get(v) {
            cross += ((w[v] - b[v]) * *sv).length_squared() as f64;
        }
    }
    Comparison {
        better_rel: error_stats(b, t, &s).rel_rmse_corrected,
        worse_rel: error_stats(w, t, &s).rel_rmse_corrected,
        gain: diff / n / (mean * mean),
        noise_sd: 2.0 * cross.sqrt() / n / (mean * mean),
    }
}

/// Prints a comparison beside `figure`, the quoted measurement.
fn report(what: &str, figure: &str, c: &Comparison) {
    eprintln!(
        "{what}: {:.3}% -> {:.3}% relative RMSE (quoted: {figure}); MSE gain {:.3e} of mean^2, reference-noise spread {:.1e}",
        100.0 * c.worse_rel,
        100.0 * c.better_rel,
        c.gain,
        c.noise_sd
    );
}

/// Asserts that `better` is closer to `truth` than `worse` over the
/// vertices `range`: the difference of their mean squared errors is
/// positive and more than 4 standard deviations of the reference noise's
/// share of it. Prints both errors beside `figure`, the quoted
/// measurement.
pub fn assert_closer(
    what: &str,
    figure: &str,
    better: &[Vec3],
    worse: &[Vec3],
    truth: &Truth,
    range: Range<usize>,
) -> Comparison {
    let c = compare(better, worse, truth, range);
    report(what, figure, &c);
    assert!(
        c.gain > 0.0 && c.gain > 4.0 * c.noise_sd,
        "{what}: not lower ({:.3}% against {:.3}%, MSE gain {:.2e}, reference-noise spread {:.1e}; quoted: {figure})",
        100.0 * c.better_rel,
        100.0 * c.worse_rel,
        c.gain,
        c.noise_sd
    );
    c
}

/// Asserts that `better` is no worse than `worse` against `truth` over
/// `range`: the difference of their mean squared errors is above minus 2
/// standard deviations of the reference noise's share of it. For a
/// quoted gain that has since shrunk into the noise. Prints as
/// [`assert_closer`].
pub fn assert_not_worse(
    what: &str,
    figure: &str,
    better: &[Vec3],
    worse: &[Vec3],
    truth: &Truth,
    range: Range<usize>,
) -> Comparison {
    let c = compare(better, worse, truth, range);
    report(what, figure, &c);
    assert!(
        c.gain > -2.0 * c.noise_sd,
        "{what}: worse ({:.3}% against {:.3}%, MSE gain {:.2e}, reference-noise spread {:.1e}; quoted: {figure})",
        100.0 * c.better_rel,
        100.0 * c.worse_rel,
        c.gain,
        c.noise_sd
    );
    c
}

/// Solves `name` at `rays` rays (seed 1) with `base` applied, and again
/// with `term` also off, and asserts ([`assert_closer`]) that the term
/// lowers the total error over the whole scene; `what` and `figure` as
/// there. Returns the solve with the term on.
pub fn assert_term_lowers_total(
    name: &str,
    rays: u32,
    term: &str,
    base: impl Fn(&mut SolveParams),
    what: &str,
    figure: &str,
) -> (Solver, Solution) {
    let s = scene(name, rays, 1);
    let r = reference(&s);
    let (with_solver, with) = solve(&s, &base);
    let (_, without) = solve(&s, |p| {
        base(p);
        p.terms.set(term, false).expect("a term's name");
    });
    let t = Truth::total(&r);
    assert_closer(
        &format!("{name} {rays} rays, {what} off -> on"),
        figure,
        &with.total(),
        &without.total(),
        &t,
        t.all(),
    );
    (with_solver, with)
}
