//! What the GPU renderer uploads per frame besides lights and shadow maps:
//! the render mesh ([`RenderVertex`], [`mesh_data`]) and the albedo textures
//! ([`GpuTextures`]).
//!
//! Albedo textures (`shaders/render.wgsl`, `sample_texture`): every image's texels in one storage buffer (linear
//! RGB as two `f16` pairs, 8 bytes a texel, rows from the top) and one
//! [`TextureInfo`] per map (first texel, size, wrap modes, filter), so the
//! shader samples exactly as [`crate::scene::texture::TextureMap::sample`]
//! does on the CPU (same texel centres, wraps, nearest rounding and
//! bilinear weights; texels rounded to `f16`).
//!
//! When the images exceed the device's largest storage buffer, the largest
//! are halved (2x2 box filter, odd edges repeated) until they fit, and a note
//! says so; the CPU fallback keeps them whole.
//!
//! The vertex and index data ([`mesh_data`]): textured triangles get three
//! vertices of their own after the solver vertices, carrying the corner's
//! coordinates, map and factor (in the albedo slot); untextured triangles
//! index the solver vertices as before, with map `NO_MAP`.

use super::Frame;
use crate::gpu::layout::TextureInfo;
use crate::scene::texture::{CornerTextures, Texture, NO_MAP};
use bytemuck::{Pod, Zeroable};
use glam::Vec3;
use std::sync::Arc;
use wgpu::util::DeviceExt;
/// One vertex of the render mesh (84 bytes): `vs_main` locations 0-7.
#[repr(C)]
#[derive(Clone, Copy, Debug, Default, PartialEq, Pod, Zeroable)]
pub struct RenderVertex {
    /// World position, metres.
    pub position: [f32; 3],
    /// Unit normal.
    pub normal: [f32; 3],
    /// Diffuse albedo (or the factor a texture is multiplied with).
    pub albedo: [f32; 3],
    /// Indirect irradiance, W/m^2.
    pub e_indirect: [f32; 3],
    /// Irradiance from the sky, W/m^2.
    pub e_sky: [f32; 3],
    /// Emitted radiance `M_e / pi`, W/(m^2 sr).
    pub emitted: [f32; 3],
    /// Texture coordinates (textured triangles' own vertices).
    pub uv: [f32; 2],
    /// Albedo texture, or `NO_MAP` (then `albedo` is drawn; else it is the
    /// factor the texture is multiplied with).
    pub map: u32,
}

/// The textures of a frame on the device, and what they were made from.
pub struct GpuTextures {
    /// The maps' images and samplers, compared by identity to reuse the buffers.
    key: Vec<(Arc<Texture>, crate::scene::texture::Sampler)>,
    /// The texels of every map, linear RGB.
    pub texels: wgpu::Buffer,
    /// One [`TextureInfo`] per map.
    pub infos: wgpu::Buffer,
}

impl GpuTextures {
    /// Whether these buffers hold `textures` (or the placeholder, for `None`).
    pub fn holds(&self, textures: Option<&CornerTextures>) -> bool {
        let maps = textures.map_or(&[][..], |t| &t.maps[..]);
        self.key.len() == maps.len()
            && self.key.iter().zip(maps).all(|((img, s), m)| Arc::ptr_eq(img, &m.image) && *s == m.sampler)
    }

    /// Uploads the frame's textures (a one-texel placeholder when it has none).
    pub fn new(d: &wgpu::Device, textures: Option<&CornerTextures>, limit: u64) -> GpuTextures {
        let maps = textures.map_or(&[][..], |t| &t.maps[..]);
        // Distinct images, in order of first use.
        let mut images: Vec<Arc<Texture>> = Vec::new();
        let image_of: Vec<usize> = maps
            .iter()
            .map(|m| match images.iter().position(|i| Arc::ptr_eq(i, &m.image)) {
                Some(i) => i,
                None => {
                    images.push(m.image.clone());
                    images.len() - 1
                }
            })
            .collect();
        let bytes = |s: &[Arc<Texture>]| s.iter().map(|t| t.texels().len() as u64 * 8).sum::<u64>();
        let mut sized = images;
        let mut halved = 0;
        while bytes(&sized) > limit {
            let largest = (0..sized.len()).max_by_key(|&i| sized[i].texels().len()).unwrap_or(0);
            if sized[largest].texels().len() <= 1 {
                break;
            }
            sized[largest] = Arc::new(halve(&sized[largest]));
            halved += 1;
        }
        if halved > 0 {
            log::info!(
                "albedo textures exceed the GPU's {} MiB storage buffer: halved {halved} time(s) for display",
                limit >> 20
            );
        }
        let mut texels: Vec<[u32; 2]> = Vec::new();
        let mut first = Vec::with_capacity(sized.len());
        for t in &sized {
            first.push(texels.len() as u32);
            texels.extend(t.texels().iter().map(|c| pack(*c)));
        }
        let mut infos: Vec<TextureInfo> = maps
            .iter()
            .zip(&image_of)
            .map(|(m, &i)| TextureInfo {
                offset: first[i],
                width: sized[i].width(),
                height: sized[i].height(),
                mode: m.sampler.wrap[0].code() | m.sampler.wrap[1].code() << 2 | (m.sampler.nearest as u32) << 4,
            })
            .collect();
        if texels.is_empty() {
            texels.push([0; 2]);
        }
        if infos.is_empty() {
            infos.push(TextureInfo { width: 1, height: 1, ..Default::default() });
        }
        let buffer = |label, contents: &[u8]| {
            d.create_buffer_init(&wgpu::util::BufferInitDescriptor {
                label: Some(label),
                contents,
                usage: wgpu::BufferUsages::STORAGE,
            })
        };
        GpuTextures {
            key: maps.iter().map(|m| (m.image.clone(), m.sampler)).collect(),
            texels: buffer("render texels", bytemuck::cast_slice(&texels)),
            infos: buffer("render texture infos", bytemuck::cast_slice(&infos)),
        }
    }
}

