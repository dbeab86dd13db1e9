//! The VEM shading passes (`shaders/vem/shading.wgsl`; Havran §4.1–4.2) as two units, the
//! objects ([`ObjectShading`]) and the receivers ([`ReceiverRatio`]), drawn in one render pass,
//! and the plan of the depth prepass before them ([`DepthPrepass`], shared with the outdoor
//! compositor: `shaders/depth_prepass.wgsl`).
//!
//! # How it works
//! The depth prepass draws the real receivers (the proxy or a ground plane) and the virtual
//! objects; the shading pass then draws each visible surface once (depth `GreaterEqual`,
//! reversed depth, the same invariant position arithmetic):
//! - **objects**: the fragment looks up the region of its normal in the cube-map LUT and walks
//!   only that region's list of `H` (every light that can face the normal is in it, Havran §4.1),
//!   summing the glTF diffuse lobe times `E_i·max(n·l_i, 0)·V_i`; the specular lobe uses the
//!   glossy split of Havran §4.2 when the frame has a set `L` (lights of `L` inside the cone
//!   around the mirror direction, from the list of its `S_L` region, plus lights of `H` outside
//!   it), else `H`. `V_i` is the light's shadow-map visibility.
//! - **receivers**: the differential ratio `Σ E_c·max(n·l_c,0)·V_c / Σ E_c·max(n·l_c,0)` over the
//!   clustered lights `c`, one per shadow map (the darkening of the outdoor mode's differential
//!   model with the VEM's lights; visibility is per map, so walking all of `H` there would only
//!   repeat each map's lookup for nearly the same direction, at 4–12× the cost).
//!
//! Without culling, every light of each set is visited (the baseline of the speedup). Both
//! write two targets, cleared to "no object" and a ratio of 1, so a frame without shadow maps
//! leaves the receivers out and one without objects the objects.

use super::frame::VemFrame;
use super::pass;
use crate::gpu::LAYER_FORMAT;
use crate::gpu::canvas::{storage_entry, uniform_entry};
use crate::gpu::mesh::{ProxyBuffers, VirtualBuffers};
use crate::gpu::shaders;
use crate::render::RenderError;
use crate::render::depth_prepass::DepthPrepass;
use crate::render::plan::{Pass, Plan};

/// Depth format of the VEM canvas (no stencil needed).
pub const DEPTH_FORMAT: wgpu::TextureFormat = wgpu::TextureFormat::Depth32Float;
/// Format of the receivers' ratio layer.
pub const RATIO_FORMAT: wgpu::TextureFormat = wgpu::TextureFormat::Rgba16Float;

/// Per-region culling on.
pub const FLAG_CULLING: u32 = 1;
/// Shadow-map visibility on.
pub const FLAG_SHADOWS: u32 = 2;
/// The glossy `L`/`H` split on.
pub const FLAG_GLOSSY: u32 = 4;

/// Mirrors `VemFrame` in `shaders/common/vem_lights.wgsl`.
#[repr(C)]
#[derive(Clone, Copy, Debug, Default, PartialEq, bytemuck::Pod, bytemuck::Zeroable)]
pub struct VemFrameUniform {
    /// Lights in `H`, `H` regions, `H` LUT size, flags.
    pub h: [u32; 4],
    /// Lights in `L`, `L` regions, `L` LUT size, the canvas width with the cuts' light (else 0).
    pub l: [u32; 4],
    /// Atlas tiles per side, tile size, shadow maps this frame, unused.
    pub atlas: [u32; 4],
    /// `cos(γ/2)`, ground albedo, unused, unused.
    pub params: [f32; 4],
}

/// The objects shaded: closed meshes with back faces culled, open ones two-sided.
pub struct ObjectShading {
    /// Closed meshes.
    pub closed: wgpu::RenderPipeline,
    /// Open meshes.
    pub open: wgpu::RenderPipeline,
    /// Closed and open meshes under the visibility cuts' light (`fs_cut_object`), when the
    /// renderer was set up for it.
    pub cut: Option<[wgpu::RenderPipeline; 2]>,
}

