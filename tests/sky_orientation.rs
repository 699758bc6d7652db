//! Sky images read unmirrored (src/sky/envmap.rs; docs/SCENES.md, "Sky
//! orientation"): Mitsuba 3's mapping, the image's left edge toward -z and
//! its columns running clockwise seen from above (-z, +x, +z, -x at 0, 1/4,
//! 1/2, 3/4 of the width). A bright band lights the vertical plate facing
//! the direction the documentation gives its columns, and a camera looking
//! that way sees the image with its columns increasing to the right. Both
//! fail on the earlier mapping (columns from +x counter-clockwise, which
//! mirrors every image).

mod common;

use glam::Vec3;
use linkgi::render::{Frame, RenderParams, Renderer};
use linkgi::scene::shapes::MeshBuilder;
use linkgi::scene::{prep, Bounces, Camera, MeshDesc};
use linkgi::sky::{EnvMap, Sky};

const W: usize = 64;
const H: usize = 32;

/// A black sky image but for the given columns, each with its radiance, in
/// the rows near the horizon (polar angles 67.5 to 112.5 degrees).
fn band_sky(columns: &[(usize, Vec3)]) -> Sky {
    let mut pixels = vec![Vec3::ZERO; W * H];
    for j in H * 3 / 8..H * 5 / 8 {
        for &(i, l) in columns {
            pixels[j * W + i] = l;
        }
    }
    Sky::image("band.exr".into(), EnvMap::new(W, H, pixels).unwrap())
}

/// The horizontal direction at `deg` clockwise from -z seen from above:
/// the documented azimuth of the columns.
fn azimuth(deg: f32) -> Vec3 {
    let (s, c) = deg.to_radians().sin_cos();
    Vec3::new(s, 0.0, -c)
}

/// A 1 m square vertical plate facing `n` (horizontal), its centre 10 m out
/// along `n`: plates on a circle facing outward do not see each other.
fn plate(n: Vec3, k: usize) -> MeshDesc {
    let mut b = MeshBuilder::new();
    let m = b.add_material("grey", Vec3::splat(0.5));
    let (u, v) = (Vec3::Y.cross(n), Vec3::Y);
    b.quad_grid(n * 10.0 - 0.5 * (u + v), u, v, 4, 4, m);
    b.finish(&format!("plate{k}"), 30.0)
}

/// A bright band two columns wide, centred on the documented direction of
/// each cardinal axis, gives the most sky light to the one of eight plates
/// facing that direction, less to its neighbours and none to the plate
/// facing away. The earlier mapping put columns 15-16 toward -z, not +x.
#[test]
fn a_bright_column_lights_the_plate_facing_its_documented_direction() {
    let white = Vec3::splat(10.0);
    // (bright columns, the documented azimuth of their shared edge)
    for (columns, deg) in [
        ([W - 1, 0], 0.0f32),
        ([W / 4 - 1, W / 4], 90.0),
        ([W / 2 - 1, W / 2], 180.0),
        ([W * 3 / 4 - 1, W * 3 / 4], 270.0),
    ] {
        let plates: Vec<MeshDesc> = (0..8).map(|k| plate(azimuth(45.0 * k as f32), k)).collect();
        let sky = band_sky(&columns.map(|c| (c, white)));
        let desc = common::scene_desc("plates", plates, vec![], Some(sky), 256, Bounces::Fixed(1));
        let (solver, sol) = common::solve(&desc);
        // Each vertex's plate by its normal.
        let mut sum = [0f64; 8];
        let mut count = [0usize; 8];
        for (n, e) in solver.scene().normals.iter().zip(&sol.e_sky) {
            let k = (0..8).max_by(|&a, &b| n.dot(azimuth(45.0 * a as f32)).total_cmp(&n.dot(azimuth(45.0 * b as f32))));
            let k = k.unwrap();
            sum[k] += e.x as f64;
            count[k] += 1;
        }
        assert!(count.iter().all(|&c| c == 25), "{count:?}");
        let e: Vec<f64> = sum.iter().zip(count).map(|(s, c)| s / c as f64).collect();
        let facing = (deg / 45.0) as usize;
        let (left, right, away) = ((facing + 7) % 8, (facing + 1) % 8, (facing + 4) % 8);
        eprintln!("columns {columns:?} (documented azimuth {deg}): E_sky per plate {e:.4?}");
        assert!(e[facing] > 0.0, "columns {columns:?}: the plate facing {deg} deg gets no sky light: {e:?}");
        for k in (0..8).filter(|&k| k != facing) {
            assert!(e[k] < e[facing], "columns {columns:?}: plate {k} gets more than the one facing {deg} deg: {e:?}");
        }
        assert!(e[left] > 0.0 && e[right] > 0.0, "columns {columns:?}: the neighbours see the band's side: {e:?}");
        assert!(e[away] == 0.0, "columns {columns:?}: the plate facing away sees the band: {e:?}");
    }
}

