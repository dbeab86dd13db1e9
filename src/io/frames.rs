//! Camera frames as decoded from files, and their linearisation.
//!
//! A frame keeps the codes it was stored with (8/16-bit LDR) or its linear values (HDR EXR).
//! [`Linearizer`] turns a pixel into scaled linear radiance with the camera response and exposure,
//! and says whether the pixel is clipped or invalid. The estimator linearises only the pixels it
//! samples, so decoding stays the only per-frame cost that scales with the frame size.

use super::{IoError, image::LinearImage, image::linear_from_srgb, image::srgb_from_linear};
use std::path::{Path, PathBuf};

/// Pixel data of a decoded frame.
#[derive(Clone, Debug)]
pub enum FrameData {
    /// Integer codes from an LDR file, 3 per pixel, row-major.
    Ldr {
        /// Bits per sample: 8 or 16.
        bits: u8,
        /// The codes.
        codes: Vec<u16>,
    },
    /// Linear values from an HDR file.
    Hdr(LinearImage),
}

/// One decoded frame.
#[derive(Clone, Debug)]
pub struct Frame {
    /// Width in pixels.
    pub width: u32,
    /// Height in pixels.
    pub height: u32,
    /// The pixel data.
    pub data: FrameData,
}

/// How usable a pixel's value is.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum PixelState {
    /// A usable linear value.
    Ok,
    /// At least one channel is at or above the saturation level.
    Clipped,
    /// At least one channel is NaN, infinite or negative.
    Invalid,
}

/// A camera response curve: from normalised code value `e ∈ [0, 1]` to relative linear exposure.
#[derive(Clone, Debug, PartialEq)]
pub enum Response {
    /// The sRGB transfer function (IEC 61966-2-1).
    Srgb,
    /// Codes are linear.
    Linear,
    /// `linear = e^gamma`.
    Gamma(f32),
    /// A monotone table of linear values per channel at evenly spaced codes from 0 to 1
    /// (at least 2 rows), interpolated linearly.
    Table(Vec<[f32; 3]>),
}

impl Response {
    /// Relative linear value of normalised code `e` in channel `c`.
    pub fn linear(&self, e: f32, c: usize) -> f32 {
        match self {
            Response::Srgb => linear_from_srgb(e),
            Response::Linear => e,
            Response::Gamma(g) => e.max(0.0).powf(*g),
            Response::Table(t) => {
                let x = e.clamp(0.0, 1.0) * (t.len() - 1) as f32;
                let i = (x as usize).min(t.len() - 2);
                let f = x - i as f32;
                t[i][c] * (1.0 - f) + t[i + 1][c] * f
            }
        }
    }
}

/// The largest finite half-float value: the default HDR clip level.
pub const HALF_MAX: f32 = 65504.0;

/// Turns frame pixels into scaled linear radiance.
///
/// LDR: `radiance = response(code / max_code) / exposure`; a pixel is clipped when any channel's
/// code is at or above `saturation · max_code`. HDR: `radiance = value / exposure`; a pixel is
/// clipped when any channel is at or above `hdr_clip`, by default [`HALF_MAX`]: a half-float
/// EXR (what cameras and most renderers write) cannot hold more, so a value there is a clipped
/// one. Frames in 32-bit float with brighter diffuse surfaces set `response.hdr_clip = inf`.
#[derive(Clone, Debug)]
pub struct Linearizer {
    lut8: [Vec<f32>; 3],
    lut16: [Vec<f32>; 3],
    inv_exposure: f32,
    sat8: u16,
    sat16: u16,
    hdr_clip: f32,
    read_noise: ReadNoise,
}

/// Where the sensor's read noise comes from: the camera file's `response.read_noise`.
#[derive(Clone, Copy, Debug, PartialEq)]
pub enum ReadNoise {
    /// Absent: none (relative weights only) while the sun is up; at dusk and night (the sun at or
    /// below the horizon) the estimator measures it on each frame (`estimate::noise_level`).
    Unknown,
    /// A number: the standard deviation in linear camera units (after the response curve,
    /// before the exposure), ≥ 0. It always wins.
    Given(f32),
    /// `"auto"`: measured on each frame (`estimate::noise_level`).
    Auto,
}

impl Linearizer {
    /// Builds the lookup tables. `exposure` multiplies scene radiance into relative linear camera
    /// exposure; `saturation` is the fraction of the full code range treated as clipped.
    pub fn new(response: &Response, exposure: f32, saturation: f32, hdr_clip: Option<f32>) -> Self {
        let lut = |n: usize| -> [Vec<f32>; 3] {
            std::array::from_fn(|c| {
                (0..n).map(|i| response.linear(i as f32 / (n - 1) as f32, c)).collect()
            })
        };
        Self {
            lut8: lut(256),
            lut16: lut(65536),
            inv_exposure: 1.0 / exposure,
            sat8: (saturation * 255.0).ceil().min(255.0) as u16,
            sat16: (saturation * 65535.0).ceil().min(65535.0) as u16,
            hdr_clip: hdr_clip.unwrap_or(HALF_MAX),
            read_noise: ReadNoise::Given(0.0),
        }
    }

