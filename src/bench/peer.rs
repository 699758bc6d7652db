//! Embree 3 beside us: runs the peer program `../shared/peers/embree_peer`
//! (a small C program over Debian's `libembree-dev`) on the very mesh a
//! benchmark solved, so our link-ray rate can be set beside Embree's measured
//! in the same run on the same machine.
//!
//! The peer shoots the link stage's workload: from every solver vertex `K`
//! cosine-weighted rays (stratified `k x k` grid, concentric map, per-vertex
//! rotation, 4 x 4 blocks), origins offset `1e-4 x` the bbox diagonal along
//! the normal and, with `--nudge`, crease vertices moved into their own faces.
//! It traces them with `rtcIntersect1` (single rays) and `rtcIntersect16`
//! (one packet per 4 x 4 block) on `T` threads, best of `R` traces, and times
//! the `RTC_BUILD_QUALITY_HIGH` build (best of 3).
//!
//! Units: [`PeerFigures::mrays_single`] and [`PeerFigures::mrays_packet16`]
//! in millions of rays per second, [`PeerFigures::build_ms`] in ms.
//!
//! The peer is optional: [`find`] gives `None` when it is not there, and the
//! benchmark then has no peer figures. Every failure (the PLY cannot be
//! written, the peer cannot start, exits non-zero, or prints no figures line)
//! is a [`crate::Error`] naming the file, never a panic.

use crate::scene::prep::PreparedScene;
use crate::{Error, Result};
use serde::Serialize;
use std::path::{Path, PathBuf};
use std::process::Command;

/// Environment variable naming the peer binary; it overrides the default place.
pub const ENV: &str = "LINKGI_EMBREE_PEER";

/// Where the peer is built by `make -C ../shared/peers/embree_peer`,
/// relative to the current directory (the project root).
pub const DEFAULT_PATH: &str = "../shared/peers/embree_peer/peer";

/// Embree's figures on one mesh.
#[derive(Clone, Copy, Debug, Default, PartialEq, Serialize)]
pub struct PeerFigures {
    /// `rtcIntersect1` (incoherent single rays), M rays/s, best of the traces.
    pub mrays_single: f64,
    /// `rtcIntersect16` (one packet per 4 x 4 block of directions), M rays/s.
    pub mrays_packet16: f64,
    /// BVH build (`rtcCommitScene`, quality high), ms, best of 3.
    pub build_ms: f64,
}

/// The peer binary: the path in [`ENV`] if set, else [`DEFAULT_PATH`] under
/// the current directory; `None` when that is not an executable file.
pub fn find() -> Option<PathBuf> {
    let cwd = std::env::current_dir().ok()?;
    find_in(std::env::var_os(ENV).map(PathBuf::from), &cwd)
}

/// [`find`] with the environment value and current directory given.
fn find_in(env: Option<PathBuf>, cwd: &Path) -> Option<PathBuf> {
    let path = match env {
        Some(p) if !p.as_os_str().is_empty() => cwd.join(p),
        _ => cwd.join(DEFAULT_PATH),
    };
    is_executable(&path).then_some(path)
}

#[cfg(unix)]
fn is_executable(path: &Path) -> bool {
    use std::os::unix::fs::PermissionsExt;
    std::fs::metadata(path).is_ok_and(|m| m.is_file() && m.permissions().mode() & 0o111 != 0)
}

#[cfg(not(unix))]
fn is_executable(path: &Path) -> bool {
    path.is_file()
}

pub use crate::export::mesh_ply_bytes;

fn other(path: &Path, message: String) -> Error {
    Error::Io { path: path.to_path_buf(), source: std::io::Error::other(message) }
}

/// The figures from the peer's output: its last line that starts with
/// `embree_mrays_per_s_single=`, of the form
/// `embree_mrays_per_s_single=X embree_mrays_per_s_packet16=Y build_ms=Z`
/// (keys in any order; all three finite and non-negative). `None` otherwise.
pub fn parse(stdout: &str) -> Option<PeerFigures> {
    let line = stdout.lines().rev().map(str::trim).find(|l| l.starts_with("embree_mrays_per_s_single="))?;
    let (mut single, mut packet, mut build) = (None, None, None);
    for field in line.split_whitespace() {
        let (key, value) = field.split_once('=')?;
        let value: f64 = value.parse().ok().filter(|v: &f64| v.is_finite() && *v >= 0.0)?;
        let slot = match key {
            "embree_mrays_per_s_single" => &mut single,
            "embree_mrays_per_s_packet16" => &mut packet,
            "build_ms" => &mut build,
            _ => continue,
        };
        *slot = Some(value);
    }
    Some(PeerFigures { mrays_single: single?, mrays_packet16: packet?, build_ms: build? })
}

