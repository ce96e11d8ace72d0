//! One document evaluation on the worker thread: what it reads (the viewed node, the wipe's,
//! every node's thumbnail), in that order, and the per-node reports it sends back.

use std::collections::{BTreeMap, BTreeSet};

use tyndall_engine::eval::{
    download, EvalError, EvalOptions, Evaluator, PortValue, Registry, Status, Target,
};
use tyndall_engine::gpu::Gpu;
use tyndall_engine::graph::Graph;
use tyndall_engine::io::Raster;

use super::{picture_ports, NodeReport, Outcome, Picture, Request, THUMB};

/// A picture a shown id reads: (the port name shown, the flattened node, its port).
type Shown = (String, String, String);

pub(super) fn evaluate(
    ev: &mut Evaluator,
    req: &Request,
    thumbed: &mut BTreeSet<String>,
    sink: &tyndall_engine::eval::ProgressSink,
    cancel: tyndall_engine::eval::CancelCheck,
) -> Outcome {
    let start = std::time::Instant::now();
    let proxy = req.proxy.max(1);
    let opts = EvalOptions {
        time: req.time,
        size: tyndall_engine::eval::proxy::proxy_size(req.size, proxy),
        progress: Some(sink.clone()),
        cancel: Some(cancel),
        ..Default::default()
    };
    let registry = ev.registry().clone();
    // Flattened once: every id below is a flattened one (`group/inner`).
    let (graph, ports) = match req.graph.flatten_ports(registry.catalog()) {
        Ok(f) => f,
        Err(e) => return failed(req, &e.to_string(), start),
    };
    // A full request evaluates the flattened document itself (no second copy).
    let graph = if proxy > 1 {
        tyndall_engine::eval::proxy::proxy_graph(&graph, registry.catalog(), proxy)
    } else {
        graph
    };
    let mut nodes: BTreeMap<String, NodeReport> = graph
        .nodes()
        .map(|n| (n.id.clone(), NodeReport::default()))
        .collect();
    let mut aliases = BTreeMap::new();
    for ((inst, _), (n, _)) in &ports {
        aliases.entry(inst.clone()).or_insert_with(|| n.clone());
    }
    let reads = reads(req, &graph, &registry, &ports, proxy);
    let (mut view, mut compare) = (None, None);
    let mut device_lost = None;
    let mut cancelled = false;
    for (id, ports, full) in reads {
        if ports.is_empty() || nodes.get(&id).is_some_and(|r| r.error.is_some()) {
            continue;
        }
        let targets: Vec<Target> = ports
            .iter()
            .map(|(_, n, p)| Target::Port(n.clone(), p.clone()))
            .collect();
        match ev.evaluate(&graph, &targets, &opts) {
            Ok(r) => {
                note_runs(&mut nodes, thumbed, &r.stats);
                if full > 0 {
                    let pictures = pictures(ev.gpu(), &r, &ports, req.textures);
                    if full == 1 {
                        view = Some((id.clone(), pictures));
                    } else {
                        compare = Some((id.clone(), pictures));
                    }
                } else if !thumbed.contains(&id) {
                    if let (Some(v), Some(rep)) = (
                        r.outputs.get(&(ports[0].1.clone(), ports[0].2.clone())),
                        nodes.get_mut(&id),
                    ) {
                        rep.thumb = if req.textures {
                            v.texture().map(|t| Picture::Texture(t.clone()))
                        } else {
                            thumbnail(ev.gpu(), v).map(Picture::Pixels)
                        };
                        thumbed.insert(id.clone());
                    }
                }
            }
            Err(EvalError::Cancelled { .. }) => {
                cancelled = true;
                break;
            }
            Err(e) => {
                let lost = e.device_lost();
                note_error(&mut nodes, thumbed, &id, &e);
                if lost {
                    // Every later read would fail the same way.
                    device_lost = Some(e.to_string());
                    break;
                }
            }
        }
    }
    Outcome {
        generation: req.generation,
        nodes,
        aliases,
        view,
        compare,
        elapsed: start.elapsed(),
        device_lost,
        proxy,
        size: opts.size,
        cancelled,
    }
}

/// What an evaluation reads, in order: the viewed node first (what the artist waits for), the
/// wipe's comparison, then every node's thumbnail (the cache makes the later reads cheap; a
/// proxy shows the viewer only, thumbnails wait for the full-resolution request). Each as
/// (shown id, its pictures as (port shown, flattened node, its port), read back in full: 1 the
/// view, 2 the comparison, 0 a thumbnail).
fn reads(
    req: &Request,
    graph: &Graph,
    registry: &Registry,
    ports: &BTreeMap<(String, String), (String, String)>,
    proxy: u32,
) -> Vec<(String, Vec<Shown>, u8)> {
    // A node's picture outputs, or a group instance's outputs that are pictures.
    let shown = |id: &str| -> Vec<Shown> {
        if graph.node(id).is_some() {
            return picture_ports(graph, registry, id)
                .into_iter()
                .map(|p| (p.clone(), id.to_string(), p))
                .collect();
        }
        ports
            .iter()
            .filter(|((inst, _), (n, p))| {
                inst == id && picture_ports(graph, registry, n).contains(p)
            })
            .map(|((_, port), (n, p))| (port.clone(), n.clone(), p.clone()))
            .collect()
    };
    let mut reads = Vec::new();
    if let Some(id) = &req.view {
        reads.push((id.clone(), shown(id), 1));
    }
    if let Some(id) = &req.compare {
        reads.push((id.clone(), shown(id), 2));
    }
    for id in graph.topo_order().into_iter().filter(|_| proxy == 1) {
        if let Some(first) = shown(&id).into_iter().next() {
            reads.push((id, vec![first], 0));
        }
    }
    reads
}

