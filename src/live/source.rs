//! The capture thread of the live window.
//!
//! A [`FrameSource`] (`crate::run::source`: a camera, a stream, a video file or a folder of
//! PNG/EXR frames) is read on its own thread; files play as if they were a camera, paced at their
//! frame rate. [`Capture`] hands every frame to a [`LatestSlot`] (the newest frame wins).
//!
//! # Camera loss
//! A read error, a camera that stops giving frames (a read that returns none), or a source that
//! cannot be opened puts the capture in [`SourceState::Lost`]; the thread then reopens the source
//! every [`CaptureOptions::retry`] until it works again. A read that blocks (a stream whose
//! server vanished) is caught by [`Capture::watchdog`]: after [`CaptureOptions::stall`] without a
//! frame it abandons that thread (it exits once its read returns) and starts a fresh one.

use super::slot::LatestSlot;
use crate::io::frames::Frame;
pub use crate::run::source::{FrameSource, Opener};
use std::sync::atomic::{AtomicBool, AtomicU64, Ordering};
use std::sync::{Arc, Mutex};
use std::time::{Duration, Instant};

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
            Ok(Some(f)) => {
                let (frame, ts_ms) = (f.frame, f.ts_ms);
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
