//! Markdown tables of benchmark rows, each of our rows followed by the
//! paper's rows for the same scene (sizes table, then times table).
//! Times: median with [min, max] in ms; rates in k rays/s. Where rows carry
//! Embree peer figures, a last table sets our ray rate and build time beside
//! Embree's (its rates in M rays/s).

use super::{paper_rows, BenchRow, PeerFigures, Stat};
use std::fmt::Write;

fn stat(s: &Stat, digits: usize) -> String {
    format!("{:.d$} [{:.d$}, {:.d$}]", s.median, s.min, s.max, d = digits)
}

/// [`stat`], or "-" where nothing was measured.
fn stat_or_dash(s: &Stat, digits: usize) -> String {
    if s.median.is_finite() {
        stat(s, digits)
    } else {
        "-".to_string()
    }
}

/// The structure a row's rays went through, as the size table names it.
fn tree(r: &BenchRow) -> &'static str {
    match r.tracer.as_str() {
        "bvh" | "gpu-bvh" => "bvh8",
        "kd" | "gpu-kd" => "kd",
        // The driver's own structure; the node count is the CPU BVH's beside it.
        "gpu-rq" => "ray queries",
        _ => "?",
    }
}

/// Both tables for `rows` as GitHub markdown.
pub fn markdown(rows: &[BenchRow]) -> String {
    let mut out = String::new();
    let rays = rows.first().map(|r| r.rays_per_vertex).unwrap_or(256);
    let runs = rows.first().map(|r| r.runs).unwrap_or(0);
    let _ = writeln!(out, "### Sizes ({rays} rays per vertex)\n");
    let _ = writeln!(
        out,
        "| scene | source | vertices | tree nodes | links raw (M) | links merged (M) | MB raw | MB merged |"
    );
    let _ = writeln!(out, "|---|---|---|---|---|---|---|---|");
    // Sizes are the same for every backend (the links are identical): one row a scene.
    let mut scenes: Vec<&str> = Vec::new();
    for r in rows {
        if !scenes.contains(&r.scene.as_str()) {
            scenes.push(&r.scene);
        }
    }
    for r in scenes.iter().filter_map(|s| rows.iter().find(|r| r.scene == *s)) {
        let _ = writeln!(
            out,
            "| {} | linkgi ({}) | {} | {} | {:.2} | {:.2} | {:.1} | {:.1} |",
            r.scene,
            tree(r),
            r.vertices,
            r.kd_nodes,
            r.links_raw as f64 / 1e6,
            r.links_merged as f64 / 1e6,
            r.mb_raw,
            r.mb_merged
        );
        // The size figures repeat across the paper's GPU rows: show them once.
        if let Some(p) = paper_rows(&r.scene).first() {
            let kd = p.kd_nodes.map(|k| format!("{k:.0}")).unwrap_or_else(|| "?".into());
            let _ = writeln!(
                out,
                "| {} | paper | {:.0} | {kd} | {:.1} | | {:.1} | {:.1} |",
                p.name, p.vertices, p.links_m, p.mb_raw, p.mb_merged
            );
        }
    }
    let _ = writeln!(
        out,
        "\nThe paper gives one link count without saying raw or merged; it is shown in the raw column. \
         Tree: the structure the rays went through (ours: 8-wide BVH nodes with the `bvh` tracer on \
         the CPU or the GPU, kd-tree nodes with `kd`, with GPU ray queries the driver's structure and \
         the CPU BVH's nodes beside it; the paper's: a kd-tree)."
    );
    let _ = writeln!(out, "\n### Times (median [min, max] of {runs} runs, 3 bounces)\n");
    let _ = writeln!(
        out,
        "| scene | source | tree ms | links ms | k rays/s | light links ms | k shadow rays/s | bounces ms | first solution s | fps | peak MB |"
    );
    let _ = writeln!(out, "|---|---|---|---|---|---|---|---|---|---|---|");
    for scene in &scenes {
        for r in rows.iter().filter(|r| r.scene == *scene) {
            let _ = writeln!(
                out,
                "| {} | linkgi {} | {} | {} | {} | {} | {} | {} | {} | {} | {} |",
                r.scene,
                r.backend,
                stat(&r.kd_ms, 1),
                stat(&r.links_ms, 0),
                stat(&r.k_rays_per_s, 0),
                stat(&r.light_links_ms, 1),
                stat(&r.k_shadow_rays_per_s, 0),
                stat(&r.bounces_ms, 1),
                stat(
                    &Stat {
                        median: r.first_solution_ms.median / 1e3,
                        min: r.first_solution_ms.min / 1e3,
                        max: r.first_solution_ms.max / 1e3
                    },
                    2
                ),
                if r.render_fps.is_finite() { format!("{:.1}", r.render_fps) } else { String::new() },
                if r.peak_mb.is_finite() { format!("{:.0}", r.peak_mb) } else { String::new() },
            );
        }
        for p in paper_rows(scene) {
            let _ = writeln!(
                out,
                "| {} | paper, {} GPU{} | {:.0} | {:.0} | {:.0} | {:.0} | | {:.0} | {:.1} | {:.1} | |",
                p.name,
                p.gpus,
                if p.gpus > 1 { "s" } else { "" },
                p.kd_ms,
                p.links_ms,
                p.k_rays_per_s,
                p.light_links_ms,
                p.bounces_ms,
                p.first_frame_s,
                p.fps
            );
        }
    }
    let _ = writeln!(
        out,
        "\n### Moving light 0 by 5 cm (median [min, max] of {runs} runs): its light links, then bounces and smoothing\n"
    );
    let _ = writeln!(out, "| scene | source | preview ms | full ms |");
    let _ = writeln!(out, "|---|---|---|---|");
    for r in rows.iter().filter(|r| r.light_move_ms.median.is_finite()) {
        let _ = writeln!(
            out,
            "| {} | linkgi {} | {} | {} |",
            r.scene,
            r.backend,
            stat(&r.light_preview_ms, 1),
            stat(&r.light_move_ms, 1)
        );
    }
    let beyond: Vec<&BenchRow> =
        rows.iter().filter(|r| r.near_hits > 0 || r.emitter_links_ms.median.is_finite()).collect();
    if !beyond.is_empty() {
        let _ = writeln!(
            out,
            "\n### Near hits and emitter links (median [min, max] of {runs} runs; part of the first solution)\n"
        );
        let _ = writeln!(out, "| scene | source | near hits | their light columns ms | emitter links ms |");
        let _ = writeln!(out, "|---|---|---|---|---|");
        for r in beyond {
            let _ = writeln!(
                out,
                "| {} | linkgi {} | {} | {} | {} |",
                r.scene,
                r.backend,
                r.near_hits,
                stat_or_dash(&r.near_ms, 1),
                stat_or_dash(&r.emitter_links_ms, 1)
            );
        }
    }
    let emitting: Vec<&BenchRow> = rows.iter().filter(|r| r.k_emitter_shadow_rays_per_s.median.is_finite()).collect();
    if !emitting.is_empty() {
        let _ = writeln!(
            out,
            "\n### Shadow rays of the light links beside the emitter links' (median [min, max] of {runs} runs, k rays/s)\n"
        );
        let _ = writeln!(out, "| scene | source | light links | emitter links | emitter rays, tracing alone |");
        let _ = writeln!(out, "|---|---|---|---|---|");
        for r in &emitting {
            let _ = writeln!(
                out,
                "| {} | linkgi {} | {} | {} | {} |",
                r.scene,
                r.backend,
                // No light, no light links' rays: their rate of 0 would read as a measurement.
                if r.k_shadow_rays_per_s.median > 0.0 { stat(&r.k_shadow_rays_per_s, 0) } else { "-".into() },
                stat(&r.k_emitter_shadow_rays_per_s, 0),
                stat(&r.k_emitter_trace_rays_per_s, 0)
            );
        }
        let _ = writeln!(
            out,
            "\nEach stage's rays over its whole time (the emitter links' includes a form factor per vertex \
             and emitter triangle, and the sampling), and the emitter rays over the tracer's time alone."
        );
    }
    let skies: Vec<&BenchRow> = rows.iter().filter(|r| r.sky_turn_ms.median.is_finite()).collect();
    if !skies.is_empty() {
        let _ = writeln!(
            out,
            "\n### Turning the sky by 30 degrees (median [min, max] of {runs} runs): sky light from the miss masks, bounces, smoothing\n"
        );
        let _ = writeln!(out, "| scene | source | ms |");
        let _ = writeln!(out, "|---|---|---|");
        for r in skies {
            let _ = writeln!(out, "| {} | linkgi {} | {} |", r.scene, r.backend, stat(&r.sky_turn_ms, 1));
        }
    }
    let deforming: Vec<&BenchRow> = rows.iter().filter(|r| r.deform_update_ms.median.is_finite()).collect();
    if !deforming.is_empty() {
        let _ = writeln!(
            out,
            "\n### Deformation from rest to t = {} s (median [min, max] of {runs} runs), with bounces and smoothing\n",
            super::DEFORM_TIME_S
        );
        let _ = writeln!(
            out,
            "| scene | source | preview ms | selective ms | full ms | speed-up | static rays re-shot | ray state MB |"
        );
        let _ = writeln!(out, "|---|---|---|---|---|---|---|---|");
        for r in deforming {
            let _ = writeln!(
                out,
                "| {} | linkgi {} | {} | {} | {} | {:.1}x | {:.1}% | {:.1} |",
                r.scene,
                r.backend,
                stat(&r.deform_preview_ms, 1),
                stat(&r.deform_update_ms, 1),
                stat(&r.deform_full_ms, 1),
                r.deform_full_ms.median / r.deform_update_ms.median,
                100.0 * r.deform_static_rays_fraction,
                r.ray_state_mb
            );
        }
        let _ = writeln!(out, "\nPaper (TORSO, two GPUs): a full update every 0.4 s; no selective updates.");
    }
    let cpu: Vec<&BenchRow> = rows.iter().filter(|r| r.backend == "CPU" && r.read_gbps.is_finite()).collect();
    if let Some(first) = cpu.first() {
        let _ = writeln!(
            out,
            "\n### Gather bandwidth (CPU; machine read bandwidth {:.1} GB/s, parallel sum over 512 MB)\n",
            first.read_gbps
        );
        let _ = writeln!(
            out,
            "| scene | bytes a link | MB per bounce | ms per bounce | G links/s | GB/s | % of read bandwidth |"
        );
        let _ = writeln!(out, "|---|---|---|---|---|---|---|");
        for r in cpu {
            let ms = r.bounces_ms.median / r.bounces.max(1) as f64;
            let gbps = r.gather_bytes as f64 / (ms * 1e-3) / 1e9;
            let _ = writeln!(
                out,
                "| {} | {:.2} | {:.1} | {:.2} | {:.2} | {:.1} | {:.0}% |",
                r.scene,
                r.mb_merged * 1e6 / r.links_merged.max(1) as f64,
                r.gather_bytes as f64 / 1e6,
                ms,
                r.links_merged as f64 / (ms * 1e-3) / 1e9,
                gbps,
                100.0 * gbps / r.read_gbps
            );
        }
    }
    let peers: Vec<(&BenchRow, &PeerFigures)> = rows.iter().filter_map(|r| r.peer.as_ref().map(|p| (r, p))).collect();
    if !peers.is_empty() {
        let _ = writeln!(out, "\n### Beside Embree 3 (same run, same machine)\n");
        let _ = writeln!(
            out,
            "| scene | tracer | ours k rays/s | ours trace-only k rays/s | Embree rtcIntersect1 M rays/s | trace-only ours/Embree | Embree rtcIntersect16 M rays/s | our build ms | Embree build ms | build ours/Embree |"
        );
        let _ = writeln!(out, "|---|---|---|---|---|---|---|---|---|---|");
        for (r, p) in peers {
            let ours_build = our_build_ms(r);
            let _ = writeln!(
                out,
                "| {} | {} | {:.0} | {:.0} | {:.2} | {:.2} | {:.2} | {:.1} | {:.1} | {:.2} |",
                r.scene,
                r.tracer,
                r.k_rays_per_s.median,
                r.trace_k_rays_per_s,
                p.mrays_single,
                r.trace_k_rays_per_s / 1e3 / p.mrays_single,
                p.mrays_packet16,
                ours_build,
                p.build_ms,
                ours_build / p.build_ms
            );
        }
        let _ = writeln!(
            out,
            "\nOurs: link shooting rate (tracing and merging into links), median of {runs} runs; trace-only: the same rays traced \
             without merging, best of {runs} passes; the build of the structure the rays go through (`tree ms` above), median. Embree (`../shared/peers/embree_peer`): \
             the same mesh, {rays} cosine-weighted rays per vertex, best of {runs} traces with as many threads; \
             BVH build `RTC_BUILD_QUALITY_HIGH`, best of 3. Ratios above 1: ours is faster (rays) or slower (build)."
        );
    }
    out
}

