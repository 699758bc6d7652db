//! The paper's published figures (docs/DESIGN.md, "The paper's figures"; 2008,
//! Core2 2.4 GHz, one or two GeForce 8800 Ultra, 256 rays per vertex, 3
//! bounces), keyed by the scene's upper-cased name. Our `sculpture` stands
//! for the paper's IPHI; `cornell` and `furnace` have no paper row.

use serde::Serialize;

/// One row of the paper's tables. `None`: not given (or unreadable) in the paper.
#[derive(Clone, Copy, Debug, PartialEq, Serialize)]
pub struct PaperRow {
    /// The paper's scene name.
    pub name: &'static str,
    /// GPUs the paper's row used (one or two).
    pub gpus: u32,
    /// Vertices.
    pub vertices: f64,
    /// Kd-tree nodes.
    pub kd_nodes: Option<f64>,
    /// Links in millions.
    pub links_m: f64,
    /// Raw link storage, MB.
    pub mb_raw: f64,
    /// Merged link storage, MB.
    pub mb_merged: f64,
    /// Kd-tree build, ms.
    pub kd_ms: f64,
    /// Link shooting, ms.
    pub links_ms: f64,
    /// Link rays per second, thousands.
    pub k_rays_per_s: f64,
    /// Light links, ms.
    pub light_links_ms: f64,
    /// Three bounces, ms.
    pub bounces_ms: f64,
    /// Time to the first frame, s.
    pub first_frame_s: f64,
    /// Frames per second.
    pub fps: f64,
}

#[allow(clippy::too_many_arguments)]
const fn row(
    name: &'static str,
    gpus: u32,
    vertices: f64,
    kd_nodes: Option<f64>,
    (links_m, mb_raw, mb_merged): (f64, f64, f64),
    (kd_ms, links_ms, k_rays_per_s, light_links_ms, bounces_ms, first_frame_s, fps): (
        f64,
        f64,
        f64,
        f64,
        f64,
        f64,
        f64,
    ),
) -> PaperRow {
    PaperRow {
        name,
        gpus,
        vertices,
        kd_nodes,
        links_m,
        mb_raw,
        mb_merged,
        kd_ms,
        links_ms,
        k_rays_per_s,
        light_links_ms,
        bounces_ms,
        first_frame_s,
        fps,
    }
}

/// Every row of the paper's timing table, with its size figures.
pub const PAPER: [PaperRow; 6] = [
    row("COLORLAMP", 1, 1.6e3, None, (0.4, 3.6, 0.5), (8.0, 833.0, 1930.0, 4.0, 3.0, 0.8, 54.0)),
    row("TORSO", 2, 7.1e3, Some(17.5e3), (1.7, 3.4, 0.8), (78.0, 256.0, 7121.0, 19.0, 4.0, 0.4, 70.0)),
    row("TEAROOM", 1, 11.9e3, Some(14.2e3), (1.5, 6.7, 2.0), (71.0, 680.0, 4472.0, 13.0, 6.0, 0.8, 65.0)),
    row("TEAROOM", 2, 11.9e3, Some(14.2e3), (1.5, 6.7, 2.0), (53.0, 400.0, 7595.0, 15.0, 6.0, 0.5, 75.0)),
    row("IPHI", 2, 76.5e3, Some(109e3), (9.4, 42.0, 12.0), (47.0, 5422.0, 3614.0, 103.0, 56.0, 7.9, 12.6)),
    row("CONFERENCE", 2, 122.8e3, Some(297e3), (30.0, 73.0, 14.0), (218.0, 11403.0, 2755.0, 516.0, 61.0, 14.7, 11.5)),
];

/// The paper's name for one of our scenes: upper case, `sculpture` ↔ IPHI.
pub fn paper_name(scene: &str) -> String {
    match scene.to_ascii_lowercase().as_str() {
        "sculpture" => "IPHI".to_string(),
        s => s.to_ascii_uppercase(),
    }
}

/// The paper's rows for one of our scenes (empty if it has none).
pub fn paper_rows(scene: &str) -> Vec<PaperRow> {
    let name = paper_name(scene);
    PAPER.iter().filter(|r| r.name == name).copied().collect()
}