/// Linear RGB as `[pack2x16float(r, g), pack2x16float(b, 0)]`.
fn pack(c: Vec3) -> [u32; 2] {
    let h = |x: f32| half::f16::from_f32(x).to_bits() as u32;
    [h(c.x) | h(c.y) << 16, h(c.z)]
}

/// The image at half its size (each side rounded up), by 2x2 box filtering.
fn halve(t: &Texture) -> Texture {
    let (w, h) = (t.width(), t.height());
    let (nw, nh) = (w.div_ceil(2), h.div_ceil(2));
    let at = |x: u32, y: u32| t.texels()[(y.min(h - 1) * w + x.min(w - 1)) as usize];
    let texels = (0..nh)
        .flat_map(|y| {
            (0..nw).map(move |x| {
                (at(2 * x, 2 * y) + at(2 * x + 1, 2 * y) + at(2 * x, 2 * y + 1) + at(2 * x + 1, 2 * y + 1)) * 0.25
            })
        })
        .collect();
    Texture::from_linear(nw, nh, texels).expect("halved image is well formed")
}

/// The render mesh: vertices (solver vertices, then three per textured
/// triangle) and triangles over them.
pub fn mesh_data(frame: &Frame) -> (Vec<RenderVertex>, Vec<[u32; 3]>) {
    let vertex = |i: usize| RenderVertex {
        position: frame.positions[i].into(),
        normal: frame.normals[i].into(),
        albedo: frame.albedo[i].into(),
        e_indirect: frame.e_indirect[i].into(),
        e_sky: frame.sky_at(i).into(),
        emitted: frame.emitted_at(i).into(),
        uv: [0.0; 2],
        map: NO_MAP,
    };
    let mut verts: Vec<RenderVertex> = (0..frame.positions.len()).map(vertex).collect();
    let Some(tex) = frame.textures else {
        return (verts, frame.triangles.to_vec());
    };
    let triangles = frame
        .triangles
        .iter()
        .enumerate()
        .map(|(ti, t)| {
            let map = tex.triangle_map[ti];
            if map == NO_MAP {
                return *t;
            }
            let first = verts.len() as u32;
            for (k, &v) in t.iter().enumerate() {
                verts.push(RenderVertex {
                    albedo: tex.factor[ti][k].into(),
                    uv: tex.uv[ti][k].into(),
                    map,
                    ..vertex(v as usize)
                });
            }
            [first, first + 1, first + 2]
        })
        .collect();
    (verts, triangles)
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn halving_averages_blocks_and_keeps_odd_edges() {
        let t = Texture::from_linear(3, 1, vec![Vec3::ZERO, Vec3::ONE, Vec3::splat(0.5)]).unwrap();
        let h = halve(&t);
        assert_eq!((h.width(), h.height()), (2, 1));
        assert_eq!(h.texels(), &[Vec3::splat(0.5), Vec3::splat(0.5)]);
    }

    #[test]
    fn packed_texels_round_to_f16() {
        let [a, b] = pack(Vec3::new(1.0, 0.5, 0.25));
        assert_eq!(a & 0xffff, half::f16::from_f32(1.0).to_bits() as u32);
        assert_eq!(a >> 16, half::f16::from_f32(0.5).to_bits() as u32);
        assert_eq!(b, half::f16::from_f32(0.25).to_bits() as u32);
    }
}
