//! Wavefront OBJ/MTL meshes: reading through `tobj` and writing back out.
//!
//! Never `single_index`, which duplicates vertices per corner attribute and
//! disconnects faces (breaking one-rings). Deviation: `tobj`'s
//! `merge_identical_points` needs a nightly compiler (its `merging` feature
//! uses `generic_const_exprs`), so positions are kept as indexed in the file
//! and [`super::prep`] welds corners by exact position, which joins the same
//! faces that option would.
//!
//! `Kd` is the diffuse albedo; `Ke` the emitted radiance, W/(m^2 sr), read
//! as exitance `pi Ke` ([`super::emission`]; the loader adds a note saying
//! so for every MTL with an emitting material, and [`write_obj`] writes
//! `Ke = M / pi` back). With a `map_Kd` texture ([`super::texture`], path
//! relative to the MTL file; a line with options such as `-bm` takes its
//! last word as the file) the albedo of a vertex is `Kd` (1 where the MTL
//! gives none) times the texture at the vertex's coordinates, clamped to
//! `[0, MAX_ALBEDO]` ([`MeshDesc::vertex_albedo`]), and the texture is kept
//! for the renderer's per-pixel albedo ([`MeshDesc::textures`]). OBJ texture
//! coordinates have `v` up (origin at the image's bottom-left): they are read
//! as `(u, 1 - v)`, the top-left origin of [`super::texture`]. A position
//! used with several texture coordinates becomes one position per pair (the
//! preparation welds them again by position and splits only where the
//! albedo differs). A texture that is missing or unreadable, or faces
//! without texture coordinates, fall back to `Kd` with a warning naming the
//! MTL file (or OBJ), material and texture. Fallbacks, each reported as a warning: an MTL
//! that is missing or unreadable gives grey albedo [`DEFAULT_ALBEDO`]; faces
//! without a material get the same; albedo above [`MAX_ALBEDO`] or below 0 is
//! clamped. Non-finite coordinates and out-of-range face indices are errors
//! naming the file and line (found by a pre-scan of the text, since `tobj`
//! does not report lines). An MTL colour line (`Ka`, `Kd`, `Ks`, `Ke`)
//! without three numbers makes its library unreadable (the warning names the
//! MTL file and line): `tobj` would panic on it.

use super::texture::{MeshTextures, Sampler, Texture, TextureMap, NO_MAP};
use super::{emission, Material, MeshDesc, Transform, MAX_ALBEDO};
use crate::{Error, Result};
use glam::{Vec2, Vec3};
use std::collections::HashMap;
use std::fmt::Write as _;
use std::path::{Path, PathBuf};
use std::sync::Arc;

/// Albedo used where an OBJ names no usable material.
pub const DEFAULT_ALBEDO: f32 = 0.5;

fn geometry_err(path: &Path, line: Option<usize>, message: impl Into<String>) -> Error {
    Error::Geometry { source_name: path.display().to_string(), line, message: message.into() }
}

