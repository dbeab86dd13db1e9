//! Frame sources and image files.
//!
//! - [`image`]: linear RGB images and their EXR/PNG files.
//! - [`frames`]: decoded camera frames (LDR codes or HDR radiance) and per-pixel linearisation.
//! - `video` (feature `opencv`): video files and cameras through OpenCV's FFMPEG backend.
//! - [`guard`]: outputs checked against the inputs and the scene before anything is written;
//!   [`write_atomic`] writes through a temporary file and a rename.

pub mod frames;
pub mod guard;
pub mod image;
#[cfg(feature = "opencv")]
pub mod video;

use std::path::PathBuf;

/// Widest or tallest image read (pixels): the largest environment map heliar bakes is
/// 16384 × 8192.
pub const MAX_IMAGE_SIDE: u32 = 16384;
/// Most pixels in an image read (16384 × 8192, 1.5 GiB as linear RGB floats).
pub const MAX_IMAGE_PIXELS: u64 = 16384 * 8192;

/// Errors reading or writing image and frame files.
#[derive(Debug, thiserror::Error)]
pub enum IoError {
    /// The file could not be opened, read or written.
    #[error("{path}: {source}")]
    File {
        /// The file.
        path: PathBuf,
        /// The OS error.
        source: std::io::Error,
    },
    /// The OpenEXR file is corrupt or not an RGB(A) image.
    #[error("{path}: not a readable RGB OpenEXR image: {message}")]
    Exr {
        /// The file.
        path: PathBuf,
        /// What the EXR decoder said.
        message: String,
    },
    /// An OpenEXR file could not be written.
    #[error("{path}: writing the OpenEXR image failed: {reason}")]
    ExrWrite {
        /// The file.
        path: PathBuf,
        /// The OS error (or the encoder's message).
        reason: String,
    },
    /// The PNG file is corrupt or could not be encoded.
    #[error("{path}: {source}")]
    Png {
        /// The file.
        path: PathBuf,
        /// What the PNG codec said.
        source: ::image::ImageError,
    },
    /// The file extension is not one heliar reads or writes.
    #[error("{path}: unsupported image format (expected .exr or .png)")]
    UnsupportedFormat {
        /// The file.
        path: PathBuf,
    },
    /// A video file or camera could not be opened, decoded or encoded.
    #[error("{path}: {message}")]
    Video {
        /// The file or camera.
        path: PathBuf,
        /// What went wrong.
        message: String,
    },
    /// The file's header claims an image over [`MAX_IMAGE_SIDE`] or [`MAX_IMAGE_PIXELS`].
    #[error("{path}: the header claims a {width}×{height} image, over the cap of {MAX_IMAGE_SIDE} pixels a side and {MAX_IMAGE_PIXELS} pixels (not decoded)")]
    TooLarge {
        /// The file.
        path: PathBuf,
        /// Width in the header.
        width: u64,
        /// Height in the header.
        height: u64,
    },
    /// The image does not have the size the camera calibration says.
    #[error("{path}: image is {got_w}×{got_h} but the camera calibration says {want_w}×{want_h} (a frame of this scene must have the camera's size)")]
    Size {
        /// The file.
        path: PathBuf,
        /// Width of the file.
        got_w: u32,
        /// Height of the file.
        got_h: u32,
        /// Width the calibration expects.
        want_w: u32,
        /// Height the calibration expects.
        want_h: u32,
    },
}

/// The size an `.exr` or `.png` file's header gives, read without decoding the pixels.
pub fn image_header_size(path: &std::path::Path) -> Result<(u64, u64), IoError> {
    let ext = path.extension().and_then(|e| e.to_str()).map(|e| e.to_ascii_lowercase());
    let (w, h) = match ext.as_deref() {
        Some("exr") => {
            let meta = exr::meta::MetaData::read_from_file(path, false).map_err(|e| match e {
                exr::error::Error::Io(source) => IoError::File { path: path.to_owned(), source },
                e => IoError::Exr { path: path.to_owned(), message: e.to_string() },
            })?;
            let header = meta.headers.first().ok_or_else(|| IoError::Exr { path: path.to_owned(), message: "no layer".into() })?;
            (header.layer_size.width() as u64, header.layer_size.height() as u64)
        }
        Some("png") => {
            let reader = ::image::ImageReader::open(path).map_err(|source| IoError::File { path: path.to_owned(), source })?;
            let (w, h) = reader.with_guessed_format().map_err(|source| IoError::File { path: path.to_owned(), source })?.into_dimensions().map_err(|source| match source {
                ::image::ImageError::IoError(e) => IoError::File { path: path.to_owned(), source: e },
                source => IoError::Png { path: path.to_owned(), source },
            })?;
            (w as u64, h as u64)
        }
        _ => return Err(IoError::UnsupportedFormat { path: path.to_owned() }),
    };
    Ok((w, h))
}

/// [`image_header_size`], refused over [`MAX_IMAGE_SIDE`] or [`MAX_IMAGE_PIXELS`].
pub fn checked_header_size(path: &std::path::Path) -> Result<(u32, u32), IoError> {
    let (w, h) = image_header_size(path)?;
    let side = MAX_IMAGE_SIDE as u64;
    if w > side || h > side || w * h > MAX_IMAGE_PIXELS {
        return Err(IoError::TooLarge { path: path.to_owned(), width: w, height: h });
    }
    Ok((w as u32, h as u32))
}

/// A temporary path beside `path` for writing it atomically: same folder (so a rename replaces
/// it in one step), hidden, unique to the process, and with the same extension (writers that
/// pick the format by extension still pick the right one).
pub fn temp_path_for(path: &std::path::Path) -> PathBuf {
    let stem = path.file_stem().map(|n| n.to_string_lossy().into_owned()).unwrap_or_else(|| "out".into());
    let ext = path.extension().map(|e| format!(".{}", e.to_string_lossy())).unwrap_or_default();
    path.with_file_name(format!(".{stem}.{}.tmp{ext}", std::process::id()))
}

/// Runs `write` on a temporary path beside `path` and renames the result over `path`, so an
/// interrupted write leaves the old file whole (or no file); the temporary file is removed when
/// `write` fails.
pub fn write_via_temp<E>(path: &std::path::Path, write: impl FnOnce(&std::path::Path) -> Result<(), E>) -> Result<(), E>
where
    E: From<IoError>,
{
    let tmp = temp_path_for(path);
    if let Err(e) = write(&tmp) {
        let _ = std::fs::remove_file(&tmp);
        return Err(e);
    }
    std::fs::rename(&tmp, path).map_err(|source| {
        let _ = std::fs::remove_file(&tmp);
        E::from(IoError::File { path: path.to_owned(), source })
    })
}

/// Writes `bytes` to `path` through a temporary file in the same folder and a rename, so that an
/// interrupted write leaves the old file whole (or no file) rather than a torn one.
pub fn write_atomic(path: &std::path::Path, bytes: &[u8]) -> Result<(), IoError> {
    let tmp = temp_path_for(path);
    let file_err = |p: &std::path::Path, source| IoError::File { path: p.to_owned(), source };
    std::fs::write(&tmp, bytes).map_err(|e| file_err(&tmp, e))?;
    std::fs::rename(&tmp, path).map_err(|e| {
        let _ = std::fs::remove_file(&tmp);
        file_err(path, e)
    })
}
