//! Recorded footage in, augmented footage out: the frame loop of `heliar augment` (and of any
//! front end that augments a file: the Python package, chunked runs).
//!
//! # How it works
//! [`augment`] reads the [`Input`]'s frames in order, runs each through the
//! [`OutdoorSession`] (estimate → relight → probes → composite) and writes the composite through
//! a [`FrameWriter`], one JSON line per frame into the report, thumbnails into the contact sheet
//! and per-stage timings into the summary.
//!
//! An interrupt (the `stop` counter set by Ctrl-C or SIGTERM) finishes the frame in hand, closes
//! the container and writes the summary; the report then lists exactly the frames in the output.
//! `resume` continues such a run: the frames already written are kept (a video's are copied into
//! the new file: bit-exact for `.mkv`, re-encoded once for `.mp4`/`.avi`), and the session is
//! replayed over them ([`OutdoorSession::replay`]: decode and estimate, the probes' relights, the
//! compositor's decisions without their work), so the smoothing and every cache continue as in
//! an uninterrupted run and the frames after the resume point equal its frames.
//!
//! # Chunks
//! With [`AugmentOptions::frames`] `A..B` (B exclusive) a run writes only frames `A..B`, under
//! their own sequence numbers and names (report lines `frame = A, …, B-1`). The `warmup` frames
//! before `A` are replayed first, as a resume replays (no output, untimed); the input's frames
//! before them are passed over unread where the source allows (folders). With the whole history
//! as warm-up (the default, `warmup: None`) the chunk's frames equal a sequential run's byte for
//! byte; shorter warm-ups are measured in `docs/measurements.md` ("Chunk warm-up"). A chunk can
//! be resumed (`resume` with the same `frames`). [`merge`] joins chunks' output folders.

mod hindsight;
mod merge;
mod resume;

pub use hindsight::HindsightSummary;
pub use merge::{MergeOptions, MergeOutcome, merge};
use resume::{Resumed, catch_up, fresh, resume};
use super::session::OutdoorSession;
use super::clock::ClockCheck;
use super::sink::{Format, FrameWriter, OutputLock, Outputs, StageTime, Thumbs};
use super::source::{FrameSource, Input, InputKind, SourceFrame};
use super::{Observer, RunCounts};
use crate::estimate::{Fallback, Status};
use crate::io::frames::Linearizer;
use crate::io::guard::OutputGuard;
use crate::io::image::Rgb8;
use crate::report::{JsonLines, Table};
use crate::run::outdoor::RelightReport;
use crate::render::PassReport;
use crate::scene::{Scene, Truth};
use anyhow::{Context, Result, bail};
use serde::Serialize;
use std::path::Path;
use std::sync::atomic::{AtomicUsize, Ordering};

/// Most thumbnails the contact sheet keeps, halved: 2·16.
const SHEET_KEEP: usize = 16;
/// Width of a contact-sheet tile, pixels.
const SHEET_TILE_WIDTH: u32 = 320;

/// How to augment.
#[derive(Clone, Debug)]
pub struct AugmentOptions {
    /// A folder, or a video file.
    pub output: std::path::PathBuf,
    /// Frame format in an output folder (default: the input's).
    pub format: Option<Format>,
    /// Continue an interrupted run into the same output.
    pub resume: bool,
    /// Stop before frame index `max_frames` (counting frames already written by a resumed run,
    /// and, for a chunk, the frames before it).
    pub max_frames: Option<usize>,
    /// Only frames `A..B` (B exclusive): a chunk (see the module docs). `None`: all.
    pub frames: Option<std::ops::Range<usize>>,
    /// Frames before the chunk's first replayed to warm the smoothing and caches; `None`: all
    /// of them (from frame 0: the chunk then equals a sequential run).
    pub warmup: Option<usize>,
    /// Columns of the contact sheet.
    pub sheet_columns: u32,
    /// Write even where an output would overwrite an input or a file of the scene.
    pub force: bool,
    /// Frame times that do not increase are an error (else a warning naming the frames).
    pub strict_clock: bool,
    /// Estimate the input once ahead of the render and give the lamps their `k` in hindsight
    /// (`hindsight`; only scenes with `[[lights]]` run it).
    pub hindsight: bool,
}

