//! Rendered images of the Cornell box, checked against the scene's
//! geometry: each pixel is classified with a primary ray through the
//! kd-tree (floor near the red wall, near the green wall, in the light's
//! shadow or lit), then the rendered radiance of those sets is compared.
//! GPU tests run on any adapter (lavapipe in CI); with no adapter they fail
//! when `CI` is set and skip with a message otherwise. The CPU fallback is
//! tested everywhere and must agree with the GPU image.

use glam::Vec3;
use linkgi::gpu::{self, GpuDevice};
use linkgi::kdtree::{KdBuildParams, KdTree};
use linkgi::render::{self, cpu::render_cpu, gpu::GpuRenderer, Frame, HdrImage, RenderParams, View};
use linkgi::scene::{builtin, prep, Light};
use linkgi::solver::{Solution, SolveParams, Solver};
use linkgi::trace::ray::Ray;
use linkgi::trace::CpuTracer;
use std::sync::{Arc, OnceLock};

const W: u32 = 160;
const H: u32 = 120;

fn device() -> Option<Arc<GpuDevice>> {
    static DEV: OnceLock<Option<Arc<GpuDevice>>> = OnceLock::new();
    DEV.get_or_init(|| {
        let d = gpu::open_all().into_iter().next();
        match &d {
            Some(d) => eprintln!("render tests on {}", d.describe()),
            None if std::env::var_os("CI").is_some() => {
                panic!("no graphics adapter in CI: install mesa-vulkan-drivers (lavapipe)")
            }
            None => eprintln!("SKIPPED: no graphics adapter (install mesa-vulkan-drivers for lavapipe)"),
        }
        d
    })
    .clone()
}

struct Cornell {
    solver: Solver,
    sol: Solution,
    camera: linkgi::scene::Camera,
}

fn cornell() -> &'static Cornell {
    static C: OnceLock<Cornell> = OnceLock::new();
    C.get_or_init(|| {
        let mut desc = builtin::builtin("cornell").unwrap();
        desc.settings.rays_per_vertex = 64;
        let scene = prep::prepare(&desc).unwrap();
        let solver = Solver::new(scene, SolveParams::from_settings(&desc.settings), &|_, _| {}).unwrap();
        let sol = solver.solve();
        // Higher and steeper than the scene's camera, so the floor beside both walls is in view.
        let camera = linkgi::scene::Camera {
            position: Vec3::new(0.0, 1.75, 0.95),
            target: Vec3::new(0.0, 0.0, -0.25),
            fov_deg: 80.0,
        };
        Cornell { solver, sol, camera }
    })
}

fn params(view: View) -> RenderParams {
    RenderParams { width: W, height: H, view, shadow_size: 512, ..Default::default() }
}

#[derive(Clone, Copy, PartialEq)]
enum Class {
    FloorRed,
    FloorGreen,
    FloorShadow,
    FloorLit,
    Other,
}

/// Classifies each pixel by what its primary ray meets.
fn classify(c: &Cornell) -> Vec<Vec<Class>> {
    let s = &c.solver.scene();
    let kd = &c.solver.accel();
    let frame = Frame::of(s, &c.sol.e_indirect, c.camera);
    let extent = frame.extent();
    let Light::Point { position: light, .. } = s.lights[0] else { panic!() };
    let mut out = Vec::new();
    for y in 0..H {
        let mut row = Vec::new();
        for x in 0..W {
            let ray = render::pixel_ray(&c.camera, W, H, extent, x, y);
            let class = match kd.intersect(&ray) {
                Some(hit) if hit.front => {
                    let p = ray.origin + ray.dir * hit.t;
                    if p.y.abs() > 1e-3 {
                        Class::Other
                    } else {
                        // Shadow: the light is blocked from this floor point and from points 3 cm around it.
                        let blocked = |q: Vec3| {
                            let o = q + Vec3::Y * 1e-3;
                            let d = light - o;
                            kd.occluded(&Ray { tmax: d.length() * 0.999, ..Ray::new(o, d.normalize()) })
                        };
                        let around = [Vec3::ZERO, Vec3::X * 0.03, -Vec3::X * 0.03, Vec3::Z * 0.03, -Vec3::Z * 0.03];
                        let n_blocked = around.iter().filter(|&&o| blocked(p + o)).count();
                        if n_blocked == around.len() {
                            Class::FloorShadow
                        } else if p.x < -0.55 && n_blocked == 0 {
                            Class::FloorRed
                        } else if p.x > 0.55 && n_blocked == 0 {
                            Class::FloorGreen
                        } else if n_blocked == 0 {
                            Class::FloorLit
                        } else {
                            Class::Other
                        }
                    }
                }
                _ => Class::Other,
            };
            row.push(class);
        }
        out.push(row);
    }
    out
}

