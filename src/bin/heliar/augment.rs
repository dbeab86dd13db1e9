//! `heliar augment`: estimate → (relight → probes) → composite over recorded footage.
//!
//! Input: a folder of frames (PNG/EXR, sorted by name) or, with the `opencv` feature, a video
//! file. Output: a folder of frames, or (feature `opencv`) a video file `.mp4` (MPEG-4 Part 2),
//! `.mkv` (lossless FFV1) or `.avi` (Motion JPEG) at the input's frame rate. Beside the output:
//! the per-frame JSON report, a summary and a contact sheet (see [`Outputs`]).
//!
//! An interrupted run (Ctrl-C, SIGTERM) finishes the frame in hand, closes the container and
//! writes the summary; the report then lists exactly the frames in the output. `--resume`
//! continues it: the frames already written are kept (a video's are copied into the new file:
//! bit-exact for `.mkv`, re-encoded once for `.mp4`/`.avi`), the estimator is replayed over them
//! (decode and estimate only) so its temporal smoothing continues as if never interrupted, and
//! compositing starts at the first missing frame.

use crate::common::{build_estimator, frame_bar, load_scene, pick_sequence, spinner};
use anyhow::{Context, Result, anyhow, bail};
use chrono::{DateTime, FixedOffset};
use clap::{Args, ValueEnum};
use heliar::io::frames::{Frame, FrameData, Linearizer, list_frame_files};
use heliar::pipeline::{Ambient, Pipeline, RelightReport, RunCounts, probe_source};
use heliar::render::output::{OutputKind, write_frame};
use heliar::io::image::{Rgb8, write_contact_sheet};
use heliar::render::{Builder, Compositor, CompositorConfig, Darkening, PassReport};
use heliar::gpu::{Gpu, GpuOptions};
use heliar::report::{JsonLines, Table, median};
use heliar::io::frames::Photometry;
use heliar::scene::{Scene, Truth, parse_time};
use serde::Serialize;
use std::path::{Path, PathBuf};
use std::sync::Arc;
use std::sync::atomic::{AtomicUsize, Ordering};

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
pub fn gpu_compositor(scene: &Scene, ray: Arc<heliar::geometry::raycast::RayScene>, samples: u32, config: CompositorConfig) -> Result<(Arc<Gpu>, Compositor)> {
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
    /// Ambient light of the virtual objects: the probe source (where the per-pixel transfer
    /// has no entry, or everywhere with --transfer-paths 0).
    #[arg(long, value_enum, default_value = "auto")]
    ambient: AmbientArg,
    /// Paths per pixel of the virtual objects' per-pixel ambient transfer, traced on the first
    /// frame and again when the sun has moved 0.25° (0: probes × ambient occlusion instead).
    #[arg(long, default_value_t = heliar::render::object_transfer::TRANSFER_PATHS)]
    transfer_paths: u32,
    /// Columns of the contact sheet.
    #[arg(long, default_value_t = 4)]
    sheet_columns: u32,
    /// Continue an interrupted run into the same output.
    #[arg(long)]
    resume: bool,
    /// Stop after this many frames (counting frames already written by a resumed run).
    #[arg(long)]
    max_frames: Option<usize>,
}

/// Extensions read and written as video files.
const VIDEO_EXTENSIONS: [&str; 9] = ["mp4", "mkv", "avi", "mov", "webm", "m4v", "mpg", "mpeg", "ts"];
/// Extensions the video writer supports.
const VIDEO_OUT_EXTENSIONS: [&str; 3] = ["mp4", "mkv", "avi"];

fn extension(p: &Path) -> Option<String> {
    p.extension().and_then(|e| e.to_str()).map(str::to_ascii_lowercase)
}

/// Where frames come from.
enum Source {
    Images(Vec<PathBuf>),
    #[cfg(feature = "opencv")]
    Video(heliar::io::video::VideoSource),
}

/// Frame times: a list (scene sequences), or a start plus the container's timestamps (or
/// index / fps).
enum Clock {
    List(Vec<DateTime<FixedOffset>>),
    Start { t0: DateTime<FixedOffset>, fps: f64 },
}

