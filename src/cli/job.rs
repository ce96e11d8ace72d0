//! `tyndall job`: an Open Job Description (2023-09) job template that renders a graph's frames
//! in chunks on a farm — Deadline Cloud, OpenCue's OpenJD path, or `openjd run` on one machine.
//!
//! The template has four job parameters, each defaulting to what `tyndall job` was given (the
//! paths relative to the template's folder, as OpenJD requires of PATH defaults; so
//! `openjd run job.yaml --step Render` renders the job as written): `Graph` (the graph file),
//! `Frames` (a frame spec, as `tyndall render --frames` reads it), `OutputDir` (where the files
//! go) and `Tyndall` (the command; default: this binary's absolute path). One step, `Render`,
//! has a task per chunk: task parameter `Chunk` = 1…N, and each task runs `tyndall render GRAPH
//! --frames FRAMES --chunk K/N --output-dir DIR --skip-existing`, so the N tasks render every
//! frame exactly once whatever `Frames` is set to at submission, and a task rerun after it was
//! killed renders only the frames it had not finished.

use super::*;

/// `tyndall job`.
#[derive(Args, Debug)]
pub struct JobArgs {
    /// The graph file.
    pub graph: PathBuf,
    /// Frames of the job: `A-B`, `A-BxS`, lists (`1,5,7-9`), as `tyndall render --frames`.
    #[arg(long)]
    pub frames: String,
    /// Frames per task (the last task may have fewer): the job has ⌈frames / N⌉ tasks.
    #[arg(long, value_name = "N", default_value_t = 10)]
    pub chunk: usize,
    /// Folder the tasks write into (the `OutputDir` parameter's default).
    #[arg(long, value_name = "DIR")]
    pub output_dir: PathBuf,
    /// The job template to write (YAML).
    #[arg(short = 'o', long = "output", value_name = "FILE")]
    pub output: PathBuf,
    /// The command each task runs; default: this binary's absolute path. A farm whose workers
    /// have `tyndall` on their PATH may name just `tyndall`.
    #[arg(long, value_name = "COMMAND")]
    pub tyndall: Option<String>,
    /// A parameter override every task passes to `tyndall render` (repeatable).
    #[arg(long = "set", value_name = "NODE.PARAM=VALUE")]
    pub set: Vec<String>,
    /// Image size every task renders at, WIDTHxHEIGHT.
    #[arg(long, value_parser = parse_size)]
    pub size: Option<(u32, u32)>,
}

/// A YAML scalar: the string JSON-quoted (a JSON string is a YAML double-quoted scalar).
fn q(s: &str) -> String {
    serde_json::Value::String(s.to_string()).to_string()
}

/// An absolute form of `p` without requiring it to exist.
fn absolute(p: &Path) -> Result<PathBuf, CliError> {
    std::path::absolute(p).map_err(|e| bad(format!("{}: {e}", p.display())))
}

/// `target` relative to the folder `base` (both absolute), with `..` where it climbs out: what
/// OpenJD wants of a PATH parameter's default (joined to the template's folder).
fn relative_to(target: &Path, base: &Path) -> PathBuf {
    let (t, b): (Vec<_>, Vec<_>) = (target.components().collect(), base.components().collect());
    let common = t.iter().zip(&b).take_while(|(x, y)| x == y).count();
    let mut out = PathBuf::new();
    for _ in common..b.len() {
        out.push("..");
    }
    for c in &t[common..] {
        out.push(c);
    }
    if out.as_os_str().is_empty() {
        out.push(".");
    }
    out
}

/// A job parameter for the path `target` (absolute): a PATH whose default is relative to the
/// template's folder `job_dir` when it lies inside it (OpenJD refuses absolute PATH defaults and
/// ones that climb out), else a STRING with the absolute path.
fn path_param(
    name: &str,
    object: &str,
    flow: &str,
    what: &str,
    target: &Path,
    job_dir: &Path,
) -> String {
    let rel = relative_to(target, job_dir);
    if rel.components().next() == Some(std::path::Component::ParentDir) {
        return format!(
            "  - name: {name}\n    type: STRING\n    description: {}\n    default: {}\n",
            q(&format!("{what} (an absolute path).")),
            q(&target.display().to_string())
        );
    }
    format!(
        "  - name: {name}\n    type: PATH\n    objectType: {object}\n    dataFlow: {flow}\n    description: {}\n    default: {}\n",
        q(&format!("{what} (default relative to this file's folder).")),
        q(&rel.display().to_string())
    )
}

/// What each task passes to `tyndall render` (OpenJD format strings for the job and task
/// parameters): the graph, the frames, chunk K of `tasks`, the output folder, resuming, ALF
/// progress (what farm monitors parse), and `tyndall job`'s `--set` and `--size`.
fn task_args(a: &JobArgs, tasks: usize) -> Vec<String> {
    let mut args: Vec<String> = [
        "render",
        "{{Param.Graph}}",
        "--frames",
        "{{Param.Frames}}",
        "--chunk",
    ]
    .map(String::from)
    .to_vec();
    args.push(format!("{{{{Task.Param.Chunk}}}}/{tasks}"));
    args.extend(
        [
            "--output-dir",
            "{{Param.OutputDir}}",
            "--skip-existing",
            "--progress",
            "alf",
        ]
        .map(String::from),
    );
    for s in &a.set {
        args.extend(["--set".to_string(), s.clone()]);
    }
    if let Some((w, h)) = a.size {
        args.extend(["--size".to_string(), format!("{w}x{h}")]);
    }
    args
}

