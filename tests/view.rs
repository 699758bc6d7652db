//! Smoke test of `linkgi view`: the binary opens a window under Xvfb, runs a
//! script (wait for GI, screenshot, move the light, wait, screenshot, switch to
//! the indirect view, screenshot, quit) and must exit cleanly with three PNGs
//! of the window's size that differ where the script changed something.
//!
//! Needs `xvfb-run` (and `xdotool` for the mouse test): without them the
//! tests panic when `CI` is set and are skipped (with a message) otherwise.

use std::path::Path;
use std::process::{Command, Stdio};
use std::time::{Duration, Instant};

const W: u32 = 160;
const H: u32 = 120;

fn have(cmd: &str) -> bool {
    Command::new("sh")
        .args(["-c", &format!("command -v {cmd}")])
        .stdout(Stdio::null())
        .status()
        .is_ok_and(|s| s.success())
}

/// True when every tool is on PATH; otherwise panics under `CI` and returns
/// false (the caller skips) with a message elsewhere.
fn tools_present(test: &str, tools: &[&str]) -> bool {
    for tool in tools {
        if !have(tool) {
            if std::env::var_os("CI").is_some() {
                panic!("{tool} is missing (apt-get install xvfb xdotool); {test} cannot run in CI without it");
            }
            eprintln!("SKIPPED {test}: {tool} not found (apt-get install xvfb xdotool)");
            return false;
        }
    }
    true
}

/// An empty folder under the test target dir.
fn fresh_dir(name: &str) -> std::path::PathBuf {
    let dir = Path::new(env!("CARGO_TARGET_TMPDIR")).join(name);
    let _ = std::fs::remove_dir_all(&dir);
    std::fs::create_dir_all(&dir).unwrap();
    dir
}

/// Mean absolute difference per channel, 0..255.
fn mean_abs_diff(a: &image::RgbImage, b: &image::RgbImage) -> f64 {
    let sum: u64 = a.as_raw().iter().zip(b.as_raw()).map(|(&x, &y)| (x as i32 - y as i32).unsigned_abs() as u64).sum();
    sum as f64 / a.as_raw().len() as f64
}

fn load(path: &Path) -> image::RgbImage {
    assert!(path.exists(), "{} was not written", path.display());
    let img = image::open(path).unwrap_or_else(|e| panic!("{}: {e}", path.display())).to_rgb8();
    assert_eq!((img.width(), img.height()), (W, H), "{} has the wrong size", path.display());
    img
}

