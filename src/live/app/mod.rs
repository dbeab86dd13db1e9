//! The live window's state and its egui drawing: the composited feed, the pass switches, the
//! estimator's status and the live plots.
//!
//! [`LiveApp::process`] runs one captured frame through the [`OutdoorSession`] (estimate →
//! relight → probes → composite offscreen → read back), or, with the VEM panel's compositing on,
//! through the VEM renderer with the panel's lights and turns the result into 8-bit RGB through the
//! camera's response ([`encode_rgb8`]: untouched pixels keep their own codes), which the window
//! shows as an egui texture. [`LiveApp::ui`] takes the newest frame from the capture slot,
//! processes it and draws; it is a plain function of the state, so the tests drive it headless
//! with egui_kittest. A person drags and turns the virtual objects on the shown frame
//! (`drag`: [`LiveApp::begin_drag`], [`LiveApp::turn_object`], [`LiveApp::reset_objects`]).

mod drag;
mod panels;

pub use drag::{MAX_DRAG_DISTANCE_M, STEP_UP_M, TURN_DEG_PER_SCROLL_POINT, UP_FACING_COS};
pub use panels::FEED_ALT_TEXT;

use super::slot::LatestSlot;
use super::source::{Capture, CaptureStatus, Captured, SourceState};
use crate::estimate::FrameEstimate;
use crate::io::frames::Linearizer;
use crate::io::image::LinearImage;
use crate::run::clock::{ClockCheck, FrameClock};
use crate::run::session::{FrameRecord, OutdoorSession};
use crate::render::frame::luma;
use crate::render::output::encode_rgb8;
use crate::io::image::Rgb8;
use crate::irradiance::sources::ProbeSource;
use crate::render::vem::VemReport;
use crate::render::{Darkening, PassReport, PassSwitches, VideoFrame};
use crate::io::frames::Photometry;
use chrono::{DateTime, FixedOffset};
use std::collections::VecDeque;
use std::sync::Arc;
use std::sync::atomic::AtomicBool;
use std::time::{Duration, Instant};

/// The reason the pass report gives for a pass switched off in the window.
pub const TURNED_OFF: &str = "turned off in the live view";
/// How much history the plots keep, seconds.
pub const HISTORY_SECS: f64 = 300.0;
/// The window over which the frame rate is measured, seconds.
const FPS_WINDOW_SECS: f64 = 2.0;

/// The reason the outdoor compositor's report gives when the VEM panel lights the objects.
pub const VEM_COMPOSITES: &str = "the VEM panel lights the virtual objects (VEM renderer)";

/// What a frame's processing gives the window: its record, the outdoor passes, the VEM
/// renderer's report, the composite and the linearised footage.
type Processed = (FrameRecord, PassReport, Option<VemReport>, Rgb8, VideoFrame);

/// One point of the plots.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct HistoryPoint {
    /// Seconds since the window opened.
    pub t_s: f64,
    /// `Pd` and `Pa` luminance of the frame's own fit (`None` when it had none).
    pub pd: Option<f64>,
    /// See `pd`.
    pub pa: Option<f64>,
    /// `Pd` and `Pa` luminance the compositor used (smoothed).
    pub pd_used: f64,
    /// See `pd_used`.
    pub pa_used: f64,
    /// Mean of the three channels' residual RMS.
    pub residual_rms: Option<f64>,
}

/// What the window shows of the newest processed frame.
#[derive(Clone, Debug)]
pub struct Shown {
    /// Capture index.
    pub index: u64,
    /// Its time.
    pub time: DateTime<FixedOffset>,
    /// Estimate, lighting, relight and timings.
    pub record: FrameRecord,
    /// The outdoor compositor's report.
    pub passes: PassReport,
    /// The VEM renderer's report, when the VEM panel lit the objects.
    pub vem: Option<VemReport>,
    /// The composited frame, 8-bit RGB through the camera response.
    pub composited: Rgb8,
    /// The input frame, the same way.
    pub input: Rgb8,
    /// Processing time (estimate to read-back and encoding), ms.
    pub frame_ms: f64,
    /// From capture to shown, ms.
    pub latency_ms: f64,
}

