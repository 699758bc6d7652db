//! Procedural deformation of `dynamic` meshes, evaluated per frame on the CPU.
//!
//! A dynamic mesh carries a list of [`Deform`]s (the `[[mesh.deform]]` tables
//! of a scene TOML). Each one maps a world-space rest position `p` (metres)
//! to a deformed one at time `t` (seconds); they are applied in order.
//! With `h = (p - center) . axis` the height along the axis and
//! `s(t) = sin(2 pi t / period_s)` the time factor (so every deformer is the
//! identity at `t = 0`, and at any `t` when `amount = 0`):
//!
//! - `twist`: rotate `p` about the axis line (through `center`) by
//!   `amount * s(t) * h` degrees. `amount` is in degrees per metre of height.
//!   Distances to the axis are preserved.
//! - `bend`: rotate `p` about the line through `center` along `axis x toward`
//!   by `amount * s(t) * h` degrees for `h > 0` (points below the centre stay).
//!   `amount` in degrees per metre; the mesh leans towards `toward`.
//! - `wave`: displace `p` along `toward` by
//!   `amount * s(t) * sin(2 pi h / wavelength)` metres. `amount` in metres.
//!
//! `toward` (unit, made perpendicular to `axis`) defaults to any perpendicular
//! of `axis`; `axis` defaults to +y, `center` to the origin, `period_s` to 4 s,
//! `wavelength` to 1 m. After deforming, normals are recomputed from the
//! triangles ([`super::deform::vertex_normals`]: angle-weighted face normals over each
//! solver vertex's incident triangles, so creases stay split).

use glam::{Quat, Vec3};

/// Which deformation.
#[derive(Clone, Copy, Debug, PartialEq, Eq, serde::Serialize, serde::Deserialize)]
#[serde(rename_all = "lowercase")]
pub enum DeformKind {
    /// Rotate about the axis, by an angle growing with the height.
    Twist,
    /// Lean toward `toward` above the centre, by an angle growing with the height.
    Bend,
    /// Displace along `toward` by a sine wave of the height.
    Wave,
}

/// One deformer; units in the module docs.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Deform {
    /// Which deformation.
    pub kind: DeformKind,
    /// Unit axis (height direction). Default +y.
    pub axis: Vec3,
    /// A point on the axis, metres. Default origin.
    pub center: Vec3,
    /// Unit direction perpendicular to `axis` that bend and wave move towards.
    pub toward: Vec3,
    /// Twist/bend: degrees per metre of height; wave: metres.
    pub amount: f32,
    /// Period of the time factor, seconds (> 0). Default 4.
    pub period_s: f32,
    /// Wave length along the axis, metres (> 0). Default 1.
    pub wavelength: f32,
}

impl Deform {
    /// A deformer with the documented defaults.
    pub fn new(kind: DeformKind, amount: f32) -> Deform {
        let axis = Vec3::Y;
        Deform {
            kind,
            axis,
            center: Vec3::ZERO,
            toward: axis.any_orthonormal_vector(),
            amount,
            period_s: 4.0,
            wavelength: 1.0,
        }
    }

    /// Checks values; the message names the bad field.
    pub fn validate(&self) -> Result<(), String> {
        if !(self.axis.is_finite() && self.axis.length_squared() > 1e-12) {
            return Err(format!("deform.axis = {} must be a finite non-zero vector", self.axis));
        }
        if !self.center.is_finite() {
            return Err(format!("deform.center = {} is not finite", self.center));
        }
        if !self.amount.is_finite() {
            return Err(format!("deform.amount = {} is not finite", self.amount));
        }
        if !(self.period_s.is_finite() && self.period_s > 0.0) {
            return Err(format!("deform.period_s = {} must be positive", self.period_s));
        }
        if !(self.wavelength.is_finite() && self.wavelength > 0.0) {
            return Err(format!("deform.wavelength = {} must be positive", self.wavelength));
        }
        if !self.toward.is_finite() {
            return Err(format!("deform.toward = {} is not finite", self.toward));
        }
        Ok(())
    }

    /// Normalizes `axis` and makes `toward` a unit perpendicular of it
    /// (any perpendicular when `toward` is zero or parallel to the axis).
    pub fn normalized(mut self) -> Deform {
        self.axis = self.axis.normalize();
        let t = self.toward - self.axis * self.toward.dot(self.axis);
        self.toward = if t.length_squared() > 1e-12 { t.normalize() } else { self.axis.any_orthonormal_vector() };
        self
    }

    /// `s(t) = sin(2 pi t / period_s)`.
    pub fn time_factor(&self, t: f32) -> f32 {
        (std::f32::consts::TAU * t / self.period_s).sin()
    }

    /// The deformed position of rest position `p` at time `t` seconds.
    pub fn apply(&self, p: Vec3, t: f32) -> Vec3 {
        let s = self.time_factor(t);
        let rel = p - self.center;
        let h = rel.dot(self.axis);
        match self.kind {
            DeformKind::Twist => {
                let q = Quat::from_axis_angle(self.axis, (self.amount * s * h).to_radians());
                self.center + q * rel
            }
            DeformKind::Bend => {
                if h <= 0.0 {
                    return p;
                }
                let pivot_axis = self.axis.cross(self.toward).normalize();
                // A positive rotation about `axis x toward` turns `axis` towards `toward`.
                let q = Quat::from_axis_angle(pivot_axis, (self.amount * s * h).to_radians());
                self.center + q * rel
            }
            DeformKind::Wave => {
                p + self.toward * (self.amount * s * (std::f32::consts::TAU * h / self.wavelength).sin())
            }
        }
    }
}

/// Applies `deforms` in order to every position of `rest`.
pub fn deform_positions(deforms: &[Deform], rest: &[Vec3], t: f32) -> Vec<Vec3> {
    rest.iter().map(|&p| deforms.iter().fold(p, |q, d| d.apply(q, t))).collect()
}
