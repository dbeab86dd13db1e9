//! The outdoor illumination estimator (Jensen §3.1, with the model of §4.2).
//!
//! Given a frame, its capture time and the calibrated scene, the estimator returns the sun
//! direction (from the solar position model), the sun's irradiance `Pd` and the sky's irradiance
//! `Pa` (RGB, see the crate docs for their definitions), their standard errors, and a status that
//! says how far the fit can be trusted.
//!
//! # How it works
//! - [`pool`]: a one-off pixel map and sample pool over the marked diffuse surfaces seen by the
//!   camera, with `ρ`, `n` and `c` per entry; per sun direction, `s`, `max(n·l,0)` and the
//!   shadow-boundary exclusion.
//! - Per frame: draw N entries (default 500, without replacement, seeded by frame index, half
//!   from sunlit and half from shadowed entries when both exist: [`SunState::draw`]), read
//!   and linearise their pixels, drop clipped and invalid ones, and fit
//!   `I = ρ/π·(c·Pa + (s·max(n·l,0) + b)·Pd)` per channel with [`solve::robust_fit`].
//! - Decide the [`Status`]; when `Pd` and `Pa` cannot be separated, fall back (see [`Fallback`])
//!   instead of reporting an arbitrary split.
//! - [`temporal`]: smooth across frames and detect when the lighting changed enough to relight.
//!
//! Thresholds are named constants or [`EstimatorConfig`] fields, documented where defined.

pub mod pool;
pub mod smoother;
pub mod solve;

pub use crate::scene::settings::EstimatorConfig;
use crate::geometry::raycast::RayScene;
use crate::io::frames::{Frame, Linearizer, PixelState};
use crate::scene::Scene;
use crate::camera::{Camera, View};
use crate::sun::{GeoFrame, Observer, SunError, SunPosition, sun_position};
use chrono::{DateTime, FixedOffset};
use glam::Vec3;
use pool::{PixelMap, Pool, SunState};
use rand::{SeedableRng, rngs::SmallRng};
use serde::{Deserialize, Serialize};
use solve::{COND_CAP, ChannelFit, ChannelRows, HDR_NOISE_FLOOR_REL, LDR_NOISE_FLOOR_REL, robust_fit};
use std::sync::Arc;
use smoother::{ChangeDetector, ChangeReason, Smoother};

/// Rec. 709 luminance weights, used to compare colour intensities.
pub const LUMA: [f64; 3] = [0.2126, 0.7152, 0.0722];
/// Sunlit samples needed (besides the condition number) before `Pd` is fitted at all.
const MIN_LIT_SAMPLES: usize = 5;
/// When more than this fraction of the drawn samples of one surface and sun class (a proxy node,
/// sunlit or not) is clipped, its unclipped samples are dropped too: they are the darkest part of
/// a partly saturated population (albedo texture, noise), so keeping them would bias the fit low.
const CENSOR_FRACTION: f64 = 0.05;

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
}

impl Status {
    /// All statuses, in report order.
    pub const ALL: [Status; 6] =
        [Status::Ok, Status::SunNotSeparable, Status::NoDirectSun, Status::Night, Status::TooFewSamples, Status::Saturated];
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
    /// Time of the sun-visibility rebuild, ms (0 when not rebuilt).
    pub sun_rebuild_ms: f64,
    /// Time of the per-frame estimate (sampling and fit, excluding decode and rebuild), ms.
    pub estimate_ms: f64,
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

/// The per-sequence estimator state.
pub struct Estimator {
    config: EstimatorConfig,
    observer: Observer,
    geo: GeoFrame,
    scene: Arc<RayScene>,
    map: PixelMap,
    pool: Pool,
    sun: Option<SunState>,
    smoother: Smoother,
    detector: ChangeDetector,
    last_split: Option<[f64; 3]>,
    last_smoothed: Option<[f64; 6]>,
    t0: Option<DateTime<FixedOffset>>,
    rows: [ChannelRows; 3],
    lit: Vec<bool>,
    bounce_only: Vec<[f64; 3]>,
    rho_over_pi: Vec<[f64; 3]>,
    drawn: Vec<u32>,
    states: Vec<([f32; 3], PixelState)>,
    noise_floor: f64,
    stats: SetupStats,
}

fn luma(v: &[f64; 3]) -> f64 {
    v[0] * LUMA[0] + v[1] * LUMA[1] + v[2] * LUMA[2]
}

impl Estimator {
    /// Sets up the estimator for a scene: builds the pixel map and the pool.
    pub fn new(scene: &Scene, ray_scene: Arc<RayScene>) -> Result<Self, EstimateError> {
        Self::with_camera(scene.estimator.clone(), scene.observer, scene.geo, &scene.camera, ray_scene)
    }

