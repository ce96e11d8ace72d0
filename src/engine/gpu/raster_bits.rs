//! The bit-pattern path of raster passes (see `raster.rs`): where the adapter cannot render into
//! 32-bit float formats (wgpu's GL backend on Mesa), a raster pass renders the same values as
//! bit patterns into 32-bit unsigned-integer targets, through a generated `fs_bits` entry point
//! (built on naga's IR) that calls the shader's `fs` and `bitcast`s each `vec4<f32>` output to
//! `vec4<u32>`; one compute pass per target then turns them back into floats. The result is
//! bit-identical to the float path.

use std::sync::Arc;

use super::{Gpu, GpuError, GpuTexture};

/// Entry point the bit-pattern path generates around `fs`.
pub(super) const BITS_ENTRY: &str = "fs_bits";

/// Turns a bit-pattern target back into floats (`texture_2d<u32>` → float storage texture).
const UNBITS: &str = r#"
@group(0) @binding(0) var bits: texture_2d<u32>;
@group(0) @binding(1) var out1: texture_storage_2d<r32float, write>;
@group(0) @binding(2) var out4: texture_storage_2d<rgba32float, write>;

@compute @workgroup_size(8, 8)
fn to_r32float(@builtin(global_invocation_id) id: vec3<u32>) {
    let size = textureDimensions(bits);
    if id.x >= size.x || id.y >= size.y { return; }
    textureStore(out1, id.xy, bitcast<vec4<f32>>(textureLoad(bits, id.xy, 0)));
}

@compute @workgroup_size(8, 8)
fn to_rgba32float(@builtin(global_invocation_id) id: vec3<u32>) {
    let size = textureDimensions(bits);
    if id.x >= size.x || id.y >= size.y { return; }
    textureStore(out4, id.xy, bitcast<vec4<f32>>(textureLoad(bits, id.xy, 0)));
}
"#;

impl Gpu {
    /// Record the compute pass that turns the bit patterns in `bits` into the floats of `dst`.
    pub(super) fn unbits(
        &self,
        enc: &mut wgpu::CommandEncoder,
        bits: &wgpu::TextureView,
        dst: &GpuTexture,
    ) -> Result<(), GpuError> {
        let (entry, slot) = match dst.stored_channels() {
            1 => ("to_r32float", 1),
            _ => ("to_rgba32float", 2),
        };
        let key = format!("raster-unbits:{entry}");
        let cell = {
            let mut cache = self.pipelines.lock().unwrap_or_else(|p| p.into_inner());
            cache.entry(key).or_default().clone()
        };
        let made = cell.get_or_init(|| {
            self.disk.note(&format!("raster-unbits:{entry}"), UNBITS);
            let module = self
                .device
                .create_shader_module(wgpu::ShaderModuleDescriptor {
                    label: Some("raster-unbits"),
                    source: wgpu::ShaderSource::Wgsl(UNBITS.into()),
                });
            Ok(Arc::new(self.device.create_compute_pipeline(
                &wgpu::ComputePipelineDescriptor {
                    label: Some("raster-unbits"),
                    layout: None,
                    module: &module,
                    entry_point: Some(entry),
                    compilation_options: Default::default(),
                    cache: self.disk.cache.as_ref(),
                },
            )))
        });
        let pipeline = made.as_ref().map_err(Clone::clone)?;
        let group = self.device.create_bind_group(&wgpu::BindGroupDescriptor {
            label: Some("raster-unbits"),
            layout: &pipeline.get_bind_group_layout(0),
            entries: &[
                wgpu::BindGroupEntry {
                    binding: 0,
                    resource: wgpu::BindingResource::TextureView(bits),
                },
                wgpu::BindGroupEntry {
                    binding: slot,
                    resource: wgpu::BindingResource::TextureView(dst.view()),
                },
            ],
        });
        let mut pass = enc.begin_compute_pass(&wgpu::ComputePassDescriptor {
            label: Some("raster-unbits"),
            timestamp_writes: None,
        });
        pass.set_pipeline(pipeline);
        pass.set_bind_group(0, &group, &[]);
        pass.dispatch_workgroups(dst.width.div_ceil(8), dst.height.div_ceil(8), 1);
        Ok(())
    }
}

/// `source` with a fragment entry point `fs_bits` beside `fs`: it calls `fs` (made a plain
/// function) and returns each of its `vec4<f32>` outputs bit-cast to `vec4<u32>` at the same
/// location, for integer render targets.
pub fn bits_module(source: &str) -> Result<naga::Module, String> {
    use naga::{FunctionResult, Span};
    let mut m = naga::front::wgsl::parse_str(source).map_err(|e| e.message().to_string())?;
    let ep = m
        .entry_points
        .iter()
        .find(|e| e.name == "fs" && e.stage == naga::ShaderStage::Fragment)
        .cloned()
        .ok_or("no fragment entry point `fs`")?;
    let result = ep.function.result.clone().ok_or("`fs` returns nothing")?;
    let outputs = fs_outputs(&m, &result)?;
    let mut inner = ep.function.clone();
    inner.name = Some("tyndall_fs_inner".into());
    for a in &mut inner.arguments {
        a.binding = None;
    }
    inner.result = Some(FunctionResult {
        ty: result.ty,
        binding: None,
    });
    let inner = m.functions.append(inner, Span::UNDEFINED);
    let out = bits_struct(&mut m, &outputs);
    let f = bits_function(&ep.function.arguments, inner, out, &outputs);
    let mut bits = ep;
    bits.name = BITS_ENTRY.into();
    bits.function = f;
    m.entry_points.push(bits);
    naga::valid::Validator::new(
        naga::valid::ValidationFlags::all(),
        naga::valid::Capabilities::all(),
    )
    .validate(&m)
    .map_err(|e| format!("generated {BITS_ENTRY}: {}", e.as_inner()))?;
    Ok(m)
}

