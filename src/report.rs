//! Machine-readable output: per-frame JSON lines, error metrics against known lighting, and
//! tables printed as text and CSV (error against run time sweeps).
//!
//! # Error metric
//! For a frame with true `(Pd, Pa)` and estimate `(P̂d, P̂a)` (RGB):
//! `err_pd = |P̂d − Pd| / max(|Pd|, |Pa|)` and `err_pa = |P̂a − Pa| / |Pa|`, with `|·|` the RGB
//! Euclidean norm. `Pd` is normalised by the larger of the two so that a frame whose sun is behind a
//! thick cloud (`Pd → 0`) is judged against the light that is there, not divided by zero.

use serde::Serialize;
use std::io::Write;
use std::path::{Path, PathBuf};

/// Writes one JSON value per line and flushes after each, so an interrupted run keeps every line
/// it reported.
pub struct JsonLines {
    out: Box<dyn Write + Send>,
    path: Option<PathBuf>,
}

impl JsonLines {
    /// Lines to a new file (parent folders are created).
    pub fn create(path: &Path) -> std::io::Result<Self> {
        if let Some(parent) = path.parent().filter(|p| !p.as_os_str().is_empty()) {
            std::fs::create_dir_all(parent)?;
        }
        let f = std::fs::File::create(path)?;
        Ok(Self { out: Box::new(std::io::BufWriter::new(f)), path: Some(path.to_owned()) })
    }

    /// Lines appended to an existing file (created when absent).
    pub fn append(path: &Path) -> std::io::Result<Self> {
        let f = std::fs::OpenOptions::new().append(true).create(true).open(path)?;
        Ok(Self { out: Box::new(std::io::BufWriter::new(f)), path: Some(path.to_owned()) })
    }

    /// Lines to standard output.
    pub fn stdout() -> Self {
        Self { out: Box::new(std::io::stdout()), path: None }
    }

    /// Where the lines go (`None` for stdout).
    pub fn path(&self) -> Option<&Path> {
        self.path.as_deref()
    }

    /// Writes one line.
    pub fn write<T: Serialize>(&mut self, value: &T) -> std::io::Result<()> {
        serde_json::to_writer(&mut self.out, value).map_err(std::io::Error::other)?;
        self.out.write_all(b"\n")?;
        self.out.flush()
    }
}

fn norm(v: &[f64; 3]) -> f64 {
    (v[0] * v[0] + v[1] * v[1] + v[2] * v[2]).sqrt()
}

fn diff(a: &[f64; 3], b: &[f64; 3]) -> [f64; 3] {
    [a[0] - b[0], a[1] - b[1], a[2] - b[2]]
}

/// Relative errors `(err_pd, err_pa)` as defined in the module docs.
pub fn lighting_error(pd: &[f64; 3], pa: &[f64; 3], true_pd: &[f64; 3], true_pa: &[f64; 3]) -> (f64, f64) {
    let scale_pd = norm(true_pd).max(norm(true_pa)).max(1e-300);
    (norm(&diff(pd, true_pd)) / scale_pd, norm(&diff(pa, true_pa)) / norm(true_pa).max(1e-300))
}

/// Median of a slice (copied); `NaN` when empty.
pub fn median(v: &[f64]) -> f64 {
    percentile(v, 0.5)
}

/// The `q`-quantile (nearest rank) of a slice; `NaN` when empty.
pub fn percentile(v: &[f64], q: f64) -> f64 {
    if v.is_empty() {
        return f64::NAN;
    }
    let mut s = v.to_vec();
    s.sort_by(|a, b| a.total_cmp(b));
    let k = ((q * (s.len() - 1) as f64).round() as usize).min(s.len() - 1);
    s[k]
}

/// A table of strings printed with aligned columns, or written as CSV.
#[derive(Clone, Debug, Default)]
pub struct Table {
    /// Column names.
    pub headers: Vec<String>,
    /// Rows, each as long as `headers`.
    pub rows: Vec<Vec<String>>,
}

impl Table {
    /// A table with these columns.
    pub fn new(headers: &[&str]) -> Self {
        Self { headers: headers.iter().map(|s| s.to_string()).collect(), rows: Vec::new() }
    }

