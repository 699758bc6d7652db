//! Textures: the one decoded image type and its sampler, shared by the glTF
//! and OBJ loaders (albedo and emission sampled per vertex) and by both
//! renderers (albedo per pixel; `shaders/render.wgsl`, `sample_texture`, is
//! the GPU's copy of [`TextureMap::sample`]).
//!
//! Texels are linear RGB, unitless (a reflectance, or a scale of an
//! emission): 8- and 16-bit images are decoded from sRGB (IEC 61966-2-1:
//! `c / 12.92` up to 0.04045, else `((c + 0.055) / 1.055)^2.4`), float images
//! are taken as linear; alpha is ignored and grey images fill all three
//! channels.
//!
//! Texture coordinates follow glTF: origin at the image's top-left corner,
//! `u` to the right, `v` down, one unit across the image. OBJ/MTL
//! coordinates have their origin at the bottom-left (`v` up): the OBJ loader
//! reads them as `(u, 1 - v)`, so everything after the loaders uses one
//! convention.
//!
//! Sampling ([`TextureMap::sample`]): texel centres sit at half-integers,
//! `p = uv * (w, h) - 1/2`; nearest takes the texel at `round(p)` (ties away
//! from zero), bilinear weighs the four texels around `p` by `p - floor(p)`;
//! each texel index is wrapped per axis by the sampler's mode (clamp to edge,
//! repeat, mirrored repeat). No mipmaps.
//!
//! A textured albedo is `factor * texture(uv)` ([`TextureMap::albedo`]),
//! where the factor is glTF's `baseColorFactor` times `COLOR_0`, or MTL's
//! `Kd`; callers clamp it to `[0, MAX_ALBEDO]`. [`MeshTextures`] carries
//! what the renderer needs per position of a loaded mesh, [`CornerTextures`]
//! the same per triangle corner of a prepared scene.

use super::MAX_ALBEDO;
use glam::{Vec2, Vec3};
use std::path::Path;
use std::sync::Arc;

/// `NO_MAP` in [`MeshTextures::triangle_map`] and [`CornerTextures::triangle_map`]:
/// the triangle is untextured (its vertices' albedo is drawn).
pub const NO_MAP: u32 = u32::MAX;

/// A decoded image: linear RGB texels, rows from the top (`v = 0`).
#[derive(Clone, PartialEq)]
pub struct Texture {
    width: u32,
    height: u32,
    texels: Vec<Vec3>,
}

impl std::fmt::Debug for Texture {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        write!(f, "Texture({}x{})", self.width, self.height)
    }
}

/// sRGB-encoded value in [0, 1] to linear.
pub fn srgb_to_linear(c: f32) -> f32 {
    if c <= 0.04045 {
        c / 12.92
    } else {
        ((c + 0.055) / 1.055).powf(2.4)
    }
}

impl Texture {
    /// An image of linear texels, rows from the top; errors on a zero size,
    /// a count that does not match, or a texel that is not finite.
    pub fn from_linear(width: u32, height: u32, texels: Vec<Vec3>) -> Result<Texture, String> {
        let n = (width as usize).checked_mul(height as usize);
        if width == 0 || height == 0 || n != Some(texels.len()) {
            return Err(format!("{width}x{height} image has {} texels", texels.len()));
        }
        if let Some(bad) = texels.iter().find(|t| !t.is_finite()) {
            return Err(format!("texel {bad} is not finite"));
        }
        Ok(Texture { width, height, texels })
    }

    /// Decodes raw pixels: `channels` (1 grey, 2 grey and alpha, 3 RGB, 4
    /// RGBA) of `bytes_per_channel` each (1 or 2: sRGB unsigned integers; 4:
    /// linear `f32`), native byte order, rows from the top.
    pub fn from_pixels(
        width: u32,
        height: u32,
        channels: usize,
        bytes_per_channel: usize,
        pixels: &[u8],
    ) -> Result<Texture, String> {
        if !(1..=4).contains(&channels) || ![1, 2, 4].contains(&bytes_per_channel) {
            return Err(format!("{channels} channels of {bytes_per_channel} bytes are not a known pixel format"));
        }
        let texel_bytes = channels * bytes_per_channel;
        let needed = (width as usize).checked_mul(height as usize).and_then(|n| n.checked_mul(texel_bytes));
        if width == 0 || height == 0 || needed.is_none_or(|n| n > pixels.len()) {
            return Err(format!("{width}x{height} image has {} bytes of pixels", pixels.len()));
        }
        let channel = |b: &[u8]| -> f32 {
            match bytes_per_channel {
                1 => srgb_to_linear(b[0] as f32 / 255.0),
                2 => srgb_to_linear(u16::from_ne_bytes([b[0], b[1]]) as f32 / 65535.0),
                _ => f32::from_ne_bytes([b[0], b[1], b[2], b[3]]),
            }
        };
        let texels = pixels[..needed.unwrap_or(0)]
            .chunks_exact(texel_bytes)
            .map(|t| {
                let c = |k: usize| channel(&t[k * bytes_per_channel..]);
                if channels < 3 {
                    Vec3::splat(c(0))
                } else {
                    Vec3::new(c(0), c(1), c(2))
                }
            })
            .collect();
        Texture::from_linear(width, height, texels)
    }

