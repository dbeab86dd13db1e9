//! What the estimator reports: the per-frame record ([`FrameEstimate`]), its status and
//! fallback, sample accounting and set-up statistics (Jensen §3.1's outputs, with the trust
//! information a user needs to act on them).

use super::smoother::ChangeReason;
use crate::sun::{SunError, SunPosition};
use serde::{Deserialize, Serialize};

/// How far a frame's fit can be trusted.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Hash, Serialize, Deserialize, PartialOrd, Ord)]
#[serde(rename_all = "snake_case")]
pub enum Status {
    /// `Pd` and `Pa` were both fitted from a well-conditioned sample.
    Ok,
    /// `Pd` and `Pa` cannot be told apart (all samples sunlit alike, or none sunlit); see the
    /// `fallback` field for what was reported instead.
    SunNotSeparable,
    /// The sun is up but `Pd` is negligible against `Pa` (overcast, or the sun behind a cloud).
    NoDirectSun,
    /// The sun is below the horizon: `Pd = 0`, `Pa` fitted.
    Night,
    /// Fewer usable samples than `min_samples`: nothing fitted.
    TooFewSamples,
    /// Too many samples clipped (see `saturated_fraction`), or every sunlit one: values come from
    /// the unclipped rest, when there were enough.
    Saturated,
    /// The frame is black, or far darker than the lighting of a moment ago predicts (a dropped
    /// frame, a lens cap, a codec glitch; see `DARK_FRACTION`): nothing is fitted and the
    /// smoother is not updated, so one bad frame cannot poison the frames after it.
    DarkFrame,
}

impl Status {
    /// All statuses, in report order.
    pub const ALL: [Status; 7] = [
        Status::Ok,
        Status::SunNotSeparable,
        Status::NoDirectSun,
        Status::Night,
        Status::TooFewSamples,
        Status::Saturated,
        Status::DarkFrame,
    ];
}

/// What was reported in place of a separate `Pd`/`Pa` fit.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Serialize, Deserialize)]
#[serde(rename_all = "snake_case")]
pub enum Fallback {
    /// `Pa` fitted with `Pd` held at its last smoothed value (no sunlit samples).
    HeldPd,
    /// The last separable ratio `Pd/Pa` per channel held and only the overall level fitted.
    HeldSplit,
    /// No previous split: only the total irradiance on the sampled surfaces is reported.
    TotalIrradiance,
    /// `Pd` not observable and nothing to hold: `Pa` fitted alone, `Pd` unknown.
    PdUnobservable,
}

/// Sun part of a frame report.
#[derive(Clone, Copy, Debug, PartialEq, Serialize)]
pub struct SunReport {
    /// Solar position.
    #[serde(flatten)]
    pub position: SunPosition,
    /// Apparent disc centre above the horizon.
    pub above_horizon: bool,
    /// Unit direction toward the sun, world frame.
    pub dir_world: [f32; 3],
}

/// Sample accounting of one frame.
#[derive(Clone, Copy, Debug, Default, PartialEq, Serialize)]
pub struct SampleCounts {
    /// Entries the frame could draw from (pool minus shadow-boundary entries).
    pub available: usize,
    /// Samples drawn (`min(N, available)`).
    pub drawn: usize,
    /// Drawn samples used in the fit.
    pub usable: usize,
    /// Drawn samples skipped as clipped.
    pub clipped: usize,
    /// Drawn samples skipped as NaN, infinite or negative.
    pub invalid: usize,
    /// Unclipped samples skipped because their surface is partly clipped (see `CENSOR_FRACTION`).
    pub censored: usize,
    /// Usable samples that are sunlit.
    pub lit: usize,
    /// Usable samples kept by the robust weights (fewest over the channels).
    pub inliers: usize,
}

/// The sun and sky intensities of a fit (the value the smoother tracks).
#[derive(Clone, Copy, Debug, PartialEq, Serialize)]
pub struct Intensities {
    /// Sun irradiance on a surface facing the sun.
    pub pd: [f64; 3],
    /// Sky irradiance on an unoccluded horizontal surface.
    pub pa: [f64; 3],
}

