//! One frame's decisions (which passes run, and why not) and its command encoding.

use super::{Compositor, StencilState};
use crate::render::RenderError;
use crate::lighting::Lighting;
use crate::render::frame::{Darkening, LightingUniform, PassReport, VideoFrame, VolumeStats, luma, pass};
use crate::render::stencil::VIRTUAL_SURFACE;
use crate::render::virtual_shading::VirtualShading;
use glam::Vec3;

fn angle_deg(a: Vec3, b: Vec3) -> f64 {
    (a.dot(b).clamp(-1.0, 1.0).acos().to_degrees()) as f64
}

impl Compositor {
    /// Decides the frame's passes, does its CPU work and uploads, and records its commands
    /// (composite into `target`).
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
        let mut report = PassReport::default();
        let sw = self.switches;
        let off = if self.switched_off_reason.is_empty() { "switched off".to_owned() } else { self.switched_off_reason.clone() };
        let has_virtual = self.virt.index_count > 0 && sw.virtual_objects;
        let l = lighting.sun_dir.normalize_or_zero();
        let (pd_l, pa_l) = (luma(lighting.pd), luma(lighting.pa));
        let no_sun: Option<String> = if !lighting.above_horizon {
            Some("the sun is below the horizon".into())
        } else if !(pd_l > 0.0) || (pd_l as f64) < self.config.no_sun_ratio * pa_l as f64 {
            Some(format!("Pd ≈ 0 (Pd/Pa = {:.3} < {})", if pa_l > 0.0 { pd_l / pa_l } else { 0.0 }, self.config.no_sun_ratio))
        } else if l == Vec3::ZERO {
            Some("no sun direction".into())
        } else {
            None
        };
        let sun_on = no_sun.is_none() && has_virtual;
        report.sun = sun_on;
        let sun_key = sun_on.then_some(l);
        // Reuse: the stored stencil matches this frame's sun (within the tolerance), the objects
        // are static (they are: placements come from the manifest) and the same masks are drawn.
        let reuse = has_virtual
            && self.stencil.is_some_and(|s| {
                s.debug == self.config.debug_masks
                    && match (s.sun, sun_key) {
                        (None, None) => true,
                        (Some(a), Some(b)) => angle_deg(a, b) <= self.config.reuse_sun_deg,
                        _ => false,
                    }
            });
        let reuse_reason = || {
            let s = self.stencil.unwrap_or(StencilState { sun: None, debug: false, frame: 0 });
            match (s.sun, sun_key) {
                (Some(a), Some(b)) => format!(
                    "sun moved {:.4}° ≤ {}° since frame {} and the objects are static: its volumes and stencil are reused",
                    angle_deg(a, b),
                    self.config.reuse_sun_deg,
                    s.frame
                ),
                _ => format!("no sun now or at frame {} and the objects are static: its depth and stencil are reused", s.frame),
            }
        };

        // The canvas region of this frame's 3D passes: recomputed with the stencil, kept with it.
        if has_virtual && !reuse {
            let t = std::time::Instant::now();
            self.region = if self.config.scissor && !self.config.debug_masks {
                crate::render::region::canvas_region(&self.canvas, &self.receivers, &self.virtual_bounds, sun_key)
            } else {
                None
            };
            report.timings.region_ms = t.elapsed().as_secs_f64() * 1e3;
        }
        report.canvas_region = if has_virtual { self.region } else { None };
        let region = self.region;

        let mut encoder = self.gpu.device.create_command_encoder(&wgpu::CommandEncoderDescriptor { label: Some("frame") });
        let mut stats = VolumeStats { compute: self.volumes.builder() == super::Builder::Compute, reused: reuse, ..Default::default() };

        // Volumes.
        if !has_virtual {
            let why = if self.virt.index_count == 0 { "the scene has no virtual objects".to_owned() } else { off.clone() };
            for p in [pass::VOLUME_BUILD, pass::DEPTH_PREPASS, pass::REAL_VOLUMES, pass::VIRTUAL_VOLUMES, pass::VIRTUAL_SHADING, pass::SHADOW_MASK, pass::SUN_TERM] {
                report.skip(p, why.clone());
            }
        } else if let Some(why) = &no_sun {
            for p in [pass::VOLUME_BUILD, pass::REAL_VOLUMES, pass::VIRTUAL_VOLUMES, pass::SUN_TERM] {
                report.skip(p, why.clone());
            }
        } else if reuse {
            report.skip(pass::VOLUME_BUILD, reuse_reason());
        } else if !sw.virtual_volumes && !sw.real_volumes {
            report.skip(pass::VOLUME_BUILD, off.clone());
        } else {
            let b = self.volumes.build(&self.gpu, &mut encoder, l, &self.virtual_bounds, self.config.cap_offset_m);
            report.ran.push(pass::VOLUME_BUILD);
            report.timings.volume_build_ms = b.build_ms;
            report.timings.upload_ms += b.upload_ms;
            stats.virtual_triangles = b.virtual_triangles;
            stats.real_triangles = b.real_triangles;
            stats.real_parts = b.real_parts;
        }
        report.volumes = stats;

