//! The plots of `tyndall bench` (PNG, drawn with `plotters`): error against time per quality
//! knob (a Pareto view) and time against kernel size.
//!
//! Pareto: every setting of a suite with an error column is a point (median time, RMSE against
//! the suite's reference, both axes logarithmic), coloured by its series (the suite's `series`
//! parameter: the method, or the node measured); the line joins the series' Pareto front — the
//! points no faster setting of the same series beats in error. An RMSE of exactly 0 (a setting
//! equal to the reference) is drawn at the bottom edge. Kernel: time against the `kernel`
//! parameter, one line per group of otherwise equal settings, time axis logarithmic.

use std::collections::BTreeMap;
use std::path::{Path, PathBuf};

use plotters::prelude::*;

use super::{Row, Suite};

/// A plot that could not be drawn or written.
#[derive(Debug, thiserror::Error)]
#[error("plot {path}: {message}")]
pub struct PlotError {
    /// The PNG being made.
    pub path: String,
    /// What went wrong.
    pub message: String,
}

/// Series colours (Tableau 10: distinct, readable on white).
const PALETTE: [RGBColor; 10] = [
    RGBColor(31, 119, 180),
    RGBColor(214, 39, 40),
    RGBColor(44, 160, 44),
    RGBColor(255, 127, 14),
    RGBColor(148, 103, 189),
    RGBColor(140, 86, 75),
    RGBColor(227, 119, 194),
    RGBColor(127, 127, 127),
    RGBColor(188, 189, 34),
    RGBColor(23, 190, 207),
];

fn colour(i: usize) -> RGBAColor {
    PALETTE[i % PALETTE.len()].to_rgba()
}

/// Plot size in pixels.
pub const SIZE: (u32, u32) = (960, 640);

fn font() {
    // The UI font egui already ships (Ubuntu Light); registering it twice is harmless.
    let _ = plotters::style::register_font(
        "sans-serif",
        FontStyle::Normal,
        epaint_default_fonts::UBUNTU_LIGHT,
    );
}

fn write_png(path: &Path, buf: Vec<u8>) -> Result<(), PlotError> {
    let err = |message: String| PlotError {
        path: path.display().to_string(),
        message,
    };
    let img = image::RgbImage::from_raw(SIZE.0, SIZE.1, buf)
        .ok_or_else(|| err("buffer of the wrong size".into()))?;
    let mut bytes = Vec::new();
    img.write_to(
        &mut std::io::Cursor::new(&mut bytes),
        image::ImageFormat::Png,
    )
    .map_err(|e| err(e.to_string()))?;
    if let Some(dir) = path.parent().filter(|d| !d.as_os_str().is_empty()) {
        std::fs::create_dir_all(dir).map_err(|e| err(e.to_string()))?;
    }
    tyndall_engine::graph::write_atomic(path, &bytes).map_err(|e| err(e.to_string()))
}

type Area<'a> = DrawingArea<BitMapBackend<'a>, plotters::coord::Shift>;

/// Draw a white `SIZE` picture with `draw` and write it to `path` as PNG.
fn render(path: &Path, draw: impl FnOnce(&Area) -> Result<(), String>) -> Result<(), PlotError> {
    let err = |message: String| PlotError {
        path: path.display().to_string(),
        message,
    };
    let mut buf = vec![255u8; (SIZE.0 * SIZE.1 * 3) as usize];
    {
        let root = BitMapBackend::with_buffer(&mut buf, SIZE).into_drawing_area();
        root.fill(&WHITE).map_err(|e| err(e.to_string()))?;
        draw(&root).map_err(err)?;
        root.present().map_err(|e| err(e.to_string()))?;
    }
    write_png(path, buf)
}

/// The chart frame both plots share: caption, margins, label areas.
fn frame<'a, 'b>(root: &'a Area<'b>, suite: &Suite) -> ChartBuilder<'a, 'a, BitMapBackend<'b>> {
    let mut b = ChartBuilder::on(root);
    b.caption(caption(suite), ("sans-serif", 20))
        .margin(12)
        .x_label_area_size(44)
        .y_label_area_size(70);
    b
}

/// The series a row belongs to.
fn series_of(suite: &Suite, row: &Row) -> String {
    suite
        .series_key()
        .and_then(|k| row.params.get(&k).cloned())
        .unwrap_or_else(|| {
            if row.node.is_empty() {
                "settings".into()
            } else {
                row.node.clone()
            }
        })
}

