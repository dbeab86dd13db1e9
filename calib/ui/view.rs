//! Images on screen: [`Picture`] (an image and its texture) and [`ImageView`], a zoomable,
//! pannable view that converts between screen positions and pixel coordinates (OpenCV
//! convention: the centre of the top-left pixel is `(0, 0)`).
//!
//! Scroll to zoom about the pointer, drag with the right or middle button to pan, double-click
//! with the middle button (or press Fit) to see the whole image.

use egui::{Color32, ColorImage, Pos2, Rect, Sense, Stroke, TextureHandle, TextureOptions, Vec2};
use glam::DVec2;
use heliar::opencv_calib::Rgb8;
use heliar::io::image::{LinearImage, srgb_u8_from_linear};

/// Textures larger than this (pixels per side) are shown downscaled; coordinates stay in full
/// resolution.
pub const MAX_TEXTURE_SIDE: u32 = 4096;
/// Largest zoom, screen points per image pixel over the fitted scale.
const MAX_ZOOM: f32 = 64.0;
/// Mid-grey (scene-referred 0.18) is shown at this multiple of the log-average luminance.
const KEY: f32 = 0.18;

/// An image with its (lazily uploaded) texture.
pub struct Picture {
    /// Full-resolution size in pixels, the space of all coordinates.
    pub size: [u32; 2],
    image: Option<ColorImage>,
    texture: Option<TextureHandle>,
    name: String,
    options: TextureOptions,
}

impl Picture {
    /// From 8-bit RGB (downscaled for display when larger than [`MAX_TEXTURE_SIDE`]).
    pub fn from_rgb8(name: &str, img: &Rgb8) -> Self {
        let small = thumbnail(img, MAX_TEXTURE_SIDE);
        let color = ColorImage::from_rgb([small.width as usize, small.height as usize], &small.data);
        Self { size: [img.width, img.height], image: Some(color), texture: None, name: name.to_owned(), options: TextureOptions::LINEAR }
    }

    /// The same picture standing for an image of `size` pixels (a thumbnail of a larger image).
    pub fn with_size(mut self, size: [u32; 2]) -> Self {
        self.size = size;
        self
    }

    /// From RGBA (not premultiplied) covering `size` pixels, drawn with nearest filtering (for
    /// tints and masks).
    pub fn from_rgba_nearest(name: &str, size: [u32; 2], map_size: [u32; 2], rgba: &[u8]) -> Self {
        let color = ColorImage::from_rgba_unmultiplied([map_size[0] as usize, map_size[1] as usize], rgba);
        Self { size, image: Some(color), texture: None, name: name.to_owned(), options: TextureOptions::NEAREST }
    }

    /// The texture, uploaded on first use.
    pub fn texture(&mut self, ctx: &egui::Context) -> egui::TextureId {
        if let Some(img) = self.image.take() {
            self.texture = Some(ctx.load_texture(&self.name, img, self.options));
        }
        self.texture.as_ref().map_or(egui::TextureId::default(), |t| t.id())
    }
}

/// A copy of `img` no larger than `max_side` pixels per side (box filter).
pub fn thumbnail(img: &Rgb8, max_side: u32) -> Rgb8 {
    let step = img.width.max(img.height).div_ceil(max_side.max(1)).max(1);
    if step == 1 {
        return img.clone();
    }
    let (w, h) = (img.width.div_ceil(step), img.height.div_ceil(step));
    let mut data = Vec::with_capacity((w * h * 3) as usize);
    for y in 0..h {
        for x in 0..w {
            let (mut acc, mut n) = ([0u32; 3], 0u32);
            for sy in y * step..((y + 1) * step).min(img.height) {
                for sx in x * step..((x + 1) * step).min(img.width) {
                    let i = ((sy * img.width + sx) * 3) as usize;
                    for c in 0..3 {
                        acc[c] += img.data[i + c] as u32;
                    }
                    n += 1;
                }
            }
            data.extend(acc.map(|a| (a / n.max(1)) as u8));
        }
    }
    Rgb8 { width: w, height: h, data }
}