/// Writes `scene`'s mesh to a fresh temporary directory and runs
/// `peer mesh.ply --rays K --nudge --repeat R --threads T` on it; the
/// directory is removed afterwards.
pub fn run(peer: &Path, scene: &PreparedScene, rays: u32, repeat: u32, threads: usize) -> Result<PeerFigures> {
    let dir = temp_dir();
    std::fs::create_dir_all(&dir).map_err(|source| Error::Io { path: dir.clone(), source })?;
    let result = run_in(&dir, peer, scene, rays, repeat, threads);
    let _ = std::fs::remove_dir_all(&dir);
    result
}

fn temp_dir() -> PathBuf {
    use std::sync::atomic::{AtomicU32, Ordering};
    static COUNTER: AtomicU32 = AtomicU32::new(0);
    let nanos = std::time::SystemTime::now().duration_since(std::time::UNIX_EPOCH).map_or(0, |d| d.subsec_nanos());
    std::env::temp_dir().join(format!(
        "linkgi-embree-peer-{}-{}-{nanos}",
        std::process::id(),
        COUNTER.fetch_add(1, Ordering::Relaxed)
    ))
}

fn run_in(
    dir: &Path,
    peer: &Path,
    scene: &PreparedScene,
    rays: u32,
    repeat: u32,
    threads: usize,
) -> Result<PeerFigures> {
    let ply = dir.join("mesh.ply");
    std::fs::write(&ply, mesh_ply_bytes(scene)).map_err(|source| Error::Io { path: ply.clone(), source })?;
    let output = Command::new(peer)
        .arg(&ply)
        .args(["--rays", &rays.to_string(), "--nudge"])
        .args(["--repeat", &repeat.max(1).to_string(), "--threads", &threads.max(1).to_string()])
        .output()
        .map_err(|source| Error::Io { path: peer.to_path_buf(), source })?;
    let stdout = String::from_utf8_lossy(&output.stdout);
    let stderr = String::from_utf8_lossy(&output.stderr);
    let tail = |s: &str| s.trim().lines().last().unwrap_or("").to_string();
    if !output.status.success() {
        let msg = [tail(&stderr), tail(&stdout)]
            .into_iter()
            .find(|m| !m.is_empty())
            .unwrap_or_else(|| "no output".to_string());
        return Err(other(peer, format!("Embree peer failed ({}) on {}: {msg}", output.status, ply.display())));
    }
    parse(&stdout).ok_or_else(|| {
        other(
            peer,
            format!(
                "Embree peer printed no 'embree_mrays_per_s_single=X embree_mrays_per_s_packet16=Y build_ms=Z' \
                 line (last line: '{}')",
                tail(&stdout)
            ),
        )
    })
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn parses_the_figures_line() {
        let out = "file mesh.ply: vertices 24, triangles 12\n\
                   single (rtcIntersect1, incoherent)     trace 0.000 s, hits 1536 (100.00%), 14.64 Mrays/s\n\
                   embree_mrays_per_s_single=14.640 embree_mrays_per_s_packet16=19.962 build_ms=0.01\n";
        let f = parse(out).expect("figures");
        assert_eq!(f, PeerFigures { mrays_single: 14.64, mrays_packet16: 19.962, build_ms: 0.01 });
        // Keys in another order, trailing blank line, extra key.
        let f =
            parse("build_ms=57 x\nembree_mrays_per_s_single=1 build_ms=2.5 embree_mrays_per_s_packet16=3 extra=4\n\n");
        assert_eq!(f, Some(PeerFigures { mrays_single: 1.0, mrays_packet16: 3.0, build_ms: 2.5 }));
    }

    #[test]
    fn garbage_gives_none() {
        for bad in [
            "",
            "Segmentation fault",
            "peer: mesh.ply: cannot open file",
            "embree_mrays_per_s_single=abc embree_mrays_per_s_packet16=1 build_ms=2",
            "embree_mrays_per_s_single=1 embree_mrays_per_s_packet16=2",
            "embree_mrays_per_s_single=nan embree_mrays_per_s_packet16=1 build_ms=2",
            "embree_mrays_per_s_single=-1 embree_mrays_per_s_packet16=1 build_ms=2",
            "embree_mrays_per_s_single=1 embree_mrays_per_s_packet16 build_ms=2",
            "\u{0}\u{1}binary\u{ff} junk",
        ] {
            assert_eq!(parse(bad), None, "{bad:?}");
        }
    }

    #[test]
    fn finds_only_executables() {
        let dir = temp_dir();
        std::fs::create_dir_all(dir.join("a")).unwrap();
        assert_eq!(find_in(None, &dir.join("a")), None);
        assert_eq!(find_in(Some("missing".into()), &dir), None);
        let exe = dir.join("peer");
        std::fs::write(&exe, "#!/bin/sh\n").unwrap();
        #[cfg(unix)]
        {
            use std::os::unix::fs::PermissionsExt;
            assert_eq!(find_in(Some(exe.clone()), &dir), None, "not executable");
            std::fs::set_permissions(&exe, std::fs::Permissions::from_mode(0o755)).unwrap();
        }
        assert_eq!(find_in(Some(exe.clone()), &dir.join("a")), Some(exe.clone()));
        assert_eq!(find_in(Some("peer".into()), &dir), Some(exe.clone()), "relative to cwd");
        let _ = std::fs::remove_dir_all(&dir);
    }

    /// [`run`], retried while the fresh script is "busy": another test thread
    /// may fork while our write handle is open (ETXTBSY), for a moment.
    #[cfg(unix)]
    fn run_retrying(peer: &Path, scene: &PreparedScene, rays: u32, repeat: u32, threads: usize) -> Result<PeerFigures> {
        for _ in 0..20 {
            match run(peer, scene, rays, repeat, threads) {
                Err(Error::Io { source, .. }) if source.kind() == std::io::ErrorKind::ExecutableFileBusy => {
                    std::thread::sleep(std::time::Duration::from_millis(50))
                }
                r => return r,
            }
        }
        run(peer, scene, rays, repeat, threads)
    }

    #[cfg(unix)]
    #[test]
    fn a_failing_or_silent_peer_is_an_error() {
        use std::os::unix::fs::PermissionsExt;
        let desc = crate::scene::load("cornell").unwrap();
        let scene = crate::scene::prep::prepare(&desc).unwrap();
        let bytes = mesh_ply_bytes(&scene);
        let header_end = bytes.windows(11).position(|w| w == b"end_header\n").unwrap() + 11;
        assert_eq!(bytes.len(), header_end + scene.vertex_count() * 24 + scene.triangles.len() * 13);
        let dir = temp_dir();
        std::fs::create_dir_all(&dir).unwrap();
        let script = |name: &str, body: &str| {
            let p = dir.join(name);
            std::fs::write(&p, format!("#!/bin/sh\n{body}\n")).unwrap();
            std::fs::set_permissions(&p, std::fs::Permissions::from_mode(0o755)).unwrap();
            p
        };
        let crash = script("crash", "echo 'peer: bad input' >&2; exit 2");
        let e = run_retrying(&crash, &scene, 16, 1, 1).unwrap_err().to_string();
        assert!(e.contains("failed") && e.contains("peer: bad input"), "{e}");
        let silent = script("silent", "echo hello");
        let e = run_retrying(&silent, &scene, 16, 1, 1).unwrap_err().to_string();
        assert!(e.contains("no 'embree_mrays_per_s_single") && e.contains("hello"), "{e}");
        // A stand-in that checks its arguments and the PLY it was given.
        let good = script(
            "good",
            "test \"$2 $3 $4 $5 $6 $7 $8\" = '--rays 16 --nudge --repeat 2 --threads 3' || exit 3\n\
             head -c 3 \"$1\" | grep -q ply || exit 4\n\
             echo 'embree_mrays_per_s_single=1.5 embree_mrays_per_s_packet16=2 build_ms=0.25'",
        );
        let f = run_retrying(&good, &scene, 16, 2, 3).unwrap();
        assert_eq!(f, PeerFigures { mrays_single: 1.5, mrays_packet16: 2.0, build_ms: 0.25 });
        let _ = std::fs::remove_dir_all(&dir);
    }
}
