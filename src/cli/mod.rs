//! The command line: `tyndall node | eval | render | pick | validate | bench | edit | nodes |
//! info`.
//!
//! Exit codes: 0 ok, 1 evaluation error, 2 bad input (file, graph, argument).

mod runtime_dir;
pub use runtime_dir::ensure_runtime_dir;
mod bench;
mod eval;
mod group;
mod info;
mod job;
mod node;
mod nodes;
mod pick;
mod render;

pub use bench::BenchArgs;
pub use eval::EvalArgs;
pub use node::NodeArgs;
pub use nodes::catalog_text;
pub use pick::PickArgs;
pub use render::{chunk_of, ProgressMode, RenderArgs};
pub use tyndall_engine::eval::{parse_frame_spec, FrameList};
pub use tyndall_engine::graph::type_for_file;

use std::collections::BTreeMap;
use std::hash::{Hash, Hasher};
use std::path::{Path, PathBuf};
use std::sync::Arc;

use clap::{Args, Parser, Subcommand};
use thiserror::Error;

use crate::eval::{
    download, upload_raster, with_suffix, EvalError, EvalOptions, Evaluation, Evaluator, PortValue,
    Registry, Target,
};
use crate::gpu::Gpu;
use crate::graph::{load_file, num, split_endpoint, Graph, NodeSchema, ParamKind, ParamValue};
use crate::io::{read_image, write_image, Precision};

/// Tyndall: a GPU node-graph compositor for stylized light shafts.
#[derive(Parser, Debug)]
#[command(name = "tyndall", version, about, long_about = None)]
pub struct Cli {
    /// GPU adapter to run on: an index or a part of the name shown by `tyndall info`,
    /// optionally with its backend (`llvmpipe/gl`, `vulkan`); default `TYNDALL_ADAPTER`, else
    /// the best adapter that qualifies. One that does not qualify is refused, saying what it
    /// lacks.
    #[arg(long, global = true, value_name = "NAME-or-INDEX")]
    pub adapter: Option<String>,
    /// Write a Chrome trace of the run (node runs, GPU passes when timed — `--stats`, benches —,
    /// pipeline creations, read-backs, file writes) to FILE: open it in Perfetto
    /// (ui.perfetto.dev) or chrome://tracing.
    #[arg(long, global = true, value_name = "FILE")]
    pub trace: Option<PathBuf>,
    /// OpenColorIO config for every colour conversion: a file (`.ocio`, `.ocioz`) or a
    /// built-in `ocio://…` name; default `$OCIO`, else
    /// `ocio://cg-config-v4.0.0_aces-v2.0_ocio-v2.5`. `tyndall info` lists its displays,
    /// views and looks; one that cannot be read is refused (exit 2).
    #[arg(long, global = true, value_name = "CONFIG")]
    pub ocio: Option<String>,
    /// What to do.
    #[command(subcommand)]
    pub command: Command,
}

