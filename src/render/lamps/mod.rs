//! The lamps on the GPU (issue 16 §2): the virtual objects lit by the scene's `[[lights]]`, with
//! shadows, in the outdoor compositor. Granier, Goesele, Heidrich and Seidel, *Interactive
//! Visualization of Complex Real-World Light Sources*, Pacific Graphics 2003
//! (`../shared/papers/granier-2003-complex-light-sources.txt`), §3.2 and §4.
//!
//! # How it works
//! - **Spots** ([`spots`]): every far-field lamp is one spot at its position; every filter
//!   position of a light field is one textured spot light at its filter centre (Eq. 14). The
//!   term of spot `j` at a visible point is `k_i · E_j · V_j · f(v, l_j)`: the lamp's scale `k_i`
//!   from the frame's [`LampScales`] (the estimator's, issue 16 §3), the irradiance of the
//!   lamp's model (`crate::lamps::model` on the CPU, the reference of the tests), the spot's
//!   shadow-map visibility and the glTF BRDF.
//! - **One pass for all spots** (Granier §4.1 combined 3 spots per pass on 2003 hardware): the
//!   fragment shader (`shaders/lamps.wgsl`) loops over the frame's lit spots in one draw of the
//!   objects, inside the virtual shading's render pass, and adds its sum onto the shading's float
//!   layer with blending (One + One, alpha kept): today's GPUs blend float targets, so the
//!   paper's read-back of each intermediate frame (§4.2) is not needed.
//! - **Shadows**: one perspective map per lit spot (per filter position for light fields, as in
//!   the paper) in the VEM mode's shadow-map atlas (`render::vem::shadow_atlas`, which
//!   [`fit_spot_view`] extends to perspective views), fitted to the objects' bounds; the objects
//!   and the real proxy are drawn into it, so the objects shadow themselves and each other and
//!   real geometry shadows them. A light field with more positions than free maps shares one map
//!   from its centre. A second atlas of the same views holds the proxy alone, for the objects'
//!   lamp shadows on the real receivers in the composite ([`ground`], `lamp_ground`).
//! - **Penumbrae**: a lamp with a luminous opening (the IES/LDT file's, `Lamp::emitter_radius_m`)
//!   and a map of its own reads it with PCSS (Fernando, *Percentage-closer soft shadows*, 2005;
//!   `spot_soft_visibility` in `shaders/common/lamp_spots.wgsl`, [`ShadowView::with_emitter`]):
//!   the mean depth `d_b` of the blockers found around the receiver's texel sets a box filter of
//!   half-width `R·(d_r − d_b)/(d_r·d_b)` in angle, the part of a disc of radius `R` a blocker at
//!   `d_b` can hide from a receiver at `d_r`. Points, spots and light fields (whose filter
//!   positions each cast their own shadow, Granier §4) keep one texel. Against the disc's
//!   visibility by shadow rays: `render::lamp_penumbra`. [`LampOptions::soft_shadows`] off (and
//!   `heliar bench render --hard-lamp-shadows`) gives the hard shadows of the lamps' centres.
//! - **Left out, with the reason in the pass report**: the whole lamp stage when the objects are
//!   not drawn; lamps that are off (`k = 0`: the schedule, or no scale in the lighting); lamps
//!   whose light cannot reach the objects' bounds ([`SpotSet::misses`]); the shadow maps when
//!   their views are those already drawn and nothing moved since (`lamp_shadows`). A scene
//!   without `[[lights]]` has no lamp stage at all: nothing is recorded or reported, and its
//!   output is bit for bit what it was before lamps existed.

pub mod ground;
pub mod ground_bounce;
pub mod spots;

pub use spots::{GpuSpot, SpotSet};

