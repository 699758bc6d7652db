//! `linkgi animate --sync` end to end (CPU GI and CPU rendering, tiny
//! images): one PNG per frame, and a CSV whose GI version and engine
//! counters show what each frame redid.

use std::path::Path;
use std::process::Command;

fn animate(scene: &str, frames: u32, dir: &Path) -> Vec<Vec<String>> {
    animate_with(scene, frames, dir, &[])
}

fn animate_with(scene: &str, frames: u32, dir: &Path, extra: &[&str]) -> Vec<Vec<String>> {
    let _ = std::fs::remove_dir_all(dir);
    let out = Command::new(env!("CARGO_BIN_EXE_linkgi"))
        .args(["animate", scene, "--frames", &frames.to_string(), "--sync", "--rays", "4", "--size", "48x36"])
        .args(extra)
        .args(["--backend", "cpu", "--out"])
        .arg(dir)
        .output()
        .unwrap();
    let stderr = String::from_utf8_lossy(&out.stderr);
    assert!(out.status.success(), "animate failed: {stderr}");
    assert!(stderr.contains("rendering on the CPU"), "no line saying the CPU fallback was used: {stderr}");
    for k in 0..frames {
        let png = dir.join(format!("frame_{k:04}.png"));
        let img = image::open(&png).unwrap_or_else(|e| panic!("{}: {e}", png.display()));
        assert_eq!((img.width(), img.height()), (48, 36));
    }
    let csv = std::fs::read_to_string(dir.join("frames.csv")).unwrap();
    let rows: Vec<Vec<String>> = csv.lines().map(|l| l.split(',').map(str::to_string).collect()).collect();
    assert_eq!(rows[0][4], "gi_version");
    assert_eq!(rows.len() as u32, frames + 1);
    rows[1..].to_vec()
}

fn col(rows: &[Vec<String>], i: usize) -> Vec<u64> {
    rows.iter().map(|r| r[i].parse().unwrap()).collect()
}

#[test]
fn cornell_light_path_never_rebuilds() {
    let dir = std::env::temp_dir().join(format!("linkgi-animate-cornell-{}", std::process::id()));
    let rows = animate("cornell", 3, &dir);
    // --sync: frame k shows the update for its own light position (version k + 2).
    assert_eq!(col(&rows, 4), vec![2, 3, 4]);
    assert_eq!(col(&rows, 7), vec![1, 1, 1], "kd builds");
    assert_eq!(col(&rows, 8), vec![2, 3, 4], "light-link updates");
}

#[test]
fn torso_deforms_every_frame() {
    let dir = std::env::temp_dir().join(format!("linkgi-animate-torso-{}", std::process::id()));
    let rows = animate("torso", 2, &dir);
    assert_eq!(col(&rows, 4), vec![2, 3]);
    // Frame 0 is at t = 0, where the deformers are the identity: no rebuild.
    assert_eq!(col(&rows, 7), vec![1, 2], "structure updates (build or BVH refit): one per deformed frame");
    // The deformed frame's selective update: rays re-shot, groups patched,
    // light links recomputed, per-ray state kept; --sync shows no previews.
    assert_eq!(col(&rows, 12), vec![0, 0], "previews");
    let (reshot, patched, light, state) = (col(&rows, 14), col(&rows, 16), col(&rows, 17), col(&rows, 18));
    assert!(reshot[1] > 0 && patched[1] > 0 && light[1] > 0 && state[1] > 0, "{:?}", rows[1]);
    let fraction: f64 = rows[1][15].parse().unwrap();
    assert!((0.0..1.0).contains(&fraction), "static rays re-shot fraction {fraction}");
}

/// `--sky-turn` turns `window`'s sky every frame: one gather per frame, no
/// structure, link or light-link work, and the picture changes.
#[test]
fn window_sky_turns_every_frame_as_a_gather() {
    let dir = std::env::temp_dir().join(format!("linkgi-animate-window-{}", std::process::id()));
    let rows = animate_with("window", 3, &dir, &["--sky-turn", "120", "--fps", "1"]);
    assert_eq!(col(&rows, 4), vec![2, 3, 4], "GI versions");
    assert_eq!(col(&rows, 7), vec![1, 1, 1], "structure builds");
    assert_eq!(col(&rows, 8), vec![1, 1, 1], "light-link updates");
    assert_eq!(col(&rows, 9), vec![2, 3, 4], "gathers");
}

#[test]
fn bad_size_is_a_clear_error() {
    for (args, needle) in [
        (vec!["render", "cornell", "--size", "0x5"], "--size 0x5"),
        (vec!["render", "cornell", "--size", "big"], "WIDTHxHEIGHT"),
        (vec!["animate", "nosuchscene", "--frames", "2"], "nosuchscene"),
    ] {
        let out = Command::new(env!("CARGO_BIN_EXE_linkgi")).args(&args).output().unwrap();
        assert!(!out.status.success(), "{args:?} succeeded");
        let stderr = String::from_utf8_lossy(&out.stderr);
        assert!(stderr.contains(needle), "{args:?}: {stderr}");
        assert!(!stderr.contains("panicked"), "{args:?} panicked: {stderr}");
    }
}
