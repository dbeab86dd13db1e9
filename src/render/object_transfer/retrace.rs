//! When the transfer is traced: in full on first use, and after a sun move in bounded slices
//! (issue 13 part 4: a moving sun must not stall a frame).
//!
//! # How it works
//! Each frame takes one [`Step`], decided from the stored state and the frame's sun only (never
//! from wall-clock time or thread timing), so a resumed or chunked run that replays the same
//! frames takes the same steps:
//! - **Full**: every lattice pixel is traced now, `R_a` and `R_d`: on first use, when the first
//!   sun appears, or after a sun move when the budget is unbounded (`slice = 0`) or covers the
//!   whole lattice.
//! - **Slice**: the sun moved more than `rebuild_deg` from the one the stored `R_d` belongs to. A
//!   job for the new sun starts; each frame (this one first) traces the next `slice` lattice
//!   pixels in lattice order into the job, while the stored `R_d` keeps serving. The frame that
//!   traces the last slice swaps the job's values in. A job is not restarted while it runs:
//!   the sun seen at its start is traced to the end, then the next frame compares the sun with
//!   it again. The served `R_d` thus lags the sun by at most the job's length in frames.
//! - A change of the sky's turbidity alone (a turbidity fitted per frame,
//!   `ObjectTransfer::set_frame_sky`) starts a job as a sun move does, for the frame's sun (or
//!   the traced one on a frame without sun) under the new sky; the job keeps the sky it started
//!   with, and the served values the sky they were traced under.
//! - **Keep**: nothing to do.
//!
//! Every pixel's value is a pure function of its seed and the sun (`trace_point`), so the job's
//! values after its last slice equal a full trace for its sun bit for bit, and a replayed frame
//! only moves the bookkeeping on: what it owes (a full trace, the job's traced slices) is paid
//! by [`ObjectTransfer::restore`].

use super::{ObjectTransfer, PointTransfer, TransferScene, trace_point};
use crate::sky::radiance::SkyModel;
use glam::Vec3;
use rayon::prelude::*;
use std::ops::Range;

/// What one [`ObjectTransfer::ensure`] call did.
#[derive(Clone, Copy, Debug, Default, PartialEq)]
pub struct TransferUpdate {
    /// Pixels traced (0 when the stored values were kept).
    pub traced: usize,
    /// Paths traced (pixels times paths per pixel).
    pub paths: u64,
    /// True when the served values changed (a full trace, or a job's last slice swapped in).
    pub changed: bool,
    /// Time spent, ms.
    pub ms: f64,
}

/// Lattice pixels per slice for `budget` paths per frame of `paths` each (0: unbounded).
pub(super) fn slice_pixels(budget: u64, paths: u64) -> usize {
    if budget == 0 { 0 } else { (budget / paths.max(1)).max(1) as usize }
}

/// A re-trace of `R_d` for a new sun, done a slice per frame.
#[derive(Clone, Debug)]
pub(super) struct SunJob {
    sun: Vec3,
    /// The sky the job traces under.
    sky: SkyModel,
    /// Lattice pixels `surfaces[..done]` are traced (or owed).
    done: usize,
    /// `R_a` and `R_d` of the traced lattice pixels, in lattice order (empty while owed).
    values: Vec<PointTransfer>,
    /// The traced slices were replayed, not traced: [`ObjectTransfer::restore`] traces them.
    owed: bool,
}

/// One frame's step (module docs).
#[derive(Clone, Debug, PartialEq)]
enum Step {
    Keep,
    Full(Option<Vec3>),
    Slice { sun: Vec3, range: Range<usize> },
}

fn angle_deg(a: Vec3, b: Vec3) -> f64 {
    a.dot(b).clamp(-1.0, 1.0).acos().to_degrees() as f64
}

impl ObjectTransfer {
    /// The step this frame takes for `sun` (no change to the state).
    fn next_step(&self, sun: Option<Vec3>, rebuild_deg: f64) -> Step {
        let n = self.surfaces.len();
        if n == 0 {
            return Step::Keep;
        }
        if !self.traced || (self.traced_sun.is_none() && sun.is_some()) {
            return Step::Full(sun);
        }
        let slice = if self.slice == 0 { n } else { self.slice };
        if let Some(job) = &self.job {
            return Step::Slice { sun: job.sun, range: job.done..(job.done + slice).min(n) };
        }
        let resky = self.traced_sky != self.sky_model;
        let target = match (self.traced_sun, sun) {
            (Some(a), Some(l)) if resky || angle_deg(a, l) > rebuild_deg => l,
            (Some(a), None) if resky => a,
            _ => return Step::Keep,
        };
        if slice >= n { Step::Full(Some(target)) } else { Step::Slice { sun: target, range: 0..slice } }
    }

