//! Every scene-running subcommand goes through the CLI's one setup
//! (src/cli/setup.rs): the loader's warnings reach stderr and the shared
//! overrides apply, whichever subcommand loaded the scene.

use std::path::{Path, PathBuf};
use std::process::Command;

/// A folder with `s.toml`: a floor quad whose material's Kd 1.5 is clamped
/// with a warning, lit by a point light above it.
fn warned_scene(name: &str) -> PathBuf {
    let d = Path::new(env!("CARGO_TARGET_TMPDIR")).join(format!("cli-{name}"));
    let _ = std::fs::remove_dir_all(&d);
    std::fs::create_dir_all(&d).unwrap();
    std::fs::write(d.join("hot.mtl"), "newmtl hot\nKd 1.5 0.5 0.2\n").unwrap();
    std::fs::write(
        d.join("floor.obj"),
        "mtllib hot.mtl\nusemtl hot\nv -1 0 -1\nv 1 0 -1\nv 1 0 1\nv -1 0 1\nf 1 3 2\nf 1 4 3\n",
    )
    .unwrap();
    std::fs::write(
        d.join("s.toml"),
        "[[mesh]]\nobj = \"floor.obj\"\n[[light]]\nkind = \"point\"\nposition = [0, 1, 0]\nintensity = [1, 1, 1]\n",
    )
    .unwrap();
    d
}

fn run(args: &[&str]) -> (bool, String) {
    let out = Command::new(env!("CARGO_BIN_EXE_linkgi")).args(args).output().unwrap();
    (out.status.success(), String::from_utf8_lossy(&out.stderr).into_owned())
}

#[test]
fn every_subcommand_reports_the_loaders_warnings() {
    let d = warned_scene("warnings");
    let path = |name: &str| d.join(name).to_str().unwrap().to_string();
    let (scene, out, png, cache) = (path("s.toml"), path("out"), path("out/r.png"), path("cache"));
    let tiny = ["--rays", "4", "--backend", "cpu"];
    for (name, args) in [
        ("solve", vec![]),
        ("render", vec!["--size", "8x6", "--out", &png]),
        ("animate", vec!["--size", "8x6", "--frames", "1", "--sync", "--out", &out]),
        ("error", vec!["--ref-samples", "16", "--cache", &cache, "--out", &out]),
        ("bench", vec!["--runs", "1"]),
    ] {
        let shared: &[&str] = if name == "error" { &[] } else { &tiny };
        let (ok, stderr) = run(&[&[name, scene.as_str()], shared, &args].concat());
        assert!(ok, "{name} failed: {stderr}");
        let warning = stderr.lines().find(|l| l.starts_with("warning: ") && l.contains("'hot'"));
        assert!(warning.is_some_and(|w| w.contains("floor.obj") && w.contains("clamped")), "{name}: {stderr}");
    }
}

#[test]
fn overrides_are_checked_before_any_work() {
    let d = warned_scene("overrides");
    let scene = d.join("s.toml");
    let scene = scene.to_str().unwrap();
    for args in [
        vec!["solve", scene, "--rays", "5"],
        vec!["render", scene, "--rays", "5", "--backend", "cpu"],
        vec!["animate", scene, "--rays", "5", "--backend", "cpu", "--frames", "1"],
        vec!["bench", scene, "--rays", "5", "--backend", "cpu"],
    ] {
        let (ok, stderr) = run(&args);
        assert!(!ok, "{args:?} accepted 5 rays per vertex");
        assert!(stderr.contains("rays_per_vertex = 5") && stderr.contains("s.toml"), "{args:?}: {stderr}");
        assert!(!stderr.contains("panicked"), "{args:?}: {stderr}");
    }
    let (ok, stderr) = run(&["solve", scene, "--backend", "tpu"]);
    assert!(!ok && stderr.contains("tpu") && stderr.contains("expected auto, gpu or cpu"), "{stderr}");
}

