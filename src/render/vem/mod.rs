//! The GPU half of the captured-VEM mode: the scene's virtual objects lit and shadowed by a
//! frame's directional lights and composited over a background (Havran 2005 §4–5,
//! `../shared/papers/havran-2005-video-environment-maps.txt`).
//!
//! # How it works
//! Per frame, [`VemRenderer::render`] takes the decomposer's lights, region lists (and glossy
//! set), and a background in the camera's pixel grid (the footage frame, or the VEM seen through
//! the camera: [`environment_background`]). It stands beside the outdoor compositor on the GPU
//! layer ([`crate::gpu`]: device, mesh upload, canvas and lens warp) and shares its depth
//! prepass ([`crate::render::depth_prepass`]). The passes, each a `src/render/vem/<pass>.rs`
//! beside `shaders/vem/<pass>.wgsl`:
//!
//! | pass | what it does |
//! |---|---|
//! | [`shadow_atlas`] | up to 72 orthographic maps of 256² of the objects, one per clustered light (Havran §4.3) |
//! | depth prepass | receivers (proxy or ground plane) and objects into depth (`shaders/depth_prepass.wgsl`) |
//! | [`shading`] | objects: region-culled light loop (Havran §4.1), glossy L/H split (§4.2), shadow-map visibility; receivers: the differential ratio over the clustered lights |
//! | [`overlay`] | the composite, in the footage grid: objects + (1 − α)·background·ratio |
//! | [`tonemap`] | global Reinhard with temporally smoothed parameters (Havran §5.1), sRGB 8-bit |
//!
//! The HDR composite is read back (for the tone-mapping parameters and for files), then the
//! tone-mapped frame. The shadow pass is skipped, with the reason in the report, when shadows
//! are off, there are no objects, or the lights carry no power (status `dark`).
//!
//! # Passes as units
//! As in the outdoor compositor ([`crate::render::plan`]), each pass plans from the frame's
//! plain values ([`frame::VemFrame`], prepared on the CPU) and records its own commands;
//! [`VemRenderer::render`] is the list: prepare, upload, then shadow atlas, depth prepass,
//! receivers and objects (one render pass), composite, readback, tone mapping. The report's
//! order is the list's.
//!
//! Not modelled: shadows of the real proxy on the virtual objects (the atlas holds the objects
//! only), MSAA (one sample per pixel), and the paper's cap on the number of glossy cone lights.
//!
//! # Moving objects and the visibility cuts (issue 15)
//! [`VemRenderer::move_objects`] re-uploads the objects' vertex buffer and bounds when they move
//! (`crate::run::vem_motion`); the atlas is drawn every frame anyway. With
//! [`ObjectLight::Cuts`] (cyberworlds §V, `../shared/papers/cyberworlds-captured-lighting-cuts.txt`)
//! the objects and receivers are drawn by the cut entry points of `shaders/vem/shading.wgsl`
//! instead: each vertex's irradiance about the normal and the mirror direction from the cuts
//! under the VEM frame (set per frame with [`VemRenderer::set_cut_light`], computed by
//! `crate::run::vem_cuts`) through the glTF split sum, and the receivers' ratio per canvas pixel
//! from the objects' visibility cut fields; the shadow atlas is skipped with that reason.

pub mod background;
pub mod frame;
pub mod lists;
pub mod overlay;
pub mod report;
pub mod shading;
pub mod shadow_atlas;
pub mod targets;
pub mod tonemap;

pub use background::{environment_background, ground_plane, ground_radiance};
pub use frame::VemLights;
pub use report::{VemOutput, VemReport, VemTimings};

use crate::camera::Camera;
use crate::geometry::Mesh;
use crate::gpu::canvas::{Canvas, camera_layout};
use crate::gpu::mesh::{ProxyBuffers, VirtualBuffers, VirtualVertex, material_layout};
use crate::gpu::readback::read_texture;
use crate::gpu::{Gpu, f32_from_f16};
use crate::io::image::LinearImage;
use crate::render::RenderError;
use crate::render::depth_prepass::DepthPrepass;
use crate::vem::reinhard::ToneParams;
use frame::VemFrame;
use glam::Vec3;
use shading::ShadingPass;
use shadow_atlas::ShadowAtlasPass;
use std::sync::Arc;
use std::time::Instant;
use targets::Targets;
use wgpu::util::DeviceExt;

