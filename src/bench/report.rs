//! What `tyndall bench` leaves behind: the suite's text (table and speed-ups), the long CSV of
//! every suite (`bench/results.csv`) and the generated blocks of BENCHMARKS.md.
//!
//! BENCHMARKS.md keeps its prose; each suite's measured block sits between the markers
//! `<!-- bench:NAME -->` and `<!-- /bench:NAME -->` (NAME: the suite file's path under `benches/`
//! without `.ron`, e.g. `visibility/tree`) and is replaced as a whole. A suite without markers
//! gets a new section at the end, so nothing measured is dropped.

use std::path::{Path, PathBuf};

use super::{cell, chain, speedup, BenchError, Row, Suite};

/// Every suite under `benches/`: its files and folders of files, in name order; each with its
/// name (path under `benches/` without `.ron`).
pub fn all_suites(root: &Path) -> Result<Vec<(String, PathBuf)>, BenchError> {
    fn walk(dir: &Path, prefix: &str, out: &mut Vec<(String, PathBuf)>) -> Result<(), BenchError> {
        let mut entries: Vec<PathBuf> = std::fs::read_dir(dir)
            .map_err(|e| BenchError::Input(format!("{}: {e}", dir.display())))?
            .filter_map(|e| e.ok().map(|e| e.path()))
            .collect();
        entries.sort();
        for p in entries {
            let Some(stem) = p.file_stem().map(|s| s.to_string_lossy().into_owned()) else {
                continue;
            };
            if p.is_dir() {
                walk(&p, &format!("{prefix}{stem}/"), out)?;
            } else if p.extension().is_some_and(|x| x == "ron") {
                out.push((format!("{prefix}{stem}"), p));
            }
        }
        Ok(())
    }
    let mut out = Vec::new();
    walk(root, "", &mut out)?;
    Ok(out)
}

/// The suite's results as printed and as written into BENCHMARKS.md: title, adapter, size, runs,
/// the command, the table and the speed-up lines.
pub fn suite_text(
    suite: &Suite,
    adapter: &str,
    (size, runs): ((u32, u32), usize),
    command: &str,
    rows: &[Row],
) -> String {
    // Chain, interactive and document suites repeat whole sequences; a setting suite stops a
    // setting's runs at its row budget.
    let budget = if suite.chain || suite.documents || !suite.proxies.is_empty() || runs < 2 {
        String::new()
    } else {
        format!(" (fewer once they pass {:.0} s)", suite.row_budget_ms / 1e3)
    };
    let mut s = format!(
        "{}\nadapter: {adapter}\nsize {}x{}, {runs} runs per setting{budget}, command: {command}\n",
        suite.title, size.0, size.1
    );
    if suite.chain {
        s.push_str(&chain::table(rows));
    } else {
        s.push_str(&table(rows));
    }
    if let Some((_, _, accelerated)) = &suite.compare {
        for acc in accelerated {
            for &bound in &suite.target_rmse {
                s.push_str(&match speedup(suite, rows, acc, bound) {
                    Some((b, a, f)) => format!(
                        "speed-up of {acc} at RMSE <= {bound}: {f:.2}x ({} {:.3} ms vs {} {:.3} ms)\n",
                        b.setting, b.median_ms, a.setting, a.median_ms
                    ),
                    None => format!(
                        "speed-up of {acc} at RMSE <= {bound}: not measurable (a method never \
                         reached it)\n"
                    ),
                });
            }
        }
    }
    s
}

/// Columns of `bench/results.csv`, one row per measured setting (and, for chain suites, one
/// row per step and one per node and step).
pub const RESULT_COLUMNS: [&str; 25] = [
    "suite",
    "adapter",
    "node",
    "kind",
    "setting",
    "row",
    "median_ms",
    "min_ms",
    "rmse",
    "max_err",
    "growth",
    "holes_before",
    "holes_after",
    "iterations",
    "residual_ratio",
    "psnr_db",
    "edge_rmse",
    "differ",
    "flicker",
    "ref_change",
    "ran",
    "reused",
    "not_needed",
    "readback_bytes",
    "status",
];