impl Clock {
    fn time(&self, i: usize, ts_ms: Option<f64>) -> Result<DateTime<FixedOffset>> {
        match self {
            Clock::List(t) => t.get(i).copied().ok_or_else(|| anyhow!("frame {i}: the sequence lists only {} times", t.len())),
            Clock::Start { t0, fps } => {
                let ms = ts_ms.filter(|v| v.is_finite() && *v >= 0.0).unwrap_or(i as f64 * 1e3 / fps);
                Ok(*t0 + chrono::Duration::microseconds((ms * 1e3).round() as i64))
            }
        }
    }
}

/// The footage and how to read it.
struct Input {
    source: Source,
    label: String,
    count: Option<usize>,
    fps: f64,
    clock: Clock,
    photometry: Photometry,
    truth: Option<Vec<Truth>>,
    sequence: Option<String>,
}

impl Input {
    /// Frame `i` (frames are read in order): the frame, its container timestamp (ms) and a label
    /// for messages. `None` at the end.
    fn next(&mut self, i: usize) -> Result<Option<(Frame, Option<f64>, String)>> {
        match &mut self.source {
            Source::Images(files) => match files.get(i) {
                None => Ok(None),
                Some(p) => Ok(Some((Frame::load(p)?, None, p.display().to_string()))),
            },
            #[cfg(feature = "opencv")]
            Source::Video(v) => Ok(v.read()?.map(|(f, ts)| (f, Some(ts), format!("{} frame {i}", self.label)))),
        }
    }

    /// Name of frame `i`'s output file in a folder.
    fn stem(&self, i: usize) -> String {
        match &self.source {
            Source::Images(files) => files.get(i).and_then(|p| p.file_stem()).map(|s| s.to_string_lossy().into_owned()).unwrap_or_else(|| format!("frame_{i:05}")),
            #[cfg(feature = "opencv")]
            Source::Video(_) => format!("frame_{i:05}"),
        }
    }
}

fn positive_fps(fps: f64, what: &str) -> Result<f64> {
    if !(fps.is_finite() && fps > 0.0) {
        bail!("{what} {fps}: must be a positive number of frames per second");
    }
    Ok(fps)
}

fn resolve_input(scene: &Scene, a: &AugmentArgs) -> Result<Input> {
    let borrowed = a.sequence.as_deref().map(|n| pick_sequence(scene, Some(n)).context("--sequence")).transpose()?;
    let photometry = borrowed.map(|s| s.photometry.clone()).unwrap_or_else(|| scene.photometry.clone());
    if !a.input.exists() {
        bail!("{}: input not found", a.input.display());
    }
    let mut input = if a.input.is_dir() {
        let want = std::fs::canonicalize(&a.input).with_context(|| format!("{}: input folder not readable", a.input.display()))?;
        let seq = scene.sequences.iter().find(|s| s.files.first().and_then(|f| f.parent()).and_then(|d| std::fs::canonicalize(d).ok()).as_deref() == Some(want.as_path()));
        let files = list_frame_files(&a.input)?;
        if files.is_empty() {
            bail!("{}: no .png or .exr frames", a.input.display());
        }
        let label = a.input.display().to_string();
        let count = Some(files.len());
        match (seq, &a.start) {
            (Some(s), None) => {
                if s.times.len() != files.len() {
                    bail!("{}: {} frames but the sequence has {} times", a.input.display(), files.len(), s.times.len());
                }
                let fps = if s.times.len() > 1 { 1e6 / (s.times[1] - s.times[0]).num_microseconds().unwrap_or(1_000_000).max(1) as f64 } else { 1.0 };
                Input { source: Source::Images(files), label, count, fps, clock: Clock::List(s.times.clone()), photometry: s.photometry.clone(), truth: s.truth.clone(), sequence: Some(s.name.clone()) }
            }
            (_, Some(start)) => {
                let fps = positive_fps(a.fps.ok_or_else(|| anyhow!("--start needs --fps for a folder of frames"))?, "--fps")?;
                let t0 = parse_time(Path::new("--start"), "start", start)?;
                Input { source: Source::Images(files), label, count, fps, clock: Clock::Start { t0, fps }, photometry, truth: None, sequence: None }
            }
            (None, None) => bail!("{} is not one of the scene's sequences: give --start and --fps", a.input.display()),
        }
    } else {
        open_video(scene, a, borrowed, photometry.clone())?
    };
    if let Some(e) = a.exposure {
        if !(e.is_finite() && e > 0.0) {
            bail!("--exposure {e}: must be positive");
        }
        input.photometry.exposure = e;
    }
    Ok(input)
}

