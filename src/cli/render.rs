//! `tyndall render`: frames of a graph's sinks, with progress, skipping and chunks for farms.

use super::*;
use crate::eval::FileRole;

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

pub(super) fn parse_chunk(s: &str) -> Result<(usize, usize), String> {
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

pub(super) fn run_render(registry: Arc<Registry>, a: RenderArgs) -> Result<(), CliError> {
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
        write_to(&registry, &mut g, &targets, o)?;
    }
    let frames = frame_list(&a)?;
    let vars = variants(&registry, &g, &a.common)?;
    let total = frames.len() * vars.len();
    let mode = progress_mode(a.progress);
    let bar = if mode == ProgressMode::Bar {
        progress(total as u64)
    } else {
        indicatif::ProgressBar::hidden()
    };
    let clock = std::time::Instant::now();
    // Files are encoded and written on background threads while the next frame evaluates.
    let writes = DeferredWrites::start();
    let (mut written, mut skipped, mut failed) = (Vec::new(), 0usize, Vec::new());
    let mut done = 0usize;
    for f in &frames {
        let epoch = ev.epoch();
        for v in &vars {
            let files = written_files(&registry, &v.graph, &targets, &v.suffix, *f);
            let status =
                if a.skip_existing && !files.is_empty() && files.iter().all(|p| p.is_file()) {
                    skipped += 1;
                    "skipped"
                } else {
                    let opts = EvalOptions {
                        time: f.map_or(0.0, |f| f as f64),
                        size: a.common.size_or((960, 540)),
                        output_suffix: v.suffix.clone(),
                        frame: *f,
                        gpu_timings: a.common.stats,
                        // The GPU works while later nodes are recorded; --stats reads its
                        // per-node time from timestamps, not from waits.
                        pipelined: true,
                        inject: BTreeMap::new(),
                        progress: Some(node_progress()),
                        ..Default::default()
                    };
                    match ev.evaluate(&v.graph, &targets, &opts) {
                        Ok(result) => {
                            print_notes(&result);
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
        // The next frame needs only what this one used (earlier frames of nodes with a
        // history included): keep about a frame's window, not the whole budget.
        ev.keep_used_since(epoch);
    }
    for e in writes.finish() {
        bar.suspend(|| eprintln!("error: {e}"));
        if let tyndall_engine::io::IoError::Write { path, .. }
        | tyndall_engine::io::IoError::Format { path, .. } = &e
        {
            written.retain(|w: &PathBuf| w != path);
            failed.push(path.display().to_string());
        }
    }
    bar.finish_and_clear();
    print_summary(
        (frames.len(), vars.len()),
        (written.len(), skipped, failed.len()),
        clock.elapsed().as_secs_f64(),
    );
    if !failed.is_empty() {
        return Err(CliError::Frames(failed));
    }
    Ok(())
}

/// Deferred image writes for the length of a render: started on creation; [`finish`]
/// waits for them and returns the failures; dropped early (an error ended the render), it waits
/// too, so no file is left half-written when the process exits.
///
/// [`finish`]: DeferredWrites::finish
struct DeferredWrites;

impl DeferredWrites {
    fn start() -> Self {
        tyndall_engine::io::deferred::defer(true);
        Self
    }

    fn finish(self) -> Vec<tyndall_engine::io::IoError> {
        tyndall_engine::io::deferred::defer(false);
        tyndall_engine::io::deferred::wait()
    }
}

impl Drop for DeferredWrites {
    fn drop(&mut self) {
        tyndall_engine::io::deferred::defer(false);
        for e in tyndall_engine::io::deferred::wait() {
            eprintln!("error: {e}");
        }
    }
}

/// `auto` progress: a bar on a terminal, ALF lines otherwise.
fn progress_mode(asked: ProgressMode) -> ProgressMode {
    use std::io::IsTerminal;
    match asked {
        ProgressMode::Auto if std::io::stderr().is_terminal() => ProgressMode::Bar,
        ProgressMode::Auto => ProgressMode::Alf,
        m => m,
    }
}

/// The run's last line: files written, for how many frames (× wedge values), skipped, failed.
fn print_summary(
    (frames, wedges): (usize, usize),
    (written, skipped, failed): (usize, usize, usize),
    secs: f64,
) {
    let plural = |n: usize, what: &str| format!("{n} {what}{}", if n == 1 { "" } else { "s" });
    let renders = match wedges {
        1 => plural(frames, "frame"),
        n => format!("{} × {}", plural(frames, "frame"), plural(n, "wedge value")),
    };
    println!(
        "{} written for {renders}, {skipped} skipped (already there), {failed} failed, {secs:.1} s",
        plural(written, "file"),
    );
}

/// `-o FILE`: the graph's one output node writes `o` (the first file its kind declares it
/// writes).
fn write_to(
    registry: &Registry,
    g: &mut Graph,
    targets: &[Target],
    o: &std::path::Path,
) -> Result<(), CliError> {
    let [Target::Node(sink)] = targets else {
        return Err(bad(format!(
            "-o needs a graph with exactly one output node; this one has {}",
            targets.len()
        )));
    };
    // The first file the sink's kind declares it writes.
    let param = g
        .node(sink)
        .and_then(|n| registry.get(&n.kind))
        .and_then(|k| k.file_params(FileRole::Write).next())
        .ok_or_else(|| bad(format!("-o: output node '{sink}' writes no file")))?;
    g.set_param(
        registry.catalog(),
        sink,
        param,
        ParamValue::Text(o.to_string_lossy().into_owned()),
    )
    .map_err(bad)?;
    Ok(())
}

/// The frames this run renders: `--frames` (or the one still frame), `--chunk` of them.
fn frame_list(a: &RenderArgs) -> Result<Vec<Option<i64>>, CliError> {
    let all: Vec<Option<i64>> = match &a.frames {
        Some(list) => list.0.iter().copied().map(Some).collect(),
        None if a.chunk.is_some() => return Err(bad("--chunk needs --frames")),
        None => vec![None],
    };
    Ok(match a.chunk {
        Some(c) => {
            let list: Vec<i64> = all.iter().flatten().copied().collect();
            chunk_of(&list, c).iter().copied().map(Some).collect()
        }
        None => all,
    })
}

pub(super) fn frame_label(f: Option<i64>) -> String {
    f.map_or_else(|| "-".into(), |f| f.to_string())
}

/// One progress report after a frame (`mode` is never `Auto` here).
pub(super) fn report(
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
pub(super) fn progress(total: u64) -> indicatif::ProgressBar {
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

/// The files a frame writes: every file parameter the sinks' kinds declare they write
/// ([`crate::eval::NodeDecl::files`]), the node's value or else the kind's default, named for
/// the frame.
fn written_files(
    registry: &Registry,
    g: &Graph,
    targets: &[Target],
    suffix: &str,
    frame: Option<i64>,
) -> Vec<PathBuf> {
    let mut out = Vec::new();
    for t in targets {
        let Target::Node(id) = t else { continue };
        let Some(n) = g.node(id) else { continue };
        let Some(k) = registry.get(&n.kind) else {
            continue;
        };
        for name in k.file_params(FileRole::Write) {
            let default = k.schema().param(name).map(|p| p.default.value());
            if let Some(ParamValue::Text(p)) = n.params.get(name).cloned().or(default) {
                if !p.is_empty() {
                    out.push(crate::eval::output_path(&p, suffix, frame));
                }
            }
        }
    }
    out
}
