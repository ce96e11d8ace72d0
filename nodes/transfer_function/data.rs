//! TransferFunction's data block: the layer stack, its key-frames and its constraints.

use super::{Deserialize, Serialize};

pub use crate::algorithms::multigrid::Rgba;

/// The node's data block: a layer stack, or key-framed stacks.
#[derive(Debug, Clone, Default, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct TfData {
    /// The layer stack, bottom first (used when `keys` is empty).
    #[serde(default)]
    pub layers: Vec<LayerEntry>,
    /// Key-framed stacks, interpolated linearly in time.
    #[serde(default, skip_serializing_if = "Vec::is_empty")]
    pub keys: Vec<TfKey>,
}

/// A layer stack at a time.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct TfKey {
    /// Time (frames).
    pub t: f64,
    /// The stack at that time.
    pub layers: Vec<LayerEntry>,
}

/// One layer with its blend mode and opacity.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct LayerEntry {
    /// What the layer paints.
    pub layer: Layer,
    /// How it composites over the layers below (default `Alpha`).
    #[serde(default)]
    pub blend: Blend,
    /// Opacity, 0…1 (default 1).
    #[serde(default = "one")]
    pub opacity: f32,
}

pub(super) fn one() -> f32 {
    1.0
}

/// How a layer composites over the ones below.
#[derive(Debug, Clone, Copy, Default, PartialEq, Eq, Serialize, Deserialize)]
pub enum Blend {
    /// dst·(1 − a) + src·a.
    #[default]
    Alpha,
    /// dst·(1 − a) + dst·src·a.
    Multiply,
    /// dst + src·a.
    Add,
}

/// What a layer paints over TF space.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub enum Layer {
    /// One colour.
    Solid {
        /// The colour.
        colour: Rgba,
    },
    /// A linear gradient along the segment `from` → `to` (TF coordinates), clamped.
    Gradient {
        /// Start point (u, v).
        from: [f32; 2],
        /// End point (u, v).
        to: [f32; 2],
        /// Colour at `from` and before.
        from_colour: Rgba,
        /// Colour at `to` and beyond.
        to_colour: Rgba,
    },
    /// Constraints diffused over the layer (harmonic interpolation).
    Diffusion {
        /// The constraints.
        constraints: Vec<Constraint>,
    },
    /// A picture stretched over TF space.
    Image {
        /// The file (PNG or EXR); a relative path is read from the graph file's folder.
        path: String,
    },
}

/// A diffusion constraint.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct Constraint {
    /// Position (u, v) in TF space.
    pub at: [f32; 2],
    /// Colour and alpha.
    pub colour: Rgba,
    /// A surface point the constraint follows (not supported yet).
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub anchor: Option<Anchor>,
}

/// A surface point: an object's triangle and barycentric coordinates.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct Anchor {
    /// Object name in the scene.
    pub object: String,
    /// Triangle index within the object.
    pub triangle: u32,
    /// Barycentric coordinates.
    pub bary: [f32; 3],
}

pub(super) fn lerp(a: f32, b: f32, f: f32) -> f32 {
    a + (b - a) * f
}

pub(super) fn lerp_n<const N: usize>(a: [f32; N], b: [f32; N], f: f32) -> [f32; N] {
    std::array::from_fn(|i| lerp(a[i], b[i], f))
}

/// Interpolate layer `i` of two stacks; `Err` says why they cannot be.
pub(super) fn lerp_layer(a: &LayerEntry, b: &LayerEntry, f: f32) -> Result<LayerEntry, String> {
    if a.blend != b.blend {
        return Err(format!("blend {:?} vs {:?}", a.blend, b.blend));
    }
    let layer = match (&a.layer, &b.layer) {
        (Layer::Solid { colour: x }, Layer::Solid { colour: y }) => Layer::Solid {
            colour: lerp_n(*x, *y, f),
        },
        (
            Layer::Gradient {
                from: f0,
                to: t0,
                from_colour: c0,
                to_colour: d0,
            },
            Layer::Gradient {
                from: f1,
                to: t1,
                from_colour: c1,
                to_colour: d1,
            },
        ) => Layer::Gradient {
            from: lerp_n(*f0, *f1, f),
            to: lerp_n(*t0, *t1, f),
            from_colour: lerp_n(*c0, *c1, f),
            to_colour: lerp_n(*d0, *d1, f),
        },
        (Layer::Diffusion { constraints: x }, Layer::Diffusion { constraints: y }) => {
            if x.len() != y.len() {
                return Err(format!("{} vs {} constraints", x.len(), y.len()));
            }
            Layer::Diffusion {
                constraints: x
                    .iter()
                    .zip(y)
                    .map(|(p, q)| Constraint {
                        at: lerp_n(p.at, q.at, f),
                        colour: lerp_n(p.colour, q.colour, f),
                        anchor: p.anchor.clone(),
                    })
                    .collect(),
            }
        }
        (Layer::Image { path: p }, Layer::Image { path: q }) if p == q => a.layer.clone(),
        (x, y) => {
            return Err(format!(
                "{} vs {}",
                layer_name(x, true),
                layer_name(y, true)
            ))
        }
    };
    Ok(LayerEntry {
        layer,
        blend: a.blend,
        opacity: lerp(a.opacity, b.opacity, f),
    })
}

/// A layer's kind name (with its image path when `detail`).
pub fn layer_name(l: &Layer, detail: bool) -> String {
    match l {
        Layer::Solid { .. } => "Solid".into(),
        Layer::Gradient { .. } => "Gradient".into(),
        Layer::Diffusion { .. } => "Diffusion".into(),
        Layer::Image { path } if detail => format!("Image({path:?})"),
        Layer::Image { .. } => "Image".into(),
    }
}

impl TfData {
    /// The layer stack at time `t` (key-frames interpolated linearly).
    pub fn stack_at(&self, t: f64) -> Result<Vec<LayerEntry>, String> {
        if self.keys.is_empty() {
            return Ok(self.layers.clone());
        }
        if !self.layers.is_empty() {
            return Err("give either `layers` or `keys`, not both".into());
        }
        let mut keys: Vec<&TfKey> = self.keys.iter().collect();
        keys.sort_by(|a, b| a.t.total_cmp(&b.t));
        let first = keys[0];
        let last = keys[keys.len() - 1];
        if t <= first.t {
            return Ok(first.layers.clone());
        }
        if t >= last.t {
            return Ok(last.layers.clone());
        }
        let i = keys.iter().rposition(|k| k.t <= t).unwrap_or(0);
        let (a, b) = (keys[i], keys[i + 1]);
        let f = ((t - a.t) / (b.t - a.t).max(1e-12)) as f32;
        if a.layers.len() != b.layers.len() {
            return Err(format!(
                "keys at t = {} and t = {} have {} and {} layers: key-framed stacks must have the same layers",
                a.t,
                b.t,
                a.layers.len(),
                b.layers.len()
            ));
        }
        a.layers
            .iter()
            .zip(&b.layers)
            .enumerate()
            .map(|(n, (x, y))| {
                lerp_layer(x, y, f).map_err(|e| {
                    format!(
                        "keys at t = {} and t = {} differ in layer {n} ({e}): key-framed stacks must have the same layers",
                        a.t, b.t
                    )
                })
            })
            .collect()
    }

    /// Whether the stack changes with time.
    pub fn keyed(&self) -> bool {
        self.keys.len() > 1
    }
}

// ---------------------------------------------------------------------------------------------
// CPU reference.