fn num(v: f64) -> String {
    if v.is_finite() {
        format!("{v}")
    } else {
        String::new()
    }
}

/// The long CSV of several suites' rows (`(suite name, adapter, rows)`). `row` is `setting`
/// for a measured setting, `step` for a chain step, `node` for one node within a step.
pub fn results_csv(results: &[(String, String, Vec<Row>)]) -> Result<Vec<u8>, BenchError> {
    let mut w = csv::Writer::from_writer(Vec::new());
    let bad = |e: csv::Error| BenchError::Input(format!("results.csv: {e}"));
    w.write_record(RESULT_COLUMNS).map_err(bad)?;
    for (suite, adapter, rows) in results {
        for r in rows {
            let (hb, ha) = r.holes.map_or((String::new(), String::new()), |(a, b)| {
                (a.to_string(), b.to_string())
            });
            let (it, res) = r
                .convergence
                .map_or((String::new(), String::new()), |(i, x)| {
                    (i.to_string(), num(x))
                });
            let (ran, reused, nn) =
                r.chain
                    .as_ref()
                    .map_or((String::new(), String::new(), String::new()), |c| {
                        (
                            c.ran.to_string(),
                            c.reused.to_string(),
                            c.not_needed.to_string(),
                        )
                    });
            w.write_record([
                suite.as_str(),
                adapter,
                &r.node,
                &r.kind,
                &r.setting,
                if r.chain.is_some() { "step" } else { "setting" },
                &num(r.median_ms),
                &num(r.min_ms),
                &num(r.rmse),
                &num(r.max_err),
                &num(r.growth),
                &hb,
                &ha,
                &it,
                &res,
                &num(r.psnr),
                &num(r.edge_rmse),
                &num(r.differ),
                &num(r.temporal.map_or(f64::NAN, |t| t.0)),
                &num(r.temporal.map_or(f64::NAN, |t| t.1)),
                &ran,
                &reused,
                &nn,
                &r.readback.map_or(String::new(), |b| b.to_string()),
                "",
            ])
            .map_err(bad)?;
            for n in r.chain.iter().flat_map(|c| &c.nodes) {
                // A node row: suite … row, its median time, and its status (last column).
                let mut cells = vec![String::new(); RESULT_COLUMNS.len()];
                let lead = [suite.as_str(), adapter, &n.id, &n.kind, &r.setting, "node"];
                for (cell, value) in cells.iter_mut().zip(lead) {
                    *cell = value.to_string();
                }
                cells[6] = num(n.median_ms);
                if let Some(last) = cells.last_mut() {
                    *last = n.status.to_string();
                }
                w.write_record(&cells).map_err(bad)?;
            }
        }
    }
    w.into_inner()
        .map_err(|e| BenchError::Input(format!("results.csv: {e}")))
}