fn classes() -> &'static Vec<Vec<Class>> {
    static C: OnceLock<Vec<Vec<Class>>> = OnceLock::new();
    C.get_or_init(|| classify(cornell()))
}

fn mean_of(img: &HdrImage, class: Class) -> (Vec3, usize) {
    let cl = classes();
    let mut sum = Vec3::ZERO;
    let mut n = 0;
    for y in 0..H {
        for x in 0..W {
            if cl[y as usize][x as usize] == class {
                sum += img.at(x, y);
                n += 1;
            }
        }
    }
    assert!(n >= 10, "only {n} pixels in class {}: the camera does not see enough floor", class as u32);
    (sum / n as f32, n)
}

/// Colour bleeding, the box's shadow, and indirect light inside the shadow.
fn check_image(name: &str, combined: &HdrImage, direct: &HdrImage, indirect: &HdrImage) {
    // Red channel relative to green on the floor: higher near the red (left) wall.
    let (red_side, _) = mean_of(indirect, Class::FloorRed);
    let (green_side, _) = mean_of(indirect, Class::FloorGreen);
    let ratio = |v: Vec3| v.x / v.y.max(1e-6);
    assert!(
        ratio(red_side) > 1.1 * ratio(green_side),
        "{name}: no red bleeding: r/g near the red wall {red_side}, near the green wall {green_side}"
    );
    assert!(red_side.x > green_side.x, "{name}: red channel near the red wall {red_side} vs {green_side}");
    // The shadow is darker than the open floor.
    let (shadow, ns) = mean_of(combined, Class::FloorShadow);
    let (lit, nl) = mean_of(combined, Class::FloorLit);
    assert!(shadow.element_sum() < 0.6 * lit.element_sum(), "{name}: shadow {shadow} ({ns} px) vs lit {lit} ({nl} px)");
    let (shadow_direct, _) = mean_of(direct, Class::FloorShadow);
    let (lit_direct, _) = mean_of(direct, Class::FloorLit);
    assert!(
        shadow_direct.element_sum() < 0.1 * lit_direct.element_sum(),
        "{name}: direct light in the shadow {shadow_direct} vs lit {lit_direct}"
    );
    // Indirect light reaches into the shadow.
    let (shadow_indirect, _) = mean_of(indirect, Class::FloorShadow);
    assert!(shadow_indirect.min_element() > 0.005, "{name}: indirect view is dark in the shadow: {shadow_indirect}");
    assert!(shadow.element_sum() > 0.5 * shadow_indirect.element_sum(), "{name}: combined lost the indirect light");
}

fn render_views(f: impl Fn(View) -> HdrImage) -> (HdrImage, HdrImage, HdrImage) {
    (f(View::Combined), f(View::Direct), f(View::Indirect))
}

fn save(name: &str, img: &HdrImage) {
    let dir = std::path::Path::new(env!("CARGO_TARGET_TMPDIR")).join("render");
    render::write_png(img, 0.6, &dir.join(name)).unwrap();
}