/// Checks vertex coordinates and face indices line by line.
fn prescan(path: &Path, text: &str) -> Result<()> {
    let mut vertex_count: i64 = 0;
    // Positive face indices may refer forward; check them once the total is known.
    let mut positive_refs: Vec<(usize, i64)> = Vec::new();
    for (i, line) in text.lines().enumerate() {
        let line_no = i + 1;
        let mut parts = line.split_whitespace();
        match parts.next() {
            Some("v") => {
                let coords: Vec<&str> = parts.take(3).collect();
                if coords.len() < 3 {
                    return Err(geometry_err(path, Some(line_no), "vertex has fewer than 3 coordinates"));
                }
                for c in coords {
                    match c.parse::<f32>() {
                        Ok(x) if x.is_finite() => {}
                        Ok(x) => {
                            return Err(geometry_err(
                                path,
                                Some(line_no),
                                format!("vertex coordinate {x} is not finite"),
                            ))
                        }
                        Err(_) => {
                            return Err(geometry_err(
                                path,
                                Some(line_no),
                                format!("vertex coordinate '{c}' is not a number"),
                            ))
                        }
                    }
                }
                vertex_count += 1;
            }
            Some("vt") => {
                for c in parts.take(3) {
                    if !c.parse::<f32>().is_ok_and(f32::is_finite) {
                        return Err(geometry_err(
                            path,
                            Some(line_no),
                            format!("texture coordinate '{c}' is not a finite number"),
                        ));
                    }
                }
            }
            Some("f") => {
                let mut corners = 0;
                for corner in parts {
                    corners += 1;
                    let idx = corner.split('/').next().unwrap_or("");
                    let Ok(idx) = idx.parse::<i64>() else {
                        return Err(geometry_err(
                            path,
                            Some(line_no),
                            format!("face index '{corner}' is not an integer"),
                        ));
                    };
                    if idx == 0 {
                        return Err(geometry_err(path, Some(line_no), "face index 0 (OBJ indices start at 1)"));
                    }
                    if idx < 0 && -idx > vertex_count {
                        return Err(geometry_err(
                            path,
                            Some(line_no),
                            format!(
                                "relative face index {idx} reaches before the first vertex ({vertex_count} so far)"
                            ),
                        ));
                    }
                    if idx > 0 {
                        positive_refs.push((line_no, idx));
                    }
                }
                if corners < 3 {
                    return Err(geometry_err(
                        path,
                        Some(line_no),
                        format!("face has {corners} corners (needs 3 or more)"),
                    ));
                }
            }
            _ => {}
        }
    }
    if let Some(&(line, idx)) = positive_refs.iter().find(|&&(_, idx)| idx > vertex_count) {
        return Err(geometry_err(
            path,
            Some(line),
            format!("face index {idx} is out of range (the file has {vertex_count} vertices)"),
        ));
    }
    Ok(())
}

/// Finds an MTL colour line that `tobj` cannot parse (it panics on fewer
/// than three numbers); `path:line: problem`.
fn mtl_prescan(path: &Path, text: &str) -> std::result::Result<(), String> {
    for (i, line) in text.lines().enumerate() {
        let mut words = line.split_whitespace();
        if let Some(key @ ("Ka" | "Kd" | "Ks" | "Ke")) = words.next() {
            if words.take(3).filter(|w| w.parse::<f32>().is_ok()).count() < 3 {
                return Err(format!("{}:{}: {key} needs three numbers", path.display(), i + 1));
            }
        }
    }
    Ok(())
}

fn clamp_albedo(path: &Path, name: &str, kd: Vec3, warnings: &mut Vec<String>) -> Vec3 {
    if !kd.is_finite() {
        warnings.push(format!("{}: material '{name}' has non-finite Kd {kd}; using {DEFAULT_ALBEDO}", path.display()));
        return Vec3::splat(DEFAULT_ALBEDO);
    }
    let c = kd.clamp(Vec3::ZERO, Vec3::splat(MAX_ALBEDO));
    if c != kd {
        warnings.push(format!(
            "{}: material '{name}' has Kd {kd} outside [0, {MAX_ALBEDO}]; clamped to {c}",
            path.display()
        ));
    }
    c
}

/// MTL `Ke` (emitted radiance, W/(m^2 sr)) as radiant exitance `pi Ke`
/// (W/m^2, [`emission::exitance`]): non-finite or negative values are
/// replaced by zero with a warning naming the file and material.
fn checked_emission(path: &Path, name: &str, ke: Vec3, warnings: &mut Vec<String>) -> Vec3 {
    if ke.is_finite() && ke.min_element() >= 0.0 {
        return emission::exitance(ke);
    }
    warnings.push(format!(
        "{}: material '{name}' has Ke {ke} (emission must be finite and non-negative); using 0",
        path.display()
    ));
    Vec3::ZERO
}

