//! Settings of the lighting stages as plain data: `[estimator]` and `[bake]` (with
//! `[bake.relight]`) of `scene.toml`, with their defaults and range checks.
//!
//! This module is a leaf: the scene owns these values, and each stage (the estimator, the bake,
//! the relighter, the compositor's defaults) builds itself from them, so `scene` never imports a
//! stage (pbrt-v4's parameter dictionaries work the same way).

use crate::geometry::ambient::TransportQuality;
use serde::{Deserialize, Serialize};

/// Estimator settings (`[estimator]` in `scene.toml`). Every field has a default.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
#[serde(default, deny_unknown_fields)]
pub struct EstimatorConfig {
    /// Pixels drawn per frame (Jensen: 500).
    pub samples: usize,
    /// Candidate pixels kept with precomputed `ρ, n, c` (the per-frame draws come from these).
    pub pool_size: usize,
    /// Pixels within this distance of a silhouette, crease, image border or shadow boundary are
    /// not sampled.
    pub edge_margin_px: u32,
    /// Quality of the weighted-ambient integral `c`.
    pub ambient: TransportQuality,
    /// Quality of the sun-bounce integral.
    pub bounce: TransportQuality,
    /// Include the sun-bounce term `b·Pd` in the model.
    pub sun_bounce: bool,
    /// Rebuild sun visibility when the sun has moved more than this, degrees.
    pub sun_rebuild_deg: f64,
    /// Paths per frame of the sun-bounce re-trace after a sun move (`estimate::rebuild`); the
    /// previous bounce serves until it completes. 0 (default): the whole re-trace in the frame
    /// that needs it (≈ 0.7 s at 320×240, once per ~65 s of 30 fps footage; offline runs keep
    /// their outputs and the bounce never lags); `heliar live` uses
    /// [`ESTIMATOR_TRACE_PATHS_PER_FRAME`] unless told otherwise.
    pub trace_paths_per_frame: u64,
    /// Fewer usable samples than this give status `too_few_samples`.
    pub min_samples: usize,
    /// Condition numbers above this give status `sun_not_separable`. The condition number
    /// bounds how much a relative error in the data (model error, not only noise) can grow in the
    /// split: at 12, a 1% model error may move `Pd` or `Pa` by about 10%. Well-posed views measure
    /// 1.5–8 (bundled courtyard ≈ 3–5; grazing sun ≈ 8).
    pub max_condition: f64,
    /// `Pd` below this fraction of `Pa` (luminance) gives status `no_direct_sun`.
    pub no_sun_ratio: f64,
    /// More than this fraction of drawn samples clipped gives status `saturated`.
    pub saturated_fraction: f64,
    /// Random-walk rate of the smoother, relative per √s (see `estimate::smoother`).
    pub smoothing_rate_per_sqrt_s: f64,
    /// Random-walk rate of each lamp's scale `k`, relative per √s: a luminaire's output is steady
    /// where daylight is not, so the lamps' filter averages over far longer than the sun's and
    /// sky's (a frame that departs from it beyond the robust band restarts it: a warm-up, a
    /// dimming step; see `estimate::smoother`).
    pub lamp_smoothing_rate_per_sqrt_s: f64,
    /// Relative change of `Pd` or `Pa` that triggers a relight.
    pub relight_threshold: f64,
    /// Sun motion that triggers a relight, degrees.
    pub relight_sun_deg: f64,
    /// Seed of all random draws.
    pub seed: u64,
    /// Per-surface outlier flags: pool entries that the fitted model cannot explain on two
    /// consecutive frames where the departure is beyond the robust fit's band are left out of the
    /// later frames' draws (at most a tenth of them), until a frame sees them consistent again
    /// (`estimate::surface_flags`).
    pub surface_flags: bool,
    /// The sky's shape and the terrain below the horizon (`[estimator.sky]`).
    pub sky: SkyTermsConfig,
}