    /// Sets up the estimator from its parts, for a calibrated camera.
    pub fn with_camera(
        config: EstimatorConfig,
        observer: Observer,
        geo: GeoFrame,
        camera: &Camera,
        scene: Arc<RayScene>,
    ) -> Result<Self, EstimateError> {
        Self::with_view(config, observer, geo, View::Camera(camera), scene)
    }

    /// Sets up the estimator for any view: a camera, or an equirect environment map at its
    /// capture centre (the bake estimates the lighting of the capture this way).
    pub fn with_view(
        config: EstimatorConfig,
        observer: Observer,
        geo: GeoFrame,
        view: View,
        scene: Arc<RayScene>,
    ) -> Result<Self, EstimateError> {
        let t = std::time::Instant::now();
        let map = PixelMap::build(view, &scene, config.edge_margin_px);
        let pixel_map_ms = t.elapsed().as_secs_f64() * 1e3;
        let candidates = map.candidates();
        if candidates < 3 {
            return Err(EstimateError::NoCandidates { diffuse: map.diffuse_pixels, margin: config.edge_margin_px });
        }
        let t = std::time::Instant::now();
        let pool = Pool::build(&map, &scene, config.pool_size, config.ambient, config.seed);
        let pool_ms = t.elapsed().as_secs_f64() * 1e3;
        let stats = SetupStats {
            diffuse_pixels: map.diffuse_pixels,
            candidate_pixels: candidates,
            pool_entries: pool.len(),
            pixel_map_ms,
            pool_ms,
        };
        Ok(Self {
            config,
            observer,
            geo,
            scene,
            map,
            pool,
            sun: None,
            smoother: Smoother::default(),
            detector: ChangeDetector::default(),
            last_split: None,
            last_smoothed: None,
            t0: None,
            rows: Default::default(),
            lit: Vec::new(),
            bounce_only: Vec::new(),
            rho_over_pi: Vec::new(),
            drawn: Vec::new(),
            states: Vec::new(),
            noise_floor: HDR_NOISE_FLOOR_REL,
            stats,
        })
    }

    /// Set-up statistics.
    pub fn stats(&self) -> SetupStats {
        self.stats
    }

    /// The configuration.
    pub fn config(&self) -> &EstimatorConfig {
        &self.config
    }

    /// Changes the per-frame sample count (for sweeps); it is capped by the pool size.
    pub fn set_samples(&mut self, n: usize) {
        self.config.samples = n.max(3);
    }

    /// The pool (for inspection and tests).
    pub fn pool(&self) -> &Pool {
        &self.pool
    }

    /// The pixel map.
    pub fn pixel_map(&self) -> &PixelMap {
        &self.map
    }

    /// The current sun state, after the first frame.
    pub fn sun_state(&self) -> Option<&SunState> {
        self.sun.as_ref()
    }

    /// Sun position and world direction at `time`.
    pub fn sun_at(&self, time: &DateTime<FixedOffset>) -> Result<(SunPosition, Vec3), SunError> {
        let pos = sun_position(&self.observer, time)?;
        Ok((pos, self.geo.sun_dir_in_world(&pos)))
    }

    /// Makes sure the sun state matches `dir`; returns whether it was rebuilt.
    fn ensure_sun(&mut self, dir: Vec3, above: bool) -> bool {
        let stale = match &self.sun {
            None => true,
            Some(s) => {
                s.above_horizon != above
                    || (above && (s.dir.dot(dir).clamp(-1.0, 1.0).acos().to_degrees() as f64) > self.config.sun_rebuild_deg)
            }
        };
        if stale {
            self.sun = Some(SunState::build(&self.map, &self.pool, &self.scene, dir, above, &self.config));
        }
        stale
    }

