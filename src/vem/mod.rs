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
//! 2. **Decomposition** ([`sampling`]): by default the coherent median cut
//!    ([`sampling::coherent_cut`]): a fixed equal-energy kd-tree over the map, one light of
//!    power `P/N` per leaf at its energy centroid, the leaf's index as the light's identity
//!    (not progressive: changing `N` shifts the lights a little), with concentrated peaks (the
//!    sun, a lamp) as lights of their own at their measured power and angular size ([`peaks`];
//!    on by default with the coherent cut, `VemConfig::peaks`). With `--sampler havran`
//!    ([`sampling::pattern`]; Havran §3.1–3.2): the PDF luminance × sin θ,
//!    its CDFs, and the continuous inverse transform of fixed relaxed Halton samples give `N`
//!    directions; every light carries `P/N` of the frame's power `P` and keeps its index (its
//!    Halton sample) from frame to frame. The light count can change at any frame without moving
//!    the other lights.
//! 3. **Temporal filter** ([`fir`]; Havran §3.3): a 9-tap linear-phase FIR on every light's
//!    direction and on `P`. Run causally, as in the paper, its output describes the frame 4
//!    frames earlier (at 21 Hz); for recorded input it runs zero-phase, centred on the frame
//!    ([`Decomposer::push`], [`Decomposer::flush`]; frame `t`'s lights describe frame `t`); live,
//!    its minimum-phase version cuts the delay ([`fir::Temporal`]).
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
mod config;
pub mod eval;
pub mod fir;
pub mod glossy;
mod lights;
pub mod peaks;
pub mod polar;
pub mod regions;
pub mod reinhard;
pub mod sampling;

use glam::Vec3;
use sampling::pattern::Pattern;
use polar::{PolarMap, luminance};
use regions::{RegionLists, RegionSet};
use sampling::{PolarDistribution, SamplerKind};
use serde::Serialize;
use fir::{CentredFilter, FirDesign, LightFilter, Temporal};
pub use config::{MAX_LIGHTS, VemConfig, VemError};
pub use lights::{irradiance, lights_of_distribution, lights_of_map, lights_with_peaks};
use std::collections::VecDeque;

/// One directional light.
#[derive(Clone, Copy, Debug, PartialEq, Serialize)]
pub struct Light {
    /// Identity: the light's sample index, stable from frame to frame.
    pub index: u32,
    /// Unit direction toward the light, world frame.
    pub dir: Vec3,
    /// RGB irradiance on a surface facing the light.
    pub rgb: [f32; 3],
    /// Angular radius (radians) of the source the light stands for: a peak's measured size
    /// ([`peaks`]), so that soft shadows and glossy highlights can use it; 0 for a sample of the
    /// map (not written then).
    #[serde(skip_serializing_if = "is_point")]
    pub radius: f32,
}

fn is_point(r: &f32) -> bool {
    *r == 0.0
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
    /// The input frame (counted from 0 over the frames given to the decomposer) whose map the
    /// lights describe: the frame itself with the zero-phase filter, `frame − delay` with a
    /// causal one (at least 0).
    pub describes_frame: u64,
    /// The input frame this summary belongs to (its power, status and texel counts).
    #[serde(skip)]
    pub frame: u64,
}

/// A frame sampled and waiting for its filtered lights (zero phase), or about to get them.
#[derive(Debug)]
struct Pending {
    frame: u64,
    status: Status,
    sanitized: usize,
    power_rgb: [f64; 3],
    power: f64,
    /// The frame's peak lights (unfiltered) and their power (luminance).
    peaks: Vec<Light>,
    peak_power: f64,
    /// Median cut's lights (unfiltered), instead of filtered samples.
    unfiltered: Option<Vec<Light>>,
}

