//! The GPU half of the captured-VEM mode: the scene's virtual objects lit and shadowed by a
//! frame's directional lights and composited over a background (Havran 2005 §4–5,
//! `../shared/papers/havran-2005-video-environment-maps.txt`).
//!
//! # How it works
//! Per frame, [`VemRenderer::render`] takes the decomposer's lights, region lists (and glossy
//! set), and a background in the camera's pixel grid (the footage frame, or the VEM seen through
//! the camera: [`environment_background`]). It reuses the outdoor compositor's device, mesh
//! upload, canvas and lens warp ([`crate::render`]). The passes, each a `src/vem/gpu/<pass>.rs`
//! beside `shaders/vem/<pass>.wgsl`:
//!
//! | pass | what it does |
//! |---|---|
//! | [`shadow_atlas`] | up to 72 orthographic maps of 256² of the objects, one per clustered light (Havran §4.3) |
//! | depth prepass | receivers (proxy or ground plane) and objects into depth (`shaders/depth_prepass.wgsl`) |
//! | [`shading`] | objects: region-culled light loop (Havran §4.1), glossy L/H split (§4.2), shadow-map visibility; receivers: the differential ratio over the clustered lights |
//! | [`composite`] | in the footage grid: objects + (1 − α)·background·ratio |
//! | [`tonemap`] | global Reinhard with temporally smoothed parameters (Havran §5.1), sRGB 8-bit |
//!
//! The HDR composite is read back (for the tone-mapping parameters and for files), then the
//! tone-mapped frame. The shadow pass is skipped, with the reason in the report, when shadows
//! are off, there are no objects, or the lights carry no power (status `dark`).
//!
//! Not modelled: shadows of the real proxy on the virtual objects (the atlas holds the objects
//! only), MSAA (one sample per pixel), and the paper's cap on the number of glossy cone lights.

pub mod background;
pub mod overlay;
pub mod lists;
pub mod shading;
pub mod shadow_atlas;
pub mod tonemap;

use crate::vem::Status;
use crate::vem::glossy::GlossyRegions;
use crate::vem::polar::luminance;
use crate::vem::regions::{GpuLight, RegionLists, RegionSet};
use crate::vem::reinhard::{ToneMapper, ToneParams};
use crate::geometry::Mesh;
use crate::io::image::LinearImage;
use crate::render::RenderError;
use crate::gpu::canvas::{Canvas, camera_layout};
use crate::gpu::readback::read_texture;
use crate::gpu::texture::Tex;
use crate::render::frame::Skipped;
use crate::gpu::{Gpu, LAYER_FORMAT, f32_from_f16};
use crate::gpu::mesh::{ProxyBuffers, VirtualBuffers, VirtualVertex, material_layout};
use crate::camera::Camera;
use glam::Vec3;
use serde::Serialize;
use shading::{FLAG_CULLING, FLAG_GLOSSY, FLAG_SHADOWS, RATIO_FORMAT, ShadingPass, VemFrameUniform};
use shadow_atlas::{ATLAS_FORMAT, ShadowAtlasPass, ShadowView};
pub use background::{environment_background, ground_plane, ground_radiance};
use lists::{group_by_slot, light_bytes, list_words};
use std::sync::Arc;
use std::time::Instant;
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
}

impl Default for VemRenderConfig {
    fn default() -> Self {
        Self { shadow_slots: shadow_atlas::DEFAULT_SLOTS, tile: shadow_atlas::DEFAULT_TILE, culling: true, shadows: true, ground_albedo: GROUND_ALBEDO }
    }
}

/// One frame's lights as the renderer takes them.
#[derive(Clone, Debug)]
pub struct VemLights<'a> {
    /// The frame's status.
    pub status: Status,
    /// The set `H`: regions and this frame's lists.
    pub h: (&'a RegionSet, &'a RegionLists),
    /// The glossy set `L`, when configured.
    pub glossy: Option<(&'a GlossyRegions, &'a RegionLists)>,
    /// Directions of the clustered lights that get shadow maps (empty: `H` is clustered here).
    pub clusters: Vec<Vec3>,
}