/// Display encoding of a linear image: exposure from its log-average luminance (so any HDR
/// image shows its mid-tones), shifted by `ev` stops, clipped, sRGB.
pub fn srgb8_from_linear(img: &LinearImage, ev: f32) -> Rgb8 {
    let lum = |p: &[f32; 3]| 0.2126 * p[0] + 0.7152 * p[1] + 0.0722 * p[2];
    let (mut sum, mut n) = (0.0f64, 0usize);
    for p in img.data.iter().step_by((img.data.len() / 65_536).max(1)) {
        let l = lum(p);
        if l.is_finite() && l > 0.0 {
            sum += (l as f64).ln();
            n += 1;
        }
    }
    let avg = if n > 0 { (sum / n as f64).exp() as f32 } else { 1.0 };
    let scale = KEY / avg.max(1e-12) * 2f32.powf(ev);
    let data = img.data.iter().flat_map(|p| p.map(|v| srgb_u8_from_linear(if v.is_finite() { v * scale } else { 0.0 }))).collect();
    Rgb8 { width: img.width, height: img.height, data }
}

/// Where an image is on screen.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Transform {
    /// Screen rectangle of the whole image (may extend past the view).
    pub rect: Rect,
    /// Image size, pixels.
    pub size: [u32; 2],
    /// The visible part of the screen.
    pub clip: Rect,
}

impl Transform {
    /// Screen points per image pixel.
    pub fn scale(&self) -> f32 {
        self.rect.width() / self.size[0].max(1) as f32
    }

    /// Screen position of pixel coordinates `p`.
    pub fn screen_from_pixel(&self, p: DVec2) -> Pos2 {
        self.rect.min + Vec2::new((p.x + 0.5) as f32, (p.y + 0.5) as f32) * self.scale()
    }

    /// Pixel coordinates under the screen position `pos`.
    pub fn pixel_from_screen(&self, pos: Pos2) -> DVec2 {
        let v = (pos - self.rect.min) / self.scale();
        DVec2::new(v.x as f64 - 0.5, v.y as f64 - 0.5)
    }

    /// True when `p` lies on the image.
    pub fn on_image(&self, p: DVec2) -> bool {
        p.x >= -0.5 && p.y >= -0.5 && p.x <= self.size[0] as f64 - 0.5 && p.y <= self.size[1] as f64 - 0.5
    }

    /// A painter that draws only over the visible part of the image.
    pub fn image_painter(&self, ui: &egui::Ui) -> egui::Painter {
        ui.painter_at(self.rect.intersect(self.clip))
    }

    /// A polyline in pixel coordinates.
    pub fn polyline(&self, painter: &egui::Painter, pts: &[DVec2], stroke: Stroke) {
        if pts.len() > 1 {
            painter.line(pts.iter().map(|p| self.screen_from_pixel(*p)).collect(), stroke);
        }
    }

    /// A rectangle `x, y, w, h` of whole pixels.
    pub fn pixel_rect(&self, r: [i32; 4]) -> Rect {
        let min = self.screen_from_pixel(DVec2::new(r[0] as f64 - 0.5, r[1] as f64 - 0.5));
        Rect::from_min_size(min, Vec2::new(r[2] as f32, r[3] as f32) * self.scale())
    }
}

/// A zoomable view of a picture.
#[derive(Debug, Default)]
pub struct ImageView {
    zoom: f32,
    /// Continuous image coordinates (`[0, w] × [0, h]`) at the view's centre; `None`: centred.
    centre: Option<Vec2>,
    /// Where the image was drawn last frame (for tests and for mapping positions).
    pub last: Option<Transform>,
}

impl ImageView {
    /// Back to the whole image.
    pub fn fit(&mut self) {
        self.zoom = 1.0;
        self.centre = None;
    }

