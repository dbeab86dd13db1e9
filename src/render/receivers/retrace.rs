//! The recomputation of the receivers' sun-dependent values after a sun move, bounded per frame
//! (issue 13 part 4: a moving sun must not stall a frame).
//!
//! # How it works
//! When the sun has moved more than `rebuild_deg` from the bounce sun and the frame's pixels
//! times their paths (the bounce quality's paths, twice with the objects' `c_v`, `b_v`) exceed
//! the per-frame budget, a job starts instead of the immediate reset and recompute: it keeps the
//! new sun, the frame's pixels and whether `c_v`, `b_v` are wanted, and each frame (this one
//! first) computes the next slice of those pixels into the job, while the stored values (for the
//! previous bounce sun) keep serving. The frame that computes the last slice swaps the job in
//! exactly as the immediate path would have done in one frame: every `b`, `b_v` dropped, then
//! the job's pixels stored. A job runs to its end once started (a frame without sun moves it on
//! too); the next frame compares the sun with the job's again. If the darkening model changes
//! (whether `c_v`, `b_v` are wanted), the job is dropped and the immediate path takes over. A
//! change of the sky's turbidity alone (fitted per frame, [`Receivers::set_frame_sky`]) starts a
//! job as a sun move does, under the new sky, which the job keeps to its end.
//!
//! The decisions depend on the frames' suns and pixel lists only, and every value is a pure
//! function of its pixel's seed and the sun, so a job's result equals the immediate
//! recomputation bit for bit, and a replayed frame (a resumed run) only moves the bookkeeping
//! on: a swap it passes is owed as the immediate path's steps, a job still in progress owes its
//! computed slices, and [`Receivers::restore`] pays both.

use super::{Receivers, Row};
use crate::geometry::ambient::TransportQuality;
use crate::geometry::raycast::RayScene;
use glam::Vec3;
use std::ops::Range;

/// A recomputation for a new sun, a slice per frame.
#[derive(Clone, Debug)]
pub(super) struct BounceJob {
    sun: Vec3,
    /// The sky the job integrates under.
    sky: crate::sky::radiance::SkyModel,
    /// Pixels to compute, in the frame's order.
    todo: Vec<u32>,
    /// With the objects' `c_v`, `b_v`.
    with: bool,
    /// `todo[..done]` are computed (or owed).
    done: usize,
    /// Values of `todo[..done]` (empty while owed).
    rows: Vec<Row>,
    /// The computed slices were replayed, not computed: `restore` computes them.
    owed: bool,
}

impl Receivers {
    /// Pixels per slice for `bounce_paths` per pixel and per scene (0: unbounded).
    fn slice_pixels(&self, bounce_paths: u32, with: bool) -> usize {
        let per_pixel = bounce_paths.max(1) as u64 * if with { 2 } else { 1 };
        if self.budget_paths == 0 { 0 } else { (self.budget_paths / per_pixel).max(1) as usize }
    }

    /// The slice of a job this frame computes, with the job started when the sun moved (module
    /// docs); `None`: the immediate path decides.
    fn job_step(&mut self, pixels: &[u32], sun: Option<Vec3>, rebuild_deg: f64, with: bool, bounce_paths: u32) -> Option<Range<usize>> {
        let slice = self.slice_pixels(bounce_paths, with);
        if slice == 0 || self.job.as_ref().is_some_and(|j| j.with != with) {
            self.job = None;
        }
        if slice == 0 {
            return None;
        }
        if self.job.is_none() {
            let (Some(l), Some(s)) = (sun, self.bounce_sun) else { return None };
            if self.bounce_sky == self.sky_model && (s.dot(l).clamp(-1.0, 1.0).acos().to_degrees() as f64) <= rebuild_deg {
                return None;
            }
            let todo: Vec<u32> = pixels.iter().copied().filter(|&p| self.point.get(p as usize).is_some_and(Option::is_some)).collect();
            if todo.len() <= slice {
                return None; // one frame does it: the immediate path
            }
            self.job = Some(BounceJob { sun: l, sky: self.sky_model.clone(), todo, with, done: 0, rows: Vec::new(), owed: false });
        }
        let job = self.job.as_mut()?;
        let range = job.done..(job.done + slice).min(job.todo.len());
        job.done = range.end;
        Some(range)
    }

