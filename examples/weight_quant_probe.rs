//! Weight quantization experiment (issue 16): link weights rounded to an
//! 8-bit float (4-bit exponent below the group's largest binade, 4-bit
//! mantissa) with error diffusion in target order; E_i of the full solve
//! against the f16 weights':
//! `cargo run --release --example weight_quant_probe -- tearoom`.
use half::f16;
use linkgi::scene::{self, prep};
use linkgi::solver::{SolveParams, Solver};

/// Rounds `x > 0` to `mbits` mantissa bits, at most `ebits` binades below `top` (a power of two).
fn round_mini(x: f64, top_exp: i32, mbits: u32, ebits: u32) -> f64 {
    let lo_exp = top_exp - (1 << ebits) + 1;
    let x = x.max(0.0);
    let e = (x.log2().floor() as i32).clamp(lo_exp, top_exp);
    let step = 2f64.powi(e - mbits as i32);
    let q = (x / step).round() * step;
    let min = 2f64.powi(lo_exp);
    q.clamp(min, 2f64.powi(top_exp + 1) - 2f64.powi(top_exp - mbits as i32))
}

fn main() {
    let name = std::env::args().nth(1).unwrap_or_else(|| "tearoom".into());
    let mbits: u32 = std::env::args().nth(2).map_or(4, |s| s.parse().unwrap());
    let mut desc = scene::load(&name).unwrap();
    desc.settings.rays_per_vertex = 256;
    let scene = prep::prepare(&desc).unwrap();
    let mut solver = Solver::new(scene, SolveParams::from_settings(&desc.settings), &|_, _| {});
    let base = solver.solve();
    let n = solver.links.vertex_count();
    let mut q = solver.links.weights.clone();
    let mut worst_row = 0f64;
    for v in 0..n {
        let r = solver.links.offsets[v] as usize..solver.links.offsets[v + 1] as usize;
        let m = q[r.clone()].iter().map(|w| w.to_f64()).fold(0.0, f64::max);
        if m == 0.0 {
            continue;
        }
        let top = m.log2().floor() as i32;
        let mut carry = 0.0;
        let (mut s0, mut s1) = (0.0, 0.0);
        for w in &mut q[r] {
            let exact = w.to_f64() + carry;
            let r = round_mini(exact, top, mbits, 4);
            carry = exact - r;
            s0 += w.to_f64();
            s1 += r;
            *w = f16::from_f64(r);
        }
        worst_row = f64::max(worst_row, (s1 - s0).abs() / s0);
    }
    solver.links.weights = q;
    solver.links_changed();
    let quant = solver.solve();
    let (mut worst, mut sq, mut sq0) = (0f64, 0f64, 0f64);
    let tb = base.total();
    for v in 0..n {
        let (a, b) = (base.gather.e_indirect[v], quant.gather.e_indirect[v]);
        for c in 0..3 {
            let d = (b[c] - a[c]) as f64;
            let rel = d.abs() / (tb[v][c] as f64).max(1e-9);
            if tb[v][c] > 1e-3 * tb.iter().map(|t| t[c]).fold(0.0, f32::max) {
                worst = worst.max(rel);
            }
            sq += d * d;
            sq0 += (a[c] as f64).powi(2);
        }
    }
    println!(
        "{name}: e4m{mbits}: worst row-sum change {worst_row:.2e}; E_i vs f16 weights: rms {:.2e} of E_i, worst vertex {worst:.2e} of its total",
        (sq / sq0).sqrt()
    );
}