    /// Reads an image file (PNG, JPEG, TGA, BMP, Radiance HDR) by its contents.
    pub fn open(path: &Path) -> Result<Texture, String> {
        let reader = image::ImageReader::open(path)
            .and_then(|r| r.with_guessed_format())
            .map_err(|e| format!("could not be opened: {e}"))?;
        let img = reader.decode().map_err(|e| format!("could not be decoded: {e}"))?;
        let color = img.color();
        let channels = color.channel_count() as usize;
        let bytes = color.bytes_per_pixel() as usize / channels;
        match bytes {
            1 | 2 | 4 => Texture::from_pixels(img.width(), img.height(), channels, bytes, img.as_bytes()),
            _ => {
                let rgb = img.to_rgb32f();
                Texture::from_pixels(img.width(), img.height(), 3, 4, bytemuck::cast_slice(rgb.as_raw()))
            }
        }
    }

    /// Width, texels.
    pub fn width(&self) -> u32 {
        self.width
    }

    /// Height, texels.
    pub fn height(&self) -> u32 {
        self.height
    }

    /// Texels, linear RGB, row by row from the top.
    pub fn texels(&self) -> &[Vec3] {
        &self.texels
    }

    /// The texel at integer coordinates `(x, y)` (any integers), wrapped.
    pub fn fetch(&self, x: i64, y: i64, wrap: [Wrap; 2]) -> Vec3 {
        let (x, y) = (wrap[0].index(x, self.width), wrap[1].index(y, self.height));
        self.texels[y * self.width as usize + x]
    }
}

/// How a texel index outside the image comes back into it (glTF's wrap modes).
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub enum Wrap {
    /// The index is clamped to the image's edge.
    ClampToEdge,
    /// The image repeats (the default).
    #[default]
    Repeat,
    /// The image repeats, mirrored every other time.
    MirroredRepeat,
}

impl Wrap {
    /// The index in `0..n` of texel `i`.
    pub fn index(self, i: i64, n: u32) -> usize {
        let n = n as i64;
        (match self {
            Wrap::ClampToEdge => i.clamp(0, n - 1),
            Wrap::Repeat => i.rem_euclid(n),
            Wrap::MirroredRepeat => {
                let m = i.rem_euclid(2 * n);
                if m < n {
                    m
                } else {
                    2 * n - 1 - m
                }
            }
        }) as usize
    }

    /// The shader's code of the mode (`render.wgsl`, `wrap_index`).
    pub fn code(self) -> u32 {
        match self {
            Wrap::ClampToEdge => 0,
            Wrap::Repeat => 1,
            Wrap::MirroredRepeat => 2,
        }
    }
}

/// How a texture is read: wrap mode per axis (u, v) and the filter.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub struct Sampler {
    /// Wrap mode along u and along v.
    pub wrap: [Wrap; 2],
    /// Nearest texel; else bilinear (the default).
    pub nearest: bool,
}

/// An image as a material uses it: shared texels and a sampler.
#[derive(Clone, Debug)]
pub struct TextureMap {
    /// The image (texels shared between the maps that use it).
    pub image: Arc<Texture>,
    /// How the image is read.
    pub sampler: Sampler,
}

impl PartialEq for TextureMap {
    fn eq(&self, other: &Self) -> bool {
        self.sampler == other.sampler && (Arc::ptr_eq(&self.image, &other.image) || self.image == other.image)
    }
}