use crate::gpu::canvas::uniform_entry;
use crate::gpu::mesh::{ProxyBuffers, VirtualBuffers, VirtualVertex};
use crate::gpu::texture::Tex;
use crate::gpu::{Gpu, GpuError, LAYER_FORMAT, shaders};
use crate::lamps::Lamp;
use crate::lighting::LampScales;
use crate::render::RenderError;
use crate::render::frame::{PassReport, pass};
use crate::render::plan::{Pass, Plan};
use crate::render::stencil::{VIRTUAL_SURFACE, test};
use crate::render::vem::shadow_atlas::{ATLAS_FORMAT, AtlasGeometry, DEFAULT_TILE, ShadowAtlasPass, ShadowView, fit_spot_view, tiles_per_side};
use bytemuck::Zeroable;
use glam::Vec3;
use spots::NO_SLOT;
use wgpu::util::DeviceExt;

/// Settings of the lamp term.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct LampOptions {
    /// Gauss points per `h/2` cell of a light field's support mean (0: one lookup along the
    /// central ray; the CPU model uses 2).
    pub support_points: usize,
    /// Shadows on.
    pub shadows: bool,
    /// Most shadow maps.
    pub shadow_maps: usize,
    /// Size of each map, texels.
    pub tile: u32,
    /// Darken the real receivers by the objects' lamp shadows ([`ground`], with the
    /// differential darkening).
    pub ground: bool,
    /// Add the lamps' light bounced off the proxy and the objects to the objects' per-pixel
    /// ambient (`render::object_transfer::lamps`; the compositor's `lamp_bounce`).
    pub bounce: bool,
    /// Add the lamps' light bounced off the proxy and the objects to the real receivers'
    /// irradiance in the ground shadows' ratio ([`ground_bounce`], with [`Self::ground`]).
    pub ground_bounce: bool,
    /// The penumbra of a lamp's emitting area in its shadows (`ShadowView::with_emitter`, the
    /// luminous opening of an IES or LDT file); off: hard shadows from its centre.
    pub soft_shadows: bool,
}

impl Default for LampOptions {
    /// One point per cell (16 lookups per spot), up to 81 maps (a 9×9 light field) of 256²,
    /// shadows on real receivers, the lamps' bounce (on the objects and on the receivers) and the
    /// penumbrae of their areas on.
    fn default() -> Self {
        Self { support_points: 1, shadows: true, shadow_maps: 81, tile: DEFAULT_TILE, ground: true, bounce: true, ground_bounce: true, soft_shadows: true }
    }
}

/// Mirrors `LampHeader` in `shaders/lamps.wgsl`.
#[repr(C)]
#[derive(Clone, Copy, Debug, PartialEq, bytemuck::Pod, bytemuck::Zeroable)]
struct GpuHeader {
    counts: [u32; 4],
    taps: [u32; 4],
}

/// One frame's lamps: the lit spots with their slots, the maps' views, what was left out.
#[derive(Clone, Debug, Default)]
struct LampFrame {
    spots: Vec<GpuSpot>,
    views: Vec<ShadowView>,
    left_out: Vec<String>,
    /// Why the whole term is left out.
    skip: Option<String>,
}

/// The lamp term and its shadow maps, with what they keep between frames.
pub struct LampPass {
    set: SpotSet,
    options: LampOptions,
    taps: u32,
    closed: wgpu::RenderPipeline,
    open: wgpu::RenderPipeline,
    atlas_pass: ShadowAtlasPass,
    header: wgpu::Buffer,
    spots: wgpu::Buffer,
    views: wgpu::Buffer,
    atlas: Tex,
    /// The same maps with the proxy alone ([`ground`]).
    proxy_atlas: Tex,
    tiles: u32,
    camera_bg: wgpu::BindGroup,
    /// Group [`ground::GROUP`]: the spots and maps, for the lamp term and the composite.
    data_bg: wgpu::BindGroup,
    /// The composite darkens the real receivers by the objects' lamp shadows this frame.
    ground: bool,
    /// The views the atlas holds (`None`: stale).
    drawn: Option<Vec<ShadowView>>,
    frame: LampFrame,
}

