//! `heliar estimate`: per-frame sun and sky intensities as JSON lines.

use crate::common::{build_estimator, frame_bar, load_scene};
use heliar::run::source::pick_sequence;
use anyhow::{Context, Result};
use clap::Args;
use heliar::estimate::{FrameEstimate, Status};
use heliar::io::frames::Frame;
use heliar::estimate::LUMA;
use heliar::report::{JsonLines, Series, Table, line_plot_svg, lighting_error, median};
use heliar::scene::Truth;
use serde::Serialize;
use std::collections::BTreeMap;
use std::path::PathBuf;

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
    let mut est = build_estimator(&scene, ray)?;
    let lin = seq.photometry.linearizer();
    let mut out = match &a.output {
        Some(p) => JsonLines::create(p).with_context(|| format!("creating {}", p.display()))?,
        None => JsonLines::stdout(),
    };
    let pb = frame_bar(seq.files.len(), &format!("estimate {}", seq.name));
    let mut statuses: BTreeMap<Status, usize> = BTreeMap::new();
    let (mut errs_pd, mut errs_pa, mut ms, mut decode) = (vec![], vec![], vec![], vec![]);
    let k = &scene.camera.intrinsics;
    let luma = |v: &[f64; 3]| v[0] * LUMA[0] + v[1] * LUMA[1] + v[2] * LUMA[2];
    let mut plot: [Vec<(f64, f64)>; 6] = Default::default(); // pd, pa, pd smoothed, pa smoothed, pd true, pa true
    for (i, path) in seq.files.iter().enumerate() {
        let t = std::time::Instant::now();
        let frame = Frame::load(path)?;
        frame.check_size(path, k.width, k.height)?;
        let decode_ms = t.elapsed().as_secs_f64() * 1e3;
        let e = est.estimate(i, &seq.times[i], &frame, &lin).with_context(|| format!("{}", path.display()))?;
        let truth = seq.truth.as_ref().map(|t| t[i]);
        let error = match (truth, e.pd, e.pa) {
            (Some(t), Some(pd), Some(pa)) => {
                let (ed, ea) = lighting_error(&pd, &pa, &t.pd, &t.pa);
                errs_pd.push(ed);
                errs_pa.push(ea);
                Some(ErrorPair { pd: ed, pa: ea })
            }
            _ => None,
        };
        *statuses.entry(e.status).or_default() += 1;
        let ts = (seq.times[i] - seq.times[0]).num_milliseconds() as f64 / 1e3;
        if let (Some(pd), Some(pa)) = (e.pd, e.pa) {
            plot[0].push((ts, luma(&pd)));
            plot[1].push((ts, luma(&pa)));
        }
        if let Some(s) = e.smoothed {
            plot[2].push((ts, luma(&s.pd)));
            plot[3].push((ts, luma(&s.pa)));
        }
        if let Some(t) = truth {
            plot[4].push((ts, luma(&t.pd)));
            plot[5].push((ts, luma(&t.pa)));
        }
        ms.push(e.estimate_ms);
        decode.push(decode_ms);
        out.write(&Record { estimate: &e, decode_ms, truth, error })?;
        pb.inc(1);
    }
    pb.finish_and_clear();

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
    if let Some(p) = out.path() {
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
        line_plot_svg(path, &title, "time since first frame (s)", "irradiance (scaled radiance units)", &series, false, false)
            .with_context(|| format!("writing {}", path.display()))?;
        eprintln!("wrote {}", path.display());
    }
    Ok(())
}
