//! `heliar bench render`: the compositor's end-to-end error against a scene's reference frames
//! (`reference/`, rendered with the virtual objects physically present), next to its run time,
//! for the quality knobs of the compositor: the per-pixel transfer's paths and lattice stride,
//! MSAA samples and canvas supersampling.
//!
//! # The sun-dependent re-trace between reference frames
//! The reference frames are far apart in the footage's time (the winter scene's are 40 min, the
//! sun 1.6–27° apart), and a sun move past `bounce_rebuild_deg` starts the sliced re-trace of the
//! receivers' `b` (`c_v`, `b_v`) and the objects' `R_d` (issue 13 part 4), which completes over
//! `pool / trace_paths_per_frame` frames (≈ 2 s of 30 fps footage, in which the sun moves by
//! 0.01°). Composited one after the other, a reference frame would be shown with the previous
//! one's terms, a lag that footage at any real frame rate does not have. So each reference frame
//! is measured three ways, and all three are reported:
//! - **settled** (the main columns): the frame composited again after the re-trace it started
//!   has completed (the frames the footage has in between, rendered as the same frame);
//! - **stale** (`stale_*`): a fresh compositor traced for a sun `bounce_rebuild_deg` (× 0.999)
//!   behind the frame's along its path (towards the previous reference frame's sun), then the
//!   frame with its own sun: the largest lag a slowly moving sun leaves in a sequence, since no
//!   re-trace starts below the threshold;
//! - **lag** (`lag_*`): the frame composited as it comes after the previous reference frame,
//!   before any slice of its re-trace (what this bench reported before; a jump between
//!   composited frames no sequence has at a real frame rate).

use crate::common::{frame_bar, load_scene};
use anyhow::{Context, Result, bail};
use clap::{Args, ValueEnum};
use heliar::estimate::Estimator;
use heliar::io::frames::Frame;
use heliar::run::outdoor::{Ambient, lighting_of, probe_source};
use heliar::render::reference::{Classes, CompositeError, References, composite_error};
use heliar::lighting::Lighting;
use heliar::render::{Compositor, CompositorConfig, VideoFrame};
use heliar::gpu::{Gpu, GpuOptions};
use heliar::report::{Series, Table, line_plot_svg, median};
use std::path::PathBuf;
use std::sync::Arc;

#[derive(Clone, Copy, ValueEnum)]
pub enum Knob {
    /// Paths per traced pixel of the objects' ambient transfer: 0 (off: probes × occlusion), 64 … 4096.
    TransferPaths,
    /// Lattice stride of the transfer's traced pixels: 1 … 4 (1024 paths each).
    TransferStride,
    /// MSAA samples: 1, 4.
    Msaa,
    /// Canvas pixels per footage pixel: 1, 1.5, 2.
    Supersample,
    /// Paths per frame of the sun-dependent re-trace: 0 (whole, as before issue 13 part 4) and
    /// the default (sliced); the reference frames are rendered in order by one compositor, so a
    /// re-trace started by the sun's motion between them lags.
    TraceBudget,
    /// Not a sweep: frame times with the sun moving past the re-trace threshold every frame,
    /// the re-trace whole and in per-frame slices (`bench_render_sun`).
    MovingSun,
}

