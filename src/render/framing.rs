//! Automatic framing: a camera for scenes whose file has none (a bare OBJ,
//! a glTF without cameras, a scene TOML without `[camera]`).
//!
//! The scene is first classed as an *enclosure* (a room, a box open on one
//! side) or an *object*, by probing it with rays: from each of 27 points of
//! a 3 x 3 x 3 grid inside its bounding box (at 1/4, 1/2 and 3/4 of each
//! side), [`PROBE_DIRECTIONS`] rays in a Fibonacci sphere of directions
//! report which faces they meet. A point is *inside an enclosure* when at
//! least [`ENCLOSED`] of its rays meet a front face (a surface facing the
//! point) and it stands at least [`CLEARANCE`] of the scene's diagonal from
//! every surface it sees; a point whose rays meet back faces is inside
//! geometry, one whose rays mostly escape is outside.
//!
//! - **Enclosure.** Of the enclosed points, the one nearest the box centre
//!   is the orbit target `P`. From `P`, eight horizontal rays (45 degrees
//!   apart) measure the room; the camera backs away from `P` along the
//!   direction with the most room (diagonals' reach counted at 1/sqrt 2, so
//!   a square room is seen square on; a ray that escapes counts as unbounded:
//!   where rays from `P` to a 5 x 5 grid on that side of the bounding box
//!   mostly escape too, the side is open, otherwise it holds a window; a box
//!   open on one side is seen through its opening, as a Cornell box is),
//!   to 85% of the distance to the wall there, and looks back across `P`;
//!   the vertical field of view fits the bounding box's far side (height,
//!   or width at 4:3), clamped to 45-75 degrees. Through an opening it
//!   backs out past the bounding box's side until a 45 degree field holds
//!   the opening, as a Cornell box's camera stands.
//! - **Object.** The camera stands outside, on the direction
//!   `(0.55, 0.4, 1)` (front, right and above, the usual three-quarter view
//!   of y-up, +z-forward models) from the bounding box's centre, at the
//!   distance where the bounding sphere fills a 40 degree vertical field.
//!
//! Either camera is then checked against the scene: where more than a
//! twentieth of its pixel rays (a 16 x 12 grid) meet back faces it is inside
//! geometry or behind a wall (outside a window taken for an opening), and
//! it moves toward the target (to 70% of its offset, up to eight times).
//! Distances are metres; angles degrees.

use crate::trace::ray::Ray;
use crate::scene::prep::PreparedScene;
use crate::scene::Camera;
use crate::trace::CpuTracer;
use glam::Vec3;

/// Rays per probed point.
pub const PROBE_DIRECTIONS: usize = 256;

/// Share of a point's rays that must meet front faces for the point to be
/// inside an enclosure. A box open on one side seen from its centre scores
/// about 5/6.
pub const ENCLOSED: f32 = 0.75;

/// Smallest distance from a point inside an enclosure to what it sees, as a
/// fraction of the bounding box's diagonal.
pub const CLEARANCE: f32 = 0.01;

/// What [`auto_camera`] chose and why.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Framing {
    /// The chosen camera.
    pub camera: Camera,
    /// True: a viewpoint inside an enclosure; false: outside an object.
    pub inside: bool,
}

impl Framing {
    /// One line for the user: where the camera stands and why.
    #[cfg(any(feature = "cli", feature = "internals"))]
    pub fn describe(&self) -> String {
        let c = &self.camera;
        format!(
            "{} camera at ({:.3}, {:.3}, {:.3}) looking at ({:.3}, {:.3}, {:.3}), {:.0} degree field",
            if self.inside { "an enclosure: inside" } else { "an object: outside" },
            c.position.x,
            c.position.y,
            c.position.z,
            c.target.x,
            c.target.y,
            c.target.z,
            c.fov_deg
        )
    }
}

/// What the rays of one point met.
#[derive(Clone, Copy, Debug, Default)]
struct Probe {
    front: f32,
    back: f32,
    nearest: f32,
}

