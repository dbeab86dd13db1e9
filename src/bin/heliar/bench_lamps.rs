//! `heliar bench lamps`: error against run time of the lamps (issue 16 §5; Granier et al. 2003,
//! `../shared/papers/granier-2003-complex-light-sources.txt`, §3–4 and Table 1).
//!
//! Knobs:
//! - `field`: the light field's filter grid (3×3 … 9×9), texture resolution and storage format
//!   (`lamps::lightfield::curves::sweep`: the synthetic torch measured at `--distance`, the
//!   exact reconstruction (Eq. 5) and the textured spots (Eq. 14) against the true emitter on a
//!   receiver plane at `--depth`), with the CPU times and the GPU frame time of each grid on the
//!   scene (`bench_lamps_gpu`; the GPU keeps half floats whatever the format);
//! - `shadow-map`: the lamp shadow maps' size against the scene's path-traced references (the
//!   truth's `k = 1`, so the error is the compositor's), with the frame time;
//! - `frame-size`: frame time at each `--sizes` with the scene's objects and a torus of
//!   `--triangles`, without lamps, with the scene's lamps and with 5×5 and 9×7 light fields;
//! - `lamp-count`: frame time against the number of far-field lamps (copies of the scene's
//!   first lamp on a ring about the objects).

use crate::bench_lamps_gpu::{GpuBench, frame_ms, light_field_lamp, night, resized, resized_video, ring_of, table1_lamps, triangles, with_torus};
use crate::common::frame_bar;
use anyhow::{Context, Result, bail};
use clap::{Args, ValueEnum};
use heliar::lamps::lightfield::curves::{SweepRow, sweep, sweep_table};
use heliar::lamps::lightfield::synthetic::TorchEmitter;
use heliar::lamps::storage::StorageFormat;
use heliar::render::lamps::LampOptions;
use heliar::render::reference::{References, composite_error};
use heliar::report::{Series, Table, line_plot_svg};
use std::path::{Path, PathBuf};

#[derive(Clone, Copy, ValueEnum)]
pub enum Knob {
    /// Filter grid × texels × storage format against the true emitter, with CPU and GPU times.
    Field,
    /// Shadow-map size against the scene's reference frames, with the frame time.
    ShadowMap,
    /// Frame time against frame size, object and lamp kind (the paper's Table 1).
    FrameSize,
    /// Frame time against the number of far-field lamps.
    LampCount,
}

#[derive(Clone, Copy, ValueEnum)]
enum Format {
    F32,
    Half,
    Rgb9e5,
    Srgbe,
}

impl From<Format> for StorageFormat {
    fn from(f: Format) -> Self {
        match f {
            Format::F32 => StorageFormat::F32,
            Format::Half => StorageFormat::Half,
            Format::Rgb9e5 => StorageFormat::Rgb9e5,
            Format::Srgbe => StorageFormat::Srgbe,
        }
    }
}

#[derive(Args)]
pub struct LampsSweep {
    /// Scene folder (lamps, objects; `shadow-map` needs `reference/reference.toml`).
    #[arg(default_value = "scenes/dusk")]
    scene: PathBuf,
    /// Which knob to sweep.
    #[arg(long, value_enum, default_value = "field")]
    knob: Knob,
    /// `field`: filter positions per axis.
    #[arg(long, value_delimiter = ',', default_values_t = [3usize, 5, 7, 9])]
    filters: Vec<usize>,
    /// `field`: texels per axis of the images.
    #[arg(long, value_delimiter = ',', default_values_t = [16u32, 32, 64])]
    texels: Vec<u32>,
    /// `field`: storage formats (f32 is the reference).
    #[arg(long, value_enum, value_delimiter = ',', default_values_t = [Format::F32, Format::Half, Format::Srgbe, Format::Rgb9e5])]
    formats: Vec<Format>,
    /// `field`: distance of the measurement plane from the sampling plane, metres.
    #[arg(long, default_value_t = 0.5)]
    distance: f64,
    /// `field`: depth of the receiver plane below the lamp, metres.
    #[arg(long, default_value_t = 1.0)]
    depth: f64,
    /// `field`: emitter points per axis of the acquisition and of the truth.
    #[arg(long, default_value_t = 32)]
    emitter_points: usize,
    /// `shadow-map`: map sizes, texels per side.
    #[arg(long, value_delimiter = ',', default_values_t = [64u32, 128, 256, 512, 1024, 2048])]
    tiles: Vec<u32>,
    /// `frame-size`: frame sizes, WxH.
    #[arg(long, value_delimiter = ',', default_values_t = ["320x240".to_string(), "640x480".to_string()])]
    sizes: Vec<String>,
    /// `frame-size`: triangles of the generated torus (0: the scene's objects only).
    #[arg(long, default_value_t = 100_000)]
    triangles: usize,
    /// `lamp-count`: numbers of far-field lamps.
    #[arg(long, value_delimiter = ',', default_values_t = [0usize, 1, 2, 4, 8, 16, 32, 64])]
    lamps: Vec<usize>,
    /// CSV output.
    #[arg(long, default_value = "out/bench_lamps.csv")]
    csv: PathBuf,
    /// SVG plot.
    #[arg(long)]
    plot: Option<PathBuf>,
    /// Write the outputs even over a file of the scene.
    #[arg(long)]
    force: bool,
}

