//! Calibration with OpenCV (feature `opencv`): what the calibration tool (`calib/`) needs to turn
//! photographs of a place into a scene folder.
//!
//! - [`chessboard`]: intrinsics and distortion from chessboard views (OpenCV calib3d): the
//!   Brown–Conrady pinhole model of the scene camera, or the Kannala–Brandt fisheye model, with the
//!   RMS reprojection error.
//! - [`pose`]: the camera pose against the proxy from clicked 2D–3D pairs (`solvePnP`).
//! - [`hdr`]: HDR images from bracketed exposures (Debevec & Malik 1997 response recovery and
//!   merge, OpenCV photo), two fisheye shots stitched into an equirect map, and removal of the lens
//!   frame's reflection by seamless cloning (Cyberworlds §IV).

pub mod chessboard;
pub mod hdr;
pub mod pose;

use opencv::core::{Mat, Vec3b, Vec3f};
use opencv::prelude::*;

/// Errors of the calibration steps.
#[derive(Debug, thiserror::Error)]
pub enum OpenCvCalibError {
    /// OpenCV reported an error.
    #[error("OpenCV: {0}")]
    OpenCv(#[from] opencv::Error),
    /// The input is unusable; the message says what and where.
    #[error("{0}")]
    Input(String),
}

/// An 8-bit RGB image, row-major (the compositor's type; the calibration adds file and OpenCV
/// conversions).
pub use crate::io::image::Rgb8;

impl Rgb8 {
    /// Reads an image file as RGB: PNG through the `image` crate, and JPEG, TIFF, BMP and the
    /// other formats OpenCV's imgcodecs reads (phone and camera photographs) through OpenCV.
    pub fn open(path: &std::path::Path) -> Result<Self, OpenCvCalibError> {
        match image::open(path) {
            Ok(img) => {
                let img = img.to_rgb8();
                Ok(Self { width: img.width(), height: img.height(), data: img.into_raw() })
            }
            Err(image::ImageError::Unsupported(_)) if path.is_file() => Self::open_with_opencv(path),
            Err(e) => Err(OpenCvCalibError::Input(format!("{}: {e}", path.display()))),
        }
    }

    fn open_with_opencv(path: &std::path::Path) -> Result<Self, OpenCvCalibError> {
        let m = opencv::imgcodecs::imread(path, opencv::imgcodecs::IMREAD_COLOR)?;
        if m.empty() {
            return Err(OpenCvCalibError::Input(format!("{}: not an image file this build can read", path.display())));
        }
        let m = if m.is_continuous() { m } else { m.try_clone()? };
        let px: &[Vec3b] = m.data_typed()?;
        Ok(Self { width: m.cols() as u32, height: m.rows() as u32, data: px.iter().flat_map(|p| [p[2], p[1], p[0]]).collect() })
    }

    /// As an OpenCV BGR matrix (copied).
    pub fn to_bgr_mat(&self) -> Result<Mat, OpenCvCalibError> {
        let px: Vec<Vec3b> = self.data.chunks_exact(3).map(|c| Vec3b::from([c[2], c[1], c[0]])).collect();
        Ok(Mat::new_rows_cols_with_data(self.height as i32, self.width as i32, &px)?.try_clone()?)
    }

    /// Luma (Rec. 601 weights, as OpenCV's BGR2GRAY) as an OpenCV 8-bit matrix.
    pub fn to_gray_mat(&self) -> Result<Mat, OpenCvCalibError> {
        let g: Vec<u8> = self
            .data
            .chunks_exact(3)
            .map(|c| (0.299 * c[0] as f32 + 0.587 * c[1] as f32 + 0.114 * c[2] as f32).round().clamp(0.0, 255.0) as u8)
            .collect();
        Ok(Mat::new_rows_cols_with_data(self.height as i32, self.width as i32, &g)?.try_clone()?)
    }
}

/// A 3-channel float OpenCV matrix (BGR order) as a linear RGB image.
pub fn linear_image_from_bgr_f32(m: &Mat) -> Result<crate::io::image::LinearImage, OpenCvCalibError> {
    let (w, h) = (m.cols() as u32, m.rows() as u32);
    let m = if m.is_continuous() { m.clone() } else { m.try_clone()? };
    let px: &[Vec3f] = m.data_typed()?;
    Ok(crate::io::image::LinearImage { width: w, height: h, data: px.iter().map(|p| [p[2], p[1], p[0]]).collect() })
}

/// A linear RGB image as a 3-channel float OpenCV matrix in BGR order.
pub fn bgr_f32_from_linear_image(img: &crate::io::image::LinearImage) -> Result<Mat, OpenCvCalibError> {
    let px: Vec<Vec3f> = img.data.iter().map(|p| Vec3f::from([p[2], p[1], p[0]])).collect();
    Ok(Mat::new_rows_cols_with_data(img.height as i32, img.width as i32, &px)?.try_clone()?)
}