/// Pass names used in reports.
pub mod pass {
    /// The shadow-map atlas.
    pub const SHADOW_ATLAS: &str = "shadow_atlas";
    /// Receivers and objects into depth.
    pub const DEPTH_PREPASS: &str = "depth_prepass";
    /// The objects shaded.
    pub const SHADING: &str = "shading";
    /// The receivers' differential ratio.
    pub const RECEIVERS: &str = "receivers";
    /// The composite over the background.
    pub const COMPOSITE: &str = "composite";
    /// Tone mapping to sRGB.
    pub const TONEMAP: &str = "tonemap";
}

/// Default albedo of the ground plane used when the scene has no proxy.
pub const GROUND_ALBEDO: f32 = 0.3;

/// Where the objects' light comes from.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub enum ObjectLight {
    /// The frame's directional lights with the shadow-map atlas (Havran §4).
    #[default]
    Lights,
    /// The visibility cuts under the VEM frame (`crate::run::vem_cuts`, cyberworlds §V): per
    /// vertex light and the receivers' ratio, set with [`VemRenderer::set_cut_light`].
    Cuts,
}

/// Settings of the VEM renderer.
#[derive(Clone, Debug, PartialEq)]
pub struct VemRenderConfig {
    /// Shadow maps in the atlas (at most this many clustered lights cast shadows).
    pub shadow_slots: usize,
    /// Tile size of a shadow map, texels.
    pub tile: u32,
    /// Walk only the region's list (else every light: the baseline).
    pub culling: bool,
    /// Shadow maps on.
    pub shadows: bool,
    /// Albedo of the ground plane (scenes without a proxy).
    pub ground_albedo: f32,
    /// Where the objects' light comes from.
    pub object_light: ObjectLight,
}

impl Default for VemRenderConfig {
    fn default() -> Self {
        Self { shadow_slots: shadow_atlas::DEFAULT_SLOTS, tile: shadow_atlas::DEFAULT_TILE, culling: true, shadows: true, ground_albedo: GROUND_ALBEDO, object_light: ObjectLight::Lights }
    }
}

/// The GPU renderer of the VEM mode (see the module docs).
pub struct VemRenderer {
    gpu: Arc<Gpu>,
    cfg: VemRenderConfig,
    canvas: Canvas,
    camera_buffer: wgpu::Buffer,
    camera_bg: wgpu::BindGroup,
    receivers: ProxyBuffers,
    receivers_kind: &'static str,
    objects: VirtualBuffers,
    /// The material bind-group layout (the objects' buffers are rebuilt when they move).
    mat_layout: wgpu::BindGroupLayout,
    /// Per object, which triangles belong to closed parts (back faces culled); a rigid move
    /// keeps it.
    closed: Vec<Vec<bool>>,
    /// Per object, the mesh vertex of each vertex-buffer vertex (`crate::gpu::mesh::vertex_sources`).
    vertex_sources: Vec<Vec<u32>>,
    /// The cuts' light per vertex-buffer vertex and the receivers' ratio per canvas pixel
    /// (bindings 10 and 11 of the shading pass; one zero entry each until set).
    cut_light: (wgpu::Buffer, wgpu::Buffer),
    /// The receivers' mesh as drawn (the proxy, or the ground plane).
    receiver_mesh: Mesh,
    bounds: Option<(Vec3, Vec3)>,
    prepass: DepthPrepass,
    shading: ShadingPass,
    atlas_pass: ShadowAtlasPass,
    composite: overlay::CompositePass,
    tonemap: tonemap::TonemapPass,
    targets: Targets,
}

/// A read-only storage buffer holding `data`.
fn storage_buffer<T: bytemuck::Pod>(device: &wgpu::Device, label: &str, data: &[T]) -> wgpu::Buffer {
    device.create_buffer_init(&wgpu::util::BufferInitDescriptor { label: Some(label), contents: bytemuck::cast_slice(data), usage: wgpu::BufferUsages::STORAGE })
}

/// Union of the bounds of `meshes`.
fn bounds_of(meshes: &[&Mesh]) -> Option<(Vec3, Vec3)> {
    meshes.iter().filter_map(|m| m.bounds()).reduce(|a, b| (a.0.min(b.0), a.1.max(b.1)))
}

/// Milliseconds since `t`.
fn ms_since(t: Instant) -> f64 {
    t.elapsed().as_secs_f64() * 1e3
}

