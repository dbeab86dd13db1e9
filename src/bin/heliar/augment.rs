//! `heliar augment`: recorded footage in, augmented footage out (see `heliar::run::augment` for
//! the frame loop, its resume and its interrupts).
//!
//! Input: a folder of frames (PNG/EXR, sorted by name) or, with the `opencv` feature, a video
//! file. Output: a folder of frames, or (feature `opencv`) a video file `.mp4` (MPEG-4 Part 2),
//! `.mkv` (lossless FFV1) or `.avi` (Motion JPEG) at the input's frame rate, with the per-frame
//! JSON report, a summary and a contact sheet beside it.

use crate::common::{BarObserver, build_estimator, interrupt_counter, load_scene, spinner};
use anyhow::{Context, Result};
use clap::{Args, ValueEnum};
use heliar::geometry::raycast::RayScene;
use heliar::gpu::{Gpu, GpuOptions};
use heliar::render::{Builder, Compositor, CompositorConfig, Darkening};
use heliar::run::augment::{AugmentOptions, augment};
use heliar::run::outdoor::{Ambient, OutdoorStage, probe_source};
use heliar::run::session::OutdoorSession;
use heliar::run::sink::Format;
use heliar::run::source::{InputOptions, resolve_input};
use heliar::scene::Scene;
use std::path::PathBuf;
use std::sync::Arc;

