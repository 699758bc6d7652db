//! glTF mesh primitives, their base colour and emission, for [`super::gltf`].
//!
//! Each primitive's positions go through the node's world transform
//! (metres); its indices (or `0..n` without any) make triangles by the
//! primitive's mode. Positions that are not finite, before or after the
//! transform, and indices past the primitive's vertices are errors.
//!
//! Albedo (linear RGB, unitless) follows glTF's base colour:
//! `baseColorFactor.rgb * texture(uv).rgb * COLOR_0.rgb`, alpha ignored.
//! The texture is the material's `baseColorTexture`, decoded and sampled by
//! [`super::texture`] (sRGB to linear; nearest texel where the sampler's
//! magnification filter says NEAREST, else bilinear, with the sampler's wrap
//! modes) at each vertex's `TEXCOORD_n`. Where any primitive of a mesh has a
//! texture, `COLOR_0` or an emissive texture, the mesh carries albedo per
//! vertex ([`MeshDesc::vertex_albedo`]); otherwise per material. Textured
//! primitives also keep their texture, coordinates and
//! `baseColorFactor * COLOR_0` per vertex ([`MeshDesc::textures`]) for the
//! renderer's per-pixel albedo. Albedo outside `[0, MAX_ALBEDO]` is clamped
//! with a warning, a non-finite `baseColorFactor` becomes grey
//! [`DEFAULT_ALBEDO`] with a warning, as in OBJ. A primitive without a
//! material gets [`DEFAULT_ALBEDO`] grey with a warning (deviation: glTF's
//! default material is white, which would be clamped to `MAX_ALBEDO` and
//! make the bounce series stiff).
//!
//! Emission: [`emission_of`] the material (`emissiveFactor` times
//! `KHR_materials_emissive_strength`, as exitance) times its
//! `emissiveTexture` (sRGB, sampled like the base colour at its own
//! `TEXCOORD_n`) per vertex, [`MeshDesc::vertex_emission`], where any
//! primitive of the mesh has an emissive texture; otherwise per material.
//!
//! Every accessor is checked (element type, count, byte range within its
//! buffer view, sparse parts likewise) before the crate reads it, since its
//! readers index and unwrap without checking.

use super::obj::DEFAULT_ALBEDO;
use super::texture::{MeshTextures, Sampler, Texture, TextureMap, Wrap, NO_MAP};
use super::{emission, Material, MeshDesc, Transform, MAX_ALBEDO};
use ::gltf::accessor::{DataType, Dimensions};
use ::gltf::mesh::{Mode, Semantic};
use ::gltf::texture::WrappingMode;
use glam::{Mat4, Vec2, Vec3};
use std::collections::{HashMap, HashSet};
use std::path::Path;
use std::sync::Arc;

type Res<T> = std::result::Result<T, String>;

/// Shared state while reading one file's meshes: its buffers and the
/// textures decoded so far.
pub(super) struct MeshContext<'a> {
    path: &'a Path,
    base: &'a Path,
    buffers: &'a [::gltf::buffer::Data],
    /// Decoded images by image index.
    images: HashMap<usize, Arc<Texture>>,
    /// Materials already warned about (emission, fallbacks).
    warned: HashSet<usize>,
}

impl<'a> MeshContext<'a> {
    pub(super) fn new(path: &'a Path, base: &'a Path, buffers: &'a [::gltf::buffer::Data]) -> Self {
        Self { path, base, buffers, images: HashMap::new(), warned: HashSet::new() }
    }

