//! Checks on a glTF file's JSON before the gltf crate reads it: the crate asserts (panics) on
//! some malformed files instead of reporting them (found by fuzzing), so every index and shape
//! the loader reads is checked here first, with a message naming the mesh, primitive, animation
//! or channel at fault.

use gltf::json::accessor::{ComponentType, Type};
use gltf::json::validation::Checked;

/// Every accessor a mesh primitive names (attributes, indices) exists, and the ones the loader
/// reads have the shape it reads them as: POSITION and NORMAL float VEC3, indices unsigned
/// SCALAR (the gltf crate asserts on a mismatch instead of reporting it; found by fuzzing).
pub(super) fn accessor_indices_exist(root: &gltf::json::Root) -> Result<(), String> {
    use gltf::json::mesh::Semantic;
    let count = root.accessors.len();
    for (m, mesh) in root.meshes.iter().enumerate() {
        for (p, prim) in mesh.primitives.iter().enumerate() {
            let named = prim.attributes.values().chain(prim.indices.as_ref());
            if let Some(bad) = named.map(|i| i.value()).find(|i| *i >= count) {
                return Err(format!(
                    "mesh {m} primitive {p} names accessor {bad}, but the file has {count}"
                ));
            }
            let shape = |i: usize| {
                let a = &root.accessors[i];
                let ty = match a.type_ {
                    Checked::Valid(t) => Some(t),
                    Checked::Invalid => None,
                };
                let component = match a.component_type {
                    Checked::Valid(c) => Some(c.0),
                    Checked::Invalid => None,
                };
                (ty, component)
            };
            for (semantic, index) in &prim.attributes {
                let read = matches!(
                    semantic,
                    Checked::Valid(Semantic::Positions) | Checked::Valid(Semantic::Normals)
                );
                if read && shape(index.value()) != (Some(Type::Vec3), Some(ComponentType::F32)) {
                    return Err(format!(
                        "mesh {m} primitive {p}: accessor {} for {semantic:?} is not a float VEC3",
                        index.value()
                    ));
                }
            }
            if let Some(index) = &prim.indices {
                let ok = matches!(
                    shape(index.value()),
                    (
                        Some(Type::Scalar),
                        Some(ComponentType::U8 | ComponentType::U16 | ComponentType::U32)
                    )
                );
                if !ok {
                    return Err(format!(
                        "mesh {m} primitive {p}: index accessor {} is not an unsigned SCALAR",
                        index.value()
                    ));
                }
            }
        }
    }
    Ok(())
}

/// Whether values of accessor type `ty` and component `comp` can drive `property`: rotations
/// VEC4 of floats or normalised integers, translations and scales float VEC3.
fn values_fit(
    property: gltf::json::animation::Property,
    ty: Option<Type>,
    comp: Option<ComponentType>,
) -> bool {
    use gltf::json::animation::Property;
    match property {
        Property::Rotation => {
            ty == Some(Type::Vec4)
                && matches!(
                    comp,
                    Some(
                        ComponentType::F32
                            | ComponentType::I8
                            | ComponentType::U8
                            | ComponentType::I16
                            | ComponentType::U16
                    )
                )
        }
        _ => (ty, comp) == (Some(Type::Vec3), Some(ComponentType::F32)),
    }
}

/// Every animation channel targets a node that exists, and its sampler's accessors exist and
/// have the shape the loader reads: times float SCALAR, translations and scales float VEC3,
/// rotations VEC4 (float or normalised integers), as many outputs as times (three per time for
/// `CUBICSPLINE`: in-tangent, value, out-tangent). Morph-target weights are not played, so their
/// channels are not checked beyond the node.
pub(super) fn animations_are_readable(root: &gltf::json::Root) -> Result<(), String> {
    use gltf::json::animation::{Interpolation, Property};
    let nodes = root.nodes.len();
    let accessors = root.accessors.len();
    for (a, anim) in root.animations.iter().enumerate() {
        let label = match &anim.name {
            Some(n) => format!("animation '{n}'"),
            None => format!("animation {a}"),
        };
        for (c, channel) in anim.channels.iter().enumerate() {
            let node = channel.target.node.value();
            if node >= nodes {
                return Err(format!(
                    "{label} channel {c} targets node {node}, but the file has {nodes} node{}",
                    if nodes == 1 { "" } else { "s" }
                ));
            }
            let s = channel.sampler.value();
            let Some(sampler) = anim.samplers.get(s) else {
                return Err(format!(
                    "{label} channel {c} names sampler {s}, but the animation has {}",
                    anim.samplers.len()
                ));
            };
            let property = match channel.target.path {
                Checked::Valid(p) => p,
                Checked::Invalid => {
                    return Err(format!("{label} channel {c}: unknown target path"));
                }
            };
            if property == Property::MorphTargetWeights {
                continue;
            }
            let (input, output) = (sampler.input.value(), sampler.output.value());
            for i in [input, output] {
                if i >= accessors {
                    return Err(format!(
                        "{label} channel {c} names accessor {i}, but the file has {accessors}"
                    ));
                }
                if root.accessors[i].buffer_view.is_none() {
                    return Err(format!(
                        "{label} channel {c}: accessor {i} has no buffer view"
                    ));
                }
            }
            let shape = |i: usize| {
                let acc = &root.accessors[i];
                let ty = match acc.type_ {
                    Checked::Valid(t) => Some(t),
                    Checked::Invalid => None,
                };
                let component = match acc.component_type {
                    Checked::Valid(c) => Some(c.0),
                    Checked::Invalid => None,
                };
                (ty, component, acc.count.0 as usize)
            };
            let (ty, comp, times) = shape(input);
            if (ty, comp) != (Some(Type::Scalar), Some(ComponentType::F32)) || times == 0 {
                return Err(format!(
                    "{label} channel {c}: key times (accessor {input}) are not a non-empty float SCALAR"
                ));
            }
            let (ty, comp, values) = shape(output);
            let ok = values_fit(property, ty, comp);
            if !ok {
                return Err(format!(
                    "{label} channel {c}: values (accessor {output}) are not {}",
                    if property == Property::Rotation {
                        "VEC4 rotations"
                    } else {
                        "float VEC3"
                    }
                ));
            }
            let per_key = match sampler.interpolation {
                Checked::Valid(Interpolation::CubicSpline) => 3,
                _ => 1,
            };
            if values != times * per_key {
                return Err(format!(
                    "{label} channel {c}: {values} values for {times} key times (expected {})",
                    times * per_key
                ));
            }
        }
    }
    Ok(())
}
