//! Export of a solved scene for other tools: `mesh.ply` (binary little-endian
//! PLY; per vertex position, normal, albedo, direct, smoothed indirect and
//! sky irradiance in W/m^2 and emitted exitance in W/m^2, then the
//! vertex's radiance `rho / pi (E_d + E_sky + E_i) + M / pi` tone mapped
//! as `linkgi render` does with its automatic exposure (over the vertices'
//! radiance: [`crate::render::exposure::key_exposure`]), as `uchar red green
//! blue`, which mesh viewers show as vertex colours; faces as
//! `uchar`-counted `uint` lists, in the solver's vertex order with
//! transforms applied) and `scene.json` (lights, sky, emitters, settings,
//! stats). Emitters' light reaches other vertices through links, so it is
//! part of `e_indirect_*`.

use crate::exchange::bounce::operator::radiosity;
use crate::render::exposure::key_exposure;
use crate::render::{display_rgb8, DEFAULT_EXPOSURE};
use crate::scene::prep::PreparedScene;
use crate::scene::{Bounces, Light};
use crate::sky::SkyModel;
use crate::solver::{Solution, SolveStats};
use crate::{Error, Result};
use glam::Vec3;
use serde_json::json;
use std::io::Write;
use std::path::Path;

/// Vertex properties written to the PLY, in order (all `float`).
pub const PLY_VERTEX_PROPERTIES: [&str; 21] = [
    "x",
    "y",
    "z",
    "nx",
    "ny",
    "nz",
    "albedo_r",
    "albedo_g",
    "albedo_b",
    "e_direct_r",
    "e_direct_g",
    "e_direct_b",
    "e_indirect_r",
    "e_indirect_g",
    "e_indirect_b",
    "e_sky_r",
    "e_sky_g",
    "e_sky_b",
    "emission_r",
    "emission_g",
    "emission_b",
];

fn io_err(path: &Path) -> impl FnOnce(std::io::Error) -> Error + '_ {
    move |source| Error::Io { path: path.to_path_buf(), source }
}

/// Vertex properties written after the floats when colours are written (`uchar`).
pub const PLY_COLOUR_PROPERTIES: [&str; 3] = ["red", "green", "blue"];

/// Binary little-endian PLY of `scene`'s mesh: the float vertex
/// properties `names`, whose values `vertex(v)` gives in that order, then
/// (with `colour`) [`PLY_COLOUR_PROPERTIES`], and the triangles (the one
/// PLY writer of the project).
fn ply_with(
    scene: &PreparedScene,
    names: &[&str],
    vertex: impl Fn(usize) -> Vec<Vec3>,
    colour: Option<&dyn Fn(usize) -> [u8; 3]>,
) -> Vec<u8> {
    let n = scene.vertex_count();
    let mut out = Vec::with_capacity(300 + n * (4 * names.len() + 3) + scene.triangles.len() * 13);
    let mut header = format!(
        "ply\nformat binary_little_endian 1.0\ncomment linkgi scene {}\n",
        scene.name.replace(['\n', '\r'], " ")
    );
    header += &format!("element vertex {n}\n");
    for p in names {
        header += &format!("property float {p}\n");
    }
    if colour.is_some() {
        for p in PLY_COLOUR_PROPERTIES {
            header += &format!("property uchar {p}\n");
        }
    }
    header += &format!("element face {}\nproperty list uchar uint vertex_indices\nend_header\n", scene.triangles.len());
    out.extend_from_slice(header.as_bytes());
    for v in 0..n {
        for vec in vertex(v) {
            for c in vec.to_array() {
                out.extend_from_slice(&c.to_le_bytes());
            }
        }
        if let Some(colour) = colour {
            out.extend_from_slice(&colour(v));
        }
    }
    for t in &scene.triangles {
        out.push(3u8);
        for i in t {
            out.extend_from_slice(&i.to_le_bytes());
        }
    }
    out
}

/// Writes the PLY bytes for `scene` and `solution`.
pub fn ply_bytes(scene: &PreparedScene, solution: &Solution) -> Vec<u8> {
    // The radiance leaving each vertex, W/(m^2 sr): `rho / pi (E_d + E_sky
    // + E_i) + M / pi`, what `linkgi render` shows there.
    let total = solution.total();
    let radiance = |v: usize| radiosity(scene.albedo[v], total[v], scene.emission[v]);
    let exposure = key_exposure((0..scene.vertex_count()).map(radiance)).unwrap_or(DEFAULT_EXPOSURE);
    let colour = |v: usize| display_rgb8(radiance(v), exposure);
    ply_with(
        scene,
        &PLY_VERTEX_PROPERTIES,
        |v| {
            vec![
                scene.positions[v],
                scene.normals[v],
                scene.albedo[v],
                solution.e_direct[v],
                solution.e_indirect[v],
                solution.e_sky_at(v),
                scene.emission[v],
            ]
        },
        Some(&colour),
    )
}

/// The PLY of the mesh alone (`x y z nx ny nz` per vertex and the
/// triangles), in the solver's vertex order: what other programs that only
/// need the geometry read (the Embree peer of `linkgi bench`).
#[cfg(any(feature = "cli", feature = "internals"))]
pub fn mesh_ply_bytes(scene: &PreparedScene) -> Vec<u8> {
    ply_with(scene, &PLY_VERTEX_PROPERTIES[..6], |v| vec![scene.positions[v], scene.normals[v]], None)
}