#[derive(Args)]
pub struct RenderSweep {
    /// Scene folder (needs `reference/reference.toml`).
    #[arg(default_value = "scenes/courtyard")]
    scene: PathBuf,
    /// Which knob to sweep.
    #[arg(long, value_enum, default_value = "transfer-paths")]
    knob: Knob,
    /// CSV output.
    #[arg(long, default_value = "out/bench_render.csv")]
    csv: PathBuf,
    /// SVG plot of error against time.
    #[arg(long)]
    plot: Option<PathBuf>,
    /// Write the outputs even over a file of the scene.
    #[arg(long)]
    force: bool,
    /// Frames of the moving-sun benchmark.
    #[arg(long, default_value_t = 40)]
    frames: usize,
    /// Sun motion per frame of the moving-sun benchmark, degrees.
    #[arg(long, default_value_t = 0.5)]
    sun_step_deg: f32,
    /// Light every lamp its schedule has on with this scale `k` instead of the estimator's
    /// (e.g. 1, the dusk scene's truth `lamp_k` on its reference frames), to tell the
    /// compositor's error from the estimator's.
    #[arg(long)]
    lamp_k: Option<f32>,
    /// The lamps' `k` from the forward filter only (the frames up to each reference frame), as
    /// the live window has it, instead of in hindsight over the whole sequence as `heliar
    /// augment` renders it.
    #[arg(long)]
    no_hindsight: bool,
    /// Leave out the objects' lamp shadows on real receivers (`lamp_ground`), to measure what
    /// they add.
    #[arg(long)]
    no_lamp_ground: bool,
    /// Leave out the lamps' light bounced onto the objects (`lamp_bounce`), to measure what it
    /// adds.
    #[arg(long)]
    no_lamp_bounce: bool,
    /// Leave out the lamps' light bounced onto the real receivers in the ground shadows' ratio
    /// (`render::lamps::ground_bounce`), to measure what it adds.
    #[arg(long)]
    no_lamp_ground_bounce: bool,
    /// Hard lamp shadows from the lamps' centres instead of the penumbrae of their luminous
    /// openings (`ShadowView::with_emitter`), to measure what the penumbra changes.
    #[arg(long)]
    hard_lamp_shadows: bool,
    /// Not a sweep: the objects' radiance split by light (sky, sun, lamps) under the truth's
    /// `Pd` and `Pa`, against the generator's per-light crops in this folder
    /// (`gen-courtyard --dusk-parts DIR`; `bench_render_parts`).
    #[arg(long, value_name = "DIR")]
    parts: Option<PathBuf>,
    /// Write each setting's settled composite of every reference frame, cropped as the
    /// reference (`<setting>_frame_NNN.exr`), into this folder, to look at where the error is
    #[arg(long, value_name = "DIR")]
    dump: Option<PathBuf>,
}

/// One reference frame: its footage, lighting, reference image and pixel classes.
pub(crate) struct RefFrame {
    pub(crate) index: usize,
    pub(crate) video: VideoFrame,
    pub(crate) lighting: Lighting,
    pub(crate) grid: heliar::irradiance::ProbeGrid,
    pub(crate) reference: heliar::io::image::LinearImage,
    pub(crate) classes: Classes,
}

struct Row {
    label: String,
    /// Each frame after its re-trace has completed.
    errors: Vec<CompositeError>,
    /// Each frame as composited right after the previous one (before its re-trace's slices).
    lag_errors: Vec<CompositeError>,
    /// Each frame with the terms traced for a sun `bounce_rebuild_deg` behind its own.
    stale_errors: Vec<CompositeError>,
    /// Most frames a re-trace took to complete.
    settle_frames: usize,
    traced: usize,
    stride: u32,
    transfer_ms: f64,
    setup_ms: f64,
    frame_ms: f64,
}

fn ms(t: std::time::Instant) -> f64 {
    t.elapsed().as_secs_f64() * 1e3
}

pub fn run(a: RenderSweep) -> Result<()> {
    if let Knob::MovingSun = a.knob {
        crate::common::guard_files(Some(&a.scene), &[], &[a.csv.as_path()], a.force)?;
        return crate::bench_render_sun::run(&a.scene, a.frames.max(2), a.sun_step_deg, &a.csv);
    }
    let (scene, ray) = load_scene(&a.scene)?;
    let outputs: Vec<&std::path::Path> = std::iter::once(&a.csv).chain(&a.plot).map(PathBuf::as_path).collect();
    crate::common::guard_files(Some(&scene.root), &[], &outputs, a.force)?;
    let Some(refs) = References::load(&scene)? else {
        bail!("{}: no reference/reference.toml (frames rendered with the virtual objects present; see scenes/README.md)", scene.root.display());
    };
    if scene.virtual_objects.is_empty() {
        bail!("{}: no [[virtual_objects]] to composite", scene.root.join(heliar::scene::MANIFEST_FILE).display());
    }
    let seq = scene.sequence(refs.sequence.as_deref()).context("the references' sequence")?.clone();
    let frames = reference_frames(&scene, &ray, &refs, &seq, a.lamp_k, a.no_hindsight)?;
    let options = heliar::render::lamps::LampOptions { ground: !a.no_lamp_ground, bounce: !a.no_lamp_bounce, ground_bounce: !a.no_lamp_ground_bounce, soft_shadows: !a.hard_lamp_shadows, ..Default::default() };
    if let Some(parts) = &a.parts {
        return crate::bench_render_parts::run(&scene, &ray, &frames, seq.truth.as_deref(), parts, options);
    }
    let values = knob_values(a.knob, &CompositorConfig::for_scene(&scene));
    if let Some(dir) = &a.dump {
        heliar::io::guard::OutputGuard::new(Some(&scene.root), &[], a.force).check_dir(dir)?;
        std::fs::create_dir_all(dir).with_context(|| format!("creating {}", dir.display()))?;
    }
    let rows = sweep(&scene, &ray, &frames, values, options, a.dump.as_deref())?;
    report(&a, &rows, &frames)
}