impl VemRenderer {
    /// Sets up the renderer for `camera`, the real `proxy` (the shadow catcher; `None`: a ground
    /// plane under the objects) and the virtual `objects`.
    pub fn new(gpu: Arc<Gpu>, camera: &Camera, proxy: Option<&Mesh>, objects: &[&Mesh], cfg: VemRenderConfig) -> Result<Self, RenderError> {
        let device = &gpu.device;
        let canvas = Canvas::new(camera, 1.0);
        let camera_buffer = device.create_buffer_init(&wgpu::util::BufferInitDescriptor {
            label: Some("vem camera"),
            contents: bytemuck::bytes_of(&canvas.uniform()),
            usage: wgpu::BufferUsages::UNIFORM,
        });
        let cam_layout = camera_layout(device);
        let camera_bg = device.create_bind_group(&wgpu::BindGroupDescriptor {
            label: Some("vem camera"),
            layout: &cam_layout,
            entries: &[wgpu::BindGroupEntry { binding: 0, resource: camera_buffer.as_entire_binding() }],
        });
        let mat_layout = material_layout(device);
        let closed: Vec<Vec<bool>> = objects.iter().map(|m| crate::render::occluder::Occluder::new(m, "virtual object").closed_triangles(m.triangles.len())).collect();
        let objects_buf = VirtualBuffers::new(device, &gpu.queue, &mat_layout, objects, &closed)?;
        let bounds = bounds_of(objects);
        let (receiver_mesh, receivers_kind) = match proxy {
            Some(p) if !p.triangles.is_empty() => (p.clone(), "proxy"),
            _ => {
                let (c, y) = bounds.map_or((Vec3::ZERO, 0.0), |(lo, hi)| (0.5 * (lo + hi), lo.y));
                (ground_plane(c, y, cfg.ground_albedo), "ground plane")
            }
        };
        let receivers = ProxyBuffers::new(device, &receiver_mesh);
        let cut_light = (storage_buffer(device, "vem cut light", &[[0.0f32; 4]]), storage_buffer(device, "vem cut ratio", &[1.0f32]));
        let stride = std::mem::size_of::<VirtualVertex>() as u64;
        Ok(Self {
            prepass: DepthPrepass::new(device, &cam_layout, shading::DEPTH_FORMAT, 1, stride)?,
            shading: ShadingPass::new(device, &mat_layout, stride, cfg.object_light == ObjectLight::Cuts)?,
            atlas_pass: ShadowAtlasPass::new(device, stride)?,
            composite: overlay::CompositePass::new(device, gpu.output_format)?,
            tonemap: tonemap::TonemapPass::new(device)?,
            targets: Targets::new(&gpu, &canvas, &cfg)?,
            gpu,
            cfg,
            canvas,
            camera_buffer,
            camera_bg,
            receivers,
            receivers_kind,
            objects: objects_buf,
            mat_layout,
            closed,
            vertex_sources: objects.iter().map(|m| crate::gpu::mesh::vertex_sources(m)).collect(),
            cut_light,
            receiver_mesh,
            bounds,
        })
    }

    /// The receivers as drawn: the proxy, or the ground plane under the objects without one.
    pub fn receiver_mesh(&self) -> &Mesh {
        &self.receiver_mesh
    }

    /// Sets the visibility cuts' light for the next frames (with [`ObjectLight::Cuts`]):
    /// `vertices[k][v]`, the irradiance about the normal (`w = 1`) and about the reflected view
    /// direction of vertex `v` of object `k`'s mesh; `ratio`, the receivers' ratio per canvas
    /// pixel (row-major).
    pub fn set_cut_light(&mut self, vertices: &[Vec<[[f32; 4]; 2]>], ratio: &[f32]) {
        let mut data: Vec<[f32; 4]> = Vec::with_capacity(2 * self.vertex_sources.iter().map(Vec::len).sum::<usize>() + 1);
        for (k, sources) in self.vertex_sources.iter().enumerate() {
            let obj = vertices.get(k);
            data.extend(sources.iter().flat_map(|&v| obj.and_then(|a| a.get(v as usize)).copied().unwrap_or([[0.0; 4]; 2])));
        }
        if data.is_empty() {
            data.push([0.0; 4]);
        }
        let ratio: &[f32] = if ratio.is_empty() { &[1.0] } else { ratio };
        let device = &self.gpu.device;
        self.cut_light = (storage_buffer(device, "vem cut light", &data), storage_buffer(device, "vem cut ratio", ratio));
    }