fn storage(device: &wgpu::Device, label: &str, bytes: &[u8]) -> wgpu::Buffer {
    device.create_buffer_init(&wgpu::util::BufferInitDescriptor { label: Some(label), contents: bytes, usage: wgpu::BufferUsages::STORAGE | wgpu::BufferUsages::COPY_DST })
}

/// Group 0 of the lamp term: the compositor's camera.
fn camera_layout(device: &wgpu::Device) -> wgpu::BindGroupLayout {
    device.create_bind_group_layout(&wgpu::BindGroupLayoutDescriptor { label: Some("lamps camera"), entries: &[uniform_entry(0, wgpu::ShaderStages::VERTEX_FRAGMENT)] })
}

/// The additive pipelines (closed meshes culled, open ones two-sided), with the virtual
/// shading's depth and stencil tests so each visible sample is lit once.
fn pipelines(gpu: &Gpu, layout: &wgpu::BindGroupLayout, material_layout: &wgpu::BindGroupLayout, data_layout: &wgpu::BindGroupLayout) -> Result<(wgpu::RenderPipeline, wgpu::RenderPipeline), RenderError> {
    let device = &gpu.device;
    let module = shaders::module(device, "lamps.wgsl")?;
    let pl = device.create_pipeline_layout(&wgpu::PipelineLayoutDescriptor { label: Some("lamps"), bind_group_layouts: &[Some(layout), Some(material_layout), Some(data_layout)], immediate_size: 0 });
    let attrs = wgpu::vertex_attr_array![0 => Float32x3, 1 => Float32x3, 2 => Float32x2];
    let add = wgpu::BlendComponent { src_factor: wgpu::BlendFactor::One, dst_factor: wgpu::BlendFactor::One, operation: wgpu::BlendOperation::Add };
    let keep = wgpu::BlendComponent { src_factor: wgpu::BlendFactor::Zero, dst_factor: wgpu::BlendFactor::One, operation: wgpu::BlendOperation::Add };
    let compare = wgpu::CompareFunction::Equal;
    let make = |label: &str, cull_mode: Option<wgpu::Face>| {
        device.create_render_pipeline(&wgpu::RenderPipelineDescriptor {
            label: Some(label),
            layout: Some(&pl),
            vertex: wgpu::VertexState {
                module: &module,
                entry_point: Some("vs_object"),
                compilation_options: Default::default(),
                buffers: &[Some(wgpu::VertexBufferLayout { array_stride: std::mem::size_of::<VirtualVertex>() as u64, step_mode: wgpu::VertexStepMode::Vertex, attributes: &attrs })],
            },
            primitive: wgpu::PrimitiveState { cull_mode, ..Default::default() },
            depth_stencil: Some(wgpu::DepthStencilState {
                format: gpu.depth_format,
                depth_write_enabled: Some(false),
                depth_compare: Some(wgpu::CompareFunction::GreaterEqual),
                stencil: wgpu::StencilState { front: test(compare), back: test(compare), read_mask: VIRTUAL_SURFACE, write_mask: 0 },
                bias: Default::default(),
            }),
            multisample: wgpu::MultisampleState { count: gpu.samples, ..Default::default() },
            fragment: Some(wgpu::FragmentState {
                module: &module,
                entry_point: Some("fs_lamps"),
                compilation_options: Default::default(),
                targets: &[Some(wgpu::ColorTargetState { format: LAYER_FORMAT, blend: Some(wgpu::BlendState { color: add, alpha: keep }), write_mask: wgpu::ColorWrites::ALL })],
            }),
            multiview_mask: None,
            cache: None,
        })
    };
    Ok((make("lamps closed", Some(wgpu::Face::Back)), make("lamps open", None)))
}

