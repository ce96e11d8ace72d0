//! The 2D geometry of Epipolar's lines: points on the screen's border and the border
//! coordinate a ray leaves it at (the slices' end points), a line clipped to a rectangle, and a
//! spot's slice line in its perspective map (the image of the slice's plane).

/// The point at border coordinate `u` of a `w × h` screen (0 top-left corner, clockwise, one
/// unit per edge).
pub(super) fn border_point(u: f64, w: f64, h: f64) -> glam::DVec2 {
    let u = u.rem_euclid(4.0);
    let f = u - u.floor();
    match u.floor() as u32 {
        0 => glam::DVec2::new(f * w, 0.0),
        1 => glam::DVec2::new(w, f * h),
        2 => glam::DVec2::new((1.0 - f) * w, h),
        _ => glam::DVec2::new(0.0, (1.0 - f) * h),
    }
}

/// The border coordinate where the ray `pc + r·t`, t > 0, from a point on a `size` screen
/// leaves it (CPU twin of the shader's `border_coordinate`).
pub(super) fn border_coordinate(pc: glam::Vec2, r: glam::Vec2, size: glam::Vec2) -> f32 {
    let exit = |k: usize| {
        if r[k] > 1e-9 {
            (size[k] - pc[k]) / r[k]
        } else if r[k] < -1e-9 {
            -pc[k] / r[k]
        } else {
            3.0e38
        }
    };
    let (tx, ty) = (exit(0), exit(1));
    if tx <= ty {
        let y = ((pc.y + r.y * tx) / size.y).clamp(0.0, 1.0);
        if r.x > 0.0 {
            1.0 + y
        } else {
            4.0 - y
        }
    } else {
        let x = ((pc.x + r.x * ty) / size.x).clamp(0.0, 1.0);
        if r.y < 0.0 {
            x
        } else {
            3.0 - x
        }
    }
}

/// The parameters `[s_in, s_out]` of the line `o + s·d` inside the box `[0, size]`
/// (Liang–Barsky; empty when `s_out < s_in`).
pub(super) fn clip_line(o: glam::DVec2, d: glam::DVec2, size: glam::DVec2) -> (f64, f64) {
    let (mut s_in, mut s_out) = (f64::NEG_INFINITY, f64::INFINITY);
    for k in 0..2 {
        if d[k].abs() < 1e-15 {
            if o[k] < 0.0 || o[k] > size[k] {
                return (1.0, 0.0);
            }
        } else {
            let (a, b) = ((0.0 - o[k]) / d[k], (size[k] - o[k]) / d[k]);
            s_in = s_in.max(a.min(b));
            s_out = s_out.min(a.max(b));
        }
    }
    (s_in, s_out)
}

/// A spot's slice line: the plane through the spot's position holding the directions `a` (to
/// the eye) and `v` (a view ray) is imaged by the spot's perspective map (`lvp`, `msize`
/// texels) as one line, whatever the distance along those directions: every ray of the slice
/// lies on it. Returns its chord through the map as ((origin, unit direction), length), texels;
/// length 0 when it misses the map (a plane at right angles to the spot's axis).
pub(super) fn spot_line(
    lvp: &glam::DMat4,
    msize: glam::DVec2,
    a: glam::DVec3,
    v: glam::DVec3,
) -> ((glam::DVec2, glam::DVec2), f64) {
    use glam::{DVec2, DVec3};
    // The map's clip (x, y, w) of a direction d from the light is linear in d (the light's own
    // position has x = y = w = 0), so the plane's image is the homogeneous line through the
    // images of a and v.
    let image = |d: DVec3| {
        let c = *lvp * d.extend(0.0);
        DVec3::new(c.x, c.y, c.w)
    };
    let l = image(a).cross(image(v));
    let n = DVec2::new(l.x, l.y);
    let miss = ((DVec2::ZERO, DVec2::X), 0.0);
    if n.length_squared() == 0.0 {
        return miss;
    }
    // In NDC: n·(x, y) + l.z = 0; its point nearest the centre and its direction, to texels
    // (x right, y down).
    let p = -n * (l.z / n.length_squared());
    let d = DVec2::new(-n.y, n.x);
    let o = DVec2::new((p.x * 0.5 + 0.5) * msize.x, (0.5 - p.y * 0.5) * msize.y);
    let dir = DVec2::new(d.x * 0.5 * msize.x, -d.y * 0.5 * msize.y).normalize_or(DVec2::X);
    let (s_in, s_out) = clip_line(o, dir, msize);
    if s_out <= s_in {
        return miss;
    }
    ((o + dir * s_in, dir), s_out - s_in)
}
