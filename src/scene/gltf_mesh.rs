//! glTF mesh primitives and their base colour, for [`super::gltf`].
//!
//! Each primitive's positions go through the node's world transform
//! (metres); its indices (or `0..n` without any) make triangles by the
//! primitive's mode. Positions that are not finite, before or after the
//! transform, and indices past the primitive's vertices are errors.
//!
//! Albedo (linear RGB, unitless) follows glTF's base colour:
//! `baseColorFactor.rgb * texture(uv).rgb * COLOR_0.rgb`, alpha ignored.
//! The texture is the material's `baseColorTexture`, decoded from sRGB to
//! linear, sampled at each vertex's `TEXCOORD_n` (nearest texel where the
//! sampler's magnification filter says NEAREST, else bilinear between texel
//! centres, with the sampler's wrap modes). Where any primitive of a mesh has
//! a texture or `COLOR_0`, the mesh carries albedo per vertex
//! ([`MeshDesc::vertex_albedo`]); otherwise per material. Albedo outside
//! `[0, MAX_ALBEDO]` is clamped with a warning, a non-finite
//! `baseColorFactor` becomes grey [`DEFAULT_ALBEDO`] with a warning, as in
//! OBJ. A primitive without a material gets [`DEFAULT_ALBEDO`] grey with a
//! warning (deviation: glTF's default material is white, which would be
//! clamped to `MAX_ALBEDO` and make the bounce series stiff).
//!
//! Every accessor is checked (element type, count, byte range within its
//! buffer view, sparse parts likewise) before the crate reads it, since its
//! readers index and unwrap without checking.

use super::obj::DEFAULT_ALBEDO;
use super::{emission, Material, MeshDesc, Transform, MAX_ALBEDO};
use ::gltf::accessor::{DataType, Dimensions};
use ::gltf::mesh::{Mode, Semantic};
use ::gltf::texture::WrappingMode;
use glam::{Mat4, Vec2, Vec3};
use std::collections::{HashMap, HashSet};
use std::path::Path;

type Res<T> = std::result::Result<T, String>;

/// Shared state while reading one file's meshes: its buffers and the
/// textures decoded so far.
pub(super) struct MeshContext<'a> {
    path: &'a Path,
    base: &'a Path,
    buffers: &'a [::gltf::buffer::Data],
    /// Decoded images by image index.
    textures: HashMap<usize, Texture>,
    /// Materials already warned about (emission).
    warned: HashSet<usize>,
}

impl<'a> MeshContext<'a> {
    pub(super) fn new(path: &'a Path, base: &'a Path, buffers: &'a [::gltf::buffer::Data]) -> Self {
        Self { path, base, buffers, textures: HashMap::new(), warned: HashSet::new() }
    }

    fn texture(&mut self, tex: &::gltf::Texture) -> Res<&Texture> {
        let image = tex.source();
        let i = image.index();
        if !self.textures.contains_key(&i) {
            let data = ::gltf::image::Data::from_source(image.source(), Some(self.base), self.buffers)
                .map_err(|e| format!("image {i} could not be decoded: {e}"))?;
            let t = Texture::from_image(&data).map_err(|m| format!("image {i}: {m}"))?;
            self.textures.insert(i, t);
        }
        Ok(&self.textures[&i])
    }
}

/// A decoded base colour image, linear RGB, rows from the top (v = 0).
struct Texture {
    width: usize,
    height: usize,
    texels: Vec<Vec3>,
}

fn srgb_to_linear(c: f32) -> f32 {
    if c <= 0.04045 {
        c / 12.92
    } else {
        ((c + 0.055) / 1.055).powf(2.4)
    }
}