/// `x` as a JSON number, or null when it is NaN or infinite (e.g. no BVH was built).
fn number_or_null(x: f64) -> serde_json::Value {
    if x.is_finite() {
        json!(x)
    } else {
        serde_json::Value::Null
    }
}

fn sky_model_json(m: &SkyModel) -> serde_json::Value {
    match m {
        SkyModel::Uniform { radiance } => json!({"kind": "uniform", "radiance": radiance.to_array()}),
        SkyModel::Gradient { zenith, horizon, ground } => json!({
            "kind": "gradient",
            "zenith": zenith.to_array(),
            "horizon": horizon.to_array(),
            "ground": ground.to_array(),
        }),
        SkyModel::Image { path, map, .. } => {
            json!({"kind": "image", "image": path.display().to_string(), "width": map.width, "height": map.height})
        }
    }
}

/// The `scene.json` document.
pub fn scene_json(scene: &PreparedScene, stats: &SolveStats) -> serde_json::Value {
    let lights: Vec<_> = scene
        .lights
        .iter()
        .map(|l| match *l {
            Light::Point { position, intensity } => {
                json!({"kind": "point", "position": position.to_array(), "intensity": intensity.to_array()})
            }
            Light::Directional { direction, irradiance } => {
                json!({"kind": "directional", "direction": direction.to_array(), "irradiance": irradiance.to_array()})
            }
        })
        .collect();
    let s = &scene.settings;
    let bounces = match s.bounces {
        Bounces::Fixed(n) => json!(n),
        Bounces::Auto => json!("auto"),
    };
    let emitters: Vec<_> = scene
        .meshes
        .iter()
        .filter_map(|m| {
            let r = m.vertices.start as usize..m.vertices.end as usize;
            let max = scene.emission[r].iter().fold(Vec3::ZERO, |a, e| a.max(*e));
            (max != Vec3::ZERO).then(|| json!({"mesh": m.name, "emission_max": max.to_array()}))
        })
        .collect();
    let sky = scene.sky.as_ref().map(|k| {
        json!({
            "description": k.describe(),
            "model": sky_model_json(&k.model),
            "rotate_deg": k.rotate_deg,
            "intensity": k.intensity,
            "portals": k.portals.iter().map(|p| p.corners().map(|c| c.to_array())).collect::<Vec<_>>(),
        })
    });
    json!({
        "lights": lights,
        "sky": sky,
        "emitters": emitters,
        "settings": {
            "rays_per_vertex": s.rays_per_vertex,
            "bounces": bounces,
            "smoothing_angle_deg": s.smoothing_angle_deg,
            "seed": s.seed,
            "tracer": s.tracer.name(),
        },
        "stats": {
            "vertices": stats.vertices,
            "triangles": stats.triangles,
            "dropped_triangles": stats.dropped_triangles,
            "accel_build_ms": stats.accel_build_ms,
            "accel_bytes": stats.accel_bytes,
            "kd_nodes": stats.kd.map(|k| k.nodes),
            "kd_leaves": stats.kd.map(|k| k.leaves),
            "kd_mean_leaf_triangles": stats.kd.map(|k| k.mean_leaf_triangles),
            "kd_max_depth": stats.kd.map(|k| k.max_depth),
            "kd_sah_cost": stats.kd.map(|k| k.sah_cost),
            "kd_build_ms": stats.kd.map(|k| k.build_ms),
            "bvh_nodes": stats.bvh.map(|b| b.nodes),
            "bvh_leaves": stats.bvh.map(|b| b.leaves),
            "bvh_mean_leaf_triangles": stats.bvh.map(|b| b.mean_leaf_triangles),
            "bvh_max_depth": stats.bvh.map(|b| b.max_depth),
            "bvh_sah_cost": stats.bvh.map(|b| b.sah_cost),
            "rays": stats.links.rays,
            "ray_misses": stats.links.misses,
            "ray_back_hits": stats.links.back_hits,
            "links_raw": stats.links.raw_links,
            "links_merged": stats.links.merged_links,
            "links_raw_bytes": stats.links.raw_bytes,
            "links_merged_bytes": stats.links.merged_bytes,
            "links_ms": stats.links.shoot_ms,
            "rays_per_second": stats.links.rays_per_second(),
            "tracer": stats.tracer,
            "bvh_build_ms": number_or_null(stats.bvh_build_ms),
            "shadow_rays": stats.shadow_rays,
            "shadow_rays_per_second": number_or_null(stats.shadow_rays_per_second),
            "light_links_ms": stats.light_links_ms,
            "bounces": stats.bounces,
            "tail_relative": stats.tail_relative,
            "gather_ms": stats.gather_ms,
            "smooth_ms": stats.smooth_ms,
        }
    })
}

/// Writes `dir/mesh.ply` and `dir/scene.json`.
pub fn export(dir: &Path, scene: &PreparedScene, solution: &Solution, stats: &SolveStats) -> Result<()> {
    std::fs::create_dir_all(dir).map_err(io_err(dir))?;
    let ply = dir.join("mesh.ply");
    std::fs::File::create(&ply).and_then(|mut f| f.write_all(&ply_bytes(scene, solution))).map_err(io_err(&ply))?;
    let js = dir.join("scene.json");
    let text = serde_json::to_string_pretty(&scene_json(scene, stats)).expect("json serializes");
    std::fs::write(&js, text).map_err(io_err(&js))?;
    Ok(())
}