#[test]
fn cpu_fallback_image() {
    let c = cornell();
    let frame = Frame::of(&c.solver.scene(), &c.sol.e_indirect, c.camera);
    let (comb, dir, ind) = render_views(|v| render_cpu(&frame, &params(v), Some(c.solver.accel())).unwrap().0);
    save("cornell-cpu.png", &comb);
    check_image("cpu", &comb, &dir, &ind);
}

#[test]
fn gpu_image_and_agreement_with_cpu() {
    let Some(dev) = device() else { return };
    let c = cornell();
    let r = GpuRenderer::new(dev).unwrap();
    let frame = Frame::of(&c.solver.scene(), &c.sol.e_indirect, c.camera);
    let (comb, dir, ind) = render_views(|v| r.render(&frame, &params(v)).unwrap().0);
    save("cornell-gpu.png", &comb);
    save("cornell-gpu-indirect.png", &ind);
    check_image("gpu", &comb, &dir, &ind);
    // CPU and GPU agree after tone mapping (shadow edges and PCF differ a little).
    let cpu = render_cpu(&frame, &params(View::Combined), Some(c.solver.accel())).unwrap().0;
    let (a, b) = (render::tone_map(&comb, 0.6), render::tone_map(&cpu, 0.6));
    let diff: f64 = a.as_raw().iter().zip(b.as_raw()).map(|(&x, &y)| (x as f64 - y as f64).abs()).sum::<f64>()
        / a.as_raw().len() as f64
        / 255.0;
    assert!(diff < 0.03, "mean abs difference GPU vs CPU {diff:.4}");
    // Indirect-only views agree more closely (no shadows involved).
    let cpu_ind = render_cpu(&frame, &params(View::Indirect), Some(c.solver.accel())).unwrap().0;
    let d: f32 = ind.pixels.iter().zip(&cpu_ind.pixels).map(|(a, b)| (*a - *b).abs().element_sum()).sum::<f32>()
        / ind.pixels.iter().map(|a| a.element_sum()).sum::<f32>();
    assert!(d < 0.05, "indirect views differ by {d:.4} relative");
}

#[test]
fn directional_lights_make_no_cube_shadow_maps() {
    let Some(dev) = device() else { return };
    let c = cornell();
    let r = GpuRenderer::new(dev).unwrap();
    let sun = [Light::Directional { direction: Vec3::new(0.3, -1.0, -0.2).normalize(), irradiance: Vec3::ONE }];
    let mut frame = Frame::of(&c.solver.scene(), &c.sol.e_indirect, c.camera);
    frame.lights = &sun;
    let (img, stats) = r.render(&frame, &params(View::Direct)).unwrap();
    save("cornell-sun.png", &img);
    assert_eq!((stats.cube_shadow_maps, stats.shadow_maps_2d, stats.shadow_layers), (0, 1, 1));
    // The room is closed: the sun lights nothing inside it (but for receivers
    // that lie exactly in a wall's plane, one-pixel lines along the corners,
    // where wall and receiver have the same shadow-map depth).
    let lit = img.pixels.iter().filter(|p| p.max_element() > 1e-3).count();
    assert!(lit * 100 < img.pixels.len(), "sunlight leaked into the closed room: {lit} pixels lit");
    // Point lights: one cube (six layers) each.
    let both = [c.solver.scene().lights[0], sun[0]];
    frame.lights = &both;
    let (_, stats) = r.render(&frame, &params(View::Direct)).unwrap();
    assert_eq!((stats.cube_shadow_maps, stats.shadow_maps_2d, stats.shadow_layers), (1, 1, 7));
}

#[test]
fn kd_tree_of_frame_matches_solver() {
    // The CPU renderer builds its own tree when none is given: same image.
    let c = cornell();
    let frame = Frame::of(&c.solver.scene(), &c.sol.e_indirect, c.camera);
    let p = RenderParams { width: 40, height: 30, ..params(View::Combined) };
    let own = render_cpu(&frame, &p, None).unwrap().0;
    let kd = KdTree::build(&c.solver.scene().positions, &c.solver.scene().triangles, &KdBuildParams::default());
    let given = render_cpu(&frame, &p, Some(&kd)).unwrap().0;
    assert_eq!(own, given);
    assert!(own.pixels.iter().any(|p| p.max_element() > 0.01), "the image is black");
}

