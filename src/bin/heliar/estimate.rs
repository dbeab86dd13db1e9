//! `heliar estimate`: per-frame sun and sky intensities as JSON lines.

use crate::common::{build_estimator, frame_bar, load_scene};
use heliar::run::source::pick_sequence;
use anyhow::{Context, Result};
use clap::Args;
use heliar::estimate::{FrameEstimate, Status};
use heliar::io::frames::Frame;
use heliar::estimate::LUMA;
use heliar::report::{JsonLines, Series, Table, line_plot_svg, lighting_error, median};
use heliar::estimate::Estimator;
use heliar::scene::{Scene, Sequence, Truth};
use serde::Serialize;
use std::collections::BTreeMap;
use std::path::{Path, PathBuf};

#[derive(Args)]
pub struct EstimateArgs {
    /// Scene folder.
    scene: PathBuf,
    /// Sequence name (default: the first in the manifest).
    #[arg(long)]
    sequence: Option<String>,
    /// JSON-lines output file (default: stdout).
    #[arg(long, short)]
    output: Option<PathBuf>,
    /// Pixels drawn per frame (overrides the manifest).
    #[arg(long)]
    samples: Option<usize>,
    /// Leave the sun-bounce term out of the model.
    #[arg(long)]
    no_sun_bounce: bool,
    /// Also write an SVG plot of Pd and Pa (luminance) over time, with the truth when known.
    #[arg(long)]
    plot: Option<PathBuf>,
    /// Write the outputs even over an input or a file of the scene.
    #[arg(long)]
    force: bool,
    /// Also give each lamp its `k` in hindsight (`k_hindsight`: smoothed forward and backward
    /// over the whole sequence, as `heliar augment` renders with). The lines are then written
    /// once every frame is estimated.
    #[arg(long)]
    hindsight: bool,
}

/// What the frame loop gathers for the summary and the plot.
#[derive(Default)]
struct Tally {
    statuses: BTreeMap<Status, usize>,
    errs_pd: Vec<f64>,
    errs_pa: Vec<f64>,
    ms: Vec<f64>,
    decode: Vec<f64>,
    /// pd, pa, pd smoothed, pa smoothed, pd true, pa true
    plot: [Vec<(f64, f64)>; 6],
}

/// Estimates every frame of `seq`, one JSON line each into `out`.
fn estimate_frames(scene: &Scene, seq: &Sequence, est: &mut Estimator, out: &mut JsonLines, hindsight: bool) -> Result<Tally> {
    let lin = seq.photometry.linearizer();
    let pb = frame_bar(seq.files.len(), &format!("estimate {}", seq.name));
    let mut t = Tally::default();
    let k = &scene.camera.intrinsics;
    let luma = |v: &[f64; 3]| v[0] * LUMA[0] + v[1] * LUMA[1] + v[2] * LUMA[2];
    // With `hindsight`, the lines wait for the backward pass: (estimate, decode ms, truth, error, s).
    let mut held = Vec::new();
    for (i, path) in seq.files.iter().enumerate() {
        let clock = std::time::Instant::now();
        let frame = Frame::load_sized(path, k.width, k.height)?;
        let decode_ms = clock.elapsed().as_secs_f64() * 1e3;
        let e = est.estimate(i, &seq.times[i], &frame, &lin).with_context(|| format!("{}", path.display()))?;
        let truth = seq.truth.as_ref().map(|t| t[i]);
        let error = match (truth, e.pd, e.pa) {
            (Some(tr), Some(pd), Some(pa)) => {
                let (ed, ea) = lighting_error(&pd, &pa, &tr.pd, &tr.pa);
                t.errs_pd.push(ed);
                t.errs_pa.push(ea);
                Some(ErrorPair { pd: ed, pa: ea })
            }
            _ => None,
        };
        *t.statuses.entry(e.status).or_default() += 1;
        let ts = (seq.times[i] - seq.times[0]).num_milliseconds() as f64 / 1e3;
        if let (Some(pd), Some(pa)) = (e.pd, e.pa) {
            t.plot[0].push((ts, luma(&pd)));
            t.plot[1].push((ts, luma(&pa)));
        }
        if let Some(s) = e.smoothed {
            t.plot[2].push((ts, luma(&s.pd)));
            t.plot[3].push((ts, luma(&s.pa)));
        }
        if let Some(tr) = truth {
            t.plot[4].push((ts, luma(&tr.pd)));
            t.plot[5].push((ts, luma(&tr.pa)));
        }
        t.ms.push(e.estimate_ms);
        t.decode.push(decode_ms);
        if hindsight {
            held.push((e, decode_ms, truth, error, ts));
        } else {
            out.write(&Record { estimate: &e, decode_ms, truth, error })?;
        }
        pb.inc(1);
    }
    pb.finish_and_clear();
    if hindsight {
        let h = heliar::estimate::hindsight::LampHindsight::from_reports(scene, held.iter().map(|(e, _, _, _, ts)| (e.frame, *ts, &e.lamps[..])));
        for (mut e, decode_ms, truth, error, _) in held {
            h.apply(e.frame, &mut e.lamps);
            out.write(&Record { estimate: &e, decode_ms, truth, error })?;
        }
    }
    Ok(t)
}

