//! Subcommands of the `linkgi` binary, one file each.

pub mod animate;
pub mod bench;
pub mod error;
pub mod render;
pub mod solve;
pub mod view;
