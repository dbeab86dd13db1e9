//! `heliar bench cuts`: error against run time of the visibility cuts (issue 15 §4;
//! Cyberworlds, `../shared/papers/cyberworlds-captured-lighting-cuts.txt`, §VI): the SVC
//! threshold, the number of directions `S` and the VCF sampling (spheres × points per sphere)
//! swept on `heliar::cuts::sweep`'s test scene, each point against the ray-traced reference.
//!
//! Per point: the vertex and receiver errors, the precompute time, the stored bytes (and the
//! SVC bytes scaled to the paper's 27,000 vertices), the mean cut sizes and the time of one
//! frame's evaluations (every vertex and receiver, one thread).

use crate::common::frame_bar;
use anyhow::{Context, Result, bail};
use clap::{Args, ValueEnum};
use heliar::cuts::sweep::{SweepPoint, SweepRow, default_sweep_points, sweep_point, sweep_scene, sweep_table, trace_reference};
use heliar::cuts::vcf::VcfSampling;
use heliar::report::{Series, Table, line_plot_svg};
use std::path::PathBuf;

/// The paper's scene size (§VI: 27,000 vertices took 270 MB).
const PAPER_VERTICES: f64 = 27_000.0;

#[derive(Clone, Copy, ValueEnum)]
pub enum Knob {
    /// SVC threshold: 0, 0.02, 0.05, 0.1, 0.2 (S and the field at `--levels`, `--vcf`).
    Threshold,
    /// Tree depth `log2 S`: 10 … 15 (threshold `--threshold`, field `--vcf`).
    Directions,
    /// Field sampling `n` spheres × `n`² points: 4, 8, 16, 24, 32 (the paper: 32 × 32² looked
    /// right, 8 × 8² blurred).
    Vcf,
    /// The library's default sweep (`cuts::sweep::default_sweep_points`: all three, then the
    /// paper's S = 2^15 and 32 × 32² at three thresholds); takes long.
    All,
}

#[derive(Args)]
pub struct CutsSweep {
    /// Which knob to sweep.
    #[arg(long, value_enum, default_value = "vcf")]
    knob: Knob,
    /// The knob's values instead of its defaults (comma-separated; not for `all`).
    #[arg(long, value_delimiter = ',')]
    values: Vec<f64>,
    /// Tree depth while another knob is swept (`S = 2^levels`).
    #[arg(long, default_value_t = 12)]
    levels: u32,
    /// SVC threshold while another knob is swept.
    #[arg(long, default_value_t = 0.05)]
    threshold: f32,
    /// Field sampling `n` (n spheres × n² points) while another knob is swept.
    #[arg(long, default_value_t = 16)]
    vcf: u32,
    /// Directions of the traced reference.
    #[arg(long, default_value_t = 1 << 16)]
    reference_dirs: usize,
    /// CSV output.
    #[arg(long, default_value = "out/bench_cuts.csv")]
    csv: PathBuf,
    /// SVG plot of the errors against the run time (log–log).
    #[arg(long)]
    plot: Option<PathBuf>,
    /// Write the outputs even over an existing file.
    #[arg(long)]
    force: bool,
}

fn sampling(n: u32) -> VcfSampling {
    VcfSampling { spheres: n, rows: n, cols: n, ..VcfSampling::default() }
}

/// A knob value that must be a whole number in `lo..=hi`.
fn whole(v: f64, lo: u32, hi: u32, what: &str) -> Result<u32> {
    if v.fract() != 0.0 || v < lo as f64 || v > hi as f64 {
        bail!("--values: {what} must be a whole number from {lo} to {hi}, not {v}");
    }
    Ok(v as u32)
}