#[test]
fn scripted_view_writes_screenshots_that_follow_the_script() {
    if !tools_present("scripted_view_writes_screenshots_that_follow_the_script", &["xvfb-run"]) {
        return;
    }
    let dir = fresh_dir("view_smoke");
    let shots = dir.join("shots");
    let script = dir.join("script.txt");
    // The cornell light hangs under the ceiling; moving it down, sideways and
    // forward changes shadows and the colour bleeding substantially.
    std::fs::write(
        &script,
        "# viewer smoke test\n\
         0 wait_gi\n\
         0 screenshot a.png\n\
         0 move_light 0 0.6 -0.8 0.3\n\
         0 wait_gi\n\
         0 screenshot b.png\n\
         0 view indirect\n\
         0 screenshot c.png\n\
         0 screenshot c2.png\n\
         0 view combined\n\
         0 remove_light 0\n\
         0 wait_gi\n\
         0 screenshot e.png\n\
         0 add_light\n\
         0 wait_gi\n\
         0 screenshot f.png\n\
         0 quit\n",
    )
    .unwrap();
    let mut child = Command::new("xvfb-run")
        .args([
            "-a",
            env!("CARGO_BIN_EXE_linkgi"),
            "view",
            "cornell",
            "--exposure",
            "0.6",
            "--size",
            &format!("{W}x{H}"),
            "--script",
        ])
        .arg(&script)
        .arg("--screenshot-dir")
        .arg(&shots)
        .stdout(Stdio::piped())
        .stderr(Stdio::piped())
        .spawn()
        .expect("start xvfb-run");
    let start = Instant::now();
    let status = loop {
        if let Some(s) = child.try_wait().unwrap() {
            break s;
        }
        if start.elapsed() > Duration::from_secs(300) {
            let _ = child.kill();
            let out = child.wait_with_output().unwrap();
            panic!("linkgi view did not quit within 300 s; stderr:\n{}", String::from_utf8_lossy(&out.stderr));
        }
        std::thread::sleep(Duration::from_millis(50));
    };
    let out = child.wait_with_output().unwrap();
    let (stdout, stderr) = (String::from_utf8_lossy(&out.stdout), String::from_utf8_lossy(&out.stderr));
    eprintln!("linkgi view stdout:\n{stdout}\nstderr:\n{stderr}");
    assert!(status.success(), "linkgi view failed: {status}");
    let (a, b, c) = (load(&shots.join("a.png")), load(&shots.join("b.png")), load(&shots.join("c.png")));
    let (ab, bc) = (mean_abs_diff(&a, &b), mean_abs_diff(&b, &c));
    eprintln!("mean abs diff a-b {ab:.2}, b-c {bc:.2}");
    assert!(ab > 5.0, "moving the light barely changed the picture (mean abs diff {ab:.2})");
    assert!(bc > 5.0, "the indirect view looks like the combined one (mean abs diff {bc:.2})");
    // The indirect view shows the engine's GI: zero GI would draw it black.
    let c_mean = c.as_raw().iter().map(|&v| v as f64).sum::<f64>() / c.as_raw().len() as f64;
    eprintln!("mean of c {c_mean:.1}");
    assert!(c_mean > 20.0, "the indirect view is (nearly) black: mean {c_mean:.1}; was the GI shown?");
    // Two screenshots in a row both run, of the same unchanged view.
    let c2 = load(&shots.join("c2.png"));
    assert!(mean_abs_diff(&c, &c2) < 1.0, "c2.png differs from c.png");
    // Without lights the room is black; a light added in front of the camera lights it again.
    let mean = |i: &image::RgbImage| i.as_raw().iter().map(|&v| v as f64).sum::<f64>() / i.as_raw().len() as f64;
    let (e, f) = (load(&shots.join("e.png")), load(&shots.join("f.png")));
    assert!(mean(&e) < 1.0, "no lights, yet the picture has mean {:.2}", mean(&e));
    assert!(mean(&f) > 20.0, "the added light lights nothing: mean {:.2}", mean(&f));
    // Not a black or blank window: the shown image has contrast.
    let (lo, hi) = a.as_raw().iter().fold((255u8, 0u8), |(l, h), &v| (l.min(v), h.max(v)));
    assert!(hi as i32 - lo as i32 > 100, "screenshot a has no contrast ({lo}..{hi})");
}

/// The panel's emission and sky controls through the script: turning the
/// lamp shade off in `window` changes the picture; with the sky at zero as
/// well nothing lights the room (and the background is black).
#[test]
fn scripted_emission_and_sky_edits() {
    if !tools_present("scripted_emission_and_sky_edits", &["xvfb-run"]) {
        return;
    }
    let dir = fresh_dir("view_emission_sky");
    let shots = dir.join("shots");
    let script = dir.join("script.txt");
    std::fs::write(
        &script,
        "0 wait_gi\n0 screenshot a.png\n0 set_emission 1 0\n0 wait_gi\n0 screenshot b.png\n\
         0 set_sky 0 45\n0 wait_gi\n0 screenshot c.png\n0 quit\n",
    )
    .unwrap();
    let out = Command::new("xvfb-run")
        .args([
            "-a",
            env!("CARGO_BIN_EXE_linkgi"),
            "view",
            "window",
            "--exposure",
            "0.6",
            "--rays",
            "64",
            "--size",
            &format!("{W}x{H}"),
        ])
        .arg("--script")
        .arg(&script)
        .arg("--screenshot-dir")
        .arg(&shots)
        .output()
        .expect("run linkgi view");
    let stderr = String::from_utf8_lossy(&out.stderr);
    assert!(out.status.success(), "linkgi view failed: {stderr}");
    let mean = |i: &image::RgbImage| i.as_raw().iter().map(|&v| v as f64).sum::<f64>() / i.as_raw().len() as f64;
    let (a, b, c) = (load(&shots.join("a.png")), load(&shots.join("b.png")), load(&shots.join("c.png")));
    eprintln!("means: lamp on {:.1}, lamp off {:.1}, sky off too {:.1}", mean(&a), mean(&b), mean(&c));
    assert!(mean_abs_diff(&a, &b) > 3.0, "turning the lamp off barely changed the picture");
    assert!(mean(&b) > 10.0, "the sky alone lights nothing: mean {:.1}", mean(&b));
    assert!(mean(&c) < 1.0, "no lamp, no sky, yet the picture has mean {:.2}", mean(&c));
}

