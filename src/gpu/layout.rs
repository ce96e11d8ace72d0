//! Checks a Rust uniform struct's layout against the WGSL struct it is bound to, with naga, so
//! the two cannot drift apart silently.

/// The layout of a `#[repr(C)]` uniform struct, as the Rust compiler laid it out.
#[derive(Debug, Clone)]
pub struct UniformLayout {
    /// Name of the WGSL struct (`Params`).
    pub wgsl_struct: &'static str,
    /// `size_of` the Rust struct.
    pub size: usize,
    /// `(field name, offset_of)` for every field, in declaration order.
    pub fields: Vec<(&'static str, usize)>,
}

/// Build a [`UniformLayout`] from a Rust struct: `uniform_layout!(MathParams, "Params", op, a, b)`.
#[macro_export]
macro_rules! uniform_layout {
    ($ty:ty, $wgsl:expr, $($field:ident),+ $(,)?) => {
        $crate::gpu::UniformLayout {
            wgsl_struct: $wgsl,
            size: std::mem::size_of::<$ty>(),
            fields: vec![$((stringify!($field), std::mem::offset_of!($ty, $field))),+],
        }
    };
}

/// Parse `wgsl` with naga and compare the struct named `layout.wgsl_struct`: same member names
/// in the same order, same offsets, and the Rust size equal to the WGSL size (uniform buffers
/// are padded to 16 bytes, so the WGSL size rounded up to 16 must equal the Rust size rounded
/// up to 16). Returns a description of the first difference.
pub fn check_uniform_layout(wgsl: &str, layout: &UniformLayout) -> Result<(), String> {
    let module = naga::front::wgsl::parse_str(wgsl).map_err(|e| e.emit_to_string(wgsl))?;
    let mut layouter = naga::proc::Layouter::default();
    layouter
        .update(module.to_ctx())
        .map_err(|e| e.to_string())?;
    let (handle, ty) = module
        .types
        .iter()
        .find(|(_, t)| t.name.as_deref() == Some(layout.wgsl_struct))
        .ok_or_else(|| format!("no struct {} in the shader", layout.wgsl_struct))?;
    let naga::TypeInner::Struct { members, span } = &ty.inner else {
        return Err(format!("{} is not a struct", layout.wgsl_struct));
    };
    let wgsl_fields: Vec<(String, usize)> = members
        .iter()
        .map(|m| (m.name.clone().unwrap_or_default(), m.offset as usize))
        .collect();
    let rust_fields: Vec<(String, usize)> = layout
        .fields
        .iter()
        .map(|(n, o)| (n.to_string(), *o))
        .collect();
    if wgsl_fields != rust_fields {
        return Err(format!(
            "struct {}: WGSL members {:?} differ from Rust fields {:?}",
            layout.wgsl_struct, wgsl_fields, rust_fields
        ));
    }
    let wgsl_size = (*span as usize).max(layouter[handle].size as usize);
    if wgsl_size.div_ceil(16) * 16 != layout.size.div_ceil(16) * 16 {
        return Err(format!(
            "struct {}: WGSL size {} but Rust size {}",
            layout.wgsl_struct, wgsl_size, layout.size
        ));
    }
    Ok(())
}
