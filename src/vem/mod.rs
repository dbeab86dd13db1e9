//! Captured HDR video environment maps (VEM) → temporally coherent directional lights: the
//! second input mode, after Havran, Smyk, Krawczyk, Myszkowski & Seidel, *Interactive system for
//! dynamic scene lighting using captured video environment maps* (EGSR 2005,
//! `../shared/papers/havran-2005-video-environment-maps.txt`, "Havran" below).
//!
//! # How it works
//! Per frame, on the CPU ([`Decomposer::process`]):
//! 1. **Input** ([`capture`]: input frames, the lens file, the photometric response and the
//!    resampling; the Kannala–Brandt lens is [`crate::camera::KannalaBrandt`]; Havran §5.1):
//!    a fisheye HDR (EXR) or LDR (PNG) frame with a Kannala–Brandt calibration and a photometric
//!    response, or an equirect or polar HDR frame, is linearised and resampled into the polar
//!    `(θ, φ)` map of the upper hemisphere in the world frame ([`polar`]; 360 × 90 by default).
//! 2. **Decomposition** ([`sampling`], [`sampling::pattern`]; Havran §3.1–3.2): the PDF luminance × sin θ,
//!    its CDFs, and the continuous inverse transform of fixed relaxed Halton samples give `N`
//!    directions; every light carries `P/N` of the frame's power `P` and keeps its index (its
//!    Halton sample) from frame to frame. The light count can change at any frame without moving
//!    the other lights.
//! 3. **Temporal filter** ([`fir`]; Havran §3.3): a 9-tap linear-phase FIR on every light's
//!    direction and on `P` (4 frames of delay at 21 Hz).
//! 4. **Clustering** ([`cluster`]; Havran §4.3), optional: at most `Q` lights.
//! 5. **Culling lists** ([`regions`], [`glossy`]; Havran §4.1–4.2): per angular region, the lights
//!    that can reach it, as flat GPU buffers; for glossy surfaces a second, denser set `L` with
//!    its own cone lists.
//!
//! [`reinhard`] holds the temporally smoothed Reinhard parameters (Havran §5.1), [`eval`] the
//! synthetic skies of the generator, tests and sweeps and the error measures. The GPU half (the
//! objects lit and shadowed by these lights) is the VEM renderer, `crate::render::vem`.
//!
//! # Conventions
//! Directions are unit vectors in the world frame (`+Y` up), toward the light. A light's `rgb` is
//! its irradiance on a surface facing it (scaled radiance × sr, like `Pd` in the crate docs), so
//! a Lambertian surface of albedo `ρ` and normal `n` has radiance `ρ/π · Σ rgb·max(n·l, 0)`, and
//! `Σ rgb·max(n·l, 0)` estimates the map's irradiance at `n`.

pub mod capture;
pub mod cluster;
pub mod eval;
pub mod fir;
pub mod glossy;
pub mod peaks;
pub mod polar;
pub mod regions;
pub mod reinhard;
pub mod sampling;

use glam::Vec3;
use sampling::pattern::Pattern;
use polar::PolarMap;
use regions::{RegionLists, RegionSet};
use sampling::{PolarDistribution, SamplerKind};
use serde::Serialize;
use std::path::PathBuf;
use fir::{FirDesign, LightFilter};

/// One directional light.
#[derive(Clone, Copy, Debug, PartialEq, Serialize)]
pub struct Light {
    /// Identity: the light's sample index, stable from frame to frame.
    pub index: u32,
    /// Unit direction toward the light, world frame.
    pub dir: Vec3,
    /// RGB irradiance on a surface facing the light.
    pub rgb: [f32; 3],
}

/// What a frame's lights mean.
#[derive(Clone, Copy, Debug, PartialEq, Eq, PartialOrd, Ord, Serialize)]
#[serde(rename_all = "snake_case")]
pub enum Status {
    /// Lights from this frame's map.
    Ok,
    /// The map has no light (all black, or nothing usable): no new directions. Lights that
    /// existed keep their directions while the filtered power decays to 0; if there never was
    /// light, there are no lights.
    Dark,
}

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
    /// Inverse transform.
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
    /// Give concentrated peaks (the sun) lights of their own and sample the rest ([`peaks`];
    /// off by default).
    pub peaks: bool,
}

impl Default for VemConfig {
    fn default() -> Self {
        Self {
            polar_width: polar::DEFAULT_WIDTH,
            polar_height: polar::DEFAULT_HEIGHT,
            lights: 300,
            sampler: SamplerKind::Havran,
            pattern: Pattern::RelaxedHalton,
            rate_hz: fir::PAPER_RATE_HZ,
            clusters: None,
            cluster_cf: cluster::DEFAULT_CF,
            regions: regions::DEFAULT_REGIONS,
            lut_size: regions::DEFAULT_LUT_SIZE,
            glossy_lights: None,
            glossy_regions: glossy::DEFAULT_GLOSSY_REGIONS,
            peaks: false,
        }
    }
}

