//! Typed parameters: a node declares its parameter table and a typed struct in one place with
//! [`params!`](crate::params), and reads every parameter once per run
//! (`let p = Params::from_ctx(ctx)?`), so no node reads a parameter by its name.

use std::collections::BTreeMap;

use super::NodeError;

use crate::graph::{Choice, ParamValue};

/// A node's parameter values read as Rust types, each failure naming the parameter: what
/// [`FromParam`] reads through, for the struct [`params!`](crate::params) declares. Its readers
/// take a parameter's name and are private to the engine, and only the macro makes one
/// ([`ParamReader::for_declared`]), so a technique cannot read a parameter by name: it reads
/// its whole declared struct (`Params::from_ctx`, `Params::from_params`). `tests/platform/shaders.rs`
/// fails on a by-name read under `nodes/`.
#[derive(Clone, Copy)]
pub struct ParamReader<'a>(&'a BTreeMap<String, ParamValue>);

impl<'a> ParamReader<'a> {
    /// The reader of a parameter map, for the code [`params!`](crate::params) expands to only.
    #[doc(hidden)]
    pub fn for_declared(params: &'a BTreeMap<String, ParamValue>) -> Self {
        Self(params)
    }

    fn param(&self, name: &str) -> Result<&'a ParamValue, NodeError> {
        self.0.get(name).ok_or_else(|| NodeError::Param {
            param: name.to_string(),
            message: "not declared by this node".into(),
        })
    }

    /// A `Float` or `Int` parameter as f64.
    pub(crate) fn f64(&self, name: &str) -> Result<f64, NodeError> {
        self.param(name)?.as_f64().ok_or_else(|| NodeError::Param {
            param: name.to_string(),
            message: "is not numeric".into(),
        })
    }

    /// A numeric parameter as f32.
    pub(crate) fn f32(&self, name: &str) -> Result<f32, NodeError> {
        Ok(self.f64(name)? as f32)
    }

    /// An `Int` parameter.
    pub(crate) fn int(&self, name: &str) -> Result<i64, NodeError> {
        match self.param(name)? {
            ParamValue::Int(v) => Ok(*v),
            ParamValue::Float(v) => Ok(v.round() as i64),
            _ => Err(NodeError::Param {
                param: name.to_string(),
                message: "is not an integer".into(),
            }),
        }
    }

    /// A `Bool` parameter.
    pub(crate) fn bool(&self, name: &str) -> Result<bool, NodeError> {
        match self.param(name)? {
            ParamValue::Bool(v) => Ok(*v),
            _ => Err(NodeError::Param {
                param: name.to_string(),
                message: "is not a boolean".into(),
            }),
        }
    }

    /// A `Text` parameter. An `Enum` parameter is refused here: read it with
    /// [`ParamReader::choice`], which checks the value against its names.
    pub(crate) fn text(&self, name: &str) -> Result<&'a str, NodeError> {
        match self.param(name)? {
            ParamValue::Text(v) => Ok(v),
            ParamValue::Enum(_) => Err(NodeError::Param {
                param: name.to_string(),
                message: "is a choice: declare it with its choice type".into(),
            }),
            _ => Err(NodeError::Param {
                param: name.to_string(),
                message: "is not text".into(),
            }),
        }
    }

    /// An `Enum` parameter as its [`Choice`] type (declared with
    /// [`choice_enum!`](crate::choice_enum)). A value that is not one of `T::NAMES` is an error
    /// naming the parameter, the value and the accepted names (the evaluator adds the node):
    /// never a silent fallback to the first option.
    pub(crate) fn choice<T: Choice>(&self, name: &str) -> Result<T, NodeError> {
        let v = self.param(name)?;
        let text = match v {
            ParamValue::Enum(t) | ParamValue::Text(t) => t.as_str(),
            _ => {
                return Err(NodeError::Param {
                    param: name.to_string(),
                    message: format!("is a {}, not one of {}", v.kind_name(), T::NAMES.join(", ")),
                })
            }
        };
        T::from_name(text).ok_or_else(|| NodeError::Param {
            param: name.to_string(),
            message: format!(
                "unknown value \"{text}\" (expected one of {})",
                T::NAMES.join(", ")
            ),
        })
    }

    /// A `Vec3` parameter.
    pub(crate) fn vec3(&self, name: &str) -> Result<[f32; 3], NodeError> {
        match self.param(name)? {
            ParamValue::Vec3(c) => Ok(c.map(|v| v as f32)),
            _ => Err(NodeError::Param {
                param: name.to_string(),
                message: "is not a 3-vector".into(),
            }),
        }
    }

    /// A `Colour` parameter.
    pub(crate) fn colour(&self, name: &str) -> Result<[f32; 4], NodeError> {
        match self.param(name)? {
            ParamValue::Colour(c) => Ok(c.map(|v| v as f32)),
            _ => Err(NodeError::Param {
                param: name.to_string(),
                message: "is not a colour".into(),
            }),
        }
    }
}