/// Refuses outputs that would overwrite the input or a file of the scene (unless forced).
fn check_outputs(scene: &Scene, input: &Input, out: &Outputs, force: bool) -> Result<()> {
    let mut guard = OutputGuard::new(Some(&scene.root), &[], force);
    match &input.kind {
        InputKind::Folder(p) | InputKind::Video(p) => guard = guard.with_input(p),
        InputKind::Camera(_) => {}
    }
    if out.video { guard.check_file(&out.target)? } else { guard.check_dir(&out.target)? }
    for f in [&out.report, &out.summary, &out.sheet] {
        guard.check_file(f)?;
    }
    Ok(())
}

/// A per-frame report line.
#[derive(Serialize)]
struct Record<'a> {
    frame: usize,
    input: String,
    output: String,
    time: &'a str,
    status: Status,
    fallback: Option<Fallback>,
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

/// Per-stage timings of a run.
#[derive(Clone, Debug, Default, Serialize)]
pub struct Stages {
    /// Reading and decoding frames.
    pub decode: StageTime,
    /// The estimator.
    pub estimate: StageTime,
    /// Relight and probe update.
    pub relight: StageTime,
    /// GPU passes and readback.
    pub composite: StageTime,
    /// Writing the output.
    pub encode: StageTime,
}

/// The run's summary (`summary.json`, and a table on the terminal).
#[derive(Clone, Debug, Serialize)]
pub struct AugmentSummary {
    /// The input.
    pub input: String,
    /// The output folder or video.
    pub output: String,
    /// Frames in the output.
    pub frames_written: usize,
    /// Frames composited by this run.
    pub frames_this_run: usize,
    /// Frames kept from the run being resumed.
    pub resumed_after: usize,
    /// The run was interrupted.
    pub interrupted: bool,
    /// What stopped the run early, if anything did.
    pub error: Option<String>,
    /// Frames the input announces.
    pub input_frames: Option<usize>,
    /// The input's frame rate.
    pub fps_in: f64,
    /// Wall time of this run, s.
    pub wall_s: f64,
    /// This run's throughput.
    pub frames_per_second: f64,
    /// The GPU adapter.
    pub gpu: String,
    /// The probe source.
    pub probe_source: String,
    /// Statuses and passes.
    pub counts: RunCounts,
    /// Per-stage timings.
    pub stages: Stages,
    /// The lamps' pre-pass (`hindsight`): ran, or why not.
    pub lamp_hindsight: HindsightSummary,
    /// The chunk this run wrote (absent for a whole run).
    #[serde(skip_serializing_if = "Option::is_none")]
    pub chunk: Option<ChunkSummary>,
}

/// A chunk's place in its sequence.
#[derive(Clone, Debug, Serialize)]
pub struct ChunkSummary {
    /// First frame of the chunk.
    pub first: usize,
    /// The frame after its last, as asked (`--frames A..B`).
    pub end: usize,
    /// Frames replayed before the first.
    pub warmup: usize,
}