/// A table and its plot's series and labels.
struct Outcome {
    title: String,
    table: Table,
    series: Vec<Series>,
    x_label: &'static str,
    y_label: &'static str,
    log_y: bool,
}

pub fn run(a: LampsSweep) -> Result<()> {
    let outputs: Vec<&Path> = std::iter::once(&a.csv).chain(&a.plot).map(PathBuf::as_path).collect();
    crate::common::guard_files(Some(&a.scene), &[], &outputs, a.force)?;
    let bench = GpuBench::new(&a.scene)?;
    let out = match a.knob {
        Knob::Field => field(&a, &bench)?,
        Knob::ShadowMap => shadow_map(&a, &bench)?,
        Knob::FrameSize => frame_size(&a, &bench)?,
        Knob::LampCount => lamp_count(&a, &bench)?,
    };
    println!("{}", out.title);
    print!("{}", out.table);
    crate::common::write_output(&a.csv, |tmp| Ok(out.table.write_csv(tmp)?))?;
    println!("wrote {}", a.csv.display());
    if let Some(path) = &a.plot {
        crate::common::write_output(path, |tmp| Ok(line_plot_svg(tmp, "lamps: error against run time", out.x_label, out.y_label, &out.series, true, out.log_y)?))?;
        println!("wrote {}", path.display());
    }
    Ok(())
}

fn field(a: &LampsSweep, bench: &GpuBench) -> Result<Outcome> {
    if a.filters.iter().any(|&m| !(2..=heliar::lamps::lightfield::MAX_FILTERS_PER_AXIS).contains(&m)) || a.texels.iter().any(|&t| t < 2) {
        bail!("--filters must be in 2..={} and --texels at least 2", heliar::lamps::lightfield::MAX_FILTERS_PER_AXIS);
    }
    let torch = TorchEmitter::default();
    let formats: Vec<StorageFormat> = a.formats.iter().map(|&f| f.into()).collect();
    // CPU: one grid at a time, for the progress bar.
    let pb = frame_bar(a.filters.len() * a.texels.len(), "light fields (CPU)");
    let mut rows: Vec<SweepRow> = Vec::new();
    for &m in &a.filters {
        for &t in &a.texels {
            rows.extend(sweep(&torch, &[m], &[t], &formats, a.distance, a.depth, a.emitter_points).with_context(|| format!("the {m}x{m} torch at {t}² texels"))?);
            pb.inc(1);
        }
    }
    pb.finish_and_clear();
    // GPU: the lamp cost of each grid and resolution on the scene.
    let mut comp = bench.compositor(&bench.scene)?;
    let (base_ms, _) = frame_ms(&mut comp, &bench.video, &night(0))?;
    let (at, place) = (bench.objects_centre(), bench.objects_centre() + glam::Vec3::new(1.0, 3.0, 1.5));
    let pb = frame_bar(a.filters.len() * a.texels.len(), "light fields (GPU)");
    let mut gpu_ms = Vec::new();
    for &m in &a.filters {
        for &t in &a.texels {
            comp.set_lamps(&[light_field_lamp([m, m], t, place, at)?], LampOptions::default())?;
            let (ms, ran) = frame_ms(&mut comp, &bench.video, &night(1))?;
            if !ran {
                bail!("the {m}x{m} light field did not light the objects of {}: nothing measured", a.scene.display());
            }
            gpu_ms.push(((m, t), ms));
            pb.inc(1);
        }
    }
    pb.finish_and_clear();
    let mut table = sweep_table(&rows);
    table.headers.extend(["gpu_frame_ms".to_string(), "gpu_lamp_ms".to_string()]);
    let mut series: Vec<Series> = formats.iter().map(|f| Series { name: format!("spots, {}", f.name()), points: Vec::new(), reference: false }).collect();
    for (cells, r) in table.rows.iter_mut().zip(&rows) {
        let ms = gpu_ms.iter().find(|(k, _)| *k == (r.filters, r.resolution)).map_or(f64::NAN, |(_, ms)| *ms);
        cells.extend([format!("{ms:.1}"), format!("{:.1}", ms - base_ms)]);
        if let Some(i) = formats.iter().position(|f| *f == r.format) {
            series[i].points.push((ms.max(1e-3), (100.0 * r.spots.rel_rms).max(1e-4)));
        }
    }
    series.iter_mut().for_each(|s| s.points.sort_by(|p, q| p.0.total_cmp(&q.0)));
    let k = &bench.scene.camera.intrinsics;
    let title = format!(
        "lamps, field: torch measured at d = {} m, receivers {} m below, relative RMS against the true emitter; CPU times over {}² receivers (parallel); GPU: one light field on {} at {}x{}, {base_ms:.1} ms without it",
        a.distance,
        a.depth,
        heliar::lamps::lightfield::curves::RECEIVERS_PER_AXIS,
        a.scene.display(),
        k.width,
        k.height
    );
    Ok(Outcome { title, table, series, x_label: "GPU frame time (ms)", y_label: "textured spots' relative RMS error (%)", log_y: true })
}