impl<'a> VemLights<'a> {
    /// The lights of the decomposer's last frame.
    pub fn of(dec: &'a crate::vem::Decomposer, status: Status) -> Self {
        Self { status, h: dec.region_lists(), glossy: dec.glossy_lists(), clusters: dec.clusters().iter().map(|c| c.dir).collect() }
    }
}

/// Where a frame's time went, ms.
#[derive(Clone, Copy, Debug, Default, PartialEq, Serialize)]
pub struct VemTimings {
    /// Slots, shadow views, list buffers (CPU).
    pub prepare_ms: f64,
    /// Uploads (lights, lists, background).
    pub upload_ms: f64,
    /// Atlas, prepass, shading and composite on the GPU, until idle.
    pub gpu_ms: f64,
    /// HDR readback.
    pub readback_ms: f64,
    /// Tone-mapping parameters, pass and readback.
    pub tonemap_ms: f64,
    /// The whole frame.
    pub total_ms: f64,
}

/// The renderer's report of a frame.
#[derive(Clone, Debug, Default, PartialEq, Serialize)]
pub struct VemReport {
    /// Passes that ran, in order.
    pub ran: Vec<&'static str>,
    /// Passes left out, with the reason.
    pub skipped: Vec<Skipped>,
    /// Lights in `H`.
    pub lights: usize,
    /// Lights in `L` (0 without the glossy set).
    pub glossy_lights: usize,
    /// Shadow maps drawn.
    pub shadow_maps: usize,
    /// Per-region culling on.
    pub culling: bool,
    /// Mean list length of `H` over regions, as a fraction of `H` (the work left by culling).
    pub list_fraction: f64,
    /// The tone-mapping parameters used.
    pub tone: Option<ToneParams>,
    /// Timings.
    pub timings: VemTimings,
}

impl VemReport {
    fn skip(&mut self, pass: &'static str, reason: impl Into<String>) {
        self.skipped.push(Skipped { pass, reason: reason.into() });
    }

    /// The reason `pass` was skipped, if it was.
    pub fn skip_reason(&self, pass: &str) -> Option<&str> {
        self.skipped.iter().find(|s| s.pass == pass).map(|s| s.reason.as_str())
    }
}

/// A rendered frame.
#[derive(Clone, Debug)]
pub struct VemOutput {
    /// The composite, linear radiance, in the camera's pixel grid.
    pub hdr: LinearImage,
    /// The tone-mapped frame: 8-bit sRGB RGBA, row-major.
    pub srgb: Vec<u8>,
    /// What ran and how long it took.
    pub report: VemReport,
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
    bounds: Option<(Vec3, Vec3)>,
    shading: ShadingPass,
    atlas_pass: ShadowAtlasPass,
    composite: overlay::CompositePass,
    tonemap: tonemap::TonemapPass,
    depth: Tex,
    virtual_layer: Tex,
    ratio_layer: Tex,
    atlas: Tex,
    background: Tex,
    warp: Tex,
    hdr: Tex,
    srgb: Tex,
    sampler: wgpu::Sampler,
    shadow_sampler: wgpu::Sampler,
    tone: ToneMapper,
}

