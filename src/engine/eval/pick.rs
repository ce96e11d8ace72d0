//! `tyndall pick` (and the editor's surface picking): what one pixel's view ray sees — V̄, the
//! linear depth, the first surface (object, triangle, barycentrics) — and, for a node that
//! places what it reads in a 2D table, where the pixel lands in it
//! ([`NodeKind::table_coordinates`](super::NodeKind::table_coordinates)).
//!
//! Everything is found by port, never by node kind: the node read is one with ports named
//! `visibility` (Scalar) and `depth` (Depth) — by default the first (by id) that reads both
//! through inputs and is not a sink, else the first that produces both — and the surface comes
//! from the `scene` input found by following `depth` inputs upstream.

use std::collections::BTreeMap;

use serde::Serialize;

use super::{download, EvalError, EvalOptions, Evaluator, Matrices, NodeError, PortValue, Target};
use crate::graph::{Graph, ParamValue, PortType};
use crate::io::Raster;

/// Where a picked pixel lands in a node's 2D table (a transfer function's (u, v)).
#[derive(Debug, Clone, Serialize)]
pub struct TablePick {
    /// The node.
    pub node: String,
    /// u (a transfer function: V̄).
    pub u: f32,
    /// v (a transfer function: normalised depth).
    pub v: f32,
    /// The depth range used (manual parameters or the frame's percentiles).
    pub depth_min: f32,
    /// Upper end of the depth range.
    pub depth_max: f32,
    /// `manual` or `auto`.
    pub depth_range: String,
}

/// What [`NodeKind::table_coordinates`] is given about the picked pixel.
///
/// [`NodeKind::table_coordinates`]: super::NodeKind::table_coordinates
pub struct PickAt<'a> {
    /// The node's id.
    pub id: &'a str,
    /// Its parameters at the evaluation time (every declared one).
    pub params: &'a BTreeMap<String, ParamValue>,
    /// V̄ at the pixel.
    pub visibility: f32,
    /// Linear depth at the pixel, metres.
    pub depth: f32,
    /// The whole depth image (for ranges taken from the frame).
    pub depth_image: &'a Raster,
    /// The camera the depth was rendered with.
    pub camera: &'a Matrices,
}

/// The surface point under a pixel.
#[derive(Debug, Clone, Serialize)]
pub struct SurfacePick {
    /// Object name.
    pub object: String,
    /// Triangle index in the object.
    pub triangle: u32,
    /// Barycentric coordinates.
    pub bary: [f32; 3],
    /// World position.
    pub position: [f32; 3],
}

/// What `tyndall pick` reports for one pixel.
#[derive(Debug, Clone, Serialize)]
pub struct Pick {
    /// The pixel (x right, y down).
    pub pixel: [u32; 2],
    /// The evaluation size the pixel refers to.
    pub size: [u32; 2],
    /// Evaluation time.
    pub time: f64,
    /// The node whose ports were read.
    pub node: String,
    /// V̄ of the view ray.
    pub visibility: f32,
    /// Linear depth, metres (sky: the camera's far distance).
    pub depth: f32,
    /// Table coordinates, when the node places what it reads in a table (JSON key `tf`, the
    /// transfer function's).
    pub tf: Option<TablePick>,
    /// The first surface along the ray, when the graph's scene can be found.
    pub surface: Option<SurfacePick>,
}

fn pick_err(message: impl Into<String>) -> EvalError {
    EvalError::Node {
        node: "-".into(),
        kind: "pick".into(),
        source: NodeError::Other(message.into()),
    }
}

/// The node and port feeding `id.port`.
fn source(g: &Graph, id: &str, port: &str) -> Option<(String, String)> {
    g.source_of(id, port)
        .map(|(n, p)| (n.to_string(), p.to_string()))
}

/// Follow `depth` inputs upstream from `start` to the first node with a connected `scene`
/// input: the scene the depth was rendered from.
fn scene_of(g: &Graph, start: &str) -> Option<(String, String)> {
    let mut id = start.to_string();
    for _ in 0..64 {
        if let Some(s) = source(g, &id, "scene") {
            return Some(s);
        }
        id = source(g, &id, "depth")?.0;
    }
    None
}

/// How a node offers the two values pick reads.
#[derive(Clone, Copy, PartialEq, Eq)]
enum Reads {
    /// Through its `visibility` and `depth` inputs.
    Inputs,
    /// As its own `visibility` and `depth` outputs.
    Outputs,
}

/// Whether `kind` has a `visibility` Scalar port and a `depth` Depth port, both inputs (and not
/// a sink) or both outputs.
fn reads(ev: &Evaluator, kind: &str) -> Option<Reads> {
    let k = ev.registry().get(kind)?;
    let s = k.schema();
    let has = |ports: &[crate::graph::PortSpec]| {
        let port =
            |name: &str, t: PortType| ports.iter().any(|p| p.name == name && p.types.contains(&t));
        port("visibility", PortType::Scalar) && port("depth", PortType::Depth)
    };
    if has(s.inputs) && !k.is_sink() {
        Some(Reads::Inputs)
    } else if has(s.outputs) {
        Some(Reads::Outputs)
    } else {
        None
    }
}