/// Our build time set beside Embree's, ms (median): the row's `kd_ms`, the
/// build of the acceleration structure the link rays went through.
fn our_build_ms(r: &BenchRow) -> f64 {
    r.kd_ms.median
}

#[cfg(test)]
mod tests {
    use super::super::{BenchRow, RunTimes, Sizes, Stat};
    use super::*;

    #[test]
    fn median_min_max() {
        let s = Stat::of(&[5.0, 1.0, 3.0]);
        assert_eq!((s.median, s.min, s.max), (3.0, 1.0, 5.0));
        let s = Stat::of(&[4.0, 1.0, 3.0, 10.0]);
        assert_eq!((s.median, s.min, s.max), (3.5, 1.0, 10.0));
        let s = Stat::of(&[f64::NAN, 2.0]);
        assert_eq!((s.median, s.min, s.max), (2.0, 2.0, 2.0));
        assert!(Stat::of(&[]).median.is_nan());
    }

    fn synthetic(scene: &str) -> BenchRow {
        let runs: Vec<RunTimes> = [30.0, 10.0, 20.0]
            .iter()
            .map(|&k| RunTimes {
                kd_ms: k,
                links_ms: 10.0 * k,
                rays_per_s: 1e6 * k,
                light_links_ms: k / 10.0,
                shadow_rays_per_s: 2e5 * k,
                near_ms: k / 8.0,
                emitter_links_ms: f64::NAN,
                emitter_shadow_rays_per_s: f64::NAN,
                emitter_trace_rays_per_s: f64::NAN,
                bounces_ms: k / 5.0,
                first_solution_ms: 100.0 * k,
                light_preview_ms: k / 20.0,
                light_move_ms: k / 4.0,
                sky_turn_ms: f64::NAN,
                deform_update_ms: f64::NAN,
                deform_full_ms: f64::NAN,
                deform_preview_ms: f64::NAN,
                deform_static_rays_fraction: f64::NAN,
            })
            .collect();
        let sizes = Sizes {
            vertices: 11_900,
            triangles: 20_000,
            kd_nodes: 14_000,
            links_raw: 3_000_000,
            links_merged: 1_000_000,
            bytes_raw: 24_000_000,
            bytes_merged: 6_000_000,
            gather_bytes: 6_500_000,
            ray_state_bytes: 0,
            near_hits: 400_000,
            tracer: "bvh",
        };
        let mut row = BenchRow::from_runs(scene, &sizes, 256, &runs);
        row.tracer = "bvh".into();
        row
    }