        // Per-pixel c and b where the virtual shadow can reach (and, for the differential
        // model, c_v and b_v near the objects).
        let differential = self.config.darkening == Darkening::Differential;
        let needs_receivers = has_virtual && !reuse && (differential || (sun_on && self.config.darkening == Darkening::Normal));
        if needs_receivers {
            // The pixel list follows the sun only as closely as `b` does: it is rebuilt when `b`
            // is (the region grows by RECEIVER_GROW_PX to cover the motion in between).
            let key = (sun_on.then_some(l), differential);
            let stale = match &self.receiver_pixels {
                Some((k, _)) => match (k.0, key.0) {
                    (Some(a), Some(b)) => angle_deg(a, b) > self.config.bounce_rebuild_deg || k.1 != key.1,
                    (a, b) => a.is_some() != b.is_some() || k.1 != key.1,
                },
                None => true,
            };
            if stale {
                let mut pixels = if sun_on { self.receivers.in_shadow_reach(&self.virtual_bounds, l, super::RECEIVER_GROW_PX) } else { Vec::new() };
                if differential {
                    let near = self.near_pixels.get_or_insert_with(|| self.receivers.near(&self.virtual_bounds, self.near_radius_m));
                    pixels.extend_from_slice(near);
                    pixels.sort_unstable();
                    pixels.dedup();
                }
                self.receiver_pixels = Some((key, pixels));
            }
            let pixels = self.receiver_pixels.as_ref().map(|(_, p)| p.as_slice()).unwrap_or(&[]);
            let with = if differential { self.with_ray.as_deref() } else { None };
            let s = self.receivers.ensure(
                &self.proxy_ray,
                with,
                pixels,
                sun_on.then_some(l),
                self.config.ambient_quality,
                self.config.bounce_quality,
                self.config.bounce_rebuild_deg,
            );
            report.receivers_computed = s.computed;
            report.timings.receivers_ms = s.ms;
            if s.computed > 0 || s.bounce_reset {
                let t = std::time::Instant::now();
                let q = &self.gpu.queue;
                self.res.ambient.write(q, &self.receivers.ambient);
                self.res.bounce.write(q, &self.receivers.bounce);
                self.res.ambient_with.write(q, &self.receivers.ambient_with);
                self.res.bounce_with.write(q, &self.receivers.bounce_with);
                report.timings.upload_ms += t.elapsed().as_secs_f64() * 1e3;
            }
        }

        // The objects' ambient transfer: traced on the first frame and when the sun has moved
        // as far as `b` tolerates.
        if !has_virtual {
            let why = if self.virt.index_count == 0 { "the scene has no virtual objects".to_owned() } else { off.clone() };
            report.skip(pass::OBJECT_TRANSFER, why);
        } else if self.transfer.is_some() && !sw.transfer {
            report.skip(pass::OBJECT_TRANSFER, off.clone());
        } else if let Some((scene, transfer)) = &mut self.transfer {
            let before = transfer.traced_sun();
            let u = transfer.ensure(scene, sun_on.then_some(l), self.config.bounce_rebuild_deg);
            report.timings.transfer_ms = u.ms;
            report.transfer_traced = u.traced;
            if u.traced > 0 {
                let t = std::time::Instant::now();
                self.res.transfer_sky.write(&self.gpu.queue, &transfer.sky);
                self.res.transfer_sun.write(&self.gpu.queue, &transfer.sun);
                report.timings.upload_ms += t.elapsed().as_secs_f64() * 1e3;
                report.ran.push(pass::OBJECT_TRANSFER);
            } else if transfer.surfaces().is_empty() {
                report.skip(pass::OBJECT_TRANSFER, "no canvas pixel shows a virtual object");
            } else {
                let why = match (before, sun_on) {
                    (Some(a), true) => format!(
                        "the sun moved {:.3}° ≤ {}° since it was traced and the camera and objects are static: the transfer is reused",
                        angle_deg(a, l),
                        self.config.bounce_rebuild_deg
                    ),
                    _ => "no sun: the traced sky transfer is reused (camera and objects are static)".to_owned(),
                };
                report.skip(pass::OBJECT_TRANSFER, why);
            }
        } else {
            report.skip(pass::OBJECT_TRANSFER, "transfer_paths = 0: ambient from the probe grid times ambient occlusion");
        }