impl Texture {
    fn from_image(data: &::gltf::image::Data) -> Res<Texture> {
        use ::gltf::image::Format::*;
        // (channels, bytes per channel); float images are taken as linear.
        let (channels, size) = match data.format {
            R8 => (1, 1),
            R8G8 => (2, 1),
            R8G8B8 => (3, 1),
            R8G8B8A8 => (4, 1),
            R16 => (1, 2),
            R16G16 => (2, 2),
            R16G16B16 => (3, 2),
            R16G16B16A16 => (4, 2),
            R32G32B32FLOAT => (3, 4),
            R32G32B32A32FLOAT => (4, 4),
        };
        let (width, height) = (data.width as usize, data.height as usize);
        let texel_bytes = channels * size;
        let needed = width.checked_mul(height).and_then(|n| n.checked_mul(texel_bytes));
        if width == 0 || height == 0 || needed.is_none_or(|n| n > data.pixels.len()) {
            return Err(format!("{width}x{height} image has {} bytes of pixels", data.pixels.len()));
        }
        let channel = |b: &[u8]| -> f32 {
            match size {
                1 => srgb_to_linear(b[0] as f32 / 255.0),
                2 => srgb_to_linear(u16::from_ne_bytes([b[0], b[1]]) as f32 / 65535.0),
                _ => f32::from_ne_bytes([b[0], b[1], b[2], b[3]]),
            }
        };
        let texels: Vec<Vec3> = data.pixels[..width * height * texel_bytes]
            .chunks_exact(texel_bytes)
            .map(|t| {
                let c: Vec<f32> = t.chunks_exact(size).map(channel).collect();
                if channels < 3 {
                    Vec3::splat(c[0])
                } else {
                    Vec3::new(c[0], c[1], c[2])
                }
            })
            .collect();
        if let Some(bad) = texels.iter().find(|t| !t.is_finite()) {
            return Err(format!("texel {bad} is not finite"));
        }
        Ok(Texture { width, height, texels })
    }

    fn fetch(&self, x: i64, y: i64, wrap: [WrappingMode; 2]) -> Vec3 {
        fn wrap_index(i: i64, n: usize, mode: WrappingMode) -> usize {
            let n = n as i64;
            (match mode {
                WrappingMode::ClampToEdge => i.clamp(0, n - 1),
                WrappingMode::Repeat => i.rem_euclid(n),
                WrappingMode::MirroredRepeat => {
                    let m = i.rem_euclid(2 * n);
                    if m < n {
                        m
                    } else {
                        2 * n - 1 - m
                    }
                }
            }) as usize
        }
        self.texels[wrap_index(y, self.height, wrap[1]) * self.width + wrap_index(x, self.width, wrap[0])]
    }

    /// Colour at texture coordinates `uv` (finite), texel centres at half-integers.
    fn sample(&self, uv: Vec2, wrap: [WrappingMode; 2], nearest: bool) -> Vec3 {
        let p =
            (uv * Vec2::new(self.width as f32, self.height as f32) - 0.5).clamp(Vec2::splat(-1e9), Vec2::splat(1e9));
        if nearest {
            return self.fetch(p.x.round() as i64, p.y.round() as i64, wrap);
        }
        let f = p.floor();
        let t = p - f;
        let (x, y) = (f.x as i64, f.y as i64);
        let row = |y: i64| self.fetch(x, y, wrap).lerp(self.fetch(x + 1, y, wrap), t.x);
        row(y).lerp(row(y + 1), t.y)
    }
}

/// Checks that `acc` has one of the element `kinds`, at least one element,
/// and that every byte it reads lies inside its buffer views.
fn check_accessor(
    acc: &::gltf::Accessor,
    buffers: &[::gltf::buffer::Data],
    kinds: &[(Dimensions, DataType)],
) -> Res<()> {
    let kind = (acc.dimensions(), acc.data_type());
    if !kinds.contains(&kind) {
        return Err(format!("accessor {} holds {:?} {:?}, expected one of {kinds:?}", acc.index(), kind.0, kind.1));
    }
    if acc.count() == 0 {
        return Err(format!("accessor {} has no elements", acc.index()));
    }
    let elem = acc.size();
    let range = |view: ::gltf::buffer::View, offset: usize, count: usize, elem: usize| -> Res<()> {
        let stride = view.stride().unwrap_or(elem);
        let end = stride.checked_mul(count - 1).and_then(|n| n.checked_add(elem)).and_then(|n| n.checked_add(offset));
        let in_buffer =
            view.offset().checked_add(view.length()).is_some_and(|e| e <= buffers[view.buffer().index()].len());
        if stride < elem || !in_buffer || end.is_none_or(|e| e > view.length()) {
            return Err(format!(
                "accessor {} ({count} elements of {elem} bytes, stride {stride}, offset {offset}) reaches past the end of buffer view {} ({} bytes)",
                acc.index(),
                view.index(),
                view.length()
            ));
        }
        Ok(())
    };
    if let Some(view) = acc.view() {
        range(view, acc.offset(), acc.count(), elem)?;
    }
    if let Some(sparse) = acc.sparse() {
        let n = sparse.count();
        if n == 0 {
            return Err(format!("accessor {} has an empty sparse part", acc.index()));
        }
        let idx = sparse.indices();
        range(idx.view(), idx.offset(), n, idx.index_type().size())?;
        let values = sparse.values();
        range(values.view(), values.offset(), n, elem)?;
    }
    Ok(())
}

