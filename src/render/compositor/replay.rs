//! Resumed runs: a frame's decisions replayed without its work, and the work owed paid later.
//!
//! # How it works
//! The compositor keeps state from frame to frame (the stored depth, stencil and mask and the
//! sun they were drawn for; the volumes; the receivers' `c`, `b` and the sun of their bounce;
//! the objects' transfer and the sun it was traced for). What a frame draws depends on that
//! history, so a run resumed at frame `k` must start from the state an uninterrupted run has
//! there, not from a fresh compositor. [`Compositor::replay`] takes each earlier frame's
//! lighting and makes every decision of [`Compositor::render`] (which passes would run, what the
//! caches would then hold and for which sun) without tracing or drawing; each cache remembers
//! what it owes. The first frame rendered afterwards pays it ([`Compositor::restore`]): the
//! receivers' pixels computed for the suns their frames would have used, the transfer traced
//! for its sun, and, when that frame reuses the stored stencil, the volumes, stencil and mask
//! drawn for the sun they were stored with. With moving objects, the `c`, `b` of the receivers
//! along the motion (`Compositor::reach_motion`) are owed for the sun of the first frame that
//! took them, and the `c_v`, `b_v` the visibility cuts set on a frame are owed with that
//! frame's poses, after its pixels. The result is the uninterrupted run's, bit for bit
//! (every computation is a pure function of its sun and seed); the report lists what was
//! restored.

use super::Compositor;
use super::context::FrameContext;
use crate::lighting::Lighting;
use crate::render::frame::{Darkening, PassReport, pass};

/// The last stencil rebuild a replay decided on: its frame context and which of its passes ran.
/// (Whether the volume passes draw depends on the volumes built, so `restore` decides that
/// after building them, as the frame itself did.)
#[derive(Clone, Debug)]
pub(super) struct OwedStencil {
    ctx: FrameContext,
    volumes: bool,
    depth: bool,
    mask: bool,
}

impl Compositor {
    /// Makes the decisions of a frame lit by `lighting` without its work (see the module docs).
    pub fn replay(&mut self, lighting: &Lighting) {
        let ctx = self.frame_context(lighting);
        let mut scratch = ctx.begin_report();
        let rebuilds = ctx.has_objects() && !ctx.reuses();
        let volumes = ctx.admit(&self.volumes, &mut scratch);
        self.replay_receivers(&ctx);
        if ctx.admit(&self.transfer, &mut scratch) {
            self.transfer.replay(&ctx);
        }
        let depth = ctx.admit(&self.prepass, &mut scratch);
        let mask = ctx.admit(&self.mask, &mut scratch);
        if mask {
            self.stencil.store(ctx.sun(), self.config.debug_masks, self.frames);
        }
        if rebuilds {
            self.owed_stencil = Some(OwedStencil { ctx, volumes, depth, mask });
        }
        self.frames += 1;
    }

    /// The receivers' decisions of a frame, without computing.
    fn replay_receivers(&mut self, ctx: &FrameContext) {
        self.receivers.set_frame_sky(ctx.sky, true);
        let differential = self.config.darkening == Darkening::Differential;
        let normal_with_sun = ctx.sun().is_some() && self.config.darkening == Darkening::Normal;
        if !ctx.has_objects() || !(differential || normal_with_sun) {
            return;
        }
        if ctx.reuses() {
            self.receivers.replay_continue_job(differential, self.config.bounce_quality.paths);
            return;
        }
        let rebuild = self.config.bounce_rebuild_deg;
        // The motion's reach, as `receiver_update::warm_reach` takes it on the first frame that
        // rebuilds: `c`, `b` (without the objects) owed for this frame's sun.
        if differential && let Some(reach) = self.take_reach_pixels(ctx) {
            let sun = ctx.traced_sun(self.receivers.sky_model());
            self.receivers.replay(&reach, sun, rebuild, false, self.config.bounce_quality.paths);
        }
        let pixels = self.receiver_pixels.pixels(&self.receivers, &self.virtual_bounds, ctx.sun(), differential, rebuild).to_vec();
        // With the visibility cuts serving all objects, `c_v`, `b_v` are not traced
        // (`receiver_update`).
        let sun = ctx.traced_sun(self.receivers.sky_model());
        let with = self.receivers_with(differential).is_some();
        self.receivers.replay(&pixels, sun, rebuild, with, self.config.bounce_quality.paths);
        // `c_v`, `b_v` from the cuts at this frame's poses, owed in order after the pixels'
        // `c`, `b` (`update_receivers` sets them right after computing those).
        if differential && let Some((kept, vis, _)) = self.cut_visibility(&pixels) {
            self.receivers.owe_visibility(kept, vis);
        }
    }

    /// Pays what replayed frames owe before the frame `now` is recorded into `encoder`.
    pub(super) fn restore(&mut self, now: &FrameContext, encoder: &mut wgpu::CommandEncoder, report: &mut PassReport) {
        let differential = self.config.darkening == Darkening::Differential;
        let with_ray = self.receivers_with(differential);
        let with = with_ray.as_deref();
        let t = std::time::Instant::now();
        let owed_values = self.receivers.owes();
        let computed = self.receivers.restore(&self.proxy_ray, with, self.config.ambient_quality, self.config.bounce_quality);
        if owed_values {
            self.upload_receivers();
            report.receivers_computed += computed;
            report.timings.receivers_ms += t.elapsed().as_secs_f64() * 1e3;
        }
        if self.transfer.restore(&self.gpu.queue, &self.res, report) {
            report.restored.push(pass::OBJECT_TRANSFER);
        }
        let Some(owed) = self.owed_stencil.take() else { return };
        if !now.reuses() {
            return; // this frame rebuilds them anyway
        }
        let mut scratch = owed.ctx.begin_report();
        self.update_region(&owed.ctx, &mut scratch);
        if owed.volumes {
            self.volumes.record(&self.gpu, encoder, &owed.ctx, &self.virtual_bounds, self.config.cap_offset_m, &mut scratch);
            report.restored.push(pass::VOLUME_BUILD);
        }
        let real = owed.ctx.admit(&self.real_volumes(), &mut scratch);
        let virtual_ = owed.ctx.admit(&self.virtual_volumes(), &mut scratch);
        if owed.depth {
            self.record_depth_and_stencil(encoder, real, virtual_);
            report.restored.push(pass::DEPTH_PREPASS);
            if real {
                report.restored.push(pass::REAL_VOLUMES);
            }
            if virtual_ {
                report.restored.push(pass::VIRTUAL_VOLUMES);
            }
        }
        if owed.mask {
            self.record_mask(encoder);
            report.restored.push(pass::SHADOW_MASK);
        }
    }

    /// True when replayed frames owe work.
    pub(super) fn owes(&self) -> bool {
        self.owed_stencil.is_some() || self.transfer.owes() || self.receivers.owes()
    }
}
