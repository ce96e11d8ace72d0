//! EXR and PNG read/write, including files written by another tool (OpenEXR's Python bindings).

use crate::common;
use std::path::Path;

use tyndall::io::{read_image, write_image, Precision, Raster};

fn fixture(name: &str) -> std::path::PathBuf {
    Path::new(env!("CARGO_MANIFEST_DIR"))
        .join("tests/fixtures")
        .join(name)
}

/// The values `tests/fixtures/make_exr.py` wrote (float64 maths rounded once to float32).
pub fn fixture_a(x: u32, y: u32) -> f32 {
    let (x, y) = (x as f64, y as f64);
    ((x + 1.0) / (y + 2.0) - 0.37 * x) as f32
}

/// See [`fixture_a`].
pub fn fixture_b(x: u32, y: u32) -> f32 {
    let (x, y) = (x as f64, y as f64);
    ((y - 5.5) * 0.25 + x / 7.0) as f32
}

#[test]
fn reads_exr_written_by_openexr() {
    let a = read_image(&fixture("A.exr"), true).expect("A");
    let b = read_image(&fixture("B.exr"), true).expect("B");
    assert_eq!((a.width, a.height, a.channels), (16, 12, 1));
    assert_eq!((b.width, b.height, b.channels), (16, 12, 1));
    for y in 0..12 {
        for x in 0..16 {
            assert_eq!(a.pixel(x, y)[0], fixture_a(x, y), "A({x},{y})");
            assert_eq!(b.pixel(x, y)[0], fixture_b(x, y), "B({x},{y})");
        }
    }
    let c = read_image(&fixture("rgba_half.exr"), true).expect("rgba");
    assert_eq!(c.channels, 4);
    let p = c.pixel(8, 6);
    assert_eq!(
        p,
        &[0.5, 0.5, 0.4375, 0.5],
        "half floats decode exactly for these values"
    );
}

#[test]
fn exr_and_png_round_trip_every_precision_and_channel_count() {
    let dir = tempfile::tempdir().expect("tempdir");
    for channels in [1, 4] {
        let r = common::random_raster(7, 5, channels, 0.0, 1.0, 42 + channels as u64);
        for (ext, precision, tol) in [
            ("exr", Precision::F32, 0.0),
            ("exr", Precision::F16, 1.0 / 2048.0), // half: 11 significant bits, values < 1
            ("png", Precision::U8, 0.5 / 255.0 + 1e-6),
            ("png", Precision::U16, 0.5 / 65535.0 + 1e-7),
        ] {
            let path = dir.path().join(format!("r{channels}_{precision:?}.{ext}"));
            write_image(&path, &r, precision, false).expect("write");
            let back = read_image(&path, false).expect("read");
            assert!(common::max_abs_diff(&back, &r) <= tol, "{}", path.display());
        }
    }
}

#[test]
fn writing_replaces_non_finite_and_refuses_bad_combinations() {
    let dir = tempfile::tempdir().expect("tempdir");
    let mut r = Raster::new(2, 1, 1, 0.5);
    r.data[1] = f32::NAN;
    let p = dir.path().join("n.exr");
    write_image(&p, &r, Precision::F32, false).expect("write");
    assert_eq!(read_image(&p, false).expect("read").data, vec![0.5, 0.0]);
    let e = write_image(&dir.path().join("x.png"), &r, Precision::F16, false).expect_err("f16 png");
    assert!(e.to_string().contains("x.png"), "{e}");
    let e = write_image(&dir.path().join("x.tif"), &r, Precision::F32, false).expect_err("tif");
    assert!(e.to_string().contains("x.tif"), "{e}");
    let e = read_image(&fixture("missing.exr"), false).expect_err("missing");
    assert!(e.to_string().contains("missing.exr"), "{e}");
    std::fs::write(dir.path().join("garbage.exr"), b"not an exr").expect("w");
    assert!(read_image(&dir.path().join("garbage.exr"), false).is_err());
}

