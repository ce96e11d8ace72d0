//! The viewer's picture maths, kept apart from egui so it can be tested: which channel to show,
//! exposure in stops, the 8-bit sRGB picture (or the picture through a display / view / look
//! of the colour config), and the pixel probe's text.

use tyndall_engine::colour_pass::ViewTransform;
use tyndall_engine::io::{linear_to_srgb, Raster};

pub use tyndall_engine::display::Channel;

/// The displayed linear RGB of pixel `i` of `r` (before exposure).
pub fn shown_rgb(r: &Raster, i: usize, channel: Channel) -> [f32; 3] {
    if r.channels == 1 {
        let v = r.data[i];
        return [v, v, v];
    }
    let p = &r.data[i * 4..i * 4 + 4];
    let grey = |v: f32| [v, v, v];
    match channel {
        Channel::Rgb => [p[0], p[1], p[2]],
        Channel::R => grey(p[0]),
        Channel::G => grey(p[1]),
        Channel::B => grey(p[2]),
        Channel::A => grey(p[3]),
        Channel::Luma => grey(0.2126 * p[0] + 0.7152 * p[1] + 0.0722 * p[2]),
    }
}

/// 8-bit sRGB pixels (RGBA, opaque) of `r` with `channel` shown and `stops` of exposure
/// (multiplied by 2^stops). Non-finite values show as magenta so they cannot hide.
pub fn to_srgb8(r: &Raster, channel: Channel, stops: f32) -> Vec<[u8; 4]> {
    to_display8(r, channel, stops, None)
}

/// 8-bit pixels (RGBA, opaque) of `r` as the viewer shows them: `channel`, `stops` of exposure,
/// then `transform` (a display / view / look; its display values clamped to [0, 1] and
/// quantized) or, without one, the sRGB encoding. Non-finite values show as magenta. The CPU
/// reference of the display pass (`shaders/display.wgsl`, after `colour_pass::view`).
pub fn to_display8(
    r: &Raster,
    channel: Channel,
    stops: f32,
    transform: Option<&ViewTransform>,
) -> Vec<[u8; 4]> {
    let gain = 2f32.powf(stops);
    let q = |x: f32| (x.clamp(0.0, 1.0) * 255.0).round() as u8;
    (0..(r.width * r.height) as usize)
        .map(|i| {
            let c = shown_rgb(r, i, channel).map(|v| v * gain);
            if c.iter().any(|v| !v.is_finite()) {
                return [255, 0, 255, 255];
            }
            let d = match transform {
                Some(t) => t.rgb(c),
                None => c.map(|v| linear_to_srgb(v.clamp(0.0, 1.0))),
            };
            if d.iter().any(|v| !v.is_finite()) {
                return [255, 0, 255, 255];
            }
            [q(d[0]), q(d[1]), q(d[2]), 255]
        })
        .collect()
}

/// The probe's line for pixel (x, y): every picture's value there, by port name (`visibility
/// 0.412  depth 12.7 …` for a scattering node: V̄ and linear depth).
pub fn probe(pictures: &[(String, Raster)], x: u32, y: u32) -> String {
    let values: Vec<(String, Vec<f32>)> = pictures
        .iter()
        .filter(|(_, r)| x < r.width && y < r.height)
        .map(|(port, r)| {
            let i = (y * r.width + x) as usize * r.channels as usize;
            (port.clone(), r.data[i..i + r.channels as usize].to_vec())
        })
        .collect();
    probe_line(x, y, &values)
}

/// The probe's line for pixel (x, y) from each port's values there (one or four channels).
pub fn probe_line(x: u32, y: u32, values: &[(String, Vec<f32>)]) -> String {
    let mut parts = vec![format!("({x}, {y})")];
    for (port, v) in values {
        let text = match v.as_slice() {
            [a] => format!("{a:.4}"),
            [a, b, c, d, ..] => format!("({a:.4}, {b:.4}, {c:.4}, {d:.4})"),
            other => format!("{other:.4?}"),
        };
        parts.push(format!("{port} {text}"));
    }
    parts.join("   ")
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn exposure_channel_and_bad_values() {
        let r = Raster {
            width: 2,
            height: 1,
            channels: 4,
            data: vec![0.25, 0.5, 1.0, 0.0, f32::NAN, 0.0, 0.0, 1.0],
        };
        let px = to_srgb8(&r, Channel::R, 1.0);
        // 0.25 · 2 = 0.5 linear → 188 in sRGB.
        assert_eq!(px[0], [188, 188, 188, 255]);
        assert_eq!(px[1], [255, 0, 255, 255], "NaN shows as magenta");
        assert_eq!(to_srgb8(&r, Channel::A, 0.0)[0], [0, 0, 0, 255]);
        assert!(probe(&[("image".into(), r)], 0, 0).contains("(0.2500, 0.5000, 1.0000"));
    }
}