impl LampPass {
    /// Sets the lamp term up for `lamps` (scene order): their spots and images uploaded, the
    /// pipelines, an atlas for the maps (and one for the proxy alone, [`ground`]).
    /// `camera`: the compositor's camera uniform; `data_layout`: [`ground::data_layout`].
    pub fn new(gpu: &Gpu, lamps: &[Lamp], options: LampOptions, camera: &wgpu::Buffer, material_layout: &wgpu::BindGroupLayout, data_layout: &wgpu::BindGroupLayout) -> Result<Self, RenderError> {
        let device = &gpu.device;
        let set = SpotSet::new(lamps);
        let texel_bytes = (set.texels.len() * std::mem::size_of::<[u32; 2]>()) as u64;
        let limit = device.limits().max_storage_buffer_binding_size as u64;
        if texel_bytes > limit {
            return Err(GpuError::Device(format!("the lamps' images take {texel_bytes} bytes, more than the adapter's largest storage buffer ({limit} bytes); use smaller light-field images")).into());
        }
        let taps = spots::support_taps(options.support_points);
        let maps = options.shadow_maps.min(set.spots.len()).max(1);
        let tiles = tiles_per_side(maps);
        let spot_count = set.spots.len().max(1);
        let header = storage(device, "lamp header", bytemuck::bytes_of(&GpuHeader { counts: [0; 4], taps: [0; 4] }));
        let spots_buf = storage(device, "lamp spots", bytemuck::cast_slice(&vec![GpuSpot::zeroed(); spot_count]));
        let texels = storage(device, "lamp texels", bytemuck::cast_slice(if set.texels.is_empty() { &[[0u32; 2]][..] } else { &set.texels[..] }));
        let taps_buf = storage(device, "lamp taps", bytemuck::cast_slice(if taps.is_empty() { &[[0.0f32; 4]][..] } else { &taps[..] }));
        let views = storage(device, "lamp shadow views", bytemuck::cast_slice(&vec![ShadowView::zeroed(); maps]));
        // The atlas must fit the adapter's largest texture.
        let tile = options.tile.clamp(1, (device.limits().max_texture_dimension_2d / tiles).max(1));
        let side = tiles * tile;
        let atlas = Tex::new(device, "lamp shadow atlas", (side, side), ATLAS_FORMAT, 1, wgpu::TextureUsages::RENDER_ATTACHMENT | wgpu::TextureUsages::TEXTURE_BINDING);
        let proxy_atlas = Tex::new(device, "lamp shadow atlas, proxy alone", (side, side), ATLAS_FORMAT, 1, wgpu::TextureUsages::RENDER_ATTACHMENT | wgpu::TextureUsages::TEXTURE_BINDING);
        let sampler = ground::atlas_sampler(device);
        let camera_layout = camera_layout(device);
        let camera_bg = device.create_bind_group(&wgpu::BindGroupDescriptor { label: Some("lamps camera"), layout: &camera_layout, entries: &[wgpu::BindGroupEntry { binding: 0, resource: camera.as_entire_binding() }] });
        let buffers = [&header, &spots_buf, &texels, &taps_buf, &views];
        let data_bg = ground::data_bind_group(device, data_layout, &ground::DataBindings { buffers, atlas: &atlas.view, proxy_atlas: &proxy_atlas.view, sampler: &sampler });
        let (closed, open) = pipelines(gpu, &camera_layout, material_layout, data_layout)?;
        let atlas_pass = ShadowAtlasPass::with_strides(device, &[std::mem::size_of::<VirtualVertex>() as u64, std::mem::size_of::<[f32; 3]>() as u64])?;
        Ok(Self {
            set,
            options: LampOptions { shadow_maps: maps, tile, ..options },
            taps: taps.len() as u32,
            closed,
            open,
            atlas_pass,
            header,
            spots: spots_buf,
            views,
            atlas,
            proxy_atlas,
            tiles,
            camera_bg,
            data_bg,
            ground: false,
            drawn: None,
            frame: LampFrame::default(),
        })
    }