/// Automatic exposure in the viewer (no `--exposure`): the first picture is
/// exposed; a light made 1000x stronger brightens the picture at once (the
/// exposure holds while lights change), and seconds later the exposure has
/// followed it back to a picture like the first.
#[test]
fn auto_exposure_holds_while_a_light_changes_then_adapts() {
    if !tools_present("auto_exposure_holds_while_a_light_changes_then_adapts", &["xvfb-run"]) {
        return;
    }
    let dir = fresh_dir("view_auto_exposure");
    let shots = dir.join("shots");
    let script = dir.join("script.txt");
    std::fs::write(
        &script,
        "0 wait_gi\n4 screenshot a.png\n4 set_intensity 0 4000\n4 screenshot b.png\n12 screenshot c.png\n12 quit\n",
    )
    .unwrap();
    let out = Command::new("xvfb-run")
        .args(["-a", env!("CARGO_BIN_EXE_linkgi"), "view", "cornell", "--rays", "64", "--size", &format!("{W}x{H}")])
        .arg("--script")
        .arg(&script)
        .arg("--screenshot-dir")
        .arg(&shots)
        .output()
        .expect("run linkgi view");
    let stderr = String::from_utf8_lossy(&out.stderr);
    assert!(out.status.success(), "linkgi view failed: {stderr}");
    let mean = |i: &image::RgbImage| i.as_raw().iter().map(|&v| v as f64).sum::<f64>() / i.as_raw().len() as f64;
    let (a, b, c) = (load(&shots.join("a.png")), load(&shots.join("b.png")), load(&shots.join("c.png")));
    let (ma, mb, mc) = (mean(&a), mean(&b), mean(&c));
    eprintln!("means: first {ma:.1}, light x1000 at once {mb:.1}, seconds later {mc:.1}");
    assert!(ma > 40.0 && ma < 200.0, "the first picture is not exposed: mean {ma:.1}");
    assert!(mb > ma + 50.0, "the exposure did not hold while the light changed: {ma:.1} -> {mb:.1}");
    assert!((mc - ma).abs() < 25.0, "the exposure did not adapt back: {ma:.1} then {mc:.1}");
}

#[test]
fn bad_script_names_file_and_line() {
    let dir = Path::new(env!("CARGO_TARGET_TMPDIR")).join("view_bad_script");
    std::fs::create_dir_all(&dir).unwrap();
    let script = dir.join("bad.txt");
    std::fs::write(&script, "0 wait_gi\n1 teleport 3\n").unwrap();
    // Parsing happens before any window is opened, so this needs no display.
    let out = Command::new(env!("CARGO_BIN_EXE_linkgi"))
        .args(["view", "cornell", "--script"])
        .arg(&script)
        .output()
        .expect("run linkgi");
    assert!(!out.status.success());
    let err = String::from_utf8_lossy(&out.stderr);
    assert!(err.contains("bad.txt:2") && err.contains("teleport"), "{err}");
}