/// Subcommands.
#[derive(Subcommand, Debug)]
pub enum Command {
    /// Run one node on files: the quickest way to try a node.
    Node(NodeArgs),
    /// Evaluate a graph: its outputs, or chosen ports written to files.
    Eval(EvalArgs),
    /// Render a graph's outputs (all sinks), optionally over a frame range.
    Render(RenderArgs),
    /// Write an Open Job Description (2023-09) job template that renders a graph's frames in
    /// chunks (`tyndall render --chunk … --skip-existing` per task): for Deadline Cloud, OpenCue,
    /// or `openjd run JOB --step Render` on this machine.
    Job(job::JobArgs),
    /// What one pixel's view ray sees: V̄, linear depth, transfer-function coordinates and the
    /// surface point under it (for 3D constraints anchored to the scene).
    Pick(PickArgs),
    /// Make a library group from nodes of a graph: the cut edges become its ports, `--expose`
    /// makes knobs; writes the library file (`graphs/lib/…`).
    Group(group::GroupArgs),
    /// Check a graph file and report the first problem with its line:column; then what its
    /// nodes find in the files they read (a glTF's animations and their frame ranges).
    Validate {
        /// The graph file.
        graph: PathBuf,
        /// Print JSON instead: `{"graph", "nodes": [{"id", "kind"}], "notes": [...]}` — what a
        /// pipeline tool (the Blender add-on) reads to find the nodes it sets.
        #[arg(long)]
        json: bool,
    },
    /// Measure speed against accuracy of node quality settings (suites in benches/). With no
    /// suite: every suite, then bench/results.csv, the plots in bench/plots/ and the tables of
    /// BENCHMARKS.md.
    Bench(BenchArgs),
    /// Open the editor window: node canvas, viewer, parameters, timeline, presets, transfer-function, stroke and 3D-brush panels.
    Edit {
        /// Graph to open (an empty graph when left out).
        graph: Option<PathBuf>,
    },
    /// What this machine offers Tyndall: every GPU adapter found (backend, device type,
    /// driver), whether it qualifies and what it lacks, which one is used and why, the limits
    /// that matter, the nodes an adapter cannot run, the crate and graph format versions. Paste
    /// it into a bug report.
    Info {
        /// JSON (for scripts and bug-report templates).
        #[arg(long)]
        json: bool,
    },
    /// List every node kind with its ports and parameters.
    Nodes {
        /// Markdown tables (for docs).
        #[arg(long, conflicts_with = "json")]
        markdown: bool,
        /// JSON (for scripts and pipeline tools).
        #[arg(long)]
        json: bool,
    },
}

/// Options shared by evaluation commands.
#[derive(Args, Debug, Clone)]
pub struct Common {
    /// Default image size for nodes that create images, WIDTHxHEIGHT.
    #[arg(long, value_parser = parse_size)]
    pub size: Option<(u32, u32)>,
    /// Print per-node statistics (ran | passed through | reused | not needed; wall ms: the
    /// node's CPU time, recording its passes — the GPU runs them while later nodes are recorded;
    /// gpu ms: its passes' GPU time from timestamp queries, read once per evaluation).
    #[arg(long)]
    pub stats: bool,
    /// Evaluate once per value of NODE.PARAM in one process: NODE.PARAM=v1,v2,... Output files
    /// get the suffix `_PARAM-VALUE`.
    #[arg(long, value_name = "NODE.PARAM=V1,V2,...")]
    pub wedge: Option<String>,
    /// Override a parameter: NODE.PARAM=VALUE (repeatable).
    #[arg(long = "set", value_name = "NODE.PARAM=VALUE")]
    pub set: Vec<String>,
    /// Folder that the graph's relative output paths are written under (default: the working
    /// directory). The graph's relative input paths are read from the graph file's folder.
    #[arg(long, value_name = "DIR")]
    pub output_dir: Option<PathBuf>,
    /// Let the graph write to absolute paths and climb out of the output directory with `..`
    /// (refused by default, so a preset from someone else cannot overwrite your files). Paths
    /// you give on the command line (-o, --output, --set) are yours and always allowed.
    #[arg(long)]
    pub allow_any_path: bool,
    /// Preview at 1/F: the image size and every size in screen pixels or light-space texels
    /// (shadow-map resolution, closure radius, soft-visibility buffer…) divided by F, as the
    /// editor shows a dragged knob (1…64; 1, the default, is the full render).
    #[arg(long, value_name = "F", default_value_t = 1,
          value_parser = clap::value_parser!(u32).range(1..=64))]
    pub proxy: u32,
}

impl Common {
    /// The evaluation size: `--size`, else `default`, divided by `--proxy`.
    pub fn size_or(&self, default: (u32, u32)) -> (u32, u32) {
        crate::eval::proxy::proxy_size(self.size.unwrap_or(default), self.proxy)
    }