/// Image writes are atomic: several threads writing the same file at once each go through
/// their own temporary file, every write succeeds, the result is one complete image, and no
/// temporary file is left beside it.
#[test]
fn concurrent_writes_of_one_file_leave_one_complete_image() {
    let dir = tempfile::tempdir().expect("tempdir");
    let path = dir.path().join("same.exr");
    std::thread::scope(|s| {
        for k in 0..6 {
            let path = path.clone();
            s.spawn(move || {
                let r = Raster::new(64, 32, 4, k as f32);
                write_image(&path, &r, Precision::F32, false).expect("write");
            });
        }
    });
    let back = read_image(&path, false).expect("read");
    assert_eq!((back.width, back.height), (64, 32));
    let v = back.data[0];
    assert!(
        back.data.iter().all(|x| *x == v),
        "one writer's image, whole"
    );
    let names: Vec<String> = std::fs::read_dir(dir.path())
        .expect("dir")
        .map(|e| e.expect("entry").file_name().to_string_lossy().into_owned())
        .collect();
    assert_eq!(names, vec!["same.exr".to_string()], "{names:?}");
}

/// Inputs found by fuzzing (`scripts/fuzz.sh`, kept in tests/fixtures/fuzz/ and the seed
/// corpus): an EXR whose header claims 889192434×12 texels (the reader asked for 42 GB and the
/// process aborted), a glTF naming an accessor that does not exist (the gltf crate's validation
/// panicked), one whose position accessor has the wrong shape (the crate's reader asserted) and
/// a GLB whose header length is under 12 (the crate subtracted with overflow). All are now
/// errors naming the file.
#[test]
fn fuzzed_inputs_are_errors_not_crashes() {
    let fixture = |name: &str| {
        std::path::Path::new(env!("CARGO_MANIFEST_DIR"))
            .join("tests/fixtures/fuzz")
            .join(name)
    };
    let e = read_image(&fixture("exr_forged_size.exr"), false).expect_err("forged size");
    assert!(e.to_string().contains("beyond the 16384×16384"), "{e}");
    let e = match tyndall::scene::load_gltf(&fixture("gltf_missing_accessor.gltf")) {
        Ok(_) => panic!("a glTF naming a missing accessor loaded"),
        Err(e) => e,
    };
    assert!(e.to_string().contains("names accessor 0"), "{e}");
    let e = match tyndall::scene::load_gltf(&fixture("gltf_accessor_size.gltf")) {
        Ok(_) => panic!("a glTF whose accessor has the wrong shape loaded"),
        Err(e) => e,
    };
    assert!(e.to_string().contains("is not a"), "{e}");
    let e = match tyndall::scene::load_gltf(&fixture("glb_short_length.gltf")) {
        Ok(_) => panic!("a GLB with a header length under 12 loaded"),
        Err(e) => e,
    };
    assert!(e.to_string().contains("GLB header length"), "{e}");
}

/// A temporary left by a writer of this machine that no longer runs (a render killed
/// mid-write) is removed by the next write of the same file; one of a running process (ours),
/// of another file, or of another machine (shared storage) is left alone.
#[test]
fn stale_temporaries_of_dead_writers_are_removed_by_the_next_write() {
    if !std::path::Path::new("/proc/self").exists() {
        return; // process ids cannot be checked here, so nothing is removed
    }
    let dir = tempfile::tempdir().expect("tempdir");
    let host = tyndall::io::host_tag();
    // A pid above Linux's largest (2^22) never runs.
    let stale = dir.path().join(format!(".x.png.tmp4194305-0-{host}.png"));
    let live = dir
        .path()
        .join(format!(".x.png.tmp{}-999-{host}.png", std::process::id()));
    let other = dir.path().join(format!(".y.png.tmp4194305-0-{host}.png"));
    // Another machine's writer on shared storage: its pid means nothing here.
    let remote = dir.path().join(".x.png.tmp4194305-0-0badf00d.png");
    for p in [&stale, &live, &other, &remote] {
        std::fs::write(p, b"partial").expect("write");
    }
    let r = Raster::new(2, 2, 1, 0.5);
    write_image(&dir.path().join("x.png"), &r, Precision::U8, false).expect("write");
    assert!(!stale.exists(), "the dead writer's temporary is gone");
    assert!(live.exists(), "a running writer's temporary stays");
    assert!(other.exists(), "another file's temporary stays");
    assert!(remote.exists(), "another machine's temporary stays");
}
