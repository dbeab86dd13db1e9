//! Where live frames come from, and the capture thread that reads them.
//!
//! A [`FrameSource`] is a camera, a stream, a video file or a folder of PNG/EXR frames; files
//! play as if they were a camera, paced at their frame rate. [`Capture`] runs one source on its
//! own thread and hands every frame to a [`LatestSlot`] (the newest frame wins).
//!
//! # Camera loss
//! A read error, a camera that stops giving frames (a read that returns none), or a source that
//! cannot be opened puts the capture in [`SourceState::Lost`]; the thread then reopens the source
//! every [`CaptureOptions::retry`] until it works again. A read that blocks (a stream whose
//! server vanished) is caught by [`Capture::watchdog`]: after [`CaptureOptions::stall`] without a
//! frame it abandons that thread (it exits once its read returns) and starts a fresh one.

use super::slot::LatestSlot;
use crate::io::frames::{Frame, list_frame_files};
use anyhow::{Context, Result, bail};
use std::path::{Path, PathBuf};
use std::sync::atomic::{AtomicBool, AtomicU64, Ordering};
use std::sync::{Arc, Mutex};
use std::time::{Duration, Instant};

/// A source of frames.
pub trait FrameSource: Send {
    /// What it reads, for messages.
    fn label(&self) -> String;
    /// The next frame and its timestamp in ms from the start of the source (when it has one);
    /// `None` at the end of a file, or when a camera gave no frame.
    fn read(&mut self) -> Result<Option<(Frame, Option<f64>)>>;
    /// Frame rate to pace reading at (files), or `None` for a source that paces itself (cameras).
    fn pace_fps(&self) -> Option<f64>;
    /// True for files and folders: the end of the frames is the end of the input, not a loss.
    fn is_file(&self) -> bool;
}

/// Opens (and reopens) a source.
pub type Opener = Box<dyn FnMut() -> Result<Box<dyn FrameSource>> + Send>;

/// A folder of PNG/EXR frames, sorted by name, played at `fps`.
pub struct FolderSource {
    dir: PathBuf,
    files: Vec<PathBuf>,
    next: usize,
    fps: f64,
}

impl FolderSource {
    /// Lists the folder's frames.
    pub fn open(dir: &Path, fps: f64) -> Result<Self> {
        let files = list_frame_files(dir)?;
        if files.is_empty() {
            bail!("{}: no .png or .exr frames", dir.display());
        }
        if !(fps.is_finite() && fps > 0.0) {
            bail!("{}: frame rate {fps} must be positive", dir.display());
        }
        Ok(Self { dir: dir.to_owned(), files, next: 0, fps })
    }
}

impl FrameSource for FolderSource {
    fn label(&self) -> String {
        self.dir.display().to_string()
    }
    fn read(&mut self) -> Result<Option<(Frame, Option<f64>)>> {
        let Some(p) = self.files.get(self.next) else { return Ok(None) };
        let ts = self.next as f64 * 1e3 / self.fps;
        self.next += 1;
        Ok(Some((Frame::load(p)?, Some(ts))))
    }
    fn pace_fps(&self) -> Option<f64> {
        Some(self.fps)
    }
    fn is_file(&self) -> bool {
        true
    }
}

/// A video file (container timestamps), played at its frame rate or a given one.
pub struct VideoFileSource {
    video: crate::io::video::VideoSource,
    fps: f64,
}

impl VideoFileSource {
    /// Opens `path`; `fps` overrides the container's rate (needed when it gives none).
    pub fn open(path: &Path, fps: Option<f64>) -> Result<Self> {
        let video = crate::io::video::VideoSource::open_file(path)?;
        let fps = match fps.or((video.fps() > 0.0).then_some(video.fps())) {
            Some(f) if f.is_finite() && f > 0.0 => f,
            _ => bail!("{}: the container gives no frame rate: give --fps", path.display()),
        };
        Ok(Self { video, fps })
    }
}

impl FrameSource for VideoFileSource {
    fn label(&self) -> String {
        self.video.label().display().to_string()
    }
    fn read(&mut self) -> Result<Option<(Frame, Option<f64>)>> {
        Ok(self.video.read()?.map(|(f, ts)| (f, ts.is_finite().then_some(ts))))
    }
    fn pace_fps(&self) -> Option<f64> {
        Some(self.fps)
    }
    fn is_file(&self) -> bool {
        true
    }
}

/// A camera (by index) or a stream (by URL).
pub struct CameraSource {
    video: crate::io::video::VideoSource,
}

impl CameraSource {
    /// Opens `spec`: a camera index (`0`) or a stream URL.
    pub fn open(spec: &str) -> Result<Self> {
        Ok(Self { video: crate::io::video::VideoSource::open_camera(spec)? })
    }
}

impl FrameSource for CameraSource {
    fn label(&self) -> String {
        self.video.label().display().to_string()
    }
    fn read(&mut self) -> Result<Option<(Frame, Option<f64>)>> {
        Ok(self.video.read()?.map(|(f, ts)| (f, ts.is_finite().then_some(ts))))
    }
    fn pace_fps(&self) -> Option<f64> {
        None
    }
    fn is_file(&self) -> bool {
        false
    }
}