/// A camera at the centre looking horizontally toward the documented
/// direction of column 16 (of 64) sees column 16 in the middle of the
/// picture and column 20 (22.5 degrees further clockwise seen from above)
/// to its right, where the projection puts 22.5 degrees: the image is not
/// mirrored. On the CPU renderer and on the first graphics adapter (the
/// shader's own lookup), where there is one.
#[test]
fn the_camera_sees_the_sky_image_unmirrored() {
    let (red, green) = (Vec3::new(5.0, 0.0, 0.0), Vec3::new(0.0, 5.0, 0.0));
    let sky = band_sky(&[(16, red), (20, green)]);
    // Some geometry, far below and out of view.
    let mut b = MeshBuilder::new();
    let m = b.add_material("grey", Vec3::splat(0.5));
    b.quad_grid(Vec3::new(-0.5, -100.0, 0.5), Vec3::X, Vec3::NEG_Z, 1, 1, m);
    let desc = common::scene_desc("sky view", vec![b.finish("floor", 30.0)], vec![], Some(sky), 16, Bounces::Fixed(1));
    let scene = prep::prepare(&desc).unwrap();
    let centre_of = |i: usize| 360.0 * (i as f32 + 0.5) / W as f32;
    let camera = Camera { position: Vec3::ZERO, target: azimuth(centre_of(16)), fov_deg: 60.0 };
    let zeros = vec![Vec3::ZERO; scene.positions.len()];
    let frame = Frame::of(&scene, &zeros, camera);
    let (width, height) = (128u32, 64u32);
    let params = RenderParams { width, height, ..Default::default() };
    // Where 22.5 degrees to the right of the view axis lands: tan(a) over
    // the half-width tan(fov / 2) * aspect, in pixels from the left.
    let half_width = (30f32.to_radians().tan() * width as f32 / height as f32) as f64;
    let expect_green = (1.0 + (22.5f64.to_radians().tan() / half_width)) / 2.0 * width as f64;
    for renderer in [Renderer::open(linkgi::gpu::Backend::Cpu), Renderer::open(linkgi::gpu::Backend::Gpu)] {
        let (img, _) = renderer.render(&frame, &params).unwrap();
        let row = height / 2;
        let peak = |channel: usize| {
            (0..width).max_by(|&a, &b| img.at(a, row)[channel].total_cmp(&img.at(b, row)[channel])).unwrap()
        };
        let (r, g) = (peak(0), peak(1));
        let (rv, gv) = (img.at(r, row).x, img.at(g, row).y);
        let who = renderer.describe();
        eprintln!(
            "{who}: red column 16 at pixel {r} ({rv}), green column 20 at pixel {g} ({gv}), expected {expect_green:.1}"
        );
        assert!(rv > 2.5 && gv > 2.5, "{who}: the columns are not in view: red {rv} at {r}, green {gv} at {g}");
        assert!((r as f64 + 0.5 - width as f64 / 2.0).abs() <= 2.0, "{who}: column 16 at pixel {r}, not the centre");
        assert!(g > r, "{who}: column 20 left of column 16: mirrored");
        assert!(
            (g as f64 + 0.5 - expect_green).abs() <= 2.5,
            "{who}: column 20 at pixel {g}, expected {expect_green:.1}"
        );
    }
}
