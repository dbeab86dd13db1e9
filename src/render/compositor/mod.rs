//! The compositor: one frame of footage in, the same frame with the virtual objects out.
//!
//! # How it works
//! (Jensen §3.2 steps 1–4, §3.3 and §5, made robust; the passes are documented in their own
//! modules.) On the undistorted canvas ([`crate::gpu::canvas`]), with MSAA when the adapter has it:
//!
//! 1. depth prepass: real proxy, then virtual objects (which set the virtual-surface stencil
//!    bit);
//! 2. shadow volumes of the real parts that can matter, z-fail counted, resolved to a flag; then
//!    those of the virtual objects, the same way (skipped without sun);
//! 3. the shadow masks: virtual shadow on real surfaces outside real shadow, and which
//!    virtual-surface samples are in some shadow;
//! 4. the virtual objects shaded in one geometry pass: sun term times the pixel's unshadowed
//!    fraction of virtual-surface samples, ambient from the per-pixel transfer
//!    ([`super::object_transfer`], traced on the CPU on the first frame and when the sun has moved past
//!    `bounce_rebuild_deg`), or SH ambient from the probe grid times the objects' own ambient
//!    occlusion where the transfer has no entry (or is off).
//!
//! Then, in the footage's pixel grid, the composite warps the canvas layers through the lens
//! model and darkens the footage: under the virtual shadow with the proxy's normal and `c`, and,
//! with the (default) differential model, also where the objects take sky and bounce light from
//! real surfaces next to them; there the virtual shadow removes the share of a pixel's sunlit
//! real samples that it covers, counted on the GPU's own samples.
//!
//! Work a frame does not need is left out, and the report says why: no virtual objects (the
//! footage passes through), no sun (`Pd ≈ 0` or the sun below the horizon: no volumes, no sun
//! term), no real part whose shadow can reach the objects or their shadows (no real volumes),
//! a sun that has not moved more than `reuse_sun_deg` with static objects (the volumes, the
//! stencil and the mask of the earlier frame are kept; only shading and composite run), and a
//! sun that has not moved more than `bounce_rebuild_deg` (the objects' transfer is kept).
mod encode;
mod resources;
mod volumes;

pub use resources::Resources;
use super::region::Rect;
use crate::gpu::readback::read_texture;
pub use volumes::{BuildStats, Builder, Volumes};

use super::RenderError;
use crate::gpu::canvas::{Canvas, camera_layout};
use super::composite::{self, Composite};
use super::depth_prepass::DepthPrepass;
use crate::lighting::Lighting;
use super::frame::{Darkening, LightingUniform, PassReport, VideoFrame, pass};
use crate::gpu::{Gpu, MASK_FORMAT, f32_from_f16};
use crate::gpu::mesh::{ProxyBuffers, VirtualBuffers, VirtualVertex, material_layout};
use super::occluder::Occluder;
use super::probes::GpuProbes;
use super::receivers::Receivers;
use super::shadow_mask::ShadowMask;
use super::shadow_volume::ShadowVolumePass;
use super::stencil::StencilResolve;
use super::virtual_shading::VirtualShading;
use super::object_transfer::{ObjectTransfer, TransferScene};
use super::volume::OPEN_CAP_OFFSET_M;
use crate::geometry::ambient::TransportQuality;
use crate::geometry::raycast::RayScene;
use crate::io::image::LinearImage;
use crate::irradiance::ProbeGrid;
use crate::scene::settings::EstimatorConfig;
use crate::geometry::Mesh;
use crate::scene::Scene;
use crate::camera::Camera;
use glam::Vec3;
use std::collections::HashMap;
use std::sync::Arc;
use wgpu::util::DeviceExt;