/// Union of the bounds of `meshes`.
fn bounds_of(meshes: &[&Mesh]) -> Option<(Vec3, Vec3)> {
    meshes.iter().filter_map(|m| m.bounds()).reduce(|a, b| (a.0.min(b.0), a.1.max(b.1)))
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
        let (receivers, receivers_kind) = match proxy {
            Some(p) if !p.triangles.is_empty() => (ProxyBuffers::new(device, p), "proxy"),
            _ => {
                let (c, y) = bounds.map_or((Vec3::ZERO, 0.0), |(lo, hi)| (0.5 * (lo + hi), lo.y));
                (ProxyBuffers::new(device, &ground_plane(c, y, cfg.ground_albedo)), "ground plane")
            }
        };
        let stride = std::mem::size_of::<VirtualVertex>() as u64;
        let shading = ShadingPass::new(device, &cam_layout, &mat_layout, stride)?;
        let atlas_pass = ShadowAtlasPass::new(device, stride)?;
        let composite = overlay::CompositePass::new(device, gpu.output_format)?;
        let tonemap = tonemap::TonemapPass::new(device)?;
        let cs = (canvas.width, canvas.height);
        let os = (canvas.out_width, canvas.out_height);
        let rt = wgpu::TextureUsages::RENDER_ATTACHMENT | wgpu::TextureUsages::TEXTURE_BINDING;
        let side = shadow_atlas::tiles_per_side(cfg.shadow_slots) * cfg.tile.max(1);
        let limit = device.limits().max_texture_dimension_2d;
        if side > limit {
            return Err(crate::gpu::GpuError::TooLarge { what: format!("a {side}² shadow atlas"), bytes: side as u64 * side as u64 * 4, limit: limit as u64 * limit as u64 * 4 }.into());
        }
        let warp = Tex::new(device, "vem warp", os, wgpu::TextureFormat::Rg32Float, 1, wgpu::TextureUsages::TEXTURE_BINDING | wgpu::TextureUsages::COPY_DST);
        warp.write(&gpu.queue, &canvas.warp);
        let sampler = device.create_sampler(&wgpu::SamplerDescriptor {
            label: Some("vem canvas"),
            mag_filter: wgpu::FilterMode::Linear,
            min_filter: wgpu::FilterMode::Linear,
            ..Default::default()
        });
        let shadow_sampler = device.create_sampler(&wgpu::SamplerDescriptor {
            label: Some("vem shadow atlas"),
            mag_filter: wgpu::FilterMode::Nearest,
            min_filter: wgpu::FilterMode::Nearest,
            compare: Some(wgpu::CompareFunction::LessEqual),
            ..Default::default()
        });
        Ok(Self {
            shadow_sampler,
            depth: Tex::new(device, "vem depth", cs, shading::DEPTH_FORMAT, 1, wgpu::TextureUsages::RENDER_ATTACHMENT),
            virtual_layer: Tex::new(device, "vem objects", cs, LAYER_FORMAT, 1, rt),
            ratio_layer: Tex::new(device, "vem ratio", cs, RATIO_FORMAT, 1, rt),
            atlas: Tex::new(device, "vem shadow atlas", (side, side), ATLAS_FORMAT, 1, rt),
            background: Tex::new(device, "vem background", os, wgpu::TextureFormat::Rgba32Float, 1, wgpu::TextureUsages::TEXTURE_BINDING | wgpu::TextureUsages::COPY_DST),
            hdr: Tex::new(device, "vem hdr", os, gpu.output_format, 1, rt | wgpu::TextureUsages::COPY_SRC),
            srgb: Tex::new(device, "vem srgb", os, tonemap::SRGB_FORMAT, 1, wgpu::TextureUsages::RENDER_ATTACHMENT | wgpu::TextureUsages::COPY_SRC),
            warp,
            sampler,
            gpu,
            cfg,
            canvas,
            camera_buffer,
            camera_bg,
            receivers,
            receivers_kind,
            objects: objects_buf,
            bounds,
            shading,
            atlas_pass,
            composite,
            tonemap,
            tone: ToneMapper::new(),
        })
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
        let device = &self.gpu.device;
        let mut report = VemReport { culling: self.cfg.culling, ..Default::default() };
        let (h_set, h_lists) = lights.h;
        let mut h_gpu = h_lists.lights.clone();
        let mut l_gpu = lights.glossy.map(|(_, l)| l.lights.clone()).unwrap_or_default();
        report.lights = h_gpu.len();
        report.glossy_lights = l_gpu.len();
        report.list_fraction = h_lists.mean_fraction();
        let has_objects = self.objects.index_count > 0;
        let power: f32 = h_gpu.iter().map(|l| l.rgb.iter().sum::<f32>()).sum();
        let no_shadows = if !self.cfg.shadows {
            Some("shadows are off".to_owned())
        } else if !has_objects {
            Some("the scene has no virtual objects".to_owned())
        } else if power.is_nan() || power <= 0.0 {
            Some(format!("the lights carry no power (status {})", if lights.status == Status::Dark { "dark" } else { "ok" }))
        } else {
            None
        };
        let (views, shadow_lights): (Vec<ShadowView>, Vec<GpuLight>) = match (&no_shadows, self.bounds) {
            (None, Some((lo, hi))) => {
                let dirs = shadow_atlas::shadow_directions(&h_gpu, &lights.clusters, self.cfg.shadow_slots);
                shadow_atlas::assign_slots(&mut h_gpu, &dirs);
                shadow_atlas::assign_slots(&mut l_gpu, &dirs);
                let mut clustered: Vec<GpuLight> =
                    dirs.iter().enumerate().map(|(k, d)| GpuLight { dir: d.to_array(), shadow: k as u32, rgb: [0.0; 3], index: k as u32 }).collect();
                for l in &h_gpu {
                    if let Some(c) = clustered.get_mut(l.shadow as usize) {
                        for k in 0..3 {
                            c.rgb[k] += l.rgb[k];
                        }
                    }
                }
                (dirs.iter().map(|d| shadow_atlas::fit_view(*d, lo, hi, self.cfg.tile)).collect(), clustered)
            }
            _ => (Vec::new(), Vec::new()),
        };
        report.shadow_maps = views.len();
        let glossy = lights.glossy.filter(|_| !l_gpu.is_empty());
        let mut flags = 0;
        if self.cfg.culling {
            flags |= FLAG_CULLING;
        }
        if !views.is_empty() {
            flags |= FLAG_SHADOWS;
        }
        if glossy.is_some() {
            flags |= FLAG_GLOSSY;
        }
        let tiles = shadow_atlas::tiles_per_side(self.cfg.shadow_slots);
        let uniform = VemFrameUniform {
            h: [h_gpu.len() as u32, h_set.len() as u32, h_set.lut.size, flags],
            l: glossy.map_or([0; 4], |(g, _)| [l_gpu.len() as u32, g.regions.len() as u32, g.regions.lut.size, 0]),
            atlas: [tiles, self.cfg.tile, views.len() as u32, 0],
            params: [glossy.map_or(2.0, |(g, _)| g.cos_cone), self.cfg.ground_albedo, 0.0, 0.0],
        };
        let mut h_words = list_words(h_set, h_lists);
        let mut l_words = glossy.map_or_else(|| vec![0u32], |(g, l)| list_words(&g.regions, l));
        if !views.is_empty() {
            group_by_slot(&mut h_gpu, &mut h_words, h_set.lut.texels.len(), h_set.len());
            if let Some((g, _)) = glossy {
                group_by_slot(&mut l_gpu, &mut l_words, g.regions.lut.texels.len(), g.regions.len());
            }
        }
        let prepare_ms = t_start.elapsed().as_secs_f64() * 1e3;

        let t = Instant::now();
        let storage = |label: &str, bytes: &[u8]| {
            device.create_buffer_init(&wgpu::util::BufferInitDescriptor { label: Some(label), contents: bytes, usage: wgpu::BufferUsages::STORAGE })
        };
        let frame_buf = device.create_buffer_init(&wgpu::util::BufferInitDescriptor { label: Some("vem frame"), contents: bytemuck::bytes_of(&uniform), usage: wgpu::BufferUsages::UNIFORM });
        let h_lights_buf = storage("vem H lights", &light_bytes(&h_gpu));
        let h_lists_buf = storage("vem H lists", bytemuck::cast_slice(&h_words));
        let l_lights_buf = storage("vem L lights", &light_bytes(&l_gpu));
        let l_lists_buf = storage("vem L lists", bytemuck::cast_slice(&l_words));
        let views_bytes: Vec<u8> = if views.is_empty() { vec![0u8; std::mem::size_of::<ShadowView>()] } else { bytemuck::cast_slice(&views).to_vec() };
        let views_buf = storage("vem shadow views", &views_bytes);
        let shadow_lights_buf = storage("vem shadow lights", &light_bytes(&shadow_lights));
        let frame_bg = device.create_bind_group(&wgpu::BindGroupDescriptor {
            label: Some("vem shading frame"),
            layout: &self.shading.frame_layout,
            entries: &[
                wgpu::BindGroupEntry { binding: 0, resource: self.camera_buffer.as_entire_binding() },
                wgpu::BindGroupEntry { binding: 1, resource: frame_buf.as_entire_binding() },
                wgpu::BindGroupEntry { binding: 2, resource: h_lights_buf.as_entire_binding() },
                wgpu::BindGroupEntry { binding: 3, resource: h_lists_buf.as_entire_binding() },
                wgpu::BindGroupEntry { binding: 4, resource: l_lights_buf.as_entire_binding() },
                wgpu::BindGroupEntry { binding: 5, resource: l_lists_buf.as_entire_binding() },
                wgpu::BindGroupEntry { binding: 6, resource: views_buf.as_entire_binding() },
                wgpu::BindGroupEntry { binding: 7, resource: wgpu::BindingResource::TextureView(&self.atlas.view) },
                wgpu::BindGroupEntry { binding: 8, resource: shadow_lights_buf.as_entire_binding() },
                wgpu::BindGroupEntry { binding: 9, resource: wgpu::BindingResource::Sampler(&self.shadow_sampler) },
            ],
        });
        let bg: Vec<[f32; 4]> = background.data.iter().map(|p| [p[0], p[1], p[2], 1.0]).collect();
        self.background.write(&self.gpu.queue, &bg);
        let composite_bg = device.create_bind_group(&wgpu::BindGroupDescriptor {
            label: Some("vem composite"),
            layout: &self.composite.layout,
            entries: &[
                wgpu::BindGroupEntry { binding: 0, resource: wgpu::BindingResource::TextureView(&self.background.view) },
                wgpu::BindGroupEntry { binding: 1, resource: wgpu::BindingResource::TextureView(&self.warp.view) },
                wgpu::BindGroupEntry { binding: 2, resource: wgpu::BindingResource::TextureView(&self.virtual_layer.view) },
                wgpu::BindGroupEntry { binding: 3, resource: wgpu::BindingResource::TextureView(&self.ratio_layer.view) },
                wgpu::BindGroupEntry { binding: 4, resource: wgpu::BindingResource::Sampler(&self.sampler) },
            ],
        });
        let upload_ms = t.elapsed().as_secs_f64() * 1e3;

        let t = Instant::now();
        let mut enc = device.create_command_encoder(&wgpu::CommandEncoderDescriptor { label: Some("vem frame") });
        if let Some(why) = &no_shadows {
            report.skip(pass::SHADOW_ATLAS, why.clone());
        } else {
            let views_bg = device.create_bind_group(&wgpu::BindGroupDescriptor {
                label: Some("vem shadow views"),
                layout: &self.atlas_pass.layout,
                entries: &[wgpu::BindGroupEntry { binding: 0, resource: views_buf.as_entire_binding() }],
            });
            let mut pa = enc.begin_render_pass(&wgpu::RenderPassDescriptor {
                label: Some("vem shadow atlas"),
                color_attachments: &[],
                depth_stencil_attachment: Some(wgpu::RenderPassDepthStencilAttachment {
                    view: &self.atlas.view,
                    depth_ops: Some(wgpu::Operations { load: wgpu::LoadOp::Clear(1.0), store: wgpu::StoreOp::Store }),
                    stencil_ops: None,
                }),
                ..Default::default()
            });
            pa.set_pipeline(&self.atlas_pass.pipeline);
            pa.set_bind_group(0, &views_bg, &[]);
            pa.set_vertex_buffer(0, self.objects.vertices.slice(..));
            pa.set_index_buffer(self.objects.indices.slice(..), wgpu::IndexFormat::Uint32);
            let tile = self.cfg.tile;
            for slot in 0..views.len() as u32 {
                let (x, y) = ((slot % tiles) * tile, (slot / tiles) * tile);
                pa.set_viewport(x as f32, y as f32, tile as f32, tile as f32, 0.0, 1.0);
                pa.set_scissor_rect(x, y, tile, tile);
                for d in &self.objects.draws {
                    pa.draw_indexed(d.indices.clone(), 0, slot..slot + 1);
                }
            }
            drop(pa);
            report.ran.push(pass::SHADOW_ATLAS);
        }
        {
            let mut pa = enc.begin_render_pass(&wgpu::RenderPassDescriptor {
                label: Some("vem depth prepass"),
                color_attachments: &[],
                depth_stencil_attachment: Some(wgpu::RenderPassDepthStencilAttachment {
                    view: &self.depth.view,
                    depth_ops: Some(wgpu::Operations { load: wgpu::LoadOp::Clear(0.0), store: wgpu::StoreOp::Store }),
                    stencil_ops: None,
                }),
                ..Default::default()
            });
            pa.set_bind_group(0, &self.camera_bg, &[]);
            pa.set_pipeline(&self.shading.prepass_receiver);
            pa.set_vertex_buffer(0, self.receivers.vertices.slice(..));
            pa.set_index_buffer(self.receivers.indices.slice(..), wgpu::IndexFormat::Uint32);
            pa.draw_indexed(0..self.receivers.index_count, 0, 0..1);
            pa.set_vertex_buffer(0, self.objects.vertices.slice(..));
            pa.set_index_buffer(self.objects.indices.slice(..), wgpu::IndexFormat::Uint32);
            for d in &self.objects.draws {
                pa.set_pipeline(if d.closed { &self.shading.prepass_closed } else { &self.shading.prepass_open });
                pa.draw_indexed(d.indices.clone(), 0, 0..1);
            }
            report.ran.push(pass::DEPTH_PREPASS);
        }
        {
            let clear = |view, c: wgpu::Color| wgpu::RenderPassColorAttachment {
                view,
                depth_slice: None,
                resolve_target: None,
                ops: wgpu::Operations { load: wgpu::LoadOp::Clear(c), store: wgpu::StoreOp::Store },
            };
            let mut pa = enc.begin_render_pass(&wgpu::RenderPassDescriptor {
                label: Some("vem shading"),
                color_attachments: &[Some(clear(&self.virtual_layer.view, wgpu::Color::TRANSPARENT)), Some(clear(&self.ratio_layer.view, wgpu::Color::WHITE))],
                depth_stencil_attachment: Some(wgpu::RenderPassDepthStencilAttachment {
                    view: &self.depth.view,
                    depth_ops: Some(wgpu::Operations { load: wgpu::LoadOp::Load, store: wgpu::StoreOp::Discard }),
                    stencil_ops: None,
                }),
                ..Default::default()
            });
            pa.set_bind_group(0, &frame_bg, &[]);
            if views.is_empty() {
                // Without shadow maps every ratio is 1: the cleared value.
                report.skip(pass::RECEIVERS, "no shadow maps this frame: the ratio is 1 everywhere");
            } else {
                pa.set_pipeline(&self.shading.receiver);
                pa.set_vertex_buffer(0, self.receivers.vertices.slice(..));
                pa.set_index_buffer(self.receivers.indices.slice(..), wgpu::IndexFormat::Uint32);
                pa.draw_indexed(0..self.receivers.index_count, 0, 0..1);
                report.ran.push(pass::RECEIVERS);
            }
            if has_objects {
                pa.set_vertex_buffer(0, self.objects.vertices.slice(..));
                pa.set_index_buffer(self.objects.indices.slice(..), wgpu::IndexFormat::Uint32);
                for d in &self.objects.draws {
                    pa.set_pipeline(if d.closed { &self.shading.closed } else { &self.shading.open });
                    pa.set_bind_group(1, &d.bind_group, &[]);
                    pa.draw_indexed(d.indices.clone(), 0, 0..1);
                }
                report.ran.push(pass::SHADING);
            } else {
                report.skip(pass::SHADING, "the scene has no virtual objects");
            }
        }
        {
            let mut pa = enc.begin_render_pass(&wgpu::RenderPassDescriptor {
                label: Some("vem composite"),
                color_attachments: &[Some(wgpu::RenderPassColorAttachment {
                    view: &self.hdr.view,
                    depth_slice: None,
                    resolve_target: None,
                    ops: wgpu::Operations { load: wgpu::LoadOp::Clear(wgpu::Color::BLACK), store: wgpu::StoreOp::Store },
                })],
                ..Default::default()
            });
            pa.set_pipeline(&self.composite.pipeline);
            pa.set_bind_group(0, &composite_bg, &[]);
            pa.draw(0..3, 0..1);
            report.ran.push(pass::COMPOSITE);
        }
        self.gpu.queue.submit([enc.finish()]);
        self.gpu.wait()?;
        let gpu_ms = t.elapsed().as_secs_f64() * 1e3;

        let t = Instant::now();
        let bytes = read_texture(&self.gpu, &self.hdr.texture, self.gpu.output_texel_bytes())?;
        let mut hdr = LinearImage::new(ow, oh);
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
        let readback_ms = t.elapsed().as_secs_f64() * 1e3;

        let t = Instant::now();
        let lum: Vec<f32> = hdr.data.iter().map(|p| luminance(*p)).collect();
        let params = self.tone.update(&lum, dt_s).unwrap_or(ToneParams { log_average: 1.0, key: 0.18, white: 1.0 });
        report.tone = Some(params);
        let srgb = self.tonemap_frame(&params)?;
        report.ran.push(pass::TONEMAP);
        let tonemap_ms = t.elapsed().as_secs_f64() * 1e3;
        report.timings = VemTimings { prepare_ms, upload_ms, gpu_ms, readback_ms, tonemap_ms, total_ms: t_start.elapsed().as_secs_f64() * 1e3 };
        Ok(VemOutput { hdr, srgb, report })
    }

    /// Tone-maps the last HDR composite with `params` on the GPU; 8-bit sRGB RGBA, row-major.
    pub fn tonemap_frame(&self, params: &ToneParams) -> Result<Vec<u8>, RenderError> {
        let device = &self.gpu.device;
        let u = tonemap::ToneUniform::new(params);
        let ubuf = device.create_buffer_init(&wgpu::util::BufferInitDescriptor { label: Some("vem tone"), contents: bytemuck::bytes_of(&u), usage: wgpu::BufferUsages::UNIFORM });
        let bg = device.create_bind_group(&wgpu::BindGroupDescriptor {
            label: Some("vem tonemap"),
            layout: &self.tonemap.layout,
            entries: &[
                wgpu::BindGroupEntry { binding: 0, resource: wgpu::BindingResource::TextureView(&self.hdr.view) },
                wgpu::BindGroupEntry { binding: 1, resource: ubuf.as_entire_binding() },
            ],
        });
        let mut enc = device.create_command_encoder(&wgpu::CommandEncoderDescriptor { label: Some("vem tonemap") });
        {
            let mut pa = enc.begin_render_pass(&wgpu::RenderPassDescriptor {
                label: Some("vem tonemap"),
                color_attachments: &[Some(wgpu::RenderPassColorAttachment {
                    view: &self.srgb.view,
                    depth_slice: None,
                    resolve_target: None,
                    ops: wgpu::Operations { load: wgpu::LoadOp::Clear(wgpu::Color::BLACK), store: wgpu::StoreOp::Store },
                })],
                ..Default::default()
            });
            pa.set_pipeline(&self.tonemap.pipeline);
            pa.set_bind_group(0, &bg, &[]);
            pa.draw(0..3, 0..1);
        }
        self.gpu.queue.submit([enc.finish()]);
        Ok(read_texture(&self.gpu, &self.srgb.texture, 4)?)
    }
}