/// The sky's angular shape in the estimator's ambient term.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Serialize, Deserialize)]
#[serde(rename_all = "snake_case")]
pub enum SkyShape {
    /// Jensen's uniform sky (the bundled courtyard's generator has one).
    Uniform,
    /// The Hosek–Wilkie clear sky for the frame's sun (brighter near the sun and the horizon).
    HosekWilkie,
}

/// `[estimator.sky]`: the sky's shape and the terrain beyond the proxy (see `estimate::sky_terms`).
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
#[serde(default, deny_unknown_fields)]
pub struct SkyTermsConfig {
    /// The sky's shape: `hosek_wilkie` (default) or `uniform`.
    pub shape: SkyShape,
    /// Turbidity of the Hosek–Wilkie sky, 1–10 (3: a clear day), or `"fit"`: per frame, the
    /// candidate of [`FIT_TURBIDITIES`] whose fit leaves the smallest robust residual
    /// (`estimate::turbidity`).
    pub turbidity: Turbidity,
    /// Albedo (RGB) of the flat terrain beyond the proxy that lights surfaces from below the
    /// horizon: 0.8 fresh snow, 0.2 grass or soil, 0.08 asphalt, 0 for nothing below; or
    /// `"map"` (the default): measured on the environment map's texels below the horizon that the
    /// proxy does not cover (`envmap::bake::terrain::resolve_scene`, which the command line and
    /// the Python bindings call when they open a scene). A scene without such texels, or one
    /// opened through [`crate::scene::Scene::load`] alone, uses [`DEFAULT_TERRAIN_ALBEDO`].
    pub terrain_albedo: TerrainAlbedo,
    /// Directions per surface of the sky and terrain quadrature.
    pub directions: usize,
    /// At twilight (the sun below the horizon or less than 3° up) under the Hošek–Wilkie shape,
    /// fit a horizon band's scale beside the shape's (`estimate::sky_band`); default true.
    pub twilight_band: bool,
    /// Carry the band's ratio to the shape from frame to frame as a prior whose spread grows
    /// with the sun's motion (`estimate::sky_band`, "At night"); false: a free column on every
    /// frame. Default true.
    pub twilight_band_prior: bool,
    /// The albedo `terrain_albedo = "map"` resolved to (`envmap::bake::terrain::resolve_scene`);
    /// not part of `scene.toml`.
    #[serde(skip)]
    pub resolved_terrain: Option<ResolvedTerrain>,
}

/// Where the terrain's albedo comes from: `terrain_albedo = [r, g, b]` or `terrain_albedo = "map"`.
#[derive(Clone, Copy, Debug, PartialEq)]
pub enum TerrainAlbedo {
    /// A fixed albedo per channel.
    Rgb([f32; 3]),
    /// The environment map's texels below the horizon that the proxy does not cover.
    Map,
}

/// The Hošek–Wilkie turbidity: `turbidity = 3.0` or `turbidity = "fit"`.
#[derive(Clone, Copy, Debug, PartialEq)]
pub enum Turbidity {
    /// A fixed turbidity.
    Value(f64),
    /// Chosen per frame by residual among [`FIT_TURBIDITIES`].
    Fit,
}

/// Default random-walk rate of a lamp's scale, relative per √s: 1.2% over ten minutes, 2% over
/// half an hour, 0.05% over a second. A luminaire's output is steady once it is on (a driven LED
/// holds it within a few percent over the first half hour's heating and about a percent after;
/// a warmed-up discharge lamp within a few percent over tens of minutes); what changes it faster
/// (a discharge lamp's warm-up after switch-on, a dimming step) is a departure beyond the robust
/// band, which restarts the filter (`estimate::smoother::LampSmoother`).
pub const LAMP_SMOOTHING_RATE: f64 = 0.0005;

/// Candidates of `turbidity = "fit"`: clear (2) to hazy (6) skies.
pub const FIT_TURBIDITIES: [f64; 4] = [2.0, 3.0, 4.0, 6.0];
/// The turbidity the renderer's sky and a frame without a turbidity fit use under `"fit"`.
pub const FIT_TURBIDITY_DEFAULT: f64 = 3.0;
/// The terrain albedo when the map gives none (or was not measured): grass or soil.
pub const DEFAULT_TERRAIN_ALBEDO: [f32; 3] = [0.2; 3];

