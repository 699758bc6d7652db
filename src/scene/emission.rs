//! Emission units: what an emission written in a scene's files means, and
//! the one conversion to what the solver stores.
//!
//! Convention. Every emission in a file is the emitted radiance `L` of a
//! Lambertian emitter, W/(m^2 sr) per channel: MTL `Ke`, the scene file's
//! per-mesh `emission = [r, g, b]`, and glTF's `emissiveFactor` times
//! `KHR_materials_emissive_strength` (default 1). A camera looking at an
//! emitter that reflects nothing sees exactly `L`. The solver keeps the
//! radiant exitance of the surface, [`super::Material::emission`] =
//! `M = pi L` in W/m^2 (a Lambertian surface of radiance `L` emits
//! `integral of L cos over the hemisphere = pi L`), so every formula of the
//! solve (`B = rho/pi E + M/pi`, docs/DESIGN.md "units and conventions") is
//! unchanged; built-in scenes, made in code, give `M` directly.
//!
//! Why radiance: it is what the renderers people compare with read.
//! Mitsuba 3's area emitter takes `radiance` ("the emitted radiance in
//! units of power per unit area per unit steradian"); pbrt's diffuse area
//! light takes `L`; Blender's OBJ importer puts `Ke` into the Principled
//! BSDF's Emission colour at strength 1, which in Blender "will ensure that
//! the object in the image has the exact same color as the Color input"
//! (source/blender/io/wavefront_obj/importer/obj_import_mtl.cc, Blender
//! manual, Emission node). McGuire's Cornell box (`Ke 17 12 4`) is lit as
//! path tracers light it only when `Ke` is read as radiance. glTF:
//! `KHR_materials_emissive_strength` names candela per square metre for
//! implementations that need a photometric unit, and says many engines
//! take a factor of 1 as a fully exposed pixel; linkgi reads the product
//! as radiance in W/(m^2 sr) like the other formats (deviation: not through
//! the 683 lm/W its glTF lights go through, which would make every glowing
//! glTF material 683 times dimmer than its own pixels mean).
//!
//! [`exitance`] is the conversion every loader calls; [`radiance`] is its
//! inverse for the writers (MTL, glTF) and for messages, chosen so that a
//! written scene reads back bit-exact wherever an `f32` radiance exists
//! whose exitance rounds to the stored value. [`note`] is the line a loader
//! adds to [`super::SceneDesc::notes`] to say what it assumed.

use glam::Vec3;

/// Exitance `M = pi L` (W/m^2) of an emitted radiance `L` (W/(m^2 sr)),
/// per channel, computed in `f64` and rounded once.
pub fn exitance(radiance: Vec3) -> Vec3 {
    let f = |l: f32| (l as f64 * std::f64::consts::PI) as f32;
    Vec3::new(f(radiance.x), f(radiance.y), f(radiance.z))
}

/// Emitted radiance `L = M / pi` (W/(m^2 sr)) of an exitance `M` (W/m^2):
/// per channel the `f32` nearest `M / pi` whose [`exitance`] is exactly `M`
/// where one lies within a few units in the last place, else the nearest.
pub fn radiance(exitance_m: Vec3) -> Vec3 {
    Vec3::new(radiance_of(exitance_m.x), radiance_of(exitance_m.y), radiance_of(exitance_m.z))
}

fn radiance_of(m: f32) -> f32 {
    let nearest = (m as f64 / std::f64::consts::PI) as f32;
    if !nearest.is_finite() || nearest == 0.0 {
        return nearest;
    }
    let back = |l: f32| (l as f64 * std::f64::consts::PI) as f32;
    let mut candidates = [nearest; 7];
    let (mut up, mut down) = (nearest, nearest);
    for k in 0..3 {
        up = up.next_up();
        down = down.next_down();
        candidates[1 + 2 * k] = up;
        candidates[2 + 2 * k] = down;
    }
    candidates.into_iter().find(|&l| back(l) == m).unwrap_or(nearest)
}

