//! The frame loop every front end calls: a source, a lighting stage, a renderer and sinks, with
//! plain values between them.
//!
//! ```text
//!  Source ─────────────> Lighting stage ────────────> Renderer ───────────> Sinks
//!  folder / video /      outdoor: estimator →          outdoor compositor    frames (PNG/EXR), video,
//!  camera, one clock     relight → probes              (render)              JSON lines, contact sheet,
//!  (source, clock)       VEM: decomposer (vem)         VEM renderer          summary, window texture
//!                        (outdoor, vem)                (render::vem)         (sink; the live window)
//! ```
//!
//! | module | what it owns |
//! |---|---|
//! | [`clock`] | the time of every frame: a sequence's list, a start plus container timestamps, the wall clock |
//! | [`source`] | frame sources (folder, video file, camera) and the resolution of the shared input options into a source, a clock and a photometric calibration |
//! | [`outdoor`] | the outdoor lighting stage: estimator and probe source, the relight hook |
//! | [`motion`] | moving virtual objects posed on the frame clock and handed to the compositor |
//! | [`cuts_gpu`] | the objects' per-vertex ambient from the cuts in a compute pass (benchmarked against the CPU path; not the default) |
//! | [`motion_cuts`] | their visibility cuts, loaded or computed, evaluated for the objects' translations |
//! | [`session`] | the outdoor stage joined to the compositor: one frame end to end |
//! | [`vem`] | the VEM stage (capture → decomposer) and its renderer's side; the `heliar vem` loop |
//! | [`vem_motion`] | the VEM mode's moving objects on its frame clock (the footage's times) |
//! | [`vem_cuts`] | the VEM mode's objects lit through the visibility cuts under the VEM frame (`--object-light cuts`) |
//! | [`sink`] | output frames (folder or video), contact sheets, per-stage timings |
//! | [`precompute`] | `heliar precompute`: the visibility cuts of a scene with moving objects, cached beside the bake |
//! | [`augment`] | recorded footage in, augmented footage out: resume, interrupts, report, summary |
//!
//! Front ends (`heliar augment`, `heliar vem`, `heliar live`) parse their arguments, build the
//! stage and the renderer, and call one function here. Progress and notes go through an
//! [`Observer`], so the library draws no progress bar of its own.

pub mod augment;
pub mod clock;
pub mod cuts_gpu;
pub mod motion;
pub mod motion_cuts;
pub mod outdoor;
pub mod precompute;
pub mod session;
pub mod sink;
pub mod source;
pub mod vem;
pub mod vem_cuts;
pub mod vem_motion;
mod vem_summary;

#[cfg(test)]
mod vem_cuts_tests;

use crate::estimate::Status;
use crate::render::PassReport;
use outdoor::RelightReport;
use serde::Serialize;
use std::collections::BTreeMap;

/// What a run tells its front end: progress and notes.
pub trait Observer {
    /// A long step starts: `total` items when known, `done` of them already done.
    fn start(&mut self, _what: &str, _total: Option<usize>, _done: usize) {}
    /// One more item done.
    fn advance(&mut self) {}
    /// The step ended.
    fn finish(&mut self) {}
    /// A line for the user ("note: …", "warning: …").
    fn note(&mut self, _message: &str) {}
}

/// An observer that ignores everything (tests, bindings).
pub struct Silent;

impl Observer for Silent {}

/// A skip reason with its numbers replaced by `#`, so that reasons of one kind count together
/// ("sun moved 0.04° ≤ 0.05° since frame 9" and "… 0.02° … frame 3" are the same kind).
pub fn reason_kind(reason: &str) -> String {
    let mut out = String::with_capacity(reason.len());
    let mut in_number = false;
    for ch in reason.chars() {
        let numeric = ch.is_ascii_digit() || (in_number && ch == '.');
        if numeric {
            if !in_number {
                out.push('#');
            }
        } else {
            out.push(ch);
        }
        in_number = numeric;
    }
    out
}

/// Counts over a run, for summaries: estimator statuses and skipped passes with their reasons.
#[derive(Clone, Debug, Default, Serialize)]
pub struct RunCounts {
    /// Frames per estimator status.
    pub statuses: BTreeMap<String, usize>,
    /// Frames on which each pass ran.
    pub passes_ran: BTreeMap<String, usize>,
    /// Frames on which each pass was skipped, per kind of reason (numbers replaced by `#`).
    pub passes_skipped: BTreeMap<String, BTreeMap<String, usize>>,
    /// Frames whose relight hook ran.
    pub relights: usize,
}

impl RunCounts {
    /// Adds one frame.
    pub fn add(&mut self, status: Status, passes: &PassReport, relight: &RelightReport) {
        let s = serde_json::to_value(status).ok().and_then(|v| v.as_str().map(str::to_owned)).unwrap_or_else(|| format!("{status:?}"));
        *self.statuses.entry(s).or_default() += 1;
        for p in &passes.ran {
            *self.passes_ran.entry(p.to_string()).or_default() += 1;
        }
        for s in &passes.skipped {
            *self.passes_skipped.entry(s.pass.to_string()).or_default().entry(reason_kind(&s.reason)).or_default() += 1;
        }
        self.relights += relight.ran as usize;
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn reasons_of_one_kind_count_together() {
        assert_eq!(reason_kind("sun moved 0.0396° ≤ 0.05° since frame 9"), "sun moved #° ≤ #° since frame #");
        assert_eq!(reason_kind("sun moved 0.02° ≤ 0.05° since frame 13"), reason_kind("sun moved 0.0396° ≤ 0.05° since frame 9"));
        assert_eq!(reason_kind("Pd ≈ 0 (Pd/Pa = 0.036 < 0.05)"), "Pd ≈ # (Pd/Pa = # < #)");
        assert_eq!(reason_kind("no numbers."), "no numbers.");
    }
}