    /// Moves the virtual objects to `objects` (every object, in set-up order, world
    /// coordinates): their vertex buffer and bounds (the shadow maps' casters) follow; the
    /// shadow atlas is drawn every frame anyway. The receivers stay: the proxy is static, and
    /// the ground plane of a scene without one stays where the objects' first bounds put it.
    /// An object whose triangle count changed gets its closed parts found again.
    pub fn move_objects(&mut self, objects: &[&Mesh]) -> Result<(), RenderError> {
        for (k, m) in objects.iter().enumerate() {
            if self.closed.get(k).is_none_or(|c| c.len() != m.triangles.len()) {
                let c = crate::render::occluder::Occluder::new(m, "virtual object").closed_triangles(m.triangles.len());
                match self.closed.get_mut(k) {
                    Some(slot) => *slot = c,
                    None => self.closed.push(c),
                }
            }
        }
        self.closed.truncate(objects.len());
        self.vertex_sources = objects.iter().map(|m| crate::gpu::mesh::vertex_sources(m)).collect();
        self.objects = VirtualBuffers::new(&self.gpu.device, &self.gpu.queue, &self.mat_layout, objects, &self.closed)?;
        self.bounds = bounds_of(objects);
        Ok(())
    }

    /// The canvas (size, pose, warp).
    pub fn canvas(&self) -> &Canvas {
        &self.canvas
    }