/// `linkgi` with no arguments renders the built-in Cornell box through the
/// scene's own camera at the default exposure: the frame must hold the whole
/// box. The top rows' middle half shows the ceiling (primary rays meet y = 2,
/// white) with the light's hot spot, the light projects inside the frame, the
/// left and right edges are the red and green walls, the boxes' shadows on
/// the room (2.5 % of the frame at least) and lit floor are in view, and little of the image is clipped.
/// (The old camera, steeply down from 1.3 m, failed the ceiling and light checks.)
#[test]
fn default_camera_frames_the_whole_box() {
    let c = cornell();
    let camera = builtin::builtin("cornell").unwrap().camera.unwrap();
    let (w, h) = (80, 60);
    let frame = Frame::of(&c.solver.scene(), &c.sol.e_indirect, camera);
    let p = RenderParams { width: w, height: h, ..params(View::Combined) };
    let img = render_cpu(&frame, &p, Some(c.solver.accel())).unwrap().0;
    save("cornell-default-camera.png", &img);
    let ldr = render::tone_map(&img, RenderParams::default().exposure);
    let rgb = |x: u32, y: u32| ldr.get_pixel(x, y).0.map(|v| v as f32);
    let extent = frame.extent();
    let accel = &c.solver.accel();
    let Light::Point { position: light, .. } = c.solver.scene().lights[0] else { panic!() };
    let hit = |x: u32, y: u32| {
        let ray = render::pixel_ray(&camera, w, h, extent, x, y);
        accel.intersect(&ray).map(|hit| ray.origin + ray.dir * hit.t).expect("every primary ray meets the closed room")
    };

    for y in 0..h / 8 {
        for x in w / 4..3 * w / 4 {
            let p = hit(x, y);
            assert!(p.y > 1.99, "pixel ({x}, {y}) of the top rows shows {p}, not the ceiling");
            let [r, g, b] = rgb(x, y);
            // White, tinted a little by the coloured walls.
            let (lo, hi) = (r.min(g).min(b), r.max(g).max(b));
            assert!(hi > 100.0 && lo > 0.75 * hi, "ceiling pixel ({x}, {y}) not white: {r} {g} {b}");
        }
    }
    let top = (0..h / 8).flat_map(|y| (0..w).map(move |x| (x, y)));
    let hot = top.map(|(x, y)| img.at(x, y).min_element()).fold(0.0, f32::max);
    assert!(hot > 5.0, "no bright ceiling over the light in the top rows (max radiance {hot})");
    let (view, proj) = render::camera_matrices(&camera, w as f32 / h as f32, extent * 4.0);
    let ndc = proj.project_point3(view.transform_point3(light));
    assert!(ndc.x.abs() < 0.95 && ndc.y.abs() < 0.95 && (0.0..1.0).contains(&ndc.z), "light off screen: {ndc}");

    for y in h / 4..3 * h / 4 {
        let [r, g, b] = rgb(0, y);
        assert!(r > 2.0 * g && r > 2.0 * b, "left edge row {y} not red: {r} {g} {b}");
        let [r, g, b] = rgb(w - 1, y);
        assert!(g > 1.4 * r && g > 1.4 * b, "right edge row {y} not green: {r} {g} {b}");
    }

    // Room surfaces (floor and walls) in the boxes' shadow, and lit.
    let (mut shadow, mut lit) = (Vec::new(), Vec::new());
    for y in 0..h {
        for x in 0..w {
            let p = hit(x, y);
            let inward = if p.y < 1e-3 {
                Vec3::Y
            } else if p.x.abs() > 0.999 {
                -Vec3::X * p.x.signum()
            } else if p.z < -0.999 {
                Vec3::Z
            } else {
                continue;
            };
            let o = p + inward * 1e-3;
            let d = light - o;
            let blocked = accel.occluded(&Ray { tmax: d.length() * 0.999, ..Ray::new(o, d.normalize()) });
            let luma = rgb(x, y).iter().sum::<f32>();
            if blocked {
                shadow.push(luma)
            } else if p.y < 1e-3 {
                lit.push(luma)
            }
        }
    }
    let n = (w * h) as usize;
    assert!(
        shadow.len() * 40 > n && lit.len() * 50 > n,
        "{} px in shadow, {} lit floor of {n}",
        shadow.len(),
        lit.len()
    );
    let mean = |v: &[f32]| v.iter().sum::<f32>() / v.len() as f32;
    assert!(mean(&shadow) < 0.7 * mean(&lit), "shadow {} vs lit floor {}", mean(&shadow), mean(&lit));

    let clipped = ldr.pixels().filter(|p| p.0.iter().all(|&v| v == 255)).count();
    let mean_luma = ldr.as_raw().iter().map(|&v| v as f32).sum::<f32>() / ldr.as_raw().len() as f32;
    eprintln!(
        "default camera: hot spot {hot:.1}, {} px shadow, {} px lit floor, {clipped} clipped, mean {mean_luma:.0}",
        shadow.len(),
        lit.len()
    );
    assert!(clipped * 20 < n, "{clipped} of {n} pixels clipped white");
    assert!((60.0..200.0).contains(&mean_luma), "mean 8-bit value {mean_luma}: too dark or too bright");
}

