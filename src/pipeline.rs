//! One frame of the outdoor mode, end to end: estimate → (relight → probes) → composite
//! (Jensen §3: the estimator of §3.1, the relighting and irradiance volume of §3.3–3.4 and §4.2,
//! the compositor of §3.2 and §5).
//!
//! [`Pipeline`] is shared by every front end: `heliar augment` (image sequences and video files)
//! and `heliar live` (a window). It owns the estimator (with its temporal state), the compositor
//! and the probe source, and returns per frame what ran, what was skipped and how long each stage
//! took ([`FrameRecord`]).
//!
//! The relight → probe update runs only on frames whose estimate says `relight` (the smoothed
//! lighting moved past the change detector's thresholds, or the sun moved past the relighter's
//! rebuild angle), and on the first frame; other frames reuse the probes and say why.

use crate::envmap::bake::{Baked, Progress};
use crate::estimate::{Estimator, FrameEstimate, Status};
use crate::geometry::raycast::RayScene;
use crate::io::frames::{Frame, Linearizer};
use crate::irradiance::sources::{ProbeSource, UniformSky, VolumeProbes};
use crate::lighting::Lighting;
use crate::render::{Compositor, PassReport, RenderedFrame, VideoFrame};
use crate::scene::Scene;
use glam::Vec3;
use serde::Serialize;
use std::sync::Arc;

/// Where the virtual objects' ambient light comes from.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Serialize)]
#[serde(rename_all = "snake_case")]
pub enum Ambient {
    /// The irradiance volume when the scene has an `[envmap]`, else the uniform sky.
    Auto,
    /// The baked irradiance volume, relit per frame.
    Volume,
    /// A uniform, unoccluded sky of the frame's `Pa` everywhere.
    Uniform,
}

/// Whether the relight → probe-update hook ran this frame, and why (not).
#[derive(Clone, Debug, PartialEq, Serialize)]
pub struct RelightReport {
    /// The hook ran.
    pub ran: bool,
    /// The probe source (`irradiance_volume` or `uniform_sky`).
    pub source: &'static str,
    /// Why it ran, or why not.
    pub reason: String,
    /// Time of the relight and probe update, ms (0 when it did not run).
    pub ms: f64,
}

/// What one frame did.
#[derive(Clone, Debug)]
pub struct FrameRecord {
    /// The estimator's output.
    pub estimate: FrameEstimate,
    /// The lighting the compositor used.
    pub lighting: Lighting,
    /// The relight hook.
    pub relight: RelightReport,
    /// Estimation time, ms.
    pub estimate_ms: f64,
    /// Compositing time (GPU passes and readback), ms; 0 when only estimated.
    pub composite_ms: f64,
}

/// The lighting the compositor uses for an estimate: the smoothed values, else the frame's own,
/// else none (a frame the estimator could not use).
pub fn lighting_of(e: &FrameEstimate) -> Lighting {
    let v = |a: [f64; 3]| Vec3::new(a[0] as f32, a[1] as f32, a[2] as f32);
    let (pd, pa) = match (&e.smoothed, e.pd, e.pa) {
        (Some(s), _, _) => (v(s.pd), v(s.pa)),
        (None, pd, pa) => (pd.map(v).unwrap_or(Vec3::ZERO), pa.map(v).unwrap_or(Vec3::ZERO)),
    };
    Lighting { sun_dir: Vec3::from(e.sun.dir_world), above_horizon: e.sun.above_horizon, pd, pa }
}

/// Builds the probe source `ambient` asks for. `bake` supplies the scene's bake (cached or
/// fresh) when the irradiance volume is wanted.
pub fn probe_source(
    scene: &Scene,
    ray: Arc<RayScene>,
    ambient: Ambient,
    bake: impl FnOnce(&Scene, Arc<RayScene>) -> anyhow::Result<Baked>,
) -> anyhow::Result<Box<dyn ProbeSource + Send>> {
    let volume = match ambient {
        Ambient::Uniform => false,
        Ambient::Volume => true,
        Ambient::Auto => scene.manifest.envmap.is_some(),
    };
    if !volume {
        return Ok(Box::new(UniformSky::for_scene(scene)));
    }
    let baked = bake(scene, ray.clone())?;
    Ok(Box::new(VolumeProbes::new(scene, ray, &baked)))
}

