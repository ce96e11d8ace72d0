//! A node's data block: structured content that is not a parameter (transfer-function layers,
//! painted strokes, splats), kept as RON text exactly as written.
//!
//! The text is kept verbatim rather than as a parsed [`ron::Value`]: a `Value` drops enum
//! variant and struct names (`Solid(colour: …)` would come back as a bare map and `blend:
//! Alpha` as `()`), so a node could not read back what the file said. The node that owns the
//! block parses it into its own typed structure with [`NodeData::parse`].

use std::fmt;
use std::hash::{Hash, Hasher};

use ron::value::RawValue;
use serde::de::DeserializeOwned;
use serde::{Deserialize, Deserializer, Serialize, Serializer};

/// A node's data block as RON text (see the module docs).
#[derive(Clone, PartialEq, Eq)]
pub struct NodeData(Box<RawValue>);

impl NodeData {
    /// Check `text` is one RON value and keep it (trimmed). Errors give the position.
    pub fn from_text(text: &str) -> Result<Self, String> {
        RawValue::from_boxed_ron(text.trim().into())
            .map(NodeData)
            .map_err(|e| format!("{}: {}", e.span.start, e.code))
    }

    /// The block written from a typed value (pretty-printed RON).
    pub fn from_value<T: Serialize>(value: &T) -> Result<Self, String> {
        let text = ron::ser::to_string_pretty(value, ron::ser::PrettyConfig::new())
            .map_err(|e| e.to_string())?;
        Self::from_text(&text)
    }

    /// The RON text.
    pub fn text(&self) -> &str {
        self.0.get_ron()
    }

    /// Parse the block into the owning node's structure. Struct and enum names in the text are
    /// checked against `T`'s (the `IMPLICIT_SOME` extension is on, as for graph files).
    pub fn parse<T: DeserializeOwned>(&self) -> Result<T, String> {
        ron::Options::default()
            .with_default_extension(ron::extensions::Extensions::IMPLICIT_SOME)
            .from_str(self.text())
            .map_err(|e| format!("{}: {}", e.span.start, e.code))
    }
}

impl fmt::Debug for NodeData {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        write!(f, "NodeData({})", self.text())
    }
}

impl Hash for NodeData {
    fn hash<H: Hasher>(&self, state: &mut H) {
        self.text().hash(state);
    }
}

impl Serialize for NodeData {
    fn serialize<S: Serializer>(&self, s: S) -> Result<S::Ok, S::Error> {
        self.0.serialize(s)
    }
}

impl<'de> Deserialize<'de> for NodeData {
    fn deserialize<D: Deserializer<'de>>(d: D) -> Result<Self, D::Error> {
        Box::<RawValue>::deserialize(d).map(|r| NodeData(r.trim_boxed()))
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[derive(Debug, Deserialize, Serialize, PartialEq)]
    enum Layer {
        Solid { colour: (f32, f32, f32, f32) },
    }
    #[derive(Debug, Deserialize, Serialize, PartialEq)]
    enum Blend {
        Alpha,
        Add,
    }
    #[derive(Debug, Deserialize, Serialize, PartialEq)]
    struct Entry {
        layer: Layer,
        blend: Blend,
    }

    #[test]
    fn variant_names_survive() {
        let d = NodeData::from_text("(layer: Solid(colour: (1.0, 0.5, 0.0, 1.0)), blend: Add)")
            .expect("valid RON");
        let e: Entry = d.parse().expect("parses");
        assert_eq!(e.blend, Blend::Add);
        let again = NodeData::from_value(&e).expect("writes");
        assert_eq!(again.parse::<Entry>().expect("parses"), e);
    }

    #[test]
    fn bad_text_is_an_error_with_a_position() {
        let e = NodeData::from_text("(layer: ").expect_err("incomplete");
        assert!(e.contains(':'), "{e}");
    }
}
