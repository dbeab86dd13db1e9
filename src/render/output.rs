//! Composited frames to files, through the camera's response so that virtual parts match the
//! footage (Jensen's output is the augmented video itself).
//!
//! # How it works
//! The composite is scene radiance. For an LDR file it becomes camera codes the way the camera
//! made the footage: times the exposure, through the inverse response (sRGB, gamma, linear or
//! the calibrated table), clipped at full scale, quantised to the input's bit depth. Pixels the
//! composite left exactly as they came in keep their original codes, so untouched footage is
//! bit-identical. An EXR file holds camera-linear values (radiance × exposure, the units of the
//! input EXR frames).

use crate::io::IoError;
use crate::io::frames::{Frame, FrameData, Photometry, code_from_linear};
use crate::io::image::{ExrPrecision, LinearImage};
use std::path::Path;

use super::frame::VideoFrame;

/// Output file kinds.
#[derive(Clone, Copy, Debug, PartialEq, Eq, serde::Serialize)]
#[serde(rename_all = "snake_case")]
pub enum OutputKind {
    /// PNG through the camera response (8 or 16 bits, as the input).
    Png,
    /// OpenEXR, camera-linear, half floats.
    Exr,
}

impl OutputKind {
    /// File extension.
    pub fn extension(self) -> &'static str {
        match self {
            OutputKind::Png => "png",
            OutputKind::Exr => "exr",
        }
    }
}

/// Writes `image` (scene radiance) to `path`. `input` is the decoded footage frame and `video`
/// its linearisation: pixels where `image` equals `video` (within the relative `precision` of
/// the GPU output) keep the input's codes (LDR) or values (HDR).
pub fn write_frame(
    path: &Path,
    kind: OutputKind,
    image: &LinearImage,
    precision: f32,
    video: &VideoFrame,
    input: &Frame,
    photometry: &Photometry,
) -> Result<(), IoError> {
    let (w, h) = (image.width, image.height);
    match kind {
        OutputKind::Exr => camera_linear(image, precision, video, input, photometry).write_exr(path, ExrPrecision::Half),
        OutputKind::Png => {
            let (bits, out) = encode_codes(image, precision, video, input, photometry);
            let res = if bits == 16 {
                let bytes: Vec<u8> = out.iter().flat_map(|v| v.to_be_bytes()).collect();
                ::image::save_buffer(path, &bytes, w, h, ::image::ExtendedColorType::Rgb16)
            } else {
                let bytes: Vec<u8> = out.iter().map(|&v| v as u8).collect();
                ::image::save_buffer(path, &bytes, w, h, ::image::ExtendedColorType::Rgb8)
            };
            res.map_err(|source| IoError::Png { path: path.to_owned(), source })
        }
    }
}

/// `image` (scene radiance) as camera-linear values (radiance × exposure, the units of HDR
/// footage), what an EXR output holds: pixels the compositor left unchanged keep the input's own
/// values (HDR input).
pub fn camera_linear(image: &LinearImage, precision: f32, video: &VideoFrame, input: &Frame, photometry: &Photometry) -> LinearImage {
    let same = |i: usize| {
        let (o, v) = (image.data[i], video.rgba[i]);
        (0..3).all(|c| (o[c] - v[c]).abs() <= precision * v[c].abs())
    };
    let mut out = LinearImage::new(image.width, image.height);
    for i in 0..out.data.len() {
        out.data[i] = match (&input.data, same(i)) {
            (FrameData::Hdr(img), true) => img.data[i],
            _ => image.data[i].map(|c| c * photometry.exposure),
        };
    }
    out
}

/// `image` (scene radiance) as integer codes through the camera response: pixels the compositor
/// left unchanged keep the input's own codes (LDR input), the rest are encoded at the input's bit
/// depth (8 bits for HDR input). Returns the bit depth and the RGB codes, row-major.
pub fn encode_codes(image: &LinearImage, precision: f32, video: &VideoFrame, input: &Frame, photometry: &Photometry) -> (u32, Vec<u16>) {
    let (w, h) = (image.width, image.height);
    let same = |i: usize| {
        let (o, v) = (image.data[i], video.rgba[i]);
        (0..3).all(|c| (o[c] - v[c]).abs() <= precision * v[c].abs())
    };
    let (bits, codes) = match &input.data {
        FrameData::Ldr { bits, codes } => (*bits, Some(codes)),
        FrameData::Hdr(_) => (8, None),
    };
    let max = if bits == 16 { 65535.0 } else { 255.0 };
    let mut out: Vec<u16> = Vec::with_capacity((w * h * 3) as usize);
    for i in 0..(w * h) as usize {
        match codes {
            Some(c) if same(i) => out.extend_from_slice(&c[3 * i..3 * i + 3]),
            _ => {
                for ch in 0..3 {
                    let e = code_from_linear(&photometry.response, image.data[i][ch] * photometry.exposure, ch);
                    out.push((e * max + 0.5).floor().clamp(0.0, max) as u16);
                }
            }
        }
    }
    (bits as u32, out)
}

/// [`encode_codes`] as 8-bit RGB bytes (16-bit codes are scaled down), for video files.
pub fn encode_rgb8(image: &LinearImage, precision: f32, video: &VideoFrame, input: &Frame, photometry: &Photometry) -> Vec<u8> {
    let (bits, codes) = encode_codes(image, precision, video, input, photometry);
    if bits == 16 { codes.iter().map(|&v| ((v as u32 + 128) / 257).min(255) as u8).collect() } else { codes.iter().map(|&v| v as u8).collect() }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::io::frames::Response;

    #[test]
    fn inverse_responses_round_trip() {
        let table = Response::Table(vec![[0.0; 3], [0.1, 0.2, 0.3], [0.5, 0.5, 0.6], [1.0; 3]]);
        for r in [Response::Srgb, Response::Linear, Response::Gamma(2.2), table] {
            for ch in 0..3 {
                for k in 0..=20 {
                    let e = k as f32 / 20.0;
                    let back = code_from_linear(&r, r.linear(e, ch), ch);
                    assert!((back - e).abs() < 1e-4, "{r:?} ch {ch}: {e} -> {back}");
                }
            }
        }
        assert!((code_from_linear(&Response::Srgb, 7.0, 0) - 1.0).abs() < 1e-6);
        assert_eq!(code_from_linear(&Response::Srgb, f32::NAN, 0), 0.0);
    }
}
