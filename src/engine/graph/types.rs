//! Port and parameter types: the vocabulary node schemas are written in.

pub(super) use super::value::{ParamProblem, ParamValue};
use std::fmt;

/// The type of data travelling along an edge.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Hash, PartialOrd, Ord)]
pub enum PortType {
    /// Light-space depth (one channel, 0 at the light's near plane, 1 at the far plane) plus the
    /// light's view/projection matrices.
    ShadowMap,
    /// Camera linear depth (one channel) plus the camera's matrices.
    Depth,
    /// A one-channel float image.
    Scalar,
    /// An RGBA float image.
    Image,
    /// A 3D float texture.
    Volume,
    /// A 2D transfer-function texture indexed by (V̄, depth).
    Lut2D,
    /// A light-space RGB texture multiplying the incoming light.
    LightMap,
    /// A 3D scene (meshes, camera, light).
    Scene,
    /// A tabulated phase function.
    Phase,
    /// A light-space soft visibility volume (occlusion per light texel and depth slice) plus
    /// the light's matrices.
    SoftShadow,
    /// Named layers of a multi-layer EXR and the header attributes that go with them
    /// (Cryptomatte's ID/coverage layers and manifest): what `AovOutput` writes as they are named.
    Layers,
}

impl PortType {
    /// Every port type, in declaration order.
    pub const ALL: [PortType; 11] = [
        PortType::ShadowMap,
        PortType::Depth,
        PortType::Scalar,
        PortType::Image,
        PortType::Volume,
        PortType::Lut2D,
        PortType::LightMap,
        PortType::Scene,
        PortType::Phase,
        PortType::SoftShadow,
        PortType::Layers,
    ];

    /// Stable name used in files, the catalog and messages.
    pub fn name(self) -> &'static str {
        match self {
            PortType::ShadowMap => "ShadowMap",
            PortType::Depth => "Depth",
            PortType::Scalar => "Scalar",
            PortType::Image => "Image",
            PortType::Volume => "Volume",
            PortType::Lut2D => "Lut2D",
            PortType::LightMap => "LightMap",
            PortType::Scene => "Scene",
            PortType::Phase => "Phase",
            PortType::SoftShadow => "SoftShadow",
            PortType::Layers => "Layers",
        }
    }

    /// Whether a value of type `self` may flow into a port of type `to`: only identical types
    /// do (a node that accepts several types lists them all), so a `ShadowMap` never silently
    /// loses its matrices by flowing into a `Scalar` port.
    pub fn can_feed(self, to: PortType) -> bool {
        self == to
    }

    /// Whether values of this type are one-channel 2D images on the GPU.
    pub fn is_single_channel(self) -> bool {
        matches!(
            self,
            PortType::ShadowMap | PortType::Depth | PortType::Scalar
        )
    }
}

impl fmt::Display for PortType {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        f.write_str(self.name())
    }
}

/// Direction of a port.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Direction {
    /// Data flows into the node.
    Input,
    /// Data flows out of the node.
    Output,
}

/// A port declared by a node kind.
#[derive(Clone, Copy, Debug)]
pub struct PortSpec {
    /// Stable port name (`node.port` in files).
    pub name: &'static str,
    /// Types this port accepts (inputs) or may produce (outputs). A polymorphic output (more than
    /// one entry) produces the highest-ranked entry that any connected input carries, else the
    /// first entry; see [`crate::graph::Graph::output_type`].
    pub types: &'static [PortType],
    /// Whether an input must be connected for the node to evaluate.
    pub required: bool,
    /// One-line description.
    pub doc: &'static str,
}

impl PortSpec {
    /// An optional input port accepting `types`.
    pub const fn input(name: &'static str, types: &'static [PortType], doc: &'static str) -> Self {
        Self {
            name,
            types,
            required: false,
            doc,
        }
    }

    /// An input port that must be connected for the node to evaluate.
    pub const fn required(
        name: &'static str,
        types: &'static [PortType],
        doc: &'static str,
    ) -> Self {
        Self {
            name,
            types,
            required: true,
            doc,
        }
    }

    /// An output port producing one of `types` (see [`PortSpec::types`]).
    pub const fn output(name: &'static str, types: &'static [PortType], doc: &'static str) -> Self {
        Self {
            name,
            types,
            required: false,
            doc,
        }
    }
}

