//! The compositor's lamp stage (issue 16 §2): the scene's `[[lights]]` set up as a
//! [`LampPass`], and per frame its plan, shadow maps and upload. The lamp term itself is drawn
//! in the virtual shading's render pass (`units.rs`); see [`crate::render::lamps`].

use super::Compositor;
use super::ground_bounce::GroundBounceUnit;
use super::lamp_bounce::LampBouncePass;
use super::context::FrameContext;
use crate::lamps::Lamp;
use crate::lighting::Lighting;
use crate::render::RenderError;
use crate::render::frame::{Darkening, PassReport};
use crate::render::lamps::{LampOptions, LampPass};

impl Compositor {
    /// Lights the virtual objects with `lamps` from the next frame on (scene order: lamp `i`
    /// takes the scale `i` of the frame's [`crate::lighting::LampScales`]); an empty list removes
    /// the lamp stage.
    pub fn set_lamps(&mut self, lamps: &[Lamp], options: LampOptions) -> Result<(), RenderError> {
        self.lamps = if lamps.is_empty() { None } else { Some(LampPass::new(&self.gpu, lamps, options, &self.camera_buf, &self.mat_layout, &self.lamp_layout)?) };
        self.lamp_bounce = (!lamps.is_empty() && options.bounce).then(|| LampBouncePass::new(lamps));
        self.ground_bounce = (!lamps.is_empty() && options.ground && options.ground_bounce).then(|| GroundBounceUnit::new(lamps));
        self.clear_ground_bounce();
        // A bounce of earlier lamps must not stay in the shading's texture.
        self.res.transfer_lamp.write(&self.gpu.queue, &vec![[0.0f32; 4]; (self.canvas.intrinsics.width * self.canvas.intrinsics.height) as usize]);
        Ok(())
    }

    /// The lamp stage, when the scene has lamps.
    pub fn lamps(&self) -> Option<&LampPass> {
        self.lamps.as_ref()
    }

    /// Plans the frame's lamps, draws their shadow maps when they must be, uploads the frame's
    /// spots (zero spots when the term does not run, so the composite's lamp loop stays idle),
    /// and decides the objects' lamp shadows on the real receivers (`lamp_ground`, run with
    /// the differential darkening, with the lamps' bounce at the receivers, `ground_bounce.rs`);
    /// true when the lamp term runs. Nothing at all without lamps.
    pub(super) fn prepare_lamps(&mut self, ctx: &FrameContext, lighting: &Lighting, encoder: &mut wgpu::CommandEncoder, report: &mut PassReport) -> bool {
        let Some(lamps) = self.lamps.as_mut() else { return false };
        let bounds = self.virtual_bounds.iter().copied().reduce(|(a, b), (c, d)| (a.min(c), b.max(d)));
        lamps.plan_frame(ctx.no_objects.as_deref(), &lighting.lamps, bounds);
        if ctx.admit(&lamps.shadows_unit(), report) {
            lamps.record_shadows(&self.gpu, encoder, &self.virt, &self.proxy);
        }
        let run = ctx.admit(&lamps.term_unit(), report);
        let differential = ctx.has_objects() && self.config.darkening == Darkening::Differential;
        let ground = ctx.admit(&lamps.ground_unit(differential), report);
        lamps.set_ground(ground);
        if run {
            lamps.upload(&self.gpu.queue, report);
        } else {
            lamps.clear(&self.gpu.queue);
        }
        if ground {
            self.prepare_ground_bounce(&lighting.lamps, report);
        }
        run
    }
}