impl TextureMap {
    /// Colour at texture coordinates `uv` (linear RGB; glTF's convention, module docs).
    pub fn sample(&self, uv: Vec2) -> Vec3 {
        let t = &self.image;
        let wrap = self.sampler.wrap;
        let p = (uv * Vec2::new(t.width as f32, t.height as f32) - 0.5).clamp(Vec2::splat(-1e9), Vec2::splat(1e9));
        if self.sampler.nearest {
            return t.fetch(p.x.round() as i64, p.y.round() as i64, wrap);
        }
        let f = p.floor();
        let w = p - f;
        let (x, y) = (f.x as i64, f.y as i64);
        let row = |y: i64| t.fetch(x, y, wrap).lerp(t.fetch(x + 1, y, wrap), w.x);
        row(y).lerp(row(y + 1), w.y)
    }

    /// Textured albedo (or emission) before clamping: `factor * texture(uv)`.
    pub fn albedo(&self, uv: Vec2, factor: Vec3) -> Vec3 {
        factor * self.sample(uv)
    }
}

/// Albedo textures of one loaded mesh, for drawing albedo per pixel:
/// indexed by the mesh's positions and triangles.
#[derive(Clone, Debug, PartialEq)]
pub struct MeshTextures {
    /// The texture maps the triangles use.
    pub maps: Vec<TextureMap>,
    /// Map per triangle (index into `maps`), or `NO_MAP`.
    pub triangle_map: Vec<u32>,
    /// Texture coordinates per position (glTF's convention).
    pub uv: Vec<Vec2>,
    /// What the texture is multiplied with, per position (`baseColorFactor`
    /// times `COLOR_0`, or `Kd`).
    pub factor: Vec<Vec3>,
}

impl MeshTextures {
    /// Checks counts against a mesh of `positions` and `triangles`, map
    /// indices, and finite coordinates and factors.
    pub fn validate(&self, positions: usize, triangles: usize) -> Result<(), String> {
        if self.uv.len() != positions || self.factor.len() != positions || self.triangle_map.len() != triangles {
            return Err(format!(
                "textures: {} texture coordinates and {} factors for {positions} vertices, {} maps for {triangles} triangles",
                self.uv.len(),
                self.factor.len(),
                self.triangle_map.len()
            ));
        }
        if let Some(t) = self.triangle_map.iter().position(|&m| m != NO_MAP && m as usize >= self.maps.len()) {
            return Err(format!("triangle {t} uses texture {}, of {}", self.triangle_map[t], self.maps.len()));
        }
        if let Some(i) = (0..positions).find(|&i| !self.uv[i].is_finite() || !self.factor[i].is_finite()) {
            return Err(format!("vertex {i} has texture coordinates {} and factor {}", self.uv[i], self.factor[i]));
        }
        Ok(())
    }
}

/// Albedo textures of a prepared scene, per triangle corner (solver
/// vertices join corners of equal albedo whatever their coordinates, so the
/// renderer reads coordinates per corner).
#[derive(Clone, Debug, Default, PartialEq)]
pub struct CornerTextures {
    /// The texture maps the triangles use.
    pub maps: Vec<TextureMap>,
    /// Map per triangle (index into `maps`), or `NO_MAP`.
    pub triangle_map: Vec<u32>,
    /// Texture coordinates of each triangle's corners.
    pub uv: Vec<[Vec2; 3]>,
    /// Factor of each triangle's corners ([`MeshTextures::factor`]).
    pub factor: Vec<[Vec3; 3]>,
}

impl CornerTextures {
    /// Albedo at barycentrics `b` of triangle `tri`: the interpolated factor
    /// times the texture at the interpolated coordinates, clamped to
    /// `[0, MAX_ALBEDO]`; `None` for an untextured triangle.
    pub fn albedo(&self, tri: usize, b: [f32; 3]) -> Option<Vec3> {
        let m = *self.triangle_map.get(tri)?;
        let map = self.maps.get(m as usize)?;
        let (uv, f) = (&self.uv[tri], &self.factor[tri]);
        let uv = uv[0] * b[0] + uv[1] * b[1] + uv[2] * b[2];
        let factor = f[0] * b[0] + f[1] * b[1] + f[2] * b[2];
        Some(map.albedo(uv, factor).clamp(Vec3::ZERO, Vec3::splat(MAX_ALBEDO)))
    }

