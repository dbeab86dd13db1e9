//! The compositor's GPU passes as units: their plans, and the render passes they record into.
//!
//! # How it works
//! Each pass's pipelines live in its own module (`src/render/<pass>.rs`, shared with the VEM
//! renderer where they can be); this file says when the compositor runs each one and opens the
//! render passes on the compositor's canvas:
//!
//! | render pass | units, in order | left out when |
//! |---|---|---|
//! | depth and stencil | [`DepthPrepass`], [`RealVolumes`], [`VirtualVolumes`] | no objects; the stored stencil serves (then all three); no sun (the volumes) |
//! | shadow mask | [`ShadowMask`] | no objects; the stored stencil serves |
//! | lamp shadow atlas | `lamp_shadows` ([`crate::render::lamps`]) | no lamps; no lamp lights the objects; the maps drawn serve |
//! | virtual shading | [`VirtualShading`], and the [`SunTerm`] in its shader; then `lamp_term` (additive) | no objects (no sun: the sun term; no lit lamp: the lamp term) |
//! | composite | [`Composite`]; with lamps, `lamp_ground` in its shader ([`crate::render::lamps::ground`]) | never (`lamp_ground`: when the lamp term is left out; darkening not differential) |
//!
//! The 3D passes are scissored to the stored stencil's canvas region.

use super::context::FrameContext;
use super::volumes::{RealVolumes, VirtualVolumes};
use super::Compositor;
use crate::render::composite::Composite;
use crate::render::depth_prepass::DepthPrepass;
use crate::render::frame::pass;
use crate::render::plan::{Pass, Plan};
use crate::render::region::set_scissor;
use crate::render::shadow_mask::ShadowMask;
use crate::render::virtual_shading::VirtualShading;
use crate::render::RenderError;

impl Pass<FrameContext> for DepthPrepass {
    const NAME: &'static str = pass::DEPTH_PREPASS;

    fn plan(&self, ctx: &FrameContext) -> Plan {
        match &ctx.reuse {
            Some(why) => Plan::skip(why.clone()),
            None => Plan::Run,
        }
    }
}

impl Pass<FrameContext> for ShadowMask {
    const NAME: &'static str = pass::SHADOW_MASK;

    fn plan(&self, ctx: &FrameContext) -> Plan {
        match &ctx.reuse {
            Some(why) => Plan::skip(why.clone()),
            None => Plan::Run,
        }
    }
}

impl Pass<FrameContext> for VirtualShading {
    const NAME: &'static str = pass::VIRTUAL_SHADING;

    /// Runs whenever objects are drawn (the gate says when not).
    fn plan(&self, _: &FrameContext) -> Plan {
        Plan::Run
    }
}

/// The sun term of the virtual objects and the darkening of real pixels. It records nothing of
/// its own: the shading and composite shaders add it when `Lighting.sun_dir.w` is 1, which the
/// frame's uniform sets exactly when this unit runs (objects and a sun, see the gate).
pub struct SunTerm;

impl Pass<FrameContext> for SunTerm {
    const NAME: &'static str = pass::SUN_TERM;

    fn plan(&self, _: &FrameContext) -> Plan {
        Plan::Run
    }
}

impl Pass<FrameContext> for Composite {
    const NAME: &'static str = pass::COMPOSITE;

    /// Always runs: without objects the footage passes through it.
    fn plan(&self, _: &FrameContext) -> Plan {
        Plan::Run
    }
}

impl Compositor {
    /// The real volume pass over the current volumes.
    pub(super) fn real_volumes(&self) -> RealVolumes<'_> {
        RealVolumes { volumes: &self.volumes, pipelines: &self.shadow, resolve: &self.resolve }
    }

    /// The virtual volume pass over the current volumes.
    pub(super) fn virtual_volumes(&self) -> VirtualVolumes<'_> {
        VirtualVolumes { volumes: &self.volumes, pipelines: &self.shadow, resolve: &self.resolve }
    }

    /// The depth and stencil render pass (depth and stencil cleared): the prepass, then the
    /// volume passes that run.
    pub(super) fn record_depth_and_stencil(&self, encoder: &mut wgpu::CommandEncoder, real: bool, virtual_: bool) {
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
        set_scissor(&mut pa, self.stencil.region());
        self.prepass.record(&mut pa, &self.camera_bg, &self.proxy, &self.virt);
        if real {
            self.real_volumes().record(&mut pa);
        }
        if virtual_ {
            self.virtual_volumes().record(&mut pa);
        }
    }

    /// The shadow-mask render pass (stencil classes into the coverage masks).
    pub(super) fn record_mask(&self, encoder: &mut wgpu::CommandEncoder) {
        let mut pm = encoder.begin_render_pass(&wgpu::RenderPassDescriptor {
            label: Some("shadow mask"),
            color_attachments: &[Some(self.res.masks.attachment())],
            depth_stencil_attachment: Some(wgpu::RenderPassDepthStencilAttachment { view: &self.res.depth.view, depth_ops: None, stencil_ops: None }),
            ..Default::default()
        });
        set_scissor(&mut pm, self.stencil.region());
        self.mask.record(&mut pm);
    }

    /// The virtual shading render pass (after the masks, whose virtual-surface channels give the
    /// sun visibility), then the lamp term added onto it when `lamps`.
    pub(super) fn record_shading(&self, encoder: &mut wgpu::CommandEncoder, lamps: bool) {
        let mut pb = encoder.begin_render_pass(&wgpu::RenderPassDescriptor {
            label: Some("virtual shading"),
            color_attachments: &[Some(self.res.layer.attachment())],
            depth_stencil_attachment: Some(wgpu::RenderPassDepthStencilAttachment { view: &self.res.depth.view, depth_ops: None, stencil_ops: None }),
            ..Default::default()
        });
        set_scissor(&mut pb, self.stencil.region());
        self.shading.record(&mut pb, &self.shading_bg, &self.virt);
        if let Some(l) = self.lamps.as_ref().filter(|_| lamps) {
            l.record(&mut pb, &self.virt);
        }
    }

    /// The composite pipelines writing `format`.
    pub(super) fn composite_for(&self, format: wgpu::TextureFormat) -> Result<&Composite, RenderError> {
        Ok(self.composites.get(&format).ok_or_else(|| crate::gpu::GpuError::Device(format!("no composite pipeline for {format:?}")))?)
    }

    /// The composite into `target` (and the warped debug masks). With the objects switched off,
    /// first clears the layers an earlier frame left, which the composite reads.
    pub(super) fn record_composite(&self, encoder: &mut wgpu::CommandEncoder, ctx: &FrameContext, composite: &Composite, target: &wgpu::TextureView) {
        if !ctx.has_objects() && self.virt.index_count > 0 {
            for attachment in [self.res.layer.attachment(), self.res.masks.attachment()] {
                encoder.begin_render_pass(&wgpu::RenderPassDescriptor { label: Some("clear switched-off layers"), color_attachments: &[Some(attachment)], ..Default::default() });
            }
        }
        let masks = self.config.debug_masks.then_some(&self.res.output_masks.view);
        let lamps = self.lamps.as_ref().map_or(&self.no_lamps_bg, |l| l.data_bind_group());
        composite.record(encoder, &self.composite_bg, lamps, target, masks);
    }
}