fn shadow_map(a: &LampsSweep, bench: &GpuBench) -> Result<Outcome> {
    let scene = &bench.scene;
    let Some(refs) = References::load(scene)? else {
        bail!("{}: no reference/reference.toml (frames rendered with the virtual objects present)", scene.root.display());
    };
    if scene.lights.is_empty() {
        bail!("{}: no [[lights]] whose shadow maps to size", scene.root.join(heliar::scene::MANIFEST_FILE).display());
    }
    let seq = scene.sequence(refs.sequence.as_deref()).context("the references' sequence")?.clone();
    let frames = crate::bench_render::reference_frames(scene, &bench.ray, &refs, &seq, Some(1.0), false)?;
    let lamps = bench.scene_lamps()?;
    let mut table = Table::new(&["tile", "mean_pct", "worst_pct", "object_pct", "shadow_pct", "frame_ms"]);
    let mut points = Vec::new();
    let pb = frame_bar(a.tiles.len(), "shadow-map sizes");
    for &tile in &a.tiles {
        let mut comp = bench.compositor(scene)?;
        comp.set_lamps(&lamps, LampOptions { tile: tile.max(1), ..LampOptions::default() })?;
        let (mut errors, mut times) = (Vec::new(), Vec::new());
        for f in &frames {
            comp.set_probes(&f.grid);
            let (out, _) = comp.render(&f.video, &f.lighting)?;
            errors.push(composite_error(&f.classes, &out.image, &f.reference));
            times.push(frame_ms(&mut comp, &f.video, &f.lighting)?.0);
        }
        let n = errors.len().max(1) as f64;
        let mean = |g: fn(&heliar::render::reference::CompositeError) -> f64| 100.0 * errors.iter().map(g).sum::<f64>() / n;
        let worst = 100.0 * errors.iter().map(|e| e.object_and_shadow).fold(0.0, f64::max);
        let ms = heliar::report::median(&times);
        points.push((ms, mean(|e| e.object_and_shadow)));
        table.push(vec![tile.to_string(), format!("{:.2}", mean(|e| e.object_and_shadow)), format!("{worst:.2}"), format!("{:.2}", mean(|e| e.object)), format!("{:.2}", mean(|e| e.shadow)), format!("{ms:.1}")]);
        pb.inc(1);
    }
    pb.finish_and_clear();
    let list: Vec<String> = frames.iter().map(|f| f.index.to_string()).collect();
    let title = format!(
        "lamps, shadow-map size on {} (reference frames {}, lamp k = 1 as in the truth; relative RMSE over the objects and their shadow; frame time: median over the frames)",
        a.scene.display(),
        list.join(", ")
    );
    Ok(Outcome { title, table, series: vec![Series { name: "objects and shadow".into(), points, reference: false }], x_label: "frame time (ms)", y_label: "relative RMSE against the references (%)", log_y: false })
}

/// `WxH`.
fn parse_size(s: &str) -> Result<(u32, u32)> {
    let (w, h) = s.split_once('x').with_context(|| format!("--sizes: '{s}' is not WxH"))?;
    let (w, h): (u32, u32) = (w.trim().parse().with_context(|| format!("--sizes: width of '{s}'"))?, h.trim().parse().with_context(|| format!("--sizes: height of '{s}'"))?);
    if w == 0 || h == 0 || w > 8192 || h > 8192 {
        bail!("--sizes: '{s}' must be 1..=8192 on each side");
    }
    Ok((w, h))
}

