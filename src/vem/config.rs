//! The VEM pipeline's settings ([`VemConfig`]) and errors ([`VemError`]).

use super::fir::{self, Temporal};
use super::sampling::SamplerKind;
use super::sampling::pattern::Pattern;
use super::{capture, cluster, glossy, polar, regions};
use std::path::PathBuf;

/// Errors of the VEM input and pipeline set-up.
#[derive(Debug, thiserror::Error)]
pub enum VemError {
    /// A calibration file problem.
    #[error(transparent)]
    LensFile(#[from] capture::lens_file::LensFileError),
    /// An image or frame file problem.
    #[error(transparent)]
    Io(#[from] crate::io::IoError),
    /// The temporal filter cannot be designed.
    #[error(transparent)]
    Temporal(#[from] fir::TemporalError),
    /// Without a calibration, the frame's shape does not say which projection it is.
    #[error("{path}: a {width}×{height} frame is neither a 2:1 equirect nor a 4:1 polar map; give --calib for a fisheye frame")]
    Projection {
        /// The frame.
        path: PathBuf,
        /// Its width.
        width: u32,
        /// Its height.
        height: u32,
    },
    /// The frames of a sequence differ in size.
    #[error("{path}: frame is {got_w}×{got_h} but the sequence (or calibration) is {want_w}×{want_h}")]
    Size {
        /// The frame.
        path: PathBuf,
        /// Width of the file.
        got_w: u32,
        /// Height of the file.
        got_h: u32,
        /// Expected width.
        want_w: u32,
        /// Expected height.
        want_h: u32,
    },
    /// Too many NaN, infinite or negative pixels to trust the frame.
    #[error("{path}: {count} of {referenced} pixels used are NaN, infinite or negative ({:.1}%, limit {:.1}%)", 100.0 * *count as f64 / *referenced as f64, 100.0 * limit)]
    InvalidPixels {
        /// The frame.
        path: PathBuf,
        /// Invalid pixels among those the resampling reads.
        count: usize,
        /// Pixels the resampling reads.
        referenced: usize,
        /// The accepted fraction.
        limit: f64,
    },
    /// No frames to read.
    #[error("{path}: no .exr or .png frames")]
    NoFrames {
        /// The folder or file given.
        path: PathBuf,
    },
    /// A setting is out of range.
    #[error("setting `{field}`: {message}")]
    Config {
        /// The setting.
        field: &'static str,
        /// What is wrong.
        message: String,
    },
}

/// Settings of the per-frame pipeline.
#[derive(Clone, Debug, PartialEq)]
pub struct VemConfig {
    /// Polar map width (default 360).
    pub polar_width: u32,
    /// Polar map height (default 90).
    pub polar_height: u32,
    /// Lights `N` (the set `H` when glossy lights are on).
    pub lights: usize,
    /// How the map becomes lights (default the coherent cut, [`super::sampling::coherent_cut`]).
    pub sampler: SamplerKind,
    /// Input samples.
    pub pattern: Pattern,
    /// Capture rate, Hz (designs the temporal filter).
    pub rate_hz: f64,
    /// Cluster `H` into at most this many lights (Havran §4.3).
    pub clusters: Option<usize>,
    /// The clustering correction factor `c_f`.
    pub cluster_cf: f32,
    /// Angular regions for the Lambertian lists (Havran §4.1).
    pub regions: usize,
    /// Cube-map LUT size per face.
    pub lut_size: u32,
    /// Size of the glossy set `L` (Havran §4.2), more than `lights`; `None`: no glossy set.
    pub glossy_lights: Option<usize>,
    /// Regions of the glossy set.
    pub glossy_regions: usize,
    /// Give concentrated peaks (the sun, a lamp) lights of their own and sample the rest
    /// ([`super::peaks`]). `None` (the default): on with the coherent cut, off with the other
    /// samplers (whose behaviour stays that of Havran's paper and of median cut); see
    /// [`VemConfig::peaks_on`].
    pub peaks: Option<bool>,
    /// How the temporal filter runs: zero phase for recorded input ([`super::Decomposer::push`] and
    /// [`super::Decomposer::flush`]), causal (the paper's, the default of the library) or minimum
    /// phase (live).
    pub temporal: Temporal,
}

impl Default for VemConfig {
    fn default() -> Self {
        Self {
            polar_width: polar::DEFAULT_WIDTH,
            polar_height: polar::DEFAULT_HEIGHT,
            lights: 300,
            sampler: SamplerKind::CoherentCut,
            pattern: Pattern::RelaxedHalton,
            rate_hz: fir::PAPER_RATE_HZ,
            clusters: None,
            cluster_cf: cluster::DEFAULT_CF,
            regions: regions::DEFAULT_REGIONS,
            lut_size: regions::DEFAULT_LUT_SIZE,
            glossy_lights: None,
            glossy_regions: glossy::DEFAULT_GLOSSY_REGIONS,
            peaks: None,
            temporal: Temporal::Causal,
        }
    }
}

/// The largest light count accepted.
pub const MAX_LIGHTS: usize = 1 << 16;

impl VemConfig {
    /// Whether peaks get lights of their own: [`VemConfig::peaks`], by default on with the
    /// coherent cut only.
    pub fn peaks_on(&self) -> bool {
        self.peaks.unwrap_or(self.sampler == SamplerKind::CoherentCut)
    }

    /// Checks ranges.
    pub fn validate(&self) -> Result<(), VemError> {
        let bad = |field, message: String| Err(VemError::Config { field, message });
        if self.polar_width < 4 || self.polar_height < 2 || self.polar_width > 8192 || self.polar_height > 4096 {
            return bad("polar", format!("{}×{} must be within 4×2 … 8192×4096", self.polar_width, self.polar_height));
        }
        if self.lights == 0 || self.lights > MAX_LIGHTS {
            return bad("lights", format!("{} must be in 1 … {MAX_LIGHTS}", self.lights));
        }
        if let Some(l) = self.glossy_lights
            && !(l > self.lights && l <= MAX_LIGHTS)
        {
            return bad("glossy_lights", format!("{l} must exceed lights ({}) and be at most {MAX_LIGHTS}", self.lights));
        }
        if self.glossy_lights.is_some() && self.sampler == SamplerKind::MedianCut {
            return bad("glossy_lights", "a glossy set needs equal-power samples: not with median cut".into());
        }
        if self.clusters == Some(0) {
            return bad("clusters", "must be positive".into());
        }
        if !(self.cluster_cf.is_finite() && self.cluster_cf > 0.0) {
            return bad("cluster_cf", "must be positive".into());
        }
        if self.regions == 0 || self.regions > 65536 || self.lut_size == 0 || self.lut_size > 1024 {
            return bad("regions", "regions must be in 1 … 65536 and the LUT size in 1 … 1024".into());
        }
        Ok(())
    }
}

