//! LightMapSolve's data block: the views and the strokes painted in each.

use super::{Camera, Deserialize, Raster, Serialize, Vec3};

/// The strokes, per view.
#[derive(Debug, Clone, Default, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct SolveData {
    /// The views.
    #[serde(default)]
    pub views: Vec<View>,
}

/// A view and the strokes painted in it.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct View {
    /// Where the view looks from.
    pub camera: ViewCamera,
    /// Width of the view in pixels (strokes are in these pixels).
    #[serde(default = "default_width")]
    pub width: u32,
    /// Height of the view in pixels.
    #[serde(default = "default_height")]
    pub height: u32,
    /// Strokes, painted in order.
    #[serde(default)]
    pub strokes: Vec<Stroke>,
}

pub(super) fn default_width() -> u32 {
    480
}

pub(super) fn default_height() -> u32 {
    270
}

/// A view's camera.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub enum ViewCamera {
    /// The scene's camera.
    Scene,
    /// A camera at `position` looking at `target` with a vertical field of view `fov` (degrees);
    /// near and far planes as the scene's camera.
    Look {
        /// Eye position.
        position: [f32; 3],
        /// Point looked at.
        target: [f32; 3],
        /// Vertical field of view, degrees.
        fov: f32,
    },
}

/// A painted polyline.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct Stroke {
    /// Desired colour of the shafts (linear RGB, relative to a white light map).
    #[serde(default = "white")]
    pub colour: [f32; 3],
    /// Brush diameter in pixels.
    #[serde(default = "default_brush")]
    pub width: f32,
    /// The polyline, pixel coordinates (x right, y down).
    pub points: Vec<[f32; 2]>,
    /// Remove constraints instead of adding them.
    #[serde(default)]
    pub erase: bool,
}

pub(super) fn white() -> [f32; 3] {
    [1.0; 3]
}

pub(super) fn default_brush() -> f32 {
    8.0
}

/// Distance from p to the segment a–b.
pub(super) fn segment_distance(p: [f32; 2], a: [f32; 2], b: [f32; 2]) -> f32 {
    let d = [b[0] - a[0], b[1] - a[1]];
    let len2 = d[0] * d[0] + d[1] * d[1];
    let t = if len2 > 0.0 {
        (((p[0] - a[0]) * d[0] + (p[1] - a[1]) * d[1]) / len2).clamp(0.0, 1.0)
    } else {
        0.0
    };
    let q = [a[0] + d[0] * t - p[0], a[1] + d[1] * t - p[1]];
    (q[0] * q[0] + q[1] * q[1]).sqrt()
}

/// Rasterise a view's strokes: RGBA per pixel, rgb = desired colour, a = 1 on constraints.
pub fn rasterise_strokes(view: &View) -> Raster {
    let (w, h) = (view.width, view.height);
    let mut r = Raster::new(w, h, 4, 0.0);
    for s in &view.strokes {
        let radius = s.width.max(0.0) * 0.5;
        let pts = &s.points;
        if pts.is_empty() {
            continue;
        }
        let lo = pts
            .iter()
            .fold([f32::MAX; 2], |m, p| [m[0].min(p[0]), m[1].min(p[1])]);
        let hi = pts
            .iter()
            .fold([f32::MIN; 2], |m, p| [m[0].max(p[0]), m[1].max(p[1])]);
        let x0 = (lo[0] - radius - 1.0).floor().max(0.0) as u32;
        let y0 = (lo[1] - radius - 1.0).floor().max(0.0) as u32;
        let x1 = ((hi[0] + radius + 1.0).ceil().max(0.0) as u32).min(w);
        let y1 = ((hi[1] + radius + 1.0).ceil().max(0.0) as u32).min(h);
        for y in y0..y1 {
            for x in x0..x1 {
                let p = [x as f32 + 0.5, y as f32 + 0.5];
                let d = if pts.len() == 1 {
                    segment_distance(p, pts[0], pts[0])
                } else {
                    pts.windows(2)
                        .map(|ab| segment_distance(p, ab[0], ab[1]))
                        .fold(f32::INFINITY, f32::min)
                };
                if d <= radius {
                    let k = ((y * w + x) * 4) as usize;
                    let v = if s.erase {
                        [0.0; 4]
                    } else {
                        [s.colour[0], s.colour[1], s.colour[2], 1.0]
                    };
                    r.data[k..k + 4].copy_from_slice(&v);
                }
            }
        }
    }
    r
}

/// The scene camera a view uses.
pub fn view_camera(v: &View, scene: &Camera) -> Camera {
    match &v.camera {
        ViewCamera::Scene => *scene,
        ViewCamera::Look {
            position,
            target,
            fov,
        } => Camera {
            position: Vec3::from(*position),
            target: Vec3::from(*target),
            fov_y: *fov,
            ..*scene
        },
    }
}