    /// `g` as evaluated under `--proxy` (flattened, its sizes divided; unchanged at 1).
    fn proxied(&self, registry: &Registry, g: Graph) -> Result<Graph, CliError> {
        if self.proxy <= 1 {
            return Ok(g);
        }
        let flat = g.flatten(registry.catalog()).map_err(bad)?;
        Ok(crate::eval::proxy::proxy_graph(
            &flat,
            registry.catalog(),
            self.proxy,
        ))
    }
}

/// A CLI failure with its exit code.
#[derive(Debug, Error)]
pub enum CliError {
    /// Bad file, graph or argument (exit 2).
    #[error("{0}")]
    BadInput(String),
    /// Evaluation failed (exit 1).
    #[error(transparent)]
    Eval(Box<EvalError>),
    /// Some frames of a render failed (exit 1); the others were written.
    #[error("frames failed: {}", .0.join(", "))]
    Frames(Vec<String>),
    /// Some bench suites failed (exit 1); the others were measured and recorded.
    #[error("bench suites failed: {}", .0.join(", "))]
    Suites(Vec<String>),
    /// No GPU to run on (exit 1): the message names each adapter seen, what it lacks and what
    /// to install.
    #[error("{0}")]
    NoGpu(String),
}

impl From<EvalError> for CliError {
    fn from(e: EvalError) -> Self {
        // A malformed input file is bad input (exit 2) wherever the evaluation found it.
        if e.bad_input() {
            return CliError::BadInput(e.to_string());
        }
        CliError::Eval(Box::new(e))
    }
}

impl CliError {
    /// The process exit code.
    pub fn exit_code(&self) -> i32 {
        match self {
            CliError::BadInput(_) => 2,
            CliError::Eval(_) | CliError::Frames(_) | CliError::Suites(_) | CliError::NoGpu(_) => 1,
        }
    }
}

pub(super) fn bad(msg: impl std::fmt::Display) -> CliError {
    CliError::BadInput(msg.to_string())
}

pub(super) fn parse_size(s: &str) -> Result<(u32, u32), String> {
    let (w, h) = s
        .split_once(['x', 'X'])
        .ok_or("expected WIDTHxHEIGHT, e.g. 960x540")?;
    let w: u32 = w.trim().parse().map_err(|_| format!("bad width '{w}'"))?;
    let h: u32 = h.trim().parse().map_err(|_| format!("bad height '{h}'"))?;
    if w == 0 || h == 0 || w > 16384 || h > 16384 {
        return Err("width and height must be within 1..=16384".into());
    }
    Ok((w, h))
}

pub(super) fn split_eq(s: &str, what: &str) -> Result<(String, String), CliError> {
    s.split_once('=')
        .map(|(a, b)| (a.trim().to_string(), b.to_string()))
        .ok_or_else(|| bad(format!("'{s}': expected {what}")))
}

/// Run the command line; returns the exit code.
pub fn main() -> i32 {
    let cli = Cli::parse();
    let code = match run(cli) {
        Ok(()) => 0,
        Err(e) => {
            eprintln!("error: {e}");
            e.exit_code()
        }
    };
    // An error can leave passes queued; the driver must finish them before the process exits.
    crate::gpu::Gpu::settle_shared();
    code
}

/// Run a parsed command.
pub fn run(cli: Cli) -> Result<(), CliError> {
    let Some(trace) = cli.trace.clone() else {
        return run_command(cli);
    };
    tyndall_engine::trace::start();
    let ran = run_command(cli);
    // Queued work finishes (and is traced) before the file is written.
    crate::gpu::Gpu::settle_shared();
    let written = tyndall_engine::trace::finish(&trace)
        .map_err(|e| bad(format!("--trace {}: {e}", trace.display())));
    ran.and(written)
}