#[cfg(feature = "opencv")]
fn open_video(scene: &Scene, a: &AugmentArgs, borrowed: Option<&heliar::scene::Sequence>, photometry: Photometry) -> Result<Input> {
    if !extension(&a.input).is_some_and(|e| VIDEO_EXTENSIONS.contains(&e.as_str())) {
        bail!("{}: not a folder of frames nor a video file (.{})", a.input.display(), VIDEO_EXTENSIONS.join(", ."));
    }
    let v = heliar::io::video::VideoSource::open_file(&a.input)?;
    let (w, h) = v.size();
    let k = &scene.camera.intrinsics;
    if (w, h) != (k.width, k.height) && (w, h) != (0, 0) {
        bail!("{}: frames are {w}×{h} but the camera calibration {} is {}×{}", a.input.display(), scene.camera_path.display(), k.width, k.height);
    }
    let fps = match (v.fps(), a.fps) {
        (_, Some(f)) => positive_fps(f, "--fps")?,
        (f, None) if f > 0.0 => f,
        _ => bail!("{}: the container gives no frame rate: give --fps", a.input.display()),
    };
    let t0 = match (&a.start, borrowed.or(scene.sequences.first())) {
        (Some(s), _) => parse_time(Path::new("--start"), "start", s)?,
        (None, Some(seq)) if !seq.times.is_empty() => {
            eprintln!("note: frame times start at sequence '{}''s start {} (give --start for the video's own)", seq.name, seq.times[0].to_rfc3339());
            seq.times[0]
        }
        _ => bail!("{}: give --start (the time of the first frame) for a video", a.input.display()),
    };
    let count = v.frame_count().map(|n| n as usize);
    Ok(Input { label: a.input.display().to_string(), source: Source::Video(v), count, fps, clock: Clock::Start { t0, fps }, photometry, truth: None, sequence: None })
}

#[cfg(not(feature = "opencv"))]
fn open_video(_scene: &Scene, a: &AugmentArgs, _borrowed: Option<&heliar::scene::Sequence>, _photometry: Photometry) -> Result<Input> {
    if extension(&a.input).is_some_and(|e| VIDEO_EXTENSIONS.contains(&e.as_str())) {
        bail!("{}: video files need heliar built with `--features opencv` (or give a folder of PNG/EXR frames)", a.input.display());
    }
    bail!("{}: not a folder of frames", a.input.display())
}

/// Where the output and its reports go.
struct Outputs {
    /// The folder, or the video file.
    target: PathBuf,
    video: bool,
    report: PathBuf,
    summary: PathBuf,
    sheet: PathBuf,
}

impl Outputs {
    fn of(path: &Path) -> Result<Self> {
        let video = extension(path).is_some_and(|e| VIDEO_EXTENSIONS.contains(&e.as_str()));
        if video {
            let ext = extension(path).unwrap_or_default();
            if !VIDEO_OUT_EXTENSIONS.contains(&ext.as_str()) {
                bail!("{}: videos are written as .mp4, .mkv or .avi", path.display());
            }
            if !cfg!(feature = "opencv") {
                bail!("{}: writing video needs heliar built with `--features opencv` (or give an output folder)", path.display());
            }
            let stem = path.file_stem().map(|s| s.to_string_lossy().into_owned()).unwrap_or_else(|| "out".into());
            let beside = |suffix: &str| path.with_file_name(format!("{stem}.{suffix}"));
            Ok(Self { target: path.to_owned(), video, report: beside("report.jsonl"), summary: beside("summary.json"), sheet: beside("contact_sheet.png") })
        } else {
            Ok(Self { target: path.to_owned(), video, report: path.join("report.jsonl"), summary: path.join("summary.json"), sheet: path.join("contact_sheet.png") })
        }
    }

