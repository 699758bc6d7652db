//! `linkgi view --script FILE`: timed actions that drive the viewer the way
//! a user would (tests, demos, reproducible screenshots).
//!
//! One action per line, `<seconds> <action> [args]`; `#` starts a comment.
//! Actions run in file order; each waits until `<seconds>` after the window
//! opened and until the one before it is done:
//! - `move_light <i> <dx> <dy> <dz>`: metres; a directional light's
//!   direction is offset and renormalised;
//! - `set_intensity <i> <value>`: the light's strongest channel becomes
//!   `value` (W/sr or W/m^2), colour kept (what the panel's slider does);
//! - `set_rays <n>`: rays per vertex, a square number (the panel's slider);
//! - `set_emission <mesh> <value>`: mesh `mesh`'s emission becomes `value`
//!   W/m^2 in its strongest channel, colour kept (the panel's slider);
//! - `set_sky <intensity> <rotate_deg>`: the sky's multiplier and its
//!   rotation about +y (the panel's sliders);
//! - `add_light`: a point light halfway from the camera to the surface at
//!   the centre of the view (the panel's button);
//! - `remove_light <i>`;
//! - `deform on|off`; `view combined|direct|indirect`;
//! - `wait_gi`: until every change sent before it is in a published result
//!   and that result has been drawn (also while deformation plays), and,
//!   where the scene refines in the background, until the final mesh's
//!   result is (`refining`); prints
//!   `gi: version .., links .., bounces .., rays ..` and light 0
//!   (`light0 point x y z intensity I`, the result's own lights); fails after 300 s;
//! - `screenshot <name.png>`: the next frame's scene, without the panel;
//! - `window_shot <name.png>`: the next frame as the window shows it,
//!   panel and light markers included;
//! - `wait_file <name>`: until `<name>` exists in the screenshot folder
//!   (lets a test drive the mouse with real window-system events in
//!   between); fails after 300 s;
//! - `quit`.
//!
//! Screenshot names and `wait_file` names are relative to `--screenshot-dir`.
//!
//! [`parse_script`] reads the file before the window opens (so a bad line
//! fails at once, naming file and line); the runner (`Viewer::run_script`)
//! runs due actions at the start of every frame and stops at one that must
//! wait or at a screenshot (written after that frame is drawn).

use super::Viewer;
use crate::render::View;
use crate::scene::Light;
use anyhow::{bail, Context, Result};
use glam::Vec3;
use std::path::Path;
use std::time::{Duration, Instant};

/// One scripted action.
#[derive(Clone, Debug, PartialEq)]
pub enum Action {
    MoveLight { index: usize, delta: Vec3 },
    SetIntensity { index: usize, value: f32 },
    SetRays(u32),
    SetEmission { mesh: usize, value: f32 },
    SetSky { intensity: f32, rotate_deg: f32 },
    AddLight,
    RemoveLight(usize),
    Deform(bool),
    View(View),
    WaitGi,
    Screenshot(String),
    WindowShot(String),
    WaitFile(String),
    Quit,
}

/// An action with its earliest time (seconds after the window opened) and source line.
#[derive(Clone, Debug, PartialEq)]
pub struct ScriptLine {
    pub at: f64,
    pub action: Action,
    pub line: usize,
}

const ACTIONS: &str = "move_light, set_intensity, set_rays, set_emission, set_sky, add_light, remove_light, \
                       deform, view, wait_gi, screenshot, window_shot, wait_file, quit";