        // Uploads.
        let t = std::time::Instant::now();
        self.res.video.write(&self.gpu.queue, &video.rgba);
        let uniform = LightingUniform {
            sun_dir: [l.x, l.y, l.z, if sun_on { 1.0 } else { 0.0 }],
            pd: lighting.pd.extend(0.0).to_array(),
            pa: lighting.pa.extend(0.0).to_array(),
            params: [
                // Objects switched off: no differential region either, so the footage passes.
                if has_virtual { self.config.darkening.shader_code() } else { Darkening::Normal.shader_code() },
                if self.config.sun_bounce { 1.0 } else { 0.0 },
                output_scale,
                match &self.transfer {
                    Some((_, t)) if sw.transfer => t.stride() as f32,
                    _ => 0.0,
                },
            ],
        };
        self.gpu.queue.write_buffer(&self.lighting_buf, 0, bytemuck::bytes_of(&uniform));
        report.timings.upload_ms += t.elapsed().as_secs_f64() * 1e3;

        let t = std::time::Instant::now();
        // Pass A: depth, volumes, resolves.
        if has_virtual && !reuse {
            let mut pa = encoder.begin_render_pass(&wgpu::RenderPassDescriptor {
                label: Some("depth and stencil"),
                color_attachments: &[],
                depth_stencil_attachment: Some(wgpu::RenderPassDepthStencilAttachment {
                    view: &self.res.depth.view,
                    depth_ops: Some(wgpu::Operations { load: wgpu::LoadOp::Clear(0.0), store: wgpu::StoreOp::Store }),
                    stencil_ops: Some(wgpu::Operations { load: wgpu::LoadOp::Clear(0), store: wgpu::StoreOp::Store }),
                }),
                ..Default::default()
            });
            crate::render::region::set_scissor(&mut pa, region);
            pa.set_bind_group(0, &self.camera_bg, &[]);
            pa.set_pipeline(&self.prepass.proxy);
            pa.set_vertex_buffer(0, self.proxy.vertices.slice(..));
            pa.set_index_buffer(self.proxy.indices.slice(..), wgpu::IndexFormat::Uint32);
            pa.draw_indexed(0..self.proxy.index_count, 0, 0..1);
            pa.set_stencil_reference(VIRTUAL_SURFACE);
            pa.set_vertex_buffer(0, self.virt.vertices.slice(..));
            pa.set_index_buffer(self.virt.indices.slice(..), wgpu::IndexFormat::Uint32);
            for d in &self.virt.draws {
                pa.set_pipeline(if d.closed { &self.prepass.virtual_closed } else { &self.prepass.virtual_ });
                pa.draw_indexed(d.indices.clone(), 0, 0..1);
            }
            report.ran.push(pass::DEPTH_PREPASS);
            if sun_on {
                if !sw.real_volumes {
                    report.skip(pass::REAL_VOLUMES, off.clone());
                } else if self.volumes.has_real() {
                    pa.set_pipeline(&self.shadow.real);
                    self.volumes.draw_real(&mut pa);
                    self.resolve.record_real(&mut pa);
                    report.ran.push(pass::REAL_VOLUMES);
                } else {
                    report.skip(pass::REAL_VOLUMES, "no part of the real proxy can shadow the virtual objects or the surfaces their shadows fall on");
                }
                if sw.virtual_volumes {
                    pa.set_pipeline(&self.shadow.virtual_);
                    self.volumes.draw_virtual(&mut pa);
                    self.resolve.record_virtual(&mut pa);
                    report.ran.push(pass::VIRTUAL_VOLUMES);
                } else {
                    report.skip(pass::VIRTUAL_VOLUMES, off.clone());
                }
            }
        } else if reuse {
            let why = reuse_reason();
            report.skip(pass::DEPTH_PREPASS, why.clone());
            if sun_on {
                report.skip(pass::REAL_VOLUMES, if sw.real_volumes { why.clone() } else { off.clone() });
                report.skip(pass::VIRTUAL_VOLUMES, if sw.virtual_volumes { why } else { off.clone() });
            }
        }