/// Clamps `a` into `[0, MAX_ALBEDO]`; true if it changed.
fn clamp_albedo(a: &mut Vec3) -> bool {
    let c = a.clamp(Vec3::ZERO, Vec3::splat(MAX_ALBEDO));
    std::mem::replace(a, c) != c
}

/// Builds the mesh of one node (`None` if it has no triangles). Errors name
/// the mesh and primitive; the caller adds file and node.
pub(super) fn build_mesh(
    cx: &mut MeshContext,
    mesh: &::gltf::Mesh,
    world: Mat4,
    name: String,
    warnings: &mut Vec<String>,
) -> Res<Option<MeshDesc>> {
    let file = cx.path.display().to_string();
    let flip = world.determinant() < 0.0;
    let per_vertex = mesh.primitives().any(|p| {
        p.get(&Semantic::Colors(0)).is_some() || p.material().pbr_metallic_roughness().base_color_texture().is_some()
    });
    if mesh.weights().is_some() || mesh.primitives().any(|p| p.morph_targets().next().is_some()) {
        warnings.push(format!("{file}: mesh {}: morph targets are ignored", mesh.index()));
    }
    let mut positions: Vec<Vec3> = Vec::new();
    let mut vertex_albedo: Vec<Vec3> = Vec::new();
    let mut triangles: Vec<[u32; 3]> = Vec::new();
    let mut triangle_material = Vec::new();
    let mut materials: Vec<Material> = Vec::new();
    let mut material_of: HashMap<Option<usize>, u32> = HashMap::new();
    // Primitives sharing a POSITION accessor share vertices (per-material albedo only).
    let mut shared: HashMap<usize, (u32, u32)> = HashMap::new();
    for prim in mesh.primitives() {
        let at = |m: String| format!("mesh {} primitive {}: {m}", mesh.index(), prim.index());
        let mode = prim.mode();
        if !matches!(mode, Mode::Triangles | Mode::TriangleStrip | Mode::TriangleFan) {
            return Err(at(format!(
                "mode {mode:?} is not a triangle mode (TRIANGLES, TRIANGLE_STRIP and TRIANGLE_FAN are read)"
            )));
        }
        let gmat = prim.material();
        let factor = material_factor(cx, &gmat, warnings);
        let mi = match material_of.get(&gmat.index()) {
            Some(&i) => i,
            None => {
                let mut albedo = factor;
                if clamp_albedo(&mut albedo) && !per_vertex {
                    warnings.push(format!(
                        "{file}: material '{}' has baseColorFactor {factor} outside [0, {MAX_ALBEDO}]; clamped to {albedo}",
                        material_name(&gmat)
                    ));
                }
                materials.push(Material { name: material_name(&gmat), albedo, emission: emission_of(&gmat) });
                material_of.insert(gmat.index(), (materials.len() - 1) as u32);
                (materials.len() - 1) as u32
            }
        };
        let buffers = cx.buffers;
        let reader = prim.reader(|b| buffers.get(b.index()).map(|d| &d.0[..]));
        let pos_acc = prim.get(&Semantic::Positions).ok_or_else(|| at("has no POSITION".into()))?;
        check_accessor(&pos_acc, buffers, &[(Dimensions::Vec3, DataType::F32)])
            .map_err(|m| at(format!("POSITION: {m}")))?;
        let (base, n) = match shared.get(&pos_acc.index()) {
            Some(&bn) if !per_vertex => bn,
            _ => {
                let base = positions.len() as u32;
                let read = reader.read_positions().ok_or_else(|| at("POSITION could not be read".into()))?;
                for (i, p) in read.enumerate() {
                    let p = Vec3::from(p);
                    let w = world.transform_point3(p);
                    if !p.is_finite() || !w.is_finite() {
                        return Err(at(format!("vertex {i} has position {p}, {w} in the world: not finite")));
                    }
                    positions.push(w);
                }
                let n = positions.len() as u32 - base;
                if n as usize != pos_acc.count() {
                    return Err(at(format!("POSITION gave {n} of its {} vertices", pos_acc.count())));
                }
                if per_vertex {
                    vertex_albedo
                        .extend(primitive_albedo(cx, &prim, &reader, factor, n as usize, warnings).map_err(at)?);
                }
                shared.insert(pos_acc.index(), (base, n));
                (base, n)
            }
        };
        let indices: Vec<u32> = match prim.indices() {
            Some(acc) => {
                let kinds = [DataType::U8, DataType::U16, DataType::U32].map(|t| (Dimensions::Scalar, t));
                check_accessor(&acc, buffers, &kinds).map_err(|m| at(format!("indices: {m}")))?;
                reader.read_indices().ok_or_else(|| at("indices could not be read".into()))?.into_u32().collect()
            }
            None => (0..n).collect(),
        };
        if let Some((k, &bad)) = indices.iter().enumerate().find(|(_, &i)| i >= n) {
            return Err(at(format!("index {k} is {bad}, out of range (the primitive has {n} vertices)")));
        }
        let tris: Vec<[u32; 3]> = match mode {
            Mode::TriangleStrip => (0..indices.len().saturating_sub(2))
                .map(|i| {
                    let t = [indices[i], indices[i + 1], indices[i + 2]];
                    if i % 2 == 0 {
                        t
                    } else {
                        [t[1], t[0], t[2]]
                    }
                })
                .collect(),
            Mode::TriangleFan => {
                (1..indices.len().saturating_sub(1)).map(|i| [indices[0], indices[i], indices[i + 1]]).collect()
            }
            _ => {
                if !indices.len().is_multiple_of(3) {
                    return Err(at(format!("{} indices are not a whole number of triangles", indices.len())));
                }
                indices.chunks_exact(3).map(|t| [t[0], t[1], t[2]]).collect()
            }
        };
        for t in tris {
            let t = if flip { [t[0], t[2], t[1]] } else { t };
            triangles.push(t.map(|i| base + i));
            triangle_material.push(mi);
        }
    }
    if triangles.is_empty() {
        return Ok(None);
    }
    Ok(Some(MeshDesc {
        name,
        positions,
        triangles,
        triangle_material,
        materials,
        vertex_albedo: per_vertex.then_some(vertex_albedo),
        crease_angle_deg: 30.0,
        transform: Transform::default(),
        dynamic: false,
        deform: Vec::new(),
        source: Some(cx.path.to_path_buf()),
    }))
}

