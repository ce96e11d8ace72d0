//! `tyndall bench`: run the suites of `benches/`, print their tables, write CSV, plots and
//! BENCHMARKS.md (the recording lives in [`crate::bench::record`]).

use super::*;
use crate::bench::record::Recorder;

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

pub(super) fn run_bench(registry: Arc<Registry>, a: BenchArgs) -> Result<(), CliError> {
    use crate::bench::{self, report};
    let all = a.suite.is_none();
    let list = suites(&a)?;
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
    let mut record = Recorder::new(out_dir, docs, all, command);
    let mut failed: Vec<String> = Vec::new();
    // Each suite's own wall-clock time, for the summary (the default run has a budget).
    let mut times: Vec<(String, f64)> = Vec::new();
    for (i, (name, path)) in list.iter().enumerate() {
        let suite_started = std::time::Instant::now();
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
        let progress = |l: &str| eprintln!("bench {name}: {l}");
        let result = bench::run(
            registry.clone(),
            gpu.clone(),
            path,
            &spec,
            runs,
            size,
            progress,
        );
        times.push((name.clone(), suite_started.elapsed().as_secs_f64()));
        let rows = match result {
            Ok(rows) => rows,
            Err(e) if all => {
                eprintln!("bench {name}: failed: {e}");
                failed.push(name.clone());
                continue;
            }
            Err(bench::BenchError::Eval(e)) => return Err(CliError::Eval(e)),
            Err(e) => return Err(bad(e)),
        };
        let text = report::suite_text(&spec, &adapter, (size, runs), &record.command, &rows);
        if i > 0 {
            println!();
        }
        print!("{text}");
        if !all {
            let csv_path = csv_path(&a, path, list.len() > 1);
            // The same columns as bench/results.csv.
            let one = [(name.clone(), adapter.clone(), rows.clone())];
            write_file(&csv_path, &report::results_csv(&one).map_err(bad)?)?;
            println!("csv: {}", csv_path.display());
        }
        for p in record
            .suite(name, &spec, &adapter, &text, rows)
            .map_err(bad)?
        {
            println!("plot: {}", p.display());
        }
    }
    println!(
        "\n{} of {} suites measured in {:.0} s{}",
        record.count(),
        list.len(),
        started.elapsed().as_secs_f64(),
        record.summary()
    );
    if times.len() > 1 {
        let each: Vec<String> = times.iter().map(|(n, t)| format!("{n} {t:.0} s")).collect();
        println!("suite times: {}", each.join(", "));
    }
    if failed.is_empty() {
        Ok(())
    } else {
        Err(CliError::Suites(failed))
    }
}

/// One suite: the CSV file given or out/bench/NAME.csv; a folder of suites: one CSV per suite
/// in the folder given or out/bench/SUITE/.
fn csv_path(a: &BenchArgs, path: &Path, many: bool) -> PathBuf {
    let stem = path
        .file_stem()
        .map(|s| s.to_string_lossy().into_owned())
        .unwrap_or_else(|| "bench".into());
    match (&a.csv, many) {
        (Some(c), false) => c.clone(),
        (Some(c), true) => c.join(format!("{stem}.csv")),
        (None, false) => PathBuf::from(format!("out/bench/{stem}.csv")),
        (None, true) => PathBuf::from(format!(
            "out/bench/{}/{stem}.csv",
            a.suite.as_deref().unwrap_or("bench")
        )),
    }
}

/// `tyndall bench --replot`: the plots of every suite recorded in `out/results.csv` (or of one
/// suite), drawn again without measuring. A suite measured on several adapters is drawn for the
/// adapter of this machine when it is one of them, else for the first in the file.
pub(super) fn replot(out: &Path, only: Option<&str>) -> Result<(), CliError> {
    use crate::bench::{load_suite, plot, report};
    let csv = out.join("results.csv");
    let text = std::fs::read(&csv).map_err(|e| bad(format!("{}: {e}", csv.display())))?;
    let suites = report::rows_from_csv(&text).map_err(bad)?;
    let here = crate::gpu::Gpu::shared().ok().map(|g| g.describe());
    let mut drawn = std::collections::BTreeSet::new();
    for (name, adapter, rows) in &suites {
        let measured_here = here
            .as_ref()
            .is_some_and(|h| suites.iter().any(|(n, a, _)| n == name && a == h));
        let wanted = if measured_here {
            here.as_ref() == Some(adapter)
        } else {
            !drawn.contains(name)
        };
        if only.is_some_and(|o| o != name) || !wanted {
            continue;
        }
        drawn.insert(name.clone());
        let (name, adapter, rows) = (name.clone(), adapter.clone(), rows.clone());
        let spec = load_suite(&Path::new("benches").join(format!("{name}.ron"))).map_err(bad)?;
        let stem = name.replace('/', "-");
        for p in plot::plots(&out.join("plots"), &stem, &spec, &adapter, &rows).map_err(bad)? {
            println!("plot: {}", p.display());
        }
    }
    Ok(())
}

/// Write a file atomically, creating its folder.
pub(super) fn write_file(path: &Path, bytes: &[u8]) -> Result<(), CliError> {
    crate::bench::record::write_file(path, bytes).map_err(bad)
}

/// The suites asked for: `benches/NAME.ron` or the folder `benches/NAME/`, or every suite,
/// as (name under `benches/`, file).
fn suites(a: &BenchArgs) -> Result<Vec<(String, PathBuf)>, CliError> {
    use crate::bench::{self, report};
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
    Ok(list)
}