/// Default largest sun motion (degrees) over which volumes and stencil are reused: the shadow of
/// an occluder 5 m from its receiver moves 4 mm, a fraction of a pixel at courtyard distances.
pub const REUSE_SUN_DEG: f64 = 0.05;
/// Pixels added around the region a virtual shadow can reach when computing `c` and `b` (the
/// bilinear warp reads one pixel beyond a mask edge).
const RECEIVER_GROW_PX: u32 = 2;
/// The differential model computes `c_v`, `b_v` on real surfaces within this many bounding-box
/// half-diagonals of a virtual object (an object of that size then takes less than about 2% of
/// the sky's cosine-weighted solid angle), and at least [`MIN_NEAR_RADIUS_M`].
const NEAR_RADIUS_HALF_DIAGONALS: f32 = 2.5;
/// Smallest radius of the differential model's region, metres.
const MIN_NEAR_RADIUS_M: f32 = 1.0;

/// Relative error of a value stored as a half float (11 significant bits; conversion may
/// truncate, so one unit in the last place).
pub const HALF_PRECISION: f32 = 1.0 / 1024.0;

/// Compositor settings.
#[derive(Clone, Debug, PartialEq)]
pub struct CompositorConfig {
    /// Canvas pixels per footage pixel (≥ 1).
    pub supersample: f64,
    /// How real pixels under a virtual shadow are darkened.
    pub darkening: Darkening,
    /// Add the sun bounce `b·Pd` to the ambient of the darkening ratio.
    pub sun_bounce: bool,
    /// Virtual volume builder.
    pub builder: Builder,
    /// Sun motion (degrees) below which volumes and stencil are reused.
    pub reuse_sun_deg: f64,
    /// `Pd/Pa` (luminance) below which there is no sun term and no volume.
    pub no_sun_ratio: f64,
    /// Cap offset of per-triangle volumes, metres.
    pub cap_offset_m: f32,
    /// Also produce the warped debug masks (the 3D passes then cover the whole canvas, so the
    /// masks are complete).
    pub debug_masks: bool,
    /// Scissor the 3D passes to the canvas region the objects and their shadows can reach
    /// ([`region`]); off, they cover the whole canvas (same picture, more time).
    pub scissor: bool,
    /// Quality of `c` (without bounce).
    pub ambient_quality: TransportQuality,
    /// Quality of `c` and `b` together.
    pub bounce_quality: TransportQuality,
    /// Sun motion (degrees) after which `b` is recomputed.
    pub bounce_rebuild_deg: f64,
    /// Rays per canvas pixel of the virtual objects' own ambient occlusion (0: none), the
    /// ambient's fallback where the per-pixel transfer has no entry.
    pub occlusion_rays: u32,
    /// Paths per canvas pixel of the virtual objects' ambient transfer ([`super::object_transfer`]);
    /// 0 turns it off (ambient from the probe grid times ambient occlusion everywhere).
    pub transfer_paths: u32,
    /// Surface hits per path of the transfer.
    pub transfer_bounces: u32,
    /// Lattice spacing of the transfer's traced pixels (0: automatic, within
    /// [`super::object_transfer::TRANSFER_PATH_BUDGET`]).
    pub transfer_stride: u32,
    /// Seed of the integrals.
    pub seed: u64,
}

impl CompositorConfig {
    /// Defaults that follow the scene's estimator settings (same `c`, `b` quality, bounce on or
    /// off, no-sun threshold).
    pub fn for_scene(scene: &Scene) -> Self {
        Self::from_estimator_settings(&scene.estimator)
    }

    /// Defaults that follow the scene's `[estimator]` settings (plain data from
    /// [`crate::scene::settings`]): the same `c`, `b` quality, bounce on or off, no-sun threshold.
    pub fn from_estimator_settings(e: &EstimatorConfig) -> Self {
        Self {
            supersample: 1.0,
            darkening: Darkening::default(),
            sun_bounce: e.sun_bounce,
            builder: Builder::Cpu,
            reuse_sun_deg: REUSE_SUN_DEG,
            no_sun_ratio: e.no_sun_ratio,
            cap_offset_m: OPEN_CAP_OFFSET_M,
            debug_masks: false,
            scissor: true,
            ambient_quality: e.ambient,
            bounce_quality: e.bounce,
            bounce_rebuild_deg: e.sun_rebuild_deg,
            occlusion_rays: super::occlusion::AO_RAYS,
            transfer_paths: super::object_transfer::TRANSFER_PATHS,
            transfer_bounces: super::object_transfer::TRANSFER_BOUNCES,
            transfer_stride: 0,
            seed: e.seed,
        }
    }
}