/// A fragment result's `vec4<f32>` outputs: (location, member index of a struct result, or
/// `None` for a bare vec4).
fn fs_outputs(
    m: &naga::Module,
    result: &naga::FunctionResult,
) -> Result<Vec<(u32, Option<u32>)>, String> {
    use naga::{Binding, TypeInner};
    let f4 = TypeInner::Vector {
        size: naga::VectorSize::Quad,
        scalar: naga::Scalar::F32,
    };
    Ok(match (&result.binding, &m.types[result.ty].inner) {
        (Some(Binding::Location { location, .. }), inner) if *inner == f4 => {
            vec![(*location, None)]
        }
        (None, TypeInner::Struct { members, .. }) => members
            .iter()
            .enumerate()
            .map(|(i, mem)| match (&mem.binding, &m.types[mem.ty].inner) {
                (Some(Binding::Location { location, .. }), inner) if *inner == f4 => {
                    Ok((*location, Some(i as u32)))
                }
                _ => Err(format!(
                    "output {} of `fs` is not a vec4<f32> at a @location",
                    mem.name.as_deref().unwrap_or("?")
                )),
            })
            .collect::<Result<_, _>>()?,
        _ => return Err("`fs` must return vec4<f32> outputs at @locations".into()),
    })
}

/// The struct `fs_bits` returns: one `vec4<u32>` per output, at its location.
fn bits_struct(m: &mut naga::Module, outputs: &[(u32, Option<u32>)]) -> naga::Handle<naga::Type> {
    use naga::{Binding, Span, StructMember, Type, TypeInner};
    let u4 = m.types.insert(
        Type {
            name: None,
            inner: TypeInner::Vector {
                size: naga::VectorSize::Quad,
                scalar: naga::Scalar::U32,
            },
        },
        Span::UNDEFINED,
    );
    m.types.insert(
        Type {
            name: Some("TyndallBits".into()),
            inner: TypeInner::Struct {
                members: outputs
                    .iter()
                    .enumerate()
                    .map(|(k, (location, _))| StructMember {
                        name: Some(format!("o{location}")),
                        ty: u4,
                        binding: Some(Binding::Location {
                            location: *location,
                            interpolation: None,
                            sampling: None,
                            blend_src: None,
                            per_primitive: false,
                        }),
                        offset: 16 * k as u32,
                    })
                    .collect(),
                span: 16 * outputs.len() as u32,
            },
        },
        Span::UNDEFINED,
    )
}

/// The body of `fs_bits`: call `inner` (the original `fs`) with the same arguments and return
/// each output bit-cast to `vec4<u32>` in the struct `out`.
fn bits_function(
    arguments: &[naga::FunctionArgument],
    inner: naga::Handle<naga::Function>,
    out: naga::Handle<naga::Type>,
    outputs: &[(u32, Option<u32>)],
) -> naga::Function {
    use naga::{Expression, FunctionResult, Span, Statement};
    let mut f = naga::Function {
        name: Some(BITS_ENTRY.into()),
        arguments: arguments.to_vec(),
        result: Some(FunctionResult {
            ty: out,
            binding: None,
        }),
        ..Default::default()
    };
    let sp = Span::UNDEFINED;
    let args = (0..f.arguments.len() as u32)
        .map(|i| f.expressions.append(Expression::FunctionArgument(i), sp))
        .collect();
    let called = f.expressions.append(Expression::CallResult(inner), sp);
    f.body.push(
        Statement::Call {
            function: inner,
            arguments: args,
            result: Some(called),
        },
        sp,
    );
    let start = f.expressions.len();
    let parts = outputs
        .iter()
        .map(|(_, member)| {
            let v = match member {
                Some(k) => f.expressions.append(
                    Expression::AccessIndex {
                        base: called,
                        index: *k,
                    },
                    sp,
                ),
                None => called,
            };
            f.expressions.append(
                Expression::As {
                    expr: v,
                    kind: naga::ScalarKind::Uint,
                    convert: None,
                },
                sp,
            )
        })
        .collect();
    let composed = f.expressions.append(
        Expression::Compose {
            ty: out,
            components: parts,
        },
        sp,
    );
    let emitted = f.expressions.range_from(start);
    f.body.push(Statement::Emit(emitted), sp);
    f.body.push(
        Statement::Return {
            value: Some(composed),
        },
        sp,
    );
    f
}
