//! The EXR reader on arbitrary bytes (through a file, as users give them): an error, never a
//! panic.
#![no_main]

use libfuzzer_sys::fuzz_target;

fuzz_target!(|data: &[u8]| {
    let path = std::env::temp_dir().join(format!("tyndall-fuzz-{}.exr", std::process::id()));
    if std::fs::write(&path, data).is_ok() {
        let _ = tyndall::io::read_image(&path, true);
    }
});