    /// Shows `pic` in the available space and returns the response (click and drag sensing)
    /// and where the image is.
    pub fn show(&mut self, ui: &mut egui::Ui, pic: &mut Picture) -> (egui::Response, Transform) {
        if self.zoom < 1.0 {
            self.zoom = 1.0;
        }
        let (view, response) = ui.allocate_exact_size(ui.available_size().max(Vec2::splat(64.0)), Sense::click_and_drag());
        let size = Vec2::new(pic.size[0].max(1) as f32, pic.size[1].max(1) as f32);
        let fit = (view.width() / size.x).min(view.height() / size.y);
        // Zoom about the pointer, pan with the secondary or middle button.
        if let Some(pointer) = response.hover_pos() {
            let scroll = ui.input(|i| i.smooth_scroll_delta.y);
            if scroll != 0.0 {
                let t = self.transform(view, fit, size, pic.size);
                let under = (pointer - t.rect.min) / t.scale();
                self.zoom = (self.zoom * (scroll * 0.003).exp()).clamp(1.0, MAX_ZOOM);
                let s = fit * self.zoom;
                self.centre = Some(under - (pointer - view.center()) / s);
            }
        }
        if response.dragged_by(egui::PointerButton::Secondary) || response.dragged_by(egui::PointerButton::Middle) {
            let s = fit * self.zoom;
            self.centre = Some(self.centre.unwrap_or(size / 2.0) - response.drag_delta() / s);
        }
        if response.double_clicked_by(egui::PointerButton::Middle) {
            self.fit();
        }
        if let Some(c) = &mut self.centre {
            *c = c.clamp(Vec2::ZERO, size);
        }
        let t = self.transform(view, fit, size, pic.size);
        let painter = ui.painter_at(view);
        painter.rect_filled(view, 0.0, Color32::from_gray(24));
        let uv = Rect::from_min_max(Pos2::ZERO, Pos2::new(1.0, 1.0));
        painter.image(pic.texture(ui.ctx()), t.rect, uv, Color32::WHITE);
        self.last = Some(t);
        (response, t)
    }

    fn transform(&self, view: Rect, fit: f32, size: Vec2, px: [u32; 2]) -> Transform {
        let s = fit * self.zoom.max(1.0);
        let centre = self.centre.unwrap_or(size / 2.0);
        let min = view.center() - centre * s;
        Transform { rect: Rect::from_min_size(min, size * s), size: px, clip: view }
    }
}

/// A cross marker with a label.
pub fn marker(painter: &egui::Painter, at: Pos2, colour: Color32, label: &str) {
    let s = Stroke::new(2.0, colour);
    painter.line_segment([at - Vec2::new(6.0, 0.0), at + Vec2::new(6.0, 0.0)], s);
    painter.line_segment([at - Vec2::new(0.0, 6.0), at + Vec2::new(0.0, 6.0)], s);
    if !label.is_empty() {
        painter.text(at + Vec2::new(6.0, -6.0), egui::Align2::LEFT_BOTTOM, label, egui::FontId::proportional(13.0), colour);
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn screen_and_pixel_coordinates_invert() {
        let t = Transform { rect: Rect::from_min_size(Pos2::new(10.0, 20.0), Vec2::new(640.0, 480.0)), size: [320, 240], clip: Rect::EVERYTHING };
        assert_eq!(t.scale(), 2.0);
        assert_eq!(t.screen_from_pixel(DVec2::new(0.0, 0.0)), Pos2::new(11.0, 21.0));
        let p = DVec2::new(123.25, 77.5);
        assert!((t.pixel_from_screen(t.screen_from_pixel(p)) - p).length() < 1e-4);
        assert!(t.on_image(DVec2::new(319.4, 239.4)) && !t.on_image(DVec2::new(319.6, 0.0)));
    }

    #[test]
    fn hdr_display_puts_the_log_average_at_mid_grey() {
        let img = LinearImage::from_fn(4, 1, |x, _| [[0.5f32, 2.0, 8.0, 32.0][x as usize]; 3]);
        let d = srgb8_from_linear(&img, 0.0);
        // Log-average 4.0 → scale 0.045: 2.0 → 0.09 → sRGB code ≈ 85, 8.0 → 0.36 → ≈ 161.
        assert!((d.data[3] as i32 - 85).abs() <= 1 && (d.data[6] as i32 - 161).abs() <= 1, "{:?}", d.data);
    }
}