        // Pass M: masks.
        if has_virtual && !reuse {
            let mut pm = encoder.begin_render_pass(&wgpu::RenderPassDescriptor {
                label: Some("shadow mask"),
                color_attachments: &[Some(self.res.masks.attachment())],
                depth_stencil_attachment: Some(wgpu::RenderPassDepthStencilAttachment { view: &self.res.depth.view, depth_ops: None, stencil_ops: None }),
                ..Default::default()
            });
            crate::render::region::set_scissor(&mut pm, region);
            self.mask.record(&mut pm);
            report.ran.push(pass::SHADOW_MASK);
            self.stencil = Some(StencilState { sun: sun_key, debug: self.config.debug_masks, frame: self.frames });
        } else if reuse {
            report.skip(pass::SHADOW_MASK, reuse_reason());
        }

        // Pass B: shading (after the masks, whose virtual-surface channels give the sun visibility).
        if has_virtual {
            let mut pb = encoder.begin_render_pass(&wgpu::RenderPassDescriptor {
                label: Some("virtual shading"),
                color_attachments: &[Some(self.res.layer.attachment())],
                depth_stencil_attachment: Some(wgpu::RenderPassDepthStencilAttachment { view: &self.res.depth.view, depth_ops: None, stencil_ops: None }),
                ..Default::default()
            });
            crate::render::region::set_scissor(&mut pb, region);
            pb.set_bind_group(0, &self.shading_bg, &[]);
            pb.set_vertex_buffer(0, self.virt.vertices.slice(..));
            pb.set_index_buffer(self.virt.indices.slice(..), wgpu::IndexFormat::Uint32);
            pb.set_stencil_reference(VirtualShading::REFERENCE);
            for d in &self.virt.draws {
                pb.set_pipeline(if d.closed { &self.shading.closed } else { &self.shading.open });
                pb.set_bind_group(1, &d.bind_group, &[]);
                pb.draw_indexed(d.indices.clone(), 0, 0..1);
            }
            report.ran.push(pass::VIRTUAL_SHADING);
            if sun_on {
                report.ran.push(pass::SUN_TERM);
            }
        }

        // Objects switched off: clear the layers an earlier frame left, which the composite reads.
        if !has_virtual && self.virt.index_count > 0 {
            for attachment in [self.res.layer.attachment(), self.res.masks.attachment()] {
                encoder.begin_render_pass(&wgpu::RenderPassDescriptor { label: Some("clear switched-off layers"), color_attachments: &[Some(attachment)], ..Default::default() });
            }
        }

        // Pass C: composite (and the warped debug masks).
        let composite = self.composites.get(&format).ok_or_else(|| crate::gpu::GpuError::Device(format!("no composite pipeline for {format:?}")))?;
        {
            let mut pc = encoder.begin_render_pass(&wgpu::RenderPassDescriptor {
                label: Some("composite"),
                color_attachments: &[Some(wgpu::RenderPassColorAttachment {
                    view: target,
                    depth_slice: None,
                    resolve_target: None,
                    ops: wgpu::Operations { load: wgpu::LoadOp::Clear(wgpu::Color::BLACK), store: wgpu::StoreOp::Store },
                })],
                ..Default::default()
            });
            pc.set_pipeline(&composite.composite);
            pc.set_bind_group(0, &self.composite_bg, &[]);
            pc.draw(0..3, 0..1);
        }
        if self.config.debug_masks
            && let Some(mp) = &composite.masks
        {
            let mut pm = encoder.begin_render_pass(&wgpu::RenderPassDescriptor {
                label: Some("warped masks"),
                color_attachments: &[Some(wgpu::RenderPassColorAttachment {
                    view: &self.res.output_masks.view,
                    depth_slice: None,
                    resolve_target: None,
                    ops: wgpu::Operations { load: wgpu::LoadOp::Clear(wgpu::Color::TRANSPARENT), store: wgpu::StoreOp::Store },
                })],
                ..Default::default()
            });
            pm.set_pipeline(mp);
            pm.set_bind_group(0, &self.composite_bg, &[]);
            pm.draw(0..3, 0..1);
        }
        report.ran.push(pass::COMPOSITE);
        report.timings.gpu_ms = t.elapsed().as_secs_f64() * 1e3;
        self.frames += 1;
        Ok((encoder, report))
    }
}