/// Passes a viewer can switch off (all on by default). A pass switched off is listed in the
/// frame's [`PassReport::skipped`] with the reason given to [`Compositor::set_switches`].
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct PassSwitches {
    /// The virtual objects and everything they need (off: the footage passes through).
    pub virtual_objects: bool,
    /// The virtual objects' shadow volumes: their shadows on real surfaces and on themselves.
    pub virtual_volumes: bool,
    /// The real proxy's shadow volumes: real shadows on the virtual objects (and real shadow
    /// that keeps a virtual shadow from darkening twice).
    pub real_volumes: bool,
    /// The objects' per-pixel ambient transfer (off: the probe grid times ambient occlusion
    /// everywhere). Without effect when the compositor was built with `transfer_paths = 0`.
    pub transfer: bool,
}

impl Default for PassSwitches {
    fn default() -> Self {
        Self { virtual_objects: true, virtual_volumes: true, real_volumes: true, transfer: true }
    }
}

/// A composited frame read back to the CPU.
#[derive(Clone, Debug)]
pub struct RenderedFrame {
    /// Linear radiance of the output.
    pub image: LinearImage,
    /// Warped masks per pixel (`r` virtual shadow on real, `g` real shadow, `b` virtual surface
    /// without sun, `a` virtual surface), when debug masks are on.
    pub masks: Option<Vec<[u8; 4]>>,
    /// Relative precision of `image`: 0 for a 32-bit float output, 2⁻¹⁰ for a half-float one
    /// (GL cannot render to 32-bit float). Pixels the composite left alone equal the footage
    /// within it.
    pub precision: f32,
}

/// What the compositor draws: the camera, the real proxy and the virtual objects (world
/// coordinates), with names for warnings.
#[derive(Clone, Copy, Debug)]
pub struct SceneParts<'a> {
    /// The calibrated camera.
    pub camera: &'a Camera,
    /// The real proxy.
    pub proxy: &'a Mesh,
    /// Name of the proxy (its file).
    pub proxy_name: &'a str,
    /// Virtual objects and their names.
    pub objects: &'a [(String, &'a Mesh)],
}

impl<'a> SceneParts<'a> {
    /// The names of a scene's virtual objects (their file names), for [`SceneParts::objects`].
    pub fn object_list(scene: &'a Scene) -> Vec<(String, &'a Mesh)> {
        scene.virtual_objects.iter().map(|o| (file_name(&o.path), &o.mesh)).collect()
    }