    /// Estimates the lighting of one frame. `index` seeds the frame's draw.
    pub fn estimate(
        &mut self,
        index: usize,
        time: &DateTime<FixedOffset>,
        frame: &Frame,
        lin: &Linearizer,
    ) -> Result<FrameEstimate, EstimateError> {
        let (pos, dir) = self.sun_at(time)?;
        let above = pos.above_horizon();
        self.noise_floor = match frame.data {
            crate::io::frames::FrameData::Ldr { .. } => LDR_NOISE_FLOOR_REL,
            crate::io::frames::FrameData::Hdr(_) => HDR_NOISE_FLOOR_REL,
        };
        let rebuilt = self.ensure_sun(dir, above);
        let sun_rebuild_ms = if rebuilt { self.sun.as_ref().map_or(0.0, |s| s.build_ms) } else { 0.0 };
        let t_start = std::time::Instant::now();
        let Some(sun) = self.sun.as_ref() else { unreachable!("ensure_sun always sets the state") };

        // Draw.
        let mut rng = SmallRng::seed_from_u64(self.config.seed ^ (index as u64).wrapping_mul(0x9e37_79b9_7f4a_7c15));
        let available = sun.available();
        let n = self.config.samples.min(available);
        let mut drawn = std::mem::take(&mut self.drawn);
        sun.draw(n, &mut rng, &mut drawn);
        for r in &mut self.rows {
            r.clear();
        }
        self.lit.clear();
        self.bounce_only.clear();
        self.rho_over_pi.clear();
        let mut counts = SampleCounts { available, drawn: n, ..Default::default() };
        let mut clipped_lit = 0;
        // Censoring: count drawn and clipped samples per (node, lit) group first.
        let mut groups: Vec<(u32, bool, u32, u32)> = Vec::new(); // (node, lit, drawn, clipped)
        let mut states = std::mem::take(&mut self.states);
        states.clear();
        for &e in &drawn {
            let e = e as usize;
            let (v, state) = lin.radiance(frame, self.pool.pixel[e] as usize);
            states.push((v, state));
            let key = (self.pool.node[e], sun.lit[e]);
            let g = match groups.iter().position(|g| (g.0, g.1) == key) {
                Some(g) => g,
                None => {
                    groups.push((key.0, key.1, 0, 0));
                    groups.len() - 1
                }
            };
            groups[g].2 += 1;
            groups[g].3 += (state == PixelState::Clipped) as u32;
        }
        let censored = |node: u32, lit: bool| {
            groups.iter().any(|g| g.0 == node && g.1 == lit && g.3 as f64 > CENSOR_FRACTION * g.2 as f64)
        };
        for (&e, &(v, state)) in drawn.iter().zip(&states) {
            let e = e as usize;
            match state {
                PixelState::Invalid => counts.invalid += 1,
                PixelState::Clipped => {
                    counts.clipped += 1;
                    clipped_lit += sun.lit[e] as usize;
                }
                PixelState::Ok if censored(self.pool.node[e], sun.lit[e]) => counts.censored += 1,
                PixelState::Ok => {
                    let (a, b) = (self.pool.a[e], sun.b[e]);
                    for c in 0..3 {
                        self.rows[c].push(a[c] as f64, b[c] as f64, v[c] as f64);
                    }
                    self.lit.push(sun.lit[e]);
                    // The part of b that is bounce light only (for held-Pd subtraction).
                    let bo = if sun.lit[e] { [0.0; 3] } else { [b[0] as f64, b[1] as f64, b[2] as f64] };
                    self.bounce_only.push(bo);
                    let rho = self.pool.albedo[e] / std::f32::consts::PI;
                    self.rho_over_pi.push([rho.x as f64, rho.y as f64, rho.z as f64]);
                }
            }
        }
        self.states = states;
        self.drawn = drawn;
        counts.usable = self.rows[0].len();
        counts.lit = self.lit.iter().filter(|&&l| l).count();
        let saturated = n > 0 && counts.clipped as f64 > self.config.saturated_fraction * n as f64;

        let mut out = FrameEstimate {
            frame: index,
            time: time.to_rfc3339(),
            sun: SunReport { position: pos, above_horizon: above, dir_world: dir.to_array() },
            status: Status::Ok,
            fallback: None,
            pd: None,
            pa: None,
            pd_se: None,
            pa_se: None,
            total_irradiance: None,
            residual_rms: None,
            condition_number: None,
            samples: counts,
            smoothed: None,
            relight: false,
            change: ChangeReason::Unchanged,
            sun_rebuilt: rebuilt,
            sun_rebuild_ms,
            estimate_ms: 0.0,
        };

        let held_pd = self.last_smoothed.map(|s| [s[0], s[1], s[2]]);
        if counts.usable < self.config.min_samples.max(3) {
            out.status = if saturated { Status::Saturated } else { Status::TooFewSamples };
        } else if !above {
            // Night: no direct sun; fit Pa alone.
            let fits = self.fit_channels(false, &mut rng);
            self.fill_pa_only(&mut out, &fits);
            out.pd = Some([0.0; 3]);
            out.pd_se = Some([0.0; 3]);
            out.status = Status::Night;
        } else if counts.lit < MIN_LIT_SAMPLES {
            // No sunlit samples: Pa is observable, Pd is not (directly). Shadowed samples still
            // receive sun light bounced off lit proxy surfaces (the `b` column). Where that bounce
            // varies enough across the samples, a two-parameter fit separates it and Pa is
            // unbiased; otherwise the bounce of the held Pd is subtracted, or, with nothing held,
            // Pa absorbs it (reported as such through the status).
            let bounce_fit = self.fit_channels(true, &mut rng).filter(|f| {
                f.iter().all(|c| c.condition <= self.config.max_condition && c.pd_se.is_finite())
                    && luma(&f.map(|c| c.pa_se)) < 0.1 * luma(&f.map(|c| c.pa))
            });
            match bounce_fit {
                Some(f) => {
                    self.fill_pa_only(&mut out, &Some(f));
                    out.condition_number = Some(f.iter().map(|c| c.condition).fold(1.0, f64::max));
                }
                None => {
                    if let Some(pd) = held_pd {
                        for i in 0..counts.usable {
                            for c in 0..3 {
                                self.rows[c].y[i] -= self.bounce_only[i][c] * pd[c];
                            }
                        }
                    }
                    let fits = self.fit_channels(false, &mut rng);
                    self.fill_pa_only(&mut out, &fits);
                }
            }
            match held_pd {
                Some(pd) => {
                    out.pd = Some(pd);
                    out.fallback = Some(Fallback::HeldPd);
                }
                None => out.fallback = Some(Fallback::PdUnobservable),
            }
            out.status = if saturated || clipped_lit > 0 { Status::Saturated } else { Status::SunNotSeparable };
        } else {
            let fits = self.fit_channels(true, &mut rng);
            if let Some(fits) = fits {
                let pd = fits.map(|f| f.pd);
                let pa = fits.map(|f| f.pa);
                let cond = fits.iter().map(|f| f.condition).fold(1.0, f64::max);
                out.condition_number = Some(cond);
                out.residual_rms = Some(fits.map(|f| f.residual_rms));
                out.samples.inliers = fits.iter().map(|f| f.inliers).min().unwrap_or(0);
                let pa_rel_se = luma(&fits.map(|f| f.pa_se)) / luma(&pa).max(1e-300);
                if cond > self.config.max_condition || !(pa_rel_se < 0.5) {
                    out.status = Status::SunNotSeparable;
                    self.separable_fallback(&mut out, &mut rng);
                } else {
                    out.pd = Some(pd);
                    out.pa = Some(pa);
                    out.pd_se = Some(fits.map(|f| f.pd_se));
                    out.pa_se = Some(fits.map(|f| f.pa_se));
                    if luma(&pd) < self.config.no_sun_ratio * luma(&pa) {
                        out.status = Status::NoDirectSun;
                    } else {
                        out.status = Status::Ok;
                        self.last_split = Some(std::array::from_fn(|c| if pa[c] > 0.0 { pd[c] / pa[c] } else { 0.0 }));
                    }
                }
            }
            if saturated {
                out.status = Status::Saturated;
            }
        }
        out.estimate_ms = t_start.elapsed().as_secs_f64() * 1e3;

        // Temporal smoothing and change detection.
        let t0 = *self.t0.get_or_insert(*time);
        let t_s = (*time - t0).num_microseconds().unwrap_or(0) as f64 * 1e-6;
        let observed_pd = matches!(out.status, Status::Ok | Status::NoDirectSun | Status::Night | Status::Saturated)
            && out.fallback.is_none();
        let mut meas = [None; 6];
        for c in 0..3 {
            if observed_pd && let (Some(pd), Some(se)) = (out.pd, out.pd_se) {
                meas[c] = Some((pd[c], if se[c].is_finite() { se[c] } else { pd[c].abs() }));
            }
            if let (Some(pa), Some(se)) = (out.pa, out.pa_se) {
                meas[c + 3] = Some((pa[c], if se[c].is_finite() { se[c] } else { pa[c].abs() }));
            }
        }
        if let Some(s) = self.smoother.update(t_s, self.config.smoothing_rate_per_sqrt_s, meas) {
            self.last_smoothed = Some(s);
            out.smoothed = Some(Intensities { pd: [s[0], s[1], s[2]], pa: [s[3], s[4], s[5]] });
            out.change = self.detector.check(dir, s, self.config.relight_threshold, self.config.relight_sun_deg);
            out.relight = out.change != ChangeReason::Unchanged;
        }
        Ok(out)
    }

