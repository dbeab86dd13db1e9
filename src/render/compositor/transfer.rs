//! The object-transfer pass as a unit: the virtual objects' per-pixel ambient transfer
//! ([`crate::render::object_transfer`]), traced on the CPU and uploaded for the shading pass.
//!
//! # How it works
//! The transfer is traced on the first frame; when the sun has moved more than
//! `bounce_rebuild_deg` from the direction its `R_d` was traced for (as far as the bounce `b` is
//! allowed to lag), `R_d` is re-traced a slice per frame within the compositor's
//! `trace_paths_per_frame` and uploaded when complete
//! ([`crate::render::object_transfer`]'s `retrace`); a frame without sun keeps it (its shading
//! ignores `R_d`). The unit's plan says which, with the report's reason, before anything is
//! traced.

use super::context::{FrameContext, angle_deg};
use glam::Vec3;
use super::resources::Resources;
use crate::render::frame::{PassReport, pass};
use crate::render::object_transfer::{ObjectTransfer, TransferScene};
use crate::render::plan::{Pass, Plan};

/// The transfer and its scene, when it is on.
pub struct TransferPass {
    traced: Option<(TransferScene, ObjectTransfer)>,
    rebuild_deg: f64,
    /// Why the transfer was dropped after set-up (an object moved), for the report.
    dropped: Option<String>,
    /// Which objects it serves while others move under the visibility cuts (`kept`), for the
    /// report.
    note: Option<String>,
}

/// The sun direction the transfer is traced for ([`FrameContext::traced_sun`]): under a sky
/// whose shape follows the sun, the sun's direction even without a sun term, so that `R_a` keeps
/// the twilight sky's shape on a frame whose `Pd` is 0 (issue 16, the dusk statue). `R_d` is
/// then traced for that direction too (per unit `Pd`; the shading adds it only with a sun term).
fn transfer_sun(transfer: &ObjectTransfer, ctx: &FrameContext) -> Option<Vec3> {
    ctx.traced_sun(transfer.sky_model())
}

impl TransferPass {
    /// The unit for `traced` (`None`: `transfer_paths = 0` or no objects), retraced past a sun
    /// motion of `rebuild_deg`.
    pub fn new(traced: Option<(TransferScene, ObjectTransfer)>, rebuild_deg: f64) -> Self {
        Self { traced, rebuild_deg, dropped: None, note: None }
    }

    /// The transfer, when it is on.
    pub fn transfer(&self) -> Option<&ObjectTransfer> {
        self.traced.as_ref().map(|(_, t)| t)
    }

    /// The transfer and its scene, when it is on.
    pub fn scene_and_transfer(&self) -> Option<(&TransferScene, &ObjectTransfer)> {
        self.traced.as_ref().map(|(s, t)| (s, t))
    }

    /// Drops the traced transfer (it no longer matches the objects); the plan reports `reason`
    /// and the shading falls back to the probe grid times ambient occlusion.
    pub fn drop_traced(&mut self, reason: &str) {
        self.traced = None;
        self.note = None;
        self.dropped = Some(reason.to_owned());
    }

    /// Says which objects the kept transfer serves (objects moved under the cuts, `kept`); the
    /// plan's reasons end with it.
    pub fn set_note(&mut self, note: Option<String>) {
        self.note = note;
    }

    /// The lattice stride the shading pass reads the transfer with (0: off this frame).
    pub fn shader_stride(&self, ctx: &FrameContext) -> f32 {
        match &self.traced {
            Some((_, t)) if ctx.switches.transfer => t.stride() as f32,
            _ => 0.0,
        }
    }

    /// Traces the transfer for this frame's sun and uploads it (the plan said it must).
    pub fn record(&mut self, ctx: &FrameContext, queue: &wgpu::Queue, res: &Resources, report: &mut PassReport) {
        let Some((scene, transfer)) = &mut self.traced else { return };
        transfer.set_frame_sky(ctx.sky);
        let u = transfer.ensure(scene, transfer_sun(transfer, ctx), self.rebuild_deg);
        debug_assert!(u.traced > 0, "the plan said the transfer must be traced");
        report.timings.transfer_ms = u.ms;
        report.transfer_traced = u.traced;
        if !u.changed {
            return; // a slice of a re-trace: the served values stay
        }
        let t = std::time::Instant::now();
        res.transfer_sky.write(queue, &transfer.sky);
        res.transfer_sun.write(queue, &transfer.sun);
        report.timings.upload_ms += t.elapsed().as_secs_f64() * 1e3;
    }
}

impl TransferPass {
    /// The decision of [`Self::record`] for this frame's sun, without tracing (a replayed frame).
    pub fn replay(&mut self, ctx: &FrameContext) {
        if let Some((_, transfer)) = &mut self.traced {
            transfer.set_frame_sky(ctx.sky);
            let sun = transfer_sun(transfer, ctx);
            transfer.replay(sun, self.rebuild_deg);
        }
    }

    /// True when replayed frames owe a trace.
    pub fn owes(&self) -> bool {
        self.traced.as_ref().is_some_and(|(_, t)| t.owes())
    }

    /// Traces what replayed frames owe and uploads it; true when it traced.
    pub fn restore(&mut self, queue: &wgpu::Queue, res: &Resources, report: &mut PassReport) -> bool {
        let Some((scene, transfer)) = &mut self.traced else { return false };
        let u = transfer.restore(scene);
        if u.traced == 0 {
            return false;
        }
        report.timings.transfer_ms += u.ms;
        report.transfer_traced += u.traced;
        if !u.changed {
            return true; // slices of a re-trace in progress: the served values stay
        }
        res.transfer_sky.write(queue, &transfer.sky);
        res.transfer_sun.write(queue, &transfer.sun);
        true
    }
}

impl Pass<FrameContext> for TransferPass {
    const NAME: &'static str = pass::OBJECT_TRANSFER;

    fn plan(&self, ctx: &FrameContext) -> Plan {
        let Some((_, transfer)) = &self.traced else {
            if let Some(reason) = &self.dropped {
                return Plan::skip(reason.clone());
            }
            return Plan::skip("transfer_paths = 0: ambient from the probe grid times ambient occlusion");
        };
        if !ctx.switches.transfer {
            return Plan::skip(ctx.off.clone());
        }
        let sun = transfer_sun(transfer, ctx);
        if transfer.needs_trace(sun, self.rebuild_deg) || transfer.sky_switch_pending(ctx.sky) {
            return Plan::Run;
        }
        if transfer.surfaces().is_empty() {
            return Plan::skip("no canvas pixel shows a virtual object");
        }
        if let Some(note) = &self.note {
            // Objects moved under the visibility cuts; the others keep the transfer (`kept`).
            return Plan::skip(match (transfer.traced_sun(), sun) {
                (Some(a), Some(l)) => format!("the sun moved {:.3}° ≤ {}° since it was traced and objects moved under the visibility cuts: the transfer is {note}", angle_deg(a, l), self.rebuild_deg),
                _ => format!("no sun and objects moved under the visibility cuts: the traced sky transfer is {note}"),
            });
        }
        Plan::skip(match (transfer.traced_sun(), sun) {
            (Some(a), Some(l)) => format!(
                "the sun moved {:.3}° ≤ {}° since it was traced and the camera and objects are static: the transfer is reused",
                angle_deg(a, l),
                self.rebuild_deg
            ),
            _ => "no sun: the traced sky transfer is reused (camera and objects are static)".to_owned(),
        })
    }
}