#[test]
fn exr_holds_linear_radiance() {
    let img = HdrImage {
        width: 3,
        height: 2,
        pixels: (0..6).map(|i| Vec3::new(i as f32 + 0.25, 10.0 + i as f32, 1e4 * (1 + i) as f32)).collect(),
    };
    let path = std::path::Path::new(env!("CARGO_TARGET_TMPDIR")).join("exr/radiance.exr");
    let _ = std::fs::remove_file(&path);
    render::write_exr(&img, &path).unwrap();
    // Read back with the exr crate: same size, the same f32 radiance in every pixel, rows top to bottom.
    let read = exr::prelude::read_first_rgba_layer_from_file(
        &path,
        |size, _| HdrImage { width: size.0 as u32, height: size.1 as u32, pixels: vec![Vec3::NAN; size.0 * size.1] },
        |out: &mut HdrImage, pos, (r, g, b, _a): (f32, f32, f32, f32)| {
            out.pixels[pos.1 * out.width as usize + pos.0] = Vec3::new(r, g, b)
        },
    )
    .unwrap();
    assert_eq!(read.layer_data.channel_data.pixels, img);
    let e = render::write_exr(&img, std::path::Path::new("/proc/no/such/dir/x.exr")).unwrap_err().to_string();
    assert!(e.contains("/proc/no/such/dir"), "{e}");
}

#[test]
fn bad_frames_are_errors() {
    let c = cornell();
    let mut frame = Frame::of(&c.solver.scene(), &c.sol.e_indirect, c.camera);
    let many = vec![c.solver.scene().lights[0]; 9];
    frame.lights = &many;
    let p = RenderParams { width: 8, height: 6, ..params(View::Combined) };
    let e = render_cpu(&frame, &p, None).unwrap_err().to_string();
    assert!(e.contains("9 lights") && e.contains("at most 8"), "{e}");
    let short = vec![Vec3::ZERO; 5];
    let mut frame = Frame::of(&c.solver.scene(), &short, c.camera);
    frame.lights = &c.solver.scene().lights;
    let e = render_cpu(&frame, &p, None).unwrap_err().to_string();
    assert!(e.contains("5 indirect"), "{e}");
    if let Some(dev) = device() {
        let r = GpuRenderer::new(dev).unwrap();
        assert!(r.render(&frame, &p).unwrap_err().to_string().contains("5 indirect"));
    }
}

