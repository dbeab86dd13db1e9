//! The stencil layout of the canvas and the resolve passes that turn volume counts into flags
//! (`shaders/stencil_resolve.wgsl`).
//!
//! # How it works
//! One 8-bit stencil value per sample:
//!
//! | bits | meaning |
//! |---|---|
//! | 0–4 | shadow-volume count (modulo 32) while a volume pass runs |
//! | 5 | the sample shows a virtual object (set by the depth prepass) |
//! | 6 | inside a virtual occluder's volume |
//! | 7 | inside a real occluder's volume |
//!
//! Jensen §3.2 counts the virtual volumes up and the real ones down in one buffer and treats a
//! positive count as "virtual shadow only"; with several overlapping volumes that count can be
//! wrong (two virtual and one real give +1). Here each kind is counted on its own in bits 0–4
//! (z-fail: real occluders count down, virtual ones up, as in the paper) and a full-screen
//! resolve turns a non-zero count into its flag and clears the counter. The stencil operations
//! only touch the bits their write mask allows, so increments wrap within bits 0–4. Volume
//! counts that are a multiple of 32 read as zero: that needs 32 overlapping volumes at one
//! sample (per-triangle volumes of a heavily layered open mesh), and is the one way a shadow can
//! be missed.
//!
//! The classes the later passes test (stencil `Equal`, read mask `0xFF`):
//! - virtual shadow on a real surface with no real shadow: [`VIRTUAL_SHADOW`] exactly;
//! - a virtual surface in the sun: [`VIRTUAL_SURFACE`] exactly; any other value with the
//!   virtual-surface bit is in some shadow.

use super::RenderError;
use crate::gpu::shaders;

/// Counter bits.
pub const COUNT_MASK: u32 = 0x1f;
/// The sample shows a virtual object.
pub const VIRTUAL_SURFACE: u32 = 0x20;
/// Inside a virtual occluder's volume.
pub const VIRTUAL_SHADOW: u32 = 0x40;
/// Inside a real occluder's volume.
pub const REAL_SHADOW: u32 = 0x80;

/// Stencil face state that applies `op` when the depth test fails (z-fail).
pub fn zfail(op: wgpu::StencilOperation) -> wgpu::StencilFaceState {
    wgpu::StencilFaceState { compare: wgpu::CompareFunction::Always, fail_op: wgpu::StencilOperation::Keep, depth_fail_op: op, pass_op: wgpu::StencilOperation::Keep }
}

/// Stencil face state that only tests `compare` against the reference.
pub fn test(compare: wgpu::CompareFunction) -> wgpu::StencilFaceState {
    wgpu::StencilFaceState { compare, fail_op: wgpu::StencilOperation::Keep, depth_fail_op: wgpu::StencilOperation::Keep, pass_op: wgpu::StencilOperation::Keep }
}

/// The two resolve pipelines: real count → [`REAL_SHADOW`], virtual count → [`VIRTUAL_SHADOW`].
pub struct StencilResolve {
    /// Real count → flag.
    pub real: wgpu::RenderPipeline,
    /// Virtual count → flag.
    pub virtual_: wgpu::RenderPipeline,
}

impl StencilResolve {
    /// Builds the pipelines for the canvas depth format and sample count.
    pub fn new(device: &wgpu::Device, depth_format: wgpu::TextureFormat, samples: u32) -> Result<Self, RenderError> {
        let module = shaders::module(device, "stencil_resolve.wgsl")?;
        let layout = device.create_pipeline_layout(&wgpu::PipelineLayoutDescriptor { label: Some("stencil resolve"), bind_group_layouts: &[], immediate_size: 0 });
        let make = |flag: u32, label: &str| {
            // Passes where (stencil & COUNT_MASK) > (reference & COUNT_MASK) = 0, i.e. the count is
            // non-zero; writes the reference (= the flag, whose counter bits are 0) into the flag
            // and counter bits.
            let face = wgpu::StencilFaceState {
                compare: wgpu::CompareFunction::Less,
                fail_op: wgpu::StencilOperation::Keep,
                depth_fail_op: wgpu::StencilOperation::Keep,
                pass_op: wgpu::StencilOperation::Replace,
            };
            device.create_render_pipeline(&wgpu::RenderPipelineDescriptor {
                label: Some(label),
                layout: Some(&layout),
                vertex: wgpu::VertexState { module: &module, entry_point: Some("vs_main"), compilation_options: Default::default(), buffers: &[] },
                primitive: wgpu::PrimitiveState::default(),
                depth_stencil: Some(wgpu::DepthStencilState {
                    format: depth_format,
                    depth_write_enabled: Some(false),
                    depth_compare: Some(wgpu::CompareFunction::Always),
                    stencil: wgpu::StencilState { front: face, back: face, read_mask: COUNT_MASK, write_mask: flag | COUNT_MASK },
                    bias: Default::default(),
                }),
                multisample: wgpu::MultisampleState { count: samples, ..Default::default() },
                fragment: None,
                multiview_mask: None,
                cache: None,
            })
        };
        Ok(Self { real: make(REAL_SHADOW, "stencil resolve real"), virtual_: make(VIRTUAL_SHADOW, "stencil resolve virtual") })
    }

    /// Records the real resolve.
    pub fn record_real(&self, pass: &mut wgpu::RenderPass<'_>) {
        pass.set_pipeline(&self.real);
        pass.set_stencil_reference(REAL_SHADOW);
        pass.draw(0..3, 0..1);
    }

    /// Records the virtual resolve.
    pub fn record_virtual(&self, pass: &mut wgpu::RenderPass<'_>) {
        pass.set_pipeline(&self.virtual_);
        pass.set_stencil_reference(VIRTUAL_SHADOW);
        pass.draw(0..3, 0..1);
    }
}