/// Estimates the whole sequence, as `heliar augment` does before it renders (the smoothing needs
/// the frames before, the lamps' `k` in hindsight those after: `estimate::hindsight`, left out
/// with `forward_only`), and keeps what the references need; `lamp_k` replaces the scale of every
/// lamp the schedule has on.
pub(crate) fn reference_frames(scene: &heliar::scene::Scene, ray: &Arc<heliar::geometry::raycast::RayScene>, refs: &References, seq: &heliar::scene::Sequence, lamp_k: Option<f32>, forward_only: bool) -> Result<Vec<RefFrame>> {
    let (scene, ray) = (scene, ray.clone());
    let lin = seq.photometry.linearizer();
    let mut est = Estimator::new(&scene, ray.clone()).with_context(|| format!("setting up the estimator for {}", scene.root.display()))?;
    let mut probes = probe_source(&scene, ray.clone(), Ambient::Auto, |s, r| crate::bake::bake_with_progress(s, r, false))?;
    let mut objects = heliar::geometry::Mesh::default();
    for o in &scene.virtual_objects {
        objects.append(&o.mesh);
    }
    let objects = heliar::geometry::raycast::RayScene::new(objects);

    // Every frame's estimate; the reference frames' footage kept.
    let mut estimates = Vec::new();
    let mut kept = Vec::new();
    let pb = frame_bar(seq.files.len(), "estimate");
    for (i, path) in seq.files.iter().enumerate() {
        let frame = Frame::load(path).with_context(|| format!("reading {}", path.display()))?;
        estimates.push(est.estimate(i, &seq.times[i], &frame, &lin).with_context(|| format!("estimating {}", path.display()))?);
        if refs.frames.contains(&i) {
            kept.push((i, frame));
        }
        pb.inc(1);
    }
    pb.finish_and_clear();
    if !forward_only && !scene.lights.is_empty() {
        let ts = |i: usize| (seq.times[i] - seq.times[0]).num_milliseconds() as f64 / 1e3;
        let h = heliar::estimate::hindsight::LampHindsight::from_reports(scene, estimates.iter().map(|e| (e.frame, ts(e.frame), &e.lamps[..])));
        for e in &mut estimates {
            h.apply(e.frame, &mut e.lamps);
        }
    }

    let mut frames = Vec::new();
    for (i, frame) in kept {
        let Some(k) = refs.frames.iter().position(|&f| f == i) else { continue };
        let e = &estimates[i];
        let mut lighting = lighting_of(e);
        if let Some(k) = lamp_k {
            let scales: Vec<[f32; 3]> = e.lamps.iter().map(|l| if l.status == heliar::estimate::LampStatus::Off { [0.0; 3] } else { [k; 3] }).collect();
            lighting.lamps = heliar::lighting::LampScales::from_slice(&scales);
        }
        let grid = probes.relight(&lighting).clone();
        // With lamps on, the shadow that matters is theirs (issue 16 §4: "the object and its
        // lamp shadow"), with the sun's while it is up; without, the sun's as before.
        // A lamp is on by its schedule, whatever the estimator's `k`.
        let lit: Vec<glam::Vec3> = scene.lights.iter().zip(&e.lamps).filter(|(_, r)| r.status != heliar::estimate::LampStatus::Off).map(|(l, _)| l.position.as_vec3()).collect();
        let classes = if lit.is_empty() {
            Classes::new(&scene, &objects, &ray, refs.crop, lighting.sun_dir)
        } else {
            Classes::with_lamps(&scene, &objects, &ray, refs.crop, lighting.above_horizon.then_some(lighting.sun_dir), &lit)
        };
        frames.push(RefFrame { index: i, video: VideoFrame::from_frame(&frame, &lin), lighting, grid, reference: refs.image(k)?, classes });
    }
    Ok(frames)
}