/// Write the job template `tyndall job` describes.
pub fn run_job(registry: &crate::eval::Registry, a: JobArgs) -> Result<(), CliError> {
    let frames = parse_frame_spec(&a.frames).map_err(|e| bad(format!("--frames: {e}")))?;
    if a.chunk == 0 {
        return Err(bad("--chunk: a task renders at least one frame"));
    }
    let graph = a
        .graph
        .canonicalize()
        .map_err(|e| bad(format!("{}: {e}", a.graph.display())))?;
    crate::graph::load_file(&graph, registry.catalog())
        .map_err(|e| bad(format!("{}: {e}", graph.display())))?;
    for s in &a.set {
        split_eq(s, "NODE.PARAM=VALUE")?;
    }
    let tasks = frames.0.len().div_ceil(a.chunk);
    let tyndall = match a.tyndall.clone() {
        Some(t) => t,
        None => std::env::current_exe()
            .map_err(|e| bad(format!("this binary's path: {e}")))?
            .display()
            .to_string(),
    };
    // PATH defaults are relative to the template's folder (OpenJD refuses absolute ones).
    let job_dir = absolute(&a.output)?
        .parent()
        .map(Path::to_path_buf)
        .unwrap_or_default();
    let graph_param = path_param(
        "Graph",
        "FILE",
        "IN",
        "The Tyndall graph (.ron) to render",
        &graph,
        &job_dir,
    );
    let out_param = path_param(
        "OutputDir",
        "DIRECTORY",
        "OUT",
        "The folder the graph's outputs are written under",
        &absolute(&a.output_dir)?,
        &job_dir,
    );
    for (name, p) in [("Graph", &graph_param), ("OutputDir", &out_param)] {
        if p.contains("type: STRING") {
            eprintln!(
                "note: {name} lies outside the job file's folder, where OpenJD allows no PATH default: \
                 it is a STRING parameter with an absolute default (a farm maps no path in it); \
                 write the job file into a folder above both to get PATH parameters"
            );
        }
    }
    let args = task_args(&a, tasks);
    let stem = graph
        .file_stem()
        .map_or("graph".into(), |s| s.to_string_lossy().into_owned());
    let params = [graph_param, out_param];
    let text = template(&stem, &params, &a.frames, &tyndall, tasks, &args);
    write_atomically(&a.output, &text)?;
    eprintln!(
        "{}: {} frames in {tasks} tasks of up to {} (step Render); `openjd run {} --step Render` renders it here",
        a.output.display(),
        frames.0.len(),
        a.chunk,
        a.output.display()
    );
    Ok(())
}

/// Write `text` to `path` through a temporary file in the same folder (no half-written job).
fn write_atomically(path: &Path, text: &str) -> Result<(), CliError> {
    let err = |e: std::io::Error| bad(format!("{}: {e}", path.display()));
    if let Some(dir) = path.parent().filter(|d| !d.as_os_str().is_empty()) {
        std::fs::create_dir_all(dir).map_err(err)?;
    }
    let tmp = path.with_extension("yaml.part");
    std::fs::write(&tmp, text).map_err(err)?;
    std::fs::rename(&tmp, path).map_err(err)
}

/// The job template's text (`params`: the Graph and OutputDir definitions).
fn template(
    stem: &str,
    params: &[String; 2],
    frames: &str,
    tyndall: &str,
    tasks: usize,
    args: &[String],
) -> String {
    let args: Vec<String> = args.iter().map(|a| q(a)).collect();
    format!(
        r#"# Written by `tyndall job`: an Open Job Description job template (specification 2023-09).
# Run it here with `openjd run THIS_FILE --step Render` (PyPI: openjd-cli), or submit it to a
# farm that speaks OpenJD (AWS Deadline Cloud, OpenCue). Every parameter defaults to what
# `tyndall job` was given; the {tasks} tasks split the frames into contiguous runs, so they render
# every frame once whatever Frames is set to, and rerunning a task skips the frames it wrote.
specificationVersion: jobtemplate-2023-09
name: {name}
parameterDefinitions:
{graph}  - name: Frames
    type: STRING
    description: {frames_doc}
    default: {frames}
{out_dir}  - name: Tyndall
    type: STRING
    description: The tyndall command the tasks run.
    default: {tyndall}
steps:
  - name: Render
    parameterSpace:
      taskParameterDefinitions:
        - name: Chunk
          type: INT
          range: "1-{tasks}"
    script:
      actions:
        onRun:
          command: "{{{{Param.Tyndall}}}}"
          args: [{args}]
"#,
        name = q(&format!("Tyndall {stem}")),
        graph = params[0],
        frames_doc =
            q("Frames to render, as `tyndall render --frames` reads them (A-B, A-BxS, lists)."),
        frames = q(frames),
        out_dir = params[1],
        tyndall = q(tyndall),
        args = args.join(", "),
    )
}