fn material_name(m: &::gltf::Material) -> String {
    match (m.name(), m.index()) {
        (Some(n), _) => n.to_string(),
        (None, Some(i)) => format!("material{i}"),
        (None, None) => "default".to_string(),
    }
}

/// Radiant exitance of a glTF material, W/m^2: its emitted radiance
/// `emissiveFactor * emissive_strength` (KHR_materials_emissive_strength,
/// default 1) taken as W/(m^2 sr), through [`emission::exitance`]. Zero
/// when not finite and non-negative (warned by [`material_factor`]).
fn emission_of(m: &::gltf::Material) -> Vec3 {
    let e = emission::exitance(Vec3::from(m.emissive_factor()) * m.emissive_strength().unwrap_or(1.0));
    if e.is_finite() && e.min_element() >= 0.0 {
        e
    } else {
        Vec3::ZERO
    }
}

/// The material's `baseColorFactor` (rgb), before clamping; warns about
/// emission and about fallbacks.
fn material_factor(cx: &mut MeshContext, m: &::gltf::Material, warnings: &mut Vec<String>) -> Vec3 {
    let file = cx.path.display();
    let Some(index) = m.index() else {
        if cx.warned.insert(usize::MAX) {
            warnings.push(format!("{file}: primitives without a material get grey albedo {DEFAULT_ALBEDO}"));
        }
        return Vec3::splat(DEFAULT_ALBEDO);
    };
    let first = cx.warned.insert(index);
    if first && m.emissive_texture().is_some() {
        warnings.push(format!(
            "{file}: material '{}' has an emissiveTexture, which is ignored (emission is uniform per material: emissiveFactor)",
            material_name(m),
        ));
    }
    if first && emission_of(m) == Vec3::ZERO && Vec3::from(m.emissive_factor()) != Vec3::ZERO {
        warnings.push(format!(
            "{file}: material '{}' has emissiveFactor {:?} x strength {:?}, not finite and non-negative; using 0",
            material_name(m),
            m.emissive_factor(),
            m.emissive_strength()
        ));
    }
    let c = m.pbr_metallic_roughness().base_color_factor();
    let factor = Vec3::new(c[0], c[1], c[2]);
    if !factor.is_finite() {
        if first {
            warnings.push(format!(
                "{file}: material '{}' has non-finite baseColorFactor {factor}; using {DEFAULT_ALBEDO}",
                material_name(m)
            ));
        }
        return Vec3::splat(DEFAULT_ALBEDO);
    }
    factor
}

