//! Frame sequences for the VEM pipeline: which files, which projection, and their decoding into
//! polar maps.
//!
//! - With a fisheye calibration ([`super::lens_file`]) frames are fisheye images of the calibrated
//!   size, linearised with its response (EXR: linear values; PNG: LDR codes through the response,
//!   e.g. the fitted logarithmic one).
//! - Without one, a frame twice as wide as high is an equirect map and one four times as wide as
//!   high a polar map, both in the world frame (HDR EXR, or sRGB PNG): row 0 the zenith, the
//!   centre column north (`−Z`), columns growing east (`+X`).
//! - A yaw ([`VemInput::set_yaw_deg`]) turns any input about the up axis (see
//!   [`super::resample`], "Orientation"); [`VemInput::layout`] says in words what is assumed.
//!
//! A frame in which more than [`DEFAULT_MAX_INVALID_FRACTION`] of the pixels the resampling reads
//! are NaN, infinite or negative is rejected with an error naming the file; below that they are
//! left out and counted.

use crate::vem::VemError;
use super::lens_file::FisheyeCalib;
use crate::vem::polar::PolarMap;
use super::resample::{Projection, ResampleStats, Resampler};
use crate::io::frames::{Frame, Linearizer, Response, list_frame_files};
use std::path::{Path, PathBuf};

/// Largest fraction of invalid pixels (among those used) before a frame is rejected.
pub const DEFAULT_MAX_INVALID_FRACTION: f64 = 0.05;

/// An opened frame sequence.
#[derive(Debug)]
pub struct VemInput {
    /// The frame files, in order.
    pub files: Vec<PathBuf>,
    /// The calibration, for fisheye frames.
    pub calib: Option<FisheyeCalib>,
    /// Largest accepted fraction of invalid pixels.
    pub max_invalid_fraction: f64,
    linearizer: Linearizer,
    polar: (u32, u32),
    yaw_deg: f64,
    resampler: Option<(Projection, Resampler)>,
}

impl VemInput {
    /// Opens a folder of `.exr`/`.png` frames (sorted by name) or a single frame file.
    pub fn open(input: &Path, calib: Option<&Path>, polar_width: u32, polar_height: u32) -> Result<Self, VemError> {
        let files = if input.is_dir() {
            list_frame_files(input)?
        } else if input.is_file() {
            vec![input.to_owned()]
        } else {
            return Err(VemError::Io(crate::io::IoError::File {
                path: input.to_owned(),
                source: std::io::Error::new(std::io::ErrorKind::NotFound, "no such file or folder"),
            }));
        };
        if files.is_empty() {
            return Err(VemError::NoFrames { path: input.to_owned() });
        }
        let calib = calib.map(FisheyeCalib::load).transpose()?;
        let linearizer = match &calib {
            Some(c) => c.photometry.linearizer(),
            None => Linearizer::new(&Response::Srgb, 1.0, 1.0, None),
        };
        Ok(Self { files, calib, max_invalid_fraction: DEFAULT_MAX_INVALID_FRACTION, linearizer, polar: (polar_width, polar_height), yaw_deg: 0.0, resampler: None })
    }

    /// Turns the input by `deg` about the up axis: its north (the centre column of an equirect
    /// or polar frame) looks toward world azimuth `deg`, clockwise from north. Refuses a
    /// non-finite angle. Applies from the next frame loaded.
    pub fn set_yaw_deg(&mut self, deg: f64) -> Result<(), VemError> {
        if !deg.is_finite() {
            return Err(VemError::Config { field: "yaw", message: format!("{deg} is not a finite angle in degrees") });
        }
        self.yaw_deg = deg;
        self.resampler = None;
        Ok(())
    }

    /// The yaw in degrees.
    pub fn yaw_deg(&self) -> f64 {
        self.yaw_deg
    }

    /// The layout the frames are read with, in words (for the start of a run): decodes the first
    /// frame to learn its shape when no frame has been loaded yet.
    pub fn layout(&mut self) -> Result<String, VemError> {
        if self.resampler.is_none() {
            let frame = Frame::load(&self.files[0])?;
            self.prepare(0, frame.width, frame.height)?;
        }
        let Some((projection, rs)) = &self.resampler else { unreachable!("set above") };
        let (w, h, yaw) = (rs.source_width, rs.source_height, self.yaw_deg);
        let turn = if yaw == 0.0 { "no yaw (--yaw 0)".to_string() } else { format!("--yaw {yaw}°: the input's north looks toward azimuth {yaw}° clockwise from north") };
        Ok(match projection {
            Projection::Equirect => format!("{w}×{h} frames read as 2:1 equirect maps in the world frame: row 0 the zenith, north (−Z) at the centre column, east (+X) to the right; {turn}"),
            Projection::Polar => format!("{w}×{h} frames read as 4:1 polar maps of the upper hemisphere: row 0 the zenith, north (−Z) at the centre column, east (+X) to the right; {turn}"),
            Projection::Fisheye(_) => format!("{w}×{h} fisheye frames oriented by the calibration's extrinsics; {turn}"),
        })
    }

    /// Chooses the projection from the first frame's shape (`path`, `w × h`) and builds the
    /// resampling.
    fn prepare(&mut self, i: usize, w: u32, h: u32) -> Result<(), VemError> {
        let path = &self.files[i];
        let projection = match &self.calib {
            Some(c) => Projection::Fisheye(c.camera.clone()),
            None if w == 2 * h => Projection::Equirect,
            None if w == 4 * h => Projection::Polar,
            None => return Err(VemError::Projection { path: path.clone(), width: w, height: h }),
        };
        let (sw, sh) = match &self.calib {
            Some(c) => (c.camera.intrinsics.width, c.camera.intrinsics.height),
            None => (w, h),
        };
        let rs = Resampler::with_yaw(&projection, sw, sh, self.polar.0, self.polar.1, self.yaw_deg);
        self.resampler = Some((projection, rs));
        Ok(())
    }

    /// Number of frames.
    pub fn len(&self) -> usize {
        self.files.len()
    }

    /// Whether there are no frames (never after [`VemInput::open`]).
    pub fn is_empty(&self) -> bool {
        self.files.is_empty()
    }

    /// Decodes frame `i` (an index into [`VemInput::files`]) into `map`.
    pub fn load(&mut self, i: usize, map: &mut PolarMap) -> Result<ResampleStats, VemError> {
        let frame = Frame::load(&self.files[i])?;
        let (w, h) = (frame.width, frame.height);
        if self.resampler.is_none() {
            self.prepare(i, w, h)?;
        }
        let path = &self.files[i];
        let Some((_, rs)) = self.resampler.as_mut() else { unreachable!("set above") };
        if (w, h) != (rs.source_width, rs.source_height) {
            return Err(VemError::Size { path: path.clone(), got_w: w, got_h: h, want_w: rs.source_width, want_h: rs.source_height });
        }
        let stats = rs.resample(&frame, &self.linearizer, map);
        let referenced = rs.referenced_pixels();
        if referenced > 0 && stats.invalid_pixels as f64 > self.max_invalid_fraction * referenced as f64 {
            return Err(VemError::InvalidPixels { path: path.clone(), count: stats.invalid_pixels, referenced, limit: self.max_invalid_fraction });
        }
        Ok(stats)
    }
}
