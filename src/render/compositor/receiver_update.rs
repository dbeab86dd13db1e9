//! The proxy's per-pixel `c` and `b` (and, for the differential model, `c_v` and `b_v`) where
//! the virtual objects can change the footage, kept up to date for the composite.
//!
//! # How it works
//! A CPU step of the frame, not a pass of its own (the report counts the pixels it computed).
//! It runs when the stencil is rebuilt and the darkening model needs receiver data: the
//! differential model always (near the objects), the normal-aware one with a sun. The pixels are
//! those the virtual shadow can reach ([`Receivers::in_shadow_reach`], grown by
//! [`RECEIVER_GROW_PX`]) plus, for the differential model, those near the objects
//! ([`Receivers::near`]); the list follows the sun only as closely as `b` does, so it is rebuilt
//! when `b` is (past `bounce_rebuild_deg`) or the model changes. Changed values are uploaded.
//! A recomputation after a sun move that exceeds the per-frame budget runs a slice per frame
//! (the receivers' `retrace`), on frames that reuse the stored stencil too, and is uploaded when
//! complete. While the visibility cuts serve (objects moved by translation, `motion`), `c_v` and
//! `b_v` are `c` and `b` times the pixel's sky visibility with the objects present, from the
//! objects' visibility cut fields (`crate::cuts::frame`), instead of a trace with the objects;
//! that visibility is evaluated only where an object that moved reaches, at its old or new pose,
//! and kept per pixel elsewhere (`cut_cache`; the report's `cut_receivers` counts both).

use super::Compositor;
use super::setup::NEAR_RADIUS_HALF_DIAGONALS;
use super::context::{FrameContext, angle_deg};
use crate::render::frame::{Darkening, PassReport};
use crate::render::receivers::Receivers;
use glam::Vec3;

/// Pixels added around the region a virtual shadow can reach when computing `c` and `b` (the
/// bilinear warp reads one pixel beyond a mask edge).
pub(super) const RECEIVER_GROW_PX: u32 = 2;

/// The sun and model a pixel list was chosen for.
type PixelKey = (Option<Vec3>, bool);

/// Relative growth of the differential region's radius below which the motion's reach keeps
/// the set-up radius (rounding of a translated box's diagonal, not a wider box).
const REACH_RADIUS_SLACK: f32 = 1e-3;

/// Which proxy pixels are kept up to date.
pub struct ReceiverPixels {
    /// Radius of the differential model's region around the objects, metres.
    near_radius_m: f32,
    /// Pixels of that region (computed on first use).
    near: Option<Vec<u32>>,
    /// The pixels, and the sun and model they were chosen for.
    chosen: Option<(PixelKey, Vec<u32>)>,
    /// The objects' boxes along their motion, whose region gets `c` and `b` on the first
    /// frame (see [`Compositor::reach_motion`]); `None` once done or without motion.
    reach: Option<Vec<(Vec3, Vec3)>>,
}

impl ReceiverPixels {
    /// No pixels chosen yet; the differential region reaches `near_radius_m` from the objects.
    pub fn new(near_radius_m: f32) -> Self {
        Self { near_radius_m, near: None, chosen: None, reach: None }
    }

    /// The same, keeping the motion's reach of `self` (a move rebuilds the pixel lists).
    pub(super) fn rebuilt(&mut self, near_radius_m: f32) -> Self {
        Self { reach: self.reach.take(), ..Self::new(near_radius_m) }
    }

    /// Radius of the differential model's region around the objects, metres.
    pub(super) fn near_radius_m(&self) -> f32 {
        self.near_radius_m
    }