/// Where the terrain albedo a model uses came from.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Serialize, Deserialize)]
#[serde(rename_all = "snake_case")]
pub enum TerrainSource {
    /// A number in `scene.toml` (or the built-in default).
    Scene,
    /// Measured on the environment map.
    Map,
    /// `"map"` asked for, but the map gave no estimate: [`DEFAULT_TERRAIN_ALBEDO`] (see `note`).
    Fallback,
}

/// The terrain albedo a model uses, and where it came from.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
pub struct ResolvedTerrain {
    /// Albedo per channel.
    pub albedo_rgb: [f32; 3],
    /// Its source.
    pub source: TerrainSource,
    /// Map texels the estimate used (0 unless measured on the map).
    pub texels: usize,
    /// Why the map gave no estimate, or how it was measured.
    #[serde(skip_serializing_if = "Option::is_none")]
    pub note: Option<String>,
}

impl Serialize for TerrainAlbedo {
    fn serialize<S: serde::Serializer>(&self, s: S) -> Result<S::Ok, S::Error> {
        match self {
            Self::Rgb(v) => v.serialize(s),
            Self::Map => s.serialize_str("map"),
        }
    }
}

impl<'de> Deserialize<'de> for TerrainAlbedo {
    fn deserialize<D: serde::Deserializer<'de>>(d: D) -> Result<Self, D::Error> {
        #[derive(Deserialize)]
        #[serde(untagged)]
        enum Raw {
            Rgb([f32; 3]),
            Word(String),
        }
        match Raw::deserialize(d).map_err(|_| <D::Error as serde::de::Error>::custom("expected [r, g, b] or \"map\""))? {
            Raw::Rgb(v) => Ok(Self::Rgb(v)),
            Raw::Word(w) if w == "map" => Ok(Self::Map),
            Raw::Word(w) => Err(serde::de::Error::custom(format!("expected [r, g, b] or \"map\", got \"{w}\""))),
        }
    }
}

impl Serialize for Turbidity {
    fn serialize<S: serde::Serializer>(&self, s: S) -> Result<S::Ok, S::Error> {
        match self {
            Self::Value(t) => t.serialize(s),
            Self::Fit => s.serialize_str("fit"),
        }
    }
}

impl<'de> Deserialize<'de> for Turbidity {
    fn deserialize<D: serde::Deserializer<'de>>(d: D) -> Result<Self, D::Error> {
        #[derive(Deserialize)]
        #[serde(untagged)]
        enum Raw {
            Value(f64),
            Word(String),
        }
        match Raw::deserialize(d).map_err(|_| <D::Error as serde::de::Error>::custom("expected a number or \"fit\""))? {
            Raw::Value(t) => Ok(Self::Value(t)),
            Raw::Word(w) if w == "fit" => Ok(Self::Fit),
            Raw::Word(w) => Err(serde::de::Error::custom(format!("expected a number or \"fit\", got \"{w}\""))),
        }
    }
}

impl Turbidity {
    /// The fixed value, or [`FIT_TURBIDITY_DEFAULT`] under `"fit"`.
    pub fn value(&self) -> f64 {
        match self {
            Self::Value(t) => *t,
            Self::Fit => FIT_TURBIDITY_DEFAULT,
        }
    }
}

/// The estimator's sliced budget of the live window (and of `heliar bench estimate --knob
/// moving-sun`): the sun-bounce re-trace after a sun move within about 15 ms a frame at 320×240.
pub const ESTIMATOR_TRACE_PATHS_PER_FRAME: u64 = 1 << 14;

/// Turbidity range of the Hosek–Wilkie model.
pub const SKY_TURBIDITY_RANGE: (f64, f64) = (1.0, 10.0);

