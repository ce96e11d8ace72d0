//! Where the selected node's quality setting lies on its measured curve.
//!
//! `tyndall bench` writes `bench/results.csv` (one row per measured setting: the node kind, the
//! setting as `key=value` pairs, the median time and the RMSE against the suite's reference).
//! The parameters panel draws, for the selected node's kind, each suite's settings as points in
//! a log–log time/error plot with the Pareto front, and marks the settings equal to the node's
//! current parameters (every plain parameter key of the measured setting equal; keys of other
//! nodes, `node.param`, are the suite's context and not compared). When no measured setting
//! matches, the closest one (most keys equal) is named instead. Clicking a point (or "Use it"
//! next to the closest setting) sets the node's parameters to that setting.
//!
//! The file is looked for at `$TYNDALL_BENCH_RESULTS`, `bench/results.csv` under the working
//! directory, then under the graph file's folder and its parents; it is read again when it
//! changes on disk.

use std::collections::BTreeMap;
use std::path::{Path, PathBuf};
use std::time::SystemTime;

use eframe::egui;

/// One measured setting of `bench/results.csv`.
#[derive(Debug, Clone, PartialEq)]
pub struct Measured {
    /// Suite name.
    pub suite: String,
    /// Adapter it ran on.
    pub adapter: String,
    /// Node kind.
    pub kind: String,
    /// The setting's `key=value` pairs.
    pub setting: BTreeMap<String, String>,
    /// Median time, ms.
    pub median_ms: f64,
    /// RMSE against the suite's reference.
    pub rmse: f64,
}

/// Keys of a setting that are not parameters of the measured node.
pub const NOT_PARAMS: [&str; 7] = [
    "node",
    "output",
    "time",
    "reference",
    "cold",
    "target",
    "runs",
];

/// Parse `bench/results.csv` text: the measured settings with a time and an error.
pub fn parse(text: &str) -> Result<Vec<Measured>, String> {
    let suites =
        tyndall_bench::report::rows_from_csv(text.as_bytes()).map_err(|e| e.to_string())?;
    Ok(suites
        .into_iter()
        .flat_map(|(suite, adapter, rows)| {
            rows.into_iter()
                .filter(|r| r.median_ms.is_finite() && r.rmse.is_finite())
                .map(move |r| Measured {
                    suite: suite.clone(),
                    adapter: adapter.clone(),
                    kind: r.kind,
                    setting: r.params,
                    median_ms: r.median_ms,
                    rmse: r.rmse,
                })
        })
        .collect())
}

fn same(a: &str, b: &str) -> bool {
    match (a.parse::<f64>(), b.parse::<f64>()) {
        (Ok(x), Ok(y)) => (x - y).abs() <= 1e-9 * x.abs().max(y.abs()).max(1.0),
        _ => a == b,
    }
}

/// How many of the setting's own parameter keys `params` agrees with, and how many there are.
pub fn agreement(
    setting: &BTreeMap<String, String>,
    params: &BTreeMap<String, String>,
) -> (usize, usize) {
    let own = setting
        .iter()
        .filter(|(k, _)| !k.contains('.') && !NOT_PARAMS.contains(&k.as_str()));
    let (mut equal, mut all) = (0, 0);
    for (k, v) in own {
        all += 1;
        if params.get(k).is_some_and(|p| same(p, v)) {
            equal += 1;
        }
    }
    (equal, all)
}

/// The measured curves, reloaded when the file changes.
#[derive(Default)]
pub struct Curves {
    /// The adapter the editor evaluates on ([`tyndall_engine::gpu::Gpu::describe`]): a suite
    /// measured on it shows that adapter's curve; one measured elsewhere only, the curve of the
    /// first adapter in the file (the plot names it).
    pub adapter: Option<String>,
    path: Option<PathBuf>,
    stamp: Option<SystemTime>,
    rows: Vec<Measured>,
    error: Option<String>,
}