/// The largest light count accepted.
pub const MAX_LIGHTS: usize = 1 << 16;

impl VemConfig {
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
        if self.glossy_lights.is_some() && (self.peaks || self.sampler == SamplerKind::MedianCut) {
            return bad("glossy_lights", "a glossy set needs equal-power samples: not with peaks or median cut".into());
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

/// A summary of one processed frame.
#[derive(Clone, Copy, Debug, PartialEq, Serialize)]
pub struct FrameSummary {
    /// Whether the frame had light.
    pub status: Status,
    /// Texels that were NaN, infinite or negative (taken as black).
    pub sanitized_texels: usize,
    /// The frame's power `Σ L·ΔΩ` per channel (before filtering).
    pub power_rgb: [f64; 3],
    /// Its luminance.
    pub power: f64,
    /// The filtered power (luminance) the lights share.
    pub filtered_power: f64,
    /// Lights whose filter window was degenerate and held their last direction.
    pub held: usize,
}

/// The per-frame pipeline (see the module docs). Buffers are reused from frame to frame.
#[derive(Debug)]
pub struct Decomposer {
    cfg: VemConfig,
    design: FirDesign,
    dist: PolarDistribution,
    filter: LightFilter,
    raw: Vec<(Vec3, [f32; 3])>,
    /// Filtered lights: `H` without a glossy set, `L` with one.
    filtered: Vec<Light>,
    /// `H` when there is a glossy set.
    high: Vec<Light>,
    clusters: Vec<cluster::Cluster>,
    regions: RegionSet,
    lists: RegionLists,
    glossy: Option<(glossy::GlossyRegions, RegionLists)>,
    peaks: peaks::PeakTracker,
}

impl Decomposer {
    /// Sets up the pipeline (regions, LUTs, the filter design, the cached samples).
    pub fn new(cfg: VemConfig) -> Result<Self, VemError> {
        cfg.validate()?;
        let design = FirDesign::for_rate(cfg.rate_hz)?;
        if cfg.pattern == Pattern::RelaxedHalton {
            sampling::pattern::relaxed(); // relax once now, not inside the first frame
        }
        let glossy = cfg.glossy_lights.map(|_| (glossy::GlossyRegions::new(cfg.glossy_regions, cfg.lut_size), RegionLists::default()));
        Ok(Self {
            filter: LightFilter::new(&design),
            design,
            dist: PolarDistribution::default(),
            raw: Vec::new(),
            filtered: Vec::new(),
            high: Vec::new(),
            clusters: Vec::new(),
            regions: RegionSet::lambertian(cfg.regions, cfg.lut_size),
            lists: RegionLists::default(),
            glossy,
            peaks: peaks::PeakTracker::new(),
            cfg,
        })
    }

    /// The settings.
    pub fn config(&self) -> &VemConfig {
        &self.cfg
    }

    /// The temporal filter in use.
    pub fn filter_design(&self) -> &FirDesign {
        &self.design
    }

    /// Changes the light count from the next frame on (existing lights do not move).
    pub fn set_lights(&mut self, n: usize) -> Result<(), VemError> {
        let cfg = VemConfig { lights: n, ..self.cfg.clone() };
        cfg.validate()?;
        self.cfg = cfg;
        Ok(())
    }

    /// Processes one frame. Texels that are NaN, infinite or negative in any channel count as
    /// black (and are counted).
    pub fn process(&mut self, map: &PolarMap) -> FrameSummary {
        let n = self.cfg.glossy_lights.unwrap_or(0).max(self.cfg.lights);
        let map = if self.cfg.peaks {
            self.peaks.split(map, n - 1);
            self.peaks.remainder()
        } else {
            map
        };
        let n = n - self.peaks.peaks().len();
        let sanitized = self.dist.rebuild(map);
        let (status, mut step) = if self.dist.is_empty() && self.peaks.peaks().is_empty() {
            (Status::Dark, self.filter.step_dark(&mut self.filtered))
        } else if self.cfg.sampler == SamplerKind::MedianCut {
            // Median cut has no sample identity for the FIR to follow: its lights go unfiltered.
            self.filtered = sampling::median_cut::median_cut_lights(map, n);
            (Status::Ok, fir::FilterStep { power: self.dist.integral(), held: 0 })
        } else {
            self.raw.clear();
            for k in 0..n {
                if let Some(r) = self.dist.sample(self.cfg.sampler, sampling::pattern::sample(self.cfg.pattern, k)) {
                    self.raw.push((r.dir, self.dist.light_rgb(map, &r)));
                }
            }
            (Status::Ok, self.filter.step(self.dist.integral(), &self.raw, &mut self.filtered))
        };
        let (mut power_rgb, mut power) = (self.dist.integral_rgb(), self.dist.integral());
        for p in self.peaks.peaks() {
            self.filtered.push(*p);
            let y = polar::luminance(p.rgb) as f64;
            (power, step.power) = (power + y, step.power + y);
            for c in 0..3 {
                power_rgb[c] += p.rgb[c] as f64;
            }
        }
        if self.glossy.is_some() {
            glossy::high_set(&self.filtered, self.cfg.lights, &mut self.high);
        }
        let high = if self.glossy.is_some() { &self.high } else { &self.filtered };
        match self.cfg.clusters {
            Some(q) => cluster::cluster_lights(high, q, cluster::cluster_radius(q, self.cfg.cluster_cf), &mut self.clusters),
            None => self.clusters.clear(),
        }
        self.regions.build_lists(high, &mut self.lists);
        if let Some((g, l_lists)) = &mut self.glossy {
            g.regions.build_lists(&self.filtered, l_lists);
        }
        FrameSummary {
            status,
            sanitized_texels: sanitized,
            power_rgb,
            power,
            filtered_power: step.power,
            held: step.held,
        }
    }

    /// This frame's lights `H` (filtered).
    pub fn lights(&self) -> &[Light] {
        if self.glossy.is_some() { &self.high } else { &self.filtered }
    }

    /// This frame's glossy set `L` (filtered), when configured.
    pub fn glossy_lights(&self) -> Option<&[Light]> {
        self.glossy.as_ref().map(|_| self.filtered.as_slice())
    }

    /// This frame's clusters (empty unless clustering is on).
    pub fn clusters(&self) -> &[cluster::Cluster] {
        &self.clusters
    }

    /// The Lambertian regions and this frame's lists.
    pub fn region_lists(&self) -> (&RegionSet, &RegionLists) {
        (&self.regions, &self.lists)
    }

    /// The glossy regions and this frame's `L` lists, when configured.
    pub fn glossy_lists(&self) -> Option<(&glossy::GlossyRegions, &RegionLists)> {
        self.glossy.as_ref().map(|(g, l)| (g, l))
    }

    /// The distribution of the last frame.
    pub fn distribution(&self) -> &PolarDistribution {
        &self.dist
    }
}

/// Unfiltered lights of one map: `n` samples of `kind`, each with power `P/n` (what one frame
/// gives before the temporal filter). Empty for a black map.
pub fn lights_of_map(map: &PolarMap, kind: SamplerKind, pattern: Pattern, n: usize) -> Vec<Light> {
    let dist = PolarDistribution::new(map);
    lights_of_distribution(&dist, map, kind, pattern, n)
}

/// [`lights_of_map`] with the distribution already built.
pub fn lights_of_distribution(dist: &PolarDistribution, map: &PolarMap, kind: SamplerKind, pattern: Pattern, n: usize) -> Vec<Light> {
    if dist.is_empty() || n == 0 {
        return Vec::new();
    }
    if kind == SamplerKind::MedianCut {
        return sampling::median_cut::median_cut_lights(map, n);
    }
    let p = (dist.integral() / n as f64) as f32;
    (0..n)
        .filter_map(|k| {
            let r = dist.sample(kind, sampling::pattern::sample(pattern, k))?;
            Some(Light { index: k as u32, dir: r.dir, rgb: dist.light_rgb(map, &r).map(|c| c * p) })
        })
        .collect()
}

/// Unfiltered lights of one map with its peaks as lights of their own ([`peaks`]): at most
/// `n − 1` peaks from `tracker` (indices tracked from its previous map), then `n − peaks`
/// lights of `kind` on the remainder.
pub fn lights_with_peaks(tracker: &mut peaks::PeakTracker, map: &PolarMap, kind: SamplerKind, pattern: Pattern, n: usize) -> Vec<Light> {
    if n == 0 {
        return Vec::new();
    }
    tracker.split(map, n - 1);
    let mut l = lights_of_map(tracker.remainder(), kind, pattern, n - tracker.peaks().len());
    l.extend_from_slice(tracker.peaks());
    l
}

/// Irradiance (RGB) of a set of lights on a surface with unit normal `n`: `Σ rgb·max(n·l, 0)`.
pub fn irradiance(lights: &[Light], n: Vec3) -> [f64; 3] {
    let mut e = [0.0f64; 3];
    for l in lights {
        let c = n.dot(l.dir);
        if c > 0.0 {
            for k in 0..3 {
                e[k] += (l.rgb[k] * c) as f64;
            }
        }
    }
    e
}