    /// The texture's image (decoded once per file) with its sampler.
    fn map(&mut self, tex: &::gltf::Texture) -> Res<TextureMap> {
        let image = tex.source();
        let i = image.index();
        if !self.images.contains_key(&i) {
            let data = ::gltf::image::Data::from_source(image.source(), Some(self.base), self.buffers)
                .map_err(|e| format!("image {i} could not be decoded: {e}"))?;
            let t = decode_image(&data).map_err(|m| format!("image {i}: {m}"))?;
            self.images.insert(i, Arc::new(t));
        }
        let s = tex.sampler();
        let wrap = |w: WrappingMode| match w {
            WrappingMode::ClampToEdge => Wrap::ClampToEdge,
            WrappingMode::Repeat => Wrap::Repeat,
            WrappingMode::MirroredRepeat => Wrap::MirroredRepeat,
        };
        let sampler = Sampler {
            wrap: [wrap(s.wrap_s()), wrap(s.wrap_t())],
            nearest: s.mag_filter() == Some(::gltf::texture::MagFilter::Nearest),
        };
        Ok(TextureMap { image: self.images[&i].clone(), sampler })
    }
}

/// A glTF image's pixels as a [`Texture`] (8 and 16 bits sRGB, floats linear).
fn decode_image(data: &::gltf::image::Data) -> Res<Texture> {
    use ::gltf::image::Format::*;
    // (channels, bytes per channel).
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
    Texture::from_pixels(data.width, data.height, channels, size, &data.pixels)
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
    let emissive_texture = mesh.primitives().any(|p| p.material().emissive_texture().is_some());
    let per_vertex = emissive_texture
        || mesh.primitives().any(|p| {
            p.get(&Semantic::Colors(0)).is_some()
                || p.material().pbr_metallic_roughness().base_color_texture().is_some()
        });
    if mesh.weights().is_some() || mesh.primitives().any(|p| p.morph_targets().next().is_some()) {
        warnings.push(format!("{file}: mesh {}: morph targets are ignored", mesh.index()));
    }
    let mut positions: Vec<Vec3> = Vec::new();
    let mut vertex_albedo: Vec<Vec3> = Vec::new();
    let mut vertex_emission: Vec<Vec3> = Vec::new();
    let mut textures = MeshTextures { maps: Vec::new(), triangle_map: Vec::new(), uv: Vec::new(), factor: Vec::new() };
    // Maps by glTF texture index.
    let mut map_of: HashMap<usize, u32> = HashMap::new();
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
        let mut prim_map = NO_MAP;
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
                    let s = primitive_surface(cx, &prim, &reader, factor, n as usize, warnings).map_err(at)?;
                    vertex_albedo.extend(s.albedo);
                    vertex_emission.extend(s.emission);
                    textures.factor.extend(s.factor);
                    match s.texture {
                        Some((index, map, uv)) => {
                            prim_map = *map_of.entry(index).or_insert_with(|| {
                                textures.maps.push(map);
                                textures.maps.len() as u32 - 1
                            });
                            textures.uv.extend(uv);
                        }
                        None => textures.uv.extend(std::iter::repeat_n(Vec2::ZERO, n as usize)),
                    }
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
            textures.triangle_map.push(prim_map);
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
        vertex_emission: emissive_texture.then_some(vertex_emission),
        textures: (!textures.maps.is_empty()).then_some(textures),
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

/// What a primitive's vertices carry besides positions, in a mesh with
/// per-vertex values.
struct Surface {
    /// Albedo, clamped.
    albedo: Vec<Vec3>,
    /// Radiant exitance, W/m^2.
    emission: Vec<Vec3>,
    /// `baseColorFactor * COLOR_0`.
    factor: Vec<Vec3>,
    /// The base colour texture (glTF texture index, map) and its coordinates.
    texture: Option<(usize, TextureMap, Vec<Vec2>)>,
}

/// Texture coordinates `TEXCOORD_set` of the primitive's `n` vertices, or
/// `None` with a warning when it has none (`what` names the texture).
fn read_uv<'a, 's, F>(
    cx: &MeshContext,
    prim: &::gltf::Primitive,
    reader: &::gltf::mesh::Reader<'a, 's, F>,
    set: u32,
    n: usize,
    what: &str,
    warnings: &mut Vec<String>,
) -> Res<Option<Vec<Vec2>>>
where
    F: Clone + Fn(::gltf::Buffer<'a>) -> Option<&'s [u8]>,
{
    let Some(acc) = prim.get(&Semantic::TexCoords(set)) else {
        warnings.push(format!(
            "{}: mesh primitive {}: its {what} texture uses TEXCOORD_{set}, which it lacks; using the factor alone",
            cx.path.display(),
            prim.index()
        ));
        return Ok(None);
    };
    let kinds = [DataType::F32, DataType::U8, DataType::U16].map(|t| (Dimensions::Vec2, t));
    check_accessor(&acc, cx.buffers, &kinds).map_err(|m| format!("TEXCOORD_{set}: {m}"))?;
    let uvs: Vec<Vec2> = reader
        .read_tex_coords(set)
        .ok_or_else(|| format!("TEXCOORD_{set} could not be read"))?
        .into_f32()
        .map(Vec2::from)
        .collect();
    if uvs.len() != n {
        return Err(format!("TEXCOORD_{set} has {} elements for {n} vertices", uvs.len()));
    }
    if let Some(i) = uvs.iter().position(|uv| !uv.is_finite()) {
        return Err(format!("vertex {i} has non-finite texture coordinates {}", uvs[i]));
    }
    Ok(Some(uvs))
}

/// Albedo (clamped, with a warning), emission and texture of each of the
/// primitive's `n` vertices.
fn primitive_surface<'a, 's, F>(
    cx: &mut MeshContext,
    prim: &::gltf::Primitive,
    reader: &::gltf::mesh::Reader<'a, 's, F>,
    factor: Vec3,
    n: usize,
    warnings: &mut Vec<String>,
) -> Res<Surface>
where
    F: Clone + Fn(::gltf::Buffer<'a>) -> Option<&'s [u8]>,
{
    let material = prim.material();
    let mut base = vec![factor; n];
    if let Some(acc) = prim.get(&Semantic::Colors(0)) {
        let kinds = [Dimensions::Vec3, Dimensions::Vec4]
            .into_iter()
            .flat_map(|d| [DataType::F32, DataType::U8, DataType::U16].map(|t| (d, t)))
            .collect::<Vec<_>>();
        check_accessor(&acc, cx.buffers, &kinds).map_err(|m| format!("COLOR_0: {m}"))?;
        let colours = reader.read_colors(0).ok_or_else(|| "COLOR_0 could not be read".to_string())?.into_rgba_f32();
        let mut count = 0;
        for (i, (o, c)) in base.iter_mut().zip(colours).enumerate() {
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
    let mut albedo = base.clone();
    let mut texture = None;
    if let Some(info) = material.pbr_metallic_roughness().base_color_texture() {
        if let Some(uv) = read_uv(cx, prim, reader, info.tex_coord(), n, "base colour", warnings)? {
            let map = cx.map(&info.texture())?;
            for (a, (b, u)) in albedo.iter_mut().zip(base.iter().zip(&uv)) {
                *a = map.albedo(*u, *b);
            }
            texture = Some((info.texture().index(), map, uv));
        }
    }
    let clamped = albedo.iter_mut().map(clamp_albedo).filter(|&c| c).count();
    if clamped > 0 {
        warnings.push(format!(
            "{}: mesh primitive {}: {clamped} of {n} vertices have albedo outside [0, {MAX_ALBEDO}]; clamped",
            cx.path.display(),
            prim.index()
        ));
    }
    let exitance = emission_of(&material);
    let mut emission = vec![exitance; n];
    if let Some(info) = material.emissive_texture().filter(|_| exitance != Vec3::ZERO) {
        if let Some(uv) = read_uv(cx, prim, reader, info.tex_coord(), n, "emissive", warnings)? {
            let map = cx.map(&info.texture())?;
            for (e, u) in emission.iter_mut().zip(&uv) {
                *e = map.albedo(*u, exitance).max(Vec3::ZERO);
            }
        }
    }
    Ok(Surface { albedo, emission, factor: base, texture })
}