/// The sweep points of `a.knob`.
fn points(a: &CutsSweep) -> Result<Vec<SweepPoint>> {
    let base = SweepPoint { levels: a.levels, svc_threshold: a.threshold, vcf: sampling(a.vcf) };
    let values = |defaults: &[f64]| if a.values.is_empty() { defaults.to_vec() } else { a.values.clone() };
    Ok(match a.knob {
        Knob::Threshold => values(&[0.0, 0.02, 0.05, 0.1, 0.2])
            .into_iter()
            .map(|t| if t.is_finite() && (0.0..=1.0).contains(&t) { Ok(SweepPoint { svc_threshold: t as f32, ..base }) } else { bail!("--values: a threshold must be in [0, 1], not {t}") })
            .collect::<Result<_>>()?,
        Knob::Directions => values(&[10.0, 11.0, 12.0, 13.0, 14.0, 15.0]).into_iter().map(|l| Ok(SweepPoint { levels: whole(l, 1, 20, "a tree depth")?, ..base })).collect::<Result<_>>()?,
        Knob::Vcf => values(&[4.0, 8.0, 16.0, 24.0, 32.0]).into_iter().map(|n| Ok(SweepPoint { vcf: sampling(whole(n, 1, 64, "a field sampling")?), ..base })).collect::<Result<_>>()?,
        Knob::All => {
            if !a.values.is_empty() {
                bail!("--values does not apply to --knob all");
            }
            default_sweep_points()
        }
    })
}

pub fn run(a: CutsSweep) -> Result<()> {
    let outputs: Vec<&std::path::Path> = std::iter::once(&a.csv).chain(&a.plot).map(PathBuf::as_path).collect();
    crate::common::guard_files(None, &[], &outputs, a.force)?;
    let points = points(&a)?;
    let scene = sweep_scene();
    let spinner = crate::common::spinner(&format!("tracing the reference ({} directions)", a.reference_dirs));
    let t = std::time::Instant::now();
    let reference = trace_reference(&scene, a.reference_dirs.max(1));
    spinner.finish_and_clear();
    let reference_s = t.elapsed().as_secs_f64();
    let pb = frame_bar(points.len(), "sweep cuts");
    let mut rows = Vec::new();
    for p in &points {
        rows.push(sweep_point(&scene, p, &reference).with_context(|| format!("sweep point {p:?}"))?);
        pb.inc(1);
    }
    pb.finish_and_clear();
    let table = table(&rows, scene.a.positions.len());
    println!(
        "visibility cuts: torus A ({} vertices) beside sphere B ({} vertices) over {} receivers; reference {} directions traced in {reference_s:.1} s; errors relative RMSE, times one thread",
        scene.a.positions.len(),
        scene.b.positions.len(),
        scene.receivers.len(),
        a.reference_dirs
    );
    print!("{table}");
    crate::common::write_output(&a.csv, |tmp| Ok(table.write_csv(tmp)?))?;
    println!("wrote {}", a.csv.display());
    if let Some(path) = &a.plot {
        plot(path, a.knob, &rows)?;
        println!("wrote {}", path.display());
    }
    Ok(())
}

/// The library's table with the SVC size scaled to the paper's scene.
fn table(rows: &[SweepRow], vertices: usize) -> Table {
    let mut t = sweep_table(rows);
    t.headers.push("svc_mb_at_27k_vertices".into());
    for (cells, r) in t.rows.iter_mut().zip(rows) {
        cells.push(format!("{:.1}", r.svc_bytes as f64 / vertices.max(1) as f64 * PAPER_VERTICES / 1e6));
    }
    t
}

/// Errors (%) against the cost the knob trades: one frame's evaluations for the threshold, the
/// precompute for the others.
fn plot(path: &std::path::Path, knob: Knob, rows: &[SweepRow]) -> Result<()> {
    let (x_label, x): (&str, fn(&SweepRow) -> f64) = match knob {
        Knob::Threshold => ("evaluation time per frame, one thread (ms)", |r| r.frame_ms),
        _ => ("precompute time (ms)", |r| r.precompute_ms),
    };
    let series = [("vertex irradiance", (|r: &SweepRow| r.vertex_rel_rmse) as fn(&SweepRow) -> f64), ("receiver occlusion", |r| r.receiver_rel_rmse)]
        .into_iter()
        .map(|(name, y)| Series { name: name.into(), points: rows.iter().map(|r| (x(r).max(1e-3), (100.0 * y(r)).max(1e-4))).collect(), reference: false })
        .collect::<Vec<_>>();
    crate::common::write_output(path, |tmp| Ok(line_plot_svg(tmp, "visibility cuts: error against run time", x_label, "relative RMSE against the traced reference (%)", &series, true, true)?))
}