/// The display pass (`tonemap.wgsl`, used by the viewer's window) agrees with
/// the CPU tone map of the read-back image, for a linear target (the shader
/// applies the sRGB curve) and an sRGB one (the hardware does), and calls the
/// overlay once per target.
#[test]
fn gpu_display_pass_matches_cpu_tone_map() {
    let Some(dev) = device() else { return };
    let c = cornell();
    let r = GpuRenderer::new(dev.clone()).unwrap();
    let frame = Frame::of(&c.solver.scene(), &c.sol.e_indirect, c.camera);
    for exposure in [0.6f32, 4.0] {
        let p = RenderParams { exposure, ..params(View::Combined) };
        let cpu = render::tone_map(&r.render(&frame, &p).unwrap().0, exposure);
        for format in [wgpu::TextureFormat::Rgba8Unorm, wgpu::TextureFormat::Bgra8UnormSrgb] {
            let pass = render::present::ToneMapPass::new(&dev, format).unwrap();
            let tex = render::present::offscreen_target(&dev, W, H, format);
            let view = tex.create_view(&Default::default());
            let mut overlays = 0;
            r.present(&frame, &p, &pass, &[&view], |_, _, _| {
                overlays += 1;
                Ok(())
            })
            .unwrap();
            assert_eq!(overlays, 1);
            let gpu = render::present::read_back_rgb8(&dev, &tex).unwrap();
            let diffs: Vec<u8> = gpu.as_raw().iter().zip(cpu.as_raw()).map(|(&a, &b)| a.abs_diff(b)).collect();
            let max = *diffs.iter().max().unwrap();
            let mean = diffs.iter().map(|&d| d as f64).sum::<f64>() / diffs.len() as f64;
            assert!(max <= 2 && mean < 0.2, "{format:?} exposure {exposure}: max diff {max}, mean {mean:.3}");
            // Not a black image: the lit scene shows.
            assert!(gpu.as_raw().iter().map(|&v| v as u64).sum::<u64>() > 40 * gpu.as_raw().len() as u64);
        }
    }
}

/// Shadow maps are reused while only the camera, the view or the indirect
/// light change, giving the same image as freshly drawn ones, and redrawn
/// when a light or the geometry moves.
#[test]
fn shadow_maps_are_reused_only_while_lights_and_geometry_stand_still() {
    let Some(dev) = device() else { return };
    let c = cornell();
    let fresh = GpuRenderer::new(dev.clone()).unwrap();
    let r = GpuRenderer::new(dev).unwrap();
    let frame = Frame::of(&c.solver.scene(), &c.sol.e_indirect, c.camera);
    let p = params(View::Combined);
    let (first, s1) = r.render(&frame, &p).unwrap();
    assert!(!s1.shadow_maps_reused);
    // Another camera and view, other indirect light: same shadow maps.
    let mut moved_cam = frame;
    moved_cam.camera.position += Vec3::new(0.2, -0.1, 0.0);
    let dim: Vec<Vec3> = c.sol.e_indirect.iter().map(|e| *e * 0.5).collect();
    moved_cam.e_indirect = &dim;
    let (reused, s2) = r.render(&moved_cam, &p).unwrap();
    assert!(s2.shadow_maps_reused);
    let (expect, s3) = fresh.render(&moved_cam, &p).unwrap();
    assert!(!s3.shadow_maps_reused);
    assert_eq!(reused, expect, "reused shadow maps gave another image");
    // A moved light or moved geometry redraws them.
    let light = [match c.solver.scene().lights[0] {
        Light::Point { position, intensity } => {
            Light::Point { position: position + Vec3::new(0.3, 0.0, 0.0), intensity }
        }
        l => l,
    }];
    let mut moved_light = frame;
    moved_light.lights = &light;
    let (other, s4) = r.render(&moved_light, &p).unwrap();
    assert!(!s4.shadow_maps_reused);
    assert_ne!(other, first);
    let shifted: Vec<Vec3> = c.solver.scene().positions.iter().map(|p| *p + Vec3::new(0.0, 1e-3, 0.0)).collect();
    let mut moved_geo = moved_light;
    moved_geo.positions = &shifted;
    assert!(!r.render(&moved_geo, &p).unwrap().1.shadow_maps_reused);
    assert!(r.render(&moved_geo, &p).unwrap().1.shadow_maps_reused);
}