/// A captured frame.
#[derive(Clone, Debug)]
pub struct Captured {
    /// The frame.
    pub frame: Frame,
    /// Frames captured before this one (over reopenings and loops).
    pub index: u64,
    /// Timestamp from the start of the source, ms, when it has one.
    pub ts_ms: Option<f64>,
    /// When it was captured.
    pub at: Instant,
}

/// What the capture is doing.
#[derive(Clone, Debug, PartialEq)]
pub enum SourceState {
    /// Opening the source (before its first frame).
    Opening,
    /// Frames arrive.
    Running,
    /// The source failed or went silent; it is reopened every [`CaptureOptions::retry`].
    Lost {
        /// What happened.
        reason: String,
        /// Reopening attempts so far.
        retries: u32,
    },
    /// A file ended (without `--loop`).
    Ended,
}

/// Capture settings.
#[derive(Clone, Copy, Debug)]
pub struct CaptureOptions {
    /// Wait between reopening attempts.
    pub retry: Duration,
    /// Time without a frame after which a running source counts as lost and is restarted.
    pub stall: Duration,
    /// Play files again from the start when they end.
    pub looped: bool,
}

impl Default for CaptureOptions {
    fn default() -> Self {
        Self { retry: Duration::from_secs(1), stall: Duration::from_secs(3), looped: false }
    }
}

/// What the window reads about the capture.
#[derive(Clone, Debug)]
pub struct CaptureStatus {
    /// State.
    pub state: SourceState,
    /// The source's label (once opened).
    pub label: String,
    /// Frames captured.
    pub captured: u64,
    /// When the newest frame arrived.
    pub last_frame: Option<Instant>,
    /// Times the source was lost.
    pub losses: u32,
    /// The interval a paced file is read at (the watchdog waits that much longer).
    pub frame_interval: Option<Duration>,
}

struct Shared {
    status: Mutex<CaptureStatus>,
    stop: AtomicBool,
    generation: AtomicU64,
    captured: AtomicU64,
}

impl Shared {
    fn status(&self) -> std::sync::MutexGuard<'_, CaptureStatus> {
        self.status.lock().unwrap_or_else(|p| p.into_inner())
    }
    fn lost(&self, reason: String) {
        let mut s = self.status();
        s.state = match &s.state {
            SourceState::Lost { retries, .. } => SourceState::Lost { reason, retries: retries + 1 },
            _ => {
                s.losses += 1;
                SourceState::Lost { reason, retries: 0 }
            }
        };
    }
    fn current(&self, generation: u64) -> bool {
        !self.stop.load(Ordering::SeqCst) && self.generation.load(Ordering::SeqCst) == generation
    }
    /// Sleeps up to `d`, returning early (false) when this thread should end.
    fn sleep(&self, generation: u64, d: Duration) -> bool {
        let end = Instant::now() + d;
        while Instant::now() < end {
            if !self.current(generation) {
                return false;
            }
            std::thread::sleep((end - Instant::now()).min(Duration::from_millis(20)));
        }
        self.current(generation)
    }
}

/// The capture thread of one source.
pub struct Capture {
    shared: Arc<Shared>,
    slot: Arc<LatestSlot<Captured>>,
    opener: Arc<Mutex<Opener>>,
    options: CaptureOptions,
    threads: Vec<std::thread::JoinHandle<()>>,
}

impl Capture {
    /// Starts capturing from what `opener` opens into `slot`.
    pub fn start(opener: Opener, slot: Arc<LatestSlot<Captured>>, options: CaptureOptions) -> Self {
        let shared = Arc::new(Shared {
            status: Mutex::new(CaptureStatus { state: SourceState::Opening, label: String::new(), captured: 0, last_frame: None, losses: 0, frame_interval: None }),
            stop: AtomicBool::new(false),
            generation: AtomicU64::new(0),
            captured: AtomicU64::new(0),
        });
        let mut c = Self { shared, slot, opener: Arc::new(Mutex::new(opener)), options, threads: Vec::new() };
        c.spawn();
        c
    }

    fn spawn(&mut self) {
        let generation = self.shared.generation.load(Ordering::SeqCst);
        let (shared, slot, opener, opts) = (self.shared.clone(), self.slot.clone(), self.opener.clone(), self.options);
        let h = std::thread::Builder::new().name("heliar-capture".into()).spawn(move || capture_loop(&shared, &slot, &opener, opts, generation));
        match h {
            Ok(h) => self.threads.push(h),
            Err(e) => self.shared.lost(format!("cannot start the capture thread: {e}")),
        }
    }

    /// The settings.
    pub fn options(&self) -> CaptureOptions {
        self.options
    }

    /// The slot frames arrive in.
    pub fn slot(&self) -> &Arc<LatestSlot<Captured>> {
        &self.slot
    }

    /// The capture's state.
    pub fn status(&self) -> CaptureStatus {
        self.shared.status().clone()
    }