/// `gi:` lines the viewer prints after each `wait_gi`: (version, links, rays, light 0 position, intensity).
fn gi_lines(stdout: &str) -> Vec<(u64, u64, u32, glam::Vec3, f32)> {
    stdout
        .lines()
        .filter_map(|l| l.strip_prefix("gi: "))
        .map(|l| {
            let w: Vec<&str> = l.split([' ', ',']).filter(|s| !s.is_empty()).collect();
            let at = |key: &str| w.iter().position(|s| *s == key).unwrap_or_else(|| panic!("no {key} in gi line {l}"));
            let num = |i: usize| -> f32 { w[i].parse().unwrap_or_else(|_| panic!("gi line {l}: '{}'", w[i])) };
            let p = at("point");
            (
                w[at("version") + 1].parse().unwrap(),
                w[at("links") + 1].parse().unwrap(),
                w[at("rays") + 1].parse().unwrap(),
                glam::Vec3::new(num(p + 1), num(p + 2), num(p + 3)),
                num(at("intensity") + 1),
            )
        })
        .collect()
}

/// Real window-system input: under Xvfb, `xdotool` drags a light in the Cornell box by
/// its on-screen ring and orbits the camera with the mouse, between steps of
/// a script; the panel's intensity and rays controls run through their
/// script twins. Checks: the panel is drawn (window shot against scene
/// shot), the light lands where the cursor ray meets the plane at its
/// height, orbiting changes the view but not the light, doubling the
/// intensity brightens the picture and the GI, and fewer rays give fewer links.
#[test]
fn mouse_drags_light_and_orbits_panel_shows() {
    if !tools_present("mouse_drags_light_and_orbits_panel_shows", &["xvfb-run", "xdotool"]) {
        return;
    }
    const MW: u32 = 640;
    const MH: u32 = 480;
    let dir = fresh_dir("view_mouse");

    // Cornell's geometry with a camera that looks up at the light, which hangs off-centre.
    let scenes = Path::new(env!("CARGO_MANIFEST_DIR")).join("scenes");
    let toml = dir.join("lamp.toml");
    let mut text = String::from(
        "[settings]\nrays_per_vertex = 64\n[camera]\nposition = [0.0, 1.0, 0.95]\ntarget = [0.0, 1.5, -0.5]\n\
         fov_deg = 80.0\n[[light]]\nkind = \"point\"\nposition = [0.35, 1.8, -0.1]\nintensity = [4.0, 4.0, 4.0]\n",
    );
    for obj in ["cornell_0.obj", "cornell_1.obj"] {
        text += &format!("[[mesh]]\nobj = {:?}\n", scenes.join(obj).display().to_string());
    }
    std::fs::write(&toml, text).unwrap();
    let desc = linkgi::scene::load(toml.to_str().unwrap()).unwrap();
    let scene = linkgi::scene::prep::prepare(&desc).unwrap();
    let (light, intensity) = match scene.lights[0] {
        linkgi::scene::Light::Point { position, intensity } => (position, intensity.max_element()),
        _ => panic!("the first light is not a point light"),
    };
    let camera = desc.camera.expect("the scene file has a camera");
    let extent = linkgi::render::Frame::of(&scene, &scene.positions, camera).extent();
    let (view, proj) = linkgi::render::camera_matrices(&camera, MW as f32 / MH as f32, extent * 4.0);
    let clip = proj * view * light.extend(1.0);
    let ndc = clip.truncate() / clip.w;
    let (lx, ly) = ((ndc.x + 1.0) * 0.5 * MW as f32, (1.0 - ndc.y) * 0.5 * MH as f32);
    assert!(clip.w > 0.0 && lx > 0.0 && ly > 0.0 && lx < MW as f32 && ly < MH as f32, "light off screen: {lx} {ly}");
    let (x0, y0) = (lx.round() as i32, ly.round() as i32);
    let (x1, y1) = (x0 + 60, y0 + 20);
    // Expected drop point: the ray through the final cursor pixel meets y = light.y.
    let ray = linkgi::render::pixel_ray(&camera, MW, MH, extent, x1 as u32, y1 as u32);
    let expected = ray.origin + ray.dir * ((light.y - ray.origin.y) / ray.dir.y);

    let script = dir.join("script.txt");
    std::fs::write(
        &script,
        format!(
            "0 wait_gi\n0 screenshot a.png\n0 window_shot aw.png\n0 wait_file dragged\n0 wait_gi\n0 screenshot b.png\n\
             0 wait_file orbited\n0 screenshot c.png\n0 set_intensity 0 {}\n0 wait_gi\n0 screenshot d.png\n\
             0 set_rays 16\n0 wait_gi\n0 quit\n",
            2.0 * intensity
        ),
    )
    .unwrap();
    let d = dir.display();
    let driver = format!(
        r#"set -u
"$BIN" view "{toml}" --exposure 0.6 --size {MW}x{MH} --script "{script}" --screenshot-dir "{d}" >"{d}/stdout.txt" 2>"{d}/stderr.txt" &
pid=$!
wait_for() {{
  i=0
  while [ ! -e "$1" ]; do
    if ! kill -0 $pid 2>/dev/null; then echo "viewer exited before $1" >&2; exit 1; fi
    i=$((i+1)); if [ $i -gt 3000 ]; then echo "timeout waiting for $1" >&2; kill $pid; exit 1; fi
    sleep 0.1
  done
}}
wait_for "{d}/aw.png"
w=$(xdotool search --sync --name '^linkgi' | head -n 1)
xdotool mousemove --window $w {x0} {y0} sleep 0.3 mousedown 1 sleep 0.3 \
  mousemove --window $w {xm} {ym} sleep 0.3 mousemove --window $w {x1} {y1} sleep 0.3 mouseup 1 sleep 0.3
touch "{d}/dragged"
wait_for "{d}/b.png"
xdotool mousemove --window $w 560 420 sleep 0.3 mousedown 1 sleep 0.3 \
  mousemove --window $w 590 420 sleep 0.3 mousemove --window $w 620 430 sleep 0.3 mouseup 1 sleep 0.3
touch "{d}/orbited"
wait $pid
"#,
        script = script.display(),
        toml = toml.display(),
        xm = (x0 + x1) / 2,
        ym = (y0 + y1) / 2,
    );
    let mut child = Command::new("xvfb-run")
        .args(["-a", "sh", "-c", &driver])
        .env("BIN", env!("CARGO_BIN_EXE_linkgi"))
        .stdout(Stdio::piped())
        .stderr(Stdio::piped())
        .spawn()
        .expect("start xvfb-run");
    let start = Instant::now();
    let status = loop {
        if let Some(s) = child.try_wait().unwrap() {
            break s;
        }
        if start.elapsed() > Duration::from_secs(400) {
            let _ = child.kill();
            panic!("the mouse test did not finish within 400 s");
        }
        std::thread::sleep(Duration::from_millis(50));
    };
    let out = child.wait_with_output().unwrap();
    let stdout = std::fs::read_to_string(dir.join("stdout.txt")).unwrap_or_default();
    let stderr = std::fs::read_to_string(dir.join("stderr.txt")).unwrap_or_default();
    eprintln!(
        "driver stderr:\n{}\nviewer stdout:\n{stdout}\nviewer stderr:\n{stderr}",
        String::from_utf8_lossy(&out.stderr)
    );
    assert!(status.success(), "viewer or driver failed: {status}");

    let load = |name: &str| {
        let img = image::open(dir.join(name)).unwrap_or_else(|e| panic!("{name}: {e}")).to_rgb8();
        assert_eq!((img.width(), img.height()), (MW, MH), "{name} has the wrong size");
        img
    };
    let (a, aw, b, c, dd) = (load("a.png"), load("aw.png"), load("b.png"), load("c.png"), load("d.png"));

    // The panel: where the window shot differs from the scene shot, but for the light's ring.
    let near_ring = |x: u32, y: u32| (x as f32 - lx).abs() < 14.0 && (y as f32 - ly).abs() < 14.0;
    let ring_diff: u32 = (0..28 * 28)
        .map(|i| {
            (
                (lx as i32 - 14 + i % 28).clamp(0, MW as i32 - 1) as u32,
                (ly as i32 - 14 + i / 28).clamp(0, MH as i32 - 1) as u32,
            )
        })
        .map(|(x, y)| (0..3).map(|k| aw.get_pixel(x, y)[k].abs_diff(a.get_pixel(x, y)[k]) as u32).sum::<u32>())
        .sum();
    assert!(ring_diff > 28 * 28 * 10, "no marker ring over the light at ({lx}, {ly})");
    let (mut x_max, mut y_max, mut n) = (0u32, 0u32, 0usize);
    for (x, y, p) in aw.enumerate_pixels() {
        let q = a.get_pixel(x, y);
        if !near_ring(x, y) && (0..3).map(|k| p[k].abs_diff(q[k]) as u32).sum::<u32>() > 30 {
            x_max = x_max.max(x);
            y_max = y_max.max(y);
            n += 1;
        }
    }
    eprintln!("panel: {n} pixels within x <= {x_max}, y <= {y_max}");
    assert!(n > (MW * MH / 50) as usize, "no panel drawn over the scene ({n} pixels differ)");
    assert!(x_max < MW * 3 / 4 && y_max < MH * 3 / 4, "the panel spreads over the window ({x_max}, {y_max})");
    assert!(!(lx as u32 <= x_max && ly as u32 <= y_max), "the light's ring ({lx}, {ly}) lies under the panel");
    // Outside the panel's box (and the light's ring) the two shots agree.
    let mut outside = (0u64, 0u64);
    for (x, y, p) in aw.enumerate_pixels() {
        if (x > x_max + 2 || y > y_max + 2) && !near_ring(x, y) {
            let q = a.get_pixel(x, y);
            outside.0 += (0..3).map(|k| p[k].abs_diff(q[k]) as u64).sum::<u64>();
            outside.1 += 3;
        }
    }
    let outside = outside.0 as f64 / outside.1 as f64;
    assert!(outside < 0.5, "window shot and scene shot differ outside the panel: {outside:.3}");

    let gi = gi_lines(&stdout);
    assert_eq!(gi.len(), 4, "expected four gi lines, got {gi:?}");
    // The drag put the light where the cursor ray meets its height.
    let (before, after) = (gi[0].3, gi[1].3);
    assert!((before - light).length() < 1e-5, "first GI had the light at {before}, scene {light}");
    assert_eq!(after.y, light.y, "a mouse drag must keep the light's height");
    let miss = (after - expected).length();
    eprintln!("light dragged to {after}, cursor ray says {expected} (miss {miss:.4} m)");
    assert!(miss < 0.01 * extent, "light at {after}, expected {expected} (miss {miss} m)");
    assert!((after - before).length() > 0.05 * extent, "the drag barely moved the light");
    assert!(mean_abs_diff(&a, &b) > 3.0, "moving the light barely changed the picture");
    // Orbiting moved the camera, not the light.
    assert!(mean_abs_diff(&b, &c) > 5.0, "the mouse orbit did not change the view");
    assert_eq!(gi[2].3, after, "orbiting moved the light");
    // Doubled intensity: twice the light in the result, a brighter picture.
    assert!((gi[2].4 / (2.0 * intensity) - 1.0).abs() < 1e-5, "intensity {} != 2 x {intensity}", gi[2].4);
    let mean = |i: &image::RgbImage| i.as_raw().iter().map(|&v| v as f64).sum::<f64>() / i.as_raw().len() as f64;
    assert!(mean(&dd) > 1.15 * mean(&c), "doubling the light: mean {} -> {}", mean(&c), mean(&dd));
    // 16 rays per vertex instead of 64: a new link set, with fewer links.
    assert_eq!((gi[0].2, gi[3].2), (64, 16));
    assert!(gi[3].1 < gi[2].1, "links {} at 16 rays, {} at 64", gi[3].1, gi[2].1);
    assert!(gi.windows(2).all(|w| w[1].0 > w[0].0), "GI versions must grow: {gi:?}");
}