    /// True when [`ObjectTransfer::ensure`] for `sun` would trace: on first use, for the first
    /// sun, when `sun` has moved more than `rebuild_deg` from the one the stored `R_d` belongs
    /// to, or while a re-trace is in progress (and there are pixels to trace).
    pub fn needs_trace(&self, sun: Option<Vec3>, rebuild_deg: f64) -> bool {
        self.next_step(sun, rebuild_deg) != Step::Keep
    }

    /// A re-trace in progress: its sun and the fraction of the lattice done.
    pub fn retrace_progress(&self) -> Option<(Vec3, f64)> {
        self.job.as_ref().map(|j| (j.sun, j.done as f64 / self.surfaces.len().max(1) as f64))
    }

    /// Moves the bookkeeping past `step`: the traced state, the job's progress. Returns the job's
    /// sun when this step completes it (the caller swaps its values in).
    fn take_step(&mut self, step: &Step) -> Option<Vec3> {
        match step {
            Step::Keep => None,
            Step::Full(sun) => {
                self.traced = true;
                if sun.is_some() {
                    self.traced_sun = *sun;
                }
                self.traced_sky = self.sky_model.clone();
                self.job = None;
                None
            }
            Step::Slice { sun, range } => {
                let sky = &self.sky_model;
                let job = self.job.get_or_insert_with(|| SunJob { sun: *sun, sky: sky.clone(), done: 0, values: Vec::new(), owed: false });
                job.done = range.end;
                (range.end == self.surfaces.len()).then_some(*sun)
            }
        }
    }

    /// Traces on first use and after a sun move (module docs): in full, or this frame's slice of
    /// the re-trace in progress. A frame without sun keeps the stored values (its shading
    /// ignores `R_d`) but moves a re-trace in progress on.
    pub fn ensure(&mut self, scene: &TransferScene, sun: Option<Vec3>, rebuild_deg: f64) -> TransferUpdate {
        let step = self.next_step(sun, rebuild_deg);
        let done = self.take_step(&step);
        match step {
            Step::Keep => TransferUpdate::default(),
            Step::Full(sun) => {
                self.owed = None;
                let sky = self.sky_model.clone();
                self.trace_values(scene, sun, &sky)
            }
            Step::Slice { sun, range } => {
                let t0 = std::time::Instant::now();
                let traced = range.len();
                let sky = self.job.as_ref().expect("take_step started the job").sky.clone();
                let values = self.trace_sun(scene, sun, &sky, range);
                let job = self.job.as_mut().expect("take_step started the job");
                job.values.extend(values);
                if done.is_some() {
                    self.swap_in_job();
                }
                let paths = traced as u64 * self.quality.paths as u64;
                TransferUpdate { traced, paths, changed: done.is_some(), ms: t0.elapsed().as_secs_f64() * 1e3 }
            }
        }
    }

    /// What [`Self::ensure`] decides, without tracing: the state moves on as if it had traced,
    /// and the work is owed (a run resumed after an interruption, whose earlier frames are
    /// replayed without their work). [`Self::restore`] pays it.
    pub fn replay(&mut self, sun: Option<Vec3>, rebuild_deg: f64) {
        let step = self.next_step(sun, rebuild_deg);
        let done = self.take_step(&step);
        match step {
            Step::Keep => {}
            Step::Full(sun) => self.owed = Some((sun, self.sky_model.clone())),
            Step::Slice { .. } => {
                let job = self.job.as_mut().expect("take_step started the job");
                job.owed = true;
                job.values.clear();
                if let Some(l) = done {
                    // The swapped-in values are a full trace for the job's sun and sky.
                    let sky = self.job.take().expect("take_step started the job").sky;
                    self.owed = Some((Some(l), sky.clone()));
                    self.traced_sun = Some(l);
                    self.traced_sky = sky;
                }
            }
        }
    }

    /// True when replayed frames owe a trace.
    pub fn owes(&self) -> bool {
        self.owed.is_some() || self.job.as_ref().is_some_and(|j| j.owed)
    }

