//! `heliar live`: the outdoor pipeline over a camera, a stream or a file played as one, in a
//! window (feature `opencv`; see `heliar::live`).
//!
//! Frame times: the wall clock for cameras (shifted by `--start` or `--time-offset`, to try a
//! place's sun at another hour); for files, the container's timestamps (or index / fps) from
//! `--start` or the scene sequence's start, and a folder that is one of the scene's sequences
//! brings its own times and exposure, as in `heliar augment`.
//! `--headless-frames N` runs the same loop without a window for N frames and prints the
//! timings (for measurements on machines without a display).

use clap::Args;
use std::path::PathBuf;

#[derive(Args)]
#[cfg_attr(not(feature = "opencv"), allow(dead_code))]
pub struct LiveArgs {
    /// Scene folder (camera, proxy, virtual objects).
    scene: PathBuf,
    /// Camera index (0, 1, …) or stream URL (rtsp://…, http://…).
    #[arg(long, conflicts_with = "input", required_unless_present = "input")]
    camera: Option<String>,
    /// A video file or a folder of PNG/EXR frames, played as if it were a camera.
    #[arg(long)]
    input: Option<PathBuf>,
    /// Play the file again from the start when it ends.
    #[arg(long = "loop")]
    looped: bool,
    /// Frame rate of a folder of frames (or overriding a video's).
    #[arg(long)]
    fps: Option<f64>,
    /// Time of the first frame (RFC 3339): files count from it; for a camera the wall clock
    /// is shifted so that it starts there.
    #[arg(long)]
    start: Option<String>,
    /// Seconds added to the wall clock of a camera.
    #[arg(long, default_value_t = 0.0, allow_negative_numbers = true)]
    time_offset: f64,
    /// Scene sequence whose exposure (and start time) to use.
    #[arg(long)]
    sequence: Option<String>,
    /// Exposure (camera linear value per unit radiance), overriding the calibration.
    #[arg(long)]
    exposure: Option<f32>,
    /// How real pixels are darkened by the virtual objects (switchable in the window).
    #[arg(long, value_enum, default_value = "differential")]
    darkening: crate::augment::DarkeningArg,
    /// Ambient light of the virtual objects (switchable in the window when the scene has an
    /// irradiance volume).
    #[arg(long, value_enum, default_value = "auto")]
    ambient: crate::augment::AmbientArg,
    /// MSAA samples (1 or 4); 1 by default in the live view (4 doubles the canvas passes on a
    /// software rasteriser).
    #[arg(long, default_value_t = 1)]
    samples: u32,
    /// Paths per pixel of the virtual objects' per-pixel ambient transfer (0: probes × ambient
    /// occlusion; switchable in the window when on).
    #[arg(long, default_value_t = heliar::render::object_transfer::TRANSFER_PATHS)]
    transfer_paths: u32,
    /// A captured VEM sequence (fisheye/equirect/polar frames) to decompose into lights in a
    /// panel of the window.
    #[arg(long)]
    vem_input: Option<PathBuf>,
    /// The VEM sequence's calibration (calib/fisheye.toml).
    #[arg(long, requires = "vem_input")]
    vem_calib: Option<PathBuf>,
    /// Initial light count of the VEM panel.
    #[arg(long, default_value_t = 64, requires = "vem_input")]
    vem_lights: usize,
    /// Run without a window for this many frames and print the timings.
    #[arg(long)]
    headless_frames: Option<usize>,
}

#[cfg(not(feature = "opencv"))]
pub fn run(_a: LiveArgs) -> anyhow::Result<()> {
    anyhow::bail!("`heliar live` needs heliar built with `--features opencv` (cameras, video and the window); `heliar augment` works on frame folders without it")
}

#[cfg(feature = "opencv")]
pub fn run(a: LiveArgs) -> anyhow::Result<()> {
    imp::run(a)
}

#[cfg(feature = "opencv")]
mod imp {
    use super::LiveArgs;
    use crate::common::{build_estimator, load_scene};
    use anyhow::{Context, Result, anyhow, bail};
    use heliar::live::source::opener_for;
    use heliar::live::{Capture, CaptureOptions, FrameClock, LatestSlot, LiveApp};
    use heliar::pipeline::{Ambient, Pipeline, probe_source};
    use heliar::irradiance::sources::{ProbeSource, UniformSky};
    use heliar::render::CompositorConfig;
    use heliar::report::median;
    use heliar::scene::{Scene, parse_time};
    use std::path::Path;
    use std::sync::Arc;
    use std::sync::atomic::{AtomicBool, Ordering};
    use std::time::Duration;

