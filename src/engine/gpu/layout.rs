//! Checks a Rust uniform struct's layout against the WGSL struct it is bound to, with naga, so
//! the two cannot drift apart silently.

/// The layout of a `#[repr(C)]` uniform struct, as the Rust compiler laid it out.
#[derive(Debug, Clone, Copy)]
pub struct UniformLayout {
    /// Name of the WGSL struct (`Params`).
    pub wgsl_struct: &'static str,
    /// `size_of` the Rust struct.
    pub size: usize,
    /// `(field name, offset_of)` for every field, in declaration order.
    pub fields: &'static [(&'static str, usize)],
}

/// Declare a uniform struct and its [`UniformLayout`] in one place, so the list of fields the
/// layout test compares with the WGSL struct is the struct's own (a field added to the Rust
/// struct cannot be missing from the check):
///
/// ```
/// tyndall_engine::uniforms! {
///     /// Uniforms of `shaders/x.wgsl`.
///     pub struct XParams as "Params" {
///         /// Radius.
///         pub r: f32,
///         /// Padding.
///         pub _pad: [f32; 3],
///     }
/// }
/// assert_eq!(XParams::LAYOUT.fields, &[("r", 0), ("_pad", 4)]);
/// ```
///
/// The struct is `#[repr(C)]`, `Pod`, `Zeroable`, `Clone`, `Copy` and `Debug`; `"Params"` names
/// the WGSL struct it must match.
#[macro_export]
macro_rules! uniforms {
    (
        $(#[$meta:meta])*
        $vis:vis struct $name:ident as $wgsl:literal {
            $( $(#[$fmeta:meta])* $fvis:vis $field:ident : $ty:ty ),+ $(,)?
        }
    ) => {
        $(#[$meta])*
        #[repr(C)]
        #[derive(Clone, Copy, Debug, bytemuck::Pod, bytemuck::Zeroable)]
        $vis struct $name {
            $( $(#[$fmeta])* $fvis $field : $ty ),+
        }

        impl $name {
            /// This struct's layout, for the check against its WGSL struct.
            pub const LAYOUT: $crate::gpu::UniformLayout = $crate::gpu::UniformLayout {
                wgsl_struct: $wgsl,
                size: ::std::mem::size_of::<$name>(),
                fields: &[$((stringify!($field), ::std::mem::offset_of!($name, $field))),+],
            };
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