/// Run a parsed command (without its trace).
fn run_command(cli: Cli) -> Result<(), CliError> {
    let registry = Arc::new(crate::nodes::registry());
    if cli.adapter.is_some() {
        crate::gpu::set_adapter_choice(cli.adapter.clone());
    }
    if let Some(spec) = &cli.ocio {
        tyndall_engine::colour::set_current(spec).map_err(|e| bad(format!("--ocio: {e}")))?;
    }
    match cli.command {
        Command::Info { json } => {
            print!("{}", info::report(&registry, json));
            Ok(())
        }
        Command::Validate { graph, json } => {
            let text = std::fs::read_to_string(&graph).unwrap_or_default();
            if crate::graph::is_library_text(&text) {
                let def = crate::graph::load_library_file(&graph, registry.catalog())
                    .map_err(|e| bad(format!("{}: {e}", graph.display())))?;
                let s = def.schema();
                println!(
                    "{}: ok (library group {} version {}: {} inputs, {} outputs, {} knobs, {} inner nodes)",
                    graph.display(),
                    def.name,
                    def.version,
                    s.inputs.len(),
                    s.outputs.len(),
                    s.params.len(),
                    def.graph.len()
                );
                return Ok(());
            }
            let g = load_file(&graph, registry.catalog()).map_err(bad)?;
            if json {
                let nodes: Vec<serde_json::Value> = g
                    .nodes()
                    .map(|n| serde_json::json!({"id": n.id, "kind": n.kind}))
                    .collect();
                let v = serde_json::json!({
                    "graph": graph.display().to_string(),
                    "nodes": nodes,
                    "notes": describe_files(&registry, &g, &graph),
                });
                println!("{}", serde_json::to_string_pretty(&v).map_err(bad)?);
                return Ok(());
            }
            println!(
                "{}: ok ({} nodes, {} edges)",
                graph.display(),
                g.len(),
                g.edges().len()
            );
            let notes = describe_files(&registry, &g, &graph);
            for line in &notes {
                println!("  {line}");
            }
            // A problem a node finds in its files (an unreadable file, a light that cannot be
            // used) makes the graph invalid: exit 2 with the lines that say so.
            let problems: Vec<&String> =
                notes.iter().filter(|l| l.contains("': error: ")).collect();
            if !problems.is_empty() {
                let lines: Vec<&str> = problems.iter().map(|l| l.as_str()).collect();
                return Err(bad(format!("{}: {}", graph.display(), lines.join("; "))));
            }
            Ok(())
        }
        Command::Nodes { markdown, json } => {
            print!("{}", catalog_text(&registry, markdown, json));
            Ok(())
        }
        Command::Node(a) => node::run_node(registry, a),
        Command::Edit { graph } => crate::editor::run(graph, registry, crate::tools::registry())
            .map_err(|e| {
                if Gpu::shared().is_err() {
                    CliError::NoGpu(e)
                } else {
                    bad(e)
                }
            }),
        Command::Bench(a) if a.replot => bench::replot(
            &a.out.unwrap_or_else(|| PathBuf::from("bench")),
            a.suite.as_deref(),
        ),
        Command::Bench(a) => bench::run_bench(registry, a),
        Command::Eval(a) => eval::run_eval(registry, a),
        Command::Pick(a) => pick::run_pick(registry, a),
        Command::Group(a) => group::run_group(registry, a),
        Command::Render(a) => render::run_render(registry, a),
        Command::Job(a) => job::run_job(&registry, a),
    }
}

pub(super) fn gpu() -> Result<Arc<Gpu>, CliError> {
    Gpu::shared().map_err(|e| match e {
        crate::gpu::GpuError::NoAdapter(m) => CliError::NoGpu(m),
        e => CliError::NoGpu(format!("cannot start the GPU: {e}")),
    })
}

/// `--set`/`--wedge`/`--input`: a parameter from text; a key-framed parameter becomes constant.
pub(super) fn set_param_str(
    registry: &Registry,
    g: &mut Graph,
    node: &str,
    param: &str,
    value: &str,
) -> Result<(), CliError> {
    g.set_param_text(registry.catalog(), node, param, value)
        .map_err(bad)?;
    g.set_keys(registry.catalog(), node, param, Vec::new())
        .map_err(bad)
}