/// One frame's report (one JSON line).
#[derive(Clone, Debug, PartialEq, Serialize)]
pub struct FrameEstimate {
    /// Frame index in the sequence.
    pub frame: usize,
    /// Capture time, RFC 3339.
    pub time: String,
    /// Sun position and direction.
    pub sun: SunReport,
    /// Trust in the fit.
    pub status: Status,
    /// What was reported instead of a separate fit, if anything.
    pub fallback: Option<Fallback>,
    /// `Pd` of this frame (RGB), `null` when unknown.
    pub pd: Option<[f64; 3]>,
    /// `Pa` of this frame (RGB), `null` when unknown.
    pub pa: Option<[f64; 3]>,
    /// Standard errors of `pd` (`null` entries: unobservable).
    pub pd_se: Option<[f64; 3]>,
    /// Standard errors of `pa`.
    pub pa_se: Option<[f64; 3]>,
    /// Irradiance on the sampled surfaces (`total_irradiance` fallback only).
    pub total_irradiance: Option<[f64; 3]>,
    /// Weighted residual RMS per channel (scaled radiance).
    pub residual_rms: Option<[f64; 3]>,
    /// Largest condition number over the channels (≥ 1e12 means singular).
    pub condition_number: Option<f64>,
    /// Sample accounting.
    pub samples: SampleCounts,
    /// Lighting after temporal smoothing.
    pub smoothed: Option<Intensities>,
    /// True when later stages should relight.
    pub relight: bool,
    /// Why (or why not).
    pub change: ChangeReason,
    /// True when this frame rebuilt sun visibility.
    pub sun_rebuilt: bool,
    /// Time spent on the sun-dependent terms this frame, ms: the rebuild of sun visibility
    /// and any slice of the bounce and sky re-trace (`estimate::rebuild`); 0 when none.
    pub sun_rebuild_ms: f64,
    /// Time of the per-frame estimate (sampling and fit, excluding decode and rebuild), ms.
    pub estimate_ms: f64,
    /// The sky's shape in this frame's model (`uniform` after a frame without direct sun).
    pub sky: crate::scene::settings::SkyShape,
    /// The sky model of this frame's fit: `"hosek_wilkie T=3"` or `"uniform"` (overcast frames,
    /// or `shape = "uniform"`); absent under Jensen's configured model (uniform, no terrain).
    #[serde(skip_serializing_if = "Option::is_none")]
    pub sky_model: Option<String>,
    /// The terrain albedo in the model and where it came from (`scene`, `map`, `fallback`);
    /// absent under Jensen's model.
    #[serde(skip_serializing_if = "Option::is_none")]
    pub terrain: Option<crate::scene::settings::ResolvedTerrain>,
    /// Under `turbidity = "fit"`: the turbidity chosen by residual, and every candidate's.
    #[serde(skip_serializing_if = "Option::is_none")]
    pub turbidity_fit: Option<super::TurbidityFit>,
    /// One entry per `[[lights]]` of the scene, in order (absent without lights).
    #[serde(skip_serializing_if = "Vec::is_empty")]
    pub lamps: Vec<LampReport>,
    /// The read noise the fit used and where it came from (`estimate::noise`,
    /// `estimate::noise_level`); absent when the fit used none (no `response.read_noise` and the
    /// sun up).
    #[serde(skip_serializing_if = "Option::is_none")]
    pub read_noise: Option<ReadNoiseReport>,
    /// At twilight: the horizon band's scale beside the sky shape's (`estimate::sky_band`; the
    /// reported `pa` is the one-shape sky that gives the samples the same sky light); absent when
    /// the band was not a column.
    #[serde(skip_serializing_if = "Option::is_none")]
    pub sky_band: Option<super::sky_band::SkyBandReport>,
    /// The per-surface outlier flags (`estimate::surface_flags`): entries flagged, left out of
    /// this frame's draw, and this frame's update; absent with `surface_flags = false`.
    #[serde(skip_serializing_if = "Option::is_none")]
    pub surface_flags: Option<super::surface_flags::SurfaceFlagsReport>,
}

/// Where the read noise of a frame's fit came from.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Serialize, Deserialize)]
#[serde(rename_all = "snake_case")]
pub enum ReadNoiseSource {
    /// The camera file's `response.read_noise` (a number).
    File,
    /// Measured on the frame (`response.read_noise = "auto"`).
    Frame,
    /// Measured on the frame because the camera file gives none and the sun is at or below the
    /// horizon.
    FrameAtDusk,
}