    /// The same tables with the sensor's read noise, as [`Photometry::read_noise`]
    /// ([`Linearizer::new`] has `Given(0)`: none).
    pub fn with_read_noise(mut self, read_noise: ReadNoise) -> Self {
        self.read_noise = read_noise;
        self
    }

    /// The read noise's standard deviation in scaled radiance (the units of [`Self::radiance`])
    /// when the calibration gives a number; 0 otherwise (see [`Self::read_noise_setting`]).
    pub fn read_noise(&self) -> f64 {
        match self.read_noise {
            ReadNoise::Given(v) => v as f64 * self.inv_exposure as f64,
            ReadNoise::Unknown | ReadNoise::Auto => 0.0,
        }
    }

    /// Where the read noise comes from.
    pub fn read_noise_setting(&self) -> ReadNoise {
        self.read_noise
    }

    /// The step in scaled radiance between the stored code nearest to `radiance` in channel `c`
    /// and the next one: the quantisation step of an LDR frame at that level; 0 for HDR frames.
    pub fn code_step(&self, frame: &Frame, radiance: f32, c: usize) -> f32 {
        let FrameData::Ldr { bits, .. } = frame.data else { return 0.0 };
        let lut = if bits == 8 { &self.lut8[c] } else { &self.lut16[c] };
        let x = radiance / self.inv_exposure;
        let i = lut.partition_point(|&v| v < x).clamp(1, lut.len() - 1);
        (lut[i] - lut[i - 1]) * self.inv_exposure
    }

    /// Linear radiance of pixel `index` (row-major) of `frame`, and whether it is usable.
    #[inline]
    pub fn radiance(&self, frame: &Frame, index: usize) -> ([f32; 3], PixelState) {
        match &frame.data {
            FrameData::Ldr { bits, codes } => {
                let (lut, sat) = if *bits == 8 { (&self.lut8, self.sat8) } else { (&self.lut16, self.sat16) };
                let k = &codes[3 * index..3 * index + 3];
                let v = [
                    lut[0][k[0] as usize] * self.inv_exposure,
                    lut[1][k[1] as usize] * self.inv_exposure,
                    lut[2][k[2] as usize] * self.inv_exposure,
                ];
                let state = if k.iter().any(|&c| c >= sat) { PixelState::Clipped } else { PixelState::Ok };
                (v, state)
            }
            FrameData::Hdr(img) => {
                let p = img.data[index];
                let v = [p[0] * self.inv_exposure, p[1] * self.inv_exposure, p[2] * self.inv_exposure];
                let state = if p.iter().any(|c| !c.is_finite() || *c < 0.0) {
                    PixelState::Invalid
                } else if p.iter().any(|&c| c >= self.hdr_clip) {
                    PixelState::Clipped
                } else {
                    PixelState::Ok
                };
                (v, state)
            }
        }
    }

    /// The whole frame in linear radiance (invalid pixels become 0).
    pub fn linear_image(&self, frame: &Frame) -> LinearImage {
        let mut img = LinearImage::new(frame.width, frame.height);
        for (i, p) in img.data.iter_mut().enumerate() {
            let (v, s) = self.radiance(frame, i);
            *p = if s == PixelState::Invalid { [0.0; 3] } else { v };
        }
        img
    }
}

impl Frame {
    /// Decodes an `.exr` (HDR, linear) or `.png` (8/16-bit LDR) file.
    pub fn load(path: &Path) -> Result<Frame, IoError> {
        let ext = path.extension().and_then(|e| e.to_str()).map(|e| e.to_ascii_lowercase());
        match ext.as_deref() {
            Some("exr") => {
                let img = LinearImage::read_exr(path)?;
                Ok(Frame { width: img.width, height: img.height, data: FrameData::Hdr(img) })
            }
            Some("png") => {
                super::checked_header_size(path)?;
                let img = ::image::open(path).map_err(|source| match source {
                    ::image::ImageError::IoError(e) => IoError::File { path: path.to_owned(), source: e },
                    source => IoError::Png { path: path.to_owned(), source },
                })?;
                let (width, height) = (img.width(), img.height());
                let sixteen = matches!(
                    img.color(),
                    ::image::ColorType::Rgb16 | ::image::ColorType::Rgba16 | ::image::ColorType::L16 | ::image::ColorType::La16
                );
                let data = if sixteen {
                    FrameData::Ldr { bits: 16, codes: img.to_rgb16().into_raw() }
                } else {
                    FrameData::Ldr { bits: 8, codes: img.to_rgb8().into_raw().into_iter().map(u16::from).collect() }
                };
                Ok(Frame { width, height, data })
            }
            _ => Err(IoError::UnsupportedFormat { path: path.to_owned() }),
        }
    }

    /// [`Frame::load`] for a frame that must be `want_w × want_h` (the camera's size): the
    /// header's size is checked before the pixels are decoded.
    pub fn load_sized(path: &Path, want_w: u32, want_h: u32) -> Result<Frame, IoError> {
        let (w, h) = super::checked_header_size(path)?;
        if (w, h) != (want_w, want_h) {
            return Err(IoError::Size { path: path.to_owned(), got_w: w, got_h: h, want_w, want_h });
        }
        let frame = Frame::load(path)?;
        frame.check_size(path, want_w, want_h)?;
        Ok(frame)
    }