/// Warn (on stderr) about each `--set` parameter that is not in effect once every `--set` is
/// applied: its value is kept but changes nothing.
pub(super) fn warn_not_in_effect(registry: &Registry, g: &Graph, set: &[(String, String)]) {
    for (node, param) in set {
        if let Err(why) = g.param_in_effect(registry.catalog(), node, param, 0.0) {
            eprintln!("warning: {node}.{param} is set but changes nothing: it counts {why}");
        }
    }
}

pub(super) fn write_value(gpu: &Gpu, v: &PortValue, path: &Path) -> Result<(), CliError> {
    let mut raster =
        download(&gpu.recorder(), v).map_err(|e| bad(format!("{}: {e}", path.display())))?;
    if let PortValue::Phase(_) = v {
        // A phase table is written as W×1 RGB (its alpha carries nothing).
        raster.data = raster
            .data
            .chunks(4)
            .flat_map(|p| [p[0], p[1], p[2]])
            .collect();
        raster.channels = 3;
    }
    let precision = match crate::io::file_kind(path).map_err(bad)? {
        crate::io::FileKind::Exr => Precision::F32,
        crate::io::FileKind::Png => Precision::U8,
    };
    write_image(path, &raster, precision, true).map_err(|e| {
        CliError::from(EvalError::Node {
            node: "-".into(),
            kind: "output".into(),
            source: e.into(),
        })
    })
}

/// What the nodes said about their runs ([`tyndall_engine::eval::RunCtx::note`]), on stderr
/// with or without `--stats`.
pub(super) fn print_notes(ev: &Evaluation) {
    for (node, note) in &ev.stats.notes {
        eprintln!("note: node '{node}': {note}");
    }
}

pub(super) fn print_stats(ev: &Evaluation, header: &str) {
    if !header.is_empty() {
        println!("{header}");
    }
    print!("{}", ev.stats);
}

pub(super) struct Wedge {
    node: String,
    param: String,
    values: Vec<String>,
}

pub(super) fn parse_wedge(s: &str) -> Result<Wedge, CliError> {
    let (target, values) = split_eq(s, "NODE.PARAM=V1,V2,...")?;
    let (node, param) = split_endpoint(&target).map_err(bad)?;
    let values: Vec<String> = values
        .split(',')
        .map(|v| v.trim().to_string())
        .filter(|v| !v.is_empty())
        .collect();
    if values.is_empty() {
        return Err(bad("--wedge needs at least one value"));
    }
    Ok(Wedge {
        node: node.to_string(),
        param: param.to_string(),
        values,
    })
}

/// Paths of the graph file `path`: inputs read from its folder, outputs under `output_dir`.
fn path_policy(path: &Path, output_dir: PathBuf, allow_any: bool) -> crate::eval::PathPolicy {
    crate::eval::PathPolicy {
        graph_dir: path
            .parent()
            .filter(|p| !p.as_os_str().is_empty())
            .unwrap_or(Path::new("."))
            .to_path_buf(),
        output_dir,
        allow_any,
    }
}

/// What each node finds in the files it reads (`NodeKind::describe_files`), paths read from
/// the graph's folder, as `node 'id': line`.
fn describe_files(registry: &Registry, g: &Graph, path: &Path) -> Vec<String> {
    let policy = path_policy(path, PathBuf::from("."), true);
    let Ok(g) = crate::eval::resolve_files(registry, g, &policy) else {
        return Vec::new();
    };
    let mut out = Vec::new();
    for node in g.nodes() {
        let Some(kind) = registry.get(&node.kind) else {
            continue;
        };
        let mut params = std::collections::BTreeMap::new();
        for p in kind.schema().params {
            if let Ok(v) = g.param_at(registry.catalog(), &node.id, p.name, 0.0) {
                params.insert(p.name.to_string(), v);
            }
        }
        for line in kind.describe_files(&params) {
            out.push(format!("node '{}': {line}", node.id));
        }
    }
    out
}