impl Default for SkyTermsConfig {
    fn default() -> Self {
        Self { shape: SkyShape::HosekWilkie, turbidity: Turbidity::Value(3.0), terrain_albedo: TerrainAlbedo::Map, directions: 512, twilight_band: true, twilight_band_prior: true, resolved_terrain: None }
    }
}

impl SkyTermsConfig {
    /// The sky as the path tracers take it (the relight, the probes, the receivers and the
    /// objects' transfer see the same sky as the estimator).
    pub fn sky_model(&self) -> crate::sky::radiance::SkyModel {
        crate::sky::radiance::SkyModel { hosek_turbidity: (self.shape == SkyShape::HosekWilkie).then_some(self.turbidity.value()), terrain_albedo: self.terrain_rgb() }
    }

    /// The terrain albedo the model uses: the number, or the map's once resolved (before, and
    /// when the map gave none, [`DEFAULT_TERRAIN_ALBEDO`]).
    pub fn terrain_rgb(&self) -> [f32; 3] {
        self.terrain_used().albedo_rgb
    }

    /// The terrain albedo the model uses and where it came from.
    pub fn terrain_used(&self) -> ResolvedTerrain {
        match (self.terrain_albedo, &self.resolved_terrain) {
            (TerrainAlbedo::Rgb(v), _) => ResolvedTerrain { albedo_rgb: v, source: TerrainSource::Scene, texels: 0, note: None },
            (TerrainAlbedo::Map, Some(r)) => r.clone(),
            (TerrainAlbedo::Map, None) => ResolvedTerrain {
                albedo_rgb: DEFAULT_TERRAIN_ALBEDO,
                source: TerrainSource::Fallback,
                texels: 0,
                note: Some("terrain_albedo = \"map\" was not resolved against the environment map".into()),
            },
        }
    }

    /// Jensen's model: uniform sky, nothing below the horizon.
    pub fn jensen() -> Self {
        Self { shape: SkyShape::Uniform, terrain_albedo: TerrainAlbedo::Rgb([0.0; 3]), ..Self::default() }
    }

    /// Checks ranges; `Err((field, message))`.
    pub fn validate(&self) -> Result<(), (&'static str, String)> {
        let (lo, hi) = SKY_TURBIDITY_RANGE;
        if let Turbidity::Value(t) = self.turbidity
            && !(lo..=hi).contains(&t)
        {
            return Err(("sky.turbidity", format!("must be in [{lo}, {hi}] or \"fit\", got {t}")));
        }
        if let TerrainAlbedo::Rgb(v) = self.terrain_albedo
            && !v.iter().all(|a| (0.0..=1.0).contains(a))
        {
            return Err(("sky.terrain_albedo", format!("must be in [0, 1] per channel or \"map\", got {v:?}")));
        }
        if !(16..=4096).contains(&self.directions) {
            return Err(("sky.directions", format!("must be in [16, 4096], got {}", self.directions)));
        }
        Ok(())
    }
}

impl Default for EstimatorConfig {
    fn default() -> Self {
        Self {
            samples: 500,
            pool_size: 4096,
            edge_margin_px: 3,
            ambient: TransportQuality { paths: 64, max_bounces: 4 },
            bounce: TransportQuality { paths: 256, max_bounces: 3 },
            sun_bounce: true,
            sun_rebuild_deg: 0.25,
            trace_paths_per_frame: 0,
            min_samples: 30,
            max_condition: 12.0,
            no_sun_ratio: 0.05,
            saturated_fraction: 0.5,
            smoothing_rate_per_sqrt_s: 0.1,
            lamp_smoothing_rate_per_sqrt_s: LAMP_SMOOTHING_RATE,
            relight_threshold: 0.02,
            relight_sun_deg: 0.5,
            seed: 0,
            surface_flags: true,
            sky: SkyTermsConfig::default(),
        }
    }
}