/// Albedo of each of the primitive's `n` vertices (clamped, with a warning).
fn primitive_albedo<'a, 's, F>(
    cx: &mut MeshContext,
    prim: &::gltf::Primitive,
    reader: &::gltf::mesh::Reader<'a, 's, F>,
    factor: Vec3,
    n: usize,
    warnings: &mut Vec<String>,
) -> Res<Vec<Vec3>>
where
    F: Clone + Fn(::gltf::Buffer<'a>) -> Option<&'s [u8]>,
{
    let mut out = vec![factor; n];
    let material = prim.material();
    if let Some(info) = material.pbr_metallic_roughness().base_color_texture() {
        let set = info.tex_coord();
        match prim.get(&Semantic::TexCoords(set)) {
            None => warnings.push(format!(
                "{}: mesh primitive {}: its base colour texture uses TEXCOORD_{set}, which it lacks; using baseColorFactor",
                cx.path.display(),
                prim.index()
            )),
            Some(acc) => {
                let kinds = [DataType::F32, DataType::U8, DataType::U16].map(|t| (Dimensions::Vec2, t));
                check_accessor(&acc, cx.buffers, &kinds).map_err(|m| format!("TEXCOORD_{set}: {m}"))?;
                let uvs: Vec<[f32; 2]> = reader
                    .read_tex_coords(set)
                    .ok_or_else(|| format!("TEXCOORD_{set} could not be read"))?
                    .into_f32()
                    .collect();
                if uvs.len() != n {
                    return Err(format!("TEXCOORD_{set} has {} elements for {n} vertices", uvs.len()));
                }
                let texture = info.texture();
                let sampler = texture.sampler();
                let wrap = [sampler.wrap_s(), sampler.wrap_t()];
                let nearest = sampler.mag_filter() == Some(::gltf::texture::MagFilter::Nearest);
                let tex = cx.texture(&texture)?;
                for (i, (o, uv)) in out.iter_mut().zip(uvs).enumerate() {
                    let uv = Vec2::from(uv);
                    if !uv.is_finite() {
                        return Err(format!("vertex {i} has non-finite texture coordinates {uv}"));
                    }
                    *o *= tex.sample(uv, wrap, nearest);
                }
            }
        }
    }
    if let Some(acc) = prim.get(&Semantic::Colors(0)) {
        let kinds = [Dimensions::Vec3, Dimensions::Vec4]
            .into_iter()
            .flat_map(|d| [DataType::F32, DataType::U8, DataType::U16].map(|t| (d, t)))
            .collect::<Vec<_>>();
        check_accessor(&acc, cx.buffers, &kinds).map_err(|m| format!("COLOR_0: {m}"))?;
        let colours = reader.read_colors(0).ok_or_else(|| "COLOR_0 could not be read".to_string())?.into_rgba_f32();
        let mut count = 0;
        for (i, (o, c)) in out.iter_mut().zip(colours).enumerate() {
            let c = Vec3::new(c[0], c[1], c[2]);
            if !c.is_finite() {
                return Err(format!("vertex {i} has non-finite COLOR_0 {c}"));
            }
            *o *= c;
            count += 1;
        }
        if count != n {
            return Err(format!("COLOR_0 has {count} elements for {n} vertices"));
        }
    }
    let clamped = out.iter_mut().map(clamp_albedo).filter(|&c| c).count();
    if clamped > 0 {
        warnings.push(format!(
            "{}: mesh primitive {}: {clamped} of {n} vertices have albedo outside [0, {MAX_ALBEDO}]; clamped",
            cx.path.display(),
            prim.index()
        ));
    }
    Ok(out)
}