    /// Appends a row.
    pub fn push(&mut self, row: Vec<String>) {
        self.rows.push(row);
    }

    /// CSV text (fields with commas or quotes are quoted).
    pub fn to_csv(&self) -> String {
        let esc = |s: &str| if s.contains([',', '"', '\n']) { format!("\"{}\"", s.replace('"', "\"\"")) } else { s.to_string() };
        let mut out = String::new();
        for row in std::iter::once(&self.headers).chain(&self.rows) {
            out += &row.iter().map(|s| esc(s)).collect::<Vec<_>>().join(",");
            out.push('\n');
        }
        out
    }

    /// Writes the CSV to `path` (parent folders are created).
    pub fn write_csv(&self, path: &Path) -> std::io::Result<()> {
        if let Some(parent) = path.parent().filter(|p| !p.as_os_str().is_empty()) {
            std::fs::create_dir_all(parent)?;
        }
        std::fs::write(path, self.to_csv())
    }
}

impl std::fmt::Display for Table {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        let n = self.headers.len();
        let mut w = vec![0; n];
        for row in std::iter::once(&self.headers).chain(&self.rows) {
            for (i, c) in row.iter().enumerate().take(n) {
                w[i] = w[i].max(c.chars().count());
            }
        }
        let line = |f: &mut std::fmt::Formatter<'_>, row: &Vec<String>| -> std::fmt::Result {
            let cells: Vec<String> = row.iter().enumerate().take(n).map(|(i, c)| format!("{c:>width$}", width = w[i])).collect();
            writeln!(f, "{}", cells.join("  "))
        };
        line(f, &self.headers)?;
        writeln!(f, "{}", w.iter().map(|k| "-".repeat(*k)).collect::<Vec<_>>().join("  "))?;
        for r in &self.rows {
            line(f, r)?;
        }
        Ok(())
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn error_metric_closed_forms() {
        let (e_pd, e_pa) = lighting_error(&[3.0, 3.0, 3.0], &[1.1, 1.0, 1.0], &[3.0, 3.0, 3.0], &[1.0, 1.0, 1.0]);
        assert_eq!(e_pd, 0.0);
        assert!((e_pa - 0.1 / 3f64.sqrt()).abs() < 1e-12);
        // Pd = 0 in truth: normalised by |Pa|.
        let (e_pd, _) = lighting_error(&[0.1, 0.0, 0.0], &[1.0; 3], &[0.0; 3], &[1.0; 3]);
        assert!((e_pd - 0.1 / 3f64.sqrt()).abs() < 1e-12);
    }

    #[test]
    fn table_csv_and_text() {
        let mut t = Table::new(&["n", "what"]);
        t.push(vec!["1".into(), "a,b".into()]);
        assert_eq!(t.to_csv(), "n,what\n1,\"a,b\"\n");
        assert!(t.to_string().contains("a,b"));
        assert_eq!(median(&[3.0, 1.0, 2.0]), 2.0);
        assert!(median(&[]).is_nan());
    }
}

/// A number with three significant digits and no trailing zeros (axis labels).
pub fn sig3(v: f64) -> String {
    if v == 0.0 || !v.is_finite() {
        return format!("{v}");
    }
    let digits = (2 - v.abs().log10().floor() as i32).max(0) as usize;
    let s = format!("{v:.digits$}");
    if s.contains('.') { s.trim_end_matches('0').trim_end_matches('.').to_string() } else { s }
}

/// One line of a plot: a name and its points.
pub struct Series {
    /// Legend text.
    pub name: String,
    /// `(x, y)` points in order.
    pub points: Vec<(f64, f64)>,
    /// Draw as a dashed reference (e.g. the truth) instead of a solid line with markers.
    pub reference: bool,
}

