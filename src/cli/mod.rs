//! The command line: `tyndall node | eval | render | pick | validate | bench | edit | nodes |
//! info`.
//!
//! Exit codes: 0 ok, 1 evaluation error, 2 bad input (file, graph, argument).

mod info;

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
use crate::graph::{
    load_file, num, split_endpoint, Graph, NodeSchema, ParamKind, ParamValue, PortType,
};
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
    /// What one pixel's view ray sees: V̄, linear depth, transfer-function coordinates and the
    /// surface point under it (for 3D constraints anchored to the scene).
    Pick(PickArgs),
    /// Check a graph file and report the first problem with its line:column.
    Validate {
        /// The graph file.
        graph: PathBuf,
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

/// `tyndall bench` options.
#[derive(Args, Debug)]
pub struct BenchArgs {
    /// Suite name (`benches/NAME.ron`, or every suite in the folder `benches/NAME/`) or path;
    /// none: every suite under benches/.
    pub suite: Option<String>,
    /// Runs per setting (default: the suite's; 1 with --quick).
    #[arg(long)]
    pub runs: Option<usize>,
    /// Evaluation size WIDTHxHEIGHT (default: the suite's).
    #[arg(long, value_parser = parse_size)]
    pub size: Option<(u32, u32)>,
    /// A reduced run: each suite's `quick` settings at its `quick_size`, one run each
    /// (a few minutes for every suite); results go to bench/quick/ and BENCHMARKS.md is left
    /// alone unless --docs names it.
    #[arg(long, conflicts_with = "full")]
    pub quick: bool,
    /// Also the settings a suite marks `slow` (left out by default to keep the whole run
    /// under 15 minutes on two CPU cores).
    #[arg(long)]
    pub full: bool,
    /// CSV file of one suite (default: out/bench/NAME.csv); for a folder of suites, the
    /// folder to write one CSV per suite in (default: out/bench/NAME/).
    #[arg(long, conflicts_with = "out")]
    pub csv: Option<PathBuf>,
    /// Folder for results.csv and plots/ when every suite runs (default: bench, or
    /// bench/quick with --quick).
    #[arg(long)]
    pub out: Option<PathBuf>,
    /// Markdown file whose generated blocks to rewrite (default: BENCHMARKS.md when every
    /// suite runs without --quick; otherwise none).
    #[arg(long, conflicts_with = "no_docs")]
    pub docs: Option<PathBuf>,
    /// Leave BENCHMARKS.md alone.
    #[arg(long)]
    pub no_docs: bool,
    /// Measure nothing: draw the plots again from the recorded results.csv (in --out).
    #[arg(long, conflicts_with_all = ["quick", "full", "csv", "docs", "runs", "size"])]
    pub replot: bool,
}

/// Options shared by evaluation commands.
#[derive(Args, Debug, Clone)]
pub struct Common {
    /// Default image size for nodes that create images, WIDTHxHEIGHT.
    #[arg(long, value_parser = parse_size)]
    pub size: Option<(u32, u32)>,
    /// Print per-node statistics (ran | passed through | reused | not needed, time).
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
}

/// `tyndall node`.
#[derive(Args, Debug)]
pub struct NodeArgs {
    /// Node kind (see `tyndall nodes`).
    pub kind: String,
    /// Parameter: NAME=VALUE (repeatable).
    #[arg(long = "param", value_name = "NAME=VALUE")]
    pub params: Vec<String>,
    /// RON file holding the node's data block.
    #[arg(long)]
    pub data: Option<PathBuf>,
    /// Input port fed from a file: PORT=FILE (repeatable).
    #[arg(long = "input", value_name = "PORT=FILE")]
    pub inputs: Vec<String>,
    /// Output port written to a file: PORT=FILE (repeatable).
    #[arg(long = "output", value_name = "PORT=FILE")]
    pub outputs: Vec<String>,
    /// Time at which key-frames are sampled.
    #[arg(long, default_value_t = 0.0)]
    pub time: f64,
    /// Default image size, WIDTHxHEIGHT.
    #[arg(long, value_parser = parse_size)]
    pub size: Option<(u32, u32)>,
    /// Print statistics.
    #[arg(long)]
    pub stats: bool,
}

/// `tyndall pick`.
#[derive(Args, Debug)]
pub struct PickArgs {
    /// The graph file.
    pub graph: PathBuf,
    /// The pixel, X,Y (x right, y down, in the evaluation size).
    #[arg(long, value_parser = parse_pixel)]
    pub pixel: (u32, u32),
    /// Time (frames) at which key-frames are sampled.
    #[arg(long, default_value_t = 0.0)]
    pub time: f64,
    /// The node to read (one with `visibility` and `depth` ports); default: the first that
    /// reads both through inputs (a transfer function), else the first that produces both (a
    /// scattering node).
    #[arg(long)]
    pub node: Option<String>,
    /// Print JSON.
    #[arg(long)]
    pub json: bool,
    /// Evaluation size, WIDTHxHEIGHT (the pixel refers to it; default 960x540, as `render`).
    #[arg(long, value_parser = parse_size)]
    pub size: Option<(u32, u32)>,
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
}

fn parse_pixel(s: &str) -> Result<(u32, u32), String> {
    let (x, y) = s
        .split_once(',')
        .ok_or_else(|| format!("expected X,Y, got {s:?}"))?;
    let n = |v: &str| {
        v.trim()
            .parse::<u32>()
            .map_err(|_| format!("{v:?} is not a pixel coordinate"))
    };
    Ok((n(x)?, n(y)?))
}

fn run_pick(registry: Arc<Registry>, a: PickArgs) -> Result<(), CliError> {
    let common = Common {
        size: a.size,
        stats: false,
        wedge: None,
        set: a.set.clone(),
        output_dir: None,
        // pick writes nothing: the graph's output paths do not matter.
        allow_any_path: true,
    };
    let g = load_graph(&registry, &a.graph, &common)?;
    let gpu = gpu()?;
    let mut ev = Evaluator::new(registry, gpu);
    let opts = EvalOptions {
        time: a.time,
        size: a.size.unwrap_or((960, 540)),
        ..Default::default()
    };
    let p = crate::eval::pick::pick(&mut ev, &g, a.node.as_deref(), a.pixel, &opts)?;
    if a.json {
        println!(
            "{}",
            serde_json::to_string_pretty(&p).map_err(|e| bad(e.to_string()))?
        );
        return Ok(());
    }
    println!(
        "pixel {},{} of {}x{} at time {} (node {})",
        p.pixel[0], p.pixel[1], p.size[0], p.size[1], p.time, p.node
    );
    println!("visibility  {:.6}", p.visibility);
    println!("depth       {:.4} m", p.depth);
    if let Some(t) = &p.tf {
        println!(
            "tf          u {:.6}  v {:.6}  (depth range {} {:.4} … {:.4} m)",
            t.u, t.v, t.depth_range, t.depth_min, t.depth_max
        );
    }
    match &p.surface {
        Some(s) => {
            println!(
                "surface     object {:?} triangle {} bary ({:.6}, {:.6}, {:.6}) at ({:.4}, {:.4}, {:.4})",
                s.object, s.triangle, s.bary[0], s.bary[1], s.bary[2], s.position[0], s.position[1], s.position[2]
            );
            println!(
                "anchor      anchor: Some((object: {:?}, triangle: {}, bary: ({:.6}, {:.6}, {:.6})))",
                s.object, s.triangle, s.bary[0], s.bary[1], s.bary[2]
            );
        }
        None => println!("surface     none (sky, or no scene upstream of the depth)"),
    }
    Ok(())
}

/// `tyndall eval`.
#[derive(Args, Debug)]
pub struct EvalArgs {
    /// The graph file.
    pub graph: PathBuf,
    /// Replace a node's `path` parameter (e.g. an ImageInput's file): NODE=FILE (repeatable).
    #[arg(long = "input", value_name = "NODE=FILE")]
    pub inputs: Vec<String>,
    /// Write an output port to a file: NODE.PORT=FILE (repeatable). Without any, the graph's
    /// outputs (sinks) are evaluated.
    #[arg(long = "output", value_name = "NODE.PORT=FILE")]
    pub outputs: Vec<String>,
    /// Time at which key-frames are sampled.
    #[arg(long, default_value_t = 0.0)]
    pub time: f64,
    /// Shared options.
    #[command(flatten)]
    pub common: Common,
}

/// `tyndall render`.
#[derive(Args, Debug)]
pub struct RenderArgs {
    /// The graph file.
    pub graph: PathBuf,
    /// Output file; replaces the `path` of the graph's single output node.
    #[arg(short = 'o', long = "output")]
    pub output: Option<PathBuf>,
    /// Frames to render: `A`, `A-B`, `A-BxS` (every S-th frame), comma-separated (`1,5,7-9`).
    /// A `####` or `%04d` in an output path becomes the zero-padded frame; other paths get
    /// `_NNNN` before the extension. Each frame depends only on the graph, its parameters and the
    /// frame number (noise seeds included), so any subset renders the same pixels.
    #[arg(long, value_parser = parse_frame_spec)]
    pub frames: Option<FrameList>,
    /// Render only chunk K of N (`K/N`, 1-based): the frames split into N contiguous runs, one
    /// per task of a farm array job (Slurm: `--chunk $((SLURM_ARRAY_TASK_ID + 1))/4`).
    #[arg(long, value_parser = parse_chunk)]
    pub chunk: Option<(usize, usize)>,
    /// Skip frames whose output files all exist (rerunning a killed job resumes it; files are
    /// written atomically, so a killed frame leaves none).
    #[arg(long)]
    pub skip_existing: bool,
    /// Progress: auto (a bar on a terminal, else `ALF_PROGRESS nn%` lines), bar, alf, json (a
    /// JSON object per frame on stdout), none.
    #[arg(long, value_enum, default_value_t = ProgressMode::Auto)]
    pub progress: ProgressMode,
    /// Shared options.
    #[command(flatten)]
    pub common: Common,
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

fn bad(msg: impl std::fmt::Display) -> CliError {
    CliError::BadInput(msg.to_string())
}

fn parse_size(s: &str) -> Result<(u32, u32), String> {
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

/// A list of frames (`--frames`).
#[derive(Clone, Debug, PartialEq)]
pub struct FrameList(pub Vec<i64>);

/// How `render` reports progress.
#[derive(Clone, Copy, Debug, PartialEq, Eq, clap::ValueEnum)]
pub enum ProgressMode {
    /// A bar on a terminal, else `ALF_PROGRESS nn%` lines.
    Auto,
    /// A progress bar (hidden when stderr is not a terminal).
    Bar,
    /// `ALF_PROGRESS nn%` lines on stdout (Tractor, OpenCue and Deadline parse them).
    Alf,
    /// One JSON object per frame on stdout.
    Json,
    /// Nothing but the summary.
    None,
}

/// Parse a frame spec: `A`, `A-B`, `A-BxS`, comma-separated; frames ≥ 0, in the order given,
/// repeats dropped.
pub fn parse_frame_spec(s: &str) -> Result<FrameList, String> {
    let mut out: Vec<i64> = Vec::new();
    for part in s.split(',').map(str::trim) {
        let num = |t: &str| -> Result<i64, String> {
            t.trim()
                .parse::<i64>()
                .ok()
                .filter(|v| *v >= 0)
                .ok_or_else(|| format!("bad frame '{t}' in '{s}' (frames are whole numbers ≥ 0)"))
        };
        let (range, step) = match part.split_once(['x', 'X']) {
            Some((r, st)) => (r, num(st)?),
            None => (part, 1),
        };
        if step == 0 {
            return Err(format!("'{part}': the step must be at least 1"));
        }
        let (a, b) = match range.split_once('-') {
            Some((a, b)) => (num(a)?, num(b)?),
            None => (num(range)?, num(range)?),
        };
        if b < a {
            return Err(format!("frame range '{part}' is empty"));
        }
        if (b - a) / step > 1_000_000 {
            return Err(format!("'{part}' is more than a million frames"));
        }
        for f in (a..=b).step_by(step as usize) {
            if !out.contains(&f) {
                out.push(f);
            }
        }
    }
    Ok(FrameList(out))
}

fn parse_chunk(s: &str) -> Result<(usize, usize), String> {
    let bad = || format!("'{s}': expected K/N with 1 ≤ K ≤ N, e.g. 2/4");
    let (k, n) = s.split_once('/').ok_or_else(bad)?;
    let (k, n): (usize, usize) = (
        k.trim().parse().map_err(|_| bad())?,
        n.trim().parse().map_err(|_| bad())?,
    );
    if k == 0 || n == 0 || k > n {
        return Err(bad());
    }
    Ok((k, n))
}

/// Chunk `k` of `n` (1-based) of `frames`: contiguous runs whose lengths differ by at most one.
pub fn chunk_of(frames: &[i64], (k, n): (usize, usize)) -> &[i64] {
    let len = frames.len();
    let start = (k - 1) * len / n;
    let end = k * len / n;
    &frames[start..end]
}

fn split_eq(s: &str, what: &str) -> Result<(String, String), CliError> {
    s.split_once('=')
        .map(|(a, b)| (a.trim().to_string(), b.to_string()))
        .ok_or_else(|| bad(format!("'{s}': expected {what}")))
}

/// Run the command line; returns the exit code.
pub fn main() -> i32 {
    let cli = Cli::parse();
    match run(cli) {
        Ok(()) => 0,
        Err(e) => {
            eprintln!("error: {e}");
            e.exit_code()
        }
    }
}

/// Point `XDG_RUNTIME_DIR` at a private directory (`$TMPDIR/tyndall-runtime-$USER`, mode 0700
/// as the XDG base-directory spec asks) when it is unset or not a directory: without it the
/// Vulkan loader's window-system probing prints "error: XDG_RUNTIME_DIR is invalid or not set in
/// the environment." twice per device (CI runners, cron jobs, farm nodes), before a render that
/// then succeeds. Call it before any thread starts (it sets an environment variable).
pub fn ensure_runtime_dir() {
    let valid = std::env::var_os("XDG_RUNTIME_DIR")
        .map(PathBuf::from)
        .is_some_and(|p| p.is_absolute() && p.is_dir());
    if valid {
        return;
    }
    let user = std::env::var("USER").unwrap_or_else(|_| "user".into());
    let dir = std::env::temp_dir().join(format!("tyndall-runtime-{user}"));
    if std::fs::create_dir_all(&dir).is_err() {
        return;
    }
    #[cfg(unix)]
    {
        use std::os::unix::fs::PermissionsExt;
        let _ = std::fs::set_permissions(&dir, std::fs::Permissions::from_mode(0o700));
    }
    std::env::set_var("XDG_RUNTIME_DIR", &dir);
}

/// Run a parsed command.
pub fn run(cli: Cli) -> Result<(), CliError> {
    let registry = Arc::new(crate::nodes::registry());
    if cli.adapter.is_some() {
        crate::gpu::set_adapter_choice(cli.adapter.clone());
    }
    match cli.command {
        Command::Info { json } => {
            print!("{}", info::report(&registry, json));
            Ok(())
        }
        Command::Validate { graph } => {
            let g = load_file(&graph, registry.catalog()).map_err(bad)?;
            println!(
                "{}: ok ({} nodes, {} edges)",
                graph.display(),
                g.len(),
                g.edges().len()
            );
            Ok(())
        }
        Command::Nodes { markdown, json } => {
            print!("{}", catalog_text(&registry, markdown, json));
            Ok(())
        }
        Command::Node(a) => run_node(registry, a),
        Command::Edit { graph } => crate::editor::run(graph).map_err(|e| {
            if Gpu::shared().is_err() {
                CliError::NoGpu(e)
            } else {
                bad(e)
            }
        }),
        Command::Bench(a) if a.replot => replot(
            &a.out.unwrap_or_else(|| PathBuf::from("bench")),
            a.suite.as_deref(),
        ),
        Command::Bench(a) => run_bench(registry, a),
        Command::Eval(a) => run_eval(registry, a),
        Command::Pick(a) => run_pick(registry, a),
        Command::Render(a) => run_render(registry, a),
    }
}

fn gpu() -> Result<Arc<Gpu>, CliError> {
    Gpu::shared().map_err(|e| match e {
        crate::gpu::GpuError::NoAdapter(m) => CliError::NoGpu(m),
        e => CliError::NoGpu(format!("cannot start the GPU: {e}")),
    })
}

/// `--set`/`--wedge`/`--input`: a parameter from text; a key-framed parameter becomes constant.
fn set_param_str(
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

fn file_key(path: &Path) -> u64 {
    let mut h = std::hash::DefaultHasher::new();
    path.hash(&mut h);
    if let Ok(m) = std::fs::metadata(path) {
        m.len().hash(&mut h);
        m.modified().ok().hash(&mut h);
    }
    h.finish()
}

/// The port type a file with `channels` channels should become on a port accepting `accepts`.
fn type_for_file(accepts: &[PortType], channels: u32) -> Option<PortType> {
    if channels == 4 {
        return [PortType::Image, PortType::Lut2D]
            .into_iter()
            .find(|t| accepts.contains(t));
    }
    accepts
        .iter()
        .copied()
        .find(|t| t.is_single_channel())
        .or_else(|| {
            accepts
                .contains(&PortType::Image)
                .then_some(PortType::Image)
        })
}

fn write_value(gpu: &Gpu, v: &PortValue, path: &Path) -> Result<(), CliError> {
    let mut raster = download(gpu, v).map_err(|e| bad(format!("{}: {e}", path.display())))?;
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

fn print_stats(ev: &Evaluation, header: &str) {
    if !header.is_empty() {
        println!("{header}");
    }
    print!("{}", ev.stats);
}

fn run_node(registry: Arc<Registry>, a: NodeArgs) -> Result<(), CliError> {
    let catalog = registry.catalog().clone();
    let schema: &NodeSchema = catalog.get(&a.kind).ok_or_else(|| {
        bad(format!(
            "unknown node kind '{}' (known kinds: {})",
            a.kind,
            catalog.kind_names()
        ))
    })?;
    let id = a.kind.to_lowercase();
    let data = match &a.data {
        Some(d) => {
            let text =
                std::fs::read_to_string(d).map_err(|e| bad(format!("{}: {e}", d.display())))?;
            let v = crate::graph::NodeData::from_text(&text)
                .map_err(|e| bad(format!("{}:{e}", d.display())))?;
            Some(v)
        }
        None => None,
    };
    let mut g = Graph::new();
    g.insert_node(
        &catalog,
        crate::graph::Node {
            id: id.clone(),
            kind: a.kind.clone(),
            params: BTreeMap::new(),
            keys: BTreeMap::new(),
            pos: None,
            data,
        },
    )
    .map_err(bad)?;
    for p in &a.params {
        let (name, value) = split_eq(p, "NAME=VALUE")?;
        set_param_str(&registry, &mut g, &id, &name, &value)?;
    }
    let gpu = gpu()?;
    let mut opts = EvalOptions {
        time: a.time,
        gpu_timings: a.stats,
        progress: Some(node_progress()),
        ..Default::default()
    };
    if let Some(s) = a.size {
        opts.size = s;
    }
    for i in &a.inputs {
        let (port, file) = split_eq(i, "PORT=FILE")?;
        let spec = schema.input(&port).ok_or_else(|| {
            bad(format!(
                "{} has no input port '{port}' (its inputs: {})",
                a.kind,
                schema.input_names()
            ))
        })?;
        let path = PathBuf::from(&file);
        let raster = read_image(&path, true).map_err(bad)?;
        let ty = type_for_file(spec.types, raster.channels).ok_or_else(|| {
            bad(format!(
                "{file}: a {}-channel image cannot feed {}.{port}",
                raster.channels, a.kind
            ))
        })?;
        let v = upload_raster(&gpu, &raster, ty).map_err(|e| bad(format!("{file}: {e}")))?;
        opts.inject
            .insert((id.clone(), port.clone()), (v, file_key(&path)));
    }
    let mut targets = Vec::new();
    let mut files = Vec::new();
    for o in &a.outputs {
        let (port, file) = split_eq(o, "PORT=FILE")?;
        if schema.output(&port).is_none() {
            return Err(bad(format!(
                "{} has no output port '{port}' (its outputs: {})",
                a.kind,
                schema.output_names()
            )));
        }
        targets.push(Target::Port(id.clone(), port.clone()));
        files.push((port, PathBuf::from(file)));
    }
    let is_sink = registry.get(&a.kind).is_some_and(|k| k.is_sink());
    if is_sink {
        targets.push(Target::Node(id.clone()));
    } else if targets.is_empty() {
        return Err(bad(format!(
            "nothing to write: give --output PORT=FILE (outputs of {}: {})",
            a.kind,
            schema.output_names()
        )));
    }
    let mut ev = Evaluator::new(registry.clone(), gpu.clone());
    let result = ev.evaluate(&g, &targets, &opts)?;
    for (port, file) in files {
        if let Some(v) = result.outputs.get(&(id.clone(), port)) {
            write_value(&gpu, v, &file)?;
        }
    }
    if a.stats {
        print_stats(&result, "");
    }
    Ok(())
}

struct Wedge {
    node: String,
    param: String,
    values: Vec<String>,
}

fn parse_wedge(s: &str) -> Result<Wedge, CliError> {
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

fn load_graph(registry: &Registry, path: &Path, common: &Common) -> Result<Graph, CliError> {
    let g = load_file(path, registry.catalog()).map_err(bad)?;
    // The graph's own file paths first (the policy); what the command line sets is the user's.
    let policy = crate::eval::PathPolicy {
        graph_dir: path
            .parent()
            .filter(|p| !p.as_os_str().is_empty())
            .unwrap_or(Path::new("."))
            .to_path_buf(),
        output_dir: common
            .output_dir
            .clone()
            .unwrap_or_else(|| PathBuf::from(".")),
        allow_any: common.allow_any_path,
    };
    let mut g = crate::eval::resolve_files(registry, &g, &policy).map_err(bad)?;
    for s in &common.set {
        let (target, value) = split_eq(s, "NODE.PARAM=VALUE")?;
        let (node, param) = split_endpoint(&target).map_err(bad)?;
        set_param_str(registry, &mut g, node, param, &value)?;
    }
    Ok(g)
}

/// One evaluation variant: the graph to evaluate, the file suffix and a label.
struct Variant {
    graph: Graph,
    suffix: String,
    label: String,
}

fn variants(registry: &Registry, g: &Graph, wedge: Option<&str>) -> Result<Vec<Variant>, CliError> {
    let Some(w) = wedge else {
        return Ok(vec![Variant {
            graph: g.clone(),
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
            graph: gv,
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

fn run_eval(registry: Arc<Registry>, a: EvalArgs) -> Result<(), CliError> {
    let mut g = load_graph(&registry, &a.graph, &a.common)?;
    for i in &a.inputs {
        let (node, file) = split_eq(i, "NODE=FILE")?;
        let has_path = g
            .node(&node)
            .and_then(|n| registry.catalog().get(&n.kind))
            .and_then(|s| s.param("path"))
            .is_some_and(|p| p.kind == ParamKind::Text);
        if !has_path {
            return Err(bad(format!(
                "--input {node}=...: node '{node}' is not in the graph or has no path parameter"
            )));
        }
        g.set_param(registry.catalog(), &node, "path", ParamValue::Text(file))
            .map_err(bad)?;
    }
    let mut targets = Vec::new();
    let mut files = Vec::new();
    for o in &a.outputs {
        let (target, file) = split_eq(o, "NODE.PORT=FILE")?;
        let (node, port) = split_endpoint(&target).map_err(bad)?;
        targets.push(Target::Port(node.to_string(), port.to_string()));
        files.push(((node.to_string(), port.to_string()), file));
    }
    let gpu = gpu()?;
    let mut ev = Evaluator::new(registry.clone(), gpu.clone());
    if targets.is_empty() {
        targets = ev.sinks(&g);
        if targets.is_empty() {
            return Err(bad(format!(
                "{}: the graph has no outputs; give --output NODE.PORT=FILE",
                a.graph.display()
            )));
        }
    }
    let vars = variants(&registry, &g, a.common.wedge.as_deref())?;
    for v in &vars {
        let opts = EvalOptions {
            time: a.time,
            size: a.common.size.unwrap_or((512, 512)),
            output_suffix: v.suffix.clone(),
            frame: None,
            gpu_timings: a.common.stats,
            inject: BTreeMap::new(),
            progress: Some(node_progress()),
        };
        let result = ev.evaluate(&v.graph, &targets, &opts)?;
        for (key, file) in &files {
            if let Some(val) = result.outputs.get(key) {
                write_value(&gpu, val, &with_suffix(file, &v.suffix))?;
            }
        }
        if a.common.stats {
            print_stats(&result, &v.label);
        }
    }
    Ok(())
}

fn run_bench(registry: Arc<Registry>, a: BenchArgs) -> Result<(), CliError> {
    use crate::bench::{self, plot, report};
    let all = a.suite.is_none();
    let root = Path::new("benches");
    if a.suite.is_none() && !root.is_dir() {
        return Err(bad(
            "no benches/ folder in the working directory: run `tyndall bench` from the \
             repository root",
        ));
    }
    let list: Vec<(String, PathBuf)> = match &a.suite {
        None => report::all_suites(root).map_err(bad)?,
        Some(name) => bench::suite_files(name)
            .map_err(bad)?
            .into_iter()
            .map(|p| {
                let name = p
                    .strip_prefix(root)
                    .unwrap_or(&p)
                    .with_extension("")
                    .to_string_lossy()
                    .into_owned();
                (name, p)
            })
            .collect(),
    };
    if list.is_empty() {
        return Err(bad("no bench suites found under benches/"));
    }
    let out_dir = a
        .out
        .clone()
        .unwrap_or_else(|| PathBuf::from(if a.quick { "bench/quick" } else { "bench" }));
    let docs = match (&a.docs, a.no_docs) {
        (Some(d), _) => Some(d.clone()),
        (None, false) if all && !a.quick => Some(PathBuf::from("BENCHMARKS.md")),
        _ => None,
    };
    let command = std::iter::once("tyndall".to_string())
        .chain(std::env::args().skip(1))
        .collect::<Vec<_>>()
        .join(" ");
    let gpu = gpu()?;
    let adapter = gpu.describe();
    let started = std::time::Instant::now();
    let mut results: Vec<(String, String, Vec<bench::Row>)> = Vec::new();
    let mut failed: Vec<String> = Vec::new();
    for (i, (name, path)) in list.iter().enumerate() {
        eprintln!(
            "bench [{}/{}] {name} ({:.0} s so far)",
            i + 1,
            list.len(),
            started.elapsed().as_secs_f64()
        );
        let mut spec = bench::load_suite(path).map_err(bad)?;
        if !a.full {
            spec = spec.without_slow();
        }
        if a.quick {
            spec = spec.reduced();
        }
        let size = a.size.unwrap_or(spec.size);
        let runs = a.runs.unwrap_or(spec.runs);
        let rows = match bench::run(
            registry.clone(),
            gpu.clone(),
            path,
            &spec,
            runs,
            size,
            |l| eprintln!("bench {name}: {l}"),
        ) {
            Ok(rows) => rows,
            Err(e) if all => {
                eprintln!("bench {name}: failed: {e}");
                failed.push(name.clone());
                continue;
            }
            Err(bench::BenchError::Eval(e)) => return Err(CliError::Eval(e)),
            Err(e) => return Err(bad(e)),
        };
        let text = report::suite_text(&spec, &adapter, (size, runs), &command, &rows);
        if i > 0 {
            println!();
        }
        print!("{text}");
        if !all {
            // One suite: the CSV file given or out/bench/NAME.csv; a folder of suites: one CSV
            // per suite in the folder given or out/bench/SUITE/.
            let stem = path
                .file_stem()
                .map(|s| s.to_string_lossy().into_owned())
                .unwrap_or_else(|| "bench".into());
            let csv_path = match (&a.csv, list.len() > 1) {
                (Some(c), false) => c.clone(),
                (Some(c), true) => c.join(format!("{stem}.csv")),
                (None, false) => PathBuf::from(format!("out/bench/{stem}.csv")),
                (None, true) => PathBuf::from(format!(
                    "out/bench/{}/{stem}.csv",
                    a.suite.as_deref().unwrap_or("bench")
                )),
            };
            // The same columns as bench/results.csv.
            let one = [(name.clone(), adapter.clone(), rows.clone())];
            write_file(&csv_path, &report::results_csv(&one).map_err(bad)?)?;
            println!("csv: {}", csv_path.display());
        }
        let mut links = Vec::new();
        if all || docs.is_some() {
            let stem = name.replace('/', "-");
            for p in
                plot::plots(&out_dir.join("plots"), &stem, &spec, &adapter, &rows).map_err(bad)?
            {
                println!("plot: {}", p.display());
                let alt = p
                    .file_stem()
                    .map(|s| s.to_string_lossy().into_owned())
                    .unwrap_or_default();
                links.push((alt, p.to_string_lossy().into_owned()));
            }
        }
        if let Some(doc) = &docs {
            let old = std::fs::read_to_string(doc).unwrap_or_else(|_| "# Benchmarks\n".into());
            let body = report::doc_body(&command, &text, &links);
            write_file(
                doc,
                report::update_doc(&old, name, &spec.title, &body).as_bytes(),
            )?;
        }
        results.push((name.clone(), adapter.clone(), rows));
        if all || docs.is_some() {
            // Rewritten after every suite: a run stopped half-way keeps what it measured. The
            // rows of suites not run this time are kept.
            let path = out_dir.join("results.csv");
            let csv = report::results_csv(&results).map_err(bad)?;
            let old = std::fs::read(&path).unwrap_or_default();
            write_file(&path, &report::merge_results(&old, &csv).map_err(bad)?)?;
        }
    }
    let mut summary = format!(
        "{} of {} suites measured in {:.0} s",
        results.len(),
        list.len(),
        started.elapsed().as_secs_f64()
    );
    if all || docs.is_some() {
        summary.push_str(&format!(
            "; results: {}; plots: {}",
            out_dir.join("results.csv").display(),
            out_dir.join("plots").display()
        ));
    }
    if let Some(doc) = &docs {
        summary.push_str(&format!("; tables: {}", doc.display()));
    }
    println!("\n{summary}");
    if failed.is_empty() {
        Ok(())
    } else {
        Err(CliError::Suites(failed))
    }
}

/// `tyndall bench --replot`: the plots of every suite recorded in `out/results.csv` (or of one
/// suite), drawn again without measuring.
fn replot(out: &Path, only: Option<&str>) -> Result<(), CliError> {
    use crate::bench::{load_suite, plot, report};
    let csv = out.join("results.csv");
    let text = std::fs::read(&csv).map_err(|e| bad(format!("{}: {e}", csv.display())))?;
    for (name, adapter, rows) in report::rows_from_csv(&text).map_err(bad)? {
        if only.is_some_and(|o| o != name) {
            continue;
        }
        let spec = load_suite(&Path::new("benches").join(format!("{name}.ron"))).map_err(bad)?;
        let stem = name.replace('/', "-");
        for p in plot::plots(&out.join("plots"), &stem, &spec, &adapter, &rows).map_err(bad)? {
            println!("plot: {}", p.display());
        }
    }
    Ok(())
}

/// Write a file atomically, creating its folder.
fn write_file(path: &Path, bytes: &[u8]) -> Result<(), CliError> {
    if let Some(dir) = path.parent().filter(|d| !d.as_os_str().is_empty()) {
        std::fs::create_dir_all(dir).map_err(|e| bad(format!("{}: {e}", dir.display())))?;
    }
    crate::graph::write_atomic(path, bytes).map_err(bad)
}

fn run_render(registry: Arc<Registry>, a: RenderArgs) -> Result<(), CliError> {
    let mut g = load_graph(&registry, &a.graph, &a.common)?;
    let gpu = gpu()?;
    let mut ev = Evaluator::new(registry.clone(), gpu);
    let targets = ev.sinks(&g);
    if targets.is_empty() {
        return Err(bad(format!(
            "{}: the graph has no output nodes to render",
            a.graph.display()
        )));
    }
    if let Some(o) = &a.output {
        let [Target::Node(sink)] = targets.as_slice() else {
            return Err(bad(format!(
                "-o needs a graph with exactly one output node; this one has {}",
                targets.len()
            )));
        };
        g.set_param(
            registry.catalog(),
            sink,
            "path",
            ParamValue::Text(o.to_string_lossy().into_owned()),
        )
        .map_err(bad)?;
    }
    let all: Vec<Option<i64>> = match &a.frames {
        Some(list) => list.0.iter().copied().map(Some).collect(),
        None if a.chunk.is_some() => return Err(bad("--chunk needs --frames")),
        None => vec![None],
    };
    let frames: Vec<Option<i64>> = match a.chunk {
        Some(c) => {
            let list: Vec<i64> = all.iter().flatten().copied().collect();
            chunk_of(&list, c).iter().copied().map(Some).collect()
        }
        None => all,
    };
    let vars = variants(&registry, &g, a.common.wedge.as_deref())?;
    let total = frames.len() * vars.len();
    use std::io::IsTerminal;
    let mode = match a.progress {
        ProgressMode::Auto if std::io::stderr().is_terminal() => ProgressMode::Bar,
        ProgressMode::Auto => ProgressMode::Alf,
        m => m,
    };
    let bar = if mode == ProgressMode::Bar {
        progress(total as u64)
    } else {
        indicatif::ProgressBar::hidden()
    };
    let clock = std::time::Instant::now();
    let (mut written, mut skipped, mut failed) = (Vec::new(), 0usize, Vec::new());
    let mut done = 0usize;
    for f in &frames {
        for v in &vars {
            // The files this frame writes: every sink's `path`, named for the frame.
            let files: Vec<PathBuf> = targets
                .iter()
                .filter_map(|t| match t {
                    Target::Node(id) => v.graph.node(id),
                    Target::Port(..) => None,
                })
                .filter_map(|n| {
                    // The node's own path, else its kind's default.
                    let default = registry.get(&n.kind).and_then(|k| {
                        k.decl()
                            .schema
                            .params
                            .iter()
                            .find(|p| p.name == "path")
                            .map(|p| p.default.value())
                    });
                    match n.params.get("path").cloned().or(default) {
                        Some(ParamValue::Text(p)) if !p.is_empty() => Some(p),
                        _ => None,
                    }
                })
                .map(|p| crate::eval::output_path(&p, &v.suffix, *f))
                .collect();
            let status =
                if a.skip_existing && !files.is_empty() && files.iter().all(|p| p.is_file()) {
                    skipped += 1;
                    "skipped"
                } else {
                    let opts = EvalOptions {
                        time: f.map_or(0.0, |f| f as f64),
                        size: a.common.size.unwrap_or((960, 540)),
                        output_suffix: v.suffix.clone(),
                        frame: *f,
                        gpu_timings: a.common.stats,
                        inject: BTreeMap::new(),
                        progress: Some(node_progress()),
                    };
                    match ev.evaluate(&v.graph, &targets, &opts) {
                        Ok(result) => {
                            if a.common.stats {
                                let label = match f {
                                    Some(f) => format!("frame {f} {}", v.label),
                                    None => v.label.clone(),
                                };
                                print_stats(&result, label.trim());
                            }
                            written.extend(files.iter().cloned());
                            "written"
                        }
                        Err(e) if e.device_lost() => {
                            // Nothing more can run on a lost device: stop, exit 1.
                            bar.finish_and_clear();
                            eprintln!("error: frame {}: {e}", frame_label(*f));
                            return Err(e.into());
                        }
                        Err(e) if frames.len() * vars.len() > 1 => {
                            // One bad frame does not stop the others; the exit code says so.
                            bar.suspend(|| eprintln!("error: frame {}: {e}", frame_label(*f)));
                            failed.push(frame_label(*f));
                            "failed"
                        }
                        Err(e) => return Err(e.into()),
                    }
                };
            done += 1;
            bar.inc(1);
            report(mode, *f, status, &files, (done, total));
        }
    }
    bar.finish_and_clear();
    let plural = |n: usize, what: &str| format!("{n} {what}{}", if n == 1 { "" } else { "s" });
    let renders = match vars.len() {
        1 => plural(frames.len(), "frame"),
        n => format!(
            "{} × {}",
            plural(frames.len(), "frame"),
            plural(n, "wedge value")
        ),
    };
    println!(
        "{} written for {renders}, {skipped} skipped (already there), {} failed, {:.1} s",
        plural(written.len(), "file"),
        failed.len(),
        clock.elapsed().as_secs_f64()
    );
    if !failed.is_empty() {
        return Err(CliError::Frames(failed));
    }
    Ok(())
}

fn frame_label(f: Option<i64>) -> String {
    f.map_or_else(|| "-".into(), |f| f.to_string())
}

/// One progress report after a frame (`mode` is never `Auto` here).
fn report(
    mode: ProgressMode,
    frame: Option<i64>,
    status: &str,
    files: &[PathBuf],
    (done, total): (usize, usize),
) {
    match mode {
        ProgressMode::Alf => println!("ALF_PROGRESS {}%", done * 100 / total.max(1)),
        ProgressMode::Json => {
            let files: Vec<String> = files.iter().map(|p| p.display().to_string()).collect();
            let line = serde_json::json!({
                "frame": frame,
                "status": status,
                "files": files,
                "done": done,
                "total": total,
            });
            println!("{line}");
        }
        _ => {}
    }
}

/// A progress bar on a terminal; hidden otherwise (long work prints plain lines via `--stats`).
fn progress(total: u64) -> indicatif::ProgressBar {
    use std::io::IsTerminal;
    if total <= 1 || !std::io::stderr().is_terminal() {
        return indicatif::ProgressBar::hidden();
    }
    let bar = indicatif::ProgressBar::new(total);
    if let Ok(style) = indicatif::ProgressStyle::with_template("{bar:40} {pos}/{len} {elapsed}") {
        bar.set_style(style);
    }
    bar
}

/// Progress of long-running nodes (a light-map solve): a bar on a terminal, else a plain line
/// at every tenth of the work.
fn node_progress() -> crate::eval::ProgressSink {
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

fn default_text(p: &crate::graph::ParamSpec) -> String {
    match p.default.value() {
        ParamValue::Text(s) => format!("\"{s}\""),
        v => v.to_string(),
    }
}

fn range_text(p: &crate::graph::ParamSpec) -> String {
    match p.kind {
        ParamKind::Float | ParamKind::Int | ParamKind::Colour | ParamKind::Vec3 => {
            format!("[{}, {}]", num(p.min), num(p.max))
        }
        ParamKind::Enum(names) => names.join(" | "),
        ParamKind::Bool => "true | false".into(),
        ParamKind::Text => "text".into(),
    }
}

/// The catalog as plain text, Markdown or JSON.
pub fn catalog_text(registry: &Registry, markdown: bool, json: bool) -> String {
    use std::fmt::Write;
    let schemas: Vec<&NodeSchema> = registry.catalog().iter().collect();
    if json {
        let v: Vec<serde_json::Value> = schemas
            .iter()
            .map(|s| {
                let ports = |dir: &str, ps: &[crate::graph::PortSpec]| -> Vec<serde_json::Value> {
                    ps.iter()
                        .map(|p| {
                            serde_json::json!({
                                "name": p.name, "direction": dir,
                                "types": p.types.iter().map(|t| t.name()).collect::<Vec<_>>(),
                                "required": p.required, "doc": p.doc,
                            })
                        })
                        .collect()
                };
                let mut all = ports("input", s.inputs);
                all.extend(ports("output", s.outputs));
                serde_json::json!({
                    "kind": s.kind, "category": s.category, "doc": s.doc,
                    "ports": all,
                    "params": s.params.iter().map(|p| {
                        let numeric = matches!(p.kind, ParamKind::Float | ParamKind::Int | ParamKind::Colour | ParamKind::Vec3);
                        serde_json::json!({
                            "name": p.name, "type": p.kind.name(),
                            "default": match p.default.value() {
                                ParamValue::Float(v) => serde_json::json!(v),
                                ParamValue::Int(v) => serde_json::json!(v),
                                ParamValue::Bool(v) => serde_json::json!(v),
                                ParamValue::Enum(v) | ParamValue::Text(v) => serde_json::json!(v),
                                ParamValue::Colour(c) => serde_json::json!(c),
                                ParamValue::Vec3(c) => serde_json::json!(c),
                            },
                            "min": if numeric { serde_json::json!(p.min) } else { serde_json::Value::Null },
                            "max": if numeric { serde_json::json!(p.max) } else { serde_json::Value::Null },
                            "values": match p.kind { ParamKind::Enum(n) => serde_json::json!(n), _ => serde_json::Value::Null },
                            "unit": p.unit, "doc": p.doc,
                        })
                    }).collect::<Vec<_>>(),
                })
            })
            .collect();
        return serde_json::to_string_pretty(&v).unwrap_or_default() + "\n";
    }
    let mut out = String::new();
    if markdown {
        out.push_str("# Tyndall node catalog\n\nGenerated by `tyndall nodes --markdown`; do not edit by hand.\n\n");
    }
    for s in schemas {
        if markdown {
            let _ = writeln!(out, "## {}\n\n*{}* — {}\n", s.kind, s.category, s.doc);
            let _ = writeln!(out, "| port | direction | type | doc |\n|---|---|---|---|");
            for (dir, ps) in [("in", s.inputs), ("out", s.outputs)] {
                for p in ps {
                    let types: Vec<&str> = p.types.iter().map(|t| t.name()).collect();
                    let _ = writeln!(
                        out,
                        "| `{}` | {dir} | {} | {} |",
                        p.name,
                        types.join(" \\| "),
                        p.doc
                    );
                }
            }
            let _ = writeln!(
                out,
                "\n| parameter | type | default | range | unit | doc |\n|---|---|---|---|---|---|"
            );
            for p in s.params {
                let _ = writeln!(
                    out,
                    "| `{}` | {} | {} | {} | {} | {} |",
                    p.name,
                    p.kind.name(),
                    default_text(p),
                    range_text(p).replace('|', "\\|"),
                    p.unit,
                    p.doc
                );
            }
            out.push('\n');
        } else {
            let _ = writeln!(out, "{} ({}): {}", s.kind, s.category, s.doc);
            for (dir, ps) in [("in ", s.inputs), ("out", s.outputs)] {
                for p in ps {
                    let types: Vec<&str> = p.types.iter().map(|t| t.name()).collect();
                    let _ = writeln!(
                        out,
                        "  {dir} {:<10} {:<16} {}",
                        p.name,
                        types.join("|"),
                        p.doc
                    );
                }
            }
            for p in s.params {
                let _ = writeln!(
                    out,
                    "  param {:<10} {:<7} default {} range {} {} — {}",
                    p.name,
                    p.kind.name(),
                    default_text(p),
                    range_text(p),
                    p.unit,
                    p.doc
                );
            }
            out.push('\n');
        }
    }
    out
}