    /// Traces what the replayed frames owe: the last full trace they decided on (with its sun),
    /// then the slices of a re-trace still in progress; nothing when they owe none.
    pub fn restore(&mut self, scene: &TransferScene) -> TransferUpdate {
        let mut u = match self.owed.take() {
            Some((sun, sky)) => self.trace_values(scene, sun, &sky),
            None => TransferUpdate::default(),
        };
        if let Some(job) = self.job.as_ref().filter(|j| j.owed) {
            let t0 = std::time::Instant::now();
            let (sun, done, sky) = (job.sun, job.done, job.sky.clone());
            let values = self.trace_sun(scene, sun, &sky, 0..done);
            let job = self.job.as_mut().expect("checked above");
            job.values = values;
            job.owed = false;
            u.traced += done;
            u.paths += done as u64 * self.quality.paths as u64;
            u.ms += t0.elapsed().as_secs_f64() * 1e3;
        }
        u
    }

    /// Stores the completed job's `R_a` and `R_d` as the served values (under the uniform sky
    /// its `R_a` equals the stored one bit for bit: the same random numbers whatever the sun).
    fn swap_in_job(&mut self) {
        let Some(job) = self.job.take() else { return };
        debug_assert_eq!(job.values.len(), self.surfaces.len());
        for (s, v) in self.surfaces.iter().zip(&job.values) {
            self.sky[s.pixel as usize] = [v.sky.x, v.sky.y, v.sky.z, 1.0];
            self.sun[s.pixel as usize] = [v.sun.x, v.sun.y, v.sun.z, 0.0];
        }
        self.traced_sun = Some(job.sun);
        self.traced_sky = job.sky;
    }

    /// `R_a` and `R_d` of lattice pixels `range` for `sun` under `sky`.
    fn trace_sun(&self, scene: &TransferScene, sun: Vec3, sky: &SkyModel, range: Range<usize>) -> Vec<PointTransfer> {
        let (q, seed) = (self.quality, self.seed);
        let sky = sky.for_sun(Some(sun));
        self.surfaces[range].par_iter().map(|s| trace_point(scene, s, Some(sun), &sky, q, pixel_seed(seed, s.pixel))).collect()
    }

    /// Traces every lattice pixel for `sun` under `sky` into the stored values.
    fn trace_values(&mut self, scene: &TransferScene, sun: Option<Vec3>, sky: &SkyModel) -> TransferUpdate {
        let t0 = std::time::Instant::now();
        let (q, seed) = (self.quality, self.seed);
        let sky = sky.for_sun(sun);
        let values: Vec<_> = self.surfaces.par_iter().map(|s| trace_point(scene, s, sun, &sky, q, pixel_seed(seed, s.pixel))).collect();
        for (s, t) in self.surfaces.iter().zip(&values) {
            self.sky[s.pixel as usize] = [t.sky.x, t.sky.y, t.sky.z, 1.0];
            self.sun[s.pixel as usize] = [t.sun.x, t.sun.y, t.sun.z, 0.0];
        }
        let traced = values.len();
        TransferUpdate { traced, paths: traced as u64 * q.paths as u64, changed: true, ms: t0.elapsed().as_secs_f64() * 1e3 }
    }
}

/// The seed of a lattice pixel's paths.
pub(super) fn pixel_seed(seed: u64, pixel: u32) -> u64 {
    seed ^ (pixel as u64).wrapping_mul(0x9e37_79b9_7f4a_7c15)
}

#[cfg(test)]
mod tests {
    use super::super::tests::lambert_ball;
    use super::*;
    use crate::camera::{Camera, Intrinsics, Pose};
    use crate::geometry::ambient::TransportQuality;
    use crate::geometry::{Material, Mesh};
    use crate::gpu::canvas::Canvas;
    use glam::DVec3;

    /// The ball over a grey floor (so `R_d` is not zero), seen by a 32×24 camera.
    fn ball_over_floor() -> (Canvas, TransferScene) {
        let mut floor = Mesh::default();
        let fm = floor.add_material(Material::diffuse("floor", [0.4; 3]));
        let fnode = floor.add_node("floor", true);
        floor.push_quad(Vec3::new(-20.0, 0.0, -20.0), Vec3::Z * 40.0, Vec3::X * 40.0, fnode, fm);
        let cam = Camera {
            intrinsics: Intrinsics::brown_conrady(32, 24, 30.0, 30.0, 16.0, 12.0, [0.0; 5]),
            pose: Pose::look_at(DVec3::new(0.0, 2.0, 4.0), DVec3::new(0.0, 2.0, 0.0), DVec3::Y).unwrap(),
        };
        (Canvas::new(&cam, 1.0), TransferScene::new(&floor, &[&lambert_ball()]))
    }

