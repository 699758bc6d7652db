//! Equirectangular environment images (OpenEXR through the `exr` crate,
//! Radiance `.hdr` through `image`): linear radiance in W/(m^2 sr) per
//! pixel, RGB.
//!
//! Mapping (Mitsuba 3's, `src/emitters/envmap.cpp` `uv_to_direction`, so
//! a sky image lights and looks here as it does there):
//! pixel column `i` of `w` has azimuth `phi = 2 pi (i + 0.5) / w`, measured
//! from -z clockwise seen from above (toward +x first); row `j` of `h` has
//! polar angle `theta = pi (j + 0.5) / h` from +y (the top row is the
//! zenith). The direction is
//! `(sin theta sin phi, cos theta, -sin theta cos phi)`, and back
//! `phi = atan2(x, -z)`. So the left edge of the image faces -z, the
//! quarter column +x, the centre column +z, the three-quarter column -x;
//! a viewer inside looking horizontally sees the columns increase to the
//! right (unmirrored). A pixel covers `(2 pi / w)(pi / h) sin theta` sr.
//! Lookups are bilinear, wrapping in azimuth and clamping at the poles.
//! (Mitsuba puts its first and last rows on the poles, `theta = pi j /
//! (h - 1)`; here rows are pixel centres, half a row apart from that.)
//! `shaders/render.wgsl` (`sky_fs`) reads the baked sky texture with the
//! same mapping.

use crate::{Error, Result};
use glam::Vec3;
use std::path::Path;

/// An equirectangular radiance image, W/(m^2 sr).
#[derive(Clone, Debug, PartialEq)]
pub struct EnvMap {
    /// Width, pixels.
    pub width: usize,
    /// Height, pixels.
    pub height: usize,
    /// Row-major from the top (zenith) row.
    pub pixels: Vec<Vec3>,
}

/// Largest sky image accepted, pixels (16384 x 4096; 800 MB as f32 RGB).
/// Headers are checked before decoding, so a file that declares more (or,
/// for Radiance HDR, more than its size can hold) is an error, not an
/// allocation that aborts the process.
pub const MAX_PIXELS: usize = 1 << 26;

fn image_err(path: &Path, message: impl Into<String>) -> Error {
    Error::Image { path: path.to_path_buf(), message: message.into() }
}

impl EnvMap {
    /// Checks size and values: at least 2 x 1 pixels, every value finite and non-negative.
    pub fn new(width: usize, height: usize, pixels: Vec<Vec3>) -> std::result::Result<EnvMap, String> {
        if width < 2 || height < 1 || pixels.len() != width * height {
            return Err(format!("{width} x {height} pixels with {} values", pixels.len()));
        }
        if let Some((i, p)) = pixels.iter().enumerate().find(|(_, p)| !(p.is_finite() && p.min_element() >= 0.0)) {
            return Err(format!(
                "pixel ({}, {}) holds {p}: radiance must be finite and non-negative",
                i % width,
                i / width
            ));
        }
        Ok(EnvMap { width, height, pixels })
    }

    /// Loads `.exr` or `.hdr` (by extension); errors name the file.
    pub fn load(path: &Path) -> Result<EnvMap> {
        if !path.exists() {
            return Err(Error::Io {
                path: path.to_path_buf(),
                source: std::io::Error::new(std::io::ErrorKind::NotFound, "no such file"),
            });
        }
        let ext = path.extension().map(|e| e.to_string_lossy().to_ascii_lowercase());
        let (w, h, px) = match ext.as_deref() {
            Some("exr") => read_exr(path)?,
            Some("hdr") => read_hdr(path)?,
            _ => return Err(image_err(path, "sky image: expected an .exr or .hdr file")),
        };
        EnvMap::new(w, h, px).map_err(|m| image_err(path, m))
    }

    /// Direction of the centre of pixel `(i, j)`.
    pub fn direction(&self, i: usize, j: usize) -> Vec3 {
        pixel_direction(i, j, self.width, self.height)
    }

    /// Solid angle of a pixel of row `j`, sr.
    pub fn pixel_solid_angle(&self, j: usize) -> f32 {
        let theta = std::f64::consts::PI * (j as f64 + 0.5) / self.height as f64;
        (std::f64::consts::TAU / self.width as f64 * std::f64::consts::PI / self.height as f64 * theta.sin()) as f32
    }