impl Curves {
    /// Curves from the first results file found for a graph at `graph` (see the module docs).
    pub fn find(graph: Option<&Path>) -> Self {
        let mut candidates: Vec<PathBuf> = std::env::var_os("TYNDALL_BENCH_RESULTS")
            .map(PathBuf::from)
            .into_iter()
            .collect();
        candidates.push(PathBuf::from("bench/results.csv"));
        if let Some(dir) = graph.and_then(Path::parent) {
            candidates.extend(dir.ancestors().map(|d| d.join("bench/results.csv")));
        }
        let path = candidates.into_iter().find(|p| p.is_file());
        let mut c = Self {
            path,
            ..Default::default()
        };
        c.refresh();
        c
    }

    /// Curves from the results file `path`.
    pub fn at(path: &Path) -> Self {
        let mut c = Self {
            path: Some(path.to_path_buf()),
            ..Default::default()
        };
        c.refresh();
        c
    }

    /// Read the file again if it changed.
    pub fn refresh(&mut self) {
        let Some(path) = &self.path else { return };
        let stamp = std::fs::metadata(path).and_then(|m| m.modified()).ok();
        if stamp.is_some() && stamp == self.stamp {
            return;
        }
        self.stamp = stamp;
        match std::fs::read_to_string(path)
            .map_err(|e| e.to_string())
            .and_then(|t| parse(&t))
        {
            Ok(rows) => {
                self.rows = rows;
                self.error = None;
            }
            Err(e) => {
                self.rows.clear();
                self.error = Some(format!("{}: {e}", path.display()));
            }
        }
    }

    /// The measured settings of a node kind, by suite: those that set at least one of the
    /// kind's own parameters (a row that only switches the measured node or changes other
    /// nodes measures no knob of this kind).
    pub fn of_kind(&self, kind: &str) -> BTreeMap<&str, Vec<&Measured>> {
        let mut out: BTreeMap<&str, Vec<&Measured>> = BTreeMap::new();
        let own = |m: &&Measured| agreement(&m.setting, &BTreeMap::new()).1 > 0;
        for m in self.rows.iter().filter(|m| m.kind == kind).filter(own) {
            out.entry(m.suite.as_str()).or_default().push(m);
        }
        // One adapter's curve per suite: the one in use where it was measured.
        for rows in out.values_mut() {
            let shown = self
                .adapter
                .as_deref()
                .filter(|a| rows.iter().any(|m| m.adapter == *a))
                .or(rows.first().map(|m| m.adapter.as_str()))
                .map(str::to_string);
            rows.retain(|m| Some(&m.adapter) == shown.as_ref());
        }
        out
    }

    /// Draw the selected node's curves (nothing when its kind was never measured). Returns the
    /// node's own parameters of a measured setting the user picked — a click on its point, or
    /// "Use it" next to the closest one — for the caller to apply as one undoable step.
    pub fn show(
        &mut self,
        ui: &mut egui::Ui,
        kind: &str,
        params: &BTreeMap<String, String>,
    ) -> Option<BTreeMap<String, String>> {
        self.refresh();
        if let Some(e) = &self.error {
            ui.small(format!("bench results unreadable: {e}"));
            return None;
        }
        let suites = self.of_kind(kind);
        if suites.is_empty() {
            return None;
        }
        ui.separator();
        ui.label("Measured speed against accuracy").on_hover_text(
            "From tyndall bench (bench/results.csv): each point a measured setting, the line the \
             fastest settings for their error; orange: this node's current setting. Click a \
             point to use its setting.",
        );
        let mut picked = None;
        for (suite, rows) in suites {
            picked = plot(ui, suite, &rows, params).or(picked);
        }
        picked.map(|m: &Measured| own_keys(&m.setting))
    }
}

/// The setting's keys that are parameters of the measured node.
pub fn own_keys(setting: &BTreeMap<String, String>) -> BTreeMap<String, String> {
    setting
        .iter()
        .filter(|(k, _)| !k.contains('.') && !NOT_PARAMS.contains(&k.as_str()))
        .map(|(k, v)| (k.clone(), v.clone()))
        .collect()
}