/// While the torso deforms every frame the engine is never idle; `wait_gi`
/// still finishes once a result that includes every change sent before it
/// has been drawn. Two waits 1 s apart give newer GI for a moved mesh.
#[test]
fn wait_gi_catches_up_while_deforming() {
    if !tools_present("wait_gi_catches_up_while_deforming", &["xvfb-run"]) {
        return;
    }
    let dir = fresh_dir("view_deform");
    let script = dir.join("script.txt");
    // Three seconds between the shots: the animation clock advances at
    // most 0.1 s a frame, and under load (the other view tests running
    // beside it) frames take over 100 ms, so 1.5 s of wall time once moved
    // the torso too little to see.
    std::fs::write(&script, "0 deform on\n0.5 wait_gi\n0 screenshot a.png\n3 wait_gi\n0 screenshot b.png\n0 quit\n")
        .unwrap();
    let out = Command::new("timeout")
        .arg("400")
        .args([
            "xvfb-run",
            "-a",
            env!("CARGO_BIN_EXE_linkgi"),
            "view",
            "torso",
            "--exposure",
            "0.6",
            "--rays",
            "16",
            "--size",
            "160x120",
        ])
        .arg("--script")
        .arg(&script)
        .arg("--screenshot-dir")
        .arg(&dir)
        .output()
        .expect("run xvfb-run");
    let stdout = String::from_utf8_lossy(&out.stdout);
    eprintln!("stdout:\n{stdout}\nstderr:\n{}", String::from_utf8_lossy(&out.stderr));
    assert!(out.status.success(), "linkgi view failed: {}", out.status);
    let versions: Vec<u64> = stdout
        .lines()
        .filter_map(|l| l.strip_prefix("gi: version "))
        .map(|l| l.split(',').next().unwrap().parse().unwrap())
        .collect();
    assert_eq!(versions.len(), 2, "{stdout}");
    assert!(versions[1] > versions[0] && versions[0] > 1, "GI versions {versions:?}: no update for the deformed mesh");
    let (a, b) = (load(&dir.join("a.png")), load(&dir.join("b.png")));
    let diff = mean_abs_diff(&a, &b);
    assert!(diff > 1.0, "the deforming torso did not change between the shots (mean difference {diff})");
}