    /// The pixels for `sun` (`None`: no sun term) and the model, rebuilt past `rebuild_deg`.
    pub(super) fn pixels(&mut self, receivers: &Receivers, bounds: &[(Vec3, Vec3)], sun: Option<Vec3>, differential: bool, rebuild_deg: f64) -> &[u32] {
        let key = (sun, differential);
        let stale = match &self.chosen {
            Some((k, _)) => match (k.0, key.0) {
                (Some(a), Some(b)) => angle_deg(a, b) > rebuild_deg || k.1 != key.1,
                (a, b) => a.is_some() != b.is_some() || k.1 != key.1,
            },
            None => true,
        };
        if stale {
            let mut pixels = match sun {
                Some(l) => receivers.in_shadow_reach(bounds, l, RECEIVER_GROW_PX),
                None => Vec::new(),
            };
            if differential {
                let radius = self.near_radius_m;
                let near = self.near.get_or_insert_with(|| receivers.near(bounds, radius));
                pixels.extend_from_slice(near);
                pixels.sort_unstable();
                pixels.dedup();
            }
            self.chosen = Some((key, pixels));
        }
        self.chosen.as_ref().map(|(_, p)| p.as_slice()).unwrap_or(&[])
    }
}

impl Compositor {
    /// Makes the first frame compute `c` and `b` (not `c_v`, `b_v`) wherever the differential
    /// model's region and the objects' shadow (for the first frame's sun) can reach along the
    /// objects' motion, the objects' boxes `boxes` at
    /// sampled times: frames where the objects move rigidly then take `c_v`, `b_v` from
    /// the visibility cuts without tracing any pixel (the set-up pays once), turned or not. The values of the
    /// pixels the frame needs anyway do not change (each pixel's paths have their own seed).
    pub fn reach_motion(&mut self, boxes: Vec<(Vec3, Vec3)>) {
        self.receiver_pixels.reach = Some(boxes);
    }

    /// The pixels of the motion's reach (see [`Self::reach_motion`]), taken once: `None` after.
    pub(super) fn take_reach_pixels(&mut self, ctx: &FrameContext) -> Option<Vec<u32>> {
        let boxes = self.receiver_pixels.reach.take()?;
        // A turned object's box can be wider than at set-up (a square pedestal's at 45°): the
        // region reaches as far as the widest box along the motion asks (the same radius
        // `motion::follow` takes). A box as wide as at set-up (translation) keeps the set-up
        // radius exactly.
        let widest = boxes.iter().map(|(lo, hi)| (*hi - *lo).length() / 2.0 * NEAR_RADIUS_HALF_DIAGONALS).fold(0.0f32, f32::max);
        let now = self.receiver_pixels.near_radius_m;
        let radius = if widest > now * (1.0 + REACH_RADIUS_SLACK) { widest } else { now };
        let mut pixels = self.receivers.near(&boxes, radius);
        if let Some(l) = ctx.sun() {
            pixels.extend(self.receivers.in_shadow_reach(&boxes, l, RECEIVER_GROW_PX));
            pixels.sort_unstable();
            pixels.dedup();
        }
        Some(pixels)
    }

    /// `c`, `b` over the motion's reach, once (see [`Self::reach_motion`]); true when it
    /// computed (the values must be uploaded).
    fn warm_reach(&mut self, ctx: &FrameContext, report: &mut PassReport) -> bool {
        let Some(pixels) = self.take_reach_pixels(ctx) else { return false };
        let c = &self.config;
        let s = self.receivers.ensure(&self.proxy_ray, None, &pixels, ctx.traced_sun(self.receivers.sky_model()), c.ambient_quality, c.bounce_quality, c.bounce_rebuild_deg);
        report.receivers_computed += s.computed;
        report.timings.receivers_ms += s.ms;
        s.computed > 0
    }

