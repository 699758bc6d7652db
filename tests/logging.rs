//! The library speaks through `log`: an embedding program's logger gets
//! its notes and warnings (with `linkgi` targets), and nothing is printed.

use log::{Level, LevelFilter, Log, Metadata, Record};
use std::sync::Mutex;

static RECORDS: Mutex<Vec<(Level, String, String)>> = Mutex::new(Vec::new());

struct Capture;

impl Log for Capture {
    fn enabled(&self, _: &Metadata) -> bool {
        true
    }
    fn log(&self, r: &Record) {
        RECORDS.lock().unwrap().push((r.level(), r.target().to_string(), r.args().to_string()));
    }
    fn flush(&self) {}
}

#[test]
fn the_cpu_renderer_fallback_is_logged_as_a_note() {
    static SINK: Capture = Capture;
    log::set_logger(&SINK).unwrap();
    log::set_max_level(LevelFilter::Trace);
    let renderer = linkgi::render::Renderer::open(linkgi::scene::Backend::Cpu);
    assert!(renderer.describe().contains("cpu"), "{}", renderer.describe());
    let records = RECORDS.lock().unwrap();
    let note = records.iter().find(|(_, _, m)| m.contains("rendering on the CPU"));
    let (level, target, _) = note.unwrap_or_else(|| panic!("no record of the fallback: {records:?}"));
    assert_eq!(*level, Level::Info);
    assert!(target.starts_with("linkgi::render"), "{target}");
}
