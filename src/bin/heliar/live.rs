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
    /// Paths per frame of the re-trace of the sun-dependent terms after the sun has moved
    /// 0.25°, done a slice per frame while the previous values serve (0: whole, stalling the
    /// window for seconds).
    #[arg(long, default_value_t = heliar::render::TRACE_PATHS_PER_FRAME)]
    trace_paths_per_frame: u64,
    /// Paths per frame of the estimator's sun-bounce re-trace after the sun has moved 0.25°, a
    /// slice per frame while the previous bounce serves (0: whole, a stall of ~0.7 s at 320×240).
    /// Overrides `[estimator] trace_paths_per_frame`, whose default (0) suits offline runs.
    #[arg(long, default_value_t = heliar::scene::settings::ESTIMATOR_TRACE_PATHS_PER_FRAME)]
    estimator_trace_paths_per_frame: u64,
    /// A captured VEM sequence (fisheye/equirect/polar frames) to decompose into lights in a
    /// panel of the window.
    #[arg(long)]
    vem_input: Option<PathBuf>,
    /// The VEM sequence's calibration (calib/fisheye.toml).
    #[arg(long, requires = "vem_input")]
    vem_calib: Option<PathBuf>,
    /// Yaw of the VEM sequence, degrees (as `heliar vem --yaw`: the azimuth its north looks
    /// toward; 2:1 frames are equirect maps with north at the centre column).
    #[arg(long, default_value_t = 0.0, allow_negative_numbers = true, requires = "vem_input")]
    vem_yaw: f64,
    /// Initial light count of the VEM panel.
    #[arg(long, default_value_t = 64, requires = "vem_input")]
    vem_lights: usize,
    /// Run without a window for this many frames and print the timings.
    #[arg(long)]
    headless_frames: Option<usize>,
    /// Without a window: give up (exit status 1) when the source stays lost, or gives no frame,
    /// this many seconds. The window keeps retrying and shows the count.
    #[arg(long, default_value_t = 30.0)]
    retry_for: f64,
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
    use crate::common::load_scene;
    use anyhow::{Result, anyhow, bail};
    use heliar::irradiance::sources::{ProbeSource, UniformSky};
    use heliar::live::{Capture, CaptureOptions, LatestSlot, LiveApp};
    use heliar::render::CompositorConfig;
    use heliar::render::vem::VemRenderConfig;
    use heliar::report::median;
    use heliar::run::source::{InputOptions, resolve_input};
    use heliar::run::vem::VemOverlay;
    use std::sync::Arc;
    use std::sync::atomic::{AtomicBool, Ordering};
    use std::time::Duration;

    pub fn run(a: LiveArgs) -> Result<()> {
        if !(a.retry_for.is_finite() && a.retry_for > 0.0) {
            bail!("--retry-for {}: must be a positive number of seconds", a.retry_for);
        }
        let (mut scene, ray) = load_scene(&a.scene)?;
        scene.estimator.trace_paths_per_frame = a.estimator_trace_paths_per_frame;
        let options = InputOptions {
            input: a.input.clone(),
            camera: a.camera.clone(),
            sequence: a.sequence.clone(),
            start: a.start.clone(),
            fps: a.fps,
            exposure: a.exposure,
            time_offset_s: a.time_offset,
            looped: a.looped,
        };
        let input = resolve_input(&scene, &options)?;
        let mut config = CompositorConfig::for_scene(&scene);
        config.darkening = a.darkening.into();
        config.transfer_paths = a.transfer_paths;
        config.trace_paths_per_frame = a.trace_paths_per_frame;
        let mut session = crate::augment::outdoor_session(&scene, ray, a.samples, config, a.ambient.into())?;
        // The objects follow their motions and can be dragged and turned by hand; their key
        // times in seconds count from the first frame. The visibility cuts of all of them are
        // loaded from `baked/cuts.bin` or computed there (`heliar precompute --draggable`).
        let start = input.clock.time(0, Some(0.0), None)?;
        let cuts = heliar::run::precompute::cuts_path(&scene);
        if !scene.virtual_objects.is_empty() && !cuts.exists() {
            eprintln!("computing the objects' visibility cuts for dragging them (once: cached in {}; `heliar precompute --draggable` takes finer settings)", cuts.display());
        }
        session.follow_live(&scene, start);
        // The uniform sky is always at hand as the other choice of the volume.
        let other: Option<Box<dyn ProbeSource + Send>> =
            (session.stage.probes.name() != "uniform_sky").then(|| Box::new(UniformSky::for_scene(&scene)) as Box<dyn ProbeSource + Send>);

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
        let gpu = session.compositor.gpu().clone();
        let capture = Capture::start(input.opener(), Arc::new(LatestSlot::new()), CaptureOptions { looped: a.looped, ..Default::default() });
        let title = format!("heliar live — {}", scene.manifest.name);
        let mut app = LiveApp::new(&title, session, other, input.photometry.clone(), input.clock.clone(), capture).quit_on(stop.clone());
        if let Some(v) = &a.vem_input {
            let panel = heliar::live::vem::VemPanel::open(v, a.vem_calib.as_deref(), a.vem_lights, a.vem_yaw)?;
            // The VEM renderer shares the compositor's device: the objects can be lit by the
            // panel's lights over the feed (switchable in the panel).
            app.vem = Some(panel.with_overlay(VemOverlay::new(gpu, &scene, VemRenderConfig::default())?));
        }

        if let Some(n) = a.headless_frames {
            return headless(&mut app, n, &stop, a.retry_for);
        }
        let opts = eframe::NativeOptions {
            viewport: egui::ViewportBuilder::default().with_inner_size([1280.0, 860.0]).with_title(&title),
            renderer: eframe::Renderer::Wgpu,
            ..Default::default()
        };
        eframe::run_native("heliar-live", opts, Box::new(move |_cc| Ok(Box::new(app))))
            .map_err(|e| anyhow!("cannot open the live window: {e} (it needs a display; `--headless-frames N` runs the same loop without one)"))
    }

    fn headless(app: &mut LiveApp, n: usize, stop: &AtomicBool, retry_for: f64) -> Result<()> {
        let (mut frame_ms, mut composite_ms) = (Vec::new(), Vec::new());
        let mut errors: Vec<String> = Vec::new();
        let t = std::time::Instant::now();
        let mut last_progress = std::time::Instant::now();
        let mut seen = 0u64;
        while app.processed() < n as u64 && !stop.load(Ordering::SeqCst) {
            if let Some(v) = app.vem.as_mut() {
                v.tick();
            }
            let got = app.process_next(Duration::from_millis(200));
            let s = app.capture_status();
            if got || s.captured > seen {
                seen = s.captured;
                last_progress = std::time::Instant::now();
            } else if last_progress.elapsed().as_secs_f64() > retry_for {
                bail!("{}: no frame for {retry_for:.0} s ({}); giving up (--retry-for)", s.label, app.source_line());
            }
            if !got {
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
                errors.push(e.to_owned());
                if errors.len() >= n.max(1) {
                    break;
                }
                continue;
            }
            if let Some(s) = app.last() {
                frame_ms.push(s.frame_ms);
                composite_ms.push(s.record.composite_ms);
                println!("frame {} {} {} Pd {:.3} Pa {:.3} {:.1} ms", s.index, s.time.to_rfc3339(), app.estimator_status().unwrap_or_default(), heliar::render::frame::luma(s.record.lighting.pd), heliar::render::frame::luma(s.record.lighting.pa), s.frame_ms);
            }
        }
        let wall = t.elapsed().as_secs_f64();
        if let Some(w) = app.clock_warning() {
            eprintln!("{w}");
        }
        if frame_ms.is_empty() {
            eprintln!("processed no frame in {wall:.1} s");
        } else {
            eprintln!(
                "processed {} frames in {wall:.1} s ({:.1} fps), dropped {}; frame time median {:.1} ms (composite {:.1} ms)",
                frame_ms.len(),
                frame_ms.len() as f64 / wall.max(1e-9),
                app.dropped(),
                median(&frame_ms),
                median(&composite_ms)
            );
        }
        if let Some(first) = errors.first() {
            bail!("{} of the frames failed; the first: {first}", errors.len());
        }
        Ok(())
    }
}