/// The line a loader adds to the scene's notes for `file`, where `key` (as
/// the file spells it: `Ke`, `emission`, ...) was read as radiance: each
/// emitter (a label such as `material 'lamp'`, and its exitance `M`) with
/// its exitance, up to four of them. `None` when none of them emits.
pub fn note(file: &str, key: &str, emitters: impl IntoIterator<Item = (String, Vec3)>) -> Option<String> {
    let emitting: Vec<(String, Vec3)> = emitters.into_iter().filter(|(_, m)| *m != Vec3::ZERO).collect();
    if emitting.is_empty() {
        return None;
    }
    const SHOWN: usize = 4;
    let mut listed: Vec<String> = emitting
        .iter()
        .take(SHOWN)
        .map(|(label, m)| format!("{label} emits M = pi*{key} = [{:.4}, {:.4}, {:.4}] W/m^2", m.x, m.y, m.z))
        .collect();
    if emitting.len() > SHOWN {
        listed.push(format!("{} more emit", emitting.len() - SHOWN));
    }
    Some(format!("{file}: {key} read as emitted radiance, W/(m^2 sr): {}", listed.join("; ")))
}

/// `(material 'name', M)` for each material, the emitters of [`note`].
pub fn materials<'a>(materials: &'a [super::Material]) -> impl Iterator<Item = (String, Vec3)> + 'a {
    materials.iter().map(|m| (format!("material '{}'", m.name), m.emission))
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn exitance_is_pi_times_radiance() {
        let l = Vec3::new(17.0, 12.0, 4.0);
        let m = exitance(l);
        for (a, b) in m.to_array().into_iter().zip(l.to_array()) {
            assert!((a / b - std::f32::consts::PI).abs() < 1e-6, "{m} from {l}");
        }
        assert_eq!(exitance(Vec3::ZERO), Vec3::ZERO);
    }

    #[test]
    fn radiance_round_trips_through_exitance() {
        // Exitances of the built-in scenes and a spread of others.
        let mut values = vec![30.0f32, 17.0, 4.0, 0.5, 2.0, 80.0, 1e-3, 123.456];
        values.extend((1..2000).map(|i| i as f32 * 0.37));
        let mut exact = 0;
        for &m in &values {
            let l = radiance(Vec3::splat(m)).x;
            let back = exitance(Vec3::splat(l)).x;
            assert!((back - m).abs() <= m * 4.0 * f32::EPSILON, "{m} -> {l} -> {back}");
            exact += (back == m) as usize;
        }
        for m in [30.0f32, 17.0, 4.0, 0.5, 2.0] {
            assert_eq!(exitance(radiance(Vec3::splat(m))).x, m, "{m} must read back bit-exact");
        }
        // Where M's mantissa is above pi/2 one step of L moves M by about
        // 1.57 of its units in the last place, so about a third of those
        // exitances have no exact radiance (about 8% of these values).
        assert!(exact * 10 >= values.len() * 8, "{exact} of {} read back exactly", values.len());
    }

    #[test]
    fn note_names_file_key_and_materials() {
        let mat = |name: &str, e: Vec3| super::super::Material { name: name.into(), albedo: Vec3::ZERO, emission: e };
        let n = note("a.mtl", "Ke", materials(&[mat("lamp", exitance(Vec3::ONE)), mat("wall", Vec3::ZERO)])).unwrap();
        assert!(n.starts_with("a.mtl: Ke read as emitted radiance, W/(m^2 sr): material 'lamp' emits"), "{n}");
        assert!(n.contains("3.1416") && !n.contains("'wall'"), "{n}");
        assert!(note("a.mtl", "Ke", materials(&[mat("wall", Vec3::ZERO)])).is_none());
        let many: Vec<_> = (0..6).map(|i| mat(&format!("m{i}"), Vec3::ONE)).collect();
        let n = note("b.mtl", "Ke", materials(&many)).unwrap();
        assert!(n.contains("'m3'") && !n.contains("'m4'") && n.contains("2 more emit"), "{n}");
    }
}
