//! The binary's `log` sink: what the library says (`log::warn!`,
//! `log::info!`, `log::error!`) printed to stderr as `warning: ...`,
//! `note: ...` and `error: ...`, the lines the command-line tool always
//! printed. Only linkgi's own records: wgpu and the windowing crates log
//! their internals at the same levels.

use log::{Level, LevelFilter, Log, Metadata, Record};

struct Stderr;

impl Log for Stderr {
    fn enabled(&self, m: &Metadata) -> bool {
        m.level() <= Level::Info && m.target().starts_with("linkgi")
    }

    fn log(&self, r: &Record) {
        if self.enabled(r.metadata()) {
            let tag = match r.level() {
                Level::Error => "error",
                Level::Warn => "warning",
                _ => "note",
            };
            eprintln!("{tag}: {}", r.args());
        }
    }

    fn flush(&self) {}
}

/// Installs the sink (once; a second call changes nothing).
pub fn install() {
    static SINK: Stderr = Stderr;
    if log::set_logger(&SINK).is_ok() {
        log::set_max_level(LevelFilter::Info);
    }
}