/// The measured-setting rows of `results.csv` text, by suite (for `--replot`: the plots drawn
/// again from recorded figures). Only what the plots read is restored: the setting, the node,
/// the times and the errors.
pub fn rows_from_csv(text: &[u8]) -> Result<Vec<(String, String, Vec<Row>)>, BenchError> {
    let bad = |e: csv::Error| BenchError::Input(format!("results.csv: {e}"));
    let mut r = csv::Reader::from_reader(text);
    let headers = r.headers().map_err(bad)?.clone();
    let col = |name: &str| {
        headers
            .iter()
            .position(|h| h == name)
            .ok_or_else(|| BenchError::Input(format!("results.csv has no column '{name}'")))
    };
    // The first ten columns: suite … max_err.
    let idx: Vec<usize> = RESULT_COLUMNS[..10]
        .iter()
        .map(|c| col(c))
        .collect::<Result<_, _>>()?;
    let mut out: Vec<(String, String, Vec<Row>)> = Vec::new();
    for rec in r.records() {
        let rec = rec.map_err(bad)?;
        let get = |i: usize| rec.get(idx[i]).unwrap_or("");
        if get(5) != "setting" {
            continue;
        }
        let f = |i: usize| get(i).parse::<f64>().unwrap_or(f64::NAN);
        let params = get(4)
            .split_whitespace()
            .filter_map(|kv| kv.split_once('='))
            .map(|(k, v)| (k.to_string(), v.to_string()))
            .collect();
        let mut row = Row::timed(&params, f(6), f(7));
        row.rmse = f(8);
        row.max_err = f(9);
        row.node = get(2).to_string();
        row.kind = get(3).to_string();
        // A temporal suite's columns (absent from files written before they existed).
        let opt = |name: &str| {
            headers
                .iter()
                .position(|h| h == name)
                .and_then(|i| rec.get(i))
                .and_then(|v| v.parse::<f64>().ok())
        };
        if let (Some(flicker), Some(change)) = (opt("flicker"), opt("ref_change")) {
            row.temporal = Some((flicker, change));
        }
        match out.last_mut() {
            Some((suite, adapter, rows)) if suite == get(0) && adapter == get(1) => rows.push(row),
            _ => out.push((get(0).to_string(), get(1).to_string(), vec![row])),
        }
    }
    Ok(out)
}

/// `new` (a results CSV of the suites just run) merged into `old` (the file as it was): the
/// rows of a suite are replaced for the adapter it was run on, and kept for the suites not run
/// and for other adapters (the curves of several machines live side by side); rows stay grouped
/// by suite in name order, then by adapter.
pub fn merge_results(old: &[u8], new: &[u8]) -> Result<Vec<u8>, BenchError> {
    let bad = |e: csv::Error| BenchError::Input(format!("results.csv: {e}"));
    let read = |bytes: &[u8]| -> Result<Vec<csv::StringRecord>, BenchError> {
        let mut r = csv::Reader::from_reader(bytes);
        let mut rows = Vec::new();
        for rec in r.records() {
            rows.push(rec.map_err(bad)?);
        }
        Ok(rows)
    };
    let fresh = read(new)?;
    let suite_and_adapter = |r: &csv::StringRecord| {
        (
            r.get(0).unwrap_or("").to_string(),
            r.get(1).unwrap_or("").to_string(),
        )
    };
    let ran: std::collections::BTreeSet<(String, String)> =
        fresh.iter().map(suite_and_adapter).collect();
    // An old file written with other columns (before a column was added) is read by column
    // name: a column it lacks is empty, one no longer written is dropped.
    let header: Vec<String> = csv::Reader::from_reader(old)
        .headers()
        .map(|h| h.iter().map(str::to_string).collect())
        .unwrap_or_default();
    let from: Vec<Option<usize>> = RESULT_COLUMNS
        .iter()
        .map(|c| header.iter().position(|h| h == c))
        .collect();
    let mut all: Vec<csv::StringRecord> = if from.first().is_some_and(Option::is_some) {
        read(old)?
            .into_iter()
            .map(|r| {
                from.iter()
                    .map(|i| i.and_then(|i| r.get(i)).unwrap_or(""))
                    .collect::<csv::StringRecord>()
            })
            .filter(|r| !ran.contains(&suite_and_adapter(r)))
            .collect()
    } else {
        Vec::new()
    };
    all.extend(fresh);
    all.sort_by(|a, b| (a.get(0), a.get(1)).cmp(&(b.get(0), b.get(1))));
    let mut w = csv::Writer::from_writer(Vec::new());
    w.write_record(RESULT_COLUMNS).map_err(bad)?;
    for r in &all {
        w.write_record(r).map_err(bad)?;
    }
    w.into_inner()
        .map_err(|e| BenchError::Input(format!("results.csv: {e}")))
}

/// The opening and closing markers of a suite's block.
pub fn markers(name: &str) -> (String, String) {
    (
        format!("<!-- bench:{name} -->"),
        format!("<!-- /bench:{name} -->"),
    )
}