    fn parent(&self) -> PathBuf {
        if self.video { self.target.parent().map(Path::to_owned).unwrap_or_default() } else { self.target.clone() }
    }
}

/// Where frames go.
enum Sink {
    Dir(Option<Format>),
    #[cfg(feature = "opencv")]
    Video {
        sink: heliar::io::video::VideoSink,
        /// Written here and renamed to the target when finished (a resumed run).
        partial: Option<PathBuf>,
    },
}

/// A per-frame report line.
#[derive(Serialize)]
struct Record<'a> {
    frame: usize,
    input: String,
    output: String,
    time: &'a str,
    status: heliar::estimate::Status,
    fallback: Option<heliar::estimate::Fallback>,
    sun_dir: [f32; 3],
    sun_above_horizon: bool,
    pd: [f32; 3],
    pa: [f32; 3],
    condition_number: Option<f64>,
    relight: &'a RelightReport,
    passes: &'a PassReport,
    decode_ms: f64,
    estimate_ms: f64,
    composite_ms: f64,
    encode_ms: f64,
    truth: Option<Truth>,
}

/// Evenly spaced thumbnails of a run of unknown length: keeps at most `2·keep` frames, halving
/// them (every other one) and doubling the stride when full.
struct Thumbs {
    keep: usize,
    stride: usize,
    items: Vec<(usize, Rgb8)>,
}

impl Thumbs {
    fn new(keep: usize) -> Self {
        Self { keep, stride: 1, items: Vec::new() }
    }
    fn wants(&self, i: usize) -> bool {
        i.is_multiple_of(self.stride)
    }
    fn push(&mut self, i: usize, img: Rgb8) {
        if !self.wants(i) {
            return;
        }
        self.items.push((i, img));
        if self.items.len() >= 2 * self.keep {
            self.stride *= 2;
            let s = self.stride;
            self.items.retain(|(k, _)| k.is_multiple_of(s));
        }
    }
}

/// A thumbnail of an output frame read back (resumed runs).
fn thumb_of(frame: &Frame, photometry: &Photometry) -> Rgb8 {
    let rgb = match &frame.data {
        FrameData::Ldr { bits: 8, codes } => Rgb8 { width: frame.width, height: frame.height, data: codes.iter().map(|&c| c as u8).collect() },
        FrameData::Ldr { codes, .. } => Rgb8 { width: frame.width, height: frame.height, data: codes.iter().map(|&c| (c >> 8) as u8).collect() },
        FrameData::Hdr(img) => {
            let mut lin = img.clone();
            lin.data.iter_mut().for_each(|p| *p = p.map(|c| c / photometry.exposure));
            Rgb8::from_radiance(&lin, photometry)
        }
    };
    rgb.shrink_to(320)
}

/// Frames of an earlier run that can be kept: leading report lines `frame = 0, 1, …` that parse
/// and whose output file exists (folders), capped by `frames_in_video` (videos). The report is
/// cut back to them.
fn resume_point(out: &Outputs, frames_in_video: Option<usize>) -> Result<usize> {
    let text = match std::fs::read_to_string(&out.report) {
        Ok(t) => t,
        Err(e) if e.kind() == std::io::ErrorKind::NotFound => return Ok(0),
        Err(e) => return Err(e).with_context(|| format!("reading {}", out.report.display())),
    };
    let mut keep = 0usize;
    let mut bytes = 0usize;
    for line in text.split_inclusive('\n') {
        if !line.ends_with('\n') {
            break;
        }
        let Ok(v) = serde_json::from_str::<serde_json::Value>(line) else { break };
        if v["frame"].as_u64() != Some(keep as u64) {
            break;
        }
        if !out.video && !v["output"].as_str().is_some_and(|p| Path::new(p).exists()) {
            break;
        }
        keep += 1;
        bytes += line.len();
    }
    if let Some(n) = frames_in_video {
        if n < keep {
            keep = n;
            bytes = text.split_inclusive('\n').take(n).map(str::len).sum();
        }
    }
    std::fs::write(&out.report, &text.as_bytes()[..bytes]).with_context(|| format!("cutting {} back to {keep} frames", out.report.display()))?;
    Ok(keep)
}