fn frame_size(a: &LampsSweep, bench: &GpuBench) -> Result<Outcome> {
    let sizes: Vec<(u32, u32)> = a.sizes.iter().map(|s| parse_size(s)).collect::<Result<_>>()?;
    let mut objects = vec![("scene".to_string(), bench.scene.clone())];
    if a.triangles > 0 {
        objects.push(("torus".to_string(), with_torus(&bench.scene, a.triangles, bench.objects_centre())?));
    }
    let sets = table1_lamps(bench, 32)?;
    let mut table = Table::new(&["object", "triangles", "size", "lamps", "frame_ms", "fps", "lamp_ms", "lamp_term"]);
    let mut series: Vec<Series> = Vec::new();
    let pb = frame_bar(objects.len() * sizes.len() * sets.len(), "frame sizes");
    for (name, scene) in &objects {
        for &(w, h) in &sizes {
            let mut comp = bench.compositor(&resized(scene, w, h))?;
            let video = resized_video(&bench.video, w, h);
            let mut none_ms = f64::NAN;
            for set in &sets {
                comp.set_lamps(&set.lamps, LampOptions::default())?;
                let (ms, ran) = frame_ms(&mut comp, &video, &night(set.lamps.len()))?;
                if set.lamps.is_empty() {
                    none_ms = ms;
                }
                let label = format!("{name}, {}", set.label);
                match series.iter_mut().find(|s| s.name == label) {
                    Some(s) => s.points.push(((w * h) as f64, ms)),
                    None => series.push(Series { name: label, points: vec![((w * h) as f64, ms)], reference: false }),
                }
                table.push(vec![name.clone(), triangles(scene).to_string(), format!("{w}x{h}"), set.label.clone(), format!("{ms:.1}"), format!("{:.2}", 1e3 / ms), format!("{:.1}", ms - none_ms), ran.to_string()]);
                pb.inc(1);
            }
        }
    }
    pb.finish_and_clear();
    let title = format!("lamps, frame time on {} (software GPU; night lighting, every lamp at k = 1; 32² light-field images; median of {} frames with the maps redrawn)", a.scene.display(), crate::bench_lamps_gpu::TIMED_FRAMES);
    Ok(Outcome { title, table, series, x_label: "pixels per frame", y_label: "frame time (ms)", log_y: true })
}

fn lamp_count(a: &LampsSweep, bench: &GpuBench) -> Result<Outcome> {
    let scene_lamps = bench.scene_lamps()?;
    let first = scene_lamps.first().with_context(|| format!("{}: no [[lights]] to copy", a.scene.display()))?;
    let mut comp = bench.compositor(&bench.scene)?;
    let mut table = Table::new(&["lamps", "frame_ms", "lamp_ms", "ms_per_lamp", "lamp_term"]);
    let (mut points, mut base) = (Vec::new(), None);
    let pb = frame_bar(a.lamps.len(), "lamp counts");
    for &n in &a.lamps {
        if n > heliar::lighting::MAX_LAMPS {
            bail!("--lamps: at most {} lamps light a frame, not {n}", heliar::lighting::MAX_LAMPS);
        }
        comp.set_lamps(&ring_of(first, n, bench.objects_centre()), LampOptions::default())?;
        let (ms, ran) = frame_ms(&mut comp, &bench.video, &night(n))?;
        let b = *base.get_or_insert(ms);
        points.push((n.max(1) as f64, ms));
        let per = if n > 0 { format!("{:.1}", (ms - b) / n as f64) } else { "-".into() };
        table.push(vec![n.to_string(), format!("{ms:.1}"), format!("{:.1}", ms - b), per, ran.to_string()]);
        pb.inc(1);
    }
    pb.finish_and_clear();
    let k = &bench.scene.camera.intrinsics;
    let title = format!(
        "lamps, frame time against far-field lamps on {} at {}x{} (copies of '{}' on a 2 m ring about the objects; lamp_ms against the first row; median of {} frames with the maps redrawn)",
        a.scene.display(),
        k.width,
        k.height,
        first.light.name,
        crate::bench_lamps_gpu::TIMED_FRAMES
    );
    Ok(Outcome { title, table, series: vec![Series { name: "frame time".into(), points, reference: false }], x_label: "far-field lamps", y_label: "frame time (ms)", log_y: false })
}