    #[test]
    fn row_takes_medians_and_units() {
        let r = synthetic("tearoom");
        assert_eq!(r.kd_ms, Stat { median: 20.0, min: 10.0, max: 30.0 });
        assert_eq!(r.k_rays_per_s.median, 20_000.0);
        assert_eq!(r.mb_raw, 24.0);
        assert_eq!(r.runs, 3);
    }

    #[test]
    fn markdown_puts_the_paper_beside_ours() {
        let md = markdown(&[synthetic("tearoom"), synthetic("cornell"), synthetic("sculpture")]);
        let lines: Vec<&str> = md.lines().collect();
        let ours = lines
            .iter()
            .position(|l| l.starts_with("| tearoom | linkgi CPU | 20.0 [10.0, 30.0] | 200 [100, 300]"))
            .expect("our tearoom time row");
        assert!(
            lines[ours + 1].starts_with("| TEAROOM | paper, 1 GPU | 71 | 680 | 4472 | 13 |"),
            "{}",
            lines[ours + 1]
        );
        assert!(lines[ours + 2].starts_with("| TEAROOM | paper, 2 GPUs | 53 | 400 | 7595 |"));
        // cornell has no paper row: the next line is our next scene.
        let c = lines.iter().position(|l| l.starts_with("| cornell | linkgi CPU")).unwrap();
        assert!(lines[c + 1].starts_with("| sculpture | linkgi CPU"));
        assert!(lines[c + 2].starts_with("| IPHI | paper, 2 GPUs | 47 |"));
        assert!(md.contains("| tearoom | linkgi (bvh8) | 11900 | 14000 | 3.00 | 1.00 | 24.0 | 6.0 |"), "{md}");
        assert!(md.contains("first solution s") && md.contains("2.00 [1.00, 3.00]"));
        assert!(md.contains("| tearoom | linkgi CPU | 1.0 [0.5, 1.5] | 5.0 [2.5, 7.5] |"), "{md}");
        // Near hits (400k, columns k / 8 ms), no emitters.
        assert!(md.contains("| tearoom | linkgi CPU | 400000 | 2.5 [1.2, 3.8] | - |"), "{md}");
        // No bandwidth measured: no bandwidth table.
        assert!(!md.contains("Gather bandwidth"));
        let mut r = synthetic("tearoom");
        r.read_gbps = 10.0;
        // 1 M links in 6 MB: 6 bytes a link; 6.5 MB a bounce, 4 ms (median)
        // for 3 bounces: 0.75 G links/s, 4.9 GB/s, 49% of 10 GB/s.
        let md = markdown(&[r]);
        assert!(md.contains("| tearoom | 6.00 | 6.5 | 1.33 | 0.75 | 4.9 | 49% |"), "{md}");
    }

