//! `heliar bench estimate --knob moving-sun`: the estimator's time per frame when the sun moves
//! past `sun_rebuild_deg` every frame (issue 13 part 4: no stall when the sun moves), and its
//! error, with the bounce and sky re-trace whole (`trace_paths_per_frame = 0`, as before) and
//! sliced (the scene's budget, or the default).
//!
//! Two sequences, both from the scene's frames:
//! - **truth**: the sequence as it is, with `sun_rebuild_deg = 0`, so every frame's sun (10 s of
//!   solar motion on the courtyard, 0.04°) is a move; the error is against the truth file.
//! - **fast**: `--frames` frames, frame `k` the sequence's frame `k mod n` stamped `k·--sun-step-s`
//!   after the first (120 s: about 0.45°, past the default 0.25° every frame); the images do not
//!   match those suns, so the error against each image's truth is large for both runs; the
//!   last columns give the sliced run's mean difference from the whole run's estimates.
//!
//! Times are the wall time of `Estimator::estimate` (sun-dependent terms and fit), median and
//! maximum over the frames after the first (the first builds everything, set-up). The stage
//! columns are medians of [`heliar::estimate::rebuild::SunTimings`]; the whole run's are where
//! a full rebuild goes.

use anyhow::{Context, Result};
use chrono::{DateTime, Duration, FixedOffset};
use heliar::estimate::rebuild::SunTimings;
use heliar::estimate::{Estimator, EstimatorConfig};
use heliar::io::frames::Frame;
use heliar::report::{Table, lighting_error, median};
use heliar::scene::settings::ESTIMATOR_TRACE_PATHS_PER_FRAME;
use std::path::Path;

/// One run's measurements.
struct Run {
    first_ms: f64,
    ms: Vec<f64>,
    parts: Vec<SunTimings>,
    /// Per frame, `Pd` and `Pa` (None: no estimate).
    est: Vec<Option<([f64; 3], [f64; 3])>>,
}

fn run_one(scene: &heliar::scene::Scene, ray: &std::sync::Arc<heliar::geometry::raycast::RayScene>, cfg: EstimatorConfig, inputs: &[(&Frame, DateTime<FixedOffset>)], lin: &heliar::io::frames::Linearizer) -> Result<Run> {
    let mut est = Estimator::with_camera(cfg, scene.observer, scene.geo, &scene.camera, ray.clone())?;
    let mut r = Run { first_ms: 0.0, ms: vec![], parts: vec![], est: vec![] };
    for (i, (frame, time)) in inputs.iter().enumerate() {
        let t = std::time::Instant::now();
        let e = est.estimate(i, time, frame, lin)?;
        let ms = t.elapsed().as_secs_f64() * 1e3;
        if i == 0 {
            r.first_ms = ms;
        } else {
            r.ms.push(ms);
            r.parts.push(est.sun_timings());
        }
        r.est.push(e.pd.zip(e.pa));
    }
    Ok(r)
}

/// Mean and maximum error (percent) of `run` against `reference` per frame, `Pd` then `Pa`.
fn errors(run: &Run, reference: &[Option<([f64; 3], [f64; 3])>]) -> [f64; 4] {
    let (mut pd, mut pa) = (Vec::new(), Vec::new());
    for (e, t) in run.est.iter().zip(reference) {
        if let (Some((a, b)), Some((ta, tb))) = (e, t) {
            let (x, y) = lighting_error(a, b, ta, tb);
            pd.push(100.0 * x);
            pa.push(100.0 * y);
        }
    }
    let mean = |v: &[f64]| if v.is_empty() { f64::NAN } else { v.iter().sum::<f64>() / v.len() as f64 };
    let max = |v: &[f64]| v.iter().copied().fold(f64::NAN, f64::max);
    [mean(&pd), max(&pd), mean(&pa), max(&pa)]
}

/// Runs the benchmark (module docs) and writes its table to `csv`.
pub fn run(scene: &heliar::scene::Scene, ray: std::sync::Arc<heliar::geometry::raycast::RayScene>, seq: &heliar::scene::Sequence, frames: &[Frame], n_fast: usize, step_s: f64, csv: &Path) -> Result<()> {
    let truth = seq.truth.as_ref().context("the sequence has no truth file")?;
    let lin = seq.photometry.linearizer();
    let budget = match scene.estimator.trace_paths_per_frame {
        0 => ESTIMATOR_TRACE_PATHS_PER_FRAME,
        b => b,
    };
    let real: Vec<(&Frame, DateTime<FixedOffset>)> = frames.iter().zip(seq.times.iter().copied()).collect();
    let t0 = *seq.times.first().context("the sequence has no frames")?;
    let fast: Vec<(&Frame, DateTime<FixedOffset>)> = (0..n_fast)
        .map(|k| (&frames[k % frames.len()], t0 + Duration::milliseconds((k as f64 * step_s * 1e3) as i64)))
        .collect();
    let truth_est: Vec<_> = truth.iter().map(|t| Some((t.pd, t.pa))).collect();
    let mut table = Table::new(&[
        "sequence", "trace_paths_per_frame", "frames", "first_ms", "median_ms", "max_ms", "visibility_ms", "rings_ms", "bounce_ms", "sky_ms",
        "pd_err_mean_pct", "pd_err_max_pct", "pa_err_mean_pct", "pa_err_max_pct", "pd_vs_whole_mean_pct", "pa_vs_whole_mean_pct",
    ]);
    for (name, inputs, rebuild_deg) in [("truth", &real, 0.0), ("fast", &fast, scene.estimator.sun_rebuild_deg)] {
        let mut whole_est = Vec::new();
        for b in [0, budget] {
            let cfg = EstimatorConfig { trace_paths_per_frame: b, sun_rebuild_deg: rebuild_deg, ..scene.estimator.clone() };
            let r = run_one(scene, &ray, cfg, inputs, &lin)?;
            // The fast sequence's images do not match its suns: its error is against each image's
            // truth (both runs alike), and the sliced run's difference from the whole run's.
            let reference: Vec<_> = (0..inputs.len()).map(|k| truth_est[k % truth_est.len()]).collect();
            let err = errors(&r, &reference);
            let diff = if b == 0 { [0.0; 4] } else { errors(&r, &whole_est) };
            let part = |f: fn(&SunTimings) -> f64| format!("{:.1}", median(&r.parts.iter().map(f).collect::<Vec<_>>()));
            let mut row = vec![
                name.to_string(),
                b.to_string(),
                inputs.len().to_string(),
                format!("{:.0}", r.first_ms),
                format!("{:.1}", median(&r.ms)),
                format!("{:.1}", r.ms.iter().copied().fold(0.0, f64::max)),
                part(|t| t.visibility_ms),
                part(|t| t.rings_ms),
                part(|t| t.bounce_ms),
                part(|t| t.sky_ms),
            ];
            row.extend(err.iter().chain(&diff[..1]).chain(&diff[2..3]).map(|e| format!("{e:.3}")));
            table.push(row);
            if b == 0 {
                whole_est = r.est;
            }
        }
    }
    println!(
        "estimator time per frame with the sun past sun_rebuild_deg every frame on '{}' ({}×{}; median and max over the frames after the first; stage columns: medians)",
        seq.name, scene.camera.intrinsics.width, scene.camera.intrinsics.height
    );
    print!("{table}");
    crate::common::write_output(csv, |tmp| Ok(table.write_csv(tmp)?))?;
    println!("wrote {}", csv.display());
    Ok(())
}