/// The kind of a parameter's value.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum ParamKind {
    /// A 64-bit float, key-frameable.
    Float,
    /// An integer, key-frameable (interpolated values are rounded to nearest).
    Int,
    /// A boolean.
    Bool,
    /// One of a fixed set of names.
    Enum(&'static [&'static str]),
    /// Free text (paths, names).
    Text,
    /// An RGBA colour, each channel within the parameter's range.
    Colour,
    /// A 3-vector (a position or direction in the scene's coordinates), each component within
    /// the parameter's range: `[x, y, z]` in RON, `x,y,z` on the command line.
    Vec3,
}

impl ParamKind {
    /// Name used in messages and the catalog.
    pub fn name(&self) -> &'static str {
        match self {
            ParamKind::Float => "Float",
            ParamKind::Int => "Int",
            ParamKind::Bool => "Bool",
            ParamKind::Enum(_) => "Enum",
            ParamKind::Text => "Text",
            ParamKind::Colour => "Colour",
            ParamKind::Vec3 => "Vec3",
        }
    }

    /// Whether the parameter can carry key-frames.
    pub fn is_numeric(&self) -> bool {
        matches!(self, ParamKind::Float | ParamKind::Int)
    }
}

/// A parameter's default, written in static node tables.
#[derive(Clone, Copy, Debug)]
pub enum DefaultValue {
    /// Default of a `Float` parameter.
    Float(f64),
    /// Default of an `Int` parameter.
    Int(i64),
    /// Default of a `Bool` parameter.
    Bool(bool),
    /// Default of an `Enum` parameter.
    Enum(&'static str),
    /// Default of a `Text` parameter.
    Text(&'static str),
    /// Default of a `Colour` parameter.
    Colour([f64; 4]),
    /// Default of a `Vec3` parameter.
    Vec3([f64; 3]),
}

impl DefaultValue {
    /// The owned runtime value.
    pub fn value(&self) -> ParamValue {
        match *self {
            DefaultValue::Float(v) => ParamValue::Float(v),
            DefaultValue::Int(v) => ParamValue::Int(v),
            DefaultValue::Bool(v) => ParamValue::Bool(v),
            DefaultValue::Enum(v) => ParamValue::Enum(v.to_string()),
            DefaultValue::Text(v) => ParamValue::Text(v.to_string()),
            DefaultValue::Colour(v) => ParamValue::Colour(v),
            DefaultValue::Vec3(v) => ParamValue::Vec3(v),
        }
    }
}

/// Whether parameter `cond.0` has one of the values `cond.1`, given `value_of` (a parameter's
/// current value, as text): the test of [`ParamSpec::when`] and of
/// [`ProxyScale::LightTexelsWhen`].
pub fn condition_holds(cond: (&str, &[&str]), value_of: impl Fn(&str) -> Option<String>) -> bool {
    value_of(cond.0).is_some_and(|v| cond.1.contains(&v.as_str()))
}

/// A parameter declared by a node kind.
#[derive(Clone, Copy, Debug)]
pub struct ParamSpec {
    /// Stable parameter name.
    pub name: &'static str,
    /// Value kind.
    pub kind: ParamKind,
    /// Default value.
    pub default: DefaultValue,
    /// Hard minimum (numeric kinds and each colour channel); values below are refused.
    pub min: f64,
    /// Hard maximum (numeric kinds and each colour channel); values above are refused.
    pub max: f64,
    /// Unit shown beside the value ("texels", "1/m", "" for none).
    pub unit: &'static str,
    /// One-line description.
    pub doc: &'static str,
    /// When the parameter is in effect: only while parameter `.0` has one of the values `.1`
    /// (e.g. Mie's `radius` only under `preset = custom`); `None`: always. A value set while it
    /// is not in effect is kept but changes nothing: the editor greys it out and `--set` warns.
    pub when: Option<(&'static str, &'static [&'static str])>,
    /// How a proxy evaluation (see [`crate::eval::proxy`]) changes the value, beyond the `px`
    /// unit's rule; declared per parameter, since `texels` also names table sizes that must
    /// not scale. Default [`ProxyScale::ByUnit`].
    pub proxy: ProxyScale,
}

pub use super::proxy_scale::ProxyScale;

impl ParamSpec {
    /// A `Float` parameter: default, hard range `[min, max]`, unit ("" for none).
    pub const fn float(
        name: &'static str,
        default: f64,
        min: f64,
        max: f64,
        unit: &'static str,
        doc: &'static str,
    ) -> Self {
        assert!(
            min <= default && default <= max,
            "float default outside its range"
        );
        Self {
            name,
            kind: ParamKind::Float,
            default: DefaultValue::Float(default),
            min,
            max,
            unit,
            doc,
            when: None,
            proxy: ProxyScale::ByUnit,
        }
    }

    /// An `Int` parameter: default, hard range `[min, max]`, unit ("" for none).
    pub const fn int(
        name: &'static str,
        default: i64,
        min: i64,
        max: i64,
        unit: &'static str,
        doc: &'static str,
    ) -> Self {
        assert!(
            min <= default && default <= max,
            "int default outside its range"
        );
        let (min, max) = (min as f64, max as f64);
        Self {
            name,
            kind: ParamKind::Int,
            default: DefaultValue::Int(default),
            min,
            max,
            unit,
            doc,
            when: None,
            proxy: ProxyScale::ByUnit,
        }
    }

    /// An `Enum` parameter: one of `names` (usually a [`Choice`] type's `NAMES`), `default`
    /// among them (checked when the table is compiled). Read it with `RunCtx::choice`.
    pub const fn choice(
        name: &'static str,
        names: &'static [&'static str],
        default: &'static str,
        doc: &'static str,
    ) -> Self {
        assert!(
            position(names, default).is_some(),
            "choice default not among its names"
        );
        Self {
            name,
            kind: ParamKind::Enum(names),
            default: DefaultValue::Enum(default),
            min: 0.0,
            max: 0.0,
            unit: "",
            doc,
            when: None,
            proxy: ProxyScale::ByUnit,
        }
    }

    /// A `Bool` parameter.
    pub const fn flag(name: &'static str, default: bool, doc: &'static str) -> Self {
        Self {
            name,
            kind: ParamKind::Bool,
            default: DefaultValue::Bool(default),
            min: 0.0,
            max: 0.0,
            unit: "",
            doc,
            when: None,
            proxy: ProxyScale::ByUnit,
        }
    }

    /// A `Text` parameter (paths, names, tag lists).
    pub const fn text(name: &'static str, default: &'static str, doc: &'static str) -> Self {
        Self {
            name,
            kind: ParamKind::Text,
            default: DefaultValue::Text(default),
            min: 0.0,
            max: 0.0,
            unit: "",
            doc,
            when: None,
            proxy: ProxyScale::ByUnit,
        }
    }

    /// A `Colour` parameter (RGBA), every channel of the default and of any value within
    /// `[min, max]`.
    pub const fn colour(
        name: &'static str,
        default: [f64; 4],
        min: f64,
        max: f64,
        unit: &'static str,
        doc: &'static str,
    ) -> Self {
        Self {
            name,
            kind: ParamKind::Colour,
            default: DefaultValue::Colour(default),
            min,
            max,
            unit,
            doc,
            when: None,
            proxy: ProxyScale::ByUnit,
        }
    }

    /// A `Vec3` parameter (`[x, y, z]`), every component within `[min, max]`.
    pub const fn vec3(
        name: &'static str,
        default: [f64; 3],
        min: f64,
        max: f64,
        unit: &'static str,
        doc: &'static str,
    ) -> Self {
        Self {
            name,
            kind: ParamKind::Vec3,
            default: DefaultValue::Vec3(default),
            min,
            max,
            unit,
            doc,
            when: None,
            proxy: ProxyScale::ByUnit,
        }
    }

    /// In effect only while parameter `param` is one of `values` (see [`ParamSpec::when`]).
    pub const fn when(self, param: &'static str, values: &'static [&'static str]) -> Self {
        Self {
            when: Some((param, values)),
            ..self
        }
    }

    /// Whether the parameter is in effect given `value_of` (another parameter's current value,
    /// as text); `Err` names what would make it count, e.g. "only with preset = custom".
    pub fn in_effect(&self, value_of: impl Fn(&str) -> Option<String>) -> Result<(), String> {
        let Some((param, values)) = self.when else {
            return Ok(());
        };
        if condition_holds((param, values), value_of) {
            Ok(())
        } else {
            Err(format!("only with {param} = {}", values.join(" or ")))
        }
    }
}

/// Index of `name` in `names` (usable in constant tables, where `==` on strings is not).
pub const fn position(names: &[&str], name: &str) -> Option<usize> {
    let mut i = 0;
    while i < names.len() {
        let (a, b) = (names[i].as_bytes(), name.as_bytes());
        if a.len() == b.len() {
            let mut j = 0;
            while j < a.len() && a[j] == b[j] {
                j += 1;
            }
            if j == a.len() {
                return Some(i);
            }
        }
        i += 1;
    }
    None
}

/// A Rust enum that mirrors an `Enum` parameter's names, declared with [`choice_enum!`](crate::choice_enum):
/// a node reads its parameter as this type, never by string comparison.
pub trait Choice: Sized + Copy + 'static {
    /// The names as written in files and on the command line, in variant order.
    const NAMES: &'static [&'static str];
    /// The variants, in the same order as [`Choice::NAMES`].
    const ALL: &'static [Self];

    /// The variant named `name`, if any.
    fn from_name(name: &str) -> Option<Self> {
        position(Self::NAMES, name).map(|i| Self::ALL[i])
    }

    /// The variant's name.
    fn name(self) -> &'static str;
}

/// Declare a [`Choice`] enum: variant `= "name in files"` pairs, in the order the shader codes
/// (`as u32`) expect.
///
/// ```
/// tyndall_engine::choice_enum! {
///     /// Footprint of a filter.
///     pub enum Shape { Circle = "Circle", Square = "Square" }
/// }
/// assert_eq!(Shape::NAMES, &["Circle", "Square"]);
/// assert_eq!(Shape::from_name("Square"), Some(Shape::Square));
/// ```
#[macro_export]
macro_rules! choice_enum {
    (
        $(#[$meta:meta])*
        $vis:vis enum $name:ident {
            $( $(#[$vmeta:meta])* $variant:ident = $text:literal ),+ $(,)?
        }
    ) => {
        $(#[$meta])*
        #[derive(Clone, Copy, Debug, PartialEq, Eq, Hash)]
        $vis enum $name {
            $( $(#[$vmeta])* #[doc = concat!("`", $text, "`")] $variant ),+
        }

        impl $name {
            /// The names as written in files and on the command line, in variant order.
            pub const NAMES: &'static [&'static str] = &[$($text),+];
            /// The variants, in the same order as `NAMES`.
            pub const ALL: &'static [Self] = &[$(Self::$variant),+];

            /// The variant's name.
            pub fn name(self) -> &'static str {
                match self {
                    $(Self::$variant => $text),+
                }
            }

            /// The variant named `name`, if any.
            pub fn from_name(name: &str) -> Option<Self> {
                <Self as $crate::graph::Choice>::from_name(name)
            }
        }

        impl $crate::graph::Choice for $name {
            const NAMES: &'static [&'static str] = Self::NAMES;
            const ALL: &'static [Self] = Self::ALL;

            fn name(self) -> &'static str {
                Self::name(self)
            }
        }
    };
}

/// Interpolation from one key-frame to the next.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Hash, serde::Serialize, serde::Deserialize)]
pub enum Interp {
    /// Straight line to the next key.
    Linear,
    /// Keep this key's value until the next key.
    Hold,
}

/// One key-frame of a numeric parameter.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Key {
    /// Time (frames or seconds, as the graph's user chooses).
    pub t: f64,
    /// Value at `t`.
    pub v: f64,
    /// Interpolation towards the next key.
    pub interp: Interp,
}

/// Evaluate a key-frame track (sorted by time, non-empty) at time `t`.
///
/// Before the first key the first value holds, after the last key the last value holds; between
/// two keys the left key's interpolation decides. Returns `None` for an empty track.
pub fn sample_keys(keys: &[Key], t: f64) -> Option<f64> {
    let first = keys.first()?;
    if t <= first.t {
        return Some(first.v);
    }
    for w in keys.windows(2) {
        let (a, b) = (w[0], w[1]);
        if t < b.t {
            return Some(match a.interp {
                Interp::Hold => a.v,
                Interp::Linear => {
                    let span = b.t - a.t;
                    if span <= 0.0 {
                        b.v
                    } else {
                        let u = (t - a.t) / span;
                        a.v + (b.v - a.v) * u
                    }
                }
            });
        }
    }
    keys.last().map(|k| k.v)
}