/// Indices of `points` (time, error) on the Pareto front, fastest first.
pub fn pareto_front(points: &[(f64, f64)]) -> Vec<usize> {
    let mut order: Vec<usize> = (0..points.len()).collect();
    order.sort_by(|a, b| {
        points[*a]
            .0
            .total_cmp(&points[*b].0)
            .then(points[*a].1.total_cmp(&points[*b].1))
    });
    let mut best = f64::INFINITY;
    let mut front = Vec::new();
    for i in order {
        if points[i].1 < best {
            best = points[i].1;
            front.push(i);
        }
    }
    front
}

fn range_log(values: impl Iterator<Item = f64>) -> Option<(f64, f64)> {
    let (lo, hi) = values
        .filter(|v| v.is_finite() && *v > 0.0)
        .fold((f64::INFINITY, 0.0f64), |(lo, hi), v| {
            (lo.min(v), hi.max(v))
        });
    (hi > 0.0).then(|| (lo / 1.5, hi * 1.5))
}

/// Draw the suite's plots into `dir` as `<stem>-pareto.png` and `<stem>-kernel.png` (each only
/// when the suite has what it shows); returns the files written.
pub fn plots(
    dir: &Path,
    stem: &str,
    suite: &Suite,
    adapter: &str,
    rows: &[Row],
) -> Result<Vec<PathBuf>, PlotError> {
    font();
    let mut out = Vec::new();
    let pareto = dir.join(format!("{stem}-pareto.png"));
    if pareto_plot(&pareto, suite, adapter, rows)? {
        out.push(pareto);
    }
    let kernel = dir.join(format!("{stem}-kernel.png"));
    if kernel_plot(&kernel, suite, adapter, rows)? {
        out.push(kernel);
    }
    let flicker = dir.join(format!("{stem}-flicker.png"));
    if flicker_plot(&flicker, suite, rows)? {
        out.push(flicker);
    }
    Ok(out)
}

/// The legend box of every plot: at `position`, labels of `size` points.
fn legend<'a, 'b: 'a, CT: CoordTranslate>(
    chart: &mut ChartContext<'a, BitMapBackend<'b>, CT>,
    position: SeriesLabelPosition,
    size: u32,
) -> Result<(), String> {
    chart
        .configure_series_labels()
        .background_style(WHITE.mix(0.85))
        .border_style(BLACK)
        .label_font(("sans-serif", size))
        .position(position)
        .draw()
        .map_err(|e| e.to_string())
}

fn caption(suite: &Suite) -> String {
    let mut t = suite.title.clone();
    if t.chars().count() > 90 {
        t = t.chars().take(88).collect::<String>() + "…";
    }
    t
}

