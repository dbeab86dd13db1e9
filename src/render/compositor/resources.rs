//! Textures of the compositor: the MSAA canvas (depth-stencil, virtual layer, masks and their
//! resolves), the footage-sized inputs of the composite (video, proxy data, lens warp) and the
//! offscreen output.

use crate::gpu::canvas::Canvas;
use crate::gpu::texture::{Layer, Tex};
use crate::render::receivers::Receivers;
use crate::gpu::{Gpu, LAYER_FORMAT, MASK_FORMAT};

/// Every texture of the compositor.
pub struct Resources {
    /// Canvas depth-stencil (MSAA).
    pub depth: Tex,
    /// Virtual objects, premultiplied.
    pub layer: Layer,
    /// Shadow classes.
    pub masks: Layer,
    /// Footage, linear (`Rgba32Float`).
    pub video: Tex,
    /// Proxy normal per footage pixel.
    pub normal: Tex,
    /// Weighted ambient `c`.
    pub ambient: Tex,
    /// Sun bounce `b`.
    pub bounce: Tex,
    /// Proxy albedo.
    pub albedo: Tex,
    /// `c_v`.
    pub ambient_with: Tex,
    /// `b_v`.
    pub bounce_with: Tex,
    /// Proxy point per footage pixel, `w = 1` where there is one (the lamps' shadows on real
    /// receivers, `render::lamps::ground`).
    pub point: Tex,
    /// The lamps' bounce `Σ k_i·B_i` at the real receivers, zero without lamps
    /// (`render::lamps::ground_bounce`).
    pub lamp_bounce: Tex,
    /// `Σ k_i·B_{v,i}`: the same with the objects present.
    pub lamp_bounce_with: Tex,
    /// Lens warp and footprint ([`crate::gpu::canvas::Canvas::warp_footprint`]).
    pub warp: Tex,
    /// Offscreen output (`Rgba32Float`).
    pub output: Tex,
    /// Warped masks (debug, `Rgba8Unorm`).
    pub output_masks: Tex,
    /// Virtual objects' own ambient occlusion per canvas pixel (`R32Float`).
    pub occlusion: Tex,
    /// Transfer `R_a` per canvas pixel, `a = 1` where there is an entry (`Rgba32Float`).
    pub transfer_sky: Tex,
    /// Transfer `R_d` per canvas pixel.
    pub transfer_sun: Tex,
    /// The lamps' bounce `Σ k_i·R_i` per canvas pixel, zero without lamps
    /// (`render::object_transfer::lamps`).
    pub transfer_lamp: Tex,
    /// Surface point of the transfer entry, `w` its footprint radius (metres).
    pub transfer_point: Tex,
    /// Shading normal of the transfer entry.
    pub transfer_normal: Tex,
    /// Sampler of the canvas layers.
    pub sampler: wgpu::Sampler,
}

