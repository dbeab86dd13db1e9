//! Where a composited frame goes: the offscreen target is built into the [`Compositor`]
//! ([`Compositor::render`] reads it back); [`WindowTarget`] presents to a window surface with
//! the same passes, only the composite's output format and exposure differ.
//!
//! The window target takes any `wgpu::Surface` (created with
//! `gpu.instance.create_surface(window)`); it is compiled here and exercised only where a display
//! exists. `heliar live` does not use it today: it shows the read-back frame as an egui texture
//! (see `crate::live`); presenting straight to a surface is the route for a real GPU.

use super::frame::{PassReport, VideoFrame};
use super::{Compositor, RenderError};
use crate::gpu::Gpu;
use crate::lighting::Lighting;

/// A window surface configured for the compositor.
pub struct WindowTarget<'w> {
    surface: wgpu::Surface<'w>,
    config: wgpu::SurfaceConfiguration,
}

impl<'w> WindowTarget<'w> {
    /// Configures `surface` at `width × height`, preferring an sRGB format (the display then
    /// encodes the linear composite, which is what an sRGB camera response does).
    pub fn new(gpu: &Gpu, surface: wgpu::Surface<'w>, width: u32, height: u32) -> Result<Self, RenderError> {
        let mut config = surface
            .get_default_config(&gpu.adapter, width.max(1), height.max(1))
            .ok_or_else(|| crate::gpu::GpuError::Surface("the adapter cannot present to this surface".into()))?;
        let caps = surface.get_capabilities(&gpu.adapter);
        if let Some(f) = caps.formats.iter().find(|f| f.is_srgb()) {
            config.format = *f;
        }
        surface.configure(&gpu.device, &config);
        Ok(Self { surface, config })
    }

    /// Follows a window resize.
    pub fn resize(&mut self, gpu: &Gpu, width: u32, height: u32) {
        self.config.width = width.max(1);
        self.config.height = height.max(1);
        self.surface.configure(&gpu.device, &self.config);
    }

    /// Composites a frame into the window (scaled by the camera's `exposure`) and presents it.
    /// Returns `None` when the surface had no texture to give (occluded, timed out).
    pub fn present(&mut self, compositor: &mut Compositor, exposure: f32, video: &VideoFrame, lighting: &Lighting) -> Result<Option<PassReport>, RenderError> {
        let frame = match self.surface.get_current_texture() {
            wgpu::CurrentSurfaceTexture::Success(t) | wgpu::CurrentSurfaceTexture::Suboptimal(t) => t,
            wgpu::CurrentSurfaceTexture::Outdated | wgpu::CurrentSurfaceTexture::Lost => {
                self.surface.configure(&compositor.gpu().device, &self.config);
                return Ok(None);
            }
            _ => return Ok(None),
        };
        let view = frame.texture.create_view(&Default::default());
        let report = compositor.render_to(&view, self.config.format, exposure, video, lighting)?;
        compositor.gpu().queue.present(frame);
        Ok(Some(report))
    }
}