/// A coarse box room (one quad a wall, a block on the floor), as OBJ
/// text: every face turned towards the room's inside or the block's outside.
fn coarse_room_obj() -> String {
    let mut v: Vec<[f32; 3]> = Vec::new();
    let mut f = String::new();
    let mut quad = |c: [[f32; 3]; 4], towards: [f32; 3], away: bool| {
        let sub = |a: [f32; 3], b: [f32; 3]| [a[0] - b[0], a[1] - b[1], a[2] - b[2]];
        let (e1, e2) = (sub(c[1], c[0]), sub(c[2], c[0]));
        let n = [e1[1] * e2[2] - e1[2] * e2[1], e1[2] * e2[0] - e1[0] * e2[2], e1[0] * e2[1] - e1[1] * e2[0]];
        let t = sub(towards, c[0]);
        let facing = n[0] * t[0] + n[1] * t[1] + n[2] * t[2] > 0.0;
        let base = v.len() + 1;
        v.extend(c);
        let (a, b, cc, d) = (base, base + 1, base + 2, base + 3);
        if facing != away {
            f += &format!("f {a} {b} {cc}\nf {a} {cc} {d}\n");
        } else {
            f += &format!("f {a} {cc} {b}\nf {a} {d} {cc}\n");
        }
    };
    let boxed = |lo: [f32; 3],
                 hi: [f32; 3],
                 quad: &mut dyn FnMut([[f32; 3]; 4], [f32; 3], bool),
                 inside: bool,
                 bottom: bool| {
        let mid = [(lo[0] + hi[0]) / 2.0, (lo[1] + hi[1]) / 2.0, (lo[2] + hi[2]) / 2.0];
        for axis in 0..3 {
            for side in [lo[axis], hi[axis]] {
                if axis == 1 && side == lo[1] && !bottom {
                    continue;
                }
                let (u, w) = ((axis + 1) % 3, (axis + 2) % 3);
                let corner = |a: f32, b: f32| {
                    let mut p = [0.0; 3];
                    p[axis] = side;
                    p[u] = a;
                    p[w] = b;
                    p
                };
                let c = [corner(lo[u], lo[w]), corner(hi[u], lo[w]), corner(hi[u], hi[w]), corner(lo[u], hi[w])];
                quad(c, mid, !inside);
            }
        }
    };
    boxed([-1.0, 0.0, -1.0], [1.0, 2.0, 1.0], &mut quad, true, true);
    boxed([-0.5, 0.0, -0.4], [0.1, 0.7, 0.2], &mut quad, false, false);
    let mut out = String::new();
    for p in &v {
        out += &format!("v {} {} {}\n", p[0], p[1], p[2]);
    }
    out + &f
}