/// Writes an SVG line plot (plotters). Axes are logarithmic when asked; non-positive values are
/// dropped from a log axis.
pub fn line_plot_svg(path: &Path, title: &str, x_label: &str, y_label: &str, series: &[Series], log_x: bool, log_y: bool) -> std::io::Result<()> {
    use plotters::prelude::*;
    if let Some(parent) = path.parent().filter(|p| !p.as_os_str().is_empty()) {
        std::fs::create_dir_all(parent)?;
    }
    let keep = |(x, y): &(f64, f64)| x.is_finite() && y.is_finite() && (!log_x || *x > 0.0) && (!log_y || *y > 0.0);
    let pts: Vec<(f64, f64)> = series.iter().flat_map(|s| s.points.iter().copied().filter(keep)).collect();
    if pts.is_empty() {
        return Err(std::io::Error::other("nothing to plot"));
    }
    let (mut x0, mut x1, mut y0, mut y1) = pts.iter().fold((f64::MAX, f64::MIN, f64::MAX, f64::MIN), |a, p| (a.0.min(p.0), a.1.max(p.0), a.2.min(p.1), a.3.max(p.1)));
    let pad = |lo: &mut f64, hi: &mut f64, log: bool| {
        if log {
            *lo /= 1.3;
            *hi *= 1.3;
        } else {
            let d = (*hi - *lo).max(1e-12 * hi.abs().max(1.0));
            *lo -= 0.05 * d;
            *hi += 0.05 * d;
        }
    };
    pad(&mut x0, &mut x1, log_x);
    pad(&mut y0, &mut y1, log_y);
    if !log_y && y0 > 0.0 && y0 < 0.3 * y1 {
        y0 = 0.0;
    }
    let err = |e: &dyn std::fmt::Display| std::io::Error::other(e.to_string());
    let root = SVGBackend::new(path, (720, 440)).into_drawing_area();
    root.fill(&WHITE).map_err(|e| err(&e))?;
    let palette = [RGBColor(31, 119, 180), RGBColor(214, 39, 40), RGBColor(44, 160, 44), RGBColor(148, 103, 189), RGBColor(255, 127, 14), RGBColor(23, 190, 207)];
    macro_rules! draw {
        ($chart:expr) => {{
            let mut chart = $chart;
            chart
                .configure_mesh()
                .x_desc(x_label)
                .y_desc(y_label)
                .x_label_formatter(&|v| sig3(*v))
                .y_label_formatter(&|v| sig3(*v))
                .x_labels(8)
                .y_labels(8)
                .draw()
                .map_err(|e| err(&e))?;
            for (i, s) in series.iter().enumerate() {
                let color = palette[i % palette.len()];
                let data: Vec<(f64, f64)> = s.points.iter().copied().filter(keep).collect();
                if s.reference {
                    chart
                        .draw_series(DashedLineSeries::new(data, 6, 4, color.stroke_width(2)))
                        .map_err(|e| err(&e))?
                        .label(s.name.clone())
                        .legend(move |(x, y)| PathElement::new(vec![(x, y), (x + 16, y)], color));
                } else {
                    chart.draw_series(LineSeries::new(data.clone(), color.stroke_width(2))).map_err(|e| err(&e))?
                        .label(s.name.clone())
                        .legend(move |(x, y)| PathElement::new(vec![(x, y), (x + 16, y)], color));
                    chart.draw_series(data.into_iter().map(|p| Circle::new(p, 3, color.filled()))).map_err(|e| err(&e))?;
                }
            }
            chart.configure_series_labels().background_style(WHITE.mix(0.8)).border_style(BLACK).draw().map_err(|e| err(&e))?;
        }};
    }
    let mut b = ChartBuilder::on(&root);
    b.caption(title, ("sans-serif", 18)).margin(12).x_label_area_size(40).y_label_area_size(60);
    match (log_x, log_y) {
        (false, false) => draw!(b.build_cartesian_2d(x0..x1, y0..y1).map_err(|e| err(&e))?),
        (true, false) => draw!(b.build_cartesian_2d((x0..x1).log_scale(), y0..y1).map_err(|e| err(&e))?),
        (false, true) => draw!(b.build_cartesian_2d(x0..x1, (y0..y1).log_scale()).map_err(|e| err(&e))?),
        (true, true) => draw!(b.build_cartesian_2d((x0..x1).log_scale(), (y0..y1).log_scale()).map_err(|e| err(&e))?),
    }
    root.present().map_err(|e| err(&e))?;
    Ok(())
}