impl AugmentSummary {
    /// The summary as a table for the terminal.
    pub fn table(&self) -> Table {
        let mut t = Table::new(&["quantity", "value"]);
        if let Some(c) = &self.chunk {
            t.push(vec!["chunk".into(), format!("frames {}..{} after {} frames of warm-up", c.first, c.end, c.warmup)]);
        }
        let resumed = if self.resumed_after > 0 { format!(", resumed after {}", self.resumed_after) } else { String::new() };
        t.push(vec!["frames written".into(), format!("{} ({} this run{resumed})", self.frames_written, self.frames_this_run)]);
        t.push(vec!["throughput".into(), format!("{:.2} frames/s over {:.1} s", self.frames_per_second, self.wall_s)]);
        let statuses: Vec<String> = self.counts.statuses.iter().map(|(k, v)| format!("{k} {v}")).collect();
        t.push(vec!["estimator status".into(), statuses.join(", ")]);
        t.push(vec!["relights (probe updates)".into(), format!("{} ({})", self.counts.relights, self.probe_source)]);
        let h = &self.lamp_hindsight;
        let lamps = if h.ran { format!("{} ({:.1} s)", h.reason, h.ms / 1e3) } else { format!("skipped: {}", h.reason) };
        t.push(vec!["lamps' k in hindsight".into(), lamps]);
        for (pass, reasons) in &self.counts.passes_skipped {
            let n: usize = reasons.values().sum();
            let first = reasons.iter().max_by_key(|(_, v)| **v).map(|(r, _)| r.as_str()).unwrap_or("");
            t.push(vec![format!("skipped {pass}"), format!("{n} frames (mostly: {first})")]);
        }
        let s = &self.stages;
        for (name, st) in [("decode", &s.decode), ("estimate", &s.estimate), ("relight", &s.relight), ("composite", &s.composite), ("encode", &s.encode)] {
            t.push(vec![format!("time: {name}"), format!("{:.1} s total, median {:.2} ms/frame", st.total_s, st.median_ms)]);
        }
        t
    }
}

/// How a run ended.
#[derive(Debug)]
pub struct AugmentOutcome {
    /// The summary (also written to the outputs' summary file).
    pub summary: AugmentSummary,
    /// The outputs.
    pub outputs: Outputs,
    /// Why the loop stopped early, when it failed (the frames before are kept and listed).
    pub error: Option<anyhow::Error>,
}

/// The run's frames: its first (`A` of a chunk, else 0), the first replayed as warm-up, and the
/// index it stops before (`max_frames`, the chunk's end), if any.
fn span(opts: &AugmentOptions) -> Result<(usize, usize, Option<usize>)> {
    let (first, end) = opts.frames.as_ref().map_or((0, None), |r| (r.start, Some(r.end)));
    if let Some(e) = end
        && e <= first
    {
        bail!("--frames {first}..{e}: the chunk is empty (A..B runs frames A to B-1)");
    }
    let from = first - opts.warmup.unwrap_or(first).min(first);
    let limit = match (opts.max_frames, end) {
        (Some(m), Some(e)) => Some(m.min(e)),
        (m, e) => m.or(e),
    };
    Ok((first, from, limit))
}