fn directions() -> Vec<Vec3> {
    // Fibonacci sphere: even coverage, no randomness.
    let golden = std::f32::consts::PI * (3.0 - 5f32.sqrt());
    (0..PROBE_DIRECTIONS)
        .map(|i| {
            let y = 1.0 - 2.0 * (i as f32 + 0.5) / PROBE_DIRECTIONS as f32;
            let r = (1.0 - y * y).max(0.0).sqrt();
            let phi = golden * i as f32;
            Vec3::new(r * phi.cos(), y, r * phi.sin())
        })
        .collect()
}

fn probe(tracer: &dyn CpuTracer, p: Vec3, dirs: &[Vec3]) -> Probe {
    let mut out = Probe { nearest: f32::INFINITY, ..Default::default() };
    for &d in dirs {
        if let Some(h) = tracer.intersect(&Ray::new(p, d)) {
            if h.front {
                out.front += 1.0;
            } else {
                out.back += 1.0;
            }
            out.nearest = out.nearest.min(h.t);
        }
    }
    out.front /= dirs.len() as f32;
    out.back /= dirs.len() as f32;
    out
}

/// Distance along `d` from `p` (inside the box) to the box's side.
fn to_box_side(p: Vec3, d: Vec3, lo: Vec3, hi: Vec3) -> f32 {
    let mut t = f32::INFINITY;
    for k in 0..3 {
        if d[k] > 1e-6 {
            t = t.min((hi[k] - p[k]) / d[k]);
        } else if d[k] < -1e-6 {
            t = t.min((lo[k] - p[k]) / d[k]);
        }
    }
    t.max(0.0)
}

/// A camera for `scene`, traced through `tracer` (built over the scene's
/// triangles). An empty scene gets [`Camera::default`].
pub fn auto_camera(scene: &PreparedScene, tracer: &dyn CpuTracer) -> Framing {
    if scene.triangles.is_empty() {
        return Framing { camera: Camera::default(), inside: false };
    }
    let (lo, hi) = scene.bounds();
    let diag = (hi - lo).length().max(1e-6);
    let centre = (lo + hi) * 0.5;
    let dirs = directions();

    let mut best: Option<(f32, Vec3)> = None;
    for i in 1..=3 {
        for j in 1..=3 {
            for k in 1..=3 {
                let p = lo + (hi - lo) * Vec3::new(i as f32, j as f32, k as f32) * 0.25;
                let pr = probe(tracer, p, &dirs);
                if pr.front >= ENCLOSED && pr.back == 0.0 && pr.nearest >= CLEARANCE * diag {
                    let dist = (p - centre).length();
                    if best.is_none_or(|(b, _)| dist < b) {
                        best = Some((dist, p));
                    }
                }
            }
        }
    }
    let framing = match best {
        Some((_, p)) => inside_camera(tracer, p, lo, hi),
        None => outside_camera(lo, hi),
    };
    unburied(tracer, framing, diag)
}

fn inside_camera(tracer: &dyn CpuTracer, p: Vec3, lo: Vec3, hi: Vec3) -> Framing {
    let reach = |d: Vec3| tracer.intersect(&Ray::new(p, d)).map_or(f32::INFINITY, |h| h.t);
    let horizontal: Vec<Vec3> = (0..8)
        .map(|i| {
            let a = i as f32 * std::f32::consts::FRAC_PI_4;
            Vec3::new(a.sin(), 0.0, a.cos())
        })
        .collect();
    // The direction with the most room, diagonals counted at 1/sqrt(2) (a
    // square room's corner is no farther, in that measure, than its walls);
    // ties go to the first (+z, the usual front).
    let (back, room, _) = horizontal.iter().enumerate().map(|(i, &d)| (d, reach(d), i)).fold(
        (Vec3::Z, -1.0f32, -1.0f32),
        |best, (d, t, i)| {
            let score = if i % 2 == 1 { t * std::f32::consts::FRAC_1_SQRT_2 } else { t };
            if score > best.2 {
                (d, t, score)
            } else {
                best
            }
        },
    );
    let size = hi - lo;
    let across = (back.x.abs() * size.z + back.z.abs() * size.x).max(1e-6);
    // Half the far side's height, or half its width at 4:3.
    let half = (0.5 * size.y).max(0.5 * across / (4.0 / 3.0));
    // The far side of the bounding box (what stands in between is furniture).
    let far_side = to_box_side(p, -back, lo, hi);
    let side = to_box_side(p, back, lo, hi);
    let open = room.is_infinite() && open_share(tracer, p, back, lo, hi) >= 0.5;
    let (offset, fov_deg) = if !open {
        // A wall, or a window in one: stay inside.
        let offset = 0.85 * room.min(side);
        (offset, (2.0 * (half / (offset + far_side).max(1e-6)).atan()).to_degrees().clamp(45.0, 75.0))
    } else {
        // An open side (a window was told apart by `open_share`): back out
        // through it until a 45 degree field holds the opening.
        let fov_deg = 45.0f32;
        (side + half / (0.5 * fov_deg.to_radians()).tan(), fov_deg)
    };
    let position = p + back * offset;
    Framing { camera: Camera { position, target: p, fov_deg }, inside: true }
}