/// The per-frame pipeline (see the module docs). Buffers are reused from frame to frame.
#[derive(Debug)]
pub struct Decomposer {
    cfg: VemConfig,
    design: FirDesign,
    dist: PolarDistribution,
    filter: LightFilter,
    centred: CentredFilter,
    pending: VecDeque<Pending>,
    pushed: u64,
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
    /// The causal temporal filter of the peaks' total power (no lights: a scalar FIR) and a
    /// buffer for its (empty) light output.
    peak_filter: LightFilter,
    no_lights: Vec<Light>,
    /// Zero phase: the peaks' total power of frames `peak_first …`, for the centred median.
    peak_powers: VecDeque<f64>,
    peak_first: u64,
    /// The coherent cut's tables and per-node axes (kept from frame to frame).
    cut: sampling::coherent_cut::CoherentCut,
    cut_lights: Vec<Light>,
}

impl Decomposer {
    /// Sets up the pipeline (regions, LUTs, the filter design, the cached samples).
    pub fn new(cfg: VemConfig) -> Result<Self, VemError> {
        cfg.validate()?;
        let linear = FirDesign::for_rate(cfg.rate_hz)?;
        let design = if cfg.temporal == Temporal::MinimumPhase { linear.minimum_phase()? } else { linear };
        if cfg.pattern == Pattern::RelaxedHalton {
            sampling::pattern::relaxed(); // relax once now, not inside the first frame
        }
        let peak_filter = LightFilter::new(&design);
        let glossy = cfg.glossy_lights.map(|_| (glossy::GlossyRegions::new(cfg.glossy_regions, cfg.lut_size), RegionLists::default()));
        Ok(Self {
            filter: LightFilter::new(&design),
            centred: CentredFilter::new(&design),
            pending: VecDeque::new(),
            pushed: 0,
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
            peak_filter,
            peak_powers: VecDeque::new(),
            peak_first: 0,
            no_lights: Vec::new(),
            cut: sampling::coherent_cut::CoherentCut::new(),
            cut_lights: Vec::new(),
            cfg,
        })
    }

    /// The settings.
    pub fn config(&self) -> &VemConfig {
        &self.cfg
    }

    /// The temporal filter in use (the minimum-phase taps with [`Temporal::MinimumPhase`]).
    pub fn filter_design(&self) -> &FirDesign {
        &self.design
    }

    /// Frames between an input frame and the frame its lights describe: 0 with the zero-phase
    /// filter, the design's delay at DC (rounded) with a causal one.
    pub fn delay_frames(&self) -> usize {
        match self.cfg.temporal {
            Temporal::ZeroPhase => 0,
            _ => self.design.delay_frames(),
        }
    }

    /// Changes the light count from the next frame on. With the inverse transforms (Havran,
    /// standard) existing lights do not move; with the coherent cut they keep their indices but
    /// shift a little (the tree's energy fractions change), and median cut starts over.
    pub fn set_lights(&mut self, n: usize) -> Result<(), VemError> {
        let cfg = VemConfig { lights: n, ..self.cfg.clone() };
        cfg.validate()?;
        self.cfg = cfg;
        Ok(())
    }

    /// Processes one frame and returns the summary of the newest frame given out. With a causal
    /// filter that is this frame. With the zero-phase filter every pending frame is given out
    /// (the newest with no future frames: unfiltered), so for footage use [`Decomposer::push`]
    /// and [`Decomposer::flush`] instead. Texels that are NaN, infinite or negative in any
    /// channel count as black (and are counted).
    pub fn process(&mut self, map: &PolarMap) -> FrameSummary {
        let mut last = self.push(map);
        while let Some(s) = self.flush() {
            last = Some(s);
        }
        match last {
            Some(s) => s,
            None => unreachable!("a pushed frame is given out by push or flush"),
        }
    }