/// Augments `input` into `opts.output` (see the module docs). `stop` counts interrupts: the
/// loop ends after the frame in hand once it is non-zero. Returns the outcome, whose `error`
/// says why the loop stopped early; set-up failures (unreadable input, unwritable output) are
/// returned as errors.
pub fn augment(scene: &Scene, input: &Input, session: &mut OutdoorSession, opts: &AugmentOptions, obs: &mut dyn Observer, stop: &AtomicUsize) -> Result<AugmentOutcome> {
    let out = Outputs::of(&opts.output)?;
    check_outputs(scene, input, &out, opts.force)?;
    std::fs::create_dir_all(out.parent()).with_context(|| format!("{}: cannot create the output folder", out.parent().display()))?;
    let _lock = OutputLock::acquire(&out)?;
    let lin = input.photometry.linearizer();
    let mut source = input.open()?;
    let mut thumbs = Thumbs::new(SHEET_KEEP, SHEET_TILE_WIDTH);
    let mut clock_check = ClockCheck::default();
    let (first, from, limit) = span(opts)?;
    let Resumed { done, mut writer } = if opts.resume {
        resume(&out, opts, input, scene, first, &mut thumbs, obs)?
    } else {
        fresh(&out, opts, input, scene, first, &mut thumbs, obs)?
    };
    let lamp_hindsight = hindsight::hindsight_pass(scene, input, session, from, opts.hindsight, obs, stop)?;
    follow_motion(scene, input, session)?;
    catch_up((from, first, done), &out, opts, input, source.as_mut(), session, &lin, &mut thumbs, &mut clock_check, obs)?;
    let mut report = if done > first { JsonLines::append(&out.report) } else { JsonLines::create(&out.report) }.with_context(|| format!("{}: cannot write the report", out.report.display()))?;

    let total = input.count.map(|n| limit.map_or(n, |m| n.min(m)));
    obs.start(&format!("augment {}", input.sequence.as_deref().unwrap_or(&input.label)), total, done);
    let started = std::time::Instant::now();
    let (mut counts, mut stages) = (RunCounts::default(), Stages::default());
    let mut frames = FrameLoop {
        scene,
        input,
        source: source.as_mut(),
        session,
        lin: &lin,
        writer: &mut writer,
        report: &mut report,
        thumbs: &mut thumbs,
        counts: &mut counts,
        stages: &mut stages,
        out: &out,
        clock: clock_check,
        strict_clock: opts.strict_clock,
    };
    let (i, interrupted, result) = frames.run(done, limit, stop, obs);
    let clock_check = frames.clock;
    obs.finish();
    if let Some(w) = clock_check.warning(&input.label) {
        obs.note(&w);
    }

    // Close everything, whatever happened: the output and its reports cover frames 0..i.
    drop(report);
    let close_err = writer.finish().err();
    let wall = started.elapsed().as_secs_f64();
    for s in [&mut stages.decode, &mut stages.estimate, &mut stages.relight, &mut stages.composite, &mut stages.encode] {
        s.finish();
    }
    if let Err(e) = thumbs.write(&out.sheet, opts.sheet_columns) {
        obs.note(&format!("warning: contact sheet not written: {e:#}"));
    }
    let this_run = i - done;
    let summary = AugmentSummary {
        input: input.label.clone(),
        output: out.target.display().to_string(),
        frames_written: i - first,
        frames_this_run: this_run,
        resumed_after: done - first,
        interrupted,
        error: result.as_ref().err().map(|e| format!("{e:#}")),
        input_frames: input.count,
        fps_in: input.fps,
        wall_s: wall,
        frames_per_second: if wall > 0.0 { this_run as f64 / wall } else { 0.0 },
        gpu: session.compositor.gpu().describe(),
        probe_source: session.stage.probes.name().to_owned(),
        counts,
        stages,
        lamp_hindsight,
        chunk: opts.frames.as_ref().map(|r| ChunkSummary { first: r.start, end: r.end, warmup: first - from }),
    };
    if let Err(e) = crate::io::write_atomic(&out.summary, serde_json::to_string_pretty(&summary)?.as_bytes()) {
        obs.note(&format!("warning: {}: summary not written: {e}", out.summary.display()));
    }
    if result.is_ok() && !interrupted {
        warn_if_truncated(input, i, limit, obs);
    }
    let error = run_error(close_err, result, (first, i), &out);
    Ok(AugmentOutcome { summary, outputs: out, error })
}

/// What went wrong in a run that wrote frames `first..i` into `out`: closing the output, or the
/// frame loop (the frames before are kept).
fn run_error(close_err: Option<anyhow::Error>, result: Result<()>, (first, i): (usize, usize), out: &Outputs) -> Option<anyhow::Error> {
    match (close_err, result) {
        (Some(e), _) => Some(e.context(format!("closing {}", out.target.display()))),
        (None, Err(e)) => {
            let kept = if first > 0 { format!("frames {first}..{i} of the chunk") } else { format!("{i} frames") };
            Some(e.context(format!("stopped after {kept}; they are kept in {} (listed in {}); `--resume` continues", out.target.display(), out.report.display())))
        }
        (None, Ok(())) => None,
    }
}

/// Makes the session's moving objects (if any) follow their motion; their key times in seconds
/// count from the input's first frame.
fn follow_motion(scene: &Scene, input: &Input, session: &mut OutdoorSession) -> Result<()> {
    if scene.virtual_objects.iter().any(|o| o.moves()) {
        let start = input.clock.time(0, Some(0.0), None).with_context(|| format!("{}: the time of frame 0", input.label))?;
        session.follow_motion(scene, start);
    }
    Ok(())
}

/// Warns when a run that ended normally at frame `i` (before `limit`) wrote fewer frames than its
/// input announces.
fn warn_if_truncated(input: &Input, i: usize, limit: Option<usize>, obs: &mut dyn Observer) {
    if let Some(n) = input.count
        && i < n
        && limit.is_none_or(|m| i < m)
    {
        obs.note(&format!("warning: {} ended after {i} of the {n} frames its container announces (truncated or corrupt)", input.label));
    }
}