/// The compositor settings of a sweep over `knob`, with their labels and MSAA sample counts.
fn knob_values(knob: Knob, base: &CompositorConfig) -> Vec<(String, CompositorConfig, u32)> {
    match knob {
        Knob::TransferPaths => [0u32, 64, 128, 256, 512, 1024, 2048, 4096]
            .iter()
            .map(|&p| (p.to_string(), CompositorConfig { transfer_paths: p, transfer_stride: 1, ..base.clone() }, 4))
            .collect(),
        Knob::TransferStride => [1u32, 2, 3, 4].iter().map(|&s| (s.to_string(), CompositorConfig { transfer_stride: s, ..base.clone() }, 4)).collect(),
        Knob::Msaa => [1u32, 4].iter().map(|&m| (m.to_string(), base.clone(), m)).collect(),
        Knob::Supersample => [1.0f64, 1.5, 2.0].iter().map(|&s| (s.to_string(), CompositorConfig { supersample: s, ..base.clone() }, 4)).collect(),
        Knob::TraceBudget => [0u64, heliar::render::TRACE_PATHS_PER_FRAME]
            .iter()
            .map(|&b| (b.to_string(), CompositorConfig { trace_paths_per_frame: b, ..base.clone() }, 4))
            .collect(),
        Knob::MovingSun => Vec::new(),
    }
}

/// Runs the compositor once per setting over the reference frames, with the lamps' `options`.
fn sweep(scene: &heliar::scene::Scene, ray: &Arc<heliar::geometry::raycast::RayScene>, frames: &[RefFrame], values: Vec<(String, CompositorConfig, u32)>, options: heliar::render::lamps::LampOptions, dump: Option<&std::path::Path>) -> Result<Vec<Row>> {
    let mut gpus: Vec<(u32, Arc<Gpu>)> = Vec::new();
    let pb = frame_bar(values.len(), "sweep");
    let mut rows = Vec::new();
    for (label, config, samples) in values {
        let gpu = match gpus.iter().find(|(s, _)| *s == samples) {
            Some((_, g)) => g.clone(),
            None => {
                let g = Arc::new(Gpu::new(GpuOptions { samples })?);
                gpus.push((samples, g.clone()));
                g
            }
        };
        let t = std::time::Instant::now();
        let mut comp = Compositor::for_scene(gpu, scene, ray.clone(), config.clone()).with_context(|| format!("setting up the compositor for {}", scene.root.display()))?;
        if options != heliar::render::lamps::LampOptions::default() && !scene.lights.is_empty() {
            let lamps = heliar::lamps::Lamp::load_all(&scene.root.join(heliar::scene::MANIFEST_FILE), &scene.lights)?;
            comp.set_lamps(&lamps, options)?;
        }
        let setup_ms = ms(t);
        let (mut errors, mut frame_ms, mut transfer_ms, mut traced) = (Vec::new(), Vec::new(), 0.0f64, 0usize);
        let (mut lag_errors, mut stale_errors, mut settle_frames) = (Vec::new(), Vec::new(), 0usize);
        for (k, f) in frames.iter().enumerate() {
            comp.set_probes(&f.grid);
            // A cold frame (transfer and receivers traced as on a run's first frame, or the
            // previous frame's terms while this frame's re-trace has just started) …
            let (out, report) = comp.render(&f.video, &f.lighting)?;
            transfer_ms = transfer_ms.max(report.timings.transfer_ms);
            traced = traced.max(report.transfer_traced);
            let lag = composite_error(&f.classes, &out.image, &f.reference);
            // … then the frames the footage has before this one's re-trace completes …
            let n = settle(&mut comp, f)?;
            settle_frames = settle_frames.max(n);
            let settled = if n == 0 { out.image } else { comp.render(&f.video, &f.lighting)?.0.image };
            let e = if n == 0 { lag } else { composite_error(&f.classes, &settled, &f.reference) };
            if let Some(dir) = dump {
                dump_crop(&dir.join(format!("{label}_frame_{:03}.exr", f.index)), &settled, &f.classes)?;
            }
            print_error(&label, f.index, "settled", &e);
            if n > 0 {
                print_error(&label, f.index, &format!("lag (before the {n} frames of its re-trace)"), &lag);
            }
            // … and the terms a slowly moving sun leaves behind (a fresh compositor).
            let toward = if k > 0 { Some((frames[k - 1].lighting.sun_dir, 1.0)) } else { frames.get(1).map(|g| (g.lighting.sun_dir, -1.0)) };
            let stale = match toward {
                Some((other, sign)) => {
                    let sun = sun_towards(f.lighting.sun_dir, other, sign * STALE_SHARE * config.bounce_rebuild_deg);
                    let mut fresh = Compositor::for_scene(comp.gpu().clone(), scene, ray.clone(), config.clone())?;
                    if options != heliar::render::lamps::LampOptions::default() && !scene.lights.is_empty() {
                        let lamps = heliar::lamps::Lamp::load_all(&scene.root.join(heliar::scene::MANIFEST_FILE), &scene.lights)?;
                        fresh.set_lamps(&lamps, options)?;
                    }
                    fresh.set_probes(&f.grid);
                    fresh.render(&f.video, &Lighting { sun_dir: sun, ..f.lighting })?;
                    settle(&mut fresh, f)?;
                    let e = composite_error(&f.classes, &fresh.render(&f.video, &f.lighting)?.0.image, &f.reference);
                    print_error(&label, f.index, &format!("stale (terms traced {:.3}° behind)", STALE_SHARE * config.bounce_rebuild_deg), &e);
                    e
                }
                None => e,
            };
            errors.push(e);
            lag_errors.push(lag);
            stale_errors.push(stale);
            // The steady frame time of the same frame.
            comp.invalidate();
            let t = std::time::Instant::now();
            comp.render(&f.video, &f.lighting)?;
            frame_ms.push(ms(t));
        }
        let stride = comp.transfer().map(|t| t.stride()).unwrap_or(0);
        rows.push(Row { label, errors, lag_errors, stale_errors, settle_frames, traced, stride, transfer_ms, setup_ms, frame_ms: median(&frame_ms) });
        pb.inc(1);
    }
    pb.finish_and_clear();

    Ok(rows)
}

