//! Pass 1 (`shaders/depth_prepass.wgsl`): the real proxy and the virtual objects into depth only
//! (Jensen §3.2: "scene occlusions would here be handled by the depth buffer"). Shared by the
//! outdoor compositor and the VEM renderer (whose receivers are the proxy or a ground plane).
//!
//! The proxy is drawn first; the virtual objects then set the virtual-surface stencil bit where
//! they are in front (on a depth format with stencil; the VEM canvas has none). Reversed depth:
//! cleared to 0 (infinitely far), nearer is greater. Each renderer opens the render pass (its
//! clears, its scissor) and decides whether the pass runs; [`DepthPrepass::record`] draws.

use super::RenderError;
use super::stencil::VIRTUAL_SURFACE;
use crate::gpu::mesh::{ProxyBuffers, VirtualBuffers};
use crate::gpu::shaders;

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
    /// The virtual-surface bit is written when `depth_format` has a stencil aspect.
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
        let bit = if depth_format.has_stencil_aspect() {
            wgpu::StencilState { front: set_bit, back: set_bit, read_mask: 0, write_mask: VIRTUAL_SURFACE }
        } else {
            wgpu::StencilState::default()
        };
        Ok(Self {
            proxy: make("depth prepass proxy", 12, wgpu::StencilState::default(), None),
            virtual_: make("depth prepass virtual", virtual_stride, bit.clone(), None),
            virtual_closed: make("depth prepass virtual closed", virtual_stride, bit, Some(wgpu::Face::Back)),
        })
    }

    /// Draws the proxy (or any receiver mesh of positions) and then the virtual objects, which set
    /// the virtual-surface stencil bit, with the camera bind group `camera`.
    pub fn record(&self, pass: &mut wgpu::RenderPass<'_>, camera: &wgpu::BindGroup, proxy: &ProxyBuffers, objects: &VirtualBuffers) {
        pass.set_bind_group(0, camera, &[]);
        pass.set_pipeline(&self.proxy);
        pass.set_vertex_buffer(0, proxy.vertices.slice(..));
        pass.set_index_buffer(proxy.indices.slice(..), wgpu::IndexFormat::Uint32);
        pass.draw_indexed(0..proxy.index_count, 0, 0..1);
        pass.set_stencil_reference(VIRTUAL_SURFACE);
        pass.set_vertex_buffer(0, objects.vertices.slice(..));
        pass.set_index_buffer(objects.indices.slice(..), wgpu::IndexFormat::Uint32);
        for d in &objects.draws {
            pass.set_pipeline(if d.closed { &self.virtual_closed } else { &self.virtual_ });
            pass.draw_indexed(d.indices.clone(), 0, 0..1);
        }
    }
}
