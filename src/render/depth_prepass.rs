//! Pass 1 (`shaders/depth_prepass.wgsl`): the real proxy and the virtual objects into depth only
//! (Jensen §3.2: "scene occlusions would here be handled by the depth buffer").
//!
//! The proxy is drawn first; the virtual objects then set the virtual-surface stencil bit where
//! they are in front. Reversed depth: cleared to 0 (infinitely far), nearer is greater.

use super::RenderError;
use crate::gpu::shaders;
use super::stencil::VIRTUAL_SURFACE;

/// The two depth pipelines.
pub struct DepthPrepass {
    /// Real proxy: positions only (12-byte stride).
    pub proxy: wgpu::RenderPipeline,
    /// Virtual objects, open meshes (two-sided): the shading vertex buffer, position only.
    pub virtual_: wgpu::RenderPipeline,
    /// Virtual objects, closed meshes (back faces culled).
    pub virtual_closed: wgpu::RenderPipeline,
}

impl DepthPrepass {
    /// Builds the pipelines; `virtual_stride` is the byte stride of the virtual vertex buffer.
    pub fn new(
        device: &wgpu::Device,
        camera_layout: &wgpu::BindGroupLayout,
        depth_format: wgpu::TextureFormat,
        samples: u32,
        virtual_stride: u64,
    ) -> Result<Self, RenderError> {
        let module = shaders::module(device, "depth_prepass.wgsl")?;
        let layout = device.create_pipeline_layout(&wgpu::PipelineLayoutDescriptor {
            label: Some("depth prepass"),
            bind_group_layouts: &[Some(camera_layout)],
            immediate_size: 0,
        });
        let make = |label: &str, stride: u64, stencil: wgpu::StencilState, cull_mode: Option<wgpu::Face>| {
            let attrs = [wgpu::VertexAttribute { format: wgpu::VertexFormat::Float32x3, offset: 0, shader_location: 0 }];
            device.create_render_pipeline(&wgpu::RenderPipelineDescriptor {
                label: Some(label),
                layout: Some(&layout),
                vertex: wgpu::VertexState {
                    module: &module,
                    entry_point: Some("vs_main"),
                    compilation_options: Default::default(),
                    buffers: &[Some(wgpu::VertexBufferLayout { array_stride: stride, step_mode: wgpu::VertexStepMode::Vertex, attributes: &attrs })],
                },
                // Proxy surfaces are two-sided; closed virtual meshes never show a back face.
                primitive: wgpu::PrimitiveState { cull_mode, ..Default::default() },
                depth_stencil: Some(wgpu::DepthStencilState {
                    format: depth_format,
                    depth_write_enabled: Some(true),
                    depth_compare: Some(wgpu::CompareFunction::Greater),
                    stencil,
                    bias: Default::default(),
                }),
                multisample: wgpu::MultisampleState { count: samples, ..Default::default() },
                fragment: None,
                multiview_mask: None,
                cache: None,
            })
        };
        let set_bit = wgpu::StencilFaceState {
            compare: wgpu::CompareFunction::Always,
            fail_op: wgpu::StencilOperation::Keep,
            depth_fail_op: wgpu::StencilOperation::Keep,
            pass_op: wgpu::StencilOperation::Replace,
        };
        let bit = wgpu::StencilState { front: set_bit, back: set_bit, read_mask: 0, write_mask: VIRTUAL_SURFACE };
        Ok(Self {
            proxy: make("depth prepass proxy", 12, wgpu::StencilState::default(), None),
            virtual_: make("depth prepass virtual", virtual_stride, bit.clone(), None),
            virtual_closed: make("depth prepass virtual closed", virtual_stride, bit, Some(wgpu::Face::Back)),
        })
    }
}
