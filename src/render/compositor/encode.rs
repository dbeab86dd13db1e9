//! One frame of the compositor, as a list of units read top to bottom.
//!
//! # How it works
//! [`Compositor::encode`] decides the frame's facts once ([`FrameContext`]: objects, sun, reuse,
//! switches), starts the report with the frame-level gate's skips, then asks each unit in turn
//! ([`FrameContext::admit`]: the gate, else the unit's own plan, into the report) and records
//! the ones that run. CPU work and uploads come first, then the render passes in the order the
//! GPU needs them. The pass report's order is the list's.

use super::Compositor;
use super::context::FrameContext;
use super::units::SunTerm;
use crate::lighting::Lighting;
use crate::render::RenderError;
use crate::render::frame::{Darkening, LightingUniform, PassReport, VideoFrame};

impl Compositor {
    /// Decides the frame's passes, does its CPU work and uploads, and records its commands
    /// (composite into `target` of `format`, scaled by `output_scale`).
    pub(super) fn encode(
        &mut self,
        video: &VideoFrame,
        lighting: &Lighting,
        target: &wgpu::TextureView,
        format: wgpu::TextureFormat,
        output_scale: f32,
    ) -> Result<(wgpu::CommandEncoder, PassReport), RenderError> {
        if (video.width, video.height) != (self.canvas.out_width, self.canvas.out_height) {
            return Err(RenderError::FrameSize { got: (video.width, video.height), want: (self.canvas.out_width, self.canvas.out_height) });
        }
        let ctx = self.frame_context(lighting);
        let mut report = ctx.begin_report();
        let mut encoder = self.gpu.device.create_command_encoder(&wgpu::CommandEncoderDescriptor { label: Some("frame") });

        // Work replayed frames owe (a resumed run), then the frame's CPU work and uploads.
        if self.owes() {
            self.restore(&ctx, &mut encoder, &mut report);
        }
        self.update_region(&ctx, &mut report);
        report.volumes = self.volumes.stats(ctx.reuses());
        if ctx.admit(&self.volumes, &mut report) {
            self.volumes.record(&self.gpu, &mut encoder, &ctx, &self.virtual_bounds, self.config.cap_offset_m, &mut report);
        }
        self.update_receivers(&ctx, &mut report);
        if ctx.sky != crate::lighting::FrameSky::Declared {
            report.sky = Some(self.receivers.sky_model().name());
        }
        if ctx.admit(&self.transfer, &mut report) {
            self.transfer.record(&ctx, &self.gpu.queue, &self.res, &mut report);
        }
        self.prepare_lamp_bounce(&ctx, &lighting.lamps, &mut report);
        self.upload_frame(&ctx, video, lighting, output_scale, &mut report);

        // Render passes.
        let t = std::time::Instant::now();
        let depth = ctx.admit(&self.prepass, &mut report);
        let real = ctx.admit(&self.real_volumes(), &mut report);
        let virtual_ = ctx.admit(&self.virtual_volumes(), &mut report);
        debug_assert!(depth || !(real || virtual_), "volume passes run inside the depth prepass's render pass");
        if depth {
            self.record_depth_and_stencil(&mut encoder, real, virtual_);
        }
        if ctx.admit(&self.mask, &mut report) {
            self.record_mask(&mut encoder);
            self.stencil.store(ctx.sun(), self.config.debug_masks, self.frames);
        }
        let lamps = self.prepare_lamps(&ctx, lighting, &mut encoder, &mut report);
        if ctx.admit(&self.shading, &mut report) {
            self.record_shading(&mut encoder, lamps);
        }
        ctx.admit(&SunTerm, &mut report);
        let composite = self.composite_for(format)?;
        if ctx.admit(composite, &mut report) {
            self.record_composite(&mut encoder, &ctx, composite, target);
        }
        report.timings.gpu_ms = t.elapsed().as_secs_f64() * 1e3;
        self.frames += 1;
        Ok((encoder, report))
    }

    /// Uploads the footage and the frame's lighting uniform.
    fn upload_frame(&self, ctx: &FrameContext, video: &VideoFrame, lighting: &Lighting, output_scale: f32, report: &mut PassReport) {
        let t = std::time::Instant::now();
        self.res.video.write(&self.gpu.queue, &video.rgba);
        let l = ctx.sun_dir;
        let uniform = LightingUniform {
            sun_dir: [l.x, l.y, l.z, if ctx.sun().is_some() { 1.0 } else { 0.0 }],
            pd: lighting.pd.extend(0.0).to_array(),
            pa: lighting.pa.extend(0.0).to_array(),
            params: [
                // Objects switched off: no differential region either, so the footage passes.
                if ctx.has_objects() { self.config.darkening.shader_code() } else { Darkening::Normal.shader_code() },
                if self.config.sun_bounce { 1.0 } else { 0.0 },
                output_scale,
                self.transfer.shader_stride(ctx),
            ],
        };
        self.gpu.queue.write_buffer(&self.lighting_buf, 0, bytemuck::bytes_of(&uniform));
        report.timings.upload_ms += t.elapsed().as_secs_f64() * 1e3;
    }
}