/// Output image format.
#[derive(Clone, Copy, Debug, ValueEnum)]
pub enum FormatArg {
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

/// Where the virtual objects' ambient light comes from.
#[derive(Clone, Copy, Debug, PartialEq, ValueEnum)]
pub enum AmbientArg {
    /// The irradiance volume when the scene has an `[envmap]`, else the uniform sky.
    Auto,
    /// The baked irradiance volume relit per frame (bakes first when needed).
    Volume,
    /// A uniform, unoccluded sky of the frame's `Pa` everywhere.
    Uniform,
}

/// Shadow-volume builder.
#[derive(Clone, Copy, Debug, ValueEnum)]
pub enum VolumesArg {
    /// rayon on the CPU.
    Cpu,
    /// A compute pass.
    Compute,
}

impl From<DarkeningArg> for Darkening {
    fn from(d: DarkeningArg) -> Self {
        match d {
            DarkeningArg::Differential => Darkening::Differential,
            DarkeningArg::Normal => Darkening::Normal,
            DarkeningArg::Constant => Darkening::Constant,
        }
    }
}

impl From<AmbientArg> for Ambient {
    fn from(a: AmbientArg) -> Self {
        match a {
            AmbientArg::Auto => Ambient::Auto,
            AmbientArg::Volume => Ambient::Volume,
            AmbientArg::Uniform => Ambient::Uniform,
        }
    }
}

/// The GPU and the compositor for `scene` with `config`, behind a spinner; prints the adapter
/// and the compositor's warnings (open meshes and the like).
pub fn gpu_compositor(scene: &Scene, ray: Arc<RayScene>, samples: u32, config: CompositorConfig) -> Result<(Arc<Gpu>, Compositor)> {
    let pb = spinner("GPU set-up: adapter, pipelines, per-pixel proxy data");
    let gpu = Arc::new(Gpu::new(GpuOptions { samples: samples.max(1) })?);
    let comp = Compositor::for_scene(gpu.clone(), scene, ray, config).with_context(|| format!("setting up the compositor for {}", scene.root.display()))?;
    pb.finish_and_clear();
    eprintln!("GPU: {} ({} MSAA samples, depth {:?})", gpu.describe(), gpu.samples, gpu.depth_format);
    for w in comp.warnings() {
        eprintln!("warning: {w}");
    }
    Ok((gpu, comp))
}

/// The outdoor session of `scene`: the estimator, the probe source `ambient` asks for (baking
/// first when needed) and the compositor. Shared by `augment` and `live`.
pub fn outdoor_session(scene: &Scene, ray: Arc<RayScene>, samples: u32, config: CompositorConfig, ambient: Ambient) -> Result<OutdoorSession> {
    let estimator = build_estimator(scene, ray.clone())?;
    let (_gpu, comp) = gpu_compositor(scene, ray.clone(), samples, config)?;
    let manifest = scene.root.join(heliar::scene::MANIFEST_FILE);
    if scene.virtual_objects.is_empty() {
        eprintln!("note: {} has no [[virtual_objects]]: the footage passes through", manifest.display());
    }
    if ambient == Ambient::Auto && scene.manifest.envmap.is_none() {
        eprintln!("note: {} has no [envmap]: ambient light from a uniform sky of the estimated Pa (no irradiance volume)", manifest.display());
    }
    let probes = probe_source(scene, ray, ambient, |s, r| crate::bake::bake_with_progress(s, r, false))?;
    Ok(OutdoorSession::new(OutdoorStage::new(estimator, probes), comp))
}

#[derive(Args)]
pub struct AugmentArgs {
    /// Scene folder (camera, proxy, virtual objects).
    scene: PathBuf,
    /// Footage: a folder of .png/.exr frames (sorted by name), or a video file (feature
    /// `opencv`). A folder that is one of the scene's sequences brings its times, exposure and
    /// truth.
    #[arg(long)]
    input: PathBuf,
    /// Output: a folder of frames, or a video file .mp4/.mkv/.avi (feature `opencv`). Reports go
    /// into the folder, or beside the video (NAME.report.jsonl, NAME.summary.json,
    /// NAME.contact_sheet.png).
    #[arg(long)]
    output: PathBuf,
    /// Scene sequence whose camera exposure and start time to use for footage that is not one
    /// of the scene's sequences (default: the camera's own exposure).
    #[arg(long)]
    sequence: Option<String>,
    /// Time of the first frame (RFC 3339). Needed for a folder that is not a scene sequence; for
    /// a video, the container's timestamps are added to it (default: the --sequence's start).
    #[arg(long)]
    start: Option<String>,
    /// Frames per second: for a folder that is not a scene sequence, or a video whose container
    /// gives none.
    #[arg(long)]
    fps: Option<f64>,
    /// Exposure (camera linear value per unit radiance), overriding the calibration.
    #[arg(long)]
    exposure: Option<f32>,
    /// Frame format in an output folder (default: the input's).
    #[arg(long, value_enum)]
    format: Option<FormatArg>,
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
    /// Ambient light of the virtual objects: the probe source (where the per-pixel transfer
    /// has no entry, or everywhere with --transfer-paths 0).
    #[arg(long, value_enum, default_value = "auto")]
    ambient: AmbientArg,
    /// Paths per pixel of the virtual objects' per-pixel ambient transfer, traced on the first
    /// frame, its sun part again when the sun has moved 0.25° (0: probes × ambient occlusion
    /// instead).
    #[arg(long, default_value_t = heliar::render::object_transfer::TRANSFER_PATHS)]
    transfer_paths: u32,
    /// Paths per frame of the re-trace of the sun-dependent terms (the receivers' `b`, the
    /// objects' `R_d`) after the sun has moved 0.25°: done a slice per frame while the previous
    /// values serve (0: the whole re-trace in one frame, which stalls it for seconds).
    #[arg(long, default_value_t = heliar::render::TRACE_PATHS_PER_FRAME)]
    trace_paths_per_frame: u64,
    /// Paths per frame of the estimator's sun-bounce re-trace after the sun has moved 0.25°,
    /// done a slice per frame while the previous bounce serves (default: `[estimator]
    /// trace_paths_per_frame`, 0 = whole in the frame; the live window slices by default).
    #[arg(long)]
    estimator_trace_paths_per_frame: Option<u64>,
    /// Columns of the contact sheet.
    #[arg(long, default_value_t = 4)]
    sheet_columns: u32,
    /// Continue an interrupted run into the same output.
    #[arg(long)]
    resume: bool,
    /// Stop after this many frames (counting frames already written by a resumed run).
    #[arg(long, conflicts_with = "frames")]
    max_frames: Option<usize>,
    /// Only frames A..B (B exclusive, counted from 0 as in the report): a chunk, whose frames
    /// keep their numbers and names. `heliar merge` joins chunks; `--resume` with the same
    /// --frames continues an interrupted chunk.
    #[arg(long, value_parser = parse_frames)]
    frames: Option<std::ops::Range<usize>>,
    /// Frames before a chunk replayed first (estimate, relights, decisions; nothing written) to
    /// warm the smoothing and caches. Default: all of them (from frame 0), which makes the chunk
    /// equal a sequential run byte for byte; see docs/measurements.md for shorter warm-ups.
    #[arg(long, requires = "frames")]
    warmup: Option<usize>,
    /// Write even where an output would overwrite the input or a file of the scene.
    #[arg(long)]
    force: bool,
    /// Frame times that do not increase are an error (default: a warning naming the frames).
    #[arg(long)]
    strict: bool,
    /// Give the lamps (`[[lights]]`) the scale `k` of the frame's own and the earlier frames'
    /// fits only (the live window's forward filter), instead of estimating the whole input
    /// first and smoothing `k` over the frames after each frame as well.
    #[arg(long)]
    no_hindsight: bool,
}

/// `A..B` with A < B.
fn parse_frames(s: &str) -> Result<std::ops::Range<usize>, String> {
    let (a, b) = s.split_once("..").ok_or_else(|| format!("`{s}`: expected A..B (frames A to B-1)"))?;
    let num = |x: &str, what: &str| x.trim().parse::<usize>().map_err(|e| format!("`{s}`: {what} `{x}`: {e}"));
    let (a, b) = (num(a, "first frame")?, num(b, "end frame")?);
    if b <= a {
        return Err(format!("`{s}`: the end {b} must be after the first frame {a} (A..B runs frames A to B-1)"));
    }
    Ok(a..b)
}

pub fn run(a: AugmentArgs) -> Result<()> {
    let (mut scene, ray) = load_scene(&a.scene)?;
    if let Some(n) = a.estimator_trace_paths_per_frame {
        scene.estimator.trace_paths_per_frame = n;
    }
    let input = resolve_input(
        &scene,
        &InputOptions { input: Some(a.input.clone()), sequence: a.sequence.clone(), start: a.start.clone(), fps: a.fps, exposure: a.exposure, ..Default::default() },
    )?;
    heliar::run::sink::Outputs::of(&a.output)?;
    let stop = interrupt_counter();
    let mut config = CompositorConfig::for_scene(&scene);
    config.darkening = a.darkening.into();
    config.sun_bounce = config.sun_bounce && !a.no_sun_bounce;
    config.builder = match a.volumes {
        VolumesArg::Cpu => Builder::Cpu,
        VolumesArg::Compute => Builder::Compute,
    };
    config.transfer_paths = a.transfer_paths;
    config.trace_paths_per_frame = a.trace_paths_per_frame;
    let mut session = outdoor_session(&scene, ray, a.samples, config, a.ambient.into())?;
    let format = a.format.map(|f| match f {
        FormatArg::Png => Format::Png,
        FormatArg::Exr => Format::Exr,
    });
    let opts = AugmentOptions {
        output: a.output.clone(),
        format,
        resume: a.resume,
        max_frames: a.max_frames,
        frames: a.frames.clone(),
        warmup: a.warmup,
        sheet_columns: a.sheet_columns,
        force: a.force,
        strict_clock: a.strict,
        hindsight: !a.no_hindsight,
    };
    let outcome = augment(&scene, &input, &mut session, &opts, &mut BarObserver::default(), &stop)?;
    eprint!("{}", outcome.summary.table());
    if let Some(e) = outcome.error {
        return Err(e);
    }
    let o = &outcome.outputs;
    let i = outcome.summary.frames_written;
    eprintln!("wrote {i} frames to {}, {}, {} and {}", o.target.display(), o.report.display(), o.summary.display(), o.sheet.display());
    if outcome.summary.interrupted {
        eprintln!("interrupted after {i} frames: `--resume` continues the run");
        std::process::exit(130);
    }
    Ok(())
}
