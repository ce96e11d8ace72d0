//! The display pass (`shaders/display.wgsl`) against its CPU reference: the viewer's 8-bit
//! sRGB picture (`view::to_srgb8`) and the node thumbnails (`worker::thumbnail_of`), drawn on
//! the GPU from the evaluated texture.

use crate::common;
use tyndall::display::{read_shown, Display, Look};
use tyndall::editor::view::{to_srgb8, Channel};
use tyndall::editor::worker::{thumbnail_of, THUMB};
use tyndall::io::Raster;

/// Each 8-bit channel within 1 of the CPU's: the GPU's `pow` is not bit for bit the CPU's
/// `powf`, so a value within an ulp of a rounding boundary may round the other way; anything
/// wrong in the maths (a channel, the exposure, the curve) is off by many.
fn assert_close(gpu: &[[u8; 4]], cpu: &[[u8; 4]], what: &str) {
    assert_eq!(gpu.len(), cpu.len(), "{what}: sizes");
    let mut off = 0;
    for (i, (g, c)) in gpu.iter().zip(cpu).enumerate() {
        let d = g
            .iter()
            .zip(c)
            .map(|(a, b)| a.abs_diff(*b))
            .max()
            .unwrap_or(0);
        assert!(d <= 1, "{what}: pixel {i}: GPU {g:?}, CPU {c:?}");
        off += usize::from(d > 0);
    }
    // A boundary case is rare: most pixels are exact.
    assert!(
        off * 20 <= gpu.len(),
        "{what}: {off} of {} pixels off by one",
        gpu.len()
    );
}

#[test]
fn the_viewer_picture_matches_the_cpu_for_every_channel_and_exposure() {
    let gpu = require_gpu!();
    let display = Display::new(&gpu).expect("display");
    for channels in [1u32, 4] {
        let mut r = common::random_raster(37, 23, channels, -0.5, 2.0, 11 + channels as u64);
        // Non-finite values show magenta (a one-channel picture's too).
        r.data[5] = f32::NAN;
        r.data[40] = f32::INFINITY;
        let t = gpu
            .upload(r.width, r.height, channels, &r.data)
            .expect("upload");
        for channel in Channel::ALL {
            for stops in [-2.0f32, 0.0, 1.5] {
                let shown = display
                    .draw(&gpu, &t, Look::viewer(channel, stops))
                    .expect("draw");
                let got = read_shown(&gpu, &shown).expect("read");
                let want = to_srgb8(&r, channel, stops);
                assert_close(
                    &got,
                    &want,
                    &format!("{channels} ch, {channel:?}, {stops} stops"),
                );
            }
        }
    }
}

#[test]
fn thumbnails_shrink_and_normalise_like_the_cpu() {
    let gpu = require_gpu!();
    let display = Display::new(&gpu).expect("display");
    // A depth-like picture (values in metres: normalised) and a colour one, neither a multiple
    // of the thumbnail factor (partial boxes at the edges).
    for (channels, lo, hi) in [(1u32, 0.5f32, 40.0f32), (4, 0.0, 1.0)] {
        let r = common::random_raster(250, 131, channels, lo, hi, 7);
        let t = gpu
            .upload(r.width, r.height, channels, &r.data)
            .expect("upload");
        let shown = display
            .draw(&gpu, &t, Look::thumbnail(r.width, r.height, THUMB))
            .expect("draw");
        let cpu = thumbnail_of(&r);
        assert_eq!(shown.size, (cpu.width, cpu.height));
        let got = read_shown(&gpu, &shown).expect("read");
        let want = to_srgb8(&cpu, Channel::Rgb, 0.0);
        let sample: &Raster = &cpu;
        assert!(sample.data.iter().all(|v| *v <= 1.0 + 1e-6), "normalised");
        assert_close(&got, &want, &format!("{channels}-channel thumbnail"));
    }
}

