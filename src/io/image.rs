//! Linear RGB images and their files: OpenEXR (linear, half or float) and PNG (8/16-bit sRGB).

use super::IoError;
use super::frames::{Photometry, code_from_linear};
use std::path::Path;

/// A linear-light RGB image, row-major, row 0 at the top.
#[derive(Clone, Debug, PartialEq)]
pub struct LinearImage {
    /// Width in pixels.
    pub width: u32,
    /// Height in pixels.
    pub height: u32,
    /// `width × height` RGB triples, row-major.
    pub data: Vec<[f32; 3]>,
}

/// Sample precision of an EXR file written by [`LinearImage::write_exr`].
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum ExrPrecision {
    /// 16-bit half floats (compact; about 3 significant digits).
    Half,
    /// 32-bit floats.
    Float,
}

impl LinearImage {
    /// A black image.
    pub fn new(width: u32, height: u32) -> Self {
        Self { width, height, data: vec![[0.0; 3]; (width * height) as usize] }
    }

    /// Builds an image from a function of `(x, y)`.
    pub fn from_fn(width: u32, height: u32, mut f: impl FnMut(u32, u32) -> [f32; 3]) -> Self {
        let mut data = Vec::with_capacity((width * height) as usize);
        for y in 0..height {
            for x in 0..width {
                data.push(f(x, y));
            }
        }
        Self { width, height, data }
    }

    /// The pixel at `(x, y)`.
    #[inline]
    pub fn get(&self, x: u32, y: u32) -> [f32; 3] {
        self.data[(y * self.width + x) as usize]
    }

    /// Sets the pixel at `(x, y)`.
    #[inline]
    pub fn set(&mut self, x: u32, y: u32, v: [f32; 3]) {
        let w = self.width;
        self.data[(y * w + x) as usize] = v;
    }

    /// Reads the first RGB(A) layer of an OpenEXR file (alpha is ignored; a missing B or G
    /// channel is an error).
    pub fn read_exr(path: &Path) -> Result<Self, IoError> {
        use exr::prelude::*;
        if !path.exists() {
            return Err(IoError::File {
                path: path.to_owned(),
                source: std::io::Error::new(std::io::ErrorKind::NotFound, "no such file"),
            });
        }
        // The header's size against the caps before the pixels are allocated.
        super::checked_header_size(path)?;
        let image = read_first_rgba_layer_from_file(
            path,
            |res, _| LinearImage::new(res.width() as u32, res.height() as u32),
            |img: &mut LinearImage, pos, (r, g, b, _a): (f32, f32, f32, f32)| {
                img.set(pos.x() as u32, pos.y() as u32, [r, g, b]);
            },
        )
        .map_err(|e| IoError::Exr { path: path.to_owned(), message: e.to_string() })?;
        Ok(image.layer_data.channel_data.pixels)
    }

    /// Writes an RGB OpenEXR file (ZIP compressed).
    pub fn write_exr(&self, path: &Path, precision: ExrPrecision) -> Result<(), IoError> {
        use exr::prelude::*;
        let (w, h) = (self.width as usize, self.height as usize);
        let err = |e: exr::error::Error| exr_write_error(path, e);
        let encoding = Encoding {
            compression: Compression::PIZ,
            blocks: Blocks::ScanLines,
            line_order: LineOrder::Increasing,
        };
        match precision {
            ExrPrecision::Float => {
                let channels = SpecificChannels::rgb(|p: Vec2<usize>| {
                    let v = self.data[p.y() * w + p.x()];
                    (v[0], v[1], v[2])
                });
                let layer = Layer::new((w, h), LayerAttributes::default(), encoding, channels);
                Image::from_layer(layer).write().to_file(path).map_err(err)
            }
            ExrPrecision::Half => {
                let channels = SpecificChannels::rgb(|p: Vec2<usize>| {
                    let v = self.data[p.y() * w + p.x()];
                    (f16::from_f32(v[0]), f16::from_f32(v[1]), f16::from_f32(v[2]))
                });
                let layer = Layer::new((w, h), LayerAttributes::default(), encoding, channels);
                Image::from_layer(layer).write().to_file(path).map_err(err)
            }
        }
    }

    /// Writes a four-channel float EXR (`R`, `G`, `B` from `self`, `A` from `alpha`), ZIP
    /// compressed; used for baked geometry (position + an integer id in alpha, exact below 2²⁴).
    pub fn write_exr_with_alpha(&self, alpha: &[f32], path: &Path) -> Result<(), IoError> {
        use exr::prelude::*;
        let (w, h) = (self.width as usize, self.height as usize);
        let channels = SpecificChannels::rgba(|p: Vec2<usize>| {
            let i = p.y() * w + p.x();
            let v = self.data[i];
            (v[0], v[1], v[2], alpha[i])
        });
        let encoding = Encoding { compression: Compression::ZIP16, blocks: Blocks::ScanLines, line_order: LineOrder::Increasing };
        let layer = Layer::new((w, h), LayerAttributes::default(), encoding, channels);
        Image::from_layer(layer)
            .write()
            .to_file(path)
            .map_err(|e| exr_write_error(path, e))
    }