/// `doc` with the block of suite `name` replaced by `body` (the markers kept); a suite without
/// markers gets a new section `## {title}` at the end.
pub fn update_doc(doc: &str, name: &str, title: &str, body: &str) -> String {
    let (open, close) = markers(name);
    let block = format!("{open}\n{}\n{close}", body.trim_end());
    if let (Some(a), Some(b)) = (doc.find(&open), doc.find(&close)) {
        if a < b {
            return format!("{}{block}{}", &doc[..a], &doc[b + close.len()..]);
        }
    }
    format!("{}\n\n## {title}\n\n{block}\n", doc.trim_end())
}

/// The markdown body of a suite's block: the command, the text in a code block, the plots.
pub fn doc_body(command: &str, text: &str, plots: &[(String, String)]) -> String {
    let mut s = format!("```\n$ {command}\n{}```\n", text);
    for (alt, link) in plots {
        s.push_str(&format!("\n![{alt}]({link})\n"));
    }
    s
}

/// The table as text (the iteration columns only when a row has them).
pub fn table(rows: &[Row]) -> String {
    let w = rows
        .iter()
        .map(|r| r.setting.len())
        .max()
        .unwrap_or(7)
        .max(7);
    let conv = rows.iter().any(|r| r.convergence.is_some());
    let psnr = rows.iter().any(|r| !r.psnr.is_nan());
    let edges = rows.iter().any(|r| !r.edge_rmse.is_nan());
    let differ = rows.iter().any(|r| !r.differ.is_nan());
    let temporal = rows.iter().any(|r| r.temporal.is_some());
    let readback = rows.iter().any(|r| r.readback.is_some());
    let mut s = format!(
        "{:<w$}  {:>10}  {:>10}  {:>10}  {:>10}  {:>8}  {:>13}",
        "setting", "median ms", "min ms", "RMSE", "max err", "x first", "holes in>out"
    );
    if conv {
        s.push_str(&format!("  {:>10}  {:>12}", "iterations", "residual/r0"));
    }
    if psnr {
        s.push_str(&format!("  {:>8}", "PSNR dB"));
    }
    if edges {
        s.push_str(&format!("  {:>10}", "edge RMSE"));
    }
    if differ {
        s.push_str(&format!("  {:>9}", "differ %"));
    }
    if temporal {
        s.push_str(&format!(
            "  {:>10}  {:>10}  {:>9}",
            "flicker", "ref change", "flicker %"
        ));
    }
    if readback {
        s.push_str(&format!("  {:>12}", "read back B"));
    }
    s.push('\n');
    for r in rows {
        let holes = r.holes.map_or("-".to_string(), |(a, b)| format!("{a}>{b}"));
        s.push_str(&format!(
            "{:<w$}  {:>10.3}  {:>10.3}  {:>10}  {:>10}  {:>8}  {:>13}",
            r.setting,
            r.median_ms,
            r.min_ms,
            cell(r.rmse, 6),
            cell(r.max_err, 6),
            cell(r.growth, 2),
            holes
        ));
        if conv {
            let (it, res) = r.convergence.unwrap_or((0, f64::NAN));
            s.push_str(&format!("  {:>10}  {:>12}", it, cell(res, 6)));
        }
        if psnr {
            s.push_str(&format!("  {:>8}", cell(r.psnr, 2)));
        }
        if edges {
            s.push_str(&format!("  {:>10}", cell(r.edge_rmse, 6)));
        }
        if differ {
            s.push_str(&format!("  {:>9}", cell(r.differ * 100.0, 3)));
        }
        if temporal {
            let (f, c) = r.temporal.unwrap_or((f64::NAN, f64::NAN));
            // The flicker as a share of the reference's own change between frames.
            let share = if c > 0.0 { 100.0 * f / c } else { f64::NAN };
            s.push_str(&format!(
                "  {:>10}  {:>10}  {:>9}",
                cell(f, 6),
                cell(c, 6),
                cell(share, 1)
            ));
        }
        if readback {
            let b = r.readback.map_or("-".to_string(), |b| b.to_string());
            s.push_str(&format!("  {b:>12}"));
        }
        s.push('\n');
    }
    s
}