/// Writes the reference's crop of `image` to `path`.
fn dump_crop(path: &std::path::Path, image: &heliar::io::image::LinearImage, classes: &Classes) -> Result<()> {
    let c = classes.crop;
    let crop = heliar::io::image::LinearImage::from_fn(c.width, c.height, |x, y| image.get(c.x + x, c.y + y));
    crate::common::write_output(path, |tmp| Ok(crop.write_exr(tmp, heliar::io::image::ExrPrecision::Float)?))
}

/// The share of `bounce_rebuild_deg` by which the stale measurement's sun lags (just under the
/// threshold, so that the frame with its own sun starts no re-trace).
const STALE_SHARE: f64 = 0.999;

/// Most frames a re-trace may take before the bench gives up (the default budget completes the
/// winter scene's in 64).
const MAX_SETTLE_FRAMES: usize = 100_000;

/// Renders `f` until no sun-dependent re-trace is in progress; returns the frames rendered.
fn settle(comp: &mut Compositor, f: &RefFrame) -> Result<usize> {
    let busy = |c: &Compositor| c.receivers().retrace_progress().is_some() || c.transfer().is_some_and(|t| t.retrace_progress().is_some());
    let mut n = 0;
    while busy(comp) {
        if n == MAX_SETTLE_FRAMES {
            bail!("frame {}: the re-trace did not complete in {MAX_SETTLE_FRAMES} frames", f.index);
        }
        comp.render(&f.video, &f.lighting)?;
        n += 1;
    }
    Ok(n)
}

/// `sun` turned by `deg` degrees towards `other` along the great circle through both (away
/// from it for a negative `deg`); `sun` itself when the two are parallel.
fn sun_towards(sun: glam::Vec3, other: glam::Vec3, deg: f64) -> glam::Vec3 {
    let axis = sun.cross(other);
    if axis.length() < 1e-6 {
        return sun;
    }
    (glam::Quat::from_axis_angle(axis.normalize(), (deg as f32).to_radians()) * sun).normalize()
}

