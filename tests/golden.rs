//! Golden hashes of the built-in scenes' results: a refactor keeps the
//! answers. Every scene up to `tearoom` (and `window`) is solved on the CPU
//! path at fixed rays and seed with its own other settings, and the bit
//! patterns of the exported `E_d`, `E_i` and `E_sky` arrays (and of the
//! unsmoothed `E_i`) are hashed (FNV-1a, 64 bits).
//!
//! The hashes must not move unless a commit of its own says why and by how
//! much. `GOLDEN_PRINT=1 cargo test --test golden -- --nocapture` prints the
//! table to paste below, `GOLDEN_DUMP=dir` writes the arrays to compare two
//! versions' (`docs/golden_diff.py old_dir new_dir` gives the largest change); the hits are bit-identical across the BVH's SIMD
//! builds (`tests/bvh.rs`), the kd-tree's shape does not depend on the
//! thread count (fixed parallel levels) and neither does the solve, so the
//! hashes hold on any machine.

use linkgi::scene::{self, prep, TracerKind};
use linkgi::solver::{SolveParams, Solver};

/// FNV-1a over the bit patterns of the array's floats.
fn hash(v: &[glam::Vec3]) -> u64 {
    let mut h: u64 = 0xcbf2_9ce4_8422_2325;
    for x in v.iter().flat_map(|v| v.to_array()) {
        for b in x.to_bits().to_le_bytes() {
            h ^= b as u64;
            h = h.wrapping_mul(0x0100_0000_01b3);
        }
    }
    h
}

/// (scene, tracer, rays, seed) and the hashes of `E_d`, `E_i`, `E_i` raw, `E_sky`.
#[rustfmt::skip]
const GOLDEN: &[(&str, TracerKind, u32, u64, [u64; 4])] = &[
    ("cornell", TracerKind::Bvh, 64, 7, [0xa2fff410559f3ad4, 0x6db354f61a046bce, 0x092d8e7ce186f7bd, 0x65f72ca439112ca5]),
    ("furnace", TracerKind::Bvh, 64, 7, [0xd6cb0114b4d6252a, 0xa5069a9bb9571d18, 0xb8692d8a502638f7, 0x77bc99222abd8305]),
    ("colorlamp", TracerKind::Bvh, 64, 7, [0x5f4110545874c195, 0x4766d1310340e959, 0xb2d14fce1d341ac0, 0x285e8ae0f09574d5]),
    ("window", TracerKind::Bvh, 64, 7, [0x31e98294b1ba2e15, 0xa84e710d325f3dce, 0xafc537ebfb7810ee, 0x81564716b6b16039]),
    ("torso", TracerKind::Bvh, 64, 7, [0x2d5c5ba603c17e13, 0x547ddff91cd04f37, 0x81a88e92b800b06c, 0x4b235a5a86553d05]),
    ("tearoom", TracerKind::Bvh, 64, 7, [0x64adcca9a5c2d3cc, 0xbe4ebe14a3519069, 0x94c6f0da0b843536, 0x51b05bcd00444155]),
    ("cornell", TracerKind::Kd, 64, 7, [0xa2fff410559f3ad4, 0x6db354f61a046bce, 0x092d8e7ce186f7bd, 0x65f72ca439112ca5]),
];

fn solve_hashes(name: &str, tracer: TracerKind, rays: u32, seed: u64) -> [u64; 4] {
    let mut desc = scene::builtin::builtin(name).expect("built-in scene");
    desc.settings.rays_per_vertex = rays;
    desc.settings.seed = seed;
    desc.settings.tracer = tracer;
    let scene = prep::prepare(&desc).expect("scene prepares");
    let params = SolveParams::from_settings(&scene.settings);
    let solver = Solver::new(scene, params, &|_, _| {}).unwrap();
    let sol = solver.solve();
    let arrays = [&sol.e_direct, &sol.e_indirect, &sol.e_indirect_raw, &sol.e_sky];
    // `GOLDEN_DUMP=dir`: the arrays as little-endian f32, to measure by how
    // much a change that moves the hashes moves the results.
    if let Some(dir) = std::env::var_os("GOLDEN_DUMP") {
        std::fs::create_dir_all(&dir).unwrap();
        for (label, a) in ["e_d", "e_i", "e_i_raw", "e_sky"].iter().zip(arrays) {
            let bytes: Vec<u8> = a.iter().flat_map(|v| v.to_array()).flat_map(f32::to_le_bytes).collect();
            std::fs::write(std::path::Path::new(&dir).join(format!("{name}_{tracer:?}_{label}.bin")), bytes).unwrap();
        }
    }
    arrays.map(|a| hash(a))
}

/// The cases: every built-in scene up to `tearoom` and `window`, the BVH at
/// 64 rays, and the Cornell box through the kd-tree too.
fn cases() -> Vec<(&'static str, TracerKind, u32, u64)> {
    let mut c: Vec<_> = ["cornell", "furnace", "colorlamp", "window", "torso", "tearoom"]
        .into_iter()
        .map(|s| (s, TracerKind::Bvh, 64, 7))
        .collect();
    c.push(("cornell", TracerKind::Kd, 64, 7));
    c
}

#[test]
fn built_in_scenes_keep_their_answers() {
    let print = std::env::var_os("GOLDEN_PRINT").is_some();
    let mut failures = Vec::new();
    for (name, tracer, rays, seed) in cases() {
        let got = solve_hashes(name, tracer, rays, seed);
        if print {
            println!(
                "    (\"{name}\", TracerKind::{tracer:?}, {rays}, {seed}, [{:#018x}, {:#018x}, {:#018x}, {:#018x}]),",
                got[0], got[1], got[2], got[3]
            );
        }
        let want = GOLDEN.iter().find(|g| g.0 == name && g.1 == tracer && g.2 == rays && g.3 == seed);
        match want {
            Some(w) if w.4 == got => {}
            Some(w) => {
                failures.push(format!("{name} ({tracer:?}, {rays} rays, seed {seed}): {:x?} != golden {:x?}", got, w.4))
            }
            None => failures.push(format!("{name} ({tracer:?}, {rays} rays, seed {seed}): no golden value")),
        }
    }
    assert!(failures.is_empty(), "results moved:\n{}", failures.join("\n"));
}