/// The loop's state over one run.
struct FrameLoop<'a> {
    scene: &'a Scene,
    input: &'a Input,
    source: &'a mut dyn FrameSource,
    session: &'a mut OutdoorSession,
    lin: &'a Linearizer,
    writer: &'a mut FrameWriter,
    report: &'a mut JsonLines,
    thumbs: &'a mut Thumbs,
    counts: &'a mut RunCounts,
    stages: &'a mut Stages,
    out: &'a Outputs,
    clock: ClockCheck,
    strict_clock: bool,
}

impl FrameLoop<'_> {
    /// Frames from `first` on, until the input ends, `max_frames`, an interrupt or an error.
    /// Returns the frames in the output, whether it was interrupted, and the error.
    fn run(&mut self, first: usize, max_frames: Option<usize>, stop: &AtomicUsize, obs: &mut dyn Observer) -> (usize, bool, Result<()>) {
        let mut i = first;
        loop {
            if stop.load(Ordering::SeqCst) > 0 {
                return (i, true, Ok(()));
            }
            if max_frames.is_some_and(|m| i >= m) {
                return (i, false, Ok(()));
            }
            let t = std::time::Instant::now();
            let f = match self.source.read() {
                Ok(Some(f)) => f,
                Ok(None) => return (i, false, Ok(())),
                Err(e) => return (i, false, Err(e.context(format!("{}: reading frame {i}", self.input.label)))),
            };
            let decode_ms = t.elapsed().as_secs_f64() * 1e3;
            match self.frame(i, f, decode_ms) {
                Ok(warnings) => warnings.iter().for_each(|w| obs.note(w)),
                Err(e) => return (i, false, Err(e)),
            }
            i += 1;
            obs.advance();
        }
    }

    /// Composites, writes and reports frame `i`; returns the frame's warnings.
    fn frame(&mut self, i: usize, f: SourceFrame, decode_ms: f64) -> Result<Vec<String>> {
        let k = &self.scene.camera.intrinsics;
        f.frame
            .check_size(Path::new(&f.label), k.width, k.height)
            .map_err(anyhow::Error::new)
            .with_context(|| format!("the camera calibration {} is {}×{}", self.scene.camera_path.display(), k.width, k.height))?;
        let time = self.input.clock.time(i, f.ts_ms, None)?;
        if !self.clock.check(i, time) && self.strict_clock {
            bail!("{}: frame {i} is stamped {}, not after the frame before (--strict)", f.label, time.to_rfc3339());
        }
        let done = self.session.process(i, &time, &f.frame, self.lin).with_context(|| f.label.clone())?;
        let t = std::time::Instant::now();
        let photometry = &self.input.photometry;
        let written = self.writer.write(i, &self.source.stem(i), &done.rendered.image, done.rendered.precision, &done.video, &f.frame, photometry).context("writing the output")?;
        let encode_ms = t.elapsed().as_secs_f64() * 1e3;
        if self.thumbs.wants(i) {
            self.thumbs.push(i, &Rgb8::from_radiance(&done.rendered.image, photometry));
        }
        let (rec, e) = (&done.record, &done.record.estimate);
        let line = Record {
            frame: i,
            input: f.label,
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
            passes: &done.passes,
            decode_ms,
            estimate_ms: rec.estimate_ms,
            composite_ms: rec.composite_ms,
            encode_ms,
            truth: self.input.truth.as_ref().and_then(|t| t.get(i).copied()),
        };
        self.report.write(&line).with_context(|| format!("writing {}", self.out.report.display()))?;
        self.counts.add(e.status, &done.passes, &rec.relight);
        self.stages.decode.add(decode_ms);
        self.stages.estimate.add(rec.estimate_ms);
        self.stages.relight.add(rec.relight.ms);
        self.stages.composite.add(rec.composite_ms);
        self.stages.encode.add(encode_ms);
        Ok(done.passes.warnings.clone())
    }
}
