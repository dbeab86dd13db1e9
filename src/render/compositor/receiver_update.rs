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
//! complete.

use super::Compositor;
use super::context::{FrameContext, angle_deg};
use crate::render::frame::{Darkening, PassReport};
use crate::render::receivers::Receivers;
use glam::Vec3;

/// Pixels added around the region a virtual shadow can reach when computing `c` and `b` (the
/// bilinear warp reads one pixel beyond a mask edge).
const RECEIVER_GROW_PX: u32 = 2;

/// The sun and model a pixel list was chosen for.
type PixelKey = (Option<Vec3>, bool);

/// Which proxy pixels are kept up to date.
pub struct ReceiverPixels {
    /// Radius of the differential model's region around the objects, metres.
    near_radius_m: f32,
    /// Pixels of that region (computed on first use).
    near: Option<Vec<u32>>,
    /// The pixels, and the sun and model they were chosen for.
    chosen: Option<(PixelKey, Vec<u32>)>,
}

impl ReceiverPixels {
    /// No pixels chosen yet; the differential region reaches `near_radius_m` from the objects.
    pub fn new(near_radius_m: f32) -> Self {
        Self { near_radius_m, near: None, chosen: None }
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
    /// Computes the receiver data this frame needs and uploads what changed.
    pub(super) fn update_receivers(&mut self, ctx: &FrameContext, report: &mut PassReport) {
        // First, so that a switch of the sky (which made `frame_context` rebuild the stencil) is
        // taken whether or not this frame needs receiver data.
        self.receivers.set_uniform_sky(ctx.uniform_sky, false);
        let differential = self.config.darkening == Darkening::Differential;
        let normal_with_sun = ctx.sun().is_some() && self.config.darkening == Darkening::Normal;
        if !ctx.has_objects() || !(differential || normal_with_sun) {
            return;
        }
        let c = &self.config;
        let with = if differential { self.with_ray.as_deref() } else { None };
        let s = if ctx.reuses() {
            // The stored stencil serves, but a recomputation in progress moves on.
            match self.receivers.continue_job(&self.proxy_ray, with, c.bounce_quality) {
                Some(s) => s,
                None => return,
            }
        } else {
            let pixels = self.receiver_pixels.pixels(&self.receivers, &self.virtual_bounds, ctx.sun(), differential, c.bounce_rebuild_deg);
            self.receivers.ensure(&self.proxy_ray, with, pixels, ctx.sun(), c.ambient_quality, c.bounce_quality, c.bounce_rebuild_deg)
        };
        report.receivers_computed = s.computed;
        report.timings.receivers_ms = s.ms;
        // A slice of a recomputation in progress changes nothing served yet.
        let staged = s.computed > 0 && !s.bounce_reset && self.receivers.retrace_progress().is_some();
        if (s.computed > 0 || s.bounce_reset) && !staged {
            let t = std::time::Instant::now();
            self.upload_receivers();
            report.timings.upload_ms += t.elapsed().as_secs_f64() * 1e3;
        }
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