    #[test]
    fn backends_of_one_scene_share_sizes_and_paper_rows() {
        let mut gpu = synthetic("tearoom");
        gpu.backend = "GPU".into();
        gpu.peak_mb = 123.4;
        let md = markdown(&[synthetic("tearoom"), gpu]);
        let count = |prefix: &str| md.lines().filter(|l| l.starts_with(prefix)).count();
        assert_eq!(count("| tearoom | linkgi ("), 1, "{md}");
        assert_eq!(count("| TEAROOM | paper |"), 1, "{md}");
        assert_eq!(count("| TEAROOM | paper, 1 GPU |"), 1, "{md}");
        let lines: Vec<&str> = md.lines().collect();
        let cpu = lines.iter().position(|l| l.starts_with("| tearoom | linkgi CPU")).unwrap();
        assert!(lines[cpu + 1].starts_with("| tearoom | linkgi GPU") && lines[cpu + 1].ends_with("| 123 |"));
        assert!(lines[cpu + 2].starts_with("| TEAROOM | paper, 1 GPU"));
    }

    #[test]
    fn embree_table_only_with_peer_figures() {
        let md = markdown(&[synthetic("tearoom")]);
        assert!(!md.contains("Beside Embree"), "{md}");
        let mut cpu = synthetic("tearoom");
        // Ours: 20,000 k rays/s = 20 M rays/s median, kd build 20 ms median.
        cpu.peer = Some(PeerFigures { mrays_single: 10.0, mrays_packet16: 12.5, build_ms: 40.0 });
        cpu.trace_k_rays_per_s = 25000.0;
        cpu.tracer = "bvh".into();
        let mut gpu = synthetic("tearoom");
        gpu.backend = "GPU".into();
        let md = markdown(&[cpu, gpu, synthetic("cornell")]);
        let lines: Vec<&str> = md.lines().collect();
        let h = lines.iter().position(|l| *l == "### Beside Embree 3 (same run, same machine)").expect("{md}");
        assert!(lines[h + 2].starts_with("| scene | tracer | ours k rays/s | ours trace-only k rays/s |"), "{md}");
        assert_eq!(lines[h + 4], "| tearoom | bvh | 20000 | 25000 | 10.00 | 2.50 | 12.50 | 20.0 | 40.0 | 0.50 |");
        // One row: the GPU row and the scene without figures are left out.
        assert!(lines[h + 5].is_empty(), "{md}");
        assert!(md.contains("best of 3 traces"), "{md}");
    }

