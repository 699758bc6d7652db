//! `linkgi animate`: moves the first light along a circle, turns the sky
//! (`--sky-turn`, degrees per second, for scenes with a sky) and runs the
//! scene's deformers while the asynchronous engine updates GI in the
//! background; each frame is rendered with whatever GI is published at that
//! moment (`--sync` waits for every update instead). Writes
//! `DIR/frame_NNNN.png` and `DIR/frames.csv` (frame time, GI version and age,
//! engine counters, and the last deformation update's figures: rays
//! re-shot, share of static rays re-shot, link groups patched, light links
//! recomputed, bytes of per-ray state). Deformations publish a preview
//! first ([`EngineParams::deform_preview`]) unless `--sync` is given.

use super::setup::{compute, setup, Overrides, Setup};
use crate::engine::{Change, Engine, EngineParams};
use crate::render::{write_png, Frame, RenderParams, Renderer};
use crate::scene::deform::{deform_scene, has_deformers};
use crate::scene::Light;
use crate::solver::SolveParams;
use anyhow::{Context, Result};
use indicatif::{ProgressBar, ProgressStyle};
use std::fmt::Write as _;
use std::path::PathBuf;
use std::time::{Duration, Instant};

/// Arguments of `linkgi animate`.
#[derive(clap::Args, Debug)]
pub struct AnimateArgs {
    /// Scene file or built-in name.
    pub scene: String,
    /// Number of frames.
    #[arg(long, default_value_t = 48)]
    pub frames: u32,
    /// Output folder for the PNGs and frames.csv.
    #[arg(long, default_value = "out/animate")]
    pub out: PathBuf,
    /// Animation time step per frame is 1/fps seconds (deformers use this time).
    #[arg(long, default_value_t = 24.0)]
    pub fps: f32,
    /// Wait for the GI of every frame's changes before rendering it.
    #[arg(long)]
    pub sync: bool,
    /// Image size, WIDTHxHEIGHT.
    #[arg(long, default_value = "320x240")]
    pub size: String,
    #[command(flatten)]
    pub overrides: Overrides,
    /// Radiance scale before tone mapping; automatic when not given: the
    /// first frame's log-average luminance mapped to middle grey, then kept
    /// for every frame (so moving lights brighten and darken the picture).
    #[arg(long)]
    pub exposure: Option<f32>,
    /// Turn the scene's sky about +y at this many degrees per second of
    /// animation time (a gather-only update per frame; ignored without a sky).
    #[arg(long, default_value_t = 0.0)]
    pub sky_turn: f32,
}