impl Resources {
    /// Creates the textures for a canvas of `canvas` pixels and footage of `out` pixels.
    pub fn new(gpu: &Gpu, canvas: (u32, u32), out: (u32, u32)) -> Self {
        let d = &gpu.device;
        let input = wgpu::TextureUsages::TEXTURE_BINDING | wgpu::TextureUsages::COPY_DST;
        let f32x4 = wgpu::TextureFormat::Rgba32Float;
        let target = wgpu::TextureUsages::RENDER_ATTACHMENT | wgpu::TextureUsages::COPY_SRC;
        Self {
            depth: Tex::new(d, "canvas depth-stencil", canvas, gpu.depth_format, gpu.samples, wgpu::TextureUsages::RENDER_ATTACHMENT),
            layer: Layer::new(d, "virtual layer", canvas, LAYER_FORMAT, gpu.samples),
            masks: Layer::new(d, "shadow masks", canvas, MASK_FORMAT, gpu.samples),
            video: Tex::new(d, "video", out, f32x4, 1, input),
            normal: Tex::new(d, "proxy normal", out, f32x4, 1, input),
            ambient: Tex::new(d, "proxy c", out, f32x4, 1, input),
            bounce: Tex::new(d, "proxy b", out, f32x4, 1, input),
            albedo: Tex::new(d, "proxy albedo", out, f32x4, 1, input),
            ambient_with: Tex::new(d, "proxy c with objects", out, f32x4, 1, input),
            bounce_with: Tex::new(d, "proxy b with objects", out, f32x4, 1, input),
            warp: Tex::new(d, "lens warp", out, f32x4, 1, input),
            point: Tex::new(d, "proxy point", out, f32x4, 1, input),
            lamp_bounce: Tex::new(d, "proxy lamp bounce", out, f32x4, 1, input),
            lamp_bounce_with: Tex::new(d, "proxy lamp bounce with objects", out, f32x4, 1, input),
            output: Tex::new(d, "output", out, gpu.output_format, 1, target),
            output_masks: Tex::new(d, "output masks", out, MASK_FORMAT, 1, target),
            occlusion: Tex::new(d, "virtual occlusion", canvas, wgpu::TextureFormat::R32Float, 1, input),
            transfer_sky: Tex::new(d, "transfer R_a", canvas, f32x4, 1, input),
            transfer_sun: Tex::new(d, "transfer R_d", canvas, f32x4, 1, input),
            transfer_lamp: Tex::new(d, "transfer lamp bounce", canvas, f32x4, 1, input),
            transfer_point: Tex::new(d, "transfer point", canvas, f32x4, 1, input),
            transfer_normal: Tex::new(d, "transfer normal", canvas, f32x4, 1, input),
            sampler: d.create_sampler(&wgpu::SamplerDescriptor {
                label: Some("canvas"),
                mag_filter: wgpu::FilterMode::Linear,
                min_filter: wgpu::FilterMode::Linear,
                ..Default::default()
            }),
        }
    }

    /// The composite bind group.
    pub fn composite_bind_group(&self, device: &wgpu::Device, layout: &wgpu::BindGroupLayout, lighting: &wgpu::Buffer) -> wgpu::BindGroup {
        let views = [
            &self.video,
            &self.normal,
            &self.ambient,
            &self.bounce,
            &self.albedo,
            &self.ambient_with,
            &self.bounce_with,
            &self.warp,
            &self.layer.resolved,
            &self.masks.resolved,
        ];
        let mut entries: Vec<wgpu::BindGroupEntry> =
            views.iter().enumerate().map(|(i, t)| wgpu::BindGroupEntry { binding: i as u32, resource: wgpu::BindingResource::TextureView(&t.view) }).collect();
        let n = views.len() as u32;
        entries.push(wgpu::BindGroupEntry { binding: n, resource: wgpu::BindingResource::Sampler(&self.sampler) });
        entries.push(wgpu::BindGroupEntry { binding: n + 1, resource: lighting.as_entire_binding() });
        entries.push(wgpu::BindGroupEntry { binding: n + 2, resource: wgpu::BindingResource::TextureView(&self.point.view) });
        entries.push(wgpu::BindGroupEntry { binding: n + 3, resource: wgpu::BindingResource::TextureView(&self.lamp_bounce.view) });
        entries.push(wgpu::BindGroupEntry { binding: n + 4, resource: wgpu::BindingResource::TextureView(&self.lamp_bounce_with.view) });
        device.create_bind_group(&wgpu::BindGroupDescriptor { label: Some("composite"), layout, entries: &entries })
    }

    /// Uploads the canvas's lens warp and footprint and the proxy's per-pixel data.
    pub fn write_receivers(&self, queue: &wgpu::Queue, canvas: &Canvas, receivers: &Receivers) {
        self.warp.write(queue, &canvas.warp_footprint());
        self.normal.write(queue, &receivers.normal);
        let points: Vec<[f32; 4]> = receivers.point.iter().map(|p| p.map_or([0.0; 4], |p| [p.x, p.y, p.z, 1.0])).collect();
        self.point.write(queue, &points);
        self.albedo.write(queue, &receivers.albedo);
        self.ambient.write(queue, &receivers.ambient);
        self.bounce.write(queue, &receivers.bounce);
        self.ambient_with.write(queue, &receivers.ambient_with);
        self.bounce_with.write(queue, &receivers.bounce_with);
    }
}
