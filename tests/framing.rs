//! Automatic framing of scenes without a camera (`render::framing`).

use linkgi::render::framing::auto_camera;
use linkgi::scene::{builtin, prep};

#[test]
fn builtin_rooms_are_framed_from_inside() {
    for name in ["cornell", "window", "tearoom"] {
        let desc = builtin::builtin(name).unwrap();
        let scene = prep::prepare(&desc).unwrap();
        let bvh = linkgi::bvh::Bvh::build(&scene.positions, &scene.triangles, &Default::default());
        let f = auto_camera(&scene, &bvh);
        eprintln!("{name}: {}", f.describe());
    }
}