    /// The spots of the scene's lamps.
    pub fn spots(&self) -> &SpotSet {
        &self.set
    }

    /// Forgets the drawn maps (something moved).
    pub fn invalidate(&mut self) {
        self.drawn = None;
    }

    /// Plans the frame (module docs): `no_objects` why the objects are not drawn, `scales` the
    /// lamps' `k`, `bounds` the objects' box.
    pub fn plan_frame(&mut self, no_objects: Option<&str>, scales: &LampScales, bounds: Option<(Vec3, Vec3)>) {
        let mut f = LampFrame::default();
        let (lo, hi) = match (no_objects, bounds) {
            (Some(why), _) => {
                f.skip = Some(why.to_owned());
                self.frame = f;
                return;
            }
            (None, None) => {
                f.skip = Some("the virtual objects have no triangles".into());
                self.frame = f;
                return;
            }
            (None, Some(b)) => b,
        };
        for (i, lamp) in self.set.lamps.iter().enumerate() {
            let k = scales.get(i);
            if !k.iter().any(|&c| c > 0.0) {
                f.left_out.push(format!("{}: off (k = 0 in the frame's lighting)", lamp.name));
                continue;
            }
            if let Some(why) = self.set.misses(i, lo, hi) {
                f.left_out.push(format!("{}: {why}", lamp.name));
                continue;
            }
            let free = self.options.shadow_maps.saturating_sub(f.views.len());
            let shared = (self.options.shadows && lamp.range.len() > free && free > 0).then(|| {
                f.views.push(fit_spot_view(lamp.position, lo, hi, self.options.tile));
                (f.views.len() - 1) as u32
            });
            for spot in &self.set.spots[lamp.range.clone()] {
                let mut s = *spot;
                s.scale = [spot.scale[0] * k[0], spot.scale[1] * k[1], spot.scale[2] * k[2], 0.0];
                s.index[1] = match shared {
                    Some(slot) => slot,
                    None if self.options.shadows && f.views.len() < self.options.shadow_maps => {
                        let view = fit_spot_view(Vec3::new(s.world[0], s.world[1], s.world[2]), lo, hi, self.options.tile);
                        f.views.push(if self.options.soft_shadows { view.with_emitter(lamp.emitter_radius_m) } else { view });
                        (f.views.len() - 1) as u32
                    }
                    None => NO_SLOT,
                };
                f.spots.push(s);
            }
        }
        if f.spots.is_empty() {
            f.skip = Some(format!("no lamp lights the objects: {}", f.left_out.join("; ")));
        }
        self.frame = f;
    }

