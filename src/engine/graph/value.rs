//! Parameter values: what a graph stores for a parameter, their checks against a spec, and
//! their text form.

use std::fmt;

use super::types::*;

/// A parameter value.
#[derive(Clone, Debug, PartialEq)]
pub enum ParamValue {
    /// Float value.
    Float(f64),
    /// Integer value.
    Int(i64),
    /// Boolean value.
    Bool(bool),
    /// Enum member name.
    Enum(String),
    /// Text value.
    Text(String),
    /// RGBA colour.
    Colour([f64; 4]),
    /// 3-vector.
    Vec3([f64; 3]),
}

impl ParamValue {
    /// The numeric value of a `Float` or `Int`.
    pub fn as_f64(&self) -> Option<f64> {
        match self {
            ParamValue::Float(v) => Some(*v),
            ParamValue::Int(v) => Some(*v as f64),
            _ => None,
        }
    }

    /// Kind name of this value, for messages.
    pub fn kind_name(&self) -> &'static str {
        match self {
            ParamValue::Float(_) => "Float",
            ParamValue::Int(_) => "Int",
            ParamValue::Bool(_) => "Bool",
            ParamValue::Enum(_) => "Enum",
            ParamValue::Text(_) => "Text",
            ParamValue::Colour(_) => "Colour",
            ParamValue::Vec3(_) => "Vec3",
        }
    }

    /// Feed this value into a hasher (floats by bit pattern).
    pub fn hash_into(&self, h: &mut impl std::hash::Hasher) {
        use std::hash::Hash;
        match self {
            ParamValue::Float(v) => (0u8, v.to_bits()).hash(h),
            ParamValue::Int(v) => (1u8, v).hash(h),
            ParamValue::Bool(v) => (2u8, v).hash(h),
            ParamValue::Enum(v) => (3u8, v).hash(h),
            ParamValue::Text(v) => (4u8, v).hash(h),
            ParamValue::Colour(c) => (5u8, c.map(f64::to_bits)).hash(h),
            ParamValue::Vec3(c) => (6u8, c.map(f64::to_bits)).hash(h),
        }
    }
}

impl fmt::Display for ParamValue {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        match self {
            ParamValue::Float(v) => write!(f, "{v}"),
            ParamValue::Int(v) => write!(f, "{v}"),
            ParamValue::Bool(v) => write!(f, "{v}"),
            ParamValue::Enum(v) | ParamValue::Text(v) => f.write_str(v),
            ParamValue::Colour(c) => write!(f, "{},{},{},{}", c[0], c[1], c[2], c[3]),
            ParamValue::Vec3(c) => write!(f, "{},{},{}", c[0], c[1], c[2]),
        }
    }
}

impl ParamSpec {
    /// Check a value against this spec: its kind, enum membership and the hard range.
    pub fn check(&self, value: &ParamValue) -> Result<(), ParamProblem> {
        let in_range = |v: f64| v.is_finite() && v >= self.min && v <= self.max;
        match (&self.kind, value) {
            (ParamKind::Float, ParamValue::Float(_)) | (ParamKind::Int, ParamValue::Int(_)) => {
                let v = value.as_f64().unwrap_or(f64::NAN);
                if in_range(v) {
                    Ok(())
                } else {
                    Err(ParamProblem::OutOfRange(v))
                }
            }
            (ParamKind::Bool, ParamValue::Bool(_)) | (ParamKind::Text, ParamValue::Text(_)) => {
                Ok(())
            }
            (ParamKind::Enum(names), ParamValue::Enum(v)) => {
                if names.contains(&v.as_str()) {
                    Ok(())
                } else {
                    Err(ParamProblem::UnknownEnum(v.clone()))
                }
            }
            (ParamKind::Colour, ParamValue::Colour(c)) => match c.iter().find(|v| !in_range(**v)) {
                None => Ok(()),
                Some(v) => Err(ParamProblem::OutOfRange(*v)),
            },
            (ParamKind::Vec3, ParamValue::Vec3(c)) => match c.iter().find(|v| !in_range(**v)) {
                None => Ok(()),
                Some(v) => Err(ParamProblem::OutOfRange(*v)),
            },
            _ => Err(ParamProblem::WrongType),
        }
    }