pub fn run(args: AnimateArgs) -> Result<()> {
    let (width, height) = super::render::parse_size(&args.size)?;
    if args.frames == 0 || !(args.fps.is_finite() && args.fps > 0.0) {
        anyhow::bail!("--frames must be at least 1 and --fps positive");
    }
    if !args.sky_turn.is_finite() {
        anyhow::bail!("--sky-turn must be finite");
    }
    let Setup { desc, prepared, settings, .. } = setup(&args.scene, &args.overrides)?;
    let compute = compute(settings.backend, 1)?;
    let renderer = Renderer::open(settings.backend);
    std::fs::create_dir_all(&args.out).with_context(|| format!("creating {}", args.out.display()))?;
    let rest = prepared.positions.clone();
    let rest_normals = prepared.normals.clone();
    let deforms = has_deformers(&prepared);
    let mut lights = prepared.lights.clone();
    let camera = super::setup::camera(&desc, &prepared, None);
    let extent = Frame::of(&prepared, &rest, camera).extent();
    let mut engine = Engine::start(
        prepared.clone(),
        SolveParams::from_settings(&settings),
        compute.clone(),
        // Previews of deformations, except when every frame waits for its full GI.
        EngineParams { deform_preview: !args.sync, ..Default::default() },
    )?;
    let t_first = Instant::now();
    engine.wait_idle(Duration::from_secs(3600));
    let first_ms = t_first.elapsed().as_secs_f64() * 1e3;
    println!("first GI in {first_ms:.0} ms ({}); rendering on {}", compute.describe(), renderer.describe());

    if let Some(e) = args.exposure.filter(|e| !(e.is_finite() && *e > 0.0)) {
        anyhow::bail!("--exposure {e}: must be positive and finite");
    }
    let params = RenderParams { width, height, ..Default::default() };
    let mut exposure = args.exposure;
    let mut csv = String::from(
        "frame,time_s,frame_ms,render_ms,gi_version,gi_age_ms,gi_updates,accel_updates,light_link_updates,gathers,refits,\
         gi_preview,previews,gi_update_ms,rays_reshot,static_rays_reshot_fraction,groups_patched,light_links_recomputed,\
         ray_state_bytes\n",
    );
    let bar = ProgressBar::new(args.frames as u64);
    bar.set_style(
        ProgressStyle::with_template("frames [{bar:40}] {pos}/{len} ({eta}) {msg}")
            .expect("template")
            .progress_chars("=> "),
    );
    let light0 = lights.first().copied();
    let mut update_ms = Vec::new();
    let mut last_version = 0;
    let start = Instant::now();
    for k in 0..args.frames {
        let tf = Instant::now();
        let time = k as f32 / args.fps;
        let mut changes = Vec::new();
        if let Some(Light::Point { position, intensity }) = light0 {
            let a = std::f32::consts::TAU * k as f32 / args.frames as f32;
            let r = 0.15 * extent;
            let p = position + glam::Vec3::new(r * a.sin(), 0.0, r * (a.cos() - 1.0));
            lights[0] = Light::Point { position: p, intensity };
            changes.push(Change::MoveLight { index: 0, light: lights[0] });
        } else if let Some(Light::Directional { direction, irradiance }) = light0 {
            let q = glam::Quat::from_rotation_y(std::f32::consts::TAU * k as f32 / args.frames as f32);
            lights[0] = Light::Directional { direction: q * direction, irradiance };
            changes.push(Change::MoveLight { index: 0, light: lights[0] });
        }
        if let Some(sky) = prepared.sky.as_ref().filter(|_| args.sky_turn != 0.0) {
            let mut turned = sky.clone();
            turned.rotate_deg = sky.rotate_deg + args.sky_turn * time;
            changes.push(Change::SetSky(Some(turned)));
        }
        let (positions, normals) = if deforms {
            let (p, n) = deform_scene(&prepared, &rest, &rest_normals, time);
            changes.push(Change::Deform { positions: p.clone() });
            (p, n)
        } else {
            (rest.clone(), rest_normals.clone())
        };
        // One message per frame: the light move and the deformation are one update.
        engine.send_batch(changes);
        if args.sync {
            engine.wait_idle(Duration::from_secs(3600));
        }
        let Some(gi) = engine.latest() else {
            anyhow::bail!("the GI engine published no result: {}", engine.last_error().unwrap_or_default());
        };
        if gi.version != last_version {
            if last_version != 0 && !gi.preview {
                update_ms.push(gi.update_ms);
            }
            last_version = gi.version;
        }
        let frame = Frame {
            positions: &positions,
            normals: &normals,
            albedo: &prepared.albedo,
            triangles: &prepared.triangles,
            textures: prepared.textures.as_deref(),
            e_indirect: &gi.e_indirect,
            e_sky: &gi.e_sky,
            emission: &gi.emission,
            sky: gi.sky.as_ref(),
            lights: &lights,
            camera,
        };
        let (img, stats) = renderer.render(&frame, &params)?;
        let e = *exposure.get_or_insert_with(|| crate::render::exposure::auto_exposure(&img));
        write_png(&img, e, &args.out.join(format!("frame_{k:04}.png")))?;
        let c = engine.counters();
        let frame_ms = tf.elapsed().as_secs_f64() * 1e3;
        let age = gi.published.elapsed().as_secs_f64() * 1e3;
        let d = c.deform.unwrap_or_default();
        writeln!(
            csv,
            "{k},{time:.4},{frame_ms:.2},{:.2},{},{age:.1},{},{},{},{},{},{},{},{:.2},{},{:.5},{},{},{}",
            stats.ms,
            gi.version,
            c.published,
            c.kd_builds + c.refits,
            c.light_link_updates,
            c.gathers,
            c.refits,
            gi.preview as u8,
            c.previews,
            gi.update_ms,
            d.links.rays_reshot,
            d.static_rays_fraction(),
            d.links.groups_patched,
            d.light_links_recomputed,
            d.ray_state_bytes
        )?;
        bar.set_message(format!("GI v{} age {age:.0} ms", gi.version));
        bar.inc(1);
    }
    bar.finish_and_clear();
    let secs = start.elapsed().as_secs_f64();
    engine.wait_idle(Duration::from_secs(3600));
    let c = engine.counters();
    let csv_path = args.out.join("frames.csv");
    std::fs::write(&csv_path, csv).with_context(|| format!("writing {}", csv_path.display()))?;
    let mean = |v: &[f64]| if v.is_empty() { 0.0 } else { v.iter().sum::<f64>() / v.len() as f64 };
    println!(
        "{} frames in {secs:.2} s ({:.1} fps); full GI updates seen {} ({:.1}/s), mean update {:.1} ms; \
         engine: {} updates ({} previews), {} structure builds, {} BVH refits, {} light-link updates, {} gathers, {} changes in {} batches",
        args.frames,
        args.frames as f64 / secs,
        update_ms.len(),
        update_ms.len() as f64 / secs,
        mean(&update_ms),
        c.published,
        c.previews,
        c.kd_builds,
        c.refits,
        c.light_link_updates,
        c.gathers,
        c.changes,
        c.batches
    );
    println!(
        "last stages: rebuild {:.1} ms, light links {:.1} ms, gather {:.1} ms",
        c.rebuild_ms, c.light_links_ms, c.gather_ms
    );
    if let Some(d) = c.deform {
        println!(
            "last deformation: {} rays re-shot ({:.2}% of the static rays), {} link groups patched, \
             {} light links recomputed, ray state {:.1} MB, preview after {:.1} ms",
            d.links.rays_reshot,
            100.0 * d.static_rays_fraction(),
            d.links.groups_patched,
            d.light_links_recomputed,
            d.ray_state_bytes as f64 / 1e6,
            c.preview_ms
        );
    }
    println!("wrote {} frames and {}", args.frames, csv_path.display());
    Ok(())
}