    /// Computes the receiver data this frame needs and uploads what changed.
    pub(super) fn update_receivers(&mut self, ctx: &FrameContext, report: &mut PassReport) {
        // First, so that a switch of the sky (which made `frame_context` rebuild the stencil) is
        // taken whether or not this frame needs receiver data.
        self.receivers.set_frame_sky(ctx.sky, false);
        let differential = self.config.darkening == Darkening::Differential;
        let normal_with_sun = ctx.sun().is_some() && self.config.darkening == Darkening::Normal;
        if !ctx.has_objects() || !(differential || normal_with_sun) {
            return;
        }
        let warmed = differential && !ctx.reuses() && self.warm_reach(ctx, report);
        let c = &self.config;
        let with_ray = self.receivers_with(differential);
        let with = with_ray.as_deref();
        let mut pixels = Vec::new();
        let s = if ctx.reuses() {
            // The stored stencil serves, but a recomputation in progress moves on.
            match self.receivers.continue_job(&self.proxy_ray, with, c.bounce_quality) {
                Some(s) => s,
                None => return,
            }
        } else {
            pixels = self.receiver_pixels.pixels(&self.receivers, &self.virtual_bounds, ctx.sun(), differential, c.bounce_rebuild_deg).to_vec();
            self.receivers.ensure(&self.proxy_ray, with, &pixels, ctx.traced_sun(self.receivers.sky_model()), c.ambient_quality, c.bounce_quality, c.bounce_rebuild_deg)
        };
        report.receivers_computed += s.computed;
        report.timings.receivers_ms += s.ms;
        let by_cuts = differential && !ctx.reuses() && self.cut_receivers(&pixels, report);
        // A slice of a recomputation in progress changes nothing served yet; `c_v`, `b_v` from
        // the cuts (the objects moved) are served at once, beside the served `c`, `b`.
        let staged = s.computed > 0 && !s.bounce_reset && self.receivers.retrace_progress().is_some();
        if (s.computed > 0 && !staged) || s.bounce_reset || by_cuts || warmed {
            let t = std::time::Instant::now();
            self.upload_receivers();
            report.timings.upload_ms += t.elapsed().as_secs_f64() * 1e3;
        }
    }

    /// Sets `c_v`, `b_v` at `pixels` from the visibility cuts when they serve (module docs of
    /// `motion`); true when it did. Its time goes to the report's `cuts_ms`.
    pub(super) fn cut_receivers(&mut self, pixels: &[u32], report: &mut PassReport) -> bool {
        let t = std::time::Instant::now();
        let Some((kept, vis, counts)) = self.cut_visibility(pixels) else { return false };
        self.receivers.set_with_from_visibility(&kept, &vis);
        let ms = t.elapsed().as_secs_f64() * 1e3;
        report.timings.cuts_ms += ms;
        report.timings.cut_receivers_ms += ms;
        let total = report.cut_receivers.get_or_insert_default();
        total.evaluated += counts.evaluated;
        total.reused += counts.reused;
        true
    }

    /// The scene the receivers' `c_v`, `b_v` are traced in: the proxy and the objects at their
    /// set-up places, unless the visibility cuts serve all of them (with the cuts serving and
    /// some objects keeping their trace, `kept`, the receivers no moved object reaches are traced
    /// as without motion); `None` without the differential model.
    pub(super) fn receivers_with(&self, differential: bool) -> Option<std::sync::Arc<crate::geometry::raycast::RayScene>> {
        if differential && (self.cuts.is_none() || self.kept.any()) { self.with_ray.clone() } else { None }
    }

    /// The sky visibility with the objects present, from the visibility cuts at their current
    /// poses, of those of `pixels` that see the proxy and take the cuts (all of them, or, while
    /// some objects keep their trace, those a moved object has reached: `kept`), with those
    /// pixels and how many were evaluated (the others keep the value of an earlier frame, where
    /// no moved object reaches: `cut_cache`); `None` when the cuts do not serve.
    pub(super) fn cut_visibility(&mut self, pixels: &[u32]) -> Option<(Vec<u32>, Vec<super::LightLeft>, super::CutReceiverCounts)> {
        let cuts = self.cuts.clone()?;
        let served = if self.kept.any() { self.receivers.by_cuts(pixels) } else { pixels.to_vec() };
        let kept: Vec<u32> = served.into_iter().filter(|&p| self.receivers.surface(p).is_some()).collect();
        let surfaces: Vec<(Vec3, Vec3)> = kept.iter().filter_map(|&p| self.receivers.surface(p)).collect();
        let (vis, counts) = self.cut_cache.visibility(&cuts, &kept, &surfaces);
        Some((kept, vis, counts))
    }

    /// Uploads the receivers' `c`, `b`, `c_v`, `b_v`.
    pub(super) fn upload_receivers(&self) {
        let q = &self.gpu.queue;
        self.res.ambient.write(q, &self.receivers.ambient);
        self.res.bounce.write(q, &self.receivers.bounce);
        self.res.ambient_with.write(q, &self.receivers.ambient_with);
        self.res.bounce_with.write(q, &self.receivers.bounce_with);
    }
}