impl ObjectShading {
    /// Draws the objects (group 0 already set) with each draw's material; `cuts`: under the
    /// visibility cuts' light (when set up for it).
    pub fn record(&self, pass: &mut wgpu::RenderPass<'_>, objects: &VirtualBuffers, cuts: bool) {
        pass.set_vertex_buffer(0, objects.vertices.slice(..));
        pass.set_index_buffer(objects.indices.slice(..), wgpu::IndexFormat::Uint32);
        let [closed, open] = match (&self.cut, cuts) {
            (Some([c, o]), true) => [c, o],
            _ => [&self.closed, &self.open],
        };
        for d in &objects.draws {
            pass.set_pipeline(if d.closed { closed } else { open });
            pass.set_bind_group(1, &d.bind_group, &[]);
            pass.draw_indexed(d.indices.clone(), 0, 0..1);
        }
    }
}

impl Pass<VemFrame> for ObjectShading {
    const NAME: &'static str = pass::SHADING;

    fn plan(&self, frame: &VemFrame) -> Plan {
        if frame.has_objects { Plan::Run } else { Plan::skip("the scene has no virtual objects") }
    }
}

/// The receivers' differential ratio over the clustered lights.
pub struct ReceiverRatio {
    /// Positions only (12-byte stride).
    pub pipeline: wgpu::RenderPipeline,
    /// The ratio from the visibility cuts (`fs_cut_receiver`), when set up for it.
    pub cut: Option<wgpu::RenderPipeline>,
}

impl ReceiverRatio {
    /// Draws the receivers (group 0 already set); `cuts`: their ratio from the visibility cuts.
    pub fn record(&self, pass: &mut wgpu::RenderPass<'_>, receivers: &ProxyBuffers, cuts: bool) {
        pass.set_pipeline(match (&self.cut, cuts) {
            (Some(c), true) => c,
            _ => &self.pipeline,
        });
        pass.set_vertex_buffer(0, receivers.vertices.slice(..));
        pass.set_index_buffer(receivers.indices.slice(..), wgpu::IndexFormat::Uint32);
        pass.draw_indexed(0..receivers.index_count, 0, 0..1);
    }
}

impl Pass<VemFrame> for ReceiverRatio {
    const NAME: &'static str = pass::RECEIVERS;

    /// Without shadow maps every ratio is 1: the cleared value (unless the visibility cuts give it).
    fn plan(&self, frame: &VemFrame) -> Plan {
        if frame.views.is_empty() && !frame.cuts { Plan::skip("no shadow maps this frame: the ratio is 1 everywhere") } else { Plan::Run }
    }
}

impl Pass<VemFrame> for DepthPrepass {
    const NAME: &'static str = pass::DEPTH_PREPASS;

    /// Every frame: the shading pass tests against it.
    fn plan(&self, _: &VemFrame) -> Plan {
        Plan::Run
    }
}

/// The shading pipelines and their frame layout.
pub struct ShadingPass {
    /// The objects.
    pub objects: ObjectShading,
    /// The receivers.
    pub receivers: ReceiverRatio,
    /// Group 0 of both.
    pub frame_layout: wgpu::BindGroupLayout,
}

/// Group 0: camera, frame uniform, lights and lists of `H` and `L`, shadow views, atlas, shadow
/// lights, comparison sampler, the cuts' light per vertex and ratio per pixel.
fn frame_layout(device: &wgpu::Device) -> wgpu::BindGroupLayout {
    device.create_bind_group_layout(&wgpu::BindGroupLayoutDescriptor {
        label: Some("vem shading frame"),
        entries: &[
            uniform_entry(0, wgpu::ShaderStages::VERTEX_FRAGMENT),
            storage_entry(1),
            storage_entry(2),
            storage_entry(3),
            storage_entry(4),
            storage_entry(5),
            storage_entry(6),
            wgpu::BindGroupLayoutEntry {
                binding: 7,
                visibility: wgpu::ShaderStages::FRAGMENT,
                ty: wgpu::BindingType::Texture { sample_type: wgpu::TextureSampleType::Depth, view_dimension: wgpu::TextureViewDimension::D2, multisampled: false },
                count: None,
            },
            storage_entry(8),
            wgpu::BindGroupLayoutEntry { binding: 9, visibility: wgpu::ShaderStages::FRAGMENT, ty: wgpu::BindingType::Sampler(wgpu::SamplerBindingType::Comparison), count: None },
            // Read by the cut objects' vertex stage.
            wgpu::BindGroupLayoutEntry { visibility: wgpu::ShaderStages::VERTEX_FRAGMENT, ..storage_entry(10) },
            storage_entry(11),
        ],
    })
}

