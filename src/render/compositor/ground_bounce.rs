//! The lamps' bounce at the real receivers (`render::lamps::ground_bounce`), with the objects'
//! lamp shadows on them (`lamp_ground`, issue 16 §3): traced on the first frame whose
//! `lamp_ground` runs, formed for the frame's scales and uploaded when they change. Part of the
//! `lamp_ground` pass (its time in the report's `receivers_ms`, as the receivers' `c`, `b`);
//! nothing at all without lamps or with [`crate::render::lamps::LampOptions::ground_bounce`] off.

use super::Compositor;
use super::receiver_update::RECEIVER_GROW_PX;
use crate::lamps::Lamp;
use crate::lighting::LampScales;
use crate::render::frame::PassReport;
use crate::render::lamps::ground_bounce::GroundBounce;
use glam::Vec3;

/// The lamps and their traced bounce at the receivers.
pub struct GroundBounceUnit {
    lamps: Vec<Lamp>,
    traced: Option<GroundBounce>,
}

impl GroundBounceUnit {
    /// The unit for `lamps` (nothing traced yet).
    pub fn new(lamps: &[Lamp]) -> Self {
        Self { lamps: lamps.to_vec(), traced: None }
    }

    /// Drops the traced bounce (the objects moved): the next frame whose `lamp_ground` runs
    /// traces it again.
    pub fn forget(&mut self) {
        self.traced = None;
    }

    /// The objects moved with the visibility cuts serving: no trace follows them, so the traced
    /// bounce stays and loses the objects' effect (`B_v = B`).
    pub fn moved_by_cuts(&mut self) {
        if let Some(g) = self.traced.as_mut() {
            g.without_objects();
        }
    }
}

impl Compositor {
    /// For a frame whose `lamp_ground` runs: traces the lamps' bounce at the receivers (first
    /// time), forms it for the scales `k` and uploads it when they changed.
    pub(super) fn prepare_ground_bounce(&mut self, k: &LampScales, report: &mut PassReport) {
        let Some(unit) = self.ground_bounce.as_ref() else { return };
        let Some(mut with) = self.with_ray.clone() else { return };
        if self.cuts.is_some() {
            // The objects moved by the cuts, which `with_ray` does not follow: no objects' share.
            with = self.proxy_ray.clone();
        }
        if unit.traced.is_none() {
            let lamps: Vec<Vec3> = unit.lamps.iter().map(|l| l.light.position.as_vec3()).collect();
            let rec = &self.receivers;
            let mut pixels = rec.near(&self.virtual_bounds, self.receiver_pixels.near_radius_m());
            pixels.extend(rec.in_lamp_reach(&self.virtual_bounds, &lamps, RECEIVER_GROW_PX));
            pixels.sort_unstable();
            pixels.dedup();
            let n = (rec.width * rec.height) as usize;
            let traced = GroundBounce::trace(|p| rec.surface(p), &pixels, n, &self.proxy_ray, &with, &unit.lamps, self.config.bounce_quality, self.config.seed);
            report.timings.receivers_ms += traced.trace_ms;
            if let Some(u) = self.ground_bounce.as_mut() {
                u.traced = Some(traced);
            }
        }
        let Some(g) = self.ground_bounce.as_mut().and_then(|u| u.traced.as_mut()) else { return };
        if g.applied() == Some(k) {
            return;
        }
        g.apply(k);
        let t = std::time::Instant::now();
        self.res.lamp_bounce.write(&self.gpu.queue, &g.without);
        self.res.lamp_bounce_with.write(&self.gpu.queue, &g.with);
        report.timings.upload_ms += t.elapsed().as_secs_f64() * 1e3;
    }

    /// Zeroes the receivers' lamp bounce textures (new lamps).
    pub(super) fn clear_ground_bounce(&self) {
        let zeros = vec![[0.0f32; 4]; (self.receivers.width * self.receivers.height) as usize];
        self.res.lamp_bounce.write(&self.gpu.queue, &zeros);
        self.res.lamp_bounce_with.write(&self.gpu.queue, &zeros);
    }

    /// The lamps' traced bounce at the real receivers, once a frame's `lamp_ground` ran (`None`
    /// before, and without lamps).
    pub fn ground_bounce(&self) -> Option<&GroundBounce> {
        self.ground_bounce.as_ref().and_then(|u| u.traced.as_ref())
    }
}
