//! Setting the compositor up for one scene and camera: the occluders and their volumes, the
//! per-pixel proxy data, the objects' own occlusion and transfer, the GPU buffers, textures and
//! pipelines of every pass.

use super::receiver_update::ReceiverPixels;
use super::resources::Resources;
use super::stencil_cache::StencilCache;
use super::transfer::TransferPass;
use super::{Compositor, CompositorConfig, PassSwitches, SceneParts, Volumes};
use crate::geometry::Mesh;
use crate::geometry::ambient::TransportQuality;
use crate::geometry::raycast::RayScene;
use crate::gpu::canvas::{Canvas, camera_layout};
use crate::gpu::mesh::{ProxyBuffers, VirtualBuffers, VirtualVertex, material_layout, vertex_sources};
use crate::gpu::{Gpu, MASK_FORMAT};
use crate::irradiance::ProbeGrid;
use crate::render::RenderError;
use crate::render::composite::{self, Composite};
use crate::render::depth_prepass::DepthPrepass;
use crate::render::frame::LightingUniform;
use crate::render::object_transfer::{ObjectTransfer, TransferScene};
use crate::render::occluder::Occluder;
use crate::render::occlusion::virtual_occlusion;
use crate::render::probes::GpuProbes;
use crate::render::receivers::Receivers;
use crate::render::shadow_mask::ShadowMask;
use crate::render::shadow_volume::ShadowVolumePass;
use crate::render::stencil::StencilResolve;
use crate::render::virtual_shading::VirtualShading;
use crate::scene::Scene;
use glam::Vec3;
use std::collections::HashMap;
use std::sync::Arc;
use wgpu::util::DeviceExt;

/// The differential model computes `c_v`, `b_v` on real surfaces within this many bounding-box
/// half-diagonals of a virtual object (an object of that size then takes less than about 2% of
/// the sky's cosine-weighted solid angle), and at least [`MIN_NEAR_RADIUS_M`].
pub(super) const NEAR_RADIUS_HALF_DIAGONALS: f32 = 2.5;
/// Smallest radius of the differential model's region, metres.
pub(super) const MIN_NEAR_RADIUS_M: f32 = 1.0;

/// The occluders of the virtual objects and of the proxy, with their set-up warnings.
fn occluders(parts: &SceneParts) -> (Vec<Occluder>, Occluder, Vec<String>) {
    let virtual_occ: Vec<Occluder> = parts.objects.iter().map(|(name, mesh)| Occluder::new(mesh, name)).collect();
    let proxy_occ = Occluder::new(parts.proxy, &format!("real proxy {}", parts.proxy_name));
    let mut warnings: Vec<String> = virtual_occ.iter().flat_map(|o| o.warnings()).collect();
    warnings.extend(proxy_occ.warnings());
    (virtual_occ, proxy_occ, warnings)
}

/// The objects' own ambient occlusion per canvas pixel (1 everywhere without objects or rays).
pub(super) fn object_occlusion(canvas: &Canvas, scene: Option<&TransferScene>, config: &CompositorConfig) -> Vec<f32> {
    match (config.occlusion_rays, scene) {
        (rays @ 1.., Some(scene)) => {
            // The objects alone: the transfer scene holds them in one mesh already.
            virtual_occlusion(canvas, &RayScene::new(scene.objects.clone()), rays, config.seed)
        }
        _ => vec![1.0f32; (canvas.intrinsics.width * canvas.intrinsics.height) as usize],
    }
}

/// The objects' transfer over `scene` (none with `transfer_paths = 0`), its points and normals
/// uploaded.
fn object_transfer(canvas: &Canvas, scene: Option<TransferScene>, config: &CompositorConfig, res: &Resources, queue: &wgpu::Queue) -> Option<(TransferScene, ObjectTransfer)> {
    let scene = scene.filter(|_| config.transfer_paths > 0)?;
    let q = TransportQuality { paths: config.transfer_paths, max_bounces: config.transfer_bounces };
    let t = ObjectTransfer::new(canvas, &scene, q, config.transfer_stride, config.seed).with_budget(config.trace_paths_per_frame).with_sky(config.sky.clone());
    res.transfer_point.write(queue, &t.point);
    res.transfer_normal.write(queue, &t.normal);
    Some((scene, t))
}