/// Which probe source lights the virtual objects.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum AmbientChoice {
    /// The uniform sky of the frame's `Pa`.
    Uniform,
    /// The baked irradiance volume, relit per frame.
    Volume,
}

/// The live view.
pub struct LiveApp {
    /// The outdoor stage and the compositor.
    pub session: OutdoorSession,
    /// The probe source not in use (the other [`AmbientChoice`]), when there is one.
    other_probes: Option<Box<dyn ProbeSource + Send>>,
    photometry: Photometry,
    lin: Linearizer,
    clock: FrameClock,
    clock_check: ClockCheck,
    capture: Capture,
    /// Pass switches applied to the next frame.
    pub switches: PassSwitches,
    /// Darkening model applied to the next frame.
    pub darkening: Darkening,
    /// Show the input instead of the composite.
    pub show_input: bool,
    /// Take and process frames inside [`Self::ui`] (the window); tests may drive
    /// [`Self::process_next`] themselves instead.
    pub process_in_ui: bool,
    last: Option<Shown>,
    history: VecDeque<HistoryPoint>,
    shown_at: VecDeque<Instant>,
    processed: u64,
    error: Option<String>,
    texture: Option<egui::TextureHandle>,
    texture_dirty: bool,
    started: Instant,
    quit: Option<Arc<AtomicBool>>,
    title: String,
    /// The VEM panel (`--vem-input`).
    pub vem: Option<super::vem::VemPanel>,
    /// The last frame taken from the capture (composited again after a move by hand).
    last_input: Option<Captured>,
    /// The object being dragged.
    drag: Option<drag::Drag>,
    /// The object last dragged or turned.
    selected: Option<usize>,
    /// An object was moved by hand since the last composite.
    objects_dirty: bool,
}

impl LiveApp {
    /// The live view over `capture`'s frames. `other_probes` is the probe source for the other
    /// ambient choice (e.g. the uniform sky when the pipeline uses the irradiance volume).
    pub fn new(title: &str, session: OutdoorSession, other_probes: Option<Box<dyn ProbeSource + Send>>, photometry: Photometry, clock: FrameClock, capture: Capture) -> Self {
        let darkening = session.compositor.config().darkening;
        let switches = session.compositor.switches();
        Self {
            session,
            other_probes,
            lin: photometry.linearizer(),
            photometry,
            clock,
            clock_check: ClockCheck::default(),
            capture,
            switches,
            darkening,
            show_input: false,
            process_in_ui: true,
            last: None,
            history: VecDeque::new(),
            shown_at: VecDeque::new(),
            processed: 0,
            error: None,
            texture: None,
            texture_dirty: false,
            started: Instant::now(),
            quit: None,
            title: title.to_owned(),
            vem: None,
            last_input: None,
            drag: None,
            selected: None,
            objects_dirty: false,
        }
    }

    /// Closes the window when `flag` is set (Ctrl-C).
    pub fn quit_on(mut self, flag: Arc<AtomicBool>) -> Self {
        self.quit = Some(flag);
        self
    }

    /// The newest processed frame.
    pub fn last(&self) -> Option<&Shown> {
        self.last.as_ref()
    }

    /// The plot history.
    pub fn history(&self) -> &VecDeque<HistoryPoint> {
        &self.history
    }

    /// Frames processed.
    pub fn processed(&self) -> u64 {
        self.processed
    }

    /// Frames the capture replaced before the pipeline took them.
    pub fn dropped(&self) -> u64 {
        self.capture.slot().counts().dropped
    }

    /// The capture's state.
    pub fn capture_status(&self) -> CaptureStatus {
        self.capture.status()
    }

    /// The capture slot.
    pub fn slot(&self) -> &Arc<LatestSlot<Captured>> {
        self.capture.slot()
    }

    /// The last processing error, if the newest frame failed.
    pub fn error(&self) -> Option<&str> {
        self.error.as_deref()
    }

    /// A warning naming the frames whose time did not increase, if any did.
    pub fn clock_warning(&self) -> Option<String> {
        self.clock_check.warning(&self.capture.status().label)
    }

    /// The ambient source in use.
    pub fn ambient(&self) -> AmbientChoice {
        if self.session.stage.probes.name() == "irradiance_volume" { AmbientChoice::Volume } else { AmbientChoice::Uniform }
    }