    /// Reads an RGBA EXR written by [`LinearImage::write_exr_with_alpha`]: the image and its alpha.
    pub fn read_exr_with_alpha(path: &Path) -> Result<(Self, Vec<f32>), IoError> {
        use exr::prelude::*;
        if !path.exists() {
            return Err(IoError::File {
                path: path.to_owned(),
                source: std::io::Error::new(std::io::ErrorKind::NotFound, "no such file"),
            });
        }
        let image = read_first_rgba_layer_from_file(
            path,
            |res, _| (LinearImage::new(res.width() as u32, res.height() as u32), vec![0.0f32; res.width() * res.height()]),
            |(img, a): &mut (LinearImage, Vec<f32>), pos, (r, g, b, alpha): (f32, f32, f32, f32)| {
                let w = img.width as usize;
                img.set(pos.x() as u32, pos.y() as u32, [r, g, b]);
                a[pos.y() * w + pos.x()] = alpha;
            },
        )
        .map_err(|e| IoError::Exr { path: path.to_owned(), message: e.to_string() })?;
        Ok(image.layer_data.channel_data.pixels)
    }

    /// Writes an 8-bit sRGB PNG of `exposure · self`, clamped to `[0, 1]` (a preview; no tone
    /// curve beyond the sRGB encoding).
    pub fn write_png_srgb(&self, path: &Path, exposure: f32) -> Result<(), IoError> {
        let mut buf = Vec::with_capacity(self.data.len() * 3);
        for p in &self.data {
            for c in p {
                buf.push(srgb_u8_from_linear(c * exposure));
            }
        }
        ::image::save_buffer(path, &buf, self.width, self.height, ::image::ExtendedColorType::Rgb8)
            .map_err(|source| IoError::Png { path: path.to_owned(), source })
    }

    /// Resamples to `width × height` by area averaging (when shrinking by an integer factor) or
    /// nearest texel (otherwise). Used to sweep map resolutions.
    pub fn resized(&self, width: u32, height: u32) -> LinearImage {
        if self.width % width == 0 && self.height % height == 0 {
            let (fx, fy) = (self.width / width, self.height / height);
            return LinearImage::from_fn(width, height, |x, y| {
                let mut acc = [0.0f32; 3];
                for j in 0..fy {
                    for i in 0..fx {
                        let p = self.get(x * fx + i, y * fy + j);
                        for c in 0..3 {
                            acc[c] += p[c];
                        }
                    }
                }
                acc.map(|v| v / (fx * fy) as f32)
            });
        }
        LinearImage::from_fn(width, height, |x, y| {
            self.get(((x as u64 * self.width as u64) / width as u64) as u32, ((y as u64 * self.height as u64) / height as u64) as u32)
        })
    }

    /// Counts and replaces non-finite and negative pixels by zero; returns how many were replaced.
    pub fn sanitize(&mut self) -> usize {
        let mut n = 0;
        for p in &mut self.data {
            if p.iter().any(|c| !c.is_finite() || *c < 0.0) {
                *p = [0.0; 3];
                n += 1;
            }
        }
        n
    }
}

/// A failed EXR write, with the OS's reason when it was the file that failed.
fn exr_write_error(path: &Path, e: exr::error::Error) -> IoError {
    let reason = match e {
        exr::error::Error::Io(io) => io.to_string(),
        other => other.to_string(),
    };
    IoError::ExrWrite { path: path.to_owned(), reason }
}

/// The sRGB encoding (IEC 61966-2-1) of a linear value in `[0, 1]`.
pub fn srgb_from_linear(x: f32) -> f32 {
    if x <= 0.003_130_8 { 12.92 * x } else { 1.055 * x.powf(1.0 / 2.4) - 0.055 }
}

/// The linear value of an sRGB-encoded value in `[0, 1]`.
pub fn linear_from_srgb(x: f32) -> f32 {
    if x <= 0.040_45 { x / 12.92 } else { ((x + 0.055) / 1.055).powf(2.4) }
}

/// 8-bit sRGB code of a linear value (clamped, NaN → 0).
pub fn srgb_u8_from_linear(x: f32) -> u8 {
    let x = if x.is_nan() { 0.0 } else { x.clamp(0.0, 1.0) };
    (srgb_from_linear(x) * 255.0 + 0.5) as u8
}

/// An 8-bit RGB image for contact sheets.
#[derive(Clone, Debug, PartialEq)]
pub struct Rgb8 {
    /// Width.
    pub width: u32,
    /// Height.
    pub height: u32,
    /// RGB bytes, row-major.
    pub data: Vec<u8>,
}

