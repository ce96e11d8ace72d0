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
