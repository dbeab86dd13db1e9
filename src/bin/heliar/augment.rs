//! `heliar augment`: estimate → (relight → probes) → composite over an image sequence.

use crate::common::{build_estimator, frame_bar, load_scene, spinner};
use anyhow::{Context, Result, anyhow, bail};
use clap::{Args, ValueEnum};
use glam::Vec3;
use heliar::estimate::{FrameEstimate, Status};
use heliar::io::frames::{Frame, list_frame_files};
use heliar::render::output::{OutputKind, Rgb8, write_contact_sheet, write_frame};
use heliar::render::probes::{ProbeSource, UniformSky};
use heliar::render::{Builder, Compositor, CompositorConfig, Darkening, FrameLighting, Gpu, GpuOptions, PassReport, VideoFrame};
use heliar::report::{JsonLines, Table, median};
use heliar::scene::{Photometry, Scene, Truth, parse_time};
use serde::Serialize;
use std::path::{Path, PathBuf};

/// Output image format.
#[derive(Clone, Copy, Debug, ValueEnum)]
pub enum Format {
    /// 8/16-bit PNG through the camera response.
    Png,
    /// Camera-linear OpenEXR.
    Exr,
}

/// Darkening model of real pixels.
#[derive(Clone, Copy, Debug, ValueEnum)]
pub enum DarkeningArg {
    /// Ratio of the model's radiance with and without the objects: shadow and contact shadows.
    Differential,
    /// With the proxy's normal and weighted ambient c.
    Normal,
    /// Jensen's constant ratio Pa/(Pa+Pd).
    Constant,
}

/// Shadow-volume builder.
#[derive(Clone, Copy, Debug, ValueEnum)]
pub enum VolumesArg {
    /// rayon on the CPU.
    Cpu,
    /// A compute pass.
    Compute,
}

#[derive(Args)]
pub struct AugmentArgs {
    /// Scene folder (camera, proxy, virtual objects).
    scene: PathBuf,
    /// Folder of input frames (.png or .exr, sorted by name). When it is one of the scene's
    /// sequences, its times, exposure and truth are used.
    #[arg(long)]
    input: PathBuf,
    /// Output folder: frames, report.jsonl, contact_sheet.png.
    #[arg(long)]
    output: PathBuf,
    /// Time of the first frame (RFC 3339), for a folder that is not a scene sequence.
    #[arg(long)]
    start: Option<String>,
    /// Frames per second, for a folder that is not a scene sequence.
    #[arg(long)]
    fps: Option<f64>,
    /// Exposure (camera linear value per unit radiance), overriding the calibration.
    #[arg(long)]
    exposure: Option<f32>,
    /// Output format (default: the input's).
    #[arg(long, value_enum)]
    format: Option<Format>,
    /// How real pixels are darkened by the virtual objects.
    #[arg(long, value_enum, default_value = "differential")]
    darkening: DarkeningArg,
    /// Leave the sun bounce b·Pd out of the darkening ratio.
    #[arg(long)]
    no_sun_bounce: bool,
    /// MSAA samples (1 or 4; 4 falls back to 1 where the adapter cannot).
    #[arg(long, default_value_t = 4)]
    samples: u32,
    /// Shadow-volume builder.
    #[arg(long, value_enum, default_value = "cpu")]
    volumes: VolumesArg,
    /// Columns of the contact sheet.
    #[arg(long, default_value_t = 4)]
    sheet_columns: u32,
}

/// The frames to process and how to read them.
struct Input {
    files: Vec<PathBuf>,
    times: Vec<chrono::DateTime<chrono::FixedOffset>>,
    photometry: Photometry,
    truth: Option<Vec<Truth>>,
    sequence: Option<String>,
}