/// The pictures `ports` read in evaluation `r`, by port shown: their textures, or read back
/// (one that failed to download is left out).
fn pictures(
    gpu: &Gpu,
    r: &tyndall_engine::eval::Evaluation,
    ports: &[Shown],
    textures: bool,
) -> Vec<(String, Picture)> {
    ports
        .iter()
        .filter_map(|(shown, n, p)| {
            let v = r.outputs.get(&(n.clone(), p.clone()))?;
            let picture = if textures {
                Picture::Texture(v.texture()?.clone())
            } else {
                Picture::Pixels(download(&gpu.recorder(), v).ok()?)
            };
            Some((shown.clone(), picture))
        })
        .collect()
}

/// Note in `nodes` which nodes ran (their time; their thumbnail is due again) or were reused.
fn note_runs(
    nodes: &mut BTreeMap<String, NodeReport>,
    thumbed: &mut BTreeSet<String>,
    stats: &tyndall_engine::eval::Stats,
) {
    for s in &stats.nodes {
        let Some(rep) = nodes.get_mut(&s.id) else {
            continue;
        };
        if s.status.ran() {
            rep.status = s.status;
            rep.time = s.time;
            thumbed.remove(&s.id);
        } else if s.status == Status::Reused && !rep.status.ran() {
            rep.status = Status::Reused;
        }
    }
}

/// Note a failed read of `id`: the error on the node that failed, and on `id` which input
/// failed when that is another node.
fn note_error(
    nodes: &mut BTreeMap<String, NodeReport>,
    thumbed: &mut BTreeSet<String>,
    id: &str,
    e: &EvalError,
) {
    let culprit = match e {
        EvalError::Node { node, .. } => node.clone(),
        _ => id.to_string(),
    };
    thumbed.remove(&culprit);
    if let Some(rep) = nodes.get_mut(&culprit) {
        rep.error = Some(e.to_string());
    }
    if culprit != id {
        if let Some(rep) = nodes.get_mut(id) {
            rep.error = Some(format!("input failed: node '{culprit}'"));
        }
    }
}

/// The outcome of a request whose graph cannot be flattened: every node carries the reason.
fn failed(req: &Request, reason: &str, start: std::time::Instant) -> Outcome {
    let nodes = req
        .graph
        .nodes()
        .map(|n| {
            let error = Some(reason.to_string());
            (
                n.id.clone(),
                NodeReport {
                    error,
                    ..NodeReport::default()
                },
            )
        })
        .collect();
    Outcome {
        generation: req.generation,
        nodes,
        aliases: BTreeMap::new(),
        view: None,
        compare: None,
        elapsed: start.elapsed(),
        device_lost: None,
        proxy: req.proxy.max(1),
        size: req.size,
        cancelled: false,
    }
}

/// A picture-like value read back and shrunk into a thumbnail ([`thumbnail_of`]); `None` for
/// values that are not 2D pictures.
fn thumbnail(gpu: &Gpu, value: &PortValue) -> Option<Raster> {
    Some(thumbnail_of(&download(&gpu.recorder(), value).ok()?))
}

/// A thumbnail of `r`: shrunk (box filter) to at most [`THUMB`] pixels wide or high; one-channel
/// values beyond 1 (depths in metres) divided by their largest finite value so the thumbnail
/// shows their shape instead of white. (The display pass does the same on the GPU,
/// `tyndall_engine::display::Look::thumbnail`.)
pub fn thumbnail_of(r: &Raster) -> Raster {
    let mut r = shrink(r, THUMB);
    if r.channels == 1 {
        let top = r
            .data
            .iter()
            .filter(|v| v.is_finite())
            .fold(0.0f32, |a, v| a.max(*v));
        if top > 1.0 {
            r.data.iter_mut().for_each(|v| *v /= top);
        }
    }
    r
}

/// Shrink `r` by an integer box filter so its longer side is at most `side` pixels.
pub fn shrink(r: &Raster, side: u32) -> Raster {
    let f = r.width.max(r.height).div_ceil(side.max(1)).max(1);
    let (w, h) = (r.width.div_ceil(f), r.height.div_ceil(f));
    let c = r.channels as usize;
    let mut data = vec![0.0f32; (w * h) as usize * c];
    for y in 0..h {
        for x in 0..w {
            let mut n = 0.0f32;
            let mut acc = [0.0f32; 4];
            for sy in y * f..((y + 1) * f).min(r.height) {
                for sx in x * f..((x + 1) * f).min(r.width) {
                    let i = (sy * r.width + sx) as usize * c;
                    for (a, v) in acc.iter_mut().zip(&r.data[i..i + c]) {
                        *a += v;
                    }
                    n += 1.0;
                }
            }
            let o = (y * w + x) as usize * c;
            for (d, a) in data[o..o + c].iter_mut().zip(acc) {
                *d = a / n.max(1.0);
            }
        }
    }
    Raster {
        width: w,
        height: h,
        channels: r.channels,
        data,
    }
}
