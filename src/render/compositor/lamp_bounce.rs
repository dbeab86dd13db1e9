//! The lamps' bounce on the objects as a unit (`lamp_bounce`, with `[[lights]]` only; issue 16
//! §3): the lamps' light that reaches the virtual objects off the real proxy and off the
//! objects, `Σ k_i·R_i` per traced pixel ([`crate::render::object_transfer::lamps`]), added to
//! the per-pixel ambient in the shading pass (`transfer_lamp`, read with the transfer's lattice
//! weights).
//!
//! # How it works
//! `R_i` is traced once, on the first frame that has a lamp on; a frame whose scales differ
//! from those uploaded forms `Σ k_i·R_i` and uploads it. Left out, with the reason in the pass
//! report: frames without objects, frames without the per-pixel transfer (the probe grid holds
//! no lamp light), frames with no lamp on (after the zeros are uploaded once), and frames whose
//! scales are those uploaded. A scene without lamps has no such unit at all: nothing is traced,
//! uploaded or reported, and its output is what it was.

use super::Compositor;
use super::context::FrameContext;
use crate::lamps::Lamp;
use crate::lighting::LampScales;
use crate::render::frame::{PassReport, pass};
use crate::render::object_transfer::LampBounce;
use crate::render::plan::{Pass, Plan};

/// The lamps, their traced bounce, and this frame's decision.
pub struct LampBouncePass {
    lamps: Vec<Lamp>,
    bounce: Option<LampBounce>,
    /// This frame's scales (set by [`Self::plan_frame`]).
    k: LampScales,
    /// Why the transfer cannot take the bounce this frame (`None`: it can).
    no_transfer: Option<String>,
}

fn any_on(k: &LampScales) -> bool {
    k.as_slice().iter().any(|k| k.iter().any(|&v| v > 0.0))
}

impl LampBouncePass {
    /// The unit for `lamps` (nothing traced yet).
    pub fn new(lamps: &[Lamp]) -> Self {
        Self { lamps: lamps.to_vec(), bounce: None, k: LampScales::NONE, no_transfer: None }
    }

    /// The traced bounce, once a frame had a lamp on.
    pub fn bounce(&self) -> Option<&LampBounce> {
        self.bounce.as_ref()
    }

    fn plan_frame(&mut self, k: LampScales, no_transfer: Option<String>) {
        self.k = k;
        self.no_transfer = no_transfer;
    }
}

impl Pass<FrameContext> for LampBouncePass {
    const NAME: &'static str = pass::LAMP_BOUNCE;

    fn plan(&self, ctx: &FrameContext) -> Plan {
        if let Some(why) = &ctx.no_objects {
            return Plan::skip(why.clone());
        }
        if let Some(why) = &self.no_transfer {
            return Plan::skip(why.clone());
        }
        let applied = self.bounce.as_ref().and_then(|b| b.applied());
        if !any_on(&self.k) && !applied.is_some_and(any_on) {
            return Plan::skip("no lamp is on");
        }
        if applied == Some(&self.k) {
            return Plan::skip("the lamps' scales are those of the bounce uploaded: it is reused (camera, lamps and objects are static)");
        }
        Plan::Run
    }
}

impl Compositor {
    /// Plans the lamps' bounce for the frame and, when it runs, traces it (first time), forms
    /// `Σ k_i·R_i` for the frame's scales and uploads it. Nothing at all without lamps.
    pub(super) fn prepare_lamp_bounce(&mut self, ctx: &FrameContext, k: &LampScales, report: &mut PassReport) {
        let Some(unit) = self.lamp_bounce.as_mut() else { return };
        let no_transfer = match (self.transfer.scene_and_transfer(), ctx.switches.transfer) {
            (Some(_), true) => None,
            (Some(_), false) => Some(ctx.off.clone()),
            (None, _) => Some("no per-pixel transfer: the probe grid's ambient holds no lamp light".to_owned()),
        };
        unit.plan_frame(*k, no_transfer);
        if !ctx.admit(&*unit, report) {
            return;
        }
        let Some((scene, transfer)) = self.transfer.scene_and_transfer() else { return };
        let bounce = unit.bounce.get_or_insert_with(|| {
            let b = transfer.trace_lamps(scene, &unit.lamps);
            report.timings.transfer_ms += b.trace_ms;
            b
        });
        bounce.apply(k);
        let t = std::time::Instant::now();
        self.res.transfer_lamp.write(&self.gpu.queue, &bounce.texels);
        report.timings.upload_ms += t.elapsed().as_secs_f64() * 1e3;
    }
}

impl Compositor {
    /// The lamps' traced bounce, once a frame had a lamp on (`None` before, and without lamps).
    pub fn lamp_bounce(&self) -> Option<&LampBounce> {
        self.lamp_bounce.as_ref().and_then(|u| u.bounce())
    }
}