    /// True when the other ambient source is available.
    pub fn can_switch_ambient(&self) -> bool {
        self.other_probes.is_some()
    }

    /// Switches the ambient source (relights on the next frame); false when that source is not
    /// available.
    pub fn set_ambient(&mut self, a: AmbientChoice) -> bool {
        if a == self.ambient() {
            return true;
        }
        match self.other_probes.as_mut() {
            Some(other) => {
                self.session.stage.swap_probes(other);
                true
            }
            None => false,
        }
    }

    /// Frames shown per second over the last two seconds.
    pub fn fps(&self) -> f64 {
        match (self.shown_at.front(), self.shown_at.back()) {
            (Some(a), Some(b)) if self.shown_at.len() > 1 && *b > *a => (self.shown_at.len() - 1) as f64 / (*b - *a).as_secs_f64(),
            _ => 0.0,
        }
    }

    /// Waits up to `timeout` for a frame and processes it; false when none came.
    pub fn process_next(&mut self, timeout: Duration) -> bool {
        match self.capture.slot().take_timeout(timeout) {
            Some(c) => {
                self.process(c);
                true
            }
            None => false,
        }
    }

    /// Runs one captured frame through the outdoor session with the current switches, or, when
    /// the VEM panel composes, estimates it and lights the objects with the panel's lights.
    pub fn process(&mut self, c: Captured) {
        let t = Instant::now();
        let canvas = self.session.compositor.canvas();
        let (w, h) = (canvas.out_width, canvas.out_height);
        if (c.frame.width, c.frame.height) != (w, h) {
            self.error = Some(format!("frame {} is {}×{} but the camera calibration is {w}×{h}", c.index, c.frame.width, c.frame.height));
            return;
        }
        self.session.compositor.set_switches(self.switches, TURNED_OFF);
        self.session.compositor.set_darkening(self.darkening);
        let time = match self.clock.time(c.index as usize, c.ts_ms, Some(c.at)) {
            Ok(t) => t,
            Err(e) => {
                self.error = Some(format!("frame {}: {e}", c.index));
                return;
            }
        };
        self.clock_check.check(c.index as usize, time);
        let composes = self.vem.as_ref().is_some_and(|v| v.composes());
        let result = if composes { self.process_vem(&c, &time) } else { self.process_outdoor(&c, &time) };
        let (record, passes, vem, composited, video) = match result {
            Ok(x) => x,
            Err(e) => {
                self.error = Some(format!("frame {}: {e:#}", c.index));
                return;
            }
        };
        self.error = None;
        let input = rgb8(encode_rgb8(&linear_of(&video), 0.0, &video, &c.frame, &self.photometry), w, h);
        self.push_history(&record);
        let now = Instant::now();
        self.shown_at.push_back(now);
        while self.shown_at.front().is_some_and(|a| (now - *a).as_secs_f64() > FPS_WINDOW_SECS) {
            self.shown_at.pop_front();
        }
        self.processed += 1;
        self.last = Some(Shown { index: c.index, time, record, passes, vem, composited, input, frame_ms: t.elapsed().as_secs_f64() * 1e3, latency_ms: c.at.elapsed().as_secs_f64() * 1e3 });
        self.texture_dirty = true;
        self.objects_dirty = false;
        self.last_input = Some(c);
    }

    /// The outdoor compositor's frame.
    fn process_outdoor(&mut self, c: &Captured, time: &DateTime<FixedOffset>) -> anyhow::Result<Processed> {
        let f = self.session.process(c.index as usize, time, &c.frame, &self.lin)?;
        let composited = rgb8(encode_rgb8(&f.rendered.image, f.rendered.precision, &f.video, &c.frame, &self.photometry), f.video.width, f.video.height);
        Ok((f.record, f.passes, None, composited, f.video))
    }

    /// The VEM renderer's frame over the feed (the estimator still runs, for the status and the
    /// plots); the outdoor compositor's passes are reported as skipped.
    fn process_vem(&mut self, c: &Captured, time: &DateTime<FixedOffset>) -> anyhow::Result<Processed> {
        let record = self.session.prepare(c.index as usize, time, &c.frame, &self.lin)?;
        let video = VideoFrame::from_frame(&c.frame, &self.lin);
        let dt_s = self.last.as_ref().map_or(0.0, |l| (*time - l.time).num_microseconds().unwrap_or(0) as f64 * 1e-6).max(0.0);
        let (passes, report, composited) = self.compose_vem(time, &video, dt_s)?;
        Ok((record, passes, Some(report), composited, video))
    }

