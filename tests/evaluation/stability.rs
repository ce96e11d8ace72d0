//! The stability matrix (issue #15, item 2): every registered node kind, evaluated at each
//! parameter's minimum, maximum and default (each enum value, both flags), one parameter at a
//! time, on small inputs from two families — constant inputs, and inputs from the tree scene
//! (with an empty shadow map for the second) — must give finite outputs or refuse cleanly (an
//! error, never a panic and never NaN/Inf). `proptest` then draws random in-range settings of
//! all parameters at once. `MATRIX` names every kind: a test asserts it covers exactly the
//! registry, so no node can be added without being entered here.

use crate::common;
use std::collections::BTreeMap;
use std::sync::Arc;

use proptest::prelude::*;
use tyndall::eval::{download, EvalOptions, Evaluator, PortValue, Registry, Target};
use tyndall::graph::{Graph, Node, ParamKind, ParamSpec, ParamValue, PortType};

/// One row: the kind, optional input ports to connect as well, parameters fixed for every case,
/// and, for parameters whose cost or memory grows with them, the largest value tested instead of
/// the maximum (with the reason in `CAP_REASON`).
struct Entry {
    kind: &'static str,
    connect: &'static [&'static str],
    fixed: &'static [(&'static str, Fixed)],
    caps: &'static [(&'static str, f64)],
}

