//! `heliar bench render --knob moving-sun`: frame times of the compositor when the sun moves
//! past `bounce_rebuild_deg` every frame (issue 13 part 4: no stall when the sun moves).
//!
//! The scene's reference sequence is estimated once; its frames are then composited in a loop
//! with the estimated lighting, but with the sun turned about the vertical by `--sun-step-deg`
//! (default 0.5°, twice the default threshold) more on every frame, so that the receivers' `b`
//! and the objects' `R_d` must be re-traced every frame. Two settings of
//! `trace_paths_per_frame`: 0 (the re-trace done whole in the frame that decides it, as before)
//! over a few frames, and the default budget (a slice per frame) over many. The first frame
//! traces everything (set-up) and is reported on its own; the median and maximum are over the
//! frames after it. Paths per frame are counted from the pass reports.

use crate::common::{frame_bar, load_scene};
use anyhow::{Context, Result};
use glam::{Quat, Vec3};
use heliar::estimate::Estimator;
use heliar::io::frames::Frame;
use heliar::lighting::Lighting;
use heliar::render::{Compositor, CompositorConfig, TRACE_PATHS_PER_FRAME, VideoFrame};
use heliar::report::{Table, median};
use heliar::run::outdoor::{Ambient, lighting_of, probe_source};
use heliar::gpu::{Gpu, GpuOptions};
use std::path::Path;
use std::sync::Arc;

/// One budget's run.
struct Run {
    budget: u64,
    first_ms: f64,
    frame_ms: Vec<f64>,
    max_paths: u64,
    swaps: usize,
    /// Stage timings of every frame after the first.
    stages: Vec<heliar::render::FrameTimings>,
}