impl Rgb8 {
    /// `image` through the camera response, as the PNG output would encode it.
    pub fn from_radiance(image: &LinearImage, photometry: &Photometry) -> Self {
        let data = image
            .data
            .iter()
            .flat_map(|p| (0..3).map(move |c| (code_from_linear(&photometry.response, p[c] * photometry.exposure, c) * 255.0 + 0.5).floor().clamp(0.0, 255.0) as u8))
            .collect();
        Self { width: image.width, height: image.height, data }
    }

    /// Box-filtered down to at most `max_width` pixels wide.
    pub fn shrink_to(&self, max_width: u32) -> Self {
        let k = self.width.div_ceil(max_width.max(1)).max(1);
        if k == 1 {
            return self.clone();
        }
        let (w, h) = (self.width / k, self.height / k);
        let mut data = Vec::with_capacity((w * h * 3) as usize);
        for y in 0..h {
            for x in 0..w {
                for c in 0..3 {
                    let mut s = 0u32;
                    for dy in 0..k {
                        for dx in 0..k {
                            s += self.data[(((y * k + dy) * self.width + x * k + dx) * 3 + c) as usize] as u32;
                        }
                    }
                    data.push((s / (k * k)) as u8);
                }
            }
        }
        Self { width: w, height: h, data }
    }
}

/// Tiles `images` (all the same size) into a grid `columns` wide with `gap` white pixels between
/// them, and writes it as PNG.
pub fn write_contact_sheet(path: &Path, images: &[Rgb8], columns: u32, gap: u32) -> Result<(), IoError> {
    let Some(first) = images.first() else { return Ok(()) };
    let (tw, th) = (first.width, first.height);
    let cols = columns.clamp(1, images.len() as u32);
    let rows = (images.len() as u32).div_ceil(cols);
    let (w, h) = (cols * tw + (cols - 1) * gap, rows * th + (rows - 1) * gap);
    let mut data = vec![255u8; (w * h * 3) as usize];
    for (k, img) in images.iter().enumerate() {
        let (cx, cy) = ((k as u32 % cols) * (tw + gap), (k as u32 / cols) * (th + gap));
        for y in 0..th.min(img.height) {
            let src = (y * img.width * 3) as usize;
            let dst = (((cy + y) * w + cx) * 3) as usize;
            let n = (tw.min(img.width) * 3) as usize;
            data[dst..dst + n].copy_from_slice(&img.data[src..src + n]);
        }
    }
    ::image::save_buffer(path, &data, w, h, ::image::ExtendedColorType::Rgb8).map_err(|source| IoError::Png { path: path.to_owned(), source })
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn srgb_round_trip() {
        for i in 0..=255u32 {
            let e = i as f32 / 255.0;
            assert!((srgb_from_linear(linear_from_srgb(e)) - e).abs() < 1e-5);
        }
    }

    #[test]
    fn exr_round_trip_float_and_half() {
        let dir = std::env::temp_dir().join(format!("heliar-exr-{}", std::process::id()));
        std::fs::create_dir_all(&dir).unwrap();
        let img = LinearImage::from_fn(7, 5, |x, y| [x as f32 * 1e3, y as f32 * 1e-3, 0.5]);
        let p = dir.join("a.exr");
        img.write_exr(&p, ExrPrecision::Float).unwrap();
        assert_eq!(LinearImage::read_exr(&p).unwrap(), img);
        img.write_exr(&p, ExrPrecision::Half).unwrap();
        let back = LinearImage::read_exr(&p).unwrap();
        for (a, b) in img.data.iter().zip(&back.data) {
            for c in 0..3 {
                // half floats keep 11 significant bits: relative error ≤ 2^-11
                assert!((a[c] - b[c]).abs() <= a[c].abs() * 4.9e-4 + 1e-7, "{a:?} {b:?}");
            }
        }
        std::fs::remove_dir_all(&dir).ok();
    }

    #[test]
    fn failed_exr_write_says_so_with_the_os_reason() {
        let p = std::env::temp_dir().join(format!("heliar-no-such-dir-{}", std::process::id())).join("out.exr");
        let e = LinearImage::new(2, 2).write_exr(&p, ExrPrecision::Half).unwrap_err().to_string();
        assert!(e.contains("out.exr") && e.contains("writing the OpenEXR image failed") && e.contains("No such file"), "{e}");
        assert!(!e.contains("readable"), "{e}");
    }

    #[test]
    fn corrupt_exr_names_the_file() {
        let dir = std::env::temp_dir().join(format!("heliar-exr-bad-{}", std::process::id()));
        std::fs::create_dir_all(&dir).unwrap();
        let p = dir.join("bad.exr");
        std::fs::write(&p, b"v/1\x01 definitely not an exr").unwrap();
        let e = LinearImage::read_exr(&p).unwrap_err().to_string();
        assert!(e.contains("bad.exr"), "{e}");
        std::fs::remove_dir_all(&dir).ok();
    }
}
