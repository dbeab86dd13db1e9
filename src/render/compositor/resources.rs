//! Textures of the compositor: the MSAA canvas (depth-stencil, virtual layer, masks and their
//! resolves), the footage-sized inputs of the composite (video, proxy data, lens warp) and the
//! offscreen output with its readback.

use crate::render::RenderError;
use crate::render::gpu::{Gpu, LAYER_FORMAT, MASK_FORMAT};

/// Bytes per row of a buffer copy must be a multiple of this.
const COPY_ALIGN: u32 = wgpu::COPY_BYTES_PER_ROW_ALIGNMENT;

/// A 2D texture and its default view.
pub struct Tex {
    /// The texture.
    pub texture: wgpu::Texture,
    /// Its view.
    pub view: wgpu::TextureView,
}

impl Tex {
    /// Creates a texture.
    pub fn new(device: &wgpu::Device, label: &str, (w, h): (u32, u32), format: wgpu::TextureFormat, samples: u32, usage: wgpu::TextureUsages) -> Self {
        let texture = device.create_texture(&wgpu::TextureDescriptor {
            label: Some(label),
            size: wgpu::Extent3d { width: w.max(1), height: h.max(1), depth_or_array_layers: 1 },
            mip_level_count: 1,
            sample_count: samples,
            dimension: wgpu::TextureDimension::D2,
            format,
            usage,
            view_formats: &[],
        });
        let view = texture.create_view(&Default::default());
        Self { texture, view }
    }

    /// Uploads tightly packed texels covering the whole texture.
    pub fn write<T: bytemuck::Pod>(&self, queue: &wgpu::Queue, texels: &[T]) {
        let size = self.texture.size();
        let bpp = std::mem::size_of::<T>() as u32;
        queue.write_texture(
            self.texture.as_image_copy(),
            bytemuck::cast_slice(texels),
            wgpu::TexelCopyBufferLayout { offset: 0, bytes_per_row: Some(size.width * bpp), rows_per_image: Some(size.height) },
            size,
        );
    }
}

/// A colour target rendered with MSAA and resolved, or rendered directly without.
pub struct Layer {
    /// The multisampled target (when MSAA is on).
    pub msaa: Option<Tex>,
    /// The single-sample result the composite samples.
    pub resolved: Tex,
}

impl Layer {
    fn new(device: &wgpu::Device, label: &str, size: (u32, u32), format: wgpu::TextureFormat, samples: u32) -> Self {
        let usage = wgpu::TextureUsages::RENDER_ATTACHMENT | wgpu::TextureUsages::TEXTURE_BINDING | wgpu::TextureUsages::COPY_SRC;
        Self {
            msaa: (samples > 1).then(|| Tex::new(device, label, size, format, samples, wgpu::TextureUsages::RENDER_ATTACHMENT)),
            resolved: Tex::new(device, label, size, format, 1, usage),
        }
    }

    /// The attachment that clears to zero, draws, and resolves.
    pub fn attachment(&self) -> wgpu::RenderPassColorAttachment<'_> {
        let (view, resolve_target) = match &self.msaa {
            Some(m) => (&m.view, Some(&self.resolved.view)),
            None => (&self.resolved.view, None),
        };
        wgpu::RenderPassColorAttachment {
            view,
            depth_slice: None,
            resolve_target,
            ops: wgpu::Operations {
                load: wgpu::LoadOp::Clear(wgpu::Color::TRANSPARENT),
                store: if self.msaa.is_some() { wgpu::StoreOp::Discard } else { wgpu::StoreOp::Store },
            },
        }
    }
}

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
    /// Lens warp and footprint ([`crate::render::camera::Canvas::warp_footprint`]).
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
            output: Tex::new(d, "output", out, gpu.output_format, 1, target),
            output_masks: Tex::new(d, "output masks", out, MASK_FORMAT, 1, target),
            occlusion: Tex::new(d, "virtual occlusion", canvas, wgpu::TextureFormat::R32Float, 1, input),
            transfer_sky: Tex::new(d, "transfer R_a", canvas, f32x4, 1, input),
            transfer_sun: Tex::new(d, "transfer R_d", canvas, f32x4, 1, input),
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
        device.create_bind_group(&wgpu::BindGroupDescriptor { label: Some("composite"), layout, entries: &entries })
    }
}

/// Copies `texture` into a new mappable buffer, waits, and returns the rows without padding.
pub fn read_texture(gpu: &Gpu, texture: &wgpu::Texture, bytes_per_texel: u32) -> Result<Vec<u8>, RenderError> {
    let size = texture.size();
    let row = size.width * bytes_per_texel;
    let padded = row.div_ceil(COPY_ALIGN) * COPY_ALIGN;
    let buffer = gpu.device.create_buffer(&wgpu::BufferDescriptor {
        label: Some("readback"),
        size: padded as u64 * size.height as u64,
        usage: wgpu::BufferUsages::COPY_DST | wgpu::BufferUsages::MAP_READ,
        mapped_at_creation: false,
    });
    let mut enc = gpu.device.create_command_encoder(&Default::default());
    enc.copy_texture_to_buffer(
        texture.as_image_copy(),
        wgpu::TexelCopyBufferInfo {
            buffer: &buffer,
            layout: wgpu::TexelCopyBufferLayout { offset: 0, bytes_per_row: Some(padded), rows_per_image: Some(size.height) },
        },
        size,
    );
    gpu.queue.submit([enc.finish()]);
    read_buffer(gpu, &buffer, row, padded, size.height)
}

/// Maps `buffer` (rows of `padded` bytes) and returns `height` rows of `row` bytes.
pub fn read_buffer(gpu: &Gpu, buffer: &wgpu::Buffer, row: u32, padded: u32, height: u32) -> Result<Vec<u8>, RenderError> {
    let slice = buffer.slice(..);
    let (tx, rx) = std::sync::mpsc::channel();
    slice.map_async(wgpu::MapMode::Read, move |r| {
        let _ = tx.send(r);
    });
    gpu.wait()?;
    rx.recv().map_err(|e| RenderError::Device(e.to_string()))?.map_err(|e| RenderError::Device(e.to_string()))?;
    let data = slice.get_mapped_range().map_err(|e| RenderError::Device(e.to_string()))?;
    let mut out = Vec::with_capacity((row * height) as usize);
    for y in 0..height as usize {
        out.extend_from_slice(&data[y * padded as usize..y * padded as usize + row as usize]);
    }
    drop(data);
    buffer.unmap();
    Ok(out)
}

/// Copies the first `size` bytes of `buffer` (which needs `COPY_SRC`) to the CPU.
pub fn read_buffer_bytes(gpu: &Gpu, buffer: &wgpu::Buffer, size: u64) -> Result<Vec<u8>, RenderError> {
    let size = size.max(4).next_multiple_of(4);
    let staging = gpu.device.create_buffer(&wgpu::BufferDescriptor {
        label: Some("readback"),
        size,
        usage: wgpu::BufferUsages::COPY_DST | wgpu::BufferUsages::MAP_READ,
        mapped_at_creation: false,
    });
    let mut enc = gpu.device.create_command_encoder(&Default::default());
    enc.copy_buffer_to_buffer(buffer, 0, &staging, 0, size);
    gpu.queue.submit([enc.finish()]);
    read_buffer(gpu, &staging, size as u32, size as u32, 1)
}