#[cfg(test)]
mod tests {
    use super::{merge_results, update_doc, RESULT_COLUMNS};

    /// A results line: suite, adapter, a setting row, its median.
    fn line(suite: &str, adapter: &str, ms: &str) -> String {
        let mut cells = vec![""; RESULT_COLUMNS.len()];
        cells[0] = suite;
        cells[1] = adapter;
        cells[5] = "setting";
        cells[6] = ms;
        cells.join(",")
    }

    #[test]
    fn merged_results_keep_other_suites_and_replace_those_run() {
        let header = RESULT_COLUMNS.join(",");
        let row = |suite: &str, ms: &str| line(suite, "", ms);
        let old = format!(
            "{header}\n{}\n{}\n{}\n",
            row("a", "1"),
            row("b", "2"),
            row("c", "3")
        );
        let new = format!("{header}\n{}\n", row("b", "20"));
        let merged =
            String::from_utf8(merge_results(old.as_bytes(), new.as_bytes()).unwrap()).unwrap();
        assert_eq!(
            merged,
            format!(
                "{header}\n{}\n{}\n{}\n",
                row("a", "1"),
                row("b", "20"),
                row("c", "3")
            )
        );
        // An unreadable or foreign old file is replaced.
        let merged =
            String::from_utf8(merge_results(b"x,y\n1,2\n", new.as_bytes()).unwrap()).unwrap();
        assert_eq!(merged, new);
        // An old file from before a column was added keeps its rows, read by column name
        // (the missing column empty, an old column no longer written dropped).
        let older = "suite,row,median_ms,gone\na,setting,1,x\n";
        let merged =
            String::from_utf8(merge_results(older.as_bytes(), new.as_bytes()).unwrap()).unwrap();
        assert_eq!(
            merged,
            format!("{header}\n{}\n{}\n", row("a", "1"), row("b", "20"))
        );
    }

    #[test]
    fn results_of_other_adapters_are_kept_beside_a_new_run() {
        let header = RESULT_COLUMNS.join(",");
        let row = line;
        let old = format!(
            "{header}\n{}\n{}\n{}\n",
            row("a", "gpu", "1"),
            row("a", "cpu", "9"),
            row("b", "cpu", "8")
        );
        let new = format!("{header}\n{}\n", row("a", "cpu", "7"));
        let merged =
            String::from_utf8(merge_results(old.as_bytes(), new.as_bytes()).unwrap()).unwrap();
        assert_eq!(
            merged,
            format!(
                "{header}\n{}\n{}\n{}\n",
                row("a", "cpu", "7"),
                row("a", "gpu", "1"),
                row("b", "cpu", "8")
            )
        );
        let groups = super::rows_from_csv(merged.as_bytes()).unwrap();
        let names: Vec<(&str, &str, usize)> = groups
            .iter()
            .map(|(s, a, r)| (s.as_str(), a.as_str(), r.len()))
            .collect();
        assert_eq!(names, [("a", "cpu", 1), ("a", "gpu", 1), ("b", "cpu", 1)]);
    }

    #[test]
    fn blocks_are_replaced_between_markers_and_missing_ones_appended() {
        let doc = "# B\n\nprose\n<!-- bench:a -->\nold\n<!-- /bench:a -->\nmore prose\n";
        let new = update_doc(doc, "a", "A", "new");
        assert_eq!(
            new,
            "# B\n\nprose\n<!-- bench:a -->\nnew\n<!-- /bench:a -->\nmore prose\n"
        );
        let appended = update_doc(&new, "b/c", "Suite C", "body");
        assert!(appended.starts_with(&new.trim_end().to_string()));
        assert!(appended.ends_with("## Suite C\n\n<!-- bench:b/c -->\nbody\n<!-- /bench:b/c -->\n"));
    }
}