    /// Restarts a capture whose source stalled (running, but no frame for
    /// [`CaptureOptions::stall`] plus, for a paced file, its frame interval): the old thread is
    /// abandoned and a new one reopens the source.
    /// Returns true when it restarted. Call it regularly (the window does, every frame).
    pub fn watchdog(&mut self) -> bool {
        let stalled = {
            let s = self.shared.status();
            let limit = self.options.stall + s.frame_interval.unwrap_or_default();
            s.state == SourceState::Running && s.last_frame.is_some_and(|t| t.elapsed() > limit)
        };
        if !stalled {
            return false;
        }
        self.shared.lost(format!("no frame for {:.1} s", self.options.stall.as_secs_f64()));
        self.shared.generation.fetch_add(1, Ordering::SeqCst);
        // Threads that ended are joined; a blocked one is left to exit when its read returns.
        let (done, running): (Vec<_>, Vec<_>) = self.threads.drain(..).partition(|h| h.is_finished());
        for h in done {
            let _ = h.join();
        }
        self.threads = running;
        self.spawn();
        true
    }

    /// Stops the capture and waits for threads that are not blocked in a read.
    pub fn stop(&mut self) {
        self.shared.stop.store(true, Ordering::SeqCst);
        let deadline = Instant::now() + Duration::from_secs(2);
        for h in self.threads.drain(..) {
            while !h.is_finished() && Instant::now() < deadline {
                std::thread::sleep(Duration::from_millis(5));
            }
            if h.is_finished() {
                let _ = h.join();
            }
        }
    }
}

impl Drop for Capture {
    fn drop(&mut self) {
        self.stop();
    }
}

fn capture_loop(shared: &Shared, slot: &LatestSlot<Captured>, opener: &Mutex<Opener>, opts: CaptureOptions, generation: u64) {
    let mut source: Option<Box<dyn FrameSource>> = None;
    // Pacing of files: frame k of a play is due at `play_start + k / fps`.
    let mut play_start = Instant::now();
    let mut k = 0u64;
    while shared.current(generation) {
        let src = match source.as_mut() {
            Some(s) => s,
            None => {
                let opened = {
                    let mut open = opener.lock().unwrap_or_else(|p| p.into_inner());
                    open()
                };
                match opened {
                    Ok(s) => {
                        let mut st = shared.status();
                        st.label = s.label();
                        st.frame_interval = s.pace_fps().map(|f| Duration::from_secs_f64(1.0 / f));
                        drop(st);
                        (play_start, k) = (Instant::now(), 0);
                        source.insert(s)
                    }
                    Err(e) => {
                        shared.lost(format!("{e:#}"));
                        shared.sleep(generation, opts.retry);
                        continue;
                    }
                }
            }
        };
        match src.read() {
            Ok(Some((frame, ts_ms))) => {
                if let Some(fps) = src.pace_fps() {
                    let due = play_start + Duration::from_secs_f64(k as f64 / fps);
                    let now = Instant::now();
                    if due > now {
                        if !shared.sleep(generation, due - now) {
                            return;
                        }
                    } else if now - due > Duration::from_secs(1) {
                        // Far behind (the machine was busy): pace from here on.
                        (play_start, k) = (now, 0);
                    }
                    k += 1;
                }
                if !shared.current(generation) {
                    return;
                }
                let index = shared.captured.fetch_add(1, Ordering::SeqCst);
                let at = Instant::now();
                slot.put(Captured { frame, index, ts_ms, at });
                let mut s = shared.status();
                s.state = SourceState::Running;
                s.captured = index + 1;
                s.last_frame = Some(at);
            }
            Ok(None) if src.is_file() => {
                if opts.looped {
                    source = None;
                } else {
                    shared.status().state = SourceState::Ended;
                    return;
                }
            }
            Ok(None) => {
                let label = src.label();
                source = None;
                shared.lost(format!("{label} gave no frame (unplugged or stopped)"));
                shared.sleep(generation, opts.retry);
            }
            Err(e) => {
                source = None;
                shared.lost(format!("{e:#}"));
                shared.sleep(generation, opts.retry);
            }
        }
    }
}

/// The opener of `--input` (a folder of frames or a video file) or `--camera` (an index or a
/// URL).
pub fn opener_for(input: Option<&Path>, camera: Option<&str>, fps: Option<f64>) -> Result<Opener> {
    match (input, camera) {
        (Some(p), None) if p.is_dir() => {
            let fps = fps.context("--fps is needed to play a folder of frames")?;
            let p = p.to_owned();
            FolderSource::open(&p, fps)?; // fail early on an empty folder
            Ok(Box::new(move || Ok(Box::new(FolderSource::open(&p, fps)?) as Box<dyn FrameSource>)))
        }
        (Some(p), None) => {
            VideoFileSource::open(p, fps)?;
            let p = p.to_owned();
            Ok(Box::new(move || Ok(Box::new(VideoFileSource::open(&p, fps)?) as Box<dyn FrameSource>)))
        }
        (None, Some(spec)) => {
            let spec = spec.to_owned();
            // A camera that is not there yet is retried like a lost one.
            Ok(Box::new(move || Ok(Box::new(CameraSource::open(&spec)?) as Box<dyn FrameSource>)))
        }
        _ => bail!("give exactly one of --input and --camera"),
    }
}
