//! Display of a solved scene: direct light per pixel, indirect light from
//! the vertices (docs/DESIGN.md §6).
//!
//! Outgoing radiance per pixel, W/(m^2 sr): `L = rho / pi * (E_d + E_i)`,
//! where `E_d` is the direct irradiance evaluated at the pixel (point lights
//! `I cos / r^2`, directional `E cos`, times visibility) and `E_i` the
//! solver's indirect irradiance interpolated from the triangle's vertices.
//! `rho` is interpolated from the vertices too, except on textured triangles
//! ([`Frame::textures`]), where it is the albedo texture at the pixel's
//! interpolated coordinates times the interpolated factor
//! ([`crate::scene::texture::CornerTextures::albedo`]): irradiance from the
//! vertices times albedo from the texture, as engines draw baked vertex or
//! lightmap light.
//! The `direct` and `indirect` views keep one of the two terms.
//!
//! Two renderers produce the same [`HdrImage`] of linear radiance:
//! - [`gpu::GpuRenderer`]: wgpu rasterization into an `Rgba16Float` target,
//!   shadow maps with percentage-closer filtering (six 2D layers per point
//!   light, a cube map's faces; one per directional light);
//! - [`cpu::render_cpu`]: the fallback with no adapter: a primary ray per
//!   pixel and a shadow ray per light through a wide BVH (hard shadows).
//!
//! [`tone_map`] is shared by both: `c = ACES(L * exposure)` (Narkowicz's fit),
//! then the sRGB transfer curve, 8 bits per channel. The camera is a pinhole
//! with a vertical field of view, y up.

pub mod cpu;
pub mod exposure;
pub mod framing;
pub mod gpu;
pub mod gpu_data;
// The viewer's presentation: the tone-map pass into a swap chain.
#[cfg(any(feature = "viewer", feature = "internals"))]
pub mod present;

use crate::exchange::bounce::operator::radiosity;
use crate::scene::prep::PreparedScene;
use crate::scene::texture::CornerTextures;
use crate::scene::{Camera, Light};
use glam::{Mat4, Vec3};
use std::path::Path;

/// Lights a renderer handles at most.
pub const MAX_LIGHTS: usize = 8;

/// Which terms of the radiance are shown.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
#[cfg_attr(feature = "cli", derive(clap::ValueEnum))]
pub enum View {
    /// Direct, sky and indirect light, and emission.
    #[default]
    Combined,
    /// Direct and sky light, and emission (no indirect light).
    Direct,
    /// Indirect light only.
    Indirect,
}

impl View {
    /// The view's code in the shader's `view_mode` (0 combined, 1 direct, 2 indirect).
    pub fn mode(self) -> u32 {
        match self {
            View::Combined => 0,
            View::Direct => 1,
            View::Indirect => 2,
        }
    }
}

/// Renderer settings.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct RenderParams {
    /// Image size in pixels. Default 640 x 480.
    pub width: u32,
    /// Image height in pixels.
    pub height: u32,
    /// Which terms of the radiance are shown. Default [`View::Combined`].
    pub view: View,
    /// Radiance scale before tone mapping. Default `DEFAULT_EXPOSURE`.
    pub exposure: f32,
    /// Shadow-map layer size in texels (GPU). Default 1024.
    pub shadow_size: u32,
    /// Offset of shadow lookups and shadow-ray origins along the normal,
    /// as a fraction of the scene's bounding-box diagonal. Default 0.002.
    pub normal_offset: f32,
}

/// The radiance scale before tone mapping of renders, animations and the
/// exported vertex colours, unless set (`--exposure`).
pub const DEFAULT_EXPOSURE: f32 = 0.6;

impl Default for RenderParams {
    fn default() -> Self {
        Self {
            width: 640,
            height: 480,
            view: View::Combined,
            exposure: DEFAULT_EXPOSURE,
            shadow_size: 1024,
            normal_offset: 0.002,
        }
    }
}