    /// Convert a loosely typed value (from RON or the command line) into this parameter's kind:
    /// an integer literal is accepted for a `Float`, a string for an `Enum`, a 3-list (read as
    /// a `Vec3`) for a `Colour` (alpha 1).
    pub fn coerce(&self, value: ParamValue) -> Result<ParamValue, ParamProblem> {
        let v = match (&self.kind, value) {
            (ParamKind::Float, ParamValue::Int(i)) => ParamValue::Float(i as f64),
            (ParamKind::Enum(_), ParamValue::Text(s)) => ParamValue::Enum(s),
            (ParamKind::Text, ParamValue::Enum(s)) => ParamValue::Text(s),
            (ParamKind::Colour, ParamValue::Vec3([r, g, b])) => ParamValue::Colour([r, g, b, 1.0]),
            (_, v) => v,
        };
        self.check(&v)?;
        Ok(v)
    }

    /// Parse a command-line string (`3`, `0.5`, `true`, `Circle`, `1,0.5,0,1`, `x,y,z`) into
    /// this kind.
    pub fn parse_str(&self, s: &str) -> Result<ParamValue, ParamProblem> {
        let v = match self.kind {
            ParamKind::Float => {
                ParamValue::Float(s.trim().parse().map_err(|_| ParamProblem::WrongType)?)
            }
            ParamKind::Int => {
                ParamValue::Int(s.trim().parse().map_err(|_| ParamProblem::WrongType)?)
            }
            ParamKind::Bool => {
                ParamValue::Bool(s.trim().parse().map_err(|_| ParamProblem::WrongType)?)
            }
            ParamKind::Enum(_) => ParamValue::Enum(s.trim().to_string()),
            ParamKind::Text => ParamValue::Text(s.to_string()),
            ParamKind::Colour => {
                let parts: Result<Vec<f64>, _> =
                    s.split(',').map(|p| p.trim().parse::<f64>()).collect();
                let parts = parts.map_err(|_| ParamProblem::WrongType)?;
                match parts.as_slice() {
                    [g] => ParamValue::Colour([*g, *g, *g, 1.0]),
                    [r, g, b] => ParamValue::Colour([*r, *g, *b, 1.0]),
                    [r, g, b, a] => ParamValue::Colour([*r, *g, *b, *a]),
                    _ => return Err(ParamProblem::WrongType),
                }
            }
            ParamKind::Vec3 => {
                let parts: Result<Vec<f64>, _> =
                    s.split(',').map(|p| p.trim().parse::<f64>()).collect();
                match parts.map_err(|_| ParamProblem::WrongType)?.as_slice() {
                    [x, y, z] => ParamValue::Vec3([*x, *y, *z]),
                    _ => return Err(ParamProblem::WrongType),
                }
            }
        };
        self.check(&v)?;
        Ok(v)
    }

    /// Human description of the accepted values, for messages.
    pub fn expected(&self) -> String {
        match self.kind {
            ParamKind::Float | ParamKind::Int => {
                format!(
                    "{} in [{}, {}]",
                    self.kind.name(),
                    num(self.min),
                    num(self.max)
                )
            }
            ParamKind::Colour => format!(
                "Colour [r, g, b, a] with channels in [{}, {}]",
                num(self.min),
                num(self.max)
            ),
            ParamKind::Vec3 => format!(
                "Vec3 [x, y, z] with components in [{}, {}]",
                num(self.min),
                num(self.max)
            ),
            ParamKind::Enum(names) => format!("one of {}", names.join(", ")),
            ParamKind::Bool => "true or false".into(),
            ParamKind::Text => "a string".into(),
        }
    }
}

/// A number for people: large round values in exponent form (`1e30`), others as they are.
pub fn num(v: f64) -> String {
    if v.abs() >= 1e6 && v.fract() == 0.0 {
        format!("{v:e}")
    } else {
        format!("{v}")
    }
}

/// Why a parameter value was refused.
#[derive(Clone, Debug, PartialEq)]
pub enum ParamProblem {
    /// The value's kind does not match the parameter's.
    WrongType,
    /// A numeric value (or colour channel) outside the hard range, or not finite.
    OutOfRange(f64),
    /// An enum value not among the allowed names.
    UnknownEnum(String),
}