    /// Checks the frame against the calibrated size.
    pub fn check_size(&self, path: &Path, want_w: u32, want_h: u32) -> Result<(), IoError> {
        if (self.width, self.height) != (want_w, want_h) {
            return Err(IoError::Size {
                path: path.to_owned(),
                got_w: self.width,
                got_h: self.height,
                want_w,
                want_h,
            });
        }
        Ok(())
    }
}

/// The `.exr` and `.png` files of a folder, sorted by name.
pub fn list_frame_files(dir: &Path) -> Result<Vec<PathBuf>, IoError> {
    let rd = std::fs::read_dir(dir).map_err(|source| IoError::File { path: dir.to_owned(), source })?;
    let mut files: Vec<PathBuf> = rd
        .filter_map(|e| e.ok().map(|e| e.path()))
        .filter(|p| {
            p.extension()
                .and_then(|e| e.to_str())
                .is_some_and(|e| e.eq_ignore_ascii_case("exr") || e.eq_ignore_ascii_case("png"))
        })
        .collect();
    files.sort();
    Ok(files)
}

/// Photometric calibration of a sequence's frames.
#[derive(Clone, Debug, PartialEq)]
pub struct Photometry {
    /// Response curve of LDR codes.
    pub response: Response,
    /// Camera linear value per unit scene radiance (LDR and HDR).
    pub exposure: f32,
    /// Fraction of the LDR code range treated as clipped.
    pub saturation: f32,
    /// HDR values at or above this are treated as clipped.
    pub hdr_clip: Option<f32>,
    /// The sensor's read noise: a standard deviation in linear camera units (after the response
    /// curve, before the exposure), or measured on the frames. The estimator's fit weights rows
    /// by it and models values clipped at zero (`estimate::noise`).
    pub read_noise: ReadNoise,
}

impl Photometry {
    /// Lookup tables for this calibration.
    pub fn linearizer(&self) -> Linearizer {
        Linearizer::new(&self.response, self.exposure, self.saturation, self.hdr_clip).with_read_noise(self.read_noise)
    }
}

/// The normalised code in `[0, 1]` of a relative linear camera value, inverting `response`.
pub fn code_from_linear(response: &Response, x: f32, channel: usize) -> f32 {
    let x = if x.is_nan() { 0.0 } else { x.max(0.0) };
    match response {
        Response::Srgb => srgb_from_linear(x.min(1.0)),
        Response::Linear => x.min(1.0),
        Response::Gamma(g) => x.min(1.0).powf(1.0 / g),
        Response::Table(t) => {
            let col = |i: usize| t[i][channel];
            let n = t.len();
            if x <= col(0) {
                return 0.0;
            }
            if x >= col(n - 1) {
                return 1.0;
            }
            // First row at or above x (the table is monotone non-decreasing).
            let hi = (0..n).find(|&i| col(i) >= x).unwrap_or(n - 1).max(1);
            let (a, b) = (col(hi - 1), col(hi));
            let f = if b > a { (x - a) / (b - a) } else { 0.0 };
            ((hi - 1) as f32 + f) / (n - 1) as f32
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn ldr_linearisation_and_clipping() {
        let frame = Frame {
            width: 2,
            height: 1,
            data: FrameData::Ldr { bits: 8, codes: vec![128, 128, 128, 255, 10, 10] },
        };
        let lin = Linearizer::new(&Response::Srgb, 0.5, 0.98, None);
        let (v, s) = lin.radiance(&frame, 0);
        assert_eq!(s, PixelState::Ok);
        assert!((v[0] - linear_from_srgb(128.0 / 255.0) * 2.0).abs() < 1e-6);
        assert_eq!(lin.radiance(&frame, 1).1, PixelState::Clipped);
    }

    #[test]
    fn hdr_nan_and_inf_are_invalid() {
        let img = LinearImage { width: 3, height: 1, data: vec![[1.0; 3], [f32::NAN, 0.0, 0.0], [0.0, f32::INFINITY, 0.0]] };
        let frame = Frame { width: 3, height: 1, data: FrameData::Hdr(img) };
        let lin = Linearizer::new(&Response::Linear, 1.0, 1.0, Some(100.0));
        assert_eq!(lin.radiance(&frame, 0).1, PixelState::Ok);
        assert_eq!(lin.radiance(&frame, 1).1, PixelState::Invalid);
        assert_eq!(lin.radiance(&frame, 2).1, PixelState::Invalid);
    }

    #[test]
    fn table_response_interpolates() {
        let r = Response::Table(vec![[0.0; 3], [0.25, 0.5, 1.0], [1.0; 3]]);
        assert!((r.linear(0.25, 0) - 0.125).abs() < 1e-6);
        assert!((r.linear(0.75, 2) - 1.0).abs() < 1e-6);
    }
}