/// What a frame draws: geometry (possibly deformed), per-vertex albedo and
/// indirect irradiance (W/m^2), albedo textures, lights and camera.
#[derive(Clone, Copy, Debug)]
pub struct Frame<'a> {
    /// Vertex positions, metres.
    pub positions: &'a [Vec3],
    /// Unit vertex normals.
    pub normals: &'a [Vec3],
    /// Diffuse albedo per vertex.
    pub albedo: &'a [Vec3],
    /// Triangles as vertex indices.
    pub triangles: &'a [[u32; 3]],
    /// Albedo textures per triangle corner (`None`: every triangle draws its
    /// vertices' albedo).
    pub textures: Option<&'a CornerTextures>,
    /// Indirect irradiance per vertex, W/m^2.
    pub e_indirect: &'a [Vec3],
    /// Irradiance from the sky per vertex, W/m^2 (empty: none).
    pub e_sky: &'a [Vec3],
    /// Emitted exitance per vertex, W/m^2 (empty: none); drawn as radiance `M_e / pi`.
    pub emission: &'a [Vec3],
    /// What pixels that see no surface show (black without a sky).
    pub sky: Option<&'a crate::sky::Sky>,
    /// The lights (at most `MAX_LIGHTS`).
    pub lights: &'a [Light],
    /// The camera the frame is seen from.
    pub camera: Camera,
}

impl<'a> Frame<'a> {
    /// A frame of `scene` as prepared, with `e_indirect` per vertex, the
    /// scene's emitters and its sky behind everything (no sky irradiance:
    /// see [`Frame::with_sky`]).
    pub fn of(scene: &'a PreparedScene, e_indirect: &'a [Vec3], camera: Camera) -> Frame<'a> {
        Frame {
            positions: &scene.positions,
            normals: &scene.normals,
            albedo: &scene.albedo,
            triangles: &scene.triangles,
            textures: scene.textures.as_deref(),
            e_indirect,
            e_sky: &[],
            emission: &scene.emission,
            sky: scene.sky.as_ref(),
            lights: &scene.lights,
            camera,
        }
    }

    /// The frame with sky irradiance `e_sky` per vertex (W/m^2).
    pub fn with_sky(self, e_sky: &'a [Vec3]) -> Frame<'a> {
        Frame { e_sky, ..self }
    }

    /// Sky irradiance of vertex `v` (zero when none is given).
    pub fn sky_at(&self, v: usize) -> Vec3 {
        self.e_sky.get(v).copied().unwrap_or_default()
    }

    /// Emitted radiance of vertex `v`, `M_e / pi` (zero when none is given).
    pub fn emitted_at(&self, v: usize) -> Vec3 {
        radiosity(Vec3::ZERO, Vec3::ZERO, self.emission.get(v).copied().unwrap_or(Vec3::ZERO))
    }

    /// Checks counts and the light limit.
    pub fn validate(&self) -> crate::Result<()> {
        let n = self.positions.len();
        let optional = |len: usize| len == n || len == 0;
        if self.normals.len() != n
            || self.albedo.len() != n
            || self.e_indirect.len() != n
            || !optional(self.e_sky.len())
            || !optional(self.emission.len())
        {
            return Err(crate::Error::Setting(format!(
                "render: {} positions, {} normals, {} albedos, {} indirect, {} sky and {} emission values",
                n,
                self.normals.len(),
                self.albedo.len(),
                self.e_indirect.len(),
                self.e_sky.len(),
                self.emission.len()
            )));
        }
        if self.lights.len() > MAX_LIGHTS {
            return Err(crate::Error::Setting(format!(
                "render: {} lights, the renderer handles at most {MAX_LIGHTS}",
                self.lights.len()
            )));
        }
        if let Some(t) = self.triangles.iter().find(|t| t.iter().any(|&i| i as usize >= n)) {
            return Err(crate::Error::Setting(format!("render: triangle {t:?} indexes past {n} vertices")));
        }
        if let Some(t) = self.textures {
            t.validate(self.triangles.len()).map_err(|m| crate::Error::Setting(format!("render: {m}")))?;
        }
        Ok(())
    }

    /// Bounding box `(min, max)` of the positions.
    pub fn bounds(&self) -> (Vec3, Vec3) {
        self.positions.iter().fold((Vec3::splat(f32::MAX), Vec3::splat(f32::MIN)), |(a, b), &p| (a.min(p), b.max(p)))
    }

    /// Length of the bounding-box diagonal, metres.
    pub fn extent(&self) -> f32 {
        let (a, b) = self.bounds();
        (b - a).length().max(1e-6)
    }
}