    #[test]
    fn emitter_shadow_rays_beside_light_shadow_rays() {
        let md = markdown(&[synthetic("tearoom")]);
        assert!(!md.contains("beside the emitter links'"), "{md}");
        let mut r = synthetic("window");
        // Light links 2e5 k rays/s (median 4000 k); emitter links 1.5 and 6 M rays/s.
        r.k_emitter_shadow_rays_per_s = Stat { median: 1500.0, min: 1400.0, max: 1600.0 };
        r.k_emitter_trace_rays_per_s = Stat { median: 6000.0, min: 5000.0, max: 7000.0 };
        let mut dark = r.clone();
        dark.scene = "unlit".into();
        dark.k_shadow_rays_per_s = Stat { median: 0.0, min: 0.0, max: 0.0 };
        let md = markdown(&[r, synthetic("tearoom"), dark]);
        let lines: Vec<&str> = md.lines().collect();
        let h = lines.iter().position(|l| l.starts_with("### Shadow rays of the light links")).expect("{md}");
        assert_eq!(
            lines[h + 4],
            "| window | linkgi CPU | 4000 [2000, 6000] | 1500 [1400, 1600] | 6000 [5000, 7000] |",
            "{md}"
        );
        // Without lights there is no light links' rate; tearoom has no emitters.
        assert_eq!(lines[h + 5], "| unlit | linkgi CPU | - | 1500 [1400, 1600] | 6000 [5000, 7000] |", "{md}");
        assert!(lines[h + 6].is_empty(), "{md}");
    }

    #[test]
    fn backend_parses() {
        use super::super::Backend;
        assert_eq!("cpu".parse::<Backend>().unwrap(), Backend::Cpu);
        assert_eq!("Both".parse::<Backend>().unwrap(), Backend::Both);
        assert!("tpu".parse::<Backend>().is_err());
        let cpu = Backend::Cpu.computes().unwrap();
        assert_eq!(cpu.len(), 1);
        assert_eq!(cpu[0].0, "CPU");
    }
}
