//! Recording a run of suites: each suite's plots, its block of BENCHMARKS.md (between its
//! markers, [`super::report::update_doc`]), and `results.csv` (rows of suites not run this time
//! kept, [`super::report::merge_results`]), rewritten after every suite so that a run stopped
//! half-way keeps what it measured.

use std::path::{Path, PathBuf};

use super::{plot, report, BenchError, Row, Suite};

/// Where a run's results go.
pub struct Recorder {
    /// The output folder (`bench/`, `bench/quick/`): `results.csv` and `plots/`.
    pub out_dir: PathBuf,
    /// The Markdown file whose generated blocks are rewritten (BENCHMARKS.md), if any.
    pub docs: Option<PathBuf>,
    /// Whether plots and `results.csv` are written (every suite was asked for, or a docs file).
    pub keep: bool,
    /// The command line, quoted in each block of the docs.
    pub command: String,
    results: Vec<(String, String, Vec<Row>)>,
}

fn input(e: impl std::fmt::Display) -> BenchError {
    BenchError::Input(e.to_string())
}

/// Write a file atomically, creating its folder.
pub fn write_file(path: &Path, bytes: &[u8]) -> Result<(), BenchError> {
    if let Some(dir) = path.parent().filter(|d| !d.as_os_str().is_empty()) {
        std::fs::create_dir_all(dir).map_err(|e| input(format!("{}: {e}", dir.display())))?;
    }
    tyndall_engine::graph::write_atomic(path, bytes).map_err(input)
}

impl Recorder {
    /// A recorder writing under `out_dir` (plots and `results.csv` only when `keep`), and the
    /// docs file's blocks when `docs` is given.
    pub fn new(out_dir: PathBuf, docs: Option<PathBuf>, keep: bool, command: String) -> Self {
        Self {
            keep: keep || docs.is_some(),
            out_dir,
            docs,
            command,
            results: Vec::new(),
        }
    }

    /// Record one measured suite (`text`: its printed table); returns the plots written.
    pub fn suite(
        &mut self,
        name: &str,
        spec: &Suite,
        adapter: &str,
        text: &str,
        rows: Vec<Row>,
    ) -> Result<Vec<PathBuf>, BenchError> {
        let mut plots = Vec::new();
        if self.keep {
            let stem = name.replace('/', "-");
            plots = plot::plots(&self.out_dir.join("plots"), &stem, spec, adapter, &rows)
                .map_err(input)?;
        }
        if let Some(doc) = &self.docs {
            let links: Vec<(String, String)> = plots
                .iter()
                .map(|p| {
                    let alt = p
                        .file_stem()
                        .map(|s| s.to_string_lossy().into_owned())
                        .unwrap_or_default();
                    (alt, p.to_string_lossy().into_owned())
                })
                .collect();
            let old = std::fs::read_to_string(doc).unwrap_or_else(|_| "# Benchmarks\n".into());
            let body = report::doc_body(&self.command, text, &links);
            let new = report::update_doc(&old, name, &spec.title, &body);
            write_file(doc, new.as_bytes())?;
        }
        self.results
            .push((name.to_string(), adapter.to_string(), rows));
        if self.keep {
            let path = self.out_dir.join("results.csv");
            let csv = report::results_csv(&self.results)?;
            let old = std::fs::read(&path).unwrap_or_default();
            write_file(&path, &report::merge_results(&old, &csv)?)?;
        }
        Ok(plots)
    }

    /// Suites recorded so far.
    pub fn count(&self) -> usize {
        self.results.len()
    }

    /// Where the results went, in words (`; results: …; plots: …; tables: …`).
    pub fn summary(&self) -> String {
        let mut s = String::new();
        if self.keep {
            s.push_str(&format!(
                "; results: {}; plots: {}",
                self.out_dir.join("results.csv").display(),
                self.out_dir.join("plots").display()
            ));
        }
        if let Some(doc) = &self.docs {
            s.push_str(&format!("; tables: {}", doc.display()));
        }
        s
    }
}