/// The objects' per-vertex ambient from the visibility cuts (`cuts::frame`): four
/// `vec4<f32>` per vertex of the objects' vertex buffer, zero (unused) until an object moves.
fn cut_ambient_buffer(d: &wgpu::Device, vertices: usize) -> wgpu::Buffer {
    d.create_buffer(&wgpu::BufferDescriptor {
        label: Some("cut ambient"),
        size: (vertices.max(1) * std::mem::size_of::<super::VertexAmbient>()) as u64,
        usage: wgpu::BufferUsages::STORAGE | wgpu::BufferUsages::COPY_DST,
        mapped_at_creation: false,
    })
}

/// The uniform buffers and the camera bind group.
struct Uniforms {
    camera_buf: wgpu::Buffer,
    lighting_buf: wgpu::Buffer,
    camera_bg: wgpu::BindGroup,
}

impl Uniforms {
    fn new(d: &wgpu::Device, canvas: &Canvas, cam_layout: &wgpu::BindGroupLayout) -> Self {
        let camera_buf = d.create_buffer_init(&wgpu::util::BufferInitDescriptor {
            label: Some("camera"),
            contents: bytemuck::bytes_of(&canvas.uniform()),
            usage: wgpu::BufferUsages::UNIFORM | wgpu::BufferUsages::COPY_DST,
        });
        let lighting_buf = d.create_buffer(&wgpu::BufferDescriptor {
            label: Some("lighting"),
            size: std::mem::size_of::<LightingUniform>() as u64,
            usage: wgpu::BufferUsages::STORAGE | wgpu::BufferUsages::COPY_DST,
            mapped_at_creation: false,
        });
        let camera_bg = d.create_bind_group(&wgpu::BindGroupDescriptor {
            label: Some("camera"),
            layout: cam_layout,
            entries: &[wgpu::BindGroupEntry { binding: 0, resource: camera_buf.as_entire_binding() }],
        });
        Self { camera_buf, lighting_buf, camera_bg }
    }
}

/// The pipelines of the GPU passes.
struct Pipelines {
    prepass: DepthPrepass,
    shadow: ShadowVolumePass,
    resolve: StencilResolve,
    shading: VirtualShading,
    mask: ShadowMask,
    composite_layout: wgpu::BindGroupLayout,
    lamp_layout: wgpu::BindGroupLayout,
    composites: HashMap<wgpu::TextureFormat, Composite>,
}

impl Pipelines {
    fn new(gpu: &Gpu, cam_layout: &wgpu::BindGroupLayout, mat_layout: &wgpu::BindGroupLayout) -> Result<Self, RenderError> {
        let (d, df, s) = (&gpu.device, gpu.depth_format, gpu.samples);
        let composite_layout = composite::layout(d);
        let lamp_layout = crate::render::lamps::ground::data_layout(d);
        let mut composites = HashMap::new();
        composites.insert(gpu.output_format, Composite::new(d, &composite_layout, &lamp_layout, gpu.output_format, Some(MASK_FORMAT))?);
        Ok(Self {
            prepass: DepthPrepass::new(d, cam_layout, df, s, std::mem::size_of::<VirtualVertex>() as u64)?,
            shadow: ShadowVolumePass::new(d, cam_layout, df, s)?,
            resolve: StencilResolve::new(d, df, s)?,
            shading: VirtualShading::new(d, mat_layout, df, s)?,
            mask: ShadowMask::new(d, df, s)?,
            composite_layout,
            lamp_layout,
            composites,
        })
    }
}