    /// Photometry, clock and playback rate of the input.
    fn timing(scene: &Scene, a: &LiveArgs) -> Result<(heliar::io::frames::Photometry, FrameClock, Option<f64>)> {
        let borrowed = a.sequence.as_deref().map(|n| crate::common::pick_sequence(scene, Some(n)).context("--sequence")).transpose()?;
        let start = a.start.as_deref().map(|s| parse_time(Path::new("--start"), "start", s)).transpose()?;
        if let Some(f) = a.fps
            && !(f.is_finite() && f > 0.0)
        {
            bail!("--fps {f}: must be a positive number of frames per second");
        }
        let mut photometry = borrowed.map(|s| s.photometry.clone()).unwrap_or_else(|| scene.photometry.clone());
        let (clock, fps) = match &a.input {
            None => (FrameClock::wall(start, a.time_offset), None),
            Some(p) => {
                if !p.exists() {
                    bail!("{}: input not found", p.display());
                }
                let want = std::fs::canonicalize(p).ok();
                let seq = scene.sequences.iter().find(|s| s.files.first().and_then(|f| f.parent()).and_then(|d| std::fs::canonicalize(d).ok()) == want && p.is_dir());
                match (seq, start) {
                    (Some(s), None) => {
                        photometry = s.photometry.clone();
                        let seq_fps = if s.times.len() > 1 { 1e6 / (s.times[1] - s.times[0]).num_microseconds().unwrap_or(1_000_000).max(1) as f64 } else { 1.0 };
                        (FrameClock::List(s.times.clone()), Some(a.fps.unwrap_or(seq_fps)))
                    }
                    (_, Some(t0)) => (FrameClock::Start { t0, fps: a.fps.unwrap_or(25.0) }, a.fps),
                    (None, None) if p.is_dir() => bail!("{} is not one of the scene's sequences: give --start and --fps", p.display()),
                    (None, None) => {
                        let seq = borrowed.or(scene.sequences.first()).filter(|s| !s.times.is_empty()).ok_or_else(|| anyhow!("{}: give --start (the time of the first frame)", p.display()))?;
                        eprintln!("note: frame times start at sequence '{}''s start {} (give --start for the video's own)", seq.name, seq.times[0].to_rfc3339());
                        (FrameClock::Start { t0: seq.times[0], fps: a.fps.unwrap_or(25.0) }, a.fps)
                    }
                }
            }
        };
        if let Some(e) = a.exposure {
            if !(e.is_finite() && e > 0.0) {
                bail!("--exposure {e}: must be positive");
            }
            photometry.exposure = e;
        }
        Ok((photometry, clock, fps))
    }

    pub fn run(a: LiveArgs) -> Result<()> {
        let (scene, ray) = load_scene(&a.scene)?;
        let (photometry, clock, fps) = timing(&scene, &a)?;
        let opener = opener_for(a.input.as_deref(), a.camera.as_deref(), fps)?;

        let estimator = build_estimator(&scene, ray.clone())?;
        let mut config = CompositorConfig::for_scene(&scene);
        config.darkening = a.darkening.into();
        config.transfer_paths = a.transfer_paths;
        let (_gpu, comp) = crate::augment::gpu_compositor(&scene, ray.clone(), a.samples, config)?;
        let ambient: Ambient = a.ambient.into();
        let probes = probe_source(&scene, ray.clone(), ambient, |s, r| crate::bake::bake_with_progress(s, r, false))?;
        // The uniform sky is always at hand as the other choice of the volume.
        let other: Option<Box<dyn ProbeSource + Send>> = (probes.name() != "uniform_sky").then(|| Box::new(UniformSky::for_scene(&scene)) as Box<dyn ProbeSource + Send>);
        let pipe = Pipeline::new(estimator, comp, probes);

        let stop = Arc::new(AtomicBool::new(false));
        {
            let stop = stop.clone();
            if let Err(e) = ctrlc::set_handler(move || {
                if stop.swap(true, Ordering::SeqCst) {
                    std::process::exit(130);
                }
            }) {
                eprintln!("warning: cannot catch Ctrl-C ({e})");
            }
        }
        let options = CaptureOptions { looped: a.looped, ..Default::default() };
        let capture = Capture::start(opener, Arc::new(LatestSlot::new()), options);
        let title = format!("heliar live — {}", scene.manifest.name);
        let mut app = LiveApp::new(&title, pipe, other, photometry, clock, capture).quit_on(stop.clone());
        if let Some(v) = &a.vem_input {
            app.vem = Some(heliar::live::vem::VemPanel::open(v, a.vem_calib.as_deref(), a.vem_lights)?);
        }

        if let Some(n) = a.headless_frames {
            return headless(&mut app, n, &stop);
        }
        let opts = eframe::NativeOptions {
            viewport: egui::ViewportBuilder::default().with_inner_size([1280.0, 860.0]).with_title(&title),
            renderer: eframe::Renderer::Wgpu,
            ..Default::default()
        };
        eframe::run_native("heliar-live", opts, Box::new(move |_cc| Ok(Box::new(app))))
            .map_err(|e| anyhow!("cannot open the live window: {e} (it needs a display; `--headless-frames N` runs the same loop without one)"))
    }

    fn headless(app: &mut LiveApp, n: usize, stop: &AtomicBool) -> Result<()> {
        let mut frame_ms = Vec::new();
        let mut composite_ms = Vec::new();
        let t = std::time::Instant::now();
        while app.processed() < n as u64 && !stop.load(Ordering::SeqCst) {
            if !app.process_next(Duration::from_millis(200)) {
                let s = app.capture_status();
                if s.state == heliar::live::SourceState::Ended && app.slot().counts().put == app.slot().counts().taken + app.dropped() {
                    break;
                }
                if let heliar::live::SourceState::Lost { .. } = s.state {
                    eprintln!("{}", app.source_line());
                }
                continue;
            }
            if let Some(e) = app.error() {
                eprintln!("error: {e}");
            }
            if let Some(s) = app.last() {
                frame_ms.push(s.frame_ms);
                composite_ms.push(s.record.composite_ms);
                println!("frame {} {} {} Pd {:.3} Pa {:.3} {:.1} ms", s.index, s.time.to_rfc3339(), app.estimator_status().unwrap_or_default(), heliar::render::frame::luma(s.record.lighting.pd), heliar::render::frame::luma(s.record.lighting.pa), s.frame_ms);
            }
        }
        let wall = t.elapsed().as_secs_f64();
        eprintln!(
            "processed {} frames in {wall:.1} s ({:.1} fps), dropped {}; frame time median {:.1} ms (composite {:.1} ms)",
            app.processed(),
            app.processed() as f64 / wall.max(1e-9),
            app.dropped(),
            median(&frame_ms),
            median(&composite_ms)
        );
        Ok(())
    }
}