/// Parses a script; errors name `file` and the line.
pub fn parse_script(text: &str, file: &Path) -> Result<Vec<ScriptLine>> {
    let mut out = Vec::new();
    for (i, raw) in text.lines().enumerate() {
        let line = i + 1;
        let here = || format!("{}:{line}", file.display());
        let body = raw.split('#').next().unwrap_or("").trim();
        if body.is_empty() {
            continue;
        }
        let words: Vec<&str> = body.split_whitespace().collect();
        let at: f64 = words[0]
            .parse()
            .ok()
            .filter(|t: &f64| t.is_finite() && *t >= 0.0)
            .with_context(|| format!("{}: '{}' is not a time in seconds (>= 0)", here(), words[0]))?;
        let Some(&name) = words.get(1) else {
            bail!("{}: missing action after the time", here());
        };
        let args = &words[2..];
        let want = |n: usize| -> Result<()> {
            if args.len() != n {
                bail!("{}: {name} takes {n} argument(s), got {}", here(), args.len());
            }
            Ok(())
        };
        let number = |a: &str| -> Result<f32> {
            a.parse()
                .ok()
                .filter(|v: &f32| v.is_finite())
                .with_context(|| format!("{}: {name}: '{a}' is not a number", here()))
        };
        let index = |a: &str| -> Result<usize> {
            a.parse().with_context(|| format!("{}: {name}: '{a}' is not a light index", here()))
        };
        let action = match name {
            "move_light" => {
                want(4)?;
                let d = [number(args[1])?, number(args[2])?, number(args[3])?];
                Action::MoveLight { index: index(args[0])?, delta: Vec3::from(d) }
            }
            "set_intensity" => {
                want(2)?;
                let value = number(args[1])?;
                if value < 0.0 {
                    bail!("{}: set_intensity: {value} is negative", here());
                }
                Action::SetIntensity { index: index(args[0])?, value }
            }
            "set_rays" => {
                want(1)?;
                let n: u32 =
                    args[0].parse().with_context(|| format!("{}: set_rays: '{}' is not a count", here(), args[0]))?;
                let k = (n as f64).sqrt().round() as u32;
                if n == 0 || k * k != n {
                    bail!("{}: set_rays: {n} is not a positive square number (1, 4, 9, 16, ...)", here());
                }
                Action::SetRays(n)
            }
            "add_light" => {
                want(0)?;
                Action::AddLight
            }
            "set_emission" => {
                want(2)?;
                let mesh = args[0]
                    .parse()
                    .with_context(|| format!("{}: set_emission: '{}' is not a mesh index", here(), args[0]))?;
                let value = number(args[1])?;
                if value < 0.0 {
                    bail!("{}: set_emission: {value} is negative", here());
                }
                Action::SetEmission { mesh, value }
            }
            "set_sky" => {
                want(2)?;
                let intensity = number(args[0])?;
                if intensity < 0.0 {
                    bail!("{}: set_sky: intensity {intensity} is negative", here());
                }
                Action::SetSky { intensity, rotate_deg: number(args[1])? }
            }
            "remove_light" => {
                want(1)?;
                Action::RemoveLight(index(args[0])?)
            }
            "deform" => {
                want(1)?;
                match args[0] {
                    "on" => Action::Deform(true),
                    "off" => Action::Deform(false),
                    a => bail!("{}: deform takes on or off, got '{a}'", here()),
                }
            }
            "view" => {
                want(1)?;
                match args[0] {
                    "combined" => Action::View(View::Combined),
                    "direct" => Action::View(View::Direct),
                    "indirect" => Action::View(View::Indirect),
                    a => bail!("{}: view takes combined, direct or indirect, got '{a}'", here()),
                }
            }
            "wait_gi" => {
                want(0)?;
                Action::WaitGi
            }
            "screenshot" => {
                want(1)?;
                Action::Screenshot(args[0].to_string())
            }
            "window_shot" => {
                want(1)?;
                Action::WindowShot(args[0].to_string())
            }
            "wait_file" => {
                want(1)?;
                Action::WaitFile(args[0].to_string())
            }
            "quit" => {
                want(0)?;
                Action::Quit
            }
            other => bail!("{}: unknown action '{other}' ({ACTIONS})", here()),
        };
        out.push(ScriptLine { at, action, line });
    }
    Ok(out)
}

/// A running `wait_gi`.
pub(super) struct GiWait {
    since: Instant,
    /// Changes sent when the wait began: all must be handled.
    target: u64,
    /// The result version that then had to be drawn.
    need: Option<u64>,
    /// The wait began while the scene refined in the background: once the
    /// final mesh is handed to the engine, the changes sent by then count.
    refining: bool,
}

impl Viewer {
    /// Runs due script actions; stops at one that must wait or at a screenshot.
    pub(super) fn run_script(&mut self) -> Result<()> {
        let Some(opened) = self.opened else { return Ok(()) };
        while self.pending.scene.is_none() && self.pending.window.is_none() && !self.quit {
            let Some(step) = self.script.get(self.script_pos).cloned() else { return Ok(()) };
            if opened.elapsed().as_secs_f64() < step.at {
                return Ok(());
            }
            let here = format!("{}:{}", self.script_file.display(), step.line);
            match step.action {
                Action::MoveLight { index, delta } => self.move_light(index, delta).with_context(|| here.clone())?,
                Action::SetIntensity { index, value } => {
                    self.set_intensity(index, value).with_context(|| here.clone())?
                }
                Action::SetRays(n) => self.set_rays(n),
                Action::AddLight => self.add_light().with_context(|| here.clone())?,
                Action::SetEmission { mesh, value } => self.set_emission(mesh, value).with_context(|| here.clone())?,
                Action::SetSky { intensity, rotate_deg } => {
                    self.set_sky(intensity, rotate_deg).with_context(|| here.clone())?
                }
                Action::RemoveLight(i) => self.remove_light(i).with_context(|| here.clone())?,
                Action::Deform(on) => {
                    if on && !self.deforms {
                        eprintln!("note: {here}: the scene has no deformers");
                    }
                    self.playing = on && self.deforms;
                }
                Action::View(v) => self.view = v,
                Action::WaitGi => {
                    if !self.wait_gi(&here)? {
                        return Ok(());
                    }
                }
                Action::Screenshot(name) => self.pending.scene = Some(self.screenshot_path(Some(&name))),
                Action::WindowShot(name) => self.pending.window = Some(self.screenshot_path(Some(&name))),
                Action::WaitFile(name) => {
                    let since = *self.wait_file_since.get_or_insert_with(Instant::now);
                    if !self.shot_dir.join(&name).exists() {
                        if since.elapsed() > Duration::from_secs(300) {
                            bail!(
                                "{here}: wait_file: {} did not appear within 300 s",
                                self.shot_dir.join(&name).display()
                            );
                        }
                        return Ok(());
                    }
                    self.wait_file_since = None;
                }
                Action::Quit => self.quit = true,
            }
            self.script_pos += 1;
        }
        Ok(())
    }