/// Per-stage timing, ms per frame.
#[derive(Default, Serialize)]
struct Stage {
    total_s: f64,
    median_ms: f64,
    mean_ms: f64,
    #[serde(skip)]
    samples: Vec<f64>,
}

impl Stage {
    fn add(&mut self, ms: f64) {
        self.samples.push(ms);
    }
    fn finish(&mut self) {
        let n = self.samples.len().max(1) as f64;
        let sum: f64 = self.samples.iter().sum();
        self.total_s = sum / 1e3;
        self.mean_ms = sum / n;
        self.median_ms = if self.samples.is_empty() { 0.0 } else { median(&self.samples) };
    }
}

#[derive(Default, Serialize)]
struct Stages {
    decode: Stage,
    estimate: Stage,
    relight: Stage,
    composite: Stage,
    encode: Stage,
}

/// The run's summary (`summary.json`, and a table on the terminal).
#[derive(Serialize)]
struct Summary {
    input: String,
    output: String,
    frames_written: usize,
    frames_this_run: usize,
    resumed_after: usize,
    interrupted: bool,
    error: Option<String>,
    input_frames: Option<usize>,
    fps_in: f64,
    wall_s: f64,
    frames_per_second: f64,
    gpu: String,
    probe_source: String,
    counts: RunCounts,
    stages: Stages,
}