fn resolve_input(scene: &Scene, a: &AugmentArgs) -> Result<Input> {
    let want = std::fs::canonicalize(&a.input).with_context(|| format!("{}: input folder not found", a.input.display()))?;
    let seq = scene.sequences.iter().find(|s| s.files.first().and_then(|f| f.parent()).and_then(|d| std::fs::canonicalize(d).ok()).as_deref() == Some(want.as_path()));
    let files = list_frame_files(&a.input)?;
    if files.is_empty() {
        bail!("{}: no .png or .exr frames", a.input.display());
    }
    let mut input = match (seq, &a.start) {
        (Some(s), None) => Input { files, times: s.times.clone(), photometry: s.photometry.clone(), truth: s.truth.clone(), sequence: Some(s.name.clone()) },
        (_, Some(start)) => {
            let fps = a.fps.ok_or_else(|| anyhow!("--start needs --fps"))?;
            if !(fps.is_finite() && fps > 0.0) {
                bail!("--fps {fps}: must be positive");
            }
            let t0 = parse_time(Path::new("--start"), "start", start)?;
            let times = (0..files.len()).map(|i| t0 + chrono::Duration::microseconds((i as f64 / fps * 1e6) as i64)).collect();
            let photometry = scene.sequences.first().map(|s| s.photometry.clone()).ok_or_else(|| anyhow!("the scene has no sequence to take the camera response from"))?;
            Input { files, times, photometry, truth: None, sequence: None }
        }
        (None, None) => bail!("{} is not one of the scene's sequences: give --start and --fps", a.input.display()),
    };
    if input.times.len() != input.files.len() {
        bail!("{}: {} frames but the sequence has {} times", a.input.display(), input.files.len(), input.times.len());
    }
    if let Some(e) = a.exposure {
        if !(e.is_finite() && e > 0.0) {
            bail!("--exposure {e}: must be positive");
        }
        input.photometry.exposure = e;
    }
    Ok(input)
}

/// Whether the relight → probe-update hook ran this frame.
#[derive(Serialize)]
struct RelightReport {
    ran: bool,
    source: &'static str,
    reason: String,
}

#[derive(Serialize)]
struct Record<'a> {
    frame: usize,
    input: String,
    output: String,
    time: &'a str,
    status: Status,
    sun_dir: [f32; 3],
    sun_above_horizon: bool,
    pd: [f32; 3],
    pa: [f32; 3],
    relight: RelightReport,
    passes: &'a PassReport,
    decode_ms: f64,
    estimate_ms: f64,
    composite_ms: f64,
    encode_ms: f64,
    truth: Option<Truth>,
}

/// The lighting the compositor uses: the smoothed estimate, else the frame's, else none.
fn lighting_of(e: &FrameEstimate) -> FrameLighting {
    let v = |a: [f64; 3]| Vec3::new(a[0] as f32, a[1] as f32, a[2] as f32);
    let (pd, pa) = match (&e.smoothed, e.pd, e.pa) {
        (Some(s), _, _) => (v(s.pd), v(s.pa)),
        (None, pd, pa) => (pd.map(v).unwrap_or(Vec3::ZERO), pa.map(v).unwrap_or(Vec3::ZERO)),
    };
    FrameLighting { sun_dir: Vec3::from(e.sun.dir_world), above_horizon: e.sun.above_horizon, pd, pa }
}

/// Probe-grid bounds: the manifest's `[irradiance]`, else the virtual objects' bounds grown by a
/// metre.
fn probe_source(scene: &Scene) -> UniformSky {
    match &scene.manifest.irradiance {
        Some(g) => UniformSky { min: glam::DVec3::from(g.min).as_vec3(), max: glam::DVec3::from(g.max).as_vec3(), spacing: g.spacing_m as f32 },
        None => {
            let b = scene.virtual_objects.iter().filter_map(|o| o.mesh.bounds()).reduce(|(a, b), (c, d)| (a.min(c), b.max(d)));
            let (lo, hi) = b.unwrap_or((Vec3::ZERO, Vec3::ONE));
            UniformSky { min: lo - Vec3::ONE, max: hi + Vec3::ONE, spacing: 1.0 }
        }
    }
}

