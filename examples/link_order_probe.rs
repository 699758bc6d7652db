//! Link encoding experiments (issue 16): gaps between consecutive sorted
//! targets of a group in the scene's vertex order, along Morton and
//! Hilbert curves, shuffled, and breadth-first over one-rings, and what
//! they cost in several codes:
//! `cargo run --release --example link_order_probe -- tearoom`.
use linkgi::links::Links;
use linkgi::scene::{self, prep};

/// The corner and edge of the cube around the points.
fn cube(p: &[glam::Vec3]) -> (glam::Vec3, f32) {
    let (mut lo, mut hi) = (glam::Vec3::splat(f32::MAX), glam::Vec3::splat(f32::MIN));
    for q in p {
        lo = lo.min(*q);
        hi = hi.max(*q);
    }
    (lo, (hi - lo).max_element().max(1e-30))
}

fn morton_order(p: &[glam::Vec3]) -> Vec<u32> {
    let (lo, ext) = cube(p);
    let spread = |mut x: u64| {
        x &= 0x1f_ffff;
        x = (x | x << 32) & 0x1f00000000ffff;
        x = (x | x << 16) & 0x1f0000ff0000ff;
        x = (x | x << 8) & 0x100f00f00f00f00f;
        x = (x | x << 4) & 0x10c30c30c30c30c3;
        (x | x << 2) & 0x1249249249249249
    };
    let mut keys: Vec<(u64, u32)> = p
        .iter()
        .enumerate()
        .map(|(i, q)| {
            let c = ((*q - lo) / ext * 2097151.0).as_uvec3();
            (spread(c.x as u64) | spread(c.y as u64) << 1 | spread(c.z as u64) << 2, i as u32)
        })
        .collect();
    keys.sort_unstable();
    keys.iter().map(|k| k.1).collect() // new -> old
}

/// Hilbert order over positions (Skilling's transpose algorithm, 3 x 16 bits).
fn hilbert_order(p: &[glam::Vec3]) -> Vec<u32> {
    let (lo, ext) = cube(p);
    const BITS: u32 = 16;
    let key = |q: glam::Vec3| -> u64 {
        let c = ((q - lo) / ext * 65535.0).as_uvec3();
        let mut x = [c.x, c.y, c.z];
        // Inverse undo excess work (axes to transpose).
        let m = 1u32 << (BITS - 1);
        let mut qb = m;
        while qb > 1 {
            let pm = qb - 1;
            for i in 0..3 {
                if x[i] & qb != 0 {
                    x[0] ^= pm;
                } else {
                    let t = (x[0] ^ x[i]) & pm;
                    x[0] ^= t;
                    x[i] ^= t;
                }
            }
            qb >>= 1;
        }
        // Gray encode.
        for i in 1..3 {
            x[i] ^= x[i - 1];
        }
        let mut t = 0;
        let mut qb = m;
        while qb > 1 {
            if x[2] & qb != 0 {
                t ^= qb - 1;
            }
            qb >>= 1;
        }
        for v in &mut x {
            *v ^= t;
        }
        // Interleave the transposed bits, most significant first.
        let mut k = 0u64;
        for b in (0..BITS).rev() {
            for v in &x {
                k = k << 1 | ((v >> b) & 1) as u64;
            }
        }
        k
    };
    let mut keys: Vec<(u64, u32)> = p.iter().enumerate().map(|(i, q)| (key(*q), i as u32)).collect();
    keys.sort_unstable();
    keys.iter().map(|k| k.1).collect()
}

fn stats(label: &str, links: &Links, new_of_old: &[u32], old_of_new: &[u32]) {
    let mut buckets = [0u64; 8];
    let (mut b_a, mut b_b, mut b_c) = (0u64, 0u64, 0u64);
    let mut t = Vec::new();
    for &old in old_of_new {
        let (tg, _) = links.group(old as usize);
        t.clear();
        let tg = &tg;
        t.extend(tg.iter().map(|&x| new_of_old[x as usize]));
        t.sort_unstable();
        let mut prev = 0u32;
        let mut first = true;
        for &x in &t {
            let gap = if first { x + 1 } else { x - prev };
            first = false;
            prev = x;
            let k = match gap {
                1 => 0,
                2..=15 => 1,
                16..=255 => 2,
                256..=4095 => 3,
                4096..=65535 => 4,
                _ => 5,
            };
            buckets[k] += 1;
            // A: {1,2,3,4} bytes; B: {0 (gap 1),1,2,3}; C: nibble code
            b_a += if gap < 256 {
                1
            } else if gap < 65536 {
                2
            } else if gap < 1 << 24 {
                3
            } else {
                4
            };
            b_b += if gap == 1 {
                0
            } else if gap < 257 {
                1
            } else if gap < 65536 + 257 {
                2
            } else {
                3
            };
            b_c += if gap <= 16 {
                1
            } else if gap < 16 + 4096 {
                2
            } else if gap < 16 + 4096 + 65536 * 16 {
                3
            } else {
                4
            };
        }
    }
    let n = links.link_count() as f64;
    println!(
        "{label:10} gap=1 {:.3} <16 {:.3} <256 {:.3} <4096 {:.3} <65536 {:.3} more {:.3} | A {:.3} B {:.3} B/link(+1 w +0.25 ctl), nibbles {:.3}",
        buckets[0] as f64 / n,
        buckets[1] as f64 / n,
        buckets[2] as f64 / n,
        buckets[3] as f64 / n,
        buckets[4] as f64 / n,
        buckets[5] as f64 / n,
        b_a as f64 / n + 1.25,
        b_b as f64 / n + 1.25,
        b_c as f64 / n * 0.5 + 1.0
    );
}