/// A fixed parameter value.
#[derive(Clone, Copy)]
enum Fixed {
    /// A file name in the test's temporary folder.
    Text(&'static str),
    /// A file of tests/fixtures.
    Fixture(&'static str),
    /// An integer (a cost knob held low while other parameters sweep).
    Int(i64),
}

/// Why some maxima are capped: they size textures or loops, and their maximum at 16×9 would
/// allocate gigabytes or run for minutes on lavapipe in CI. Their maxima are checked by the
/// node's own tests where that is affordable (largest shadow map, Mie radii, …).
const CAP_REASON: &str = "cost or memory grows with the parameter";

#[rustfmt::skip]
const MATRIX: &[Entry] = &[
    Entry { kind: "AovOutput", connect: &["rgba", "visibility", "depth", "layers"], fixed: &[("path", Fixed::Text("aovs.exr"))], caps: &[] },
    Entry { kind: "BilateralFilter", connect: &["guide"], fixed: &[], caps: &[] },
    Entry { kind: "BlendVolume", connect: &[], fixed: &[], caps: &[("resolution", 64.0)] },
    Entry { kind: "Blur", connect: &[], fixed: &[], caps: &[] },
    Entry { kind: "Closure2D", connect: &[], fixed: &[], caps: &[] },
    Entry { kind: "ColourSpace", connect: &[], fixed: &[], caps: &[] },
    Entry { kind: "Composite", connect: &["inscatter", "transmittance"], fixed: &[], caps: &[] },
    Entry { kind: "Constant", connect: &[], fixed: &[], caps: &[("width", 64.0), ("height", 64.0)] },
    Entry { kind: "Cryptomatte", connect: &[], fixed: &[], caps: &[("width", 64.0), ("height", 64.0)] },
    Entry { kind: "DepthUpsample", connect: &[], fixed: &[], caps: &[] },
    Entry { kind: "Dilate2D", connect: &[], fixed: &[], caps: &[] },
    Entry { kind: "DisplayView", connect: &[], fixed: &[], caps: &[] },
    Entry { kind: "Downsample", connect: &[], fixed: &[], caps: &[] },
    Entry { kind: "EpipolarClosure", connect: &["camera"], fixed: &[], caps: &[] },
    Entry { kind: "EpipolarDilation", connect: &["camera"], fixed: &[], caps: &[] },
    Entry { kind: "Erode2D", connect: &[], fixed: &[], caps: &[] },
    Entry { kind: "GBuffer", connect: &[], fixed: &[], caps: &[("width", 64.0), ("height", 64.0)] },
    Entry { kind: "HenyeyGreenstein", connect: &[], fixed: &[], caps: &[] },
    Entry { kind: "Heterogeneity", connect: &[], fixed: &[], caps: &[] },
    Entry { kind: "HoleComposite", connect: &[], fixed: &[], caps: &[] },
    Entry { kind: "HoleMap", connect: &[], fixed: &[], caps: &[] },
    Entry { kind: "IceCrystals", connect: &[], fixed: &[("rays", Fixed::Int(10_000)), ("samples", Fixed::Int(900))], caps: &[("rays", 20_000.0), ("samples", 900.0)] },
    Entry { kind: "ImageInput", connect: &[], fixed: &[("path", Fixed::Fixture("A.exr"))], caps: &[] },
    Entry { kind: "ImageOutput", connect: &[], fixed: &[("path", Fixed::Text("out.exr"))], caps: &[] },
    Entry { kind: "LightMap", connect: &[], fixed: &[], caps: &[] },
    Entry { kind: "LightMapSolve", connect: &[], fixed: &[], caps: &[("resolution", 32.0), ("iterations", 8.0), ("steps", 64.0)] },
    Entry { kind: "Math", connect: &["a", "b"], fixed: &[], caps: &[] },
    Entry { kind: "Mie", connect: &[], fixed: &[("radii", Fixed::Int(2)), ("samples", Fixed::Int(900))], caps: &[("radius", 20.0), ("rain_radius", 150.0), ("radii", 4.0), ("samples", 900.0)] },
    Entry { kind: "MultipleScatteringPhase", connect: &[], fixed: &[], caps: &[] },
    Entry { kind: "NoiseVolume", connect: &[], fixed: &[], caps: &[("resolution", 64.0)] },
    Entry { kind: "PerlinNoise2D", connect: &[], fixed: &[], caps: &[("width", 64.0), ("height", 64.0)] },
    Entry { kind: "PlateDepth", connect: &[], fixed: &[], caps: &[] },
    Entry { kind: "PlateOver", connect: &["inscatter", "transmittance"], fixed: &[], caps: &[] },
    Entry { kind: "RadialBlur", connect: &[], fixed: &[], caps: &[] },
    Entry { kind: "Rayleigh", connect: &[], fixed: &[], caps: &[] },
    Entry { kind: "Remap", connect: &[], fixed: &[], caps: &[] },
    Entry { kind: "Scene", connect: &[], fixed: &[], caps: &[] },
    Entry { kind: "ShadowMap", connect: &[], fixed: &[], caps: &[("resolution", 256.0)] },
    Entry { kind: "SideBySide", connect: &[], fixed: &[], caps: &[] },
    Entry { kind: "SingleScattering", connect: &[], fixed: &[], caps: &[] },
    Entry { kind: "Sky", connect: &[], fixed: &[], caps: &[] },
    Entry { kind: "SoftVisibility", connect: &[], fixed: &[], caps: &[("slices", 16.0), ("resolution", 64.0)] },
    Entry { kind: "TemporalAccumulate", connect: &[], fixed: &[], caps: &[] },
    Entry { kind: "Tonemap", connect: &[], fixed: &[], caps: &[] },
    Entry { kind: "TransferFunction", connect: &["visibility", "depth"], fixed: &[], caps: &[("resolution", 64.0), ("diffusion_cycles", 4.0)] },
    Entry { kind: "VdbVolume", connect: &[], fixed: &[("path", Fixed::Fixture("vdb/float.vdb"))], caps: &[] },
];

const SIZE: (u32, u32) = (16, 9);

/// Input families.
#[derive(Clone, Copy, Debug)]
enum Family {
    /// Constant images and scalars; the tree scene's maps.
    Constant,
    /// Noise and G-buffer images; an empty shadow map (no object drawn).
    Scene,
}

/// The provider node (kind, params) and port for an input of type `t`.
fn provider(
    t: PortType,
    family: Family,
) -> (&'static str, &'static str, Vec<(&'static str, ParamValue)>) {
    let int = |v| ParamValue::Int(v);
    match (t, family) {
        (PortType::Scalar, Family::Constant) => {
            ("Constant", "value", vec![("value", ParamValue::Float(0.5))])
        }
        (PortType::Scalar, Family::Scene) => ("PerlinNoise2D", "noise", vec![]),
        (PortType::Image, Family::Constant) => ("Constant", "colour", vec![]),
        (PortType::Image, Family::Scene) => ("GBuffer", "normal", vec![]),
        (PortType::ShadowMap, Family::Constant) => {
            ("ShadowMap", "map", vec![("resolution", int(64))])
        }
        (PortType::ShadowMap, Family::Scene) => (
            "ShadowMap",
            "map",
            vec![
                ("resolution", int(64)),
                ("include", ParamValue::Text("no-such-tag".into())),
            ],
        ),
        (PortType::Depth, _) => ("GBuffer", "depth", vec![]),
        (PortType::Scene, _) => ("Scene", "scene", vec![]),
        (PortType::Volume, _) => ("NoiseVolume", "volume", vec![("resolution", int(32))]),
        (PortType::Phase, _) => ("HenyeyGreenstein", "phase", vec![("samples", int(900))]),
        (PortType::SoftShadow, _) => (
            "SoftVisibility",
            "soft",
            vec![("resolution", int(16)), ("slices", int(2))],
        ),
        (PortType::LightMap, _) => ("LightMap", "light_map", vec![]),
        (PortType::Lut2D, _) => ("TransferFunction", "lut", vec![("resolution", int(16))]),
        (PortType::Layers, _) => ("Cryptomatte", "layers", vec![("samples", int(1))]),
    }
}

fn node(id: &str, kind: &str) -> Node {
    Node {
        id: id.into(),
        kind: kind.into(),
        params: BTreeMap::new(),
        keys: BTreeMap::new(),
        pos: None,
        data: None,
    }
}

/// The graph of one kind: the node `n`, the scene, and a provider per connected input (and
/// per input of a provider, recursively).
fn graph(registry: &Registry, entry: &Entry, family: Family, dir: &std::path::Path) -> Graph {
    let cat = registry.catalog();
    let mut g = Graph::new();
    g.insert_node(cat, node("n", entry.kind)).expect("node");
    let mut pending = vec!["n".to_string()];
    while let Some(id) = pending.pop() {
        let kind = g.node(&id).expect("node").kind.clone();
        let schema = cat.get(&kind).expect("schema");
        for port in schema.inputs {
            let wanted = port.required || (id == "n" && entry.connect.contains(&port.name));
            if !wanted {
                continue;
            }
            let (pkind, pport, params) = provider(port.types[0], family);
            let pid = format!("{pkind}_{}", params.len());
            if g.node(&pid).is_none() {
                g.insert_node(cat, node(&pid, pkind)).expect("provider");
                for (k, v) in params {
                    g.set_param(cat, &pid, k, v).expect("provider param");
                }
                pending.push(pid.clone());
            }
            g.connect(
                cat,
                &format!("{pid}.{pport}"),
                &format!("{id}.{}", port.name),
            )
            .expect("edge");
        }
    }
    for (k, v) in entry.fixed {
        let value = match v {
            Fixed::Text(t) => ParamValue::Text(dir.join(t).display().to_string()),
            Fixed::Fixture(f) => ParamValue::Text(
                std::path::Path::new(env!("CARGO_MANIFEST_DIR"))
                    .join("tests/fixtures")
                    .join(f)
                    .display()
                    .to_string(),
            ),
            Fixed::Int(i) => ParamValue::Int(*i),
        };
        g.set_param(cat, "n", k, value).expect("fixed");
    }
    g
}

/// The values tested for one parameter: minimum, maximum (or cap), default; every enum value;
/// both flags. Text parameters keep their value.
fn values(spec: &ParamSpec, cap: Option<f64>) -> Vec<ParamValue> {
    let hi = cap.unwrap_or(spec.max).min(spec.max);
    match spec.kind {
        ParamKind::Float => vec![ParamValue::Float(spec.min), ParamValue::Float(hi)],
        ParamKind::Int => vec![ParamValue::Int(spec.min as i64), ParamValue::Int(hi as i64)],
        ParamKind::Bool => vec![ParamValue::Bool(false), ParamValue::Bool(true)],
        ParamKind::Enum(names) => names
            .iter()
            .map(|n| ParamValue::Enum(n.to_string()))
            .collect(),
        ParamKind::Colour => vec![
            ParamValue::Colour([spec.min; 4]),
            ParamValue::Colour([hi; 4]),
        ],
        ParamKind::Vec3 => vec![ParamValue::Vec3([spec.min; 3]), ParamValue::Vec3([hi; 3])],
        ParamKind::Text => vec![],
    }
}

/// Evaluate node `n`'s outputs (a sink: the node itself); `Ok(None)` when every output is finite,
/// `Ok(Some(what))` naming a non-finite output, `Err` for a clean refusal.
fn check(
    ev: &mut Evaluator,
    gpu: &tyndall::gpu::Gpu,
    registry: &Registry,
    g: &Graph,
) -> Result<Option<String>, String> {
    let kind = g.node("n").expect("n").kind.clone();
    let schema = registry.catalog().get(&kind).expect("schema");
    let targets: Vec<Target> = if schema.outputs.is_empty() {
        vec![Target::Node("n".into())]
    } else {
        schema
            .outputs
            .iter()
            .map(|p| Target::Port("n".into(), p.name.into()))
            .collect()
    };
    let opts = EvalOptions {
        size: SIZE,
        ..Default::default()
    };
    let result = ev.evaluate(g, &targets, &opts).map_err(|e| e.to_string())?;
    for (key, value) in &result.outputs {
        if key.0 != "n" {
            continue;
        }
        let data = match value {
            PortValue::Volume(v, _) | PortValue::SoftShadow(v, _) => gpu
                .recorder()
                .read_volume(v, 0)
                .map_err(|e| e.to_string())?,
            v if v.texture().is_some() => {
                download(&gpu.recorder(), v)
                    .map_err(|e| e.to_string())?
                    .data
            }
            _ => continue,
        };
        if let Some(i) = data.iter().position(|x| !x.is_finite()) {
            return Ok(Some(format!("output {} sample {i} is {}", key.1, data[i])));
        }
    }
    Ok(None)
}

#[test]
fn the_matrix_covers_exactly_the_registered_kinds() {
    let registry = tyndall::nodes::registry();
    let registered: Vec<&str> = registry.catalog().iter().map(|s| s.kind).collect();
    let listed: Vec<&str> = MATRIX.iter().map(|e| e.kind).collect();
    assert_eq!(
        listed, registered,
        "MATRIX must list every registered kind, in name order"
    );
    for e in MATRIX {
        let schema = registry.catalog().get(e.kind).expect("schema");
        for (p, _) in e.caps {
            assert!(
                schema.param(p).is_some(),
                "{}: no parameter {p} to cap",
                e.kind
            );
        }
        for p in e.connect {
            assert!(
                schema.inputs.iter().any(|i| i.name == *p),
                "{}: no input {p}",
                e.kind
            );
        }
    }
}

#[test]
fn every_node_stays_finite_at_every_parameter_extreme() {
    let gpu = require_gpu!();
    let registry = Arc::new(tyndall::nodes::registry());
    let dir = tempfile::tempdir().expect("tempdir");
    let (mut failures, mut refusals, mut cases) = (Vec::new(), Vec::new(), 0usize);
    for entry in MATRIX {
        let schema = registry.catalog().get(entry.kind).expect("schema");
        for family in [Family::Constant, Family::Scene] {
            let base = graph(&registry, entry, family, dir.path());
            // A node this adapter cannot run (volume writers on wgpu's GL backend) is a
            // capability, not an instability: its refusal is tested in tests/platform/gpu.rs.
            if let Some(why) = base
                .nodes()
                .find_map(|n| common::unsupported(&gpu, &n.kind))
            {
                eprintln!("skipping on this adapter: {why}");
                continue;
            }
            let mut ev = Evaluator::new(registry.clone(), gpu.clone());
            let label = |what: &str| format!("{} ({family:?}) {what}", entry.kind);
            match check(&mut ev, &gpu, &registry, &base) {
                Ok(None) => {}
                Ok(Some(bad)) => failures.push(label(&format!("defaults: {bad}"))),
                Err(e) => failures.push(label(&format!("defaults refused: {e}"))),
            }
            for spec in schema.params {
                let cap = entry
                    .caps
                    .iter()
                    .find(|(p, _)| *p == spec.name)
                    .map(|c| c.1);
                for v in values(spec, cap) {
                    cases += 1;
                    let mut g = base.clone();
                    g.set_param(registry.catalog(), "n", spec.name, v.clone())
                        .expect("in range");
                    match check(&mut ev, &gpu, &registry, &g) {
                        Ok(None) => {}
                        Ok(Some(bad)) => {
                            failures.push(label(&format!("{} = {v}: {bad}", spec.name)))
                        }
                        Err(e) => refusals.push(label(&format!("{} = {v}: {e}", spec.name))),
                    }
                }
            }
        }
    }
    println!(
        "{cases} cases ({CAP_REASON}: capped as listed in MATRIX); {} refused cleanly:",
        refusals.len()
    );
    for r in &refusals {
        println!("  refused: {r}");
    }
    assert!(
        failures.is_empty(),
        "{} failures:\n{}",
        failures.len(),
        failures.join("\n")
    );
}

proptest! {
    #![proptest_config(ProptestConfig { cases: 4, ..ProptestConfig::default() })]

    /// Random in-range settings of every numeric parameter at once (caps as in the matrix), on
    /// the constant family: outputs finite or a clean refusal.
    #[test]
    fn random_in_range_parameters_stay_finite(u in proptest::collection::vec(0.0f64..=1.0, 64)) {
        let Some(gpu) = common::gpu() else { return Ok(()); };
        let registry = Arc::new(tyndall::nodes::registry());
        let dir = tempfile::tempdir().expect("tempdir");
        for entry in MATRIX {
            let schema = registry.catalog().get(entry.kind).expect("schema");
            let mut g = graph(&registry, entry, Family::Constant, dir.path());
            if g.nodes().any(|n| common::unsupported(&gpu, &n.kind).is_some()) {
                continue;
            }
            for (i, spec) in schema.params.iter().enumerate() {
                let cap = entry.caps.iter().find(|(p, _)| *p == spec.name).map(|c| c.1);
                let hi = cap.unwrap_or(spec.max).min(spec.max);
                let x = u[i % u.len()];
                let v = match spec.kind {
                    ParamKind::Float => ParamValue::Float(spec.min + x * (hi - spec.min)),
                    ParamKind::Int => ParamValue::Int((spec.min + x * (hi - spec.min)).round() as i64),
                    ParamKind::Bool => ParamValue::Bool(x < 0.5),
                    ParamKind::Enum(names) => ParamValue::Enum(names[((x * names.len() as f64) as usize).min(names.len() - 1)].to_string()),
                    ParamKind::Colour => ParamValue::Colour([spec.min + x * (hi - spec.min); 4]),
                    ParamKind::Vec3 => ParamValue::Vec3([spec.min + x * (hi - spec.min); 3]),
                    ParamKind::Text => continue,
                };
                g.set_param(registry.catalog(), "n", spec.name, v).expect("in range");
            }
            let mut ev = Evaluator::new(registry.clone(), gpu.clone());
            if let Ok(Some(bad)) = check(&mut ev, &gpu, &registry, &g) {
                prop_assert!(false, "{}: {bad} with {:?}", entry.kind, g.node("n").map(|n| &n.params));
            }
        }
    }
}