/// Emitters are drawn with their radiance `M_e / pi`, the sky shows
/// through the window (its radiance along each pixel's ray on the CPU; the
/// GPU's sky pass samples a baked 512 x 256 map: within 5% there); without
/// emission and sky, `window` is black.
#[test]
fn window_draws_emitters_and_sky() {
    use linkgi::scene::builtin;
    let mut desc = builtin::builtin("window").unwrap();
    desc.settings.rays_per_vertex = 16;
    let scene = linkgi::scene::prep::prepare(&desc).unwrap();
    let solver = linkgi::solver::Solver::new(
        scene.clone(),
        linkgi::solver::SolveParams::from_settings(&scene.settings),
        &|_, _| {},
    )
    .unwrap();
    let sol = solver.solve();
    let camera = desc.camera.unwrap();
    let p = RenderParams { width: 96, height: 72, ..params(View::Combined) };
    let frame = Frame::of(&solver.scene(), &sol.e_indirect, camera).with_sky(&sol.e_sky);
    let (img, _) = render_cpu(&frame, &p, None).unwrap();
    let sky = solver.scene().sky.as_ref().unwrap();
    let extent = frame.extent();
    let sky_pixels: Vec<(usize, Vec3)> = (0..p.height)
        .flat_map(|y| (0..p.width).map(move |x| (x, y)))
        .filter_map(|(x, y)| {
            let ray = render::pixel_ray(&camera, p.width, p.height, extent, x, y);
            let i = (y * p.width + x) as usize;
            (img.pixels[i] == sky.radiance(ray.dir)).then_some((i, img.pixels[i]))
        })
        .collect();
    let brightest = img.pixels.iter().fold(0f32, |m, px| m.max(px.x));
    eprintln!("{} pixels show the sky; brightest red {brightest}", sky_pixels.len());
    assert!(sky_pixels.len() > 20, "the window shows no sky");
    if let Some(dev) = device() {
        let (gpu_img, _) = GpuRenderer::new(dev).unwrap().render(&frame, &p).unwrap();
        let close = sky_pixels
            .iter()
            .filter(|(i, l)| (gpu_img.pixels[*i] - *l).abs().max_element() <= 0.05 * l.max_element())
            .count();
        eprintln!("GPU sky within 5% at {close}/{} pixels", sky_pixels.len());
        assert!(close as f64 >= 0.9 * sky_pixels.len() as f64, "GPU sky pass: {close}/{}", sky_pixels.len());
    }
    assert!(brightest >= 30.0 / std::f32::consts::PI, "the glowing shade is not drawn with its radiance");
    let mut dark = solver.scene().clone();
    dark.emission.iter_mut().for_each(|e| *e = Vec3::ZERO);
    dark.sky = None;
    let zeros = vec![Vec3::ZERO; dark.vertex_count()];
    let (img, _) = render_cpu(&Frame::of(&dark, &zeros, camera), &p, None).unwrap();
    assert!(img.pixels.iter().all(|px| *px == Vec3::ZERO));
}

/// An image's size is its pixels': `HdrImage::new` refuses a buffer of
/// another length (the pixel lookup and the PNG and EXR writers index by
/// the size), and keeps one of the right length as given.
#[test]
fn hdr_images_hold_width_times_height_pixels() {
    let px: Vec<Vec3> = (0..6).map(|i| Vec3::splat(i as f32)).collect();
    assert!(HdrImage::new(2, 2, px.clone()).is_none());
    assert!(HdrImage::new(4, 2, px.clone()).is_none());
    let img = HdrImage::new(3, 2, px.clone()).expect("3 x 2 pixels");
    assert_eq!((img.width(), img.height(), img.pixels()), (3, 2, px.as_slice()));
    assert_eq!(img.at(2, 1), Vec3::splat(5.0));
}