pub fn run(a: AugmentArgs) -> Result<()> {
    let (scene, ray) = load_scene(&a.scene)?;
    let mut input = resolve_input(&scene, &a)?;
    let out = Outputs::of(&a.output)?;
    std::fs::create_dir_all(out.parent()).with_context(|| format!("{}: cannot create the output folder", out.parent().display()))?;

    // Interrupts: the first finishes the current frame, the second exits at once.
    let stop = Arc::new(AtomicUsize::new(0));
    {
        let stop = stop.clone();
        if let Err(e) = ctrlc::set_handler(move || {
            if stop.fetch_add(1, Ordering::SeqCst) == 0 {
                eprintln!("\ninterrupted: finishing the current frame and closing the output (again to quit at once)");
            } else {
                eprintln!("\ninterrupted twice: exiting without closing the output");
                std::process::exit(130);
            }
        }) {
            eprintln!("warning: cannot catch Ctrl-C ({e}); an interrupt will end the run without closing the output");
        }
    }

    // Set-up: estimator, GPU, probes.
    let estimator = build_estimator(&scene, ray.clone())?;
    let mut config = CompositorConfig::for_scene(&scene);
    config.darkening = a.darkening.into();
    config.sun_bounce = config.sun_bounce && !a.no_sun_bounce;
    config.builder = match a.volumes {
        VolumesArg::Cpu => Builder::Cpu,
        VolumesArg::Compute => Builder::Compute,
    };
    config.transfer_paths = a.transfer_paths;
    let (gpu, comp) = gpu_compositor(&scene, ray.clone(), a.samples, config)?;
    if scene.virtual_objects.is_empty() {
        eprintln!("note: {} has no [[virtual_objects]]: the footage passes through", scene.root.join(heliar::scene::MANIFEST_FILE).display());
    }
    let ambient: Ambient = a.ambient.into();
    if ambient == Ambient::Auto && scene.manifest.envmap.is_none() {
        eprintln!("note: {} has no [envmap]: ambient light from a uniform sky of the estimated Pa (no irradiance volume)", scene.root.join(heliar::scene::MANIFEST_FILE).display());
    }
    let probes = probe_source(&scene, ray.clone(), ambient, |s, r| crate::bake::bake_with_progress(s, r, false))?;
    let mut pipe = Pipeline::new(estimator, comp, probes);
    let lin: Linearizer = input.photometry.linearizer();
    let k = scene.camera.intrinsics.clone();

    // Resume: keep what an earlier run wrote, replay the estimator over it.
    let mut thumbs = Thumbs::new(16);
    let mut done = 0usize;
    #[cfg(feature = "opencv")]
    let mut old_video: Option<heliar::io::video::VideoSource> = None;
    if a.resume {
        #[cfg(feature = "opencv")]
        let in_video = if out.video && out.target.exists() {
            let v = heliar::io::video::VideoSource::open_file(&out.target).with_context(|| format!("{}: the earlier output cannot be read to resume", out.target.display()))?;
            let n = v.frame_count().map(|n| n as usize);
            old_video = Some(v);
            Some(n.unwrap_or(usize::MAX))
        } else if out.video {
            Some(0)
        } else {
            None
        };
        #[cfg(not(feature = "opencv"))]
        let in_video: Option<usize> = None;
        done = resume_point(&out, in_video)?;
        if done > 0 {
            let pb = frame_bar(done, "replaying the estimator over the frames written");
            for i in 0..done {
                let Some((frame, ts, label)) = input.next(i)? else { bail!("{}: the input has fewer frames ({i}) than the run being resumed ({done})", input.label) };
                let t = input.clock.time(i, ts)?;
                pipe.estimate_only(i, &t, &frame, &lin).with_context(|| label.clone())?;
                if !out.video {
                    let p = a.output.join(format!("{}.{}", input.stem(i), output_kind(a.format, &frame).extension()));
                    if thumbs.wants(i)
                        && let Ok(f) = Frame::load(&p)
                    {
                        thumbs.push(i, thumb_of(&f, &input.photometry));
                    }
                }
                pb.inc(1);
            }
            pb.finish_and_clear();
            eprintln!("resuming after {done} frames");
        } else {
            eprintln!("note: nothing to resume in {}: starting from the first frame", out.report.display());
        }
    } else if out.report.exists() {
        eprintln!("note: overwriting the earlier run in {} (--resume continues one instead)", out.target.display());
    }

    // Open the sink.
    let mut sink = if out.video {
        #[cfg(feature = "opencv")]
        {
            let partial = (done > 0).then(|| {
                let ext = extension(&out.target).unwrap_or_default();
                out.target.with_extension(format!("partial.{ext}"))
            });
            let path = partial.clone().unwrap_or_else(|| out.target.clone());
            let mut sink = heliar::io::video::VideoSink::create(&path, input.fps, k.width, k.height).with_context(|| format!("{}: cannot write the output video", path.display()))?;
            if let Some(v) = old_video.as_mut() {
                for i in 0..done {
                    let Some((f, _)) = v.read()? else { bail!("{}: ended after {i} frames while copying {done}", out.target.display()) };
                    let rgb: Vec<u8> = match &f.data {
                        FrameData::Ldr { codes, .. } => codes.iter().map(|&c| c as u8).collect(),
                        FrameData::Hdr(_) => bail!("{}: unexpected HDR frame from a video", out.target.display()),
                    };
                    sink.write_rgb8(&rgb)?;
                    thumbs.push(i, thumb_of(&f, &input.photometry));
                }
            }
            drop(old_video.take());
            Sink::Video { sink, partial }
        }
        #[cfg(not(feature = "opencv"))]
        unreachable!("Outputs::of refuses video without the feature")
    } else {
        Sink::Dir(a.format)
    };
    let mut report = if done > 0 { JsonLines::append(&out.report) } else { JsonLines::create(&out.report) }.with_context(|| format!("{}: cannot write the report", out.report.display()))?;

    // The frames.
    let total = input.count.map(|n| a.max_frames.map_or(n, |m| n.min(m)));
    let bar = match total {
        Some(n) => frame_bar(n, &format!("augment {}", input.sequence.as_deref().unwrap_or(&input.label))),
        None => {
            let b = indicatif::ProgressBar::new_spinner();
            b.set_style(indicatif::ProgressStyle::with_template("{prefix} {pos} frames, {per_sec} [{elapsed}]").unwrap_or_else(|_| indicatif::ProgressStyle::default_spinner()));
            b.set_prefix(format!("augment {}", input.label));
            b
        }
    };
    bar.set_position(done as u64);
    bar.reset_eta();
    let started = std::time::Instant::now();
    let mut counts = RunCounts::default();
    let mut stages = Stages::default();
    let mut i = done;
    let mut interrupted = false;
    let result: Result<()> = loop {
        if stop.load(Ordering::SeqCst) > 0 {
            interrupted = true;
            break Ok(());
        }
        if a.max_frames.is_some_and(|m| i >= m) {
            break Ok(());
        }
        let t = std::time::Instant::now();
        let (frame, ts, label) = match input.next(i) {
            Ok(Some(x)) => x,
            Ok(None) => break Ok(()),
            Err(e) => break Err(e.context(format!("{}: reading frame {i}", input.label))),
        };
        if let Err(e) = frame.check_size(Path::new(&label), k.width, k.height) {
            break Err(anyhow::Error::new(e).context(format!("the camera calibration {} is {}×{}", scene.camera_path.display(), k.width, k.height)));
        }
        let decode_ms = t.elapsed().as_secs_f64() * 1e3;
        let time = match input.clock.time(i, ts) {
            Ok(t) => t,
            Err(e) => break Err(e),
        };
        let (rendered, passes, rec, video) = match pipe.process(i, &time, &frame, &lin) {
            Ok(x) => x,
            Err(e) => break Err(e.context(label)),
        };
        let t = std::time::Instant::now();
        let written = match &mut sink {
            Sink::Dir(format) => {
                let kind = output_kind(*format, &frame);
                let p = a.output.join(format!("{}.{}", input.stem(i), kind.extension()));
                write_frame(&p, kind, &rendered.image, rendered.precision, &video, &frame, &input.photometry).map(|_| p.display().to_string())
            }
            #[cfg(feature = "opencv")]
            Sink::Video { sink, .. } => {
                let rgb = heliar::render::output::encode_rgb8(&rendered.image, rendered.precision, &video, &frame, &input.photometry);
                sink.write_rgb8(&rgb).map(|_| format!("{} frame {i}", out.target.display()))
            }
        };
        let written = match written {
            Ok(w) => w,
            Err(e) => break Err(anyhow::Error::new(e).context("writing the output")),
        };
        let encode_ms = t.elapsed().as_secs_f64() * 1e3;
        if thumbs.wants(i) {
            thumbs.push(i, Rgb8::from_radiance(&rendered.image, &input.photometry).shrink_to(320));
        }
        let e = &rec.estimate;
        let line = Record {
            frame: i,
            input: label,
            output: written,
            time: &e.time,
            status: e.status,
            fallback: e.fallback,
            sun_dir: e.sun.dir_world,
            sun_above_horizon: e.sun.above_horizon,
            pd: rec.lighting.pd.to_array(),
            pa: rec.lighting.pa.to_array(),
            condition_number: e.condition_number,
            relight: &rec.relight,
            passes: &passes,
            decode_ms,
            estimate_ms: rec.estimate_ms,
            composite_ms: rec.composite_ms,
            encode_ms,
            truth: input.truth.as_ref().and_then(|t| t.get(i).copied()),
        };
        if let Err(e) = report.write(&line) {
            break Err(anyhow::Error::new(e).context(format!("writing {}", out.report.display())));
        }
        counts.add(e.status, &passes, &rec.relight);
        stages.decode.add(decode_ms);
        stages.estimate.add(rec.estimate_ms);
        stages.relight.add(rec.relight.ms);
        stages.composite.add(rec.composite_ms);
        stages.encode.add(encode_ms);
        i += 1;
        bar.inc(1);
    };
    bar.finish_and_clear();

    // Close everything, whatever happened: the output and its reports cover frames 0..i.
    drop(report);
    #[cfg_attr(not(feature = "opencv"), allow(unused_mut))]
    let mut close_err: Option<anyhow::Error> = None;
    #[cfg(feature = "opencv")]
    if let Sink::Video { sink, partial } = &mut sink {
        if let Err(e) = sink.finish() {
            close_err = Some(anyhow::Error::new(e));
        } else if let Some(p) = partial
            && let Err(e) = std::fs::rename(&*p, &out.target)
        {
            close_err = Some(anyhow::Error::new(e).context(format!("renaming {} to {}", p.display(), out.target.display())));
        }
    }
    drop(sink);
    let this_run = i - done;
    let wall = started.elapsed().as_secs_f64();
    for s in [&mut stages.decode, &mut stages.estimate, &mut stages.relight, &mut stages.composite, &mut stages.encode] {
        s.finish();
    }
    let thumbs_list: Vec<Rgb8> = thumbs.items.into_iter().map(|(_, t)| t).collect();
    if let Err(e) = write_contact_sheet(&out.sheet, &thumbs_list, a.sheet_columns, 4) {
        eprintln!("warning: contact sheet not written: {e}");
    }
    let summary = Summary {
        input: input.label.clone(),
        output: out.target.display().to_string(),
        frames_written: i,
        frames_this_run: this_run,
        resumed_after: done,
        interrupted,
        error: result.as_ref().err().map(|e| format!("{e:#}")),
        input_frames: input.count,
        fps_in: input.fps,
        wall_s: wall,
        frames_per_second: if wall > 0.0 { this_run as f64 / wall } else { 0.0 },
        gpu: gpu.describe(),
        probe_source: pipe.probes.name().to_owned(),
        counts,
        stages,
    };
    if let Err(e) = std::fs::write(&out.summary, serde_json::to_string_pretty(&summary)?) {
        eprintln!("warning: {}: summary not written: {e}", out.summary.display());
    }
    print_summary(&summary);
    if let Some(n) = input.count
        && i < n
        && result.is_ok()
        && !interrupted
        && a.max_frames.is_none_or(|m| i < m)
    {
        eprintln!("warning: {} ended after {i} of the {n} frames its container announces (truncated or corrupt)", input.label);
    }
    if let Some(e) = close_err {
        return Err(e.context(format!("closing {}", out.target.display())));
    }
    if let Err(e) = result {
        return Err(e.context(format!("stopped after {i} frames; they are kept in {} (listed in {}); `--resume` continues", out.target.display(), out.report.display())));
    }
    eprintln!("wrote {i} frames to {}, {}, {} and {}", out.target.display(), out.report.display(), out.summary.display(), out.sheet.display());
    if interrupted {
        eprintln!("interrupted after {i} frames: `--resume` continues the run");
        std::process::exit(130);
    }
    Ok(())
}