/// One line of a frame's error on stderr.
fn print_error(label: &str, index: usize, what: &str, e: &CompositeError) {
    eprintln!(
        "{label}, frame {index}, {what}: {:.2}% (object {:.2}%, shadow {:.2}%, {} px; away from 1-px edges {:.2}%, {} px); object mean {:.4} against the reference's {:.4}, shadow mean {:.5} against {:.5}",
        100.0 * e.object_and_shadow,
        100.0 * e.object,
        100.0 * e.shadow,
        e.pixels,
        100.0 * e.interior,
        e.interior_pixels,
        e.object_mean,
        e.object_mean_reference,
        e.shadow_mean,
        e.shadow_mean_reference
    );
}

/// Prints the table, writes the CSV and the plot.
fn report(a: &RenderSweep, rows: &[Row], frames: &[RefFrame]) -> Result<()> {
    let name = match a.knob {
        Knob::TransferPaths => "transfer_paths",
        Knob::TransferStride => "transfer_stride",
        Knob::Msaa => "msaa_samples",
        Knob::Supersample => "supersample",
        Knob::TraceBudget => "trace_paths_per_frame",
        Knob::MovingSun => "moving_sun",
    };
    let mut table = Table::new(&[name, "worst_pct", "mean_pct", "object_pct", "shadow_pct", "interior_pct", "traced_px", "stride", "transfer_ms", "frame_ms", "setup_ms", "stale_worst_pct", "stale_mean_pct", "lag_worst_pct", "lag_mean_pct", "settle_frames"]);
    let mut pts = Vec::new();
    for r in rows {
        let n = r.errors.len().max(1) as f64;
        let worst = r.errors.iter().map(|e| e.object_and_shadow).fold(0.0, f64::max);
        let worst_of = |v: &[CompositeError]| 100.0 * v.iter().map(|e| e.object_and_shadow).fold(0.0, f64::max);
        let mean_of = |v: &[CompositeError]| 100.0 * v.iter().map(|e| e.object_and_shadow).sum::<f64>() / v.len().max(1) as f64;
        let mean = |f: &dyn Fn(&CompositeError) -> f64| 100.0 * r.errors.iter().map(f).sum::<f64>() / n;
        table.push(vec![
            r.label.clone(),
            format!("{:.2}", 100.0 * worst),
            format!("{:.2}", mean(&|e| e.object_and_shadow)),
            format!("{:.2}", mean(&|e| e.object)),
            format!("{:.2}", mean(&|e| e.shadow)),
            format!("{:.2}", mean(&|e| e.interior)),
            r.traced.to_string(),
            r.stride.to_string(),
            format!("{:.0}", r.transfer_ms),
            format!("{:.1}", r.frame_ms),
            format!("{:.0}", r.setup_ms),
            format!("{:.2}", worst_of(&r.stale_errors)),
            format!("{:.2}", mean_of(&r.stale_errors)),
            format!("{:.2}", worst_of(&r.lag_errors)),
            format!("{:.2}", mean_of(&r.lag_errors)),
            r.settle_frames.to_string(),
        ]);
        let cost = match a.knob {
            Knob::TransferPaths | Knob::TransferStride => r.transfer_ms,
            _ => r.frame_ms,
        };
        pts.push((cost.max(1e-3), mean(&|e| e.object_and_shadow)));
    }
    let frame_list: Vec<String> = frames.iter().map(|f| f.index.to_string()).collect();
    println!(
        "compositor sweep on {} (reference frames {}: relative RMSE over the objects and their shadow, all channels, each frame after the re-trace its sun move started has completed; mean and worst over the frames; stale_*: the terms traced for a sun bounce_rebuild_deg behind; lag_*: each frame right after the previous one, before its re-trace, in settle_frames frames; transfer_ms: one trace, frame_ms: median steady frame incl. readback)",
        a.scene.display(),
        frame_list.join(", ")
    );
    print!("{table}");
    crate::common::write_output(&a.csv, |tmp| Ok(table.write_csv(tmp)?))?;
    println!("wrote {}", a.csv.display());
    if let Some(path) = &a.plot {
        let x = match a.knob {
            Knob::TransferPaths | Knob::TransferStride => "transfer trace time (ms)",
            _ => "frame time (ms)",
        };
        crate::common::write_output(path, |tmp| Ok(line_plot_svg(tmp, &format!("end-to-end error against run time ({name})"), x, "relative RMSE, objects and shadow (%)", &[Series { name: "mean over reference frames".into(), points: pts, reference: false }], true, false)?))?;
        println!("wrote {}", path.display());
    }
    Ok(())
}