pub(super) fn load_graph(
    registry: &Registry,
    path: &Path,
    common: &Common,
) -> Result<Graph, CliError> {
    let g = load_file(path, registry.catalog()).map_err(bad)?;
    // The graph's own file paths first (the policy); what the command line sets is the user's.
    let policy = path_policy(
        path,
        common
            .output_dir
            .clone()
            .unwrap_or_else(|| PathBuf::from(".")),
        common.allow_any_path,
    );
    let mut g = crate::eval::resolve_files(registry, &g, &policy).map_err(bad)?;
    let mut set = Vec::new();
    for s in &common.set {
        let (target, value) = split_eq(s, "NODE.PARAM=VALUE")?;
        let (node, param) = split_endpoint(&target).map_err(bad)?;
        set_param_str(registry, &mut g, node, param, &value)?;
        set.push((node.to_string(), param.to_string()));
    }
    warn_not_in_effect(registry, &g, &set);
    Ok(g)
}

/// One evaluation variant: the graph to evaluate, the file suffix and a label.
pub(super) struct Variant {
    graph: Graph,
    suffix: String,
    label: String,
}

/// The evaluations a command makes of `g`: one per `--wedge` value (one without it), each
/// under `--proxy`.
pub(super) fn variants(
    registry: &Registry,
    g: &Graph,
    common: &Common,
) -> Result<Vec<Variant>, CliError> {
    let Some(w) = common.wedge.as_deref() else {
        return Ok(vec![Variant {
            graph: common.proxied(registry, g.clone())?,
            suffix: String::new(),
            label: String::new(),
        }]);
    };
    let w = parse_wedge(w)?;
    let mut out = Vec::new();
    for (i, v) in w.values.iter().enumerate() {
        let mut gv = g.clone();
        set_param_str(registry, &mut gv, &w.node, &w.param, v)?;
        let clean: String = v
            .chars()
            .map(|c| {
                if c.is_ascii_alphanumeric() || c == '.' || c == '-' {
                    c
                } else {
                    '_'
                }
            })
            .collect();
        out.push(Variant {
            graph: common.proxied(registry, gv)?,
            suffix: format!("_{}-{clean}", w.param),
            label: format!(
                "evaluation {}/{} ({}.{} = {v})",
                i + 1,
                w.values.len(),
                w.node,
                w.param
            ),
        });
    }
    Ok(out)
}

/// Progress of long-running nodes (a light-map solve): a bar on a terminal, else a plain line
/// at every tenth of the work.
pub(super) fn node_progress() -> crate::eval::ProgressSink {
    use std::io::IsTerminal;
    use std::sync::Mutex;
    let terminal = std::io::stderr().is_terminal();
    let bar: Mutex<Option<(String, indicatif::ProgressBar)>> = Mutex::new(None);
    let last_tenth = Mutex::new(u64::MAX);
    crate::eval::ProgressSink(Arc::new(move |p: &crate::eval::Progress| {
        if !terminal {
            let tenth = (p.done * 10).checked_div(p.total).unwrap_or(0);
            if let Ok(mut last) = last_tenth.lock() {
                if *last != tenth || p.done == p.total {
                    *last = tenth;
                    eprintln!("{}: {}/{} {}", p.node, p.done, p.total, p.message);
                }
            }
            return;
        }
        let Ok(mut guard) = bar.lock() else {
            return;
        };
        if guard.as_ref().is_none_or(|(n, _)| *n != p.node) {
            let b = indicatif::ProgressBar::new(p.total);
            let template = format!("{} {{bar:30}} {{pos}}/{{len}} {{msg}}", p.node);
            if let Ok(style) = indicatif::ProgressStyle::with_template(&template) {
                b.set_style(style);
            }
            *guard = Some((p.node.clone(), b));
        }
        if let Some((_, b)) = guard.as_ref() {
            b.set_length(p.total);
            b.set_position(p.done);
            b.set_message(p.message.clone());
            if p.done >= p.total {
                b.finish_and_clear();
                *guard = None;
            }
        }
    }))
}
