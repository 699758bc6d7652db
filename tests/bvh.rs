//! Wide BVH: structure checks, closest and any hits against brute force on
//! random and degenerate meshes, the same hits from every SIMD build and
//! from same-origin packets (scattered and coherent directions), and
//! refits that equal fresh builds.

use glam::Vec3;
use linkgi::bvh::refit::Update;
use linkgi::bvh::{Bvh, BvhBuildParams, Isa};
use linkgi::kdtree::traverse::brute_force;
use linkgi::kdtree::{KdBuildParams, KdTree};
use linkgi::trace::ray::{Hit, Ray};
use rand::SeedableRng;
use rand_pcg::Pcg32;

mod common;
use common::{grid, random_rays, rvec, soup};

type Mesh = (Vec<Vec3>, Vec<[u32; 3]>);

/// Axis-aligned grids on the three middle planes (coincident bounds, many ties).
fn axis_aligned(n: u32) -> Mesh {
    let (mut pos, mut tris) = (Vec::new(), Vec::new());
    for axis in 0..3 {
        grid(n, axis, 0.5, &mut pos, &mut tris);
    }
    (pos, tris)
}

fn key(h: Option<Hit>) -> Option<(u32, u32, u32, u32, bool)> {
    h.map(|h| (h.tri, h.t.to_bits(), h.u.to_bits(), h.v.to_bits(), h.front))
}

fn isas() -> Vec<Isa> {
    [Isa::Avx512, Isa::Avx2, Isa::Portable].into_iter().filter(|i| i.supported()).collect()
}

/// Every supported build agrees with brute force on every ray (closest hit
/// bit for bit, any-hit as its existence); returns the rays that hit.
fn check(mesh: &Mesh, rays: &[Ray], params: &BvhBuildParams) -> usize {
    let (pos, tris) = mesh;
    let mut bvh = Bvh::build(pos, tris, params);
    bvh.validate().expect("bvh valid");
    let kd = KdTree::build(pos, tris, &KdBuildParams::default());
    let mut hits = 0;
    let wants: Vec<Option<Hit>> = rays.iter().map(|r| brute_force(&kd, r)).collect();
    for isa in isas() {
        assert_eq!(bvh.set_isa(isa), isa);
        for (i, (r, want)) in rays.iter().zip(&wants).enumerate() {
            assert_eq!(key(bvh.intersect(r)), key(*want), "ray {i} {r:?} ({isa:?})");
            assert_eq!(bvh.occluded(r), want.is_some(), "any-hit of ray {i} ({isa:?})");
        }
        // Runs of rays in flight together give the same answers.
        let mut free = vec![false; rays.len()];
        bvh.visible_run(rays, &mut free);
        for (i, (f, want)) in free.iter().zip(&wants).enumerate() {
            assert_eq!(*f, want.is_none(), "visible_run ray {i} ({isa:?})");
        }
        let mut near = vec![None; rays.len()];
        bvh.intersect_run(rays, &mut near);
        for (i, (got, want)) in near.iter().zip(&wants).enumerate() {
            assert_eq!(key(*got), key(*want), "intersect_run ray {i} ({isa:?})");
        }
        // Rays sharing an origin, as a vertex shoots them.
        for (j, r) in rays.iter().enumerate().step_by(331) {
            let dirs: Vec<Vec3> = rays.iter().map(|q| q.dir).collect();
            let mut out = vec![None; dirs.len()];
            bvh.intersect_origin(r.origin, r.skip, &dirs, &mut out);
            for (d, got) in dirs.iter().zip(&out) {
                let one = Ray { origin: r.origin, dir: *d, tmin: 0.0, tmax: f32::INFINITY, skip: r.skip };
                assert_eq!(key(*got), key(brute_force(&kd, &one)), "origin of ray {j}, dir {d} ({isa:?})");
            }
            // Walked in same-origin packets: scattered directions, and a
            // vertex's direction set in its 4x4 blocks about the ray.
            let frame = linkgi::sampling::vertex_frame(r.dir, 0.3);
            let set = linkgi::sampling::DirectionSet::new(16, j as u64);
            let coherent: Vec<Vec3> = set.set(0).iter().map(|d| linkgi::sampling::world_direction(frame, *d)).collect();
            for dirs in [&dirs, &coherent] {
                let mut packed = vec![None; dirs.len()];
                bvh.intersect_packets_with(r.origin, r.skip, dirs, &mut packed, isa);
                for (d, got) in dirs.iter().zip(&packed) {
                    let one = Ray { origin: r.origin, dir: *d, tmin: 0.0, tmax: f32::INFINITY, skip: r.skip };
                    assert_eq!(key(*got), key(brute_force(&kd, &one)), "packet from ray {j}, dir {d} ({isa:?})");
                }
            }
        }
    }
    hits += wants.iter().filter(|w| w.is_some()).count();
    hits
}