/// One suite's plot; returns the measured setting the user picked, if any.
fn plot<'a>(
    ui: &mut egui::Ui,
    suite: &str,
    rows: &[&'a Measured],
    params: &BTreeMap<String, String>,
) -> Option<&'a Measured> {
    let pos = |v: f64| v.max(1e-12).log10();
    let xs: Vec<f64> = rows.iter().map(|m| pos(m.median_ms)).collect();
    let ys: Vec<f64> = rows.iter().map(|m| pos(m.rmse)).collect();
    let range = |v: &[f64]| {
        let lo = v.iter().copied().fold(f64::INFINITY, f64::min);
        let hi = v.iter().copied().fold(f64::NEG_INFINITY, f64::max);
        (lo - 0.1, (hi - lo).max(0.2) + 0.2)
    };
    let ((x0, xw), (y0, yw)) = (range(&xs), range(&ys));
    let width = ui.available_width().clamp(160.0, 420.0);
    let (rect, response) = ui.allocate_exact_size(egui::vec2(width, 120.0), egui::Sense::click());
    let painter = ui.painter_at(rect);
    let visuals = ui.visuals();
    painter.rect_filled(rect, 2.0, visuals.extreme_bg_color);
    let at = |x: f64, y: f64| {
        egui::pos2(
            rect.left() + 6.0 + ((x - x0) / xw) as f32 * (rect.width() - 12.0),
            rect.bottom() - 6.0 - ((y - y0) / yw) as f32 * (rect.height() - 12.0),
        )
    };
    let points: Vec<(f64, f64)> = xs.iter().copied().zip(ys.iter().copied()).collect();
    let front: Vec<egui::Pos2> = tyndall_bench::plot::pareto_front(&points)
        .iter()
        .map(|i| at(points[*i].0, points[*i].1))
        .collect();
    painter.add(egui::Shape::line(
        front,
        egui::Stroke::new(1.0, visuals.weak_text_color()),
    ));
    let agreements: Vec<(usize, usize)> =
        rows.iter().map(|m| agreement(&m.setting, params)).collect();
    let current = egui::Color32::from_rgb(255, 150, 40);
    for (i, p) in points.iter().enumerate() {
        painter.circle_filled(at(p.0, p.1), 2.5, visuals.text_color());
        let (eq, all) = agreements[i];
        if all > 0 && eq == all {
            painter.circle_stroke(at(p.0, p.1), 5.0, egui::Stroke::new(2.0, current));
        }
    }
    // The point under the pointer (within 10 px): named on hover, taken on click.
    let near = response.hover_pos().and_then(|h| {
        points
            .iter()
            .enumerate()
            .map(|(i, p)| (i, at(p.0, p.1).distance(h)))
            .filter(|(_, d)| *d <= 10.0)
            .min_by(|a, b| a.1.total_cmp(&b.1))
            .map(|(i, _)| i)
    });
    let mut picked = None;
    if let Some(i) = near {
        let m = rows[i];
        painter.circle_stroke(
            at(points[i].0, points[i].1),
            6.0,
            egui::Stroke::new(1.0, visuals.strong_text_color()),
        );
        if response.clicked() {
            picked = Some(m);
        }
        response.on_hover_text(format!(
            "{}\n{:.1} ms, RMSE {:.2e}\nclick to use this setting",
            describe(&m.setting),
            m.median_ms,
            m.rmse
        ));
    }
    let adapter = rows.first().map_or("", |m| m.adapter.as_str());
    ui.small(format!(
        "{suite}: median time (across, log) against RMSE (up, log); {adapter}"
    ));
    if let Some(m) = current_setting(ui, rows, &agreements, current) {
        picked = Some(m);
    }
    picked
}

