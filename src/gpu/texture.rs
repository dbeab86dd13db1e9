//! Textures: a 2D texture with its view ([`Tex`]) and a colour target that is rendered with MSAA
//! and resolved, or rendered directly without ([`Layer`]).

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
    /// A layer of `size` and `format` with `samples` MSAA samples (1: no MSAA target).
    pub fn new(device: &wgpu::Device, label: &str, size: (u32, u32), format: wgpu::TextureFormat, samples: u32) -> Self {
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