/// The `map_Kd` of each material, read once per file into `maps`: the
/// map's index and the factor it multiplies (`Kd`, 1 where absent, clamped
/// to [0, 1]); `None` where there is none or it cannot be read (a warning
/// naming the MTL file, material and texture).
fn diffuse_maps(
    obj: &Path,
    materials: &[tobj::Material],
    libraries: &[(PathBuf, usize)],
    maps: &mut Vec<TextureMap>,
    warnings: &mut Vec<String>,
) -> Vec<Option<(u32, Vec3)>> {
    let mut read: HashMap<PathBuf, Option<u32>> = HashMap::new();
    // The MTL file of material `i` (libraries are merged in order).
    let library = |i: usize| {
        let mut first = 0;
        for (file, count) in libraries {
            if i < first + count {
                return file.clone();
            }
            first += count;
        }
        obj.to_path_buf()
    };
    materials
        .iter()
        .enumerate()
        .map(|(i, m)| {
            let name = m.diffuse_texture.as_deref().map(str::trim).filter(|t| !t.is_empty())?;
            // Options (`-bm 1 file.png`) come before the file name.
            let file = if name.starts_with('-') { name.split_whitespace().last().unwrap_or(name) } else { name };
            let mtl = library(i);
            let full = mtl.parent().unwrap_or(Path::new(".")).join(file.replace('\\', "/"));
            let map = read.entry(full.clone()).or_insert_with(|| match Texture::open(&full) {
                Ok(t) => {
                    maps.push(TextureMap { image: Arc::new(t), sampler: Sampler::default() });
                    Some(maps.len() as u32 - 1)
                }
                Err(why) => {
                    warnings.push(format!(
                        "{}: material '{}': map_Kd '{file}' ({}) {why}; using Kd",
                        mtl.display(),
                        m.name,
                        full.display()
                    ));
                    None
                }
            });
            let map = (*map)?;
            let kd = Vec3::from(m.diffuse.unwrap_or([1.0; 3]));
            let kd = if kd.is_finite() { kd.clamp(Vec3::ZERO, Vec3::ONE) } else { Vec3::ONE };
            Some((map, kd))
        })
        .collect()
}