    /// This frame's slice of a job (computed, and swapped in when it is the last), or `None` when
    /// the immediate path decides.
    pub(super) fn job_slice(
        &mut self,
        proxy: &RayScene,
        with: Option<&RayScene>,
        pixels: &[u32],
        sun: Option<Vec3>,
        bounce_quality: TransportQuality,
        rebuild_deg: f64,
    ) -> Option<super::EnsureStats> {
        let range = self.job_step(pixels, sun, rebuild_deg, with.is_some(), bounce_quality.paths)?;
        let job = self.job.as_ref()?;
        let rows = self.trace_rows(proxy, with.filter(|_| job.with), &job.todo[range.clone()], Some(job.sun), bounce_quality, &job.sky);
        let job = self.job.as_mut()?;
        job.rows.extend(rows);
        let complete = job.done == job.todo.len();
        if complete {
            self.swap_in_job();
        }
        Some(super::EnsureStats { computed: range.len(), bounce_reset: complete, ms: 0.0 })
    }

    /// The decisions of [`Self::job_slice`] without computing (a replayed frame).
    pub(super) fn replay_job_slice(&mut self, pixels: &[u32], sun: Option<Vec3>, rebuild_deg: f64, with: bool, bounce_paths: u32) -> Option<super::EnsureStats> {
        let range = self.job_step(pixels, sun, rebuild_deg, with, bounce_paths)?;
        let job = self.job.as_mut()?;
        job.owed = true;
        job.rows.clear();
        let complete = job.done == job.todo.len();
        if complete {
            let job = self.job.take()?;
            // The immediate path's steps, owed in its order.
            self.reset_bounce(job.sun, job.sky.clone());
            self.mark(&job.todo, true, job.with);
            self.owed.push(super::Owed::Reset);
            self.owed.push(super::Owed::Compute { todo: job.todo, bounce_sun: Some(job.sun), with: job.with, sky: job.sky });
        }
        Some(super::EnsureStats { computed: range.len(), bounce_reset: complete, ms: 0.0 })
    }

    /// This frame's slice of a job in progress, on a frame that chose no pixels (it reuses the
    /// stored stencil); `None` without a job.
    pub fn continue_job(&mut self, proxy: &RayScene, with: Option<&RayScene>, bounce_quality: TransportQuality) -> Option<super::EnsureStats> {
        self.job.as_ref()?;
        let t = std::time::Instant::now();
        let mut s = self.job_slice(proxy, with, &[], None, bounce_quality, f64::INFINITY)?;
        s.ms = t.elapsed().as_secs_f64() * 1e3;
        Some(s)
    }

    /// The decisions of [`Self::continue_job`] without computing (a replayed frame).
    pub fn replay_continue_job(&mut self, with: bool, bounce_paths: u32) -> Option<super::EnsureStats> {
        self.job.as_ref()?;
        self.replay_job_slice(&[], None, f64::INFINITY, with, bounce_paths)
    }

    /// True when a job in progress owes its replayed slices.
    pub(super) fn job_owes(&self) -> bool {
        self.job.as_ref().is_some_and(|j| j.owed)
    }

    /// Computes the slices a job in progress owes; returns the pixels computed.
    pub(super) fn restore_job(&mut self, proxy: &RayScene, with: Option<&RayScene>, bounce_quality: TransportQuality) -> usize {
        let Some(job) = self.job.as_ref().filter(|j| j.owed) else { return 0 };
        let rows = self.trace_rows(proxy, with.filter(|_| job.with), &job.todo[..job.done], Some(job.sun), bounce_quality, &job.sky);
        let Some(job) = self.job.as_mut() else { return 0 };
        job.rows = rows;
        job.owed = false;
        job.done
    }

    /// Stores the completed job: every `b`, `b_v` dropped, then its pixels' values, as the
    /// immediate path stores them.
    fn swap_in_job(&mut self) {
        let Some(job) = self.job.take() else { return };
        self.reset_bounce(job.sun, job.sky);
        self.mark(&job.todo, true, job.with);
        self.apply_rows(job.rows, true);
    }