    const Q: TransportQuality = TransportQuality { paths: 16, max_bounces: 2 };
    /// Lattice pixels per slice in these tests.
    const SLICE: usize = 7;

    /// The sun tilted by `deg` degrees from (0.3, 0.8, 0.2) about Z.
    fn sun(deg: f32) -> Vec3 {
        glam::Quat::from_rotation_z(deg.to_radians()) * Vec3::new(0.3, 0.8, 0.2).normalize()
    }

    #[test]
    fn an_amortised_retrace_equals_a_full_trace_for_its_sun() {
        let (canvas, scene) = ball_over_floor();
        let mut sliced = ObjectTransfer::new(&canvas, &scene, Q, 1, 4).with_budget(SLICE as u64 * Q.paths as u64);
        let n = sliced.surfaces().len();
        assert!(n > 3 * SLICE, "{n} lattice pixels");
        assert_eq!(sliced.ensure(&scene, Some(sun(0.0)), 0.25).traced, n, "the first trace is whole");
        let first = sliced.sun.clone();
        assert!(first.iter().any(|v| v[0] > 0.0), "the floor bounces sun light onto the ball");
        // The sun moves 3°: a job for that sun starts; the old R_d serves until it is done,
        // even as the sun keeps moving, and no frame traces more than its slice.
        let mut frames = 0;
        loop {
            let u = sliced.ensure(&scene, Some(sun(3.0 + frames as f32)), 0.25);
            frames += 1;
            assert!(u.traced > 0 && u.traced <= SLICE && u.paths <= SLICE as u64 * Q.paths as u64, "{u:?}");
            if u.changed {
                break;
            }
            assert_eq!(sliced.sun, first, "frame {frames}: the previous R_d serves");
        }
        assert_eq!(frames, n.div_ceil(SLICE));
        assert_eq!(sliced.traced_sun(), Some(sun(3.0)), "the job's sun, not the frame's");
        let mut full = ObjectTransfer::new(&canvas, &scene, Q, 1, 4);
        full.ensure(&scene, Some(sun(0.0)), 0.25);
        full.ensure(&scene, Some(sun(3.0)), 0.25);
        assert_eq!(sliced.sun, full.sun, "bit for bit");
        assert_eq!(sliced.sky, full.sky);
        assert_ne!(sliced.sun, first);
        // The sun is now 5° past the job's: the next job starts at once.
        assert_eq!(sliced.ensure(&scene, Some(sun(8.0)), 0.25).traced, SLICE);
        assert!(sliced.retrace_progress().is_some());
    }

    #[test]
    fn a_run_resumed_across_a_swap_equals_the_uninterrupted_run() {
        let (canvas, scene) = ball_over_floor();
        let budget = SLICE as u64 * Q.paths as u64;
        let n = ObjectTransfer::new(&canvas, &scene, Q, 1, 2).surfaces().len();
        // A sun that moves 1° per frame, one frame without sun: several jobs and swaps.
        let suns: Vec<Option<Vec3>> = (0..3 * n.div_ceil(SLICE) + 5).map(|i| (i != 4).then(|| sun(i as f32))).collect();
        let mut whole = ObjectTransfer::new(&canvas, &scene, Q, 1, 2).with_budget(budget);
        let states: Vec<_> = suns
            .iter()
            .map(|&l| {
                whole.ensure(&scene, l, 0.25);
                (whole.sky.clone(), whole.sun.clone())
            })
            .collect();
        // Resumed before the first swap, right after it, and mid-way through the second job.
        for resume_at in [3, n.div_ceil(SLICE) + 1, n.div_ceil(SLICE) + 4] {
            let mut resumed = ObjectTransfer::new(&canvas, &scene, Q, 1, 2).with_budget(budget);
            for &l in &suns[..resume_at] {
                resumed.replay(l, 0.25);
            }
            assert!(resumed.owes());
            resumed.restore(&scene);
            assert!(!resumed.owes());
            for (k, &l) in suns.iter().enumerate().skip(resume_at) {
                resumed.ensure(&scene, l, 0.25);
                assert!(resumed.sun == states[k].1 && resumed.sky == states[k].0, "resumed at {resume_at}: frame {k} differs");
            }
        }
    }
}