    /// Checks counts against `triangles` and map indices.
    pub fn validate(&self, triangles: usize) -> Result<(), String> {
        if self.uv.len() != triangles || self.factor.len() != triangles || self.triangle_map.len() != triangles {
            return Err(format!(
                "textures: {} maps, {} coordinate and {} factor triples for {triangles} triangles",
                self.triangle_map.len(),
                self.uv.len(),
                self.factor.len()
            ));
        }
        if let Some(t) = self.triangle_map.iter().position(|&m| m != NO_MAP && m as usize >= self.maps.len()) {
            return Err(format!("triangle {t} uses texture {}, of {}", self.triangle_map[t], self.maps.len()));
        }
        Ok(())
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn map(w: u32, h: u32, texels: Vec<Vec3>, sampler: Sampler) -> TextureMap {
        TextureMap { image: Arc::new(Texture::from_linear(w, h, texels).unwrap()), sampler }
    }

    #[test]
    fn texel_centres_return_their_texel_and_midpoints_average() {
        let t = [Vec3::X, Vec3::Y, Vec3::Z, Vec3::ONE];
        for nearest in [false, true] {
            let m = map(2, 2, t.to_vec(), Sampler { nearest, ..Default::default() });
            for (i, c) in t.iter().enumerate() {
                let uv = Vec2::new(0.25 + 0.5 * (i % 2) as f32, 0.25 + 0.5 * (i / 2) as f32);
                assert_eq!(m.sample(uv), *c, "texel {i}, nearest {nearest}");
            }
        }
        let m = map(2, 2, t.to_vec(), Sampler::default());
        // Halfway between the centres of the top row: their mean.
        assert!((m.sample(Vec2::new(0.5, 0.25)) - (t[0] + t[1]) / 2.0).length() < 1e-6);
        // At u = 0 with repeat, halfway between the last and the first column.
        assert!((m.sample(Vec2::new(0.0, 0.25)) - (t[0] + t[1]) / 2.0).length() < 1e-6);
        let clamp = map(2, 2, t.to_vec(), Sampler { wrap: [Wrap::ClampToEdge; 2], nearest: false });
        assert_eq!(clamp.sample(Vec2::new(0.0, 0.25)), t[0]);
    }

    #[test]
    fn wrap_modes_index_as_gltf_says() {
        let n = 3;
        let got = |w: Wrap| (-4..7).map(|i| w.index(i, n)).collect::<Vec<_>>();
        assert_eq!(got(Wrap::ClampToEdge), [0, 0, 0, 0, 0, 1, 2, 2, 2, 2, 2]);
        assert_eq!(got(Wrap::Repeat), [2, 0, 1, 2, 0, 1, 2, 0, 1, 2, 0]);
        assert_eq!(got(Wrap::MirroredRepeat), [2, 2, 1, 0, 0, 1, 2, 2, 1, 0, 0]);
    }

    #[test]
    fn pixels_decode_from_srgb_except_floats() {
        let t = Texture::from_pixels(2, 1, 3, 1, &[255, 0, 188, 0, 128, 255]).unwrap();
        assert_eq!(t.texels()[0], Vec3::new(1.0, 0.0, srgb_to_linear(188.0 / 255.0)));
        assert!((t.texels()[1].y - 0.2158605).abs() < 1e-6, "{}", t.texels()[1]);
        let grey = Texture::from_pixels(1, 1, 2, 2, &[0xff, 0xff, 0, 0]).unwrap();
        assert_eq!(grey.texels()[0], Vec3::ONE);
        let f: Vec<u8> = [0.5f32, 2.0, 0.25].iter().flat_map(|x| x.to_ne_bytes()).collect();
        assert_eq!(Texture::from_pixels(1, 1, 3, 4, &f).unwrap().texels()[0], Vec3::new(0.5, 2.0, 0.25));
        assert!(Texture::from_pixels(2, 2, 3, 1, &[0; 11]).is_err());
        assert!(Texture::from_linear(1, 1, vec![Vec3::NAN]).is_err());
    }

    #[test]
    fn corner_albedo_interpolates_factor_and_coordinates_and_clamps() {
        let m = map(2, 1, vec![Vec3::splat(0.5), Vec3::ONE], Sampler { nearest: true, ..Default::default() });
        let c = CornerTextures {
            maps: vec![m],
            triangle_map: vec![0, NO_MAP],
            uv: vec![[Vec2::new(0.25, 0.5), Vec2::new(0.75, 0.5), Vec2::new(0.75, 0.5)]; 2],
            factor: vec![[Vec3::ONE, Vec3::splat(2.0), Vec3::splat(2.0)]; 2],
        };
        assert!(c.validate(2).is_ok());
        assert_eq!(c.albedo(0, [1.0, 0.0, 0.0]), Some(Vec3::splat(0.5)));
        assert_eq!(c.albedo(0, [0.0, 0.5, 0.5]), Some(Vec3::splat(MAX_ALBEDO)));
        assert_eq!(c.albedo(1, [1.0, 0.0, 0.0]), None);
        assert!(c.validate(3).is_err());
    }
}