/// The viewer's display / view / look menus (issue #45, item 5): the exposed picture through
/// OpenColorIO's GPU pass (`colour_pass::view`), then quantized by the display pass, against the
/// CPU (`view::to_display8`: the crate's CPU processor) — within one 8-bit step, as above (the
/// GPU transform is within 7e-6 of the CPU's, `tests/nodes/colour.rs`, so only a value at a
/// rounding boundary can differ). ACES 2.0 SDR with and without the built-in config's look,
/// every channel, three exposures, NaN and infinity magenta; the un-tone-mapped view is the
/// plain sRGB picture, and the ACES view is not (it rolls the highlights off).
#[test]
fn the_viewer_display_transform_matches_the_cpu() {
    use tyndall::colour_pass::{view, ViewTransform};
    use tyndall::editor::view::to_display8;
    let gpu = require_gpu!();
    let display = Display::new(&gpu).expect("display");
    let config =
        tyndall::colour::load("ocio://cg-config-v4.0.0_aces-v2.0_ocio-v2.5").expect("config");
    let make = |view: &str, look: &str| {
        ViewTransform::new(&config, "", "sRGB - Display", view, look).expect("transform")
    };
    let aces = "ACES 2.0 - SDR 100 nits (Rec.709)";
    let look = "ACES 1.3 Reference Gamut Compression";
    for channels in [1u32, 4] {
        let mut r = common::random_raster(37, 23, channels, -0.5, 4.0, 3 + channels as u64);
        r.data[5] = f32::NAN;
        r.data[40] = f32::INFINITY;
        let t = gpu
            .upload(r.width, r.height, channels, &r.data)
            .expect("upload");
        for (v, l) in [(aces, ""), (aces, look), ("Un-tone-mapped", "")] {
            let transform = make(v, l);
            for channel in Channel::ALL {
                for stops in [-2.0f32, 0.0, 1.5] {
                    let viewed =
                        view(&gpu.recorder(), transform.pass(), &t, channel, stops).expect("view");
                    let shown = display.draw(&gpu, &viewed, Look::encoded()).expect("draw");
                    let got = read_shown(&gpu, &shown).expect("read");
                    let want = to_display8(&r, channel, stops, Some(&transform));
                    let what = format!("{channels} ch, {v} / {l:?}, {channel:?}, {stops} stops");
                    assert_close(&got, &want, &what);
                    if channels == 1 || matches!(channel, Channel::Rgb | Channel::G | Channel::Luma)
                    {
                        assert_eq!(
                            got[5 / channels as usize],
                            [255, 0, 255, 255],
                            "{what}: NaN"
                        );
                    }
                }
            }
        }
    }
    // The un-tone-mapped view is the plain encoding; the ACES view is another picture.
    let r = common::random_raster(37, 23, 4, 0.0, 4.0, 9);
    let plain = to_srgb8(&r, Channel::Rgb, 0.0);
    let untoned = to_display8(&r, Channel::Rgb, 0.0, Some(&make("Un-tone-mapped", "")));
    assert_close(&untoned, &plain, "Un-tone-mapped against plain sRGB");
    let toned = to_display8(&r, Channel::Rgb, 0.0, Some(&make(aces, "")));
    let apart = toned
        .iter()
        .zip(&plain)
        .filter(|(a, b)| a.iter().zip(b.iter()).any(|(x, y)| x.abs_diff(*y) > 8))
        .count();
    assert!(
        apart * 2 > plain.len(),
        "ACES 2.0 differs from plain sRGB in only {apart} pixels"
    );
}

/// The viewer's menus driven as an artist would: `plain sRGB` → `sRGB - Display` (its default
/// view, ACES 2.0 SDR) changes the picture without reading it back (on every backend but GL,
/// where the editor reads pictures back and converts them on the CPU), the look changes it
/// again, and back to plain sRGB is the first picture exactly. The probe names the working
/// space its values are in.
#[test]
fn the_viewer_menus_apply_a_display_view_and_look() {
    use eframe::egui;
    use egui_kittest::kittest::Queryable;
    if common::gpu().is_none() {
        return;
    }
    let path = std::path::Path::new(env!("CARGO_MANIFEST_DIR")).join("graphs/physical/window.ron");
    let mut h = common::editor::open_sharing(&path, (1200.0, 760.0));
    h.state_mut().selected = Some("composite".into());
    common::editor::settle(&mut h);
    h.run_steps(2);
    let plain = h.render().expect("render");
    let gpu = h.state().evaluation_gpu().expect("evaluating").clone();
    let (_, bytes) = gpu.readbacks();
    let changed = |a: &image::RgbaImage, b: &image::RgbaImage| {
        a.pixels().zip(b.pixels()).filter(|(x, y)| x != y).count()
    };
    h.get_by_value("plain sRGB").click();
    h.run_steps(2);
    h.get_by_label("sRGB - Display").click();
    h.run_steps(4);
    assert_eq!(h.state().viewer_colour.display, "sRGB - Display");
    assert_eq!(h.state().viewer_colour.error(), None);
    let _ = h.get_by_value("ACES 2.0 - SDR 100 nits (Rec.709)");
    let aces = h.render().expect("render");
    // The viewer's picture (about 530×300 on screen) rolls its highlights off.
    let n = changed(&plain, &aces);
    assert!(n > 20_000, "ACES 2.0 changed only {n} pixels");
    if h.state().shares_window_device() {
        let (_, after) = gpu.readbacks();
        assert!(
            after - bytes <= 64,
            "the transform read back {} bytes",
            after - bytes
        );
    }
    h.get_by_value("None").click();
    h.run_steps(2);
    h.get_by_label("ACES 1.3 Reference Gamut Compression")
        .click();
    h.run_steps(4);
    assert_eq!(
        h.state().viewer_colour.look,
        "ACES 1.3 Reference Gamut Compression"
    );
    let looked = h.render().expect("render");
    assert!(changed(&aces, &looked) > 0, "the look changed nothing");
    h.get_by_value("sRGB - Display").click();
    h.run_steps(2);
    h.get_by_label("plain sRGB").click();
    h.run_steps(2);
    // The pointer off the picture (the screenshot draws it), the picture compared.
    h.hover_at(egui::pos2(5.0, 750.0));
    h.run_steps(4);
    let rect = h.get_by_label("viewer picture").rect();
    let back = h.render().expect("render");
    let inside = |img: &image::RgbaImage| {
        let (x0, y0) = (rect.left().ceil() as u32, rect.top().ceil() as u32);
        let (x1, y1) = (rect.right().floor() as u32, rect.bottom().floor() as u32);
        image::imageops::crop_imm(img, x0, y0, x1 - x0, y1 - y0).to_image()
    };
    assert_eq!(changed(&inside(&plain), &inside(&back)), 0);
    // The probe over the picture names the space of its values.
    h.hover_at(rect.center());
    h.run_steps(6);
    assert!(
        h.state().probe.starts_with('('),
        "probe: {:?}",
        h.state().probe
    );
    let _ = h.get_by_label_contains("[Linear Rec.709 (sRGB)]");
}