#[test]
fn random_soup_matches_brute_force() {
    let mut rng = Pcg32::seed_from_u64(11);
    let mesh = soup(&mut rng, 3000, 0.05);
    let rays = random_rays(&mut rng, 4000, mesh.0.len() as u32);
    let hits = check(&mesh, &rays, &BvhBuildParams::default());
    assert!(hits > 1000, "{hits}");
    // Other leaf sizes and bin counts give the same hits.
    let p = BvhBuildParams { max_leaf_triangles: 16, bins: 32, parallel_threshold: 64, ..Default::default() };
    check(&mesh, &rays[..1500], &p);
}

#[test]
fn flat_and_axis_aligned_meshes_match_brute_force() {
    let mut rng = Pcg32::seed_from_u64(12);
    let aa = axis_aligned(24);
    let rays = random_rays(&mut rng, 3000, aa.0.len() as u32);
    let hits = check(&aa, &rays, &BvhBuildParams::default());
    assert!(hits > 600, "{hits}");
    // A single flat grid: every box has zero thickness along z.
    let (mut pos, mut tris) = (Vec::new(), Vec::new());
    grid(40, 2, 0.25, &mut pos, &mut tris);
    let flat = (pos, tris);
    let rays = random_rays(&mut rng, 3000, flat.0.len() as u32);
    assert!(check(&flat, &rays, &BvhBuildParams::default()) > 300);
    // Rays through the grid's vertices and edges exactly.
    let through: Vec<Ray> = (0..400)
        .map(|i| {
            let p = Vec3::new((i % 41) as f32 / 40.0, ((i * 7) % 41) as f32 / 40.0 * 0.5 + (i % 2) as f32 / 80.0, 0.25);
            Ray::new(p + Vec3::new(0.1, -0.2, 1.0), (-Vec3::new(0.1, -0.2, 1.0)).normalize())
        })
        .collect();
    check(&flat, &through, &BvhBuildParams::default());
}

#[test]
fn coincident_and_single_triangles() {
    let mut rng = Pcg32::seed_from_u64(13);
    // 40 copies of the same triangles: ties go to the lowest id.
    let (mut pos, mut tris) = (Vec::new(), Vec::new());
    for _ in 0..40 {
        let base = pos.len() as u32;
        pos.extend([Vec3::new(0.0, 0.0, 0.5), Vec3::new(1.0, 0.0, 0.5), Vec3::new(0.0, 1.0, 0.5)]);
        tris.push([base, base + 1, base + 2]);
    }
    let same = (pos, tris);
    let rays = random_rays(&mut rng, 2000, 0);
    let hits = check(&same, &rays, &BvhBuildParams::default());
    assert!(hits > 100);
    let bvh = Bvh::build(&same.0, &same.1, &BvhBuildParams::default());
    for r in &rays {
        if let Some(h) = bvh.intersect(r) {
            assert_eq!(h.tri, 0, "a tie must go to the lowest id");
        }
    }
    let one = (vec![Vec3::ZERO, Vec3::X, Vec3::Y], vec![[0, 1, 2]]);
    let rays: Vec<Ray> = (0..500)
        .map(|_| {
            let o = rvec(&mut rng, -1.0, 1.0) + Vec3::Z;
            Ray::new(o, (rvec(&mut rng, 0.0, 0.6).with_z(0.0) - o).normalize())
        })
        .collect();
    assert!(check(&one, &rays, &BvhBuildParams::default()) > 100);
    let none = Bvh::build(&[], &[], &BvhBuildParams::default());
    none.validate().unwrap();
    assert!(none.intersect(&rays[0]).is_none() && !none.occluded(&rays[0]));
}

/// Twists the mesh about the vertical axis through (0.5, *, 0.5).
fn twist(pos: &[Vec3], amount: f32) -> Vec<Vec3> {
    pos.iter()
        .map(|p| {
            let a = amount * p.y;
            let (s, c) = a.sin_cos();
            let (x, z) = (p.x - 0.5, p.z - 0.5);
            Vec3::new(0.5 + c * x - s * z, p.y, 0.5 + s * x + c * z)
        })
        .collect()
}