fn main() {
    let name = std::env::args().nth(1).unwrap_or_else(|| "tearoom".into());
    let mut desc = scene::load(&name).unwrap();
    desc.settings.rays_per_vertex = 256;
    let scene = prep::prepare(&desc).unwrap();
    let params = linkgi::solver::SolveParams::from_settings(&desc.settings);
    let accel = linkgi::trace::Accel::build(params.tracer, &scene.positions, &scene.triangles, &params.bvh, &params.kd);
    let links = linkgi::links::shoot_links(&scene, &accel, &params.links, &|_, _| {});
    let n = links.vertex_count();
    println!(
        "{name}: {n} vertices, {} links, {:.1} links/vertex",
        links.link_count(),
        links.link_count() as f64 / n as f64
    );
    let id: Vec<u32> = (0..n as u32).collect();
    stats("scene", &links, &id, &id);
    let old_of_new = morton_order(&scene.positions);
    let mut new_of_old = vec![0u32; n];
    for (i, &o) in old_of_new.iter().enumerate() {
        new_of_old[o as usize] = i as u32;
    }
    stats("morton", &links, &new_of_old, &old_of_new);
    let h = hilbert_order(&scene.positions);
    let mut hinv = vec![0u32; n];
    for (i, &o) in h.iter().enumerate() {
        hinv[o as usize] = i as u32;
    }
    stats("hilbert", &links, &hinv, &h);
    // A shuffled order (an exporter that scrambles vertices), and Morton over it.
    let mut shuffled: Vec<u32> = (0..n as u32).collect();
    let mut state = 0x9E3779B97F4A7C15u64;
    for i in (1..n).rev() {
        state ^= state << 13;
        state ^= state >> 7;
        state ^= state << 17;
        shuffled.swap(i, (state % (i as u64 + 1)) as usize);
    }
    let mut inv = vec![0u32; n];
    for (i, &o) in shuffled.iter().enumerate() {
        inv[o as usize] = i as u32;
    }
    stats("shuffled", &links, &inv, &shuffled);
    // Breadth-first over one-rings, from each unvisited vertex in the given order.
    let bfs = |start_order: &[u32]| {
        let mut seen = vec![false; n];
        let mut order = Vec::with_capacity(n);
        for &s0 in start_order {
            if seen[s0 as usize] {
                continue;
            }
            seen[s0 as usize] = true;
            let mut head = order.len();
            order.push(s0);
            while head < order.len() {
                let v = order[head] as usize;
                head += 1;
                for &u in scene.rings.row(v) {
                    if !seen[u as usize] {
                        seen[u as usize] = true;
                        order.push(u);
                    }
                }
            }
        }
        let mut inv = vec![0u32; n];
        for (i, &o) in order.iter().enumerate() {
            inv[o as usize] = i as u32;
        }
        (order, inv)
    };
    let (o, i) = bfs(&id);
    stats("bfs", &links, &i, &o);
    let (o, i) = bfs(&shuffled);
    stats("bfs(shuf)", &links, &i, &o);
    // The same links renumbered, timed in the library's gather.
    let (mut offsets, mut targets, mut weights) = (vec![0u32], Vec::new(), Vec::new());
    let mut row: Vec<(u32, half::f16)> = Vec::new();
    for &old in &old_of_new {
        let (t, w) = links.group(old as usize);
        row.clear();
        row.extend(t.iter().zip(w).map(|(&t, &w)| (new_of_old[t as usize], w)));
        row.sort_unstable_by_key(|x| x.0);
        targets.extend(row.iter().map(|x| x.0));
        weights.extend(row.iter().map(|x| x.1));
        offsets.push(targets.len() as u32);
    }
    let perm = Links::from_csr(offsets, &targets, weights);
    let b: Vec<glam::Vec4> = (0..n).map(|i| glam::Vec4::new(1.0 + (i % 7) as f32, 0.5, 0.25, 0.0)).collect();
    let mut out = vec![glam::Vec3::ZERO; n];
    for (label, l) in [("scene", &links), ("morton", &perm), ("scene", &links), ("morton", &perm)] {
        let mut best = f64::MAX;
        for _ in 0..10 {
            let t = std::time::Instant::now();
            linkgi::exchange::gather::gather_bounce_padded(l, &b, &mut out);
            best = best.min(t.elapsed().as_secs_f64() * 1e3);
        }
        println!("gather {label}: {best:.2} ms, {:.2} G links/s", l.link_count() as f64 / best / 1e6);
    }
    // Weights relative to the group's largest, log2 histogram.
    let mut h = [0u64; 20];
    for v in 0..n {
        let (_, w) = links.group(v);
        let m = w.iter().map(|x| x.to_f32()).fold(0f32, f32::max);
        for x in w {
            let r = (m / x.to_f32()).log2().floor().clamp(0.0, 19.0) as usize;
            h[r] += 1;
        }
    }
    let tot: u64 = h.iter().sum();
    println!(
        "weights: share by log2(max/w): {:?}",
        h.iter().map(|&c| format!("{:.3}", c as f64 / tot as f64)).collect::<Vec<_>>()
    );
}
