//! The OpenVDB reader (VdbVolume's, issue #61) on arbitrary bytes, through a file as users give
//! them: listing the grids and densifying one, an error naming the file, never a panic.
#![no_main]

use libfuzzer_sys::fuzz_target;

fuzz_target!(|data: &[u8]| {
    let path = std::env::temp_dir().join(format!("tyndall-fuzz-{}.vdb", std::process::id()));
    if std::fs::write(&path, data).is_ok() {
        let _ = tyndall::io::vdb_grids(&path);
        let _ = tyndall::io::read_vdb_grid(&path, "density", 64);
    }
});
