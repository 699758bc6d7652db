//! Subcommands of the `linkgi` binary, one file each.

pub mod animate;
pub mod bench;
pub mod error;
pub mod logger;
pub mod render;
pub mod runtime_dir;
pub mod setup;
pub mod solve;
pub mod view;

use linkgi::scene::TracerKind;

/// Parses `--tracer` (clap value parser): "auto", "bvh", "kd" or "rq".
pub fn parse_tracer(s: &str) -> Result<TracerKind, String> {
    s.parse::<TracerKind>().map_err(|_| format!("unknown tracer \"{s}\": expected auto, bvh, kd or rq"))
}