/// The read noise of a frame's fit (`estimate::noise_level`).
#[derive(Clone, Copy, Debug, PartialEq, Serialize)]
pub struct ReadNoiseReport {
    /// Where it came from.
    pub source: ReadNoiseSource,
    /// The standard deviation used, scaled radiance (0 when the frame's measurement failed).
    pub value: f64,
    /// Measured on the frame: its standard error.
    #[serde(skip_serializing_if = "Option::is_none")]
    pub se: Option<f64>,
    /// Measured on the frame: the flat 8×8 blocks (of all channels) in the fit; 0 when too few
    /// were left for one (then `value` is 0 and the fit is the relative one).
    #[serde(skip_serializing_if = "Option::is_none")]
    pub blocks: Option<usize>,
}

/// What the frame's fit says about one lamp (`estimate::lamps`).
#[derive(Clone, Copy, Debug, PartialEq, Eq, Serialize, Deserialize)]
#[serde(rename_all = "snake_case")]
pub enum LampStatus {
    /// `k` fitted with `Pd` and `Pa`.
    Fitted,
    /// Off at the frame's time (its schedule): left out of the model, skipped.
    Off,
    /// On, but its light reaches too few of the frame's samples: `k` is its prior.
    Unreached,
    /// Its column cannot be told apart from the others (condition number above
    /// `max_condition`): fitted together with the lamps it shares its samples with at their prior
    /// ratio, or, against the sun and sky, kept at its prior.
    NotSeparable,
    /// The frame had no fit (a dark frame, too few samples): `k` is its prior.
    NotFitted,
}

/// One lamp in a frame's report.
#[derive(Clone, Debug, PartialEq, Serialize)]
pub struct LampReport {
    /// The light's name (`[[lights]]` `name`, or `lights[i]`).
    pub name: String,
    /// What the fit did with it.
    pub status: LampStatus,
    /// Its scale per channel (model units → scaled radiance): fitted, or the prior.
    pub k: [f64; 3],
    /// Standard errors of `k` (`null` when not fitted).
    pub k_se: Option<[f64; 3]>,
    /// `k` smoothed over the frames since the lamp last switched on (`estimate::smoother`;
    /// `null` while off and until its first fit).
    pub k_smoothed: Option<[f64; 3]>,
    /// `k` smoothed over the whole recording, later frames included (`estimate::hindsight`):
    /// set by `heliar augment` and `heliar estimate --hindsight`, absent otherwise. The renderer
    /// prefers it to `k_smoothed`.
    #[serde(skip_serializing_if = "Option::is_none")]
    pub k_hindsight: Option<[f64; 3]>,
    /// Usable samples its light reaches.
    pub samples: usize,
    /// Condition number of its column against the others (largest over the channels).
    pub condition_number: Option<f64>,
    /// Why it was skipped, held or merged.
    pub reason: Option<String>,
}

/// Errors setting up the estimator.
#[derive(Debug, thiserror::Error)]
pub enum EstimateError {
    /// The camera sees no usable pixel of a marked diffuse surface.
    #[error(
        "the camera sees no usable pixel of a marked diffuse surface ({diffuse} diffuse pixels, all within {margin} px of an edge); \
         check the camera pose in the calibration file and the diffuse marks in the proxy"
    )]
    NoCandidates {
        /// Pixels that see a diffuse surface.
        diffuse: usize,
        /// The edge margin.
        margin: u32,
    },
    /// The solar position model failed.
    #[error(transparent)]
    Sun(#[from] SunError),
    /// The sky model (`[estimator.sky]`) cannot be built.
    #[error("[estimator.sky]: {0}")]
    Sky(crate::sky::SkyError),
    /// A lamp's model (`[[lights]]`) cannot be built.
    #[error(transparent)]
    Lamp(#[from] crate::lamps::LampError),
}

/// Set-up statistics, for the run summary.
#[derive(Clone, Copy, Debug, Serialize)]
pub struct SetupStats {
    /// Pixels that see a marked diffuse surface.
    pub diffuse_pixels: usize,
    /// Of those, away from edges.
    pub candidate_pixels: usize,
    /// Pool entries.
    pub pool_entries: usize,
    /// Time to build the pixel map, ms.
    pub pixel_map_ms: f64,
    /// Time to build the pool (including `c`), ms.
    pub pool_ms: f64,
}