fn pareto_plot(path: &Path, suite: &Suite, adapter: &str, rows: &[Row]) -> Result<bool, PlotError> {
    let measured: Vec<&Row> = rows
        .iter()
        .filter(|r| r.rmse.is_finite() && r.median_ms > 0.0)
        .collect();
    let Some((t0, t1)) = range_log(measured.iter().map(|r| r.median_ms)) else {
        return Ok(false);
    };
    let Some((e0, e1)) = range_log(measured.iter().map(|r| r.rmse)) else {
        return Ok(false);
    };
    let floor = e0;
    let mut series: BTreeMap<String, Vec<(f64, f64)>> = BTreeMap::new();
    let mut members: BTreeMap<String, Vec<&Row>> = BTreeMap::new();
    for r in &measured {
        let name = series_of(suite, r);
        series
            .entry(name.clone())
            .or_default()
            .push((r.median_ms, r.rmse.max(floor)));
        members.entry(name).or_default().push(r);
    }
    // Points are labelled with the keys that vary within their series.
    let mut labels: Vec<((f64, f64), String)> = Vec::new();
    for rows in members.values() {
        let varying: Vec<&String> = rows
            .iter()
            .flat_map(|r| r.params.keys())
            .filter(|k| k.as_str() != "runs" && k.as_str() != "time")
            .filter(|k| {
                let first = rows[0].params.get(*k);
                rows.iter().any(|r| r.params.get(*k) != first)
            })
            .collect::<std::collections::BTreeSet<_>>()
            .into_iter()
            .collect();
        // Only the series' Pareto front is labelled (the other points would bury it).
        let points: Vec<(f64, f64)> = rows.iter().map(|r| (r.median_ms, r.rmse)).collect();
        for i in pareto_front(&points) {
            let r = rows[i];
            let text: Vec<String> = varying
                .iter()
                .filter_map(|k| r.params.get(*k).map(|v| format!("{k}={v}")))
                .collect();
            labels.push(((r.median_ms, r.rmse.max(floor)), text.join(" ")));
        }
    }
    render(path, |root| {
        let err = |e: &dyn std::fmt::Display| e.to_string();
        let mut chart = frame(root, suite)
            .build_cartesian_2d((t0..t1).log_scale(), (e0..e1).log_scale())
            .map_err(|e| err(&e))?;
        chart
            .configure_mesh()
            .x_desc(format!("median time, ms ({adapter})"))
            .y_desc("RMSE against the reference")
            .x_labels(6)
            .x_label_formatter(&|v| format!("{v:.0}"))
            .y_label_formatter(&|v| format!("{v:.0e}"))
            .label_style(("sans-serif", 14))
            .draw()
            .map_err(|e| err(&e))?;
        for (i, (name, points)) in series.iter().enumerate() {
            let colour = colour(i);
            let front: Vec<(f64, f64)> = pareto_front(points).iter().map(|j| points[*j]).collect();
            chart
                .draw_series(LineSeries::new(front, colour.stroke_width(2)))
                .map_err(|e| err(&e))?
                .label(name.clone())
                .legend(move |(x, y)| {
                    PathElement::new(vec![(x, y), (x + 18, y)], colour.stroke_width(2))
                });
            chart
                .draw_series(points.iter().map(|p| Circle::new(*p, 4, colour.filled())))
                .map_err(|e| err(&e))?;
        }
        chart
            .draw_series(labels.iter().map(|(p, text)| {
                Text::new(
                    text.clone(),
                    *p,
                    ("sans-serif", 11).into_font().color(&BLACK.mix(0.7)),
                )
            }))
            .map_err(|e| err(&e))?;
        legend(&mut chart, SeriesLabelPosition::UpperRight, 14)?;
        Ok(())
    })?;
    Ok(true)
}

/// A temporal suite's flicker against its error: each setting a point (mean RMSE over the
/// frames, flicker), coloured by series and labelled with its setting; the reference's own
/// frame-to-frame change drawn as a dashed line for scale.
fn flicker_plot(path: &Path, suite: &Suite, rows: &[Row]) -> Result<bool, PlotError> {
    let points: Vec<(&Row, f64, f64)> = rows
        .iter()
        .filter_map(|r| r.temporal.map(|(f, _)| (r, r.rmse, f)))
        .filter(|(_, e, f)| e.is_finite() && f.is_finite() && *e > 0.0 && *f > 0.0)
        .collect();
    let change = rows.iter().find_map(|r| r.temporal.map(|t| t.1));
    let Some((e0, e1)) = range_log(points.iter().map(|p| p.1)) else {
        return Ok(false);
    };
    let Some((f0, f1)) = range_log(
        points
            .iter()
            .map(|p| p.2)
            .chain(change.filter(|c| *c > 0.0)),
    ) else {
        return Ok(false);
    };
    let mut series: BTreeMap<String, Vec<(f64, f64, String)>> = BTreeMap::new();
    for (r, e, f) in &points {
        let label: Vec<String> = r
            .params
            .iter()
            .filter(|(k, _)| !["method", "node", "output", "time"].contains(&k.as_str()))
            .map(|(k, v)| format!("{k}={v}"))
            .collect();
        series
            .entry(series_of(suite, r))
            .or_default()
            .push((*e, *f, label.join(" ")));
    }
    render(path, |root| {
        let err = |e: &dyn std::fmt::Display| e.to_string();
        let mut chart = frame(root, suite)
            .build_cartesian_2d((e0..e1).log_scale(), (f0..f1).log_scale())
            .map_err(|e| err(&e))?;
        chart
            .configure_mesh()
            .x_desc("mean RMSE against the reference, per frame")
            .y_desc("flicker: mean |Δ method − Δ reference| between frames")
            .x_label_formatter(&|v| format!("{v:.0e}"))
            .y_label_formatter(&|v| format!("{v:.0e}"))
            .label_style(("sans-serif", 14))
            .draw()
            .map_err(|e| err(&e))?;
        if let Some(c) = change.filter(|c| *c > 0.0) {
            chart
                .draw_series(DashedLineSeries::new(
                    vec![(e0, c), (e1, c)],
                    6,
                    4,
                    BLACK.mix(0.5).stroke_width(1),
                ))
                .map_err(|e| err(&e))?
                .label("the reference's own change between frames")
                .legend(|(x, y)| PathElement::new(vec![(x, y), (x + 18, y)], BLACK.mix(0.5)));
        }
        for (i, (name, pts)) in series.iter().enumerate() {
            let colour = colour(i);
            chart
                .draw_series(
                    pts.iter()
                        .map(|p| Circle::new((p.0, p.1), 5, colour.filled())),
                )
                .map_err(|e| err(&e))?
                .label(name.clone())
                .legend(move |(x, y)| Circle::new((x + 9, y), 5, colour.filled()));
            chart
                .draw_series(pts.iter().map(|p| {
                    Text::new(
                        p.2.clone(),
                        (p.0, p.1),
                        ("sans-serif", 11).into_font().color(&BLACK.mix(0.7)),
                    )
                }))
                .map_err(|e| err(&e))?;
        }
        legend(&mut chart, SeriesLabelPosition::UpperLeft, 14)?;
        Ok(())
    })?;
    Ok(true)
}