/// A bake from the scene's cache, or a fresh one saved to it (no progress output).
pub fn cached_bake(scene: &Scene, ray: Arc<RayScene>, progress: Progress) -> anyhow::Result<Baked> {
    use anyhow::Context;
    Ok(crate::envmap::bake::bake_cached(scene, ray, false, progress).with_context(|| format!("baking {}", scene.root.display()))?.0)
}

/// Estimator, probe source and compositor of one scene.
pub struct Pipeline {
    /// The estimator (its temporal state spans the frames given to it).
    pub estimator: Estimator,
    /// The compositor.
    pub compositor: Compositor,
    /// The probe source.
    pub probes: Box<dyn ProbeSource + Send>,
    relit_once: bool,
    relights: usize,
}

impl Pipeline {
    /// Joins the three parts.
    pub fn new(estimator: Estimator, compositor: Compositor, probes: Box<dyn ProbeSource + Send>) -> Self {
        Self { estimator, compositor, probes, relit_once: false, relights: 0 }
    }

    /// Probe updates so far.
    pub fn relights(&self) -> usize {
        self.relights
    }

    /// Forces a relight on the next frame (after a jump in the footage, e.g. a resumed run).
    pub fn force_relight(&mut self) {
        self.relit_once = false;
    }

    /// Estimates frame `index` (taken at `time`) without compositing: keeps the estimator's
    /// temporal state going over frames whose output exists already (a resumed run).
    pub fn estimate_only(&mut self, index: usize, time: &chrono::DateTime<chrono::FixedOffset>, frame: &Frame, lin: &Linearizer) -> anyhow::Result<FrameEstimate> {
        Ok(self.estimator.estimate(index, time, frame, lin)?)
    }

    /// Estimates the frame and runs the relight hook; the compositor's probes are up to date
    /// afterwards. Used by [`Self::process`] and by front ends that render to their own target.
    pub fn prepare(&mut self, index: usize, time: &chrono::DateTime<chrono::FixedOffset>, frame: &Frame, lin: &Linearizer) -> anyhow::Result<FrameRecord> {
        let t = std::time::Instant::now();
        let estimate = self.estimator.estimate(index, time, frame, lin)?;
        let estimate_ms = t.elapsed().as_secs_f64() * 1e3;
        let lighting = lighting_of(&estimate);
        let source = self.probes.name();
        let relight = if !self.relit_once || estimate.relight {
            let t = std::time::Instant::now();
            let grid = self.probes.relight(&lighting);
            self.compositor.set_probes(grid);
            self.relights += 1;
            let reason = if !self.relit_once { "first frame".to_owned() } else { format!("{:?}", estimate.change) };
            self.relit_once = true;
            RelightReport { ran: true, source, reason, ms: t.elapsed().as_secs_f64() * 1e3 }
        } else {
            RelightReport { ran: false, source, reason: "lighting unchanged (relight = false)".into(), ms: 0.0 }
        };
        Ok(FrameRecord { estimate, lighting, relight, estimate_ms, composite_ms: 0.0 })
    }

    /// One frame: estimate, relight when needed, composite. Returns the composited frame (scene
    /// radiance, the footage's size), the pass report and the frame's record.
    pub fn process(
        &mut self,
        index: usize,
        time: &chrono::DateTime<chrono::FixedOffset>,
        frame: &Frame,
        lin: &Linearizer,
    ) -> anyhow::Result<(RenderedFrame, PassReport, FrameRecord, VideoFrame)> {
        let mut rec = self.prepare(index, time, frame, lin)?;
        let video = VideoFrame::from_frame(frame, lin);
        let t = std::time::Instant::now();
        let (rendered, passes) = self.compositor.render(&video, &rec.lighting)?;
        rec.composite_ms = t.elapsed().as_secs_f64() * 1e3;
        Ok((rendered, passes, rec, video))
    }
}

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
    pub statuses: std::collections::BTreeMap<String, usize>,
    /// Frames on which each pass ran.
    pub passes_ran: std::collections::BTreeMap<String, usize>,
    /// Frames on which each pass was skipped, per kind of reason (numbers replaced by `#`).
    pub passes_skipped: std::collections::BTreeMap<String, std::collections::BTreeMap<String, usize>>,
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