/// `solve --time T` solves the deformers' pose at T: the exported figure
/// moved (the room did not), the rest pose at T = 0; a scene without
/// deformers says so and solves its rest pose; a non-finite T is an error.
#[test]
fn solve_time_evaluates_the_deformers() {
    use linkgi::scene::deform::deform_scene;
    use linkgi::scene::{builtin, prep};
    let d = Path::new(env!("CARGO_TARGET_TMPDIR")).join("cli-time");
    let _ = std::fs::remove_dir_all(&d);
    let positions = |t: &str| {
        let dir = d.join(format!("t{t}"));
        let (ok, err) = run(&["solve", "torso", "--time", t, "--rays", "4", "--export", dir.to_str().unwrap()]);
        assert!(ok, "{err}");
        let bytes = std::fs::read(dir.join("mesh.ply")).unwrap();
        let at = bytes.windows(11).position(|w| w == b"end_header\n").unwrap() + 11;
        // `k` floats and three colour bytes a vertex; the first three floats are the position.
        let k = linkgi::export::PLY_VERTEX_PROPERTIES.len();
        let stride = 4 * k + linkgi::export::PLY_COLOUR_PROPERTIES.len();
        let f = |v: usize, i: usize| {
            let o = at + v * stride + 4 * i;
            f32::from_le_bytes(bytes[o..o + 4].try_into().unwrap())
        };
        let n = prep::prepare(&builtin::builtin("torso").unwrap()).unwrap().vertex_count();
        (0..n).map(|v| glam::Vec3::new(f(v, 0), f(v, 1), f(v, 2))).collect::<Vec<_>>()
    };
    let rest = prep::prepare(&builtin::builtin("torso").unwrap()).unwrap();
    let (expected, _) = deform_scene(&rest, &rest.positions, &rest.normals, 1.3);
    let posed = positions("1.3");
    assert!(posed == expected, "--time 1.3 did not solve the deformers' pose");
    assert!(posed != rest.positions);
    assert!(positions("0") == rest.positions);
    let (ok, err) = run(&["solve", "cornell", "--time", "2", "--rays", "4"]);
    assert!(ok && err.contains("no deformers"), "{err}");
    let (ok, err) = run(&["solve", "torso", "--time", "nan", "--rays", "4"]);
    assert!(!ok && err.contains("--time"), "{err}");
}

/// `--off` switches terms off end to end: `solve --off near` records no
/// near hits where the default does; an unknown term, on the command line
/// or in a scene file's `off` list, is an error listing the terms (and
/// naming the file).
#[test]
fn off_switches_terms_and_rejects_unknown_names() {
    let solve = |extra: &[&str]| {
        let out = Command::new(env!("CARGO_BIN_EXE_linkgi"))
            .args(["solve", "cornell", "--rays", "16", "--backend", "cpu"])
            .args(extra)
            .output()
            .unwrap();
        (
            out.status.success(),
            String::from_utf8_lossy(&out.stdout).into_owned(),
            String::from_utf8_lossy(&out.stderr).into_owned(),
        )
    };
    let (ok, on, _) = solve(&[]);
    assert!(ok && on.contains("near hits"), "the default solve records near hits:\n{on}");
    let (ok, off, _) = solve(&["--off", "near,near_gather"]);
    assert!(ok && !off.contains("near hits"), "--off near records none:\n{off}");
    let (ok, _, err) = solve(&["--off", "nearr"]);
    assert!(!ok && err.contains("unknown term") && err.contains("near_gather"), "{err}");
    let d = std::env::temp_dir().join(format!("linkgi_off_{}", std::process::id()));
    std::fs::create_dir_all(&d).unwrap();
    std::fs::write(d.join("floor.obj"), "v 0 0 0\nv 1 0 0\nv 0 0 -1\nf 1 2 3\n").unwrap();
    let scene = d.join("bad.toml");
    std::fs::write(&scene, "[settings]\noff = [\"hiden\"]\n[[mesh]]\nobj = \"floor.obj\"\n").unwrap();
    let (ok, err) = run(&["solve", scene.to_str().unwrap(), "--rays", "4", "--backend", "cpu"]);
    std::fs::remove_dir_all(&d).ok();
    assert!(!ok && err.contains("bad.toml") && err.contains("settings.off") && err.contains("hidden"), "{err}");
}

/// On a headless machine, probing for a GPU (`--backend auto`, for the
/// solve and for the rasterizer) prints no libwayland line about
/// `XDG_RUNTIME_DIR`, whether the variable is missing or relative
/// (src/cli/runtime_dir.rs); the command still succeeds.
#[test]
fn no_xdg_runtime_dir_noise_on_headless_machines() {
    let d = warned_scene("xdg");
    let scene = d.join("s.toml");
    let png = d.join("r.png");
    let args = ["render", scene.to_str().unwrap(), "--rays", "4", "--size", "8x6", "--backend", "auto"];
    let args = [&args[..], &["--out", png.to_str().unwrap()]].concat();
    for value in [None, Some("relative/dir")] {
        let mut cmd = Command::new(env!("CARGO_BIN_EXE_linkgi"));
        cmd.args(&args).env_remove("XDG_RUNTIME_DIR").env_remove("WAYLAND_DISPLAY");
        if let Some(v) = value {
            cmd.env("XDG_RUNTIME_DIR", v);
        }
        let out = cmd.output().unwrap();
        let stderr = String::from_utf8_lossy(&out.stderr);
        assert!(out.status.success(), "XDG_RUNTIME_DIR {value:?}: {stderr}");
        assert!(!stderr.lines().any(|l| l.contains("XDG_RUNTIME_DIR")), "XDG_RUNTIME_DIR {value:?}: {stderr}");
        assert!(stderr.contains("warning: "), "the loader's warnings still reach stderr: {stderr}");
    }
}