/// Loads an OBJ (and its MTL) as one mesh. Settings from the scene file
/// (crease angle, transform, dynamic) are left at defaults for the caller.
/// Problems worked around go to `warnings`, what was assumed (how `Ke` was
/// read) to `notes`.
pub fn load_obj(path: &Path, warnings: &mut Vec<String>, notes: &mut Vec<String>) -> Result<MeshDesc> {
    let text = std::fs::read_to_string(path).map_err(|source| Error::Io { path: path.to_path_buf(), source })?;
    prescan(path, &text)?;
    let options = tobj::LoadOptions {
        triangulate: true,
        single_index: false,
        ignore_points: true,
        ignore_lines: true,
        ..Default::default()
    };
    let dir = path.parent().unwrap_or(Path::new(".")).to_path_buf();
    let mut reader = std::io::BufReader::new(text.as_bytes());
    let mtl_problem = std::cell::RefCell::new(None);
    let mtl_files = std::cell::RefCell::new(Vec::new());
    // The MTL files read, in order, with their material counts.
    let libraries = std::cell::RefCell::new(Vec::<(PathBuf, usize)>::new());
    let (models, materials) = tobj::load_obj_buf(&mut reader, &options, |mtl| {
        let full = dir.join(mtl);
        mtl_files.borrow_mut().push(full.display().to_string());
        let text = std::fs::read_to_string(&full).map_err(|_| tobj::LoadError::OpenFileFailed)?;
        if let Err(problem) = mtl_prescan(&full, &text) {
            *mtl_problem.borrow_mut() = Some(problem);
            return Err(tobj::LoadError::MaterialParseError);
        }
        let loaded = tobj::load_mtl_buf(&mut text.as_bytes())?;
        libraries.borrow_mut().push((full, loaded.0.len()));
        Ok(loaded)
    })
    .map_err(|e| Error::Obj { path: path.to_path_buf(), message: e.to_string() })?;

    let mut maps: Vec<TextureMap> = Vec::new();
    // Per material: its map_Kd (index into `maps`) and the factor it multiplies.
    let mut textured: Vec<Option<(u32, Vec3)>> = Vec::new();
    let mut mats: Vec<Material> = match materials {
        Ok(ms) => {
            textured = diffuse_maps(path, &ms, &libraries.borrow(), &mut maps, warnings);
            ms.iter()
                .zip(&textured)
                .map(|(m, tex)| {
                    let kd = Vec3::from(m.diffuse.unwrap_or([DEFAULT_ALBEDO; 3]));
                    let ke = Vec3::from(m.emissive.unwrap_or([0.0; 3]));
                    // A textured material's albedo is per vertex (clamped there, counted in one warning).
                    let albedo = match tex {
                        Some((_, factor)) => factor.min(Vec3::splat(MAX_ALBEDO)),
                        None => clamp_albedo(path, &m.name, kd, warnings),
                    };
                    Material { name: m.name.clone(), albedo, emission: checked_emission(path, &m.name, ke, warnings) }
                })
                .collect()
        }
        Err(e) => {
            if text.lines().any(|l| l.trim_start().starts_with("mtllib")) {
                let why = mtl_problem.borrow_mut().take().unwrap_or_else(|| e.to_string());
                warnings.push(format!(
                    "{}: its material library could not be loaded ({why}); using grey albedo {DEFAULT_ALBEDO}",
                    path.display()
                ));
            }
            Vec::new()
        }
    };
    let mtl_files = mtl_files.into_inner().join(", ");
    notes.extend(emission::note(&mtl_files, "Ke", emission::materials(&mats)));
    let mut default_mat: Option<u32> = None;
    let mut positions = Vec::new();
    let mut triangles = Vec::new();
    let mut triangle_material = Vec::new();
    // Per position (kept when some face is textured): albedo, coordinates, factor; per triangle: map.
    let (mut albedo, mut uv, mut factor, mut triangle_map) = (Vec::new(), Vec::new(), Vec::new(), Vec::new());
    let mut no_uv_warned = vec![false; textured.len()];
    for model in &models {
        let mesh = &model.mesh;
        let base = positions.len() as u32;
        let texture = mesh.material_id.and_then(|id| textured.get(id).copied().flatten());
        let has_uv = !mesh.texcoords.is_empty() && mesh.texcoord_indices.len() == mesh.indices.len();
        if let (Some(_), false, Some(id)) = (texture, has_uv, mesh.material_id) {
            if !std::mem::replace(&mut no_uv_warned[id], true) {
                warnings.push(format!(
                    "{}: faces with material '{}' have no texture coordinates; its map_Kd is not drawn (Kd used)",
                    path.display(),
                    mats[id].name
                ));
            }
        }
        if let (Some((map, kd)), true) = (texture, has_uv) {
            // One position per (position, texture coordinate) pair of the faces.
            let mut pair: HashMap<(u32, u32), u32> = HashMap::new();
            for t in mesh.indices.chunks_exact(3).zip(mesh.texcoord_indices.chunks_exact(3)) {
                let tri = [0, 1, 2].map(|k| {
                    *pair.entry((t.0[k], t.1[k])).or_insert_with(|| {
                        let (p, c) = (t.0[k] as usize * 3, t.1[k] as usize * 2);
                        positions.push(Vec3::new(mesh.positions[p], mesh.positions[p + 1], mesh.positions[p + 2]));
                        let coords = Vec2::new(mesh.texcoords[c], 1.0 - mesh.texcoords[c + 1]);
                        albedo.push(maps[map as usize].albedo(coords, kd));
                        uv.push(coords);
                        factor.push(kd);
                        positions.len() as u32 - 1
                    })
                });
                triangles.push(tri);
                triangle_material.push(mesh.material_id.unwrap_or_default() as u32);
                triangle_map.push(map);
            }
            continue;
        }
        positions.extend(mesh.positions.chunks_exact(3).map(|p| Vec3::new(p[0], p[1], p[2])));
        let mat = match mesh.material_id {
            Some(id) if id < mats.len() => id as u32,
            _ => *default_mat.get_or_insert_with(|| {
                mats.push(Material {
                    name: "default".into(),
                    albedo: Vec3::splat(DEFAULT_ALBEDO),
                    emission: Vec3::ZERO,
                });
                (mats.len() - 1) as u32
            }),
        };
        for t in mesh.indices.chunks_exact(3) {
            triangles.push([base + t[0], base + t[1], base + t[2]]);
            triangle_material.push(mat);
            triangle_map.push(NO_MAP);
        }
        let n = positions.len() - albedo.len();
        albedo.extend(std::iter::repeat_n(mats[mat as usize].albedo, n));
        uv.extend(std::iter::repeat_n(Vec2::ZERO, n));
        factor.extend(std::iter::repeat_n(Vec3::ZERO, n));
    }
    if triangles.is_empty() {
        return Err(geometry_err(path, None, "the file has no faces"));
    }
    let textures = triangle_map.iter().any(|&m| m != NO_MAP).then(|| {
        let clamped = albedo.iter_mut().filter(|a| a.max_element() > MAX_ALBEDO || a.min_element() < 0.0).count();
        if clamped > 0 {
            warnings.push(format!(
                "{}: {clamped} of {} vertices have albedo Kd x map_Kd outside [0, {MAX_ALBEDO}]; clamped",
                path.display(),
                albedo.len()
            ));
        }
        albedo.iter_mut().for_each(|a| *a = a.clamp(Vec3::ZERO, Vec3::splat(MAX_ALBEDO)));
        MeshTextures { maps, triangle_map, uv, factor }
    });
    Ok(MeshDesc {
        name: path.display().to_string(),
        positions,
        triangles,
        triangle_material,
        materials: mats,
        vertex_albedo: textures.is_some().then_some(albedo),
        vertex_emission: None,
        textures,
        crease_angle_deg: 30.0,
        transform: Transform::default(),
        dynamic: false,
        deform: Vec::new(),
        source: Some(path.to_path_buf()),
    })
}

