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
//! `Ke = M / pi` back). Fallbacks, each reported as a warning: an MTL
//! that is missing or unreadable gives grey albedo [`DEFAULT_ALBEDO`]; faces
//! without a material get the same; albedo above [`MAX_ALBEDO`] or below 0 is
//! clamped. Non-finite coordinates and out-of-range face indices are errors
//! naming the file and line (found by a pre-scan of the text, since `tobj`
//! does not report lines). An MTL colour line (`Ka`, `Kd`, `Ks`, `Ke`)
//! without three numbers makes its library unreadable (the warning names the
//! MTL file and line): `tobj` would panic on it.

use super::{emission, Material, MeshDesc, Transform, MAX_ALBEDO};
use crate::{Error, Result};
use glam::Vec3;
use std::fmt::Write as _;
use std::path::Path;

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
    let (models, materials) = tobj::load_obj_buf(&mut reader, &options, |mtl| {
        let full = dir.join(mtl);
        mtl_files.borrow_mut().push(full.display().to_string());
        let text = std::fs::read_to_string(&full).map_err(|_| tobj::LoadError::OpenFileFailed)?;
        if let Err(problem) = mtl_prescan(&full, &text) {
            *mtl_problem.borrow_mut() = Some(problem);
            return Err(tobj::LoadError::MaterialParseError);
        }
        tobj::load_mtl_buf(&mut text.as_bytes())
    })
    .map_err(|e| Error::Obj { path: path.to_path_buf(), message: e.to_string() })?;

    let mut mats: Vec<Material> = match materials {
        Ok(ms) => ms
            .iter()
            .map(|m| {
                let kd = Vec3::from(m.diffuse.unwrap_or([DEFAULT_ALBEDO; 3]));
                let ke = Vec3::from(m.emissive.unwrap_or([0.0; 3]));
                Material {
                    name: m.name.clone(),
                    albedo: clamp_albedo(path, &m.name, kd, warnings),
                    emission: checked_emission(path, &m.name, ke, warnings),
                }
            })
            .collect(),
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
    for model in &models {
        let mesh = &model.mesh;
        let base = positions.len() as u32;
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
        }
    }
    if triangles.is_empty() {
        return Err(geometry_err(path, None, "the file has no faces"));
    }
    Ok(MeshDesc {
        name: path.display().to_string(),
        positions,
        triangles,
        triangle_material,
        materials: mats,
        vertex_albedo: None,
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