impl Compositor {
    /// Sets up the compositor for a loaded scene, with its lamps when it has `[[lights]]`.
    /// `proxy_ray` is the proxy's BVH (the estimator's).
    /// In a scene where some objects have a motion and others do not, the movers are left out of
    /// the traced transfer, ambient occlusion and `c_v`, `b_v` (`kept`, issue 15 §5): the frame
    /// loop serves them from the visibility cuts from the first frame (`run::motion`).
    pub fn for_scene(gpu: Arc<Gpu>, scene: &Scene, proxy_ray: Arc<RayScene>, config: CompositorConfig) -> Result<Self, RenderError> {
        let objects = SceneParts::object_list(scene);
        let movers: Vec<bool> = scene.virtual_objects.iter().map(|o| o.motion.is_some()).collect();
        let mixed = movers.iter().any(|m| *m) && !movers.iter().all(|m| *m);
        let left_out = if mixed { movers } else { Vec::new() };
        let mut c = Self::leaving_out(gpu, &SceneParts::of(scene, &objects), proxy_ray, config, &left_out)?;
        if !scene.lights.is_empty() {
            let lamps = crate::lamps::Lamp::load_all(&scene.root.join(crate::scene::MANIFEST_FILE), &scene.lights)?;
            c.set_lamps(&lamps, crate::render::lamps::LampOptions::default())?;
        }
        Ok(c)
    }

    /// Sets up the compositor for a camera, a proxy and virtual objects. `proxy_ray` is the
    /// proxy's BVH.
    pub fn new(gpu: Arc<Gpu>, parts: &SceneParts, proxy_ray: Arc<RayScene>, config: CompositorConfig) -> Result<Self, RenderError> {
        Self::leaving_out(gpu, parts, proxy_ray, config, &[])
    }