fn outside_camera(lo: Vec3, hi: Vec3) -> Framing {
    let fov_deg = 40.0f32;
    let centre = (lo + hi) * 0.5;
    let radius = (0.5 * (hi - lo).length()).max(1e-6);
    let dist = radius / (0.5 * fov_deg.to_radians()).sin();
    let dir = Vec3::new(0.55, 0.4, 1.0).normalize();
    Framing { camera: Camera { position: centre + dir * dist, target: centre, fov_deg }, inside: false }
}

/// Share of rays from `p` toward a 5 x 5 grid of points on the bounding
/// box's side in direction `d` that escape: an open side, not a window.
fn open_share(tracer: &dyn CpuTracer, p: Vec3, d: Vec3, lo: Vec3, hi: Vec3) -> f32 {
    let centre = p + d * to_box_side(p, d, lo, hi);
    let size = hi - lo;
    let across = Vec3::new(d.z, 0.0, -d.x).normalize_or_zero();
    let width = (across.x.abs() * size.x + across.z.abs() * size.z).max(1e-6);
    let mut open = 0;
    for i in 0..5 {
        for j in 0..5 {
            let q = centre
                + across * (width * ((i as f32 + 0.5) / 5.0 - 0.5))
                + Vec3::Y * (lo.y + size.y * (j as f32 + 0.5) / 5.0 - centre.y);
            let dir = (q - p).normalize_or_zero();
            if dir != Vec3::ZERO && tracer.intersect(&Ray::new(p, dir)).is_none() {
                open += 1;
            }
        }
    }
    open as f32 / 25.0
}

/// Share of a 16 x 12 grid of the camera's pixel rays that meet back faces.
fn back_in_view(tracer: &dyn CpuTracer, c: &Camera, diag: f32) -> f32 {
    let (w, h) = (16, 12);
    let back = (0..h)
        .flat_map(|y| (0..w).map(move |x| (x, y)))
        .filter(|&(x, y)| tracer.intersect(&super::pixel_ray(c, w, h, diag, x, y)).is_some_and(|hit| !hit.front))
        .count();
    back as f32 / (w * h) as f32
}

/// Moves a camera that stands inside geometry, or behind a wall, toward
/// its target.
fn unburied(tracer: &dyn CpuTracer, mut f: Framing, diag: f32) -> Framing {
    for _ in 0..8 {
        if back_in_view(tracer, &f.camera, diag) <= 0.05 {
            break;
        }
        let c = &mut f.camera;
        c.position = c.target + (c.position - c.target) * 0.7;
    }
    f
}

/// The scene's own camera, or (`None`) an [`auto_camera`] with what it
/// chose, traced through `tracer`, or through a wide BVH built here when
/// there is none.
pub fn camera_or_framed(
    camera: Option<Camera>,
    scene: &PreparedScene,
    tracer: Option<&dyn CpuTracer>,
) -> (Camera, Option<Framing>) {
    if let Some(c) = camera {
        return (c, None);
    }
    let framing = match tracer {
        Some(t) => auto_camera(scene, t),
        None => {
            let bvh = crate::bvh::Bvh::build(&scene.positions, &scene.triangles, &Default::default());
            auto_camera(scene, &bvh)
        }
    };
    (framing.camera, Some(framing))
}