impl EstimatorConfig {
    /// Checks ranges; `Err((field, message))`.
    pub fn validate(&self) -> Result<(), (&'static str, String)> {
        if self.samples < 3 {
            return Err(("samples", "must be at least 3".into()));
        }
        if self.pool_size < self.samples {
            return Err(("pool_size", format!("must be at least samples ({})", self.samples)));
        }
        if self.ambient.paths == 0 {
            return Err(("ambient.paths", "must be positive".into()));
        }
        if self.sun_bounce && self.bounce.paths == 0 {
            return Err(("bounce.paths", "must be positive when sun_bounce is on".into()));
        }
        for (name, v) in [
            ("sun_rebuild_deg", self.sun_rebuild_deg),
            ("max_condition", self.max_condition),
            ("no_sun_ratio", self.no_sun_ratio),
            ("smoothing_rate_per_sqrt_s", self.smoothing_rate_per_sqrt_s),
            ("lamp_smoothing_rate_per_sqrt_s", self.lamp_smoothing_rate_per_sqrt_s),
            ("relight_threshold", self.relight_threshold),
            ("relight_sun_deg", self.relight_sun_deg),
        ] {
            if !(v.is_finite() && v >= 0.0) {
                return Err((name, format!("{v} must be a non-negative number")));
            }
        }
        if !(self.saturated_fraction > 0.0 && self.saturated_fraction <= 1.0) {
            return Err(("saturated_fraction", "must be in (0, 1]".into()));
        }
        self.sky.validate()
    }
}

/// `[bake]` settings in `scene.toml`.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
#[serde(default, deny_unknown_fields)]
pub struct BakeConfig {
    /// Quality of the weighted-ambient map `c`.
    pub ambient: TransportQuality,
    /// Quality of the sun-bounce integral used by the albedo inversion.
    pub bounce: TransportQuality,
    /// Runtime relighting settings.
    pub relight: RelightConfig,
    /// Directions per probe of the irradiance-volume transfer.
    pub probe_directions: usize,
}

impl Default for BakeConfig {
    fn default() -> Self {
        Self {
            ambient: TransportQuality { paths: 256, max_bounces: 4 },
            bounce: TransportQuality { paths: 128, max_bounces: 3 },
            relight: RelightConfig::default(),
            probe_directions: 1024,
        }
    }
}

impl BakeConfig {
    /// Checks ranges; `Err((field, message))`.
    pub fn validate(&self) -> Result<(), (&'static str, String)> {
        if self.ambient.paths == 0 {
            return Err(("ambient.paths", "must be positive".into()));
        }
        if self.bounce.paths == 0 {
            return Err(("bounce.paths", "must be positive".into()));
        }
        if self.probe_directions < 16 {
            return Err(("probe_directions", "must be at least 16".into()));
        }
        self.relight.validate().map_err(|(f, m)| (f, m))
    }
}

/// Runtime relighting settings (`[bake.relight]`).
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
#[serde(default, deny_unknown_fields)]
pub struct RelightConfig {
    /// Rebuild sun visibility and bounce when the sun has moved more than this, degrees.
    pub sun_rebuild_deg: f64,
    /// Include sun light bounced between proxy surfaces in the relit map.
    pub sun_bounce: bool,
    /// Quality of that bounce integral per texel.
    pub bounce: TransportQuality,
}

impl Default for RelightConfig {
    fn default() -> Self {
        Self { sun_rebuild_deg: 0.5, sun_bounce: true, bounce: TransportQuality { paths: 64, max_bounces: 3 } }
    }
}

impl RelightConfig {
    /// Checks ranges; `Err((field, message))`.
    pub fn validate(&self) -> Result<(), (&'static str, String)> {
        if !(self.sun_rebuild_deg.is_finite() && self.sun_rebuild_deg >= 0.0) {
            return Err(("relight.sun_rebuild_deg", "must be a non-negative number".into()));
        }
        if self.sun_bounce && self.bounce.paths == 0 {
            return Err(("relight.bounce.paths", "must be positive when sun_bounce is on".into()));
        }
        Ok(())
    }
}
