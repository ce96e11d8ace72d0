//! The glTF loader (JSON or binary glTF, meshes, camera, sun, tags) on arbitrary bytes: an
//! error, never a panic.
#![no_main]

use libfuzzer_sys::fuzz_target;

fuzz_target!(|data: &[u8]| {
    let dir = std::env::temp_dir().join(format!("tyndall-fuzz-gltf-{}", std::process::id()));
    let path = dir.join("scene.gltf");
    if std::fs::create_dir_all(&dir).is_ok() && std::fs::write(&path, data).is_ok() {
        let _ = tyndall::scene::load_gltf(&path);
    }
});