fn output_kind(format: Option<Format>, frame: &Frame) -> OutputKind {
    match (format, &frame.data) {
        (Some(Format::Exr), _) | (None, FrameData::Hdr(_)) => OutputKind::Exr,
        _ => OutputKind::Png,
    }
}

fn print_summary(s: &Summary) {
    let mut t = Table::new(&["quantity", "value"]);
    t.push(vec!["frames written".into(), format!("{} ({} this run{})", s.frames_written, s.frames_this_run, if s.resumed_after > 0 { format!(", resumed after {}", s.resumed_after) } else { String::new() })]);
    t.push(vec!["throughput".into(), format!("{:.2} frames/s over {:.1} s", s.frames_per_second, s.wall_s)]);
    let statuses: Vec<String> = s.counts.statuses.iter().map(|(k, v)| format!("{k} {v}")).collect();
    t.push(vec!["estimator status".into(), statuses.join(", ")]);
    t.push(vec!["relights (probe updates)".into(), format!("{} ({})", s.counts.relights, s.probe_source)]);
    for (pass, reasons) in &s.counts.passes_skipped {
        let n: usize = reasons.values().sum();
        let first = reasons.iter().max_by_key(|(_, v)| **v).map(|(r, _)| r.as_str()).unwrap_or("");
        t.push(vec![format!("skipped {pass}"), format!("{n} frames (mostly: {first})")]);
    }
    for (name, st) in [("decode", &s.stages.decode), ("estimate", &s.stages.estimate), ("relight", &s.stages.relight), ("composite", &s.stages.composite), ("encode", &s.stages.encode)] {
        t.push(vec![format!("time: {name}"), format!("{:.1} s total, median {:.2} ms/frame", st.total_s, st.median_ms)]);
    }
    eprint!("{t}");
}