    /// [`Self::new`], with the objects `left_out[k]` left out of the traced per-pixel transfer,
    /// the objects' ambient occlusion and the receivers' `c_v`, `b_v` (the movers of a scene whose
    /// other objects stand still; `kept`): the visibility cuts serve them from the first frame,
    /// and until they do they take the probe grid's ambient.
    pub fn leaving_out(gpu: Arc<Gpu>, parts: &SceneParts, proxy_ray: Arc<RayScene>, config: CompositorConfig, left_out: &[bool]) -> Result<Self, RenderError> {
        let canvas = Canvas::new(parts.camera, config.supersample);
        let receivers = Receivers::new(parts.camera, &proxy_ray, config.seed).with_budget(config.trace_paths_per_frame).with_sky(config.sky.clone());
        let (virtual_occ, proxy_occ, warnings) = occluders(parts);
        let virtual_bounds: Vec<(Vec3, Vec3)> = parts.objects.iter().filter_map(|(_, m)| m.bounds()).collect();
        let near_radius_m = virtual_bounds.iter().map(|(lo, hi)| (*hi - *lo).length() / 2.0 * NEAR_RADIUS_HALF_DIAGONALS).fold(MIN_NEAR_RADIUS_M, f32::max);
        let meshes: Vec<&Mesh> = parts.objects.iter().map(|(_, m)| *m).collect();
        let traced: Vec<&Mesh> = meshes.iter().enumerate().filter(|(k, _)| !left_out.get(*k).copied().unwrap_or(false)).map(|(_, m)| *m).collect();
        let transfer_scene = (!traced.is_empty()).then(|| TransferScene::new(parts.proxy, &traced));
        let with_ray = transfer_scene.as_ref().map(|t| t.world.clone());
        let closed: Vec<Vec<bool>> = virtual_occ.iter().zip(parts.objects).map(|(o, (_, m))| o.closed_triangles(m.triangles.len())).collect();
        let volumes = Volumes::new(&gpu, virtual_occ, proxy_occ, config.builder)?;
        let d = &gpu.device;
        let res = Resources::new(&gpu, (canvas.intrinsics.width, canvas.intrinsics.height), (canvas.out_width, canvas.out_height));
        let cam_layout = camera_layout(d);
        let uniforms = Uniforms::new(d, &canvas, &cam_layout);
        let mat_layout = material_layout(d);
        let virt = VirtualBuffers::new(d, &gpu.queue, &mat_layout, &meshes, &closed)?;
        let proxy = ProxyBuffers::new(d, parts.proxy);
        let p = Pipelines::new(&gpu, &cam_layout, &mat_layout)?;
        let composite_bg = res.composite_bind_group(d, &p.composite_layout, &uniforms.lighting_buf);
        let no_lamps_bg = crate::render::lamps::ground::empty_data(d, &p.lamp_layout);
        let probes = GpuProbes::new(d, &gpu.queue, &ProbeGrid::filled(Vec3::ZERO, Vec3::ZERO, 1.0, [[0.0; 3]; 9]));
        res.occlusion.write(&gpu.queue, &object_occlusion(&canvas, transfer_scene.as_ref(), &config));
        let transfer = TransferPass::new(object_transfer(&canvas, transfer_scene, &config, &res, &gpu.queue), config.bounce_rebuild_deg);
        let vertex_sources: Vec<Vec<u32>> = meshes.iter().map(|m| vertex_sources(m)).collect();
        let cut_ambient = cut_ambient_buffer(d, vertex_sources.iter().map(Vec::len).sum());
        let shading_bg = Self::shading_bind_group(d, &p.shading, &uniforms.camera_buf, &uniforms.lighting_buf, &probes, &res, &cut_ambient);
        res.write_receivers(&gpu.queue, &canvas, &receivers);
        let kept = super::kept::KeptTrace::new(virtual_bounds.clone(), left_out);
        Ok(Self {
            config,
            canvas,
            proxy_ray,
            receivers,
            volumes,
            virtual_bounds,
            res,
            camera_bg: uniforms.camera_bg,
            lighting_buf: uniforms.lighting_buf,
            camera_buf: uniforms.camera_buf,
            probes,
            shading_bg,
            proxy,
            virt,
            prepass: p.prepass,
            shadow: p.shadow,
            resolve: p.resolve,
            shading: p.shading,
            mask: p.mask,
            composite_layout: p.composite_layout,
            composite_bg,
            lamp_layout: p.lamp_layout,
            no_lamps_bg,
            composites: p.composites,
            stencil: StencilCache::default(),
            switches: PassSwitches::default(),
            switched_off_reason: String::new(),
            warnings,
            frames: 0,
            with_ray,
            transfer,
            receiver_pixels: ReceiverPixels::new(near_radius_m),
            mat_layout,
            owed_stencil: None,
            cut_ambient,
            vertex_sources,
            cuts: None,
            cut_cache: Default::default(),
            kept,
            lamps: None,
            lamp_bounce: None,
            ground_bounce: None,
            gpu,
        })
    }

    /// Group 0 of the shading pass: camera, lighting, probes, the objects' occlusion, the
    /// transfer textures and the per-vertex cut ambient.
    pub(super) fn shading_bind_group(
        d: &wgpu::Device,
        shading: &VirtualShading,
        camera: &wgpu::Buffer,
        lighting: &wgpu::Buffer,
        probes: &GpuProbes,
        res: &Resources,
        cut_ambient: &wgpu::Buffer,
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
                wgpu::BindGroupEntry { binding: 7, resource: wgpu::BindingResource::TextureView(&res.transfer_sky.view) },
                wgpu::BindGroupEntry { binding: 8, resource: wgpu::BindingResource::TextureView(&res.transfer_sun.view) },
                wgpu::BindGroupEntry { binding: 9, resource: wgpu::BindingResource::TextureView(&res.transfer_point.view) },
                wgpu::BindGroupEntry { binding: 10, resource: wgpu::BindingResource::TextureView(&res.transfer_normal.view) },
                wgpu::BindGroupEntry { binding: 11, resource: cut_ambient.as_entire_binding() },
                wgpu::BindGroupEntry { binding: 12, resource: wgpu::BindingResource::TextureView(&res.transfer_lamp.view) },
            ],
        })
    }
}