/// Runs the moving-sun benchmark on `scene_dir`: `frames` frames with the default budget (and
/// `min(frames, 4)` unbounded), the sun turned by `step_deg` per frame.
pub fn run(scene_dir: &Path, frames: usize, step_deg: f32, csv: &Path) -> Result<()> {
    let (scene, ray) = load_scene(scene_dir)?;
    let seq = scene.sequences.first().context("the scene has no [[sequences]]")?.clone();
    let lin = seq.photometry.linearizer();
    let mut est = Estimator::new(&scene, ray.clone()).with_context(|| format!("setting up the estimator for {}", scene.root.display()))?;
    let mut probes = probe_source(&scene, ray.clone(), Ambient::Auto, |s, r| crate::bake::bake_with_progress(s, r, false))?;
    let pb = frame_bar(seq.files.len(), "estimate");
    let mut inputs: Vec<(VideoFrame, Lighting)> = Vec::new();
    for (i, path) in seq.files.iter().enumerate() {
        let frame = Frame::load(path).with_context(|| format!("reading {}", path.display()))?;
        let e = est.estimate(i, &seq.times[i], &frame, &lin).with_context(|| format!("estimating {}", path.display()))?;
        inputs.push((VideoFrame::from_frame(&frame, &lin), lighting_of(&e)));
        pb.inc(1);
    }
    pb.finish_and_clear();
    let grid = probes.relight(&inputs[0].1).clone();
    let gpu = Arc::new(Gpu::new(GpuOptions { samples: 4 })?);
    let mut runs = Vec::new();
    for (budget, n) in [(0u64, frames.min(4)), (TRACE_PATHS_PER_FRAME, frames)] {
        let config = CompositorConfig { trace_paths_per_frame: budget, ..CompositorConfig::for_scene(&scene) };
        let paths = (config.bounce_quality.paths as u64 * 2, config.transfer_paths as u64);
        let mut comp = Compositor::for_scene(gpu.clone(), &scene, ray.clone(), config).with_context(|| format!("setting up the compositor for {}", scene.root.display()))?;
        comp.set_probes(&grid);
        let mut r = Run { budget, first_ms: 0.0, frame_ms: Vec::new(), max_paths: 0, swaps: 0, stages: Vec::new() };
        let pb = frame_bar(n, if budget == 0 { "whole re-trace" } else { "sliced re-trace" });
        for k in 0..n {
            let (video, lighting) = &inputs[k % inputs.len()];
            let turn = Quat::from_rotation_y((step_deg * k as f32).to_radians());
            let lighting = Lighting { sun_dir: (turn * lighting.sun_dir).normalize_or(Vec3::Y), ..*lighting };
            let t = std::time::Instant::now();
            let (_, report) = comp.render(video, &lighting)?;
            let ms = t.elapsed().as_secs_f64() * 1e3;
            if k == 0 {
                r.first_ms = ms;
            } else {
                r.frame_ms.push(ms);
                r.stages.push(report.timings);
                // Receivers with the objects: two integrals per pixel (the differential model).
                let p = report.receivers_computed as u64 * paths.0 + report.transfer_traced as u64 * paths.1;
                r.max_paths = r.max_paths.max(p);
                r.swaps += usize::from(report.transfer_traced > 0 && comp.transfer().is_some_and(|t| t.retrace_progress().is_none()));
            }
            pb.inc(1);
        }
        pb.finish_and_clear();
        runs.push(r);
    }
    let mut table = Table::new(&["trace_paths_per_frame", "frames", "first_frame_ms", "median_ms", "max_ms", "max_paths_per_frame", "transfer_swaps"]);
    for r in &runs {
        let max = r.frame_ms.iter().copied().fold(0.0, f64::max);
        table.push(vec![
            r.budget.to_string(),
            (r.frame_ms.len() + 1).to_string(),
            format!("{:.0}", r.first_ms),
            format!("{:.1}", median(&r.frame_ms)),
            format!("{:.1}", max),
            r.max_paths.to_string(),
            r.swaps.to_string(),
        ]);
    }
    println!(
        "compositor frame time on {} with the sun turned {step_deg}° per frame (past bounce_rebuild_deg every frame; {}×{}, software GPU; median and max over the frames after the first, incl. readback)",
        scene_dir.display(),
        scene.camera.intrinsics.width,
        scene.camera.intrinsics.height
    );
    print!("{table}");
    print_stages(&runs);
    crate::common::write_output(csv, |tmp| Ok(table.write_csv(tmp)?))?;
    println!("wrote {}", csv.display());
    Ok(())
}

/// The median of each stage per run, and the stages of its slowest frame.
fn print_stages(runs: &[Run]) {
    type Get = fn(&heliar::render::FrameTimings) -> f64;
    let stages: [(&str, Get); 7] = [
        ("volume_build", |t| t.volume_build_ms),
        ("receivers", |t| t.receivers_ms),
        ("transfer", |t| t.transfer_ms),
        ("region", |t| t.region_ms),
        ("upload", |t| t.upload_ms),
        ("gpu", |t| t.gpu_ms),
        ("readback", |t| t.readback_ms),
    ];
    let mut head = vec!["trace_paths_per_frame", "frame"];
    head.extend(stages.iter().map(|(n, _)| *n));
    let mut table = Table::new(&head);
    for r in runs {
        let Some(slowest) = (0..r.frame_ms.len()).max_by(|&a, &b| r.frame_ms[a].total_cmp(&r.frame_ms[b])) else { continue };
        let mut row = vec![r.budget.to_string(), "median".to_owned()];
        row.extend(stages.iter().map(|(_, f)| format!("{:.1}", median(&r.stages.iter().map(f).collect::<Vec<_>>()))));
        table.push(row);
        let mut row = vec![r.budget.to_string(), format!("slowest ({:.0} ms)", r.frame_ms[slowest])];
        row.extend(stages.iter().map(|(_, f)| format!("{:.1}", f(&r.stages[slowest]))));
        table.push(row);
    }
    println!("stage times, ms (the report's timings)");
    print!("{table}");
}