    /// The shadow maps as a unit of the frame.
    pub fn shadows_unit(&self) -> LampShadows<'_> {
        LampShadows(self)
    }

    /// The lamp term as a unit of the frame.
    pub fn term_unit(&self) -> LampTerm<'_> {
        LampTerm(self)
    }

    /// Draws the frame's maps: the objects and the proxy into each.
    pub fn record_shadows(&mut self, gpu: &Gpu, encoder: &mut wgpu::CommandEncoder, objects: &VirtualBuffers, proxy: &ProxyBuffers) {
        let views = &self.frame.views;
        gpu.queue.write_buffer(&self.views, 0, bytemuck::cast_slice(views));
        let proxy_geometry = AtlasGeometry { pipeline: 1, vertices: &proxy.vertices, indices: &proxy.indices, ranges: vec![0..proxy.index_count] };
        let geometry = [AtlasGeometry::objects(objects), proxy_geometry];
        self.atlas_pass.record_geometry(&gpu.device, encoder, &self.atlas.view, &self.views, &geometry, views.len() as u32, self.tiles, self.options.tile);
        let [_, proxy_geometry] = geometry;
        self.atlas_pass.record_geometry(&gpu.device, encoder, &self.proxy_atlas.view, &self.views, &[proxy_geometry], views.len() as u32, self.tiles, self.options.tile);
        self.drawn = Some(views.clone());
    }

    /// The ground unit of the frame (`lamp_ground`, [`ground::LampGround`]); `differential`:
    /// the composite darkens by the differential model.
    pub fn ground_unit(&self, differential: bool) -> ground::LampGround<'_> {
        ground::LampGround { term: self.frame.skip.as_deref(), differential, enabled: self.options.ground && self.options.shadows }
    }

    /// Whether the composite darkens the real receivers by the objects' lamp shadows (read by
    /// the next [`LampPass::upload`]).
    pub fn set_ground(&mut self, on: bool) {
        self.ground = on;
    }

    /// The spots and maps as bind group [`ground::GROUP`].
    pub fn data_bind_group(&self) -> &wgpu::BindGroup {
        &self.data_bg
    }

    /// Zero spots for the frame (the lamp term does not run): the composite's lamp loop stays
    /// idle.
    pub fn clear(&self, queue: &wgpu::Queue) {
        queue.write_buffer(&self.header, 0, bytemuck::bytes_of(&GpuHeader { counts: [0; 4], taps: [0; 4] }));
    }

    /// Uploads the frame's spots and writes the lamps it left out into `report`.
    pub fn upload(&self, queue: &wgpu::Queue, report: &mut PassReport) {
        let f = &self.frame;
        let maps = if self.drawn.is_some() { f.views.len() as u32 } else { 0 };
        let header = GpuHeader { counts: [f.spots.len() as u32, self.tiles, self.options.tile, maps], taps: [self.taps, u32::from(self.ground), 0, 0] };
        queue.write_buffer(&self.header, 0, bytemuck::bytes_of(&header));
        queue.write_buffer(&self.spots, 0, bytemuck::cast_slice(&f.spots));
        for why in &f.left_out {
            report.skip(pass::LAMP, why.clone());
        }
    }

    /// Draws the lamp term of the objects into the virtual shading's render pass (after it).
    pub fn record(&self, pass: &mut wgpu::RenderPass<'_>, objects: &VirtualBuffers) {
        pass.set_bind_group(0, &self.camera_bg, &[]);
        pass.set_bind_group(ground::GROUP, &self.data_bg, &[]);
        pass.set_vertex_buffer(0, objects.vertices.slice(..));
        pass.set_index_buffer(objects.indices.slice(..), wgpu::IndexFormat::Uint32);
        pass.set_stencil_reference(VIRTUAL_SURFACE);
        for d in &objects.draws {
            pass.set_pipeline(if d.closed { &self.closed } else { &self.open });
            pass.set_bind_group(1, &d.bind_group, &[]);
            pass.draw_indexed(d.indices.clone(), 0, 0..1);
        }
    }
}

/// The lamps' shadow maps (`lamp_shadows`).
pub struct LampShadows<'a>(&'a LampPass);

impl<F> Pass<F> for LampShadows<'_> {
    const NAME: &'static str = pass::LAMP_SHADOWS;

    fn plan(&self, _: &F) -> Plan {
        let p = self.0;
        if let Some(why) = &p.frame.skip {
            return Plan::skip(why.clone());
        }
        if !p.options.shadows {
            return Plan::skip("lamp shadows are switched off");
        }
        if p.drawn.as_ref() == Some(&p.frame.views) {
            return Plan::skip("nothing moved since the lamp shadow maps were drawn: they are kept");
        }
        Plan::Run
    }
}

/// The lamp term of the virtual objects (`lamp_term`).
pub struct LampTerm<'a>(&'a LampPass);

impl<F> Pass<F> for LampTerm<'_> {
    const NAME: &'static str = pass::LAMP_TERM;

    fn plan(&self, _: &F) -> Plan {
        match &self.0.frame.skip {
            Some(why) => Plan::skip(why.clone()),
            None => Plan::Run,
        }
    }
}