    /// A job in progress: its sun and the fraction of its pixels done.
    pub fn retrace_progress(&self) -> Option<(Vec3, f64)> {
        self.job.as_ref().map(|j| (j.sun, j.done as f64 / j.todo.len().max(1) as f64))
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::camera::{Camera, Intrinsics, Pose};
    use crate::geometry::{Material, Mesh};
    use glam::DVec3;

    /// A grey floor with a white wall (so the floor gets sun bounce), a box standing in for the
    /// virtual objects (for `c_v`, `b_v`), and a 24×18 camera looking down at them.
    fn scenes() -> (Camera, RayScene, RayScene) {
        let mut proxy = Mesh::default();
        let grey = proxy.add_material(Material::diffuse("floor", [0.4; 3]));
        let white = proxy.add_material(Material::diffuse("wall", [0.8; 3]));
        let node = proxy.add_node("proxy", true);
        proxy.push_quad(Vec3::new(-10.0, 0.0, -10.0), Vec3::Z * 20.0, Vec3::X * 20.0, node, grey);
        proxy.push_box(Vec3::new(-3.0, 0.0, -2.5), Vec3::new(3.0, 2.0, -2.0), node, white, true);
        let mut with = proxy.clone();
        let obj = with.add_material(Material::diffuse("object", [0.6; 3]));
        let onode = with.add_node("object", false);
        with.push_box(Vec3::new(-0.5, 0.0, -0.5), Vec3::new(0.5, 1.0, 0.5), onode, obj, true);
        let cam = Camera {
            intrinsics: Intrinsics::brown_conrady(24, 18, 20.0, 20.0, 12.0, 9.0, [0.0; 5]),
            pose: Pose::look_at(DVec3::new(0.0, 4.0, 5.0), DVec3::new(0.0, 0.0, -1.0), DVec3::Y).unwrap(),
        };
        (cam, RayScene::new(proxy), RayScene::new(with))
    }

    const AMBIENT: TransportQuality = TransportQuality { paths: 4, max_bounces: 2 };
    const BOUNCE: TransportQuality = TransportQuality { paths: 8, max_bounces: 2 };
    /// Pixels per slice with the objects (two integrals of `BOUNCE.paths` each).
    const SLICE: usize = 10;
    const BUDGET: u64 = SLICE as u64 * 2 * BOUNCE.paths as u64;

    fn sun(deg: f32) -> Vec3 {
        glam::Quat::from_rotation_y(deg.to_radians()) * Vec3::new(0.2, 0.7, 0.6).normalize()
    }

    /// All stored values, for comparing two runs bit for bit.
    fn values(r: &Receivers) -> (Vec<[f32; 4]>, Vec<[f32; 4]>, Vec<[f32; 4]>, Vec<[f32; 4]>) {
        (r.ambient.clone(), r.bounce.clone(), r.ambient_with.clone(), r.bounce_with.clone())
    }

    #[test]
    fn a_sliced_recomputation_equals_the_immediate_one() {
        let (cam, proxy, with) = scenes();
        let mut sliced = Receivers::new(&cam, &proxy, 3).with_budget(BUDGET);
        let pixels: Vec<u32> = (0..sliced.point.len() as u32).filter(|&p| sliced.point[p as usize].is_some()).collect();
        assert!(pixels.len() > 4 * SLICE, "{} pixels", pixels.len());
        let ensure = |r: &mut Receivers, l: Vec3| r.ensure(&proxy, Some(&with), &pixels, Some(l), AMBIENT, BOUNCE, 0.25);
        assert_eq!(ensure(&mut sliced, sun(0.0)).computed, pixels.len(), "the first frame computes all");
        let first = values(&sliced);
        assert!(first.1.iter().any(|b| b[0] > 0.0), "the wall bounces sun light onto the floor");
        let mut frames = 0;
        loop {
            let s = ensure(&mut sliced, sun(2.0 + frames as f32));
            frames += 1;
            assert!(s.computed > 0 && s.computed <= SLICE, "{s:?}");
            if s.bounce_reset {
                break;
            }
            assert_eq!(values(&sliced), first, "frame {frames}: the previous values serve");
        }
        assert_eq!(frames, pixels.len().div_ceil(SLICE));
        assert_eq!(sliced.bounce_sun, Some(sun(2.0)));
        let mut immediate = Receivers::new(&cam, &proxy, 3);
        let ensure_all = |r: &mut Receivers, l: Vec3| r.ensure(&proxy, Some(&with), &pixels, Some(l), AMBIENT, BOUNCE, 0.25);
        ensure_all(&mut immediate, sun(0.0));
        assert_eq!(ensure_all(&mut immediate, sun(2.0)).computed, pixels.len());
        assert_eq!(values(&sliced), values(&immediate), "bit for bit");
        assert_ne!(values(&sliced).1, first.1, "the bounce followed the sun");
    }

    #[test]
    fn a_resumed_run_equals_the_uninterrupted_one_across_a_swap() {
        let (cam, proxy, with) = scenes();
        let fresh = || Receivers::new(&cam, &proxy, 5).with_budget(BUDGET);
        let all: Vec<u32> = {
            let r = fresh();
            (0..r.point.len() as u32).filter(|&p| r.point[p as usize].is_some()).collect()
        };
        let job_frames = all.len().div_ceil(SLICE);
        // 1° per frame; frame 3 without sun, frame 6 keeps the previous frame's pixels only.
        let frames: Vec<(Option<Vec3>, Vec<u32>)> =
            (0..3 * job_frames).map(|i| ((i != 3).then(|| sun(i as f32)), if i == 6 { all[..all.len() / 2].to_vec() } else { all.clone() })).collect();
        let mut whole = fresh();
        let states: Vec<_> = frames
            .iter()
            .map(|(l, px)| {
                whole.ensure(&proxy, Some(&with), px, *l, AMBIENT, BOUNCE, 0.25);
                values(&whole)
            })
            .collect();
        for resume_at in [2, job_frames + 1, job_frames + 3] {
            let mut resumed = fresh();
            for (l, px) in &frames[..resume_at] {
                resumed.replay(px, *l, 0.25, true, BOUNCE.paths);
            }
            assert!(resumed.owes());
            resumed.restore(&proxy, Some(&with), AMBIENT, BOUNCE);
            assert!(!resumed.owes());
            for (k, (l, px)) in frames.iter().enumerate().skip(resume_at) {
                resumed.ensure(&proxy, Some(&with), px, *l, AMBIENT, BOUNCE, 0.25);
                assert!(values(&resumed) == states[k], "resumed at {resume_at}: frame {k} differs");
            }
        }
    }

    /// A turbidity fitted per frame (issue 13): the receivers recompute under it a slice per
    /// frame as after a sun move, the values of the declared sky serving until the last slice,
    /// and end with the bits of receivers built under that turbidity from the start.
    #[test]
    fn a_fitted_turbidity_is_recomputed_in_slices_and_equals_its_fixed_sky() {
        use crate::lighting::FrameSky;
        use crate::sky::radiance::SkyModel;
        let (cam, proxy, with) = scenes();
        let declared = SkyModel { hosek_turbidity: Some(3.0), terrain_albedo: [0.5; 3] };
        let fitted = FrameSky::Turbidity(6.0);
        let mut r = Receivers::new(&cam, &proxy, 3).with_budget(BUDGET).with_sky(declared.clone());
        let pixels: Vec<u32> = (0..r.point.len() as u32).filter(|&p| r.point[p as usize].is_some()).collect();
        let l = sun(0.0);
        let ensure = |r: &mut Receivers| r.ensure(&proxy, Some(&with), &pixels, Some(l), AMBIENT, BOUNCE, 0.25);
        assert_eq!(ensure(&mut r).computed, pixels.len());
        let first = values(&r);
        assert!(r.sky_switch_pending(fitted) && r.set_frame_sky(fitted, false));
        assert_eq!(values(&r), first, "a change of turbidity drops nothing");
        let mut frames = 0;
        loop {
            let s = ensure(&mut r);
            frames += 1;
            assert!(s.computed > 0 && s.computed <= SLICE, "{s:?}");
            if s.bounce_reset {
                break;
            }
            assert_eq!((values(&r), r.bounce_sky()), (first.clone(), &declared), "frame {frames}: the declared sky's values serve");
        }
        assert_eq!(frames, pixels.len().div_ceil(SLICE));
        assert_eq!(r.bounce_sky(), &declared.for_frame(fitted.parts()));
        let mut fixed = Receivers::new(&cam, &proxy, 3).with_sky(declared.for_frame(fitted.parts()));
        fixed.ensure(&proxy, Some(&with), &pixels, Some(l), AMBIENT, BOUNCE, 0.25);
        assert_eq!(values(&r), values(&fixed), "bit for bit the fixed turbidity's");
        assert_ne!(values(&r).0, first.0, "turbidity 6 gives another c than 3");
        assert!(!r.set_frame_sky(fitted, false) && ensure(&mut r).computed == 0, "the same sky again: nothing computed");
    }
}