    /// The parts of a loaded scene; `objects` from [`SceneParts::object_list`].
    pub fn of(scene: &'a Scene, objects: &'a [(String, &'a Mesh)]) -> Self {
        Self { camera: &scene.camera, proxy: &scene.proxy, proxy_name: &scene.manifest.proxy.file, objects }
    }
}

/// What the stored stencil and mask hold.
#[derive(Clone, Copy, Debug, PartialEq)]
struct StencilState {
    sun: Option<Vec3>,
    debug: bool,
    frame: u64,
}

/// The GPU compositor of one scene and camera.
pub struct Compositor {
    gpu: Arc<Gpu>,
    config: CompositorConfig,
    canvas: Canvas,
    proxy_ray: Arc<RayScene>,
    receivers: Receivers,
    volumes: Volumes,
    virtual_bounds: Vec<(Vec3, Vec3)>,
    res: Resources,
    camera_bg: wgpu::BindGroup,
    lighting_buf: wgpu::Buffer,
    camera_buf: wgpu::Buffer,
    probes: GpuProbes,
    shading_bg: wgpu::BindGroup,
    proxy: ProxyBuffers,
    virt: VirtualBuffers,
    prepass: DepthPrepass,
    shadow: ShadowVolumePass,
    resolve: StencilResolve,
    shading: VirtualShading,
    mask: ShadowMask,
    composite_layout: wgpu::BindGroupLayout,
    composite_bg: wgpu::BindGroup,
    composites: HashMap<wgpu::TextureFormat, Composite>,
    stencil: Option<StencilState>,
    switches: PassSwitches,
    switched_off_reason: String,
    warnings: Vec<String>,
    frames: u64,
    /// The proxy and the virtual objects in one BVH (for `c_v`, `b_v` and the transfer).
    with_ray: Option<Arc<RayScene>>,
    /// The objects' per-pixel ambient transfer and its scene (none without objects or with
    /// `transfer_paths = 0`).
    transfer: Option<(TransferScene, ObjectTransfer)>,
    /// The canvas region of the stored stencil's frame (`None`: the whole canvas).
    region: Option<Rect>,
    /// Radius of the differential model's region around the objects.
    near_radius_m: f32,
    /// Pixels of that region (computed on first use).
    near_pixels: Option<Vec<u32>>,
    /// The pixels whose `c`, `b` (`c_v`, `b_v`) are kept up to date, and the sun and model they
    /// were chosen for.
    receiver_pixels: Option<((Option<Vec3>, bool), Vec<u32>)>,
}

fn file_name(p: &std::path::Path) -> String {
    p.file_name().map(|s| s.to_string_lossy().into_owned()).unwrap_or_else(|| p.display().to_string())
}

impl Compositor {
    /// Sets up the compositor for a loaded scene. `proxy_ray` is the proxy's BVH (the
    /// estimator's).
    pub fn for_scene(gpu: Arc<Gpu>, scene: &Scene, proxy_ray: Arc<RayScene>, config: CompositorConfig) -> Result<Self, RenderError> {
        let objects = SceneParts::object_list(scene);
        Self::new(gpu, &SceneParts::of(scene, &objects), proxy_ray, config)
    }

    /// Sets up the compositor for a camera, a proxy and virtual objects. `proxy_ray` is the
    /// proxy's BVH.
    pub fn new(gpu: Arc<Gpu>, parts: &SceneParts, proxy_ray: Arc<RayScene>, config: CompositorConfig) -> Result<Self, RenderError> {
        let canvas = Canvas::new(parts.camera, config.supersample);
        let receivers = Receivers::new(parts.camera, &proxy_ray, config.seed);
        let virtual_occ: Vec<Occluder> = parts.objects.iter().map(|(name, mesh)| Occluder::new(mesh, name)).collect();
        let proxy_occ = Occluder::new(parts.proxy, &format!("real proxy {}", parts.proxy_name));
        let mut warnings: Vec<String> = virtual_occ.iter().flat_map(|o| o.warnings()).collect();
        warnings.extend(proxy_occ.warnings());
        let virtual_bounds: Vec<(Vec3, Vec3)> = parts.objects.iter().filter_map(|(_, m)| m.bounds()).collect();
        let near_radius_m = virtual_bounds.iter().map(|(lo, hi)| (*hi - *lo).length() / 2.0 * NEAR_RADIUS_HALF_DIAGONALS).fold(MIN_NEAR_RADIUS_M, f32::max);
        let object_meshes: Vec<&Mesh> = parts.objects.iter().map(|(_, m)| *m).collect();
        let transfer_scene = (!parts.objects.is_empty()).then(|| TransferScene::new(parts.proxy, &object_meshes));
        let with_ray = transfer_scene.as_ref().map(|t| t.world.clone());
        let closed: Vec<Vec<bool>> = virtual_occ.iter().zip(parts.objects).map(|(o, (_, m))| o.closed_triangles(m.triangles.len())).collect();
        let volumes = Volumes::new(&gpu, virtual_occ, proxy_occ, config.builder)?;
        let d = &gpu.device;
        let res = Resources::new(&gpu, (canvas.width, canvas.height), (canvas.out_width, canvas.out_height));
        let cam_layout = camera_layout(d);
        let camera_buf = d.create_buffer_init(&wgpu::util::BufferInitDescriptor {
            label: Some("camera"),
            contents: bytemuck::bytes_of(&canvas.uniform()),
            usage: wgpu::BufferUsages::UNIFORM | wgpu::BufferUsages::COPY_DST,
        });
        let lighting_buf = d.create_buffer(&wgpu::BufferDescriptor {
            label: Some("lighting"),
            size: std::mem::size_of::<LightingUniform>() as u64,
            usage: wgpu::BufferUsages::UNIFORM | wgpu::BufferUsages::COPY_DST,
            mapped_at_creation: false,
        });
        let camera_bg = d.create_bind_group(&wgpu::BindGroupDescriptor {
            label: Some("camera"),
            layout: &cam_layout,
            entries: &[wgpu::BindGroupEntry { binding: 0, resource: camera_buf.as_entire_binding() }],
        });
        let mat_layout = material_layout(d);
        let meshes: Vec<&Mesh> = parts.objects.iter().map(|(_, m)| *m).collect();
        let virt = VirtualBuffers::new(d, &gpu.queue, &mat_layout, &meshes, &closed)?;
        let proxy = ProxyBuffers::new(d, parts.proxy);
        let (df, s) = (gpu.depth_format, gpu.samples);
        let prepass = DepthPrepass::new(d, &cam_layout, df, s, std::mem::size_of::<VirtualVertex>() as u64)?;
        let shadow = ShadowVolumePass::new(d, &cam_layout, df, s)?;
        let resolve = StencilResolve::new(d, df, s)?;
        let shading = VirtualShading::new(d, &mat_layout, df, s)?;
        let mask = ShadowMask::new(d, df, s)?;
        let composite_layout = composite::layout(d);
        let composite_bg = res.composite_bind_group(d, &composite_layout, &lighting_buf);
        let mut composites = HashMap::new();
        composites.insert(gpu.output_format, Composite::new(d, &composite_layout, gpu.output_format, Some(MASK_FORMAT))?);
        let probes = GpuProbes::new(d, &gpu.queue, &ProbeGrid::filled(Vec3::ZERO, Vec3::ZERO, 1.0, [[0.0; 3]; 9]));
        let occlusion = match (config.occlusion_rays, parts.objects.is_empty()) {
            (0, _) | (_, true) => vec![1.0f32; (canvas.width * canvas.height) as usize],
            (rays, false) => {
                // The objects alone: the transfer scene holds them in one mesh already.
                let objects = transfer_scene.as_ref().map(|t| t.objects.clone()).unwrap_or_default();
                super::occlusion::virtual_occlusion(&canvas, &RayScene::new(objects), rays, config.seed)
            }
        };
        res.occlusion.write(&gpu.queue, &occlusion);
        let transfer = match (config.transfer_paths, transfer_scene) {
            (paths @ 1.., Some(scene)) => {
                let q = TransportQuality { paths, max_bounces: config.transfer_bounces };
                let t = ObjectTransfer::new(&canvas, &scene, q, config.transfer_stride, config.seed);
                res.transfer_point.write(&gpu.queue, &t.point);
                res.transfer_normal.write(&gpu.queue, &t.normal);
                Some((scene, t))
            }
            _ => None,
        };
        let shading_bg = Self::shading_bind_group(d, &shading, &camera_buf, &lighting_buf, &probes, &res);
        res.warp.write(&gpu.queue, &canvas.warp_footprint());
        res.normal.write(&gpu.queue, &receivers.normal);
        res.albedo.write(&gpu.queue, &receivers.albedo);
        res.ambient.write(&gpu.queue, &receivers.ambient);
        res.bounce.write(&gpu.queue, &receivers.bounce);
        res.ambient_with.write(&gpu.queue, &receivers.ambient_with);
        res.bounce_with.write(&gpu.queue, &receivers.bounce_with);
        Ok(Self {
            gpu,
            config,
            canvas,
            proxy_ray,
            receivers,
            volumes,
            virtual_bounds,
            res,
            camera_bg,
            lighting_buf,
            camera_buf,
            probes,
            shading_bg,
            proxy,
            virt,
            prepass,
            shadow,
            resolve,
            shading,
            mask,
            composite_layout,
            composite_bg,
            composites,
            stencil: None,
            switches: PassSwitches::default(),
            switched_off_reason: String::new(),
            warnings,
            frames: 0,
            with_ray,
            transfer,
            region: None,
            near_radius_m,
            near_pixels: None,
            receiver_pixels: None,
        })
    }

    fn shading_bind_group(
        d: &wgpu::Device,
        shading: &VirtualShading,
        camera: &wgpu::Buffer,
        lighting: &wgpu::Buffer,
        probes: &GpuProbes,
        res: &Resources,
    ) -> wgpu::BindGroup {
        d.create_bind_group(&wgpu::BindGroupDescriptor {
            label: Some("shading frame"),
            layout: &shading.frame_layout,
            entries: &[
                wgpu::BindGroupEntry { binding: 0, resource: camera.as_entire_binding() },
                wgpu::BindGroupEntry { binding: 1, resource: lighting.as_entire_binding() },
                wgpu::BindGroupEntry { binding: 2, resource: probes.header.as_entire_binding() },
                wgpu::BindGroupEntry { binding: 3, resource: probes.coeffs.as_entire_binding() },
                wgpu::BindGroupEntry { binding: 4, resource: probes.valid.as_entire_binding() },
                wgpu::BindGroupEntry { binding: 5, resource: wgpu::BindingResource::TextureView(&res.occlusion.view) },
                wgpu::BindGroupEntry { binding: 6, resource: wgpu::BindingResource::TextureView(&res.masks.resolved.view) },
                wgpu::BindGroupEntry { binding: 7, resource: wgpu::BindingResource::TextureView(&res.transfer_sky.view) },
                wgpu::BindGroupEntry { binding: 8, resource: wgpu::BindingResource::TextureView(&res.transfer_sun.view) },
                wgpu::BindGroupEntry { binding: 9, resource: wgpu::BindingResource::TextureView(&res.transfer_point.view) },
                wgpu::BindGroupEntry { binding: 10, resource: wgpu::BindingResource::TextureView(&res.transfer_normal.view) },
            ],
        })
    }

    /// Warnings from set-up (open or non-manifold occluders), one line each.
    pub fn warnings(&self) -> &[String] {
        &self.warnings
    }
    /// The canvas and lens warp.
    pub fn canvas(&self) -> &Canvas {
        &self.canvas
    }
    /// The per-pixel proxy data.
    pub fn receivers(&self) -> &Receivers {
        &self.receivers
    }
    /// The device.
    pub fn gpu(&self) -> &Arc<Gpu> {
        &self.gpu
    }
    /// The settings.
    pub fn config(&self) -> &CompositorConfig {
        &self.config
    }
    /// Changes the darkening model (takes effect on the next frame, which rebuilds its stencil
    /// so that the per-pixel data the new model needs is computed).
    pub fn set_darkening(&mut self, d: Darkening) {
        if self.config.darkening != d {
            self.config.darkening = d;
            self.invalidate();
        }
    }
    /// Switches passes on or off from the next frame on; the passes switched off are reported
    /// as skipped with `reason` (e.g. "turned off in the live view"). A change rebuilds the
    /// stencil on the next frame.
    pub fn set_switches(&mut self, switches: PassSwitches, reason: &str) {
        if self.switches != switches {
            self.switches = switches;
            self.invalidate();
        }
        self.switched_off_reason = reason.to_owned();
    }
    /// The pass switches.
    pub fn switches(&self) -> PassSwitches {
        self.switches
    }
    /// The shadow volumes.
    pub fn volumes(&self) -> &Volumes {
        &self.volumes
    }
    /// The virtual objects' per-pixel ambient transfer, when it is on.
    pub fn transfer(&self) -> Option<&ObjectTransfer> {
        self.transfer.as_ref().map(|(_, t)| t)
    }
    /// The bounding boxes of the virtual objects.
    pub fn virtual_bounds(&self) -> &[(Vec3, Vec3)] {
        &self.virtual_bounds
    }
    /// Forgets the stored stencil, so the next frame rebuilds everything.
    pub fn invalidate(&mut self) {
        self.stencil = None;
    }

    /// Replaces the probe grid (call when the lighting was relit).
    pub fn set_probes(&mut self, grid: &ProbeGrid) {
        if self.probes.fits(grid) {
            self.probes.write(&self.gpu.queue, grid);
        } else {
            self.probes = GpuProbes::new(&self.gpu.device, &self.gpu.queue, grid);
            self.shading_bg = Self::shading_bind_group(&self.gpu.device, &self.shading, &self.camera_buf, &self.lighting_buf, &self.probes, &self.res);
        }
    }

    /// Composites one frame offscreen and reads it back.
    pub fn render(&mut self, video: &VideoFrame, lighting: &Lighting) -> Result<(RenderedFrame, PassReport), RenderError> {
        let target = self.res.output.view.clone();
        let (encoder, mut report) = self.encode(video, lighting, &target, self.gpu.output_format, 1.0)?;
        let t = std::time::Instant::now();
        self.gpu.queue.submit([encoder.finish()]);
        self.gpu.wait()?;
        report.timings.gpu_ms += t.elapsed().as_secs_f64() * 1e3;
        let t = std::time::Instant::now();
        let bytes = read_texture(&self.gpu, &self.res.output.texture, self.gpu.output_texel_bytes())?;
        let data: Vec<[f32; 3]> = if self.gpu.output_texel_bytes() == 16 {
            bytemuck::cast_slice::<u8, [f32; 4]>(&bytes).iter().map(|p| [p[0], p[1], p[2]]).collect()
        } else {
            bytes.chunks_exact(8).map(|p| std::array::from_fn(|c| f32_from_f16(u16::from_le_bytes([p[2 * c], p[2 * c + 1]])))).collect()
        };
        let image = LinearImage { width: self.canvas.out_width, height: self.canvas.out_height, data };
        let masks = if self.config.debug_masks {
            let b = read_texture(&self.gpu, &self.res.output_masks.texture, 4)?;
            Some(bytemuck::cast_slice::<u8, [u8; 4]>(&b).to_vec())
        } else {
            None
        };
        report.timings.readback_ms = t.elapsed().as_secs_f64() * 1e3;
        report.ran.push(pass::READBACK);
        let precision = if self.gpu.output_texel_bytes() == 16 { 0.0 } else { HALF_PRECISION };
        Ok((RenderedFrame { image, masks, precision }, report))
    }

    /// Composites one frame into `view` (a window's surface texture of `format`), with the
    /// output scaled by `exposure`. Submits without waiting.
    pub fn render_to(&mut self, view: &wgpu::TextureView, format: wgpu::TextureFormat, exposure: f32, video: &VideoFrame, lighting: &Lighting) -> Result<PassReport, RenderError> {
        if !self.composites.contains_key(&format) {
            let c = Composite::new(&self.gpu.device, &self.composite_layout, format, None)?;
            self.composites.insert(format, c);
        }
        let (encoder, report) = self.encode(video, lighting, view, format, exposure)?;
        self.gpu.queue.submit([encoder.finish()]);
        Ok(report)
    }
}