/// The node to read: `node`, or the default (see the module doc).
fn choose(ev: &Evaluator, g: &Graph, node: Option<&str>) -> Result<(String, Reads), EvalError> {
    if let Some(id) = node {
        let n = g
            .node(id)
            .ok_or_else(|| pick_err(format!("no node '{id}' in the graph")))?;
        let how = reads(ev, &n.kind).ok_or_else(|| {
            pick_err(format!(
                "node '{id}' is a {}: pick reads a node with `visibility` and `depth` ports",
                n.kind
            ))
        })?;
        return Ok((id.to_string(), how));
    }
    for want in [Reads::Inputs, Reads::Outputs] {
        if let Some(n) = g.nodes().find(|n| reads(ev, &n.kind) == Some(want)) {
            return Ok((n.id.clone(), want));
        }
    }
    Err(pick_err(
        "the graph has no node with `visibility` and `depth` ports (a scattering node, or one \
         reading it)",
    ))
}

/// Evaluate what pixel `pixel` sees at the node `node` (default: see the module doc): V̄,
/// linear depth, the node's table coordinates and the surface point under it.
pub fn pick(
    ev: &mut Evaluator,
    g: &Graph,
    node: Option<&str>,
    pixel: (u32, u32),
    opts: &EvalOptions,
) -> Result<Pick, EvalError> {
    // Inside groups too: the flattened graph (a transfer function in a group is
    // `group/inner`).
    let flat;
    let g = if g.has_group_nodes() {
        flat = g.flatten(ev.registry().catalog())?;
        &flat
    } else {
        g
    };
    let (id, how) = choose(ev, g, node)?;
    let port = |name: &str| match how {
        Reads::Inputs => {
            source(g, &id, name).ok_or_else(|| pick_err(format!("{id}.{name} is not connected")))
        }
        Reads::Outputs => Ok((id.clone(), name.to_string())),
    };
    let (vis_src, depth_src) = (port("visibility")?, port("depth")?);
    let scene_src = scene_of(g, &depth_src.0);
    let mut targets = vec![
        Target::Port(vis_src.0.clone(), vis_src.1.clone()),
        Target::Port(depth_src.0.clone(), depth_src.1.clone()),
    ];
    if let Some((n, p)) = &scene_src {
        targets.push(Target::Port(n.clone(), p.clone()));
    }
    let r = ev.evaluate(g, &targets, opts)?;
    let gpu = ev.gpu().clone();
    let rec = gpu.recorder();
    let get = |src: &(String, String)| {
        r.outputs
            .get(src)
            .ok_or_else(|| pick_err(format!("{}.{} produced nothing", src.0, src.1)))
    };
    let vis = download(&rec, get(&vis_src)?).map_err(|e| pick_err(e.to_string()))?;
    let depth_value = get(&depth_src)?;
    let PortValue::Depth(_, camera) = depth_value else {
        return Err(pick_err("the depth input is not a Depth value"));
    };
    let camera = *camera;
    let depth = download(&rec, depth_value).map_err(|e| pick_err(e.to_string()))?;
    let (x, y) = pixel;
    if x >= depth.width || y >= depth.height {
        return Err(pick_err(format!(
            "pixel {x},{y} is outside the {}×{} image",
            depth.width, depth.height
        )));
    }
    let k = (y * depth.width + x) as usize;
    let (visibility, d) = (vis.data[k], depth.data[k]);
    let tf = table(ev, g, &id, opts.time, (visibility, d), &depth, &camera)?;
    let surface = match scene_src.as_ref().and_then(|s| r.outputs.get(s)) {
        Some(v) => {
            let scene = v
                .payload::<crate::scene::GpuScene>()
                .ok_or_else(|| pick_err("the scene port holds no scene"))?;
            let dir = camera.pixel_ray(x, y, depth.width, depth.height);
            scene.scene.ray_hit(camera.eye(), dir).map(|h| SurfacePick {
                object: h.object,
                triangle: h.triangle,
                bary: h.bary,
                position: h.position.to_array(),
            })
        }
        None => None,
    };
    Ok(Pick {
        pixel: [x, y],
        size: [depth.width, depth.height],
        time: opts.time,
        node: id,
        visibility,
        depth: d,
        tf,
        surface,
    })
}

/// The node's table coordinates for the pixel, if its kind has a table.
fn table(
    ev: &Evaluator,
    g: &Graph,
    id: &str,
    time: f64,
    (visibility, depth): (f32, f32),
    depth_image: &Raster,
    camera: &Matrices,
) -> Result<Option<TablePick>, EvalError> {
    let Some(node) = g.node(id) else {
        return Ok(None);
    };
    let Some(kind) = ev.registry().get(&node.kind) else {
        return Ok(None);
    };
    let cat = ev.registry().catalog().clone();
    let mut params = BTreeMap::new();
    for spec in kind.schema().params {
        let v = g
            .param_at(&cat, id, spec.name, time)
            .map_err(|e| pick_err(e.to_string()))?;
        params.insert(spec.name.to_string(), v);
    }
    let at = PickAt {
        id,
        params: &params,
        visibility,
        depth,
        depth_image,
        camera,
    };
    kind.table_coordinates(&at)
        .transpose()
        .map_err(|e| EvalError::Node {
            node: id.to_string(),
            kind: node.kind.clone(),
            source: e,
        })
}