impl ShadingPass {
    /// Builds the pipelines; `object_stride` is the byte stride of the objects' vertices
    /// (`VirtualVertex`); `cuts`: also those of the visibility cuts' light.
    pub fn new(device: &wgpu::Device, material_layout: &wgpu::BindGroupLayout, object_stride: u64, cuts: bool) -> Result<Self, RenderError> {
        let module = shaders::module(device, "vem/shading.wgsl")?;
        let frame_layout = frame_layout(device);
        let object_layout = device.create_pipeline_layout(&wgpu::PipelineLayoutDescriptor {
            label: Some("vem shading objects"),
            bind_group_layouts: &[Some(&frame_layout), Some(material_layout)],
            immediate_size: 0,
        });
        let receiver_layout = device.create_pipeline_layout(&wgpu::PipelineLayoutDescriptor { label: Some("vem shading receivers"), bind_group_layouts: &[Some(&frame_layout)], immediate_size: 0 });
        let pos_attr = [wgpu::VertexAttribute { format: wgpu::VertexFormat::Float32x3, offset: 0, shader_location: 0 }];
        let obj_attrs = wgpu::vertex_attr_array![0 => Float32x3, 1 => Float32x3, 2 => Float32x2];
        let depth = Some(wgpu::DepthStencilState {
            format: DEPTH_FORMAT,
            depth_write_enabled: Some(false),
            depth_compare: Some(wgpu::CompareFunction::GreaterEqual),
            stencil: Default::default(),
            bias: Default::default(),
        });
        let targets = [
            Some(wgpu::ColorTargetState { format: LAYER_FORMAT, blend: None, write_mask: wgpu::ColorWrites::ALL }),
            Some(wgpu::ColorTargetState { format: RATIO_FORMAT, blend: None, write_mask: wgpu::ColorWrites::ALL }),
        ];
        let make = |label: &str, layout: &wgpu::PipelineLayout, vs: &str, fs: &str, vb: wgpu::VertexBufferLayout<'_>, cull_mode: Option<wgpu::Face>| {
            device.create_render_pipeline(&wgpu::RenderPipelineDescriptor {
                label: Some(label),
                layout: Some(layout),
                vertex: wgpu::VertexState { module: &module, entry_point: Some(vs), compilation_options: Default::default(), buffers: &[Some(vb)] },
                primitive: wgpu::PrimitiveState { cull_mode, ..Default::default() },
                depth_stencil: depth.clone(),
                multisample: wgpu::MultisampleState::default(),
                fragment: Some(wgpu::FragmentState { module: &module, entry_point: Some(fs), compilation_options: Default::default(), targets: &targets }),
                multiview_mask: None,
                cache: None,
            })
        };
        let obj_vb = || wgpu::VertexBufferLayout { array_stride: object_stride, step_mode: wgpu::VertexStepMode::Vertex, attributes: &obj_attrs };
        let rec_vb = wgpu::VertexBufferLayout { array_stride: 12, step_mode: wgpu::VertexStepMode::Vertex, attributes: &pos_attr };
        Ok(Self {
            objects: ObjectShading {
                closed: make("vem shading closed", &object_layout, "vs_object", "fs_object", obj_vb(), Some(wgpu::Face::Back)),
                open: make("vem shading open", &object_layout, "vs_object", "fs_object", obj_vb(), None),
                cut: cuts.then(|| {
                    [
                        make("vem cut shading closed", &object_layout, "vs_cut_object", "fs_cut_object", obj_vb(), Some(wgpu::Face::Back)),
                        make("vem cut shading open", &object_layout, "vs_cut_object", "fs_cut_object", obj_vb(), None),
                    ]
                }),
            },
            receivers: ReceiverRatio {
                pipeline: make("vem shading receivers", &receiver_layout, "vs_receiver", "fs_receiver", rec_vb.clone(), None),
                cut: cuts.then(|| make("vem cut receivers", &receiver_layout, "vs_receiver", "fs_cut_receiver", rec_vb.clone(), None)),
            },
            frame_layout,
        })
    }
}