/// Under the plot: the node's current setting where it was measured (in `current`'s colour),
/// else the closest measured one with a button to use it (returned when clicked).
fn current_setting<'a>(
    ui: &mut egui::Ui,
    rows: &[&'a Measured],
    agreements: &[(usize, usize)],
    current: egui::Color32,
) -> Option<&'a Measured> {
    let mut picked = None;
    let matched: Vec<&&Measured> = rows
        .iter()
        .zip(agreements)
        .filter(|(_, (eq, all))| *all > 0 && eq == all)
        .map(|(m, _)| m)
        .collect();
    if matched.is_empty() {
        let best = rows
            .iter()
            .zip(agreements)
            .max_by_key(|(_, (eq, _))| *eq)
            .map(|(m, _)| *m);
        if let Some(m) = best {
            ui.horizontal_wrapped(|ui| {
                ui.small(format!(
                    "current setting not measured; closest: {} ({:.1} ms, RMSE {:.2e})",
                    describe(&m.setting),
                    m.median_ms,
                    m.rmse
                ));
                if ui
                    .small_button("Use it")
                    .on_hover_text("Set this node's parameters to the closest measured setting")
                    .clicked()
                {
                    picked = Some(m);
                }
            });
        }
    } else {
        for m in matched {
            ui.colored_label(
                current,
                format!(
                    "current setting: {:.1} ms, RMSE {:.2e} ({})",
                    m.median_ms,
                    m.rmse,
                    describe(&m.setting)
                ),
            );
        }
    }
    picked
}

fn describe(s: &BTreeMap<String, String>) -> String {
    s.iter()
        .map(|(k, v)| format!("{k}={v}"))
        .collect::<Vec<_>>()
        .join(" ")
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn results_are_parsed_and_settings_matched_on_the_nodes_own_keys() {
        let text = "suite,adapter,node,kind,setting,row,median_ms,min_ms,rmse,max_err\n\
            visibility/tree,gpu,scatter,Scatter,method=MinMax min_level=2,setting,10,9,0.01,0.1\n\
            chain,gpu,,,cold=true,step,100,90,,\n\
            visibility/tree,gpu,scatter,Scatter,method=BruteForce shadow.resolution=2048 steps=64,setting,20,19,0.002,0.02\n";
        let rows = parse(text).unwrap();
        assert_eq!(rows.len(), 2, "the chain step has no error and is left out");
        let params: BTreeMap<String, String> = [
            ("method", "BruteForce"),
            ("steps", "64.0"),
            ("min_level", "0"),
        ]
        .iter()
        .map(|(k, v)| (k.to_string(), v.to_string()))
        .collect();
        // `shadow.resolution` is context, not a parameter of the node; 64 equals 64.0.
        assert_eq!(agreement(&rows[1].setting, &params), (2, 2));
        assert_eq!(agreement(&rows[0].setting, &params), (0, 2));
        // Rows that set none of the kind's own parameters measure no knob of it.
        let mut curves = Curves::default();
        let other = "suite,adapter,node,kind,setting,row,median_ms,min_ms,rmse,max_err\n\
            medium,gpu,s32,Scatter,node=s32 output=inscatter,setting,10,9,0.01,0.1\n";
        curves.rows = parse(&format!(
            "{}{}",
            other,
            text.lines().skip(1).collect::<Vec<_>>().join("\n")
        ))
        .unwrap();
        let of = curves.of_kind("Scatter");
        assert_eq!(of.keys().copied().collect::<Vec<_>>(), ["visibility/tree"]);
    }

    #[test]
    fn a_suite_measured_on_several_adapters_shows_the_one_in_use() {
        let text = "suite,adapter,node,kind,setting,row,median_ms,min_ms,rmse,max_err\n\
            blur,cpu,b,Smear,sigma=1,setting,50,49,0.01,0.1\n\
            blur,cpu,b,Smear,sigma=2,setting,60,59,0.005,0.1\n\
            blur,gpu,b,Smear,sigma=1,setting,0.5,0.4,0.01,0.1\n";
        let mut curves = Curves {
            rows: parse(text).unwrap(),
            ..Default::default()
        };
        let adapters = |c: &Curves| -> Vec<String> {
            c.of_kind("Smear")["blur"]
                .iter()
                .map(|m| m.adapter.clone())
                .collect()
        };
        assert_eq!(
            adapters(&curves),
            ["cpu", "cpu"],
            "no adapter: the first one"
        );
        curves.adapter = Some("gpu".into());
        assert_eq!(adapters(&curves), ["gpu"]);
        curves.adapter = Some("another".into());
        assert_eq!(
            adapters(&curves),
            ["cpu", "cpu"],
            "not measured on it: the first one"
        );
    }
}