    /// "proxy" or "ground plane".
    pub fn receivers_kind(&self) -> &'static str {
        self.receivers_kind
    }

    /// The settings.
    pub fn config(&self) -> &VemRenderConfig {
        &self.cfg
    }

    /// Changes culling (for the benchmark).
    pub fn set_culling(&mut self, on: bool) {
        self.cfg.culling = on;
    }

    /// Renders one frame over `background` (linear radiance in the camera's pixel grid); `dt_s`
    /// is the time since the previous frame (the tone-mapping smoothing).
    pub fn render(&mut self, lights: &VemLights<'_>, background: &LinearImage, dt_s: f64) -> Result<VemOutput, RenderError> {
        let t_start = Instant::now();
        let (ow, oh) = (self.canvas.out_width, self.canvas.out_height);
        if (background.width, background.height) != (ow, oh) {
            return Err(RenderError::FrameSize { got: (background.width, background.height), want: (ow, oh) });
        }
        let mut frame = VemFrame::prepare(lights, &self.cfg, self.objects.index_count > 0, self.bounds);
        if frame.cuts {
            // The cut ratio's row length (shaders/vem/shading.wgsl, fs_cut_receiver).
            frame.uniform.l[3] = self.canvas.intrinsics.width;
        }
        let mut report = VemReport::begin(lights, &frame, self.cfg.culling);
        let prepare_ms = ms_since(t_start);

        let t = Instant::now();
        let bind = self.upload(&frame, background);
        let upload_ms = ms_since(t);

        let t = Instant::now();
        let mut enc = self.gpu.device.create_command_encoder(&wgpu::CommandEncoderDescriptor { label: Some("vem frame") });
        if report.admit(&frame, &self.atlas_pass) {
            let (maps, tiles) = (frame.views.len() as u32, shadow_atlas::tiles_per_side(self.cfg.shadow_slots));
            self.atlas_pass.record(&self.gpu.device, &mut enc, &self.targets.atlas.view, &bind.views, &self.objects, maps, tiles, self.cfg.tile);
        }
        if report.admit(&frame, &self.prepass) {
            self.record_prepass(&mut enc);
        }
        let receivers = report.admit(&frame, &self.shading.receivers);
        let objects = report.admit(&frame, &self.shading.objects);
        self.record_shading(&mut enc, &bind.shading, receivers, objects, frame.cuts);
        if report.admit(&frame, &self.composite) {
            self.composite.record(&mut enc, &bind.composite, &self.targets.hdr.view);
        }
        self.gpu.queue.submit([enc.finish()]);
        self.gpu.wait()?;
        let gpu_ms = ms_since(t);

        let t = Instant::now();
        let hdr = self.read_hdr()?;
        let readback_ms = ms_since(t);

        let t = Instant::now();
        let mut srgb = Vec::new();
        if report.admit(&frame, &self.tonemap) {
            let params = self.tonemap.params(&hdr, dt_s);
            report.tone = Some(params);
            srgb = self.tonemap_frame(&params)?;
        }
        let tonemap_ms = ms_since(t);
        report.timings = VemTimings { prepare_ms, upload_ms, gpu_ms, readback_ms, tonemap_ms, total_ms: ms_since(t_start) };
        Ok(VemOutput { hdr, srgb, report })
    }

    /// The depth prepass's render pass (depth cleared, no stencil).
    fn record_prepass(&self, enc: &mut wgpu::CommandEncoder) {
        let mut pa = enc.begin_render_pass(&wgpu::RenderPassDescriptor {
            label: Some("vem depth prepass"),
            color_attachments: &[],
            depth_stencil_attachment: Some(wgpu::RenderPassDepthStencilAttachment {
                view: &self.targets.depth.view,
                depth_ops: Some(wgpu::Operations { load: wgpu::LoadOp::Clear(0.0), store: wgpu::StoreOp::Store }),
                stencil_ops: None,
            }),
            ..Default::default()
        });
        self.prepass.record(&mut pa, &self.camera_bg, &self.receivers, &self.objects);
    }

    /// The shading render pass: both layers cleared (no object, ratio 1), then the receivers and
    /// the objects that run.
    fn record_shading(&self, enc: &mut wgpu::CommandEncoder, frame_bg: &wgpu::BindGroup, receivers: bool, objects: bool, cuts: bool) {
        let clear = |view, c: wgpu::Color| wgpu::RenderPassColorAttachment {
            view,
            depth_slice: None,
            resolve_target: None,
            ops: wgpu::Operations { load: wgpu::LoadOp::Clear(c), store: wgpu::StoreOp::Store },
        };
        let t = &self.targets;
        let mut pa = enc.begin_render_pass(&wgpu::RenderPassDescriptor {
            label: Some("vem shading"),
            color_attachments: &[Some(clear(&t.virtual_layer.view, wgpu::Color::TRANSPARENT)), Some(clear(&t.ratio_layer.view, wgpu::Color::WHITE))],
            depth_stencil_attachment: Some(wgpu::RenderPassDepthStencilAttachment {
                view: &t.depth.view,
                depth_ops: Some(wgpu::Operations { load: wgpu::LoadOp::Load, store: wgpu::StoreOp::Discard }),
                stencil_ops: None,
            }),
            ..Default::default()
        });
        pa.set_bind_group(0, frame_bg, &[]);
        if receivers {
            self.shading.receivers.record(&mut pa, &self.receivers, cuts);
        }
        if objects {
            self.shading.objects.record(&mut pa, &self.objects, cuts);
        }
    }

    /// Reads the HDR composite back (32- or 16-bit float output).
    fn read_hdr(&self) -> Result<LinearImage, RenderError> {
        let bytes = read_texture(&self.gpu, &self.targets.hdr.texture, self.gpu.output_texel_bytes())?;
        let mut hdr = LinearImage::new(self.canvas.out_width, self.canvas.out_height);
        if self.gpu.output_texel_bytes() == 16 {
            let v: &[f32] = bytemuck::cast_slice(&bytes);
            for (i, p) in hdr.data.iter_mut().enumerate() {
                *p = [v[4 * i], v[4 * i + 1], v[4 * i + 2]];
            }
        } else {
            let v: Vec<u16> = bytes.chunks_exact(2).map(|b| u16::from_le_bytes([b[0], b[1]])).collect();
            for (i, p) in hdr.data.iter_mut().enumerate() {
                *p = [f32_from_f16(v[4 * i]), f32_from_f16(v[4 * i + 1]), f32_from_f16(v[4 * i + 2])];
            }
        }
        Ok(hdr)
    }

    /// Tone-maps the last HDR composite with `params` on the GPU; 8-bit sRGB RGBA, row-major.
    pub fn tonemap_frame(&self, params: &ToneParams) -> Result<Vec<u8>, RenderError> {
        let device = &self.gpu.device;
        let mut enc = device.create_command_encoder(&wgpu::CommandEncoderDescriptor { label: Some("vem tonemap") });
        self.tonemap.record(device, &mut enc, &self.targets.hdr.view, &self.targets.srgb.view, params);
        self.gpu.queue.submit([enc.finish()]);
        Ok(read_texture(&self.gpu, &self.targets.srgb.texture, 4)?)
    }
}