#[derive(Serialize)]
struct Record<'a> {
    #[serde(flatten)]
    estimate: &'a FrameEstimate,
    decode_ms: f64,
    truth: Option<Truth>,
    error: Option<ErrorPair>,
}

#[derive(Serialize, Clone, Copy)]
struct ErrorPair {
    pd: f64,
    pa: f64,
}

/// The folder of `seq`'s frames (an input the outputs must not overwrite).
fn seq_dir(scene: &Scene, seq: &Sequence) -> PathBuf {
    let dir = scene.manifest.sequences.iter().find(|s| s.name == seq.name).map(|s| s.dir.as_str()).unwrap_or(".");
    scene.root.join(dir)
}

pub fn run(a: EstimateArgs) -> Result<()> {
    let (mut scene, ray) = load_scene(&a.scene)?;
    if let Some(n) = a.samples {
        scene.estimator.samples = n;
        scene.estimator.pool_size = scene.estimator.pool_size.max(n);
        // The manifest's rule for `estimator.samples`, from the same check.
        if let Err((field, msg)) = scene.estimator.validate() {
            let option = if field == "samples" { "--samples" } else { field };
            anyhow::bail!("{option} {n}: {msg} (the rule of scene.toml's estimator.{field})");
        }
    }
    if a.no_sun_bounce {
        scene.estimator.sun_bounce = false;
    }
    let seq = pick_sequence(&scene, a.sequence.as_deref())?.clone();
    let outputs: Vec<&Path> = a.output.iter().chain(&a.plot).map(PathBuf::as_path).collect();
    crate::common::guard_files(Some(&scene.root), &[seq_dir(&scene, &seq).as_path()], &outputs, a.force)?;
    let mut est = build_estimator(&scene, ray)?;
    let tally = match &a.output {
        Some(p) => {
            let mut tally = None;
            crate::common::write_output(p, |tmp| {
                let mut out = JsonLines::create(tmp).with_context(|| format!("creating {}", tmp.display()))?;
                tally = Some(estimate_frames(&scene, &seq, &mut est, &mut out, a.hindsight)?);
                Ok(())
            })?;
            tally.unwrap_or_default()
        }
        None => estimate_frames(&scene, &seq, &mut est, &mut JsonLines::stdout(), a.hindsight)?,
    };
    let Tally { statuses, errs_pd, errs_pa, ms, decode, plot } = tally;
    let mut t = Table::new(&["quantity", "value"]);
    t.push(vec!["frames".into(), seq.files.len().to_string()]);
    for (s, n) in &statuses {
        t.push(vec![format!("status {}", serde_json::to_value(s)?.as_str().unwrap_or("?")), n.to_string()]);
    }
    if !errs_pd.is_empty() {
        let mean = |v: &[f64]| v.iter().sum::<f64>() / v.len() as f64;
        let max = |v: &[f64]| v.iter().cloned().fold(0.0, f64::max);
        t.push(vec!["Pd error vs truth, mean / max".into(), format!("{:.2}% / {:.2}%", 100.0 * mean(&errs_pd), 100.0 * max(&errs_pd))]);
        t.push(vec!["Pa error vs truth, mean / max".into(), format!("{:.2}% / {:.2}%", 100.0 * mean(&errs_pa), 100.0 * max(&errs_pa))]);
    }
    t.push(vec!["median estimate time per frame".into(), format!("{:.3} ms", median(&ms))]);
    t.push(vec!["median decode time per frame".into(), format!("{:.3} ms", median(&decode))]);
    eprint!("{t}");
    if let Some(p) = &a.output {
        eprintln!("wrote {}", p.display());
    }
    if let Some(path) = &a.plot {
        let names = ["Pd", "Pa", "Pd smoothed", "Pa smoothed", "Pd true", "Pa true"];
        let series: Vec<Series> = plot
            .into_iter()
            .zip(names)
            .enumerate()
            .filter(|(_, (p, _))| !p.is_empty())
            .map(|(k, (points, name))| Series { name: name.into(), points, reference: k >= 4 })
            .collect();
        let title = format!("{} / {}: sun and sky irradiance (luminance)", scene.manifest.name, seq.name);
        crate::common::write_output(path, |tmp| {
            Ok(line_plot_svg(tmp, &title, "time since first frame (s)", "irradiance (scaled radiance units)", &series, false, false)?)
        })?;
        eprintln!("wrote {}", path.display());
    }
    Ok(())
}