    /// Bilinear radiance along unit direction `d`.
    pub fn lookup(&self, d: Vec3) -> Vec3 {
        let theta = d.y.clamp(-1.0, 1.0).acos();
        let mut phi = d.x.atan2(-d.z);
        if phi < 0.0 {
            phi += std::f32::consts::TAU;
        }
        let x = phi / std::f32::consts::TAU * self.width as f32 - 0.5;
        let y = (theta / std::f32::consts::PI * self.height as f32 - 0.5).clamp(0.0, (self.height - 1) as f32);
        let (x0, y0) = (x.floor(), y.floor());
        let (fx, fy) = (x - x0, y - y0);
        let w = self.width as i64;
        let col = |c: i64| c.rem_euclid(w) as usize;
        let (c0, c1) = (col(x0 as i64), col(x0 as i64 + 1));
        let (r0, r1) = (y0 as usize, (y0 as usize + 1).min(self.height - 1));
        let p = |c: usize, r: usize| self.pixels[r * self.width + c];
        (p(c0, r0) * (1.0 - fx) + p(c1, r0) * fx) * (1.0 - fy) + (p(c0, r1) * (1.0 - fx) + p(c1, r1) * fx) * fy
    }
}

/// Direction of the centre of pixel `(i, j)` of a `width` x `height`
/// equirectangular image (the mapping of the module doc).
pub fn pixel_direction(i: usize, j: usize, width: usize, height: usize) -> Vec3 {
    let phi = std::f64::consts::TAU * (i as f64 + 0.5) / width as f64;
    let theta = std::f64::consts::PI * (j as f64 + 0.5) / height as f64;
    let (st, ct) = theta.sin_cos();
    let (sp, cp) = phi.sin_cos();
    Vec3::new((st * sp) as f32, ct as f32, (-st * cp) as f32)
}

/// Checks a declared image size against [`MAX_PIXELS`] and `max_by_file`.
fn check_size(path: &Path, w: usize, h: usize, max_by_file: usize) -> Result<()> {
    let pixels = w.saturating_mul(h);
    if pixels > MAX_PIXELS.min(max_by_file) {
        return Err(image_err(
            path,
            format!("declares {w} x {h} pixels: more than the file can hold or the {MAX_PIXELS}-pixel limit"),
        ));
    }
    Ok(())
}

fn read_exr(path: &Path) -> Result<(usize, usize, Vec<Vec3>)> {
    use exr::prelude::*;
    let meta = exr::meta::MetaData::read_from_file(path, false)
        .map_err(|e| image_err(path, format!("not a readable OpenEXR image: {e}")))?;
    for h in &meta.headers {
        check_size(path, h.layer_size.width(), h.layer_size.height(), usize::MAX)?;
    }
    let image = read_first_rgba_layer_from_file(
        path,
        |size, _| (size.width(), vec![Vec3::ZERO; size.width() * size.height()]),
        |(w, px): &mut (usize, Vec<Vec3>), pos, (r, g, b, _a): (f32, f32, f32, f32)| {
            px[pos.y() * *w + pos.x()] = Vec3::new(r, g, b);
        },
    )
    .map_err(|e| image_err(path, format!("not a readable OpenEXR image: {e}")))?;
    let size = image.layer_data.size;
    let (_, px) = image.layer_data.channel_data.pixels;
    Ok((size.width(), size.height(), px))
}

fn read_hdr(path: &Path) -> Result<(usize, usize, Vec<Vec3>)> {
    let file = std::fs::File::open(path).map_err(|source| Error::Io { path: path.to_path_buf(), source })?;
    let dec = image::codecs::hdr::HdrDecoder::new(std::io::BufReader::new(file))
        .map_err(|e| image_err(path, format!("not a readable Radiance HDR image: {e}")))?;
    let meta = dec.metadata();
    // Run-length coding needs at least about 8 bytes per 127 pixels.
    let file_len = std::fs::metadata(path).map(|m| m.len() as usize).unwrap_or(usize::MAX);
    check_size(path, meta.width as usize, meta.height as usize, file_len.saturating_mul(32).saturating_add(1 << 16))?;
    // Decoded as RGB f32, 12 bytes a pixel.
    let mut bytes = vec![0u8; meta.width as usize * meta.height as usize * 12];
    image::ImageDecoder::read_image(dec, &mut bytes)
        .map_err(|e| image_err(path, format!("Radiance HDR pixels: {e}")))?;
    let channel = |b: &[u8]| f32::from_ne_bytes([b[0], b[1], b[2], b[3]]);
    let px = bytes.chunks_exact(12).map(|p| Vec3::new(channel(&p[0..4]), channel(&p[4..8]), channel(&p[8..12])));
    Ok((meta.width as usize, meta.height as usize, px.collect()))
}

/// Writes `map` as an OpenEXR file (tests and examples make sky images with it).
#[cfg(any(test, feature = "internals"))]
pub fn write_exr(map: &EnvMap, path: &Path) -> Result<()> {
    exr::prelude::write_rgb_file(path, map.width, map.height, |x, y| {
        let p = map.pixels[y * map.width + x];
        (p.x, p.y, p.z)
    })
    .map_err(|e| Error::Io { path: path.to_path_buf(), source: std::io::Error::other(e.to_string()) })
}