    /// One step of `wait_gi`: true once every change sent before the wait
    /// is in a published result and that result has been drawn.
    fn wait_gi(&mut self, here: &str) -> Result<bool> {
        let sent = self.engine.sent();
        let refining = self.refining.is_some();
        let w = self.wait.get_or_insert_with(|| GiWait { since: Instant::now(), target: sent, need: None, refining });
        // A scene refining in the background: its final mesh's result too
        // (handed to the engine when it lands, a change sent then). Only
        // then is the target raised: a deforming scene sends a change every
        // frame, and a target that followed them would never be reached.
        if w.refining && !refining {
            w.target = sent;
            w.refining = false;
        }
        let c = self.engine.counters();
        if !refining && w.need.is_none() && c.changes >= w.target && (c.published > 0 || c.errors > 0) {
            if c.published == 0 {
                bail!(
                    "{here}: wait_gi: the GI engine published no result: {}",
                    self.engine.last_error().unwrap_or_default()
                );
            }
            w.need = Some(c.published);
        }
        if w.need.is_some_and(|v| self.shown_version >= v) {
            self.wait = None;
            if let Some(g) = self.engine.latest() {
                let light0 = match g.lights.first() {
                    Some(Light::Point { position: p, intensity: i }) => {
                        format!(", light0 point {} {} {} intensity {}", p.x, p.y, p.z, i.max_element())
                    }
                    Some(Light::Directional { direction: d, irradiance: e }) => {
                        format!(", light0 directional {} {} {} irradiance {}", d.x, d.y, d.z, e.max_element())
                    }
                    None => String::new(),
                };
                println!(
                    "gi: version {}, links {}, bounces {}, rays {}{light0}",
                    g.version, g.links, g.bounces, self.settings.rays_per_vertex
                );
            }
            return Ok(true);
        }
        if w.since.elapsed() > Duration::from_secs(300) {
            bail!(
                "{here}: wait_gi: the GI did not catch up within 300 s{}",
                self.engine.last_error().map(|e| format!(" (last error: {e})")).unwrap_or_default()
            );
        }
        Ok(false)
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn parses_actions_and_names_bad_lines() {
        let f = Path::new("s.txt");
        let s = parse_script(
            "# c\n0 wait_gi\n0.5 move_light 0 0.1 0 -0.2\n1 view indirect # x\n1 set_intensity 0 2.5\n\
             1 set_rays 16\n1 window_shot w.png\n1 wait_file go\n1 add_light\n1 remove_light 1\n2 quit\n",
            f,
        )
        .unwrap();
        assert_eq!(s.len(), 10);
        assert_eq!(s[7].action, Action::AddLight);
        assert_eq!(s[8].action, Action::RemoveLight(1));
        assert_eq!(s[1].action, Action::MoveLight { index: 0, delta: Vec3::new(0.1, 0.0, -0.2) });
        assert_eq!(s[1].line, 3);
        assert_eq!(s[2].action, Action::View(View::Indirect));
        assert_eq!(s[3].action, Action::SetIntensity { index: 0, value: 2.5 });
        assert_eq!(s[4].action, Action::SetRays(16));
        assert_eq!(s[5].action, Action::WindowShot("w.png".into()));
        assert_eq!(s[6].action, Action::WaitFile("go".into()));
        for (bad, line) in [
            ("0 wait_gi\nx quit", 2),
            ("1 fly", 1),
            ("0 view sideways", 1),
            ("0 move_light 0 1", 1),
            ("0 set_rays 15", 1),
            ("0 set_rays 0", 1),
            ("0 quit\n0 set_intensity 0 -1", 2),
            ("0 set_intensity 0 nan", 1),
        ] {
            let e = format!("{:#}", parse_script(bad, f).unwrap_err());
            assert!(e.contains(&format!("s.txt:{line}")), "{bad}: {e}");
        }
    }
}
