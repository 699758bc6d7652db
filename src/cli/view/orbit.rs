//! The viewer's camera and mouse geometry: an orbit camera (yaw and pitch
//! in radians about a target, distance in metres), projection of points to
//! window pixels, and the cursor ray's hit on a horizontal plane (dragging
//! a light at its height).

use crate::render::{camera_matrices, pixel_ray};
use crate::scene::Camera;
use glam::{Vec2, Vec3, Vec4};

/// Orbit camera around a target.
#[derive(Clone, Copy, Debug)]
pub struct Orbit {
    pub target: Vec3,
    pub yaw: f32,
    pub pitch: f32,
    pub distance: f32,
    pub fov_deg: f32,
}

impl Orbit {
    pub fn from_camera(c: Camera) -> Orbit {
        let off = c.position - c.target;
        let distance = off.length().max(1e-3);
        Orbit {
            target: c.target,
            yaw: off.x.atan2(off.z),
            pitch: (off.y / distance).clamp(-1.0, 1.0).asin(),
            distance,
            fov_deg: c.fov_deg,
        }
    }

    pub fn camera(&self) -> Camera {
        let dir = Vec3::new(self.pitch.cos() * self.yaw.sin(), self.pitch.sin(), self.pitch.cos() * self.yaw.cos());
        Camera { position: self.target + dir * self.distance, target: self.target, fov_deg: self.fov_deg }
    }

    /// Camera right and up vectors.
    pub fn basis(&self) -> (Vec3, Vec3) {
        let c = self.camera();
        let fwd = (c.target - c.position).normalize_or_zero();
        let right = fwd.cross(Vec3::Y).normalize_or_zero();
        (right, right.cross(fwd))
    }

    /// Left-drag by `(dx, dy)` pixels: turns about the target.
    pub fn rotate(&mut self, dx: f32, dy: f32) {
        self.yaw -= dx * 0.005;
        self.pitch = (self.pitch + dy * 0.005).clamp(-1.5, 1.5);
    }

    /// Right-drag: moves the target in the view plane.
    pub fn pan(&mut self, dx: f32, dy: f32) {
        let (right, up) = self.basis();
        let s = self.distance * 0.002;
        self.target += (-right * dx + up * dy) * s;
    }

    /// Wheel: `lines` notches closer (positive) or farther; `extent` bounds the distance.
    pub fn zoom(&mut self, lines: f32, extent: f32) {
        self.distance = (self.distance * 0.9f32.powf(lines)).clamp(1e-3 * extent, 20.0 * extent);
    }
}

/// Pixel position (x right, y down; pixel centres at +0.5) of `p` seen by
/// `camera` in a `width` x `height` window, or `None` behind the camera.
pub fn project(camera: &Camera, width: u32, height: u32, extent: f32, p: Vec3) -> Option<Vec2> {
    let (view, proj) = camera_matrices(camera, width as f32 / height as f32, extent * 4.0);
    let clip = proj * view * Vec4::new(p.x, p.y, p.z, 1.0);
    if clip.w <= 1e-6 {
        return None;
    }
    let ndc = clip.truncate() / clip.w;
    Some(Vec2::new((ndc.x + 1.0) * 0.5 * width as f32, (1.0 - ndc.y) * 0.5 * height as f32))
}

/// Where the ray through pixel `(x, y)` meets the horizontal plane at
/// height `y_plane`, or `None` when it runs (nearly) parallel or away.
pub fn cursor_on_plane(
    camera: &Camera,
    width: u32,
    height: u32,
    extent: f32,
    x: f32,
    y: f32,
    y_plane: f32,
) -> Option<Vec3> {
    let (px, py) = (x.clamp(0.0, width as f32 - 1.0) as u32, y.clamp(0.0, height as f32 - 1.0) as u32);
    let ray = pixel_ray(camera, width, height, extent, px, py);
    let (o, d) = (ray.origin, ray.dir);
    if d.y.abs() < 1e-4 {
        return None;
    }
    let t = (y_plane - o.y) / d.y;
    (t > 0.0 && t < 10.0 * extent).then(|| o + d * t)
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn projection_and_cursor_ray_are_inverse() {
        let cam = Camera { position: Vec3::new(0.3, 1.8, 2.5), target: Vec3::new(0.0, 0.5, 0.0), fov_deg: 50.0 };
        let (w, h, extent) = (400, 300, 3.0);
        for p in [Vec3::new(0.2, 0.0, -0.3), Vec3::new(-0.8, 0.0, 0.4), Vec3::new(0.0, 0.0, 0.0)] {
            let px = project(&cam, w, h, extent, p).unwrap();
            // pixel_ray shoots through pixel centres: snap to the pixel grid.
            let hit = cursor_on_plane(&cam, w, h, extent, px.x.floor(), px.y.floor(), p.y).unwrap();
            assert!((hit - p).length() < 0.02, "{p} -> {px} -> {hit}");
        }
        assert!(project(&cam, w, h, extent, Vec3::new(0.6, 3.6, 5.0)).is_none(), "behind the camera");
    }

    #[test]
    fn orbit_round_trips_its_camera() {
        let c = Camera { position: Vec3::new(1.0, 2.0, 3.0), target: Vec3::new(0.0, 0.5, 0.0), fov_deg: 40.0 };
        let back = Orbit::from_camera(c).camera();
        assert!((back.position - c.position).length() < 1e-5);
    }
}