/// The camera's view and projection. `far` in metres.
pub fn camera_matrices(c: &Camera, aspect: f32, far: f32) -> (Mat4, Mat4) {
    let view = Mat4::look_at_rh(c.position, c.target, up_for(c.target - c.position));
    let proj = Mat4::perspective_rh(c.fov_deg.to_radians(), aspect, far * 1e-4, far);
    (view, proj)
}

/// The primary ray through the centre of pixel `(x, y)` (rows top to bottom)
/// of a `width` x `height` image; `extent` is the scene's diagonal (sets the far plane).
pub fn pixel_ray(c: &Camera, width: u32, height: u32, extent: f32, x: u32, y: u32) -> crate::trace::ray::Ray {
    let (view, proj) = camera_matrices(c, width as f32 / height as f32, extent * 4.0);
    let inv = (proj * view).inverse();
    let ndc_x = (x as f32 + 0.5) / width as f32 * 2.0 - 1.0;
    let ndc_y = 1.0 - (y as f32 + 0.5) / height as f32 * 2.0;
    let far = inv * glam::Vec4::new(ndc_x, ndc_y, 1.0, 1.0);
    let dir = (far.truncate() / far.w - c.position).normalize();
    crate::trace::ray::Ray::new(c.position, dir)
}

/// +y, or +z when looking straight up or down.
pub fn up_for(forward: Vec3) -> Vec3 {
    if forward.normalize_or_zero().cross(Vec3::Y).length_squared() < 1e-6 {
        Vec3::Z
    } else {
        Vec3::Y
    }
}

internal_fields! {
    /// Linear radiance per pixel, rows top to bottom.
    #[derive(Clone, Debug, PartialEq)]
    pub struct HdrImage {
        /// Width in pixels.
        pub width: u32,
        /// Height in pixels.
        pub height: u32,
        /// Linear radiance per pixel before exposure and tone mapping, `width * height` of them, rows top to bottom.
        pub pixels: Vec<Vec3>,
    }
}

impl HdrImage {
    /// An image of `width x height` pixels of linear radiance, rows top to
    /// bottom; `None` where `pixels` does not hold `width * height` of them.
    pub fn new(width: u32, height: u32, pixels: Vec<Vec3>) -> Option<HdrImage> {
        (pixels.len() as u64 == u64::from(width) * u64::from(height)).then_some(HdrImage { width, height, pixels })
    }

    /// Width in pixels.
    pub fn width(&self) -> u32 {
        self.width
    }

    /// Height in pixels.
    pub fn height(&self) -> u32 {
        self.height
    }

    /// Linear radiance per pixel, W/(m^2 sr), rows top to bottom.
    pub fn pixels(&self) -> &[Vec3] {
        &self.pixels
    }

    /// The pixel at column `x`, row `y` (row 0 at the top).
    pub fn at(&self, x: u32, y: u32) -> Vec3 {
        self.pixels[(y * self.width + x) as usize]
    }
}

/// Figures of one render.
#[derive(Clone, Copy, Debug, Default, PartialEq)]
pub struct RenderStats {
    /// Point lights given a cube shadow map (six layers each).
    pub cube_shadow_maps: u32,
    /// Directional lights given a 2D shadow map.
    pub shadow_maps_2d: u32,
    /// Shadow-map layers allocated (0 when the frame has no lights).
    pub shadow_layers: u32,
    /// The previous frame's shadow maps were reused (same lights, geometry
    /// and shadow size; GPU renderer only).
    pub shadow_maps_reused: bool,
    /// Time from call to read-back, ms.
    pub ms: f64,
}

/// ACES filmic curve (Narkowicz 2015 fit), input and output in [0, inf) -> [0, 1].
pub fn aces(x: f32) -> f32 {
    let (a, b, c, d, e) = (2.51, 0.03, 2.43, 0.59, 0.14);
    ((x * (a * x + b)) / (x * (c * x + d) + e)).clamp(0.0, 1.0)
}

/// sRGB transfer curve of a linear value in [0, 1].
pub fn srgb(x: f32) -> f32 {
    if x <= 0.0031308 {
        12.92 * x
    } else {
        1.055 * x.powf(1.0 / 2.4) - 0.055
    }
}