/// A Rust type a parameter can be read as (see [`params!`](crate::params)): `f32`, `f64`
/// (`Float`, or `Int` widened), `i64`, `u32` (`Int`; a negative value is an error), `bool`,
/// `String` (`Text`), `[f32; 3]` (`Vec3`), `[f32; 4]` (`Colour`), and every
/// [`choice_enum!`](crate::choice_enum) type (`Enum`).
pub trait FromParam: Sized {
    /// Read parameter `name` as this type.
    fn from_param(r: ParamReader, name: &str) -> Result<Self, NodeError>;
}

/// `FromParam` for types a [`ParamReader`] method reads directly.
macro_rules! from_reader {
    ($($ty:ty => $method:ident),+ $(,)?) => {
        $(impl FromParam for $ty {
            fn from_param(r: ParamReader, name: &str) -> Result<Self, NodeError> {
                r.$method(name)
            }
        })+
    };
}

from_reader!(f32 => f32, f64 => f64, i64 => int, bool => bool, [f32; 3] => vec3, [f32; 4] => colour);

impl FromParam for u32 {
    fn from_param(r: ParamReader, name: &str) -> Result<Self, NodeError> {
        let v = r.int(name)?;
        u32::try_from(v).map_err(|_| NodeError::Param {
            param: name.to_string(),
            message: format!("{v} is not a count (0 … {})", u32::MAX),
        })
    }
}

impl FromParam for String {
    fn from_param(r: ParamReader, name: &str) -> Result<Self, NodeError> {
        r.text(name).map(str::to_string)
    }
}

impl<T: Choice> FromParam for T {
    fn from_param(r: ParamReader, name: &str) -> Result<Self, NodeError> {
        r.choice(name)
    }
}

/// Declare a node's parameters once: the table (`NAME::SPECS`, for the declaration's
/// `params`) and a typed struct read in one call (`NAME::from_ctx(ctx)?`).
///
/// ```text
/// crate::params! {
///     /// Blur's parameters.
///     pub struct Params {
///         sigma: f32 = ParamSpec::float("sigma", 2.0, 0.0, 256.0, "texels", "Standard deviation σ."),
///         shape: Shape = ParamSpec::choice("shape", Shape::NAMES, "Circle", "Footprint."),
///     }
/// }
/// static DECL: NodeDecl = NodeDecl::new(NodeSchema { …, params: Params::SPECS });
/// fn run(&self, ctx: &mut RunCtx) -> Result<(), NodeError> {
///     let p = Params::from_ctx(ctx)?;   // p.sigma: f32, p.shape: Shape
/// ```
///
/// Each field is read as its type through [`FromParam`] from the parameter its spec names; the
/// field and the parameter usually share a name. Fields are crate-visible: the spec's `doc` is
/// the parameter's documentation.
#[macro_export]
macro_rules! params {
    (
        $(#[$meta:meta])*
        $vis:vis struct $name:ident {
            $( $field:ident : $ty:ty = $spec:expr ),+ $(,)?
        }
    ) => {
        $(#[$meta])*
        #[derive(Clone, Debug)]
        $vis struct $name {
            $( pub(crate) $field: $ty ),+
        }

        impl $name {
            /// The parameter table, in field order (the declaration's `params`).
            pub const SPECS: &'static [$crate::graph::ParamSpec] = &[$($spec),+];

            /// Every parameter of the running node, read once as its field's type.
            pub fn from_ctx(ctx: &$crate::eval::RunCtx) -> Result<Self, $crate::eval::NodeError> {
                Self::from_params(ctx.params)
            }

            /// The same from a parameter map (where there is no `RunCtx`: a cache key).
            pub fn from_params(
                params: &::std::collections::BTreeMap<String, $crate::graph::ParamValue>,
            ) -> Result<Self, $crate::eval::NodeError> {
                let r = $crate::eval::ParamReader::for_declared(params);
                Ok(Self {
                    $( $field: <$ty as $crate::eval::FromParam>::from_param(r, {
                        const SPEC: $crate::graph::ParamSpec = $spec;
                        SPEC.name
                    })?, )+
                })
            }

            /// Every parameter at its declared default but those in `overrides` (a CPU
            /// reference's settings, a test's case): the same checks as a node's run.
            pub fn with_overrides(
                overrides: &[(&str, $crate::graph::ParamValue)],
            ) -> Result<Self, $crate::eval::NodeError> {
                let mut params: ::std::collections::BTreeMap<String, $crate::graph::ParamValue> =
                    Self::SPECS
                        .iter()
                        .map(|s| (s.name.to_string(), s.default.value()))
                        .collect();
                for (name, value) in overrides {
                    if !params.contains_key(*name) {
                        return Err($crate::eval::NodeError::Param {
                            param: name.to_string(),
                            message: "not declared by this node".into(),
                        });
                    }
                    params.insert(name.to_string(), value.clone());
                }
                Self::from_params(&params)
            }
        }
    };
}