/// A scene with coarse meshes refines in the viewer's background: the
/// a-priori mesh's GI is shown first, each round as it lands, and after
/// `wait_gi` the window shows the refined mesh's solution, the same picture
/// `linkgi render` makes of the scene (same rasterizer and exposure).
#[test]
fn the_viewer_refines_in_the_background_to_what_render_shows() {
    if !tools_present("the_viewer_refines_in_the_background_to_what_render_shows", &["xvfb-run"]) {
        return;
    }
    let dir = fresh_dir("view_refine");
    std::fs::write(dir.join("room.obj"), coarse_room_obj()).unwrap();
    std::fs::write(
        dir.join("room.toml"),
        "[camera]\nposition = [0, 1, 3.4]\ntarget = [0, 1, 0]\nfov_deg = 45\n\
         [settings]\nrays_per_vertex = 64\n\
         [[mesh]]\nobj = \"room.obj\"\n\
         [[light]]\nkind = \"point\"\nposition = [0.3, 1.7, 0.2]\nintensity = [3, 3, 3]\n",
    )
    .unwrap();
    let script = dir.join("script.txt");
    std::fs::write(&script, "0 wait_gi\n0 screenshot v.png\n0 quit\n").unwrap();
    let size = format!("{W}x{H}");
    let out = Command::new("timeout")
        .arg("400")
        .args(["xvfb-run", "-a", env!("CARGO_BIN_EXE_linkgi"), "view"])
        .arg(dir.join("room.toml"))
        .args(["--exposure", "0.6", "--size", &size, "--script"])
        .arg(&script)
        .arg("--screenshot-dir")
        .arg(&dir)
        .output()
        .expect("run xvfb-run");
    let (stdout, stderr) = (String::from_utf8_lossy(&out.stdout), String::from_utf8_lossy(&out.stderr));
    eprintln!("stdout:\n{stdout}\nstderr:\n{stderr}");
    assert!(out.status.success(), "linkgi view failed: {}", out.status);
    assert!(stderr.contains("refined: "), "no refinement landed");
    let version: u64 = stdout
        .lines()
        .find_map(|l| l.strip_prefix("gi: version "))
        .and_then(|l| l.split(',').next())
        .and_then(|v| v.parse().ok())
        .expect("a gi line");
    assert!(version >= 2, "the a-priori mesh's result, then the refined one's: version {version}");
    let rendered = dir.join("r.png");
    let r = Command::new(env!("CARGO_BIN_EXE_linkgi"))
        .arg("render")
        .arg(dir.join("room.toml"))
        .args(["--exposure", "0.6", "--size", &size, "--out"])
        .arg(&rendered)
        .output()
        .expect("run linkgi render");
    assert!(r.status.success(), "render failed: {}", String::from_utf8_lossy(&r.stderr));
    let (v, rr) = (load(&dir.join("v.png")), load(&rendered));
    let diff = mean_abs_diff(&v, &rr);
    eprintln!("view against render: mean abs diff {diff:.3}");
    assert!(diff < 1.0, "the refined view differs from render's picture by {diff:.2} a channel");
}
