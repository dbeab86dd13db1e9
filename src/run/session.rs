//! A lighting stage joined to its renderer: what one frame of the outdoor mode does, end to end
//! (estimate → relight → probes → composite), for every front end.

use super::motion::{FrameMotion, MovingObjects};
use super::outdoor::{OutdoorStage, RelightReport};
use crate::scene::Scene;
use crate::estimate::FrameEstimate;
use crate::io::frames::{Frame, Linearizer};
use crate::lighting::Lighting;
use crate::render::{Compositor, PassReport, RenderedFrame, VideoFrame};
use chrono::{DateTime, FixedOffset};

/// What one outdoor frame did.
#[derive(Clone, Debug)]
pub struct FrameRecord {
    /// The estimator's output.
    pub estimate: FrameEstimate,
    /// The lighting the compositor used.
    pub lighting: Lighting,
    /// The relight hook (its time includes the probe upload).
    pub relight: RelightReport,
    /// Estimation time, ms.
    pub estimate_ms: f64,
    /// Compositing time (GPU passes and readback), ms; 0 when only estimated.
    pub composite_ms: f64,
}

/// One composited outdoor frame.
#[derive(Clone, Debug)]
pub struct OutdoorFrame {
    /// The composite (scene radiance, the footage's size).
    pub rendered: RenderedFrame,
    /// The compositor's pass report.
    pub passes: PassReport,
    /// Estimate, lighting, relight and timings.
    pub record: FrameRecord,
    /// The footage, linearised.
    pub video: VideoFrame,
}

/// The outdoor stage and the compositor of one scene.
pub struct OutdoorSession {
    /// Estimator and probe source.
    pub stage: OutdoorStage,
    /// The GPU compositor.
    pub compositor: Compositor,
    /// The virtual objects that move, when any does.
    pub motion: Option<MovingObjects>,
}

impl OutdoorSession {
    /// Joins the stage and the compositor.
    pub fn new(stage: OutdoorStage, compositor: Compositor) -> Self {
        Self { stage, compositor, motion: None }
    }

    /// Makes the scene's moving objects follow their motion from the next frame on; `start` is
    /// the time of the sequence's first frame (key times in seconds count from it). Their
    /// visibility cuts are loaded from `baked/cuts.bin` or computed (`super::motion_cuts`).
    /// Nothing changes for a scene where nothing moves.
    pub fn follow_motion(&mut self, scene: &Scene, start: DateTime<FixedOffset>) {
        self.follow(scene, MovingObjects::for_scene(scene, start));
    }

    /// [`Self::follow_motion`] for the live window, where a person also drags and turns the
    /// objects (`MovingObjects::for_live`): every object is followed, with a motion or not, and
    /// the cuts are computed for them all (`heliar precompute --draggable`).
    pub fn follow_live(&mut self, scene: &Scene, start: DateTime<FixedOffset>) {
        self.follow(scene, MovingObjects::for_live(scene, start));
    }

    fn follow(&mut self, scene: &Scene, objects: Option<MovingObjects>) {
        self.motion = objects.map(|m| m.attach(scene, &mut self.compositor));
    }

    /// Poses the moving objects for frame `index` and hands those that moved to the compositor
    /// (after the relight: the cuts shade with the relit map).
    fn pose_objects(&mut self, index: usize, time: &DateTime<FixedOffset>) -> anyhow::Result<Option<FrameMotion>> {
        let Some(m) = &mut self.motion else { return Ok(None) };
        let frame = m.advance(index, time);
        m.apply(&mut self.compositor, &frame, self.stage.probes.relighter())?;
        Ok(Some(frame))
    }

    /// Estimates the frame and relights when needed; the compositor's probes are up to date
    /// afterwards. For front ends that render to their own target.
    pub fn prepare(&mut self, index: usize, time: &DateTime<FixedOffset>, frame: &Frame, lin: &Linearizer) -> anyhow::Result<FrameRecord> {
        let light = self.stage.light(index, time, frame, lin)?;
        let mut relight = light.relight;
        if let Some(grid) = light.grid {
            let t = std::time::Instant::now();
            self.compositor.set_probes(grid);
            relight.ms += t.elapsed().as_secs_f64() * 1e3;
        }
        Ok(FrameRecord { estimate: light.estimate, lighting: light.lighting, relight, estimate_ms: light.estimate_ms, composite_ms: 0.0 })
    }

    /// Keeps the state of every stage going over a frame whose output exists already (a resumed
    /// run): the estimator's smoothing, the relights of the probes, and the compositor's
    /// decisions (replayed without their work: see `render::compositor::replay`), so the frames
    /// that follow equal an uninterrupted run's.
    pub fn replay(&mut self, index: usize, time: &DateTime<FixedOffset>, frame: &Frame, lin: &Linearizer) -> anyhow::Result<FrameEstimate> {
        let light = self.stage.light(index, time, frame, lin)?;
        if let Some(grid) = light.grid {
            self.compositor.set_probes(grid);
        }
        let (lighting, estimate) = (light.lighting, light.estimate);
        self.pose_objects(index, time)?;
        self.compositor.replay(&lighting);
        Ok(estimate)
    }

    /// Frame `index` composited again under `lighting` (as it was estimated), with the objects
    /// where they stand now: the live window's answer to a move by hand while the footage is
    /// paused or has ended. Nothing is estimated or relit.
    pub fn recompose(&mut self, index: usize, time: &DateTime<FixedOffset>, video: &VideoFrame, lighting: &Lighting) -> anyhow::Result<(RenderedFrame, PassReport)> {
        let motion = self.pose_objects(index, time)?;
        let (rendered, mut passes) = self.compositor.render(video, lighting)?;
        if let (Some(m), Some(frame)) = (&self.motion, &motion) {
            m.report(frame, &mut passes);
        }
        Ok((rendered, passes))
    }

    /// One frame: estimate, relight when needed, composite offscreen and read back.
    pub fn process(&mut self, index: usize, time: &DateTime<FixedOffset>, frame: &Frame, lin: &Linearizer) -> anyhow::Result<OutdoorFrame> {
        let mut record = self.prepare(index, time, frame, lin)?;
        let video = VideoFrame::from_frame(frame, lin);
        let t = std::time::Instant::now();
        let motion = self.pose_objects(index, time)?;
        let (rendered, mut passes) = self.compositor.render(&video, &record.lighting)?;
        if let (Some(m), Some(frame)) = (&self.motion, &motion) {
            m.report(frame, &mut passes);
        }
        record.composite_ms = t.elapsed().as_secs_f64() * 1e3;
        Ok(OutdoorFrame { rendered, passes, record, video })
    }
}