    /// Takes the next input frame. With a causal filter, returns its summary (its lights are
    /// ready). With the zero-phase filter, returns the summary of the frame `m` before it once
    /// that frame's window is complete, else `None`; [`Decomposer::flush`] gives out the last
    /// `m` frames at the end.
    pub fn push(&mut self, map: &PolarMap) -> Option<FrameSummary> {
        let mut pending = self.sample(map);
        if self.cfg.temporal == Temporal::ZeroPhase {
            self.peak_powers.push_back(pending.peak_power);
            match (&pending.unfiltered, pending.status) {
                (_, Status::Dark) => self.centred.push_dark(),
                (Some(_), _) => self.centred.push(pending.power, &[]),
                (None, _) => self.centred.push(pending.power, &self.raw),
            }
            self.pending.push_back(pending);
            return if self.centred.ready() { self.emit_centred() } else { None };
        }
        let power = pending.power;
        // Causal (the paper's): the FIR with its delay; minimum phase (live, low delay first):
        // the peaks' power of this frame, as a step through a filter would lag.
        let peak_power = match self.cfg.temporal {
            Temporal::MinimumPhase => pending.peak_power,
            _ => self.peak_filter.step(pending.peak_power, &[], &mut self.no_lights).power,
        };
        let (step, peak_power) = match (pending.status, pending.unfiltered.take()) {
            (Status::Dark, _) => (self.filter.step_dark(&mut self.filtered), peak_power),
            (_, Some(lights)) => {
                self.filtered = lights;
                (fir::FilterStep { power, held: 0 }, pending.peak_power)
            }
            _ => (self.filter.step(power, &self.raw, &mut self.filtered), peak_power),
        };
        Some(self.finish(pending, step, peak_power))
    }

    /// Gives out the next pending frame at the end of a recording (zero phase, with the
    /// shortened symmetric window); `None` when none is pending (always with a causal filter).
    pub fn flush(&mut self) -> Option<FrameSummary> {
        if self.cfg.temporal == Temporal::ZeroPhase && self.centred.pending() { self.emit_centred() } else { None }
    }

    /// Filters the next pending frame with the zero-phase filter and finishes it.
    fn emit_centred(&mut self) -> Option<FrameSummary> {
        let (t, mut step) = self.centred.emit(&mut self.filtered)?;
        let mut p = self.pending.pop_front()?;
        debug_assert_eq!(p.frame, t);
        let mut peak_power = self.centred_peak_power(t);
        if let Some(lights) = p.unfiltered.take() {
            self.filtered = lights;
            step = fir::FilterStep { power: p.power, held: 0 };
            peak_power = p.peak_power;
        }
        Some(self.finish(p, step, peak_power))
    }

    /// The peaks' total power for frame `t` on files: the median over the FIR's centred window
    /// (shortened at the ends like it). A median removes a lamp's flicker as the FIR does
    /// (Havran §3.3) but keeps a step (a cloud reaching the sun) where it is, so the peaks'
    /// lights describe their own frame. Drops the frames no later window needs.
    fn centred_peak_power(&mut self, t: u64) -> f64 {
        let m = self.centred.half_width() as u64;
        let last = self.peak_first + self.peak_powers.len() as u64;
        if t < self.peak_first || t >= last {
            return 0.0;
        }
        let r = m.min(t - self.peak_first).min(last - 1 - t);
        let mut w: Vec<f64> = (t - r..=t + r).map(|k| self.peak_powers[(k - self.peak_first) as usize]).collect();
        let mid = w.len() / 2;
        let v = *w.select_nth_unstable_by(mid, f64::total_cmp).1;
        while self.peak_first + m < t + 1 && !self.peak_powers.is_empty() {
            self.peak_powers.pop_front();
            self.peak_first += 1;
        }
        v
    }