#[test]
fn refit_equals_a_fresh_build() {
    let mut rng = Pcg32::seed_from_u64(14);
    let (mut pos, mut tris) = (Vec::new(), Vec::new());
    for axis in 0..3 {
        grid(20, axis, 0.3 + 0.2 * axis as f32, &mut pos, &mut tris);
    }
    let params = BvhBuildParams::default();
    let mut bvh = Bvh::build(&pos, &tris, &params);
    let rays = random_rays(&mut rng, 3000, pos.len() as u32);
    for step in 1..4 {
        let moved = twist(&pos, 0.05 * step as f32);
        assert_eq!(bvh.update(&moved, &tris), Update::Refit, "a small twist refits");
        bvh.validate().expect("refitted bvh valid");
        assert!(bvh.stats.sah_cost >= 0.99 * bvh.stats.fresh_sah_cost);
        let fresh = Bvh::build(&moved, &tris, &params);
        let kd = KdTree::build(&moved, &tris, &KdBuildParams::default());
        for r in &rays {
            let want = key(brute_force(&kd, r));
            assert_eq!(key(bvh.intersect(r)), want);
            assert_eq!(key(fresh.intersect(r)), want);
        }
    }
    // Scrambling every vertex makes the refit far worse than a fresh tree: rebuilt.
    let scrambled: Vec<Vec3> = pos.iter().map(|_| rvec(&mut rng, 0.0, 1.0)).collect();
    assert_eq!(bvh.update(&scrambled, &tris), Update::Rebuild);
    bvh.validate().expect("rebuilt bvh valid");
    assert_eq!(bvh.stats.sah_cost, bvh.stats.fresh_sah_cost);
}

#[test]
fn build_does_not_depend_on_threads() {
    let mut rng = Pcg32::seed_from_u64(15);
    let (pos, tris) = soup(&mut rng, 20000, 0.02);
    let params = BvhBuildParams { parallel_threshold: 256, ..Default::default() };
    let a = Bvh::build(&pos, &tris, &params);
    let pool = rayon::ThreadPoolBuilder::new().num_threads(1).build().unwrap();
    let b = pool.install(|| Bvh::build(&pos, &tris, &params));
    a.validate().unwrap();
    assert_eq!(a.nodes, b.nodes);
    assert_eq!(a.blocks.len(), b.blocks.len());
    assert!(a.blocks.iter().zip(&b.blocks).all(|(x, y)| x.tri == y.tri));
}

/// Box queries name exactly the triangles whose boxes overlap the query box
/// (brute force over every triangle), each once: random boxes over a soup,
/// and boxes that only touch a flat grid's (zero-thickness) boxes.
#[test]
fn box_queries_match_brute_force() {
    let mut rng = Pcg32::seed_from_u64(14);
    let (mut flat_pos, mut flat_tris) = (Vec::new(), Vec::new());
    grid(30, 1, 0.0, &mut flat_pos, &mut flat_tris);
    for (pos, tris) in [soup(&mut rng, 4000, 0.05), (flat_pos, flat_tris)] {
        let bvh = Bvh::build(&pos, &tris, &BvhBuildParams::default());
        bvh.validate().expect("bvh valid");
        let boxes = |t: &[u32; 3]| {
            let [a, b, c] = t.map(|i| pos[i as usize]);
            (a.min(b).min(c), a.max(b).max(c))
        };
        let mut found_some = 0;
        for q in 0..300 {
            let c = rvec(&mut rng, -0.1, 1.1);
            let h = rvec(&mut rng, 0.0, 0.15);
            // Every third box is flat on the grid's plane (touching only).
            let (min, max) = if q % 3 == 0 {
                (Vec3::new(c.x - h.x, 0.0, c.z - h.z), Vec3::new(c.x + h.x, 0.0, c.z + h.z))
            } else {
                (c - h, c + h)
            };
            let mut got = Vec::new();
            bvh.overlapping(min, max, |t| got.push(t));
            got.sort_unstable();
            let want: Vec<u32> = (0..tris.len() as u32)
                .filter(|&t| {
                    let (lo, hi) = boxes(&tris[t as usize]);
                    lo.cmple(max).all() && hi.cmpge(min).all()
                })
                .collect();
            assert_eq!(got, want, "query {q}: {min} .. {max}");
            found_some += usize::from(!want.is_empty());
        }
        assert!(found_some > 100, "{found_some} of 300 queries found triangles");
    }
}