fn kernel_plot(path: &Path, suite: &Suite, adapter: &str, rows: &[Row]) -> Result<bool, PlotError> {
    let mut groups: BTreeMap<String, Vec<(f64, f64)>> = BTreeMap::new();
    let mut label = String::new();
    for r in rows {
        let Some((k, v)) = suite
            .kernel
            .iter()
            .find_map(|k| r.params.get(k).map(|v| (k, v)))
        else {
            continue;
        };
        let Ok(x) = v.parse::<f64>() else { continue };
        if !label.contains(k.as_str()) {
            if !label.is_empty() {
                label.push_str(" / ");
            }
            label.push_str(k);
        }
        let group: Vec<String> = r
            .params
            .iter()
            .filter(|(key, _)| !suite.kernel.contains(key) && key.as_str() != "runs")
            .map(|(key, v)| format!("{key}={v}"))
            .collect();
        groups
            .entry(group.join(" "))
            .or_default()
            .push((x, r.median_ms));
    }
    if groups.is_empty() {
        return Ok(false);
    }
    let xs = groups.values().flatten().map(|p| p.0);
    let (x0, x1) = xs.fold((f64::INFINITY, 0.0f64), |(a, b), x| (a.min(x), b.max(x)));
    if !(x1 > 0.0 && x1.is_finite()) {
        return Ok(false);
    }
    let Some((t0, t1)) = range_log(groups.values().flatten().map(|p| p.1)) else {
        return Ok(false);
    };
    render(path, |root| {
        let err = |e: &dyn std::fmt::Display| e.to_string();
        let mut chart = frame(root, suite)
            .build_cartesian_2d(0.0..x1 * 1.05 + (x1 - x0) * 0.02, (t0..t1).log_scale())
            .map_err(|e| err(&e))?;
        chart
            .configure_mesh()
            .x_desc(format!("kernel size ({label})"))
            .y_desc(format!("median time, ms ({adapter})"))
            .y_label_formatter(&|v| format!("{v:.0}"))
            .label_style(("sans-serif", 14))
            .draw()
            .map_err(|e| err(&e))?;
        for (i, (name, points)) in groups.iter().enumerate() {
            let colour = colour(i);
            let mut pts = points.clone();
            pts.sort_by(|a, b| a.0.total_cmp(&b.0));
            chart
                .draw_series(LineSeries::new(pts.clone(), colour.stroke_width(2)))
                .map_err(|e| err(&e))?
                .label(name.clone())
                .legend(move |(x, y)| {
                    PathElement::new(vec![(x, y), (x + 18, y)], colour.stroke_width(2))
                });
            chart
                .draw_series(pts.iter().map(|p| Circle::new(*p, 3, colour.filled())))
                .map_err(|e| err(&e))?;
        }
        // One group needs no legend (its name would be empty).
        if groups.len() > 1 {
            legend(&mut chart, SeriesLabelPosition::LowerRight, 12)?;
        }
        Ok(())
    })?;
    Ok(true)
}

#[cfg(test)]
mod tests {
    use super::pareto_front;

    #[test]
    fn pareto_front_keeps_only_undominated_points() {
        // (time, error): (2, 0.5) is beaten by (1, 0.4); (3, 0.1) and (1, 0.4) stay; (4, 0.1)
        // is no better than (3, 0.1).
        let pts = [(2.0, 0.5), (1.0, 0.4), (3.0, 0.1), (4.0, 0.1)];
        assert_eq!(pareto_front(&pts), vec![1, 2]);
    }
}