/// Writes `mesh` (object space, without its transform) as `path` plus a
/// `.mtl` beside it, emission as `Ke` = radiance `M / pi`
/// ([`emission::radiance`]). Coordinates are written so they read back
/// bit-exact (emission too, where an `f32` radiance gives back `M`).
pub fn write_obj(mesh: &MeshDesc, path: &Path) -> Result<()> {
    let mtl_path = path.with_extension("mtl");
    let mtl_name = mtl_path.file_name().map(|s| s.to_string_lossy().into_owned()).unwrap_or_default();
    let mut mtl = String::new();
    for m in &mesh.materials {
        let _ = writeln!(mtl, "newmtl {}\nKd {} {} {}", m.name, m.albedo.x, m.albedo.y, m.albedo.z);
        if m.emission != Vec3::ZERO {
            let ke = emission::radiance(m.emission);
            let _ = writeln!(mtl, "Ke {} {} {}", ke.x, ke.y, ke.z);
        }
        let _ = writeln!(mtl);
    }
    let mut obj = String::with_capacity(mesh.positions.len() * 32 + mesh.triangles.len() * 24);
    let _ = writeln!(
        obj,
        "# {} ({} vertices, {} triangles)\nmtllib {mtl_name}",
        mesh.name,
        mesh.positions.len(),
        mesh.triangles.len()
    );
    for p in &mesh.positions {
        let _ = writeln!(obj, "v {} {} {}", p.x, p.y, p.z);
    }
    // Faces in their original order (a new group wherever the material
    // changes), so the mesh reads back with the same vertex order.
    let mut current = u32::MAX;
    for (t, &m) in mesh.triangles.iter().zip(&mesh.triangle_material) {
        if m != current {
            let name = &mesh.materials[m as usize].name;
            let _ = writeln!(obj, "g {name}\nusemtl {name}");
            current = m;
        }
        let _ = writeln!(obj, "f {} {} {}", t[0] + 1, t[1] + 1, t[2] + 1);
    }
    std::fs::write(path, obj).map_err(|source| Error::Io { path: path.to_path_buf(), source })?;
    std::fs::write(&mtl_path, mtl).map_err(|source| Error::Io { path: mtl_path.clone(), source })?;
    Ok(())
}