    fn fit_channels(&self, two: bool, rng: &mut SmallRng) -> Option<[ChannelFit; 3]> {
        let fl = self.noise_floor;
        let f0 = robust_fit(&self.rows[0], &self.lit, two, fl, rng)?;
        let f1 = robust_fit(&self.rows[1], &self.lit, two, fl, rng)?;
        let f2 = robust_fit(&self.rows[2], &self.lit, two, fl, rng)?;
        Some([f0, f1, f2])
    }

    fn fill_pa_only(&self, out: &mut FrameEstimate, fits: &Option<[ChannelFit; 3]>) {
        if let Some(f) = fits {
            out.pa = Some(f.map(|f| f.pa));
            out.pa_se = Some(f.map(|f| f.pa_se));
            out.residual_rms = Some(f.map(|f| f.residual_rms));
            out.samples.inliers = f.iter().map(|f| f.inliers).min().unwrap_or(0);
            out.condition_number = Some(1.0);
        }
    }

    /// `Pd`/`Pa` not separable: hold the last split, or report the total irradiance.
    fn separable_fallback(&mut self, out: &mut FrameEstimate, rng: &mut SmallRng) {
        let n = self.rows[0].len();
        match self.last_split {
            Some(k) => {
                // y = (a + k·b)·Pa: a one-parameter fit per channel.
                let mut fits = [ChannelFit::default(); 3];
                for c in 0..3 {
                    let r = &self.rows[c];
                    let mut z = ChannelRows::default();
                    for i in 0..n {
                        z.push(r.a[i] + k[c] * r.b[i], 0.0, r.y[i]);
                    }
                    if let Some(f) = robust_fit(&z, &self.lit, false, self.noise_floor, rng) {
                        fits[c] = f;
                    }
                }
                out.pa = Some(fits.map(|f| f.pa));
                out.pd = Some(std::array::from_fn(|c| k[c] * fits[c].pa));
                out.pa_se = Some(fits.map(|f| f.pa_se));
                out.pd_se = Some(std::array::from_fn(|c| k[c] * fits[c].pa_se));
                out.fallback = Some(Fallback::HeldSplit);
            }
            None => {
                // y = ρ/π·E, with E the irradiance on the sampled surfaces (c·Pa + s·cos·Pd
                // evaluated on their common geometry).
                let mut total = [0.0; 3];
                for c in 0..3 {
                    let r = &self.rows[c];
                    let mut z = ChannelRows::default();
                    for i in 0..n {
                        z.push(self.rho_over_pi[i][c], 0.0, r.y[i]);
                    }
                    if let Some(f) = robust_fit(&z, &self.lit, false, self.noise_floor, rng) {
                        total[c] = f.pa;
                    }
                }
                out.total_irradiance = Some(total);
                out.fallback = Some(Fallback::TotalIrradiance);
            }
        }
        out.condition_number = out.condition_number.map(|c| c.min(COND_CAP));
    }
}