pub fn run(a: AugmentArgs) -> Result<()> {
    let (scene, ray) = load_scene(&a.scene)?;
    let input = resolve_input(&scene, &a)?;
    std::fs::create_dir_all(&a.output).with_context(|| format!("creating {}", a.output.display()))?;
    let mut est = build_estimator(&scene, ray.clone())?;
    let pb = spinner("GPU set-up: adapter, pipelines, per-pixel proxy data");
    let gpu = std::sync::Arc::new(Gpu::new(GpuOptions { samples: a.samples.max(1) })?);
    let mut config = CompositorConfig::for_scene(&scene);
    config.darkening = match a.darkening {
        DarkeningArg::Differential => Darkening::Differential,
        DarkeningArg::Normal => Darkening::Normal,
        DarkeningArg::Constant => Darkening::Constant,
    };
    config.sun_bounce = config.sun_bounce && !a.no_sun_bounce;
    config.builder = match a.volumes {
        VolumesArg::Cpu => Builder::Cpu,
        VolumesArg::Compute => Builder::Compute,
    };
    let mut comp = Compositor::for_scene(gpu.clone(), &scene, ray, config).with_context(|| format!("setting up the compositor for {}", scene.root.display()))?;
    pb.finish_and_clear();
    eprintln!("GPU: {} ({} MSAA samples, depth {:?})", gpu.describe(), gpu.samples, gpu.depth_format);
    for w in comp.warnings() {
        eprintln!("warning: {w}");
    }
    if scene.virtual_objects.is_empty() {
        eprintln!("note: {} has no [[virtual_objects]]: the footage passes through", scene.root.join(heliar::scene::MANIFEST_FILE).display());
    }
    let mut probes = probe_source(&scene);
    let report_path = a.output.join("report.jsonl");
    let mut out = JsonLines::create(&report_path).with_context(|| format!("creating {}", report_path.display()))?;
    let lin = input.photometry.linearizer();
    let k = &scene.camera.intrinsics;
    let bar = frame_bar(input.files.len(), &format!("augment {}", input.sequence.as_deref().unwrap_or("frames")));
    let (mut thumbs, mut composite_ms, mut relights) = (Vec::new(), Vec::new(), 0);
    for (i, path) in input.files.iter().enumerate() {
        let t = std::time::Instant::now();
        let frame = Frame::load(path)?;
        frame.check_size(path, k.width, k.height)?;
        let decode_ms = t.elapsed().as_secs_f64() * 1e3;
        let t = std::time::Instant::now();
        let e = est.estimate(i, &input.times[i], &frame, &lin).with_context(|| format!("{}", path.display()))?;
        let estimate_ms = t.elapsed().as_secs_f64() * 1e3;
        let lighting = lighting_of(&e);
        // The hook: relight the environment and update the probes only when the estimate says
        // the lighting moved (and once to start).
        let relight = if i == 0 || e.relight {
            let grid = probes.relight(&e, lighting.pd, lighting.pa);
            comp.set_probes(&grid);
            relights += 1;
            RelightReport { ran: true, source: probes.name(), reason: if i == 0 { "first frame".into() } else { format!("{:?}", e.change) } }
        } else {
            RelightReport { ran: false, source: probes.name(), reason: "lighting unchanged (relight = false)".into() }
        };
        let video = VideoFrame::from_frame(&frame, &lin);
        let t = std::time::Instant::now();
        let (rendered, passes) = comp.render(&video, &lighting).with_context(|| format!("compositing {}", path.display()))?;
        composite_ms.push(t.elapsed().as_secs_f64() * 1e3);
        let kind = match (a.format, &frame.data) {
            (Some(Format::Exr), _) | (None, heliar::io::frames::FrameData::Hdr(_)) => OutputKind::Exr,
            _ => OutputKind::Png,
        };
        let stem = path.file_stem().map(|s| s.to_string_lossy().into_owned()).unwrap_or_else(|| format!("frame_{i:03}"));
        let out_path = a.output.join(format!("{stem}.{}", kind.extension()));
        let t = std::time::Instant::now();
        write_frame(&out_path, kind, &rendered.image, rendered.precision, &video, &frame, &input.photometry)?;
        let encode_ms = t.elapsed().as_secs_f64() * 1e3;
        thumbs.push(Rgb8::from_radiance(&rendered.image, &input.photometry).shrink_to(320));
        out.write(&Record {
            frame: i,
            input: path.display().to_string(),
            output: out_path.display().to_string(),
            time: &e.time,
            status: e.status,
            sun_dir: e.sun.dir_world,
            sun_above_horizon: e.sun.above_horizon,
            pd: lighting.pd.to_array(),
            pa: lighting.pa.to_array(),
            relight,
            passes: &passes,
            decode_ms,
            estimate_ms,
            composite_ms: *composite_ms.last().unwrap_or(&0.0),
            encode_ms,
            truth: input.truth.as_ref().map(|t| t[i]),
        })?;
        bar.inc(1);
    }
    bar.finish_and_clear();
    let sheet = a.output.join("contact_sheet.png");
    write_contact_sheet(&sheet, &thumbs, a.sheet_columns, 4)?;
    let mut t = Table::new(&["quantity", "value"]);
    t.push(vec!["frames".into(), input.files.len().to_string()]);
    t.push(vec!["relights (probe updates)".into(), relights.to_string()]);
    t.push(vec!["median composite time per frame".into(), format!("{:.1} ms", median(&composite_ms))]);
    eprint!("{t}");
    eprintln!("wrote {} frames, {} and {}", input.files.len(), report_path.display(), sheet.display());
    Ok(())
}