    /// Per frame, before filtering: peaks, the distribution and the raw samples (in `raw`), or
    /// median cut's lights.
    fn sample(&mut self, map: &PolarMap) -> Pending {
        let frame = self.pushed;
        self.pushed += 1;
        let n = self.cfg.glossy_lights.unwrap_or(0).max(self.cfg.lights);
        let coherent = self.cfg.sampler == SamplerKind::CoherentCut;
        let peaks_on = self.cfg.peaks_on();
        // At most N − 1 peak lights, so that `H` keeps a sample of the remainder; with a glossy
        // set they belong to `L` and `H` alike. The coherent cut reads the remainder as patches
        // of the map; the others get it as a map.
        match (peaks_on, coherent) {
            (true, true) => self.peaks.find(map, self.cfg.lights - 1),
            (true, false) => self.peaks.split(map, self.cfg.lights - 1),
            _ => {}
        }
        let map = if peaks_on && !coherent { self.peaks.remainder() } else { map };
        let n = n - self.peaks.peaks().len();
        // The coherent cut's summed-area tables give the power: no CDFs for it.
        let (sanitized, power, power_rgb) = if coherent {
            self.cut.rebuild_patched(map, if peaks_on { self.peaks.patches() } else { &[] });
            (self.cut.invalid_texels(), self.cut.total(), self.cut.total_rgb())
        } else {
            let s = self.dist.rebuild(map);
            (s, self.dist.integral(), self.dist.integral_rgb())
        };
        let status = if !(power > 0.0) && self.peaks.peaks().is_empty() { Status::Dark } else { Status::Ok };
        self.raw.clear();
        let mut unfiltered = None;
        if status == Status::Ok && self.cfg.sampler == SamplerKind::MedianCut {
            // Median cut has no sample identity for the FIR to follow: its lights go unfiltered.
            unfiltered = Some(sampling::median_cut::median_cut_lights(map, n));
        } else if status == Status::Ok && coherent {
            // One light per leaf, index = leaf index: the FIR follows each leaf. Every leaf holds
            // P/n, so the filter's equal sharing keeps each leaf's power; the colour goes in per
            // unit luminance.
            self.cut.lights_of_tables(n, &mut self.cut_lights);
            self.raw.extend(self.cut_lights.iter().map(|l| {
                let y = luminance(l.rgb);
                (l.dir, if y > 0.0 && y.is_finite() { l.rgb.map(|c| c / y) } else { [1.0; 3] })
            }));
        } else if status == Status::Ok {
            for k in 0..n {
                if let Some(r) = self.dist.sample(self.cfg.sampler, sampling::pattern::sample(self.cfg.pattern, k)) {
                    self.raw.push((r.dir, self.dist.light_rgb(map, &r)));
                }
            }
        }
        Pending {
            frame,
            status,
            sanitized,
            power_rgb,
            power,
            peaks: self.peaks.peaks().to_vec(),
            peak_power: self.peaks.peaks().iter().map(|l| luminance(l.rgb) as f64).sum(),
            unfiltered,
        }
    }

    /// Adds the frame's peaks to the filtered lights (to `L` and `H` with a glossy set: `H` is
    /// the first `N − peaks` samples of `L` rescaled, then the same peak lights), clusters them,
    /// builds the region lists and the summary. The peaks keep their directions and share
    /// `peak_power`, their filtered total power (Havran §3.3: a lamp's flicker is filtered
    /// like the rest of the map's; on files by a centred median, by the FIR with the paper's
    /// causal filter, not at all live with the minimum-phase one).
    fn finish(&mut self, mut p: Pending, mut step: fir::FilterStep, peak_power: f64) -> FrameSummary {
        let (mut power_rgb, mut power) = (p.power_rgb, p.power);
        let scale = if p.peak_power > 0.0 { (peak_power / p.peak_power) as f32 } else { 1.0 };
        for l in &p.peaks {
            (power, step.power) = (power + luminance(l.rgb) as f64, step.power + (luminance(l.rgb) * scale) as f64);
            for c in 0..3 {
                power_rgb[c] += l.rgb[c] as f64;
            }
        }
        p.peaks.iter_mut().for_each(|l| l.rgb = l.rgb.map(|c| c * scale));
        if self.glossy.is_some() {
            glossy::high_set(&self.filtered, self.cfg.lights.saturating_sub(p.peaks.len()), &mut self.high);
            self.high.extend_from_slice(&p.peaks);
        }
        self.filtered.extend_from_slice(&p.peaks);
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
            status: p.status,
            sanitized_texels: p.sanitized,
            power_rgb,
            power,
            filtered_power: step.power,
            held: step.held,
            describes_frame: p.frame.saturating_sub(self.delay_frames() as u64),
            frame: p.frame,
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

    /// The distribution of the last frame pushed (with the zero-phase filter, `m` frames after
    /// the one whose lights are out). Not built with the coherent cut (which needs no CDFs):
    /// then empty.
    pub fn distribution(&self) -> &PolarDistribution {
        &self.dist
    }
}
