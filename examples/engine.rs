//! Embedding the asynchronous engine: a worker thread owns the solver; a
//! "render loop" (here 60 iterations at 60 Hz) moves a light every frame,
//! never waits for GI, and reads whatever result is newest. Prints the
//! versions it saw and how old they were.
//!
//! Run: `cargo run --release --example engine`

use glam::Vec3;
use linkgi::{load_scene, prepare, Change, Compute, Engine, EngineParams, Light, SolveParams};
use std::time::{Duration, Instant};

fn main() -> linkgi::Result<()> {
    let mut desc = load_scene("cornell")?;
    desc.settings.rays_per_vertex = 64;
    let scene = prepare(&desc)?;
    let Light::Point { position, intensity } = scene.lights()[0] else { unreachable!("cornell has a point light") };
    let mut engine = Engine::start(
        scene.clone(),
        SolveParams::from_settings(scene.settings()),
        Compute::Cpu,
        EngineParams::default(),
    )?;
    let start = Instant::now();
    let (mut seen, mut last) = (Vec::new(), 0);
    for frame in 0..60u32 {
        let t = frame as f32 / 60.0;
        let moved = position + Vec3::new(0.4 * (6.0 * t).cos(), 0.0, 0.4 * (6.0 * t).sin());
        engine.send(Change::MoveLight { index: 0, light: Light::Point { position: moved, intensity } });
        if let Some(r) = engine.latest() {
            if r.version != last {
                last = r.version;
                seen.push((frame, r.version, r.published.elapsed().as_secs_f64() * 1e3, r.e_indirect.len()));
            }
        }
        std::thread::sleep(Duration::from_millis(16));
    }
    engine.wait_idle(Duration::from_secs(60));
    let end = engine.latest().expect("a result");
    for (frame, version, age_ms, n) in &seen {
        println!("frame {frame:2}: GI version {version} ({n} vertices, {age_ms:.0} ms old when drawn)");
    }
    let c = engine.counters();
    println!(
        "{} light moves sent in {:.2} s; {} GI updates published, the last version {}, {} gathers",
        engine.sent(),
        start.elapsed().as_secs_f64(),
        seen.len(),
        end.version,
        c.gathers
    );
    Ok(())
}