    /// The VEM overlay over `video`, its objects brought to where their motions and the moves by
    /// hand put them at `time` first (`VemPanel::pose_objects`; the pass report lists those that
    /// moved). The outdoor compositor's objects are left where it last put them: it catches up
    /// on its own next frame.
    fn compose_vem(&mut self, time: &DateTime<FixedOffset>, video: &VideoFrame, dt_s: f64) -> anyhow::Result<(PassReport, VemReport, Rgb8)> {
        let panel = self.vem.as_mut().ok_or_else(|| anyhow::anyhow!("no VEM panel"))?;
        let mut passes = PassReport::default();
        if let Some(m) = &self.session.motion {
            let moved = panel.pose_objects(m.poses_at(time), |p| m.meshes_in(p))?;
            passes.moved = m.names().into_iter().zip(moved).filter(|(_, moved)| *moved).map(|(n, _)| n.to_owned()).collect();
        }
        let out = panel.render_over(&linear_of(video), dt_s).ok_or_else(|| anyhow::anyhow!("the VEM panel has no frame yet"))??;
        let composited = rgb8(out.srgb.chunks_exact(4).flat_map(|p| [p[0], p[1], p[2]]).collect(), video.width, video.height);
        passes.skip(crate::render::frame::pass::COMPOSITE, VEM_COMPOSITES);
        Ok((passes, out.report, composited))
    }

    fn push_history(&mut self, r: &FrameRecord) {
        let l = |v: Option<[f64; 3]>| v.map(|v| 0.2126 * v[0] + 0.7152 * v[1] + 0.0722 * v[2]);
        let e: &FrameEstimate = &r.estimate;
        let t_s = self.started.elapsed().as_secs_f64();
        self.history.push_back(HistoryPoint {
            t_s,
            pd: l(e.pd),
            pa: l(e.pa),
            pd_used: luma(r.lighting.pd) as f64,
            pa_used: luma(r.lighting.pa) as f64,
            residual_rms: e.residual_rms.map(|v| (v[0] + v[1] + v[2]) / 3.0),
        });
        while self.history.front().is_some_and(|p| t_s - p.t_s > HISTORY_SECS) {
            self.history.pop_front();
        }
    }

    /// The status line of the estimator ("status ok", "status no_direct_sun (fallback held_split)").
    pub fn estimator_status(&self) -> Option<String> {
        let e = &self.last.as_ref()?.record.estimate;
        let mut s = format!("status {}", snake(&e.status));
        if let Some(f) = &e.fallback {
            s += &format!(" (fallback {})", snake(f));
        }
        Some(s)
    }

    /// The capture line ("running", "lost: … — retrying every 1 s", "ended").
    pub fn source_line(&self) -> String {
        let s = self.capture.status();
        match &s.state {
            SourceState::Opening => format!("opening {}", s.label),
            SourceState::Running => format!("running: {}", s.label),
            SourceState::Lost { reason, retries } => format!("camera lost, retrying ({} attempts): {reason}", retries + 1),
            SourceState::Ended => format!("ended: {} (all {} frames shown or dropped)", s.label, s.captured),
        }
    }

}

impl eframe::App for LiveApp {
    fn ui(&mut self, ui: &mut egui::Ui, _frame: &mut eframe::Frame) {
        LiveApp::ui(self, ui);
    }
}

fn rgb8(data: Vec<u8>, width: u32, height: u32) -> Rgb8 {
    Rgb8 { width, height, data }
}

fn linear_of(v: &VideoFrame) -> LinearImage {
    LinearImage { width: v.width, height: v.height, data: v.rgba.iter().map(|p| [p[0], p[1], p[2]]).collect() }
}

fn snake<T: serde::Serialize + std::fmt::Debug>(v: &T) -> String {
    serde_json::to_value(v).ok().and_then(|v| v.as_str().map(str::to_owned)).unwrap_or_else(|| format!("{v:?}"))
}