/// One radiance (W/(m^2 sr)) as 8-bit sRGB: exposure, ACES and sRGB
/// (negative and NaN channels give 0).
pub fn display_rgb8(radiance: Vec3, exposure: f32) -> [u8; 3] {
    let l = radiance * exposure;
    let c = |v: f32| (srgb(aces(v.max(0.0))) * 255.0 + 0.5) as u8;
    [c(l.x), c(l.y), c(l.z)]
}

/// Exposure, ACES and sRGB: 8-bit RGB rows, top to bottom.
pub fn tone_map(img: &HdrImage, exposure: f32) -> image::RgbImage {
    let mut out = image::RgbImage::new(img.width, img.height);
    for (i, p) in out.pixels_mut().enumerate() {
        *p = image::Rgb(display_rgb8(img.pixels[i], exposure));
    }
    out
}

/// Writes the tone-mapped image as PNG.
pub fn write_png(img: &HdrImage, exposure: f32, path: &Path) -> crate::Result<()> {
    if let Some(dir) = path.parent().filter(|d| !d.as_os_str().is_empty()) {
        std::fs::create_dir_all(dir).map_err(|source| crate::Error::Io { path: dir.to_path_buf(), source })?;
    }
    tone_map(img, exposure)
        .save_with_format(path, image::ImageFormat::Png)
        .map_err(|e| crate::Error::Io { path: path.to_path_buf(), source: std::io::Error::other(e.to_string()) })
}

/// The renderer: the wgpu rasterizer, or the CPU ray-traced fallback
/// where there is no adapter.
pub struct Renderer(Kind);

enum Kind {
    /// The GPU renderer.
    Gpu(Box<gpu::GpuRenderer>),
    /// No adapter: [`cpu::render_cpu`].
    Cpu,
}

impl Renderer {
    /// The GPU renderer on the first adapter (software ones included), or
    /// the CPU fallback with one line saying so when there is none or it fails.
    pub fn open(backend: crate::gpu::Backend) -> Renderer {
        if backend == crate::gpu::Backend::Cpu {
            log::info!("rendering on the CPU (--backend cpu): ray-traced fallback, hard shadows");
            return Renderer(Kind::Cpu);
        }
        match crate::gpu::open_all().into_iter().next() {
            Some(dev) => match gpu::GpuRenderer::new(dev) {
                Ok(r) => Renderer(Kind::Gpu(Box::new(r))),
                Err(e) => {
                    log::info!("{e}; rendering on the CPU (ray-traced fallback)");
                    Renderer(Kind::Cpu)
                }
            },
            None => {
                log::info!("no graphics adapter: rendering on the CPU (ray-traced fallback, hard shadows)");
                Renderer(Kind::Cpu)
            }
        }
    }

    /// A one-line description: `"gpu: <adapter>"` or `"cpu fallback"`.
    pub fn describe(&self) -> String {
        match &self.0 {
            Kind::Gpu(r) => format!("gpu: {}", r.dev.describe()),
            Kind::Cpu => "cpu fallback".into(),
        }
    }

    /// Renders `frame`; the CPU path builds a wide BVH of the frame's geometry.
    pub fn render(&self, frame: &Frame, params: &RenderParams) -> crate::Result<(HdrImage, RenderStats)> {
        match &self.0 {
            Kind::Gpu(r) => r.render(frame, params),
            Kind::Cpu => cpu::render_cpu(frame, params, None),
        }
    }
}

/// Writes linear radiance, W/(m^2 sr), as an OpenEXR file through the
/// `exr` crate: one RGB layer of 32-bit floats, lossless compression.
pub fn write_exr(img: &HdrImage, path: &Path) -> crate::Result<()> {
    if let Some(dir) = path.parent().filter(|d| !d.as_os_str().is_empty()) {
        std::fs::create_dir_all(dir).map_err(|source| crate::Error::Io { path: dir.to_path_buf(), source })?;
    }
    exr::prelude::write_rgb_file(path, img.width as usize, img.height as usize, |x, y| {
        let p = img.at(x as u32, y as u32);
        (p.x, p.y, p.z)
    })
    .map_err(|e| crate::Error::Io { path: path.to_path_buf(), source: std::io::Error::other(e.to_string()) })
}
