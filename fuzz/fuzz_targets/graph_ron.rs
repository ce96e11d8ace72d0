//! The RON graph loader (parse, migrate, check against the catalog) on arbitrary text: it must
//! return a located error, never panic.
#![no_main]

use libfuzzer_sys::fuzz_target;
use std::sync::OnceLock;

static CATALOG: OnceLock<tyndall::graph::Catalog> = OnceLock::new();

fuzz_target!(|data: &[u8]| {
    let catalog = CATALOG.get_or_init(|| tyndall::nodes::registry().catalog().clone());
    if let Ok(text) = std::str::from_utf8(data) {
        let _ = tyndall::graph::load_str(text, std::path::Path::new("fuzz.ron"), catalog);
    }
});
