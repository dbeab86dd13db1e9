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
//! - [`lamps`]: with `[[lights]]`, each lamp that is on and reaches the samples is one more
//!   column `ρ/π·E·V` whose scale `k` is fitted with `Pd` and `Pa` ([`solve_multi`]); without
//!   lamps nothing of it runs.
//! - [`noise`]: with the camera's read noise (`response.read_noise`), the fits weight rows by an
//!   absolute noise floor beside the relative one and model values clipped at zero.
//!   [`noise_level`] measures the read noise on the frame when the camera file says `"auto"`, or
//!   gives none and the sun is at or below the horizon (dusk and night).
//! - [`surface_flags`]: after each fitted frame, the fitted model on every valid pool entry; the
//!   entries that it cannot explain on two or more frames (a wet patch, a person: surfaces the
//!   proxy does not know) are left out of the later frames' draws, so what the bright frames see
//!   carries into the night, where their departure hides in the read noise.
//! - [`temporal`]: smooth across frames and detect when the lighting changed enough to relight.
//!
//! Thresholds are named constants or [`EstimatorConfig`] fields, documented where defined.

pub mod hindsight;
pub mod lamps;
pub mod lamp_bounce;
pub mod pool;
pub mod rebuild;
mod report;
mod gather;
mod decide;
pub mod noise;
pub mod noise_level;
pub mod sky_terms;
pub mod sky_band;
pub mod smoother;
pub mod solve;
pub mod solve_multi;
pub mod surface_flags;
mod turbidity;

pub use crate::scene::settings::EstimatorConfig;
use crate::geometry::raycast::RayScene;
use crate::io::frames::{Frame, Linearizer, PixelState};
use gather::Gathered;
use crate::scene::Scene;
use crate::camera::{Camera, View};
use crate::sun::{GeoFrame, Observer, SunError, SunPosition, sun_position};
use chrono::{DateTime, FixedOffset};
use glam::Vec3;
use pool::{PixelMap, Pool, SunState};
use rand::{SeedableRng, rngs::SmallRng};
use solve::{ChannelRows, HDR_NOISE_FLOOR_REL, LDR_NOISE_FLOOR_REL};
use std::sync::Arc;
use smoother::{ChangeDetector, ChangeReason, Smoother};
pub use turbidity::TurbidityFit;
pub use report::{EstimateError, Fallback, FrameEstimate, Intensities, LampReport, LampStatus, ReadNoiseReport, ReadNoiseSource, SampleCounts, SetupStats, Status, SunReport};

/// Rec. 709 luminance weights, used to compare colour intensities.
pub const LUMA: [f64; 3] = [0.2126, 0.7152, 0.0722];
/// Sunlit samples needed (besides the condition number) before `Pd` is fitted at all.
const MIN_LIT_SAMPLES: usize = 5;
/// When more than this fraction of the drawn samples of one surface and sun class (a proxy node,
/// sunlit or not) is clipped, its unclipped samples are dropped too: they are the darkest part of
/// a partly saturated population (albedo texture, noise), so keeping them would bias the fit low.
const CENSOR_FRACTION: f64 = 0.05;
/// A frame whose samples carry less than this fraction of the light that the smoothed lighting
/// predicts for the same samples is a [`Status::DarkFrame`]. Real light does not drop 50× within
/// [`DARK_MAX_GAP_S`]: a cloud over the sun leaves the sky (at least 20% of a clear day's light
/// on these surfaces), and dusk dims by about 2× per minute at its fastest.
pub const DARK_FRACTION: f64 = 0.02;
/// The relative darkness test applies only this soon after the last frame that updated the
/// smoother; after a longer gap (a time-lapse, a night), a dark frame is taken as real.
pub const DARK_MAX_GAP_S: f64 = 60.0;
/// The per-sequence estimator state.
pub struct Estimator {
    config: EstimatorConfig,
    observer: Observer,
    geo: GeoFrame,
    scene: Arc<RayScene>,
    map: PixelMap,
    pool: Pool,
    sun: Option<SunState>,
    /// The sun-dependent terms across frames ([`rebuild`]), and the last frame's work on them.
    sun_terms: rebuild::SunTerms,
    sun_timings: rebuild::SunTimings,
    smoother: Smoother,
    detector: ChangeDetector,
    last_split: Option<[f64; 3]>,
    last_smoothed: Option<[f64; 6]>,
    /// [`Estimator::overcast`]'s verdict, from the last frame that measured `Pd` with the sun up.
    overcast_sky: bool,
    t0: Option<DateTime<FixedOffset>>,
    /// The sky's shape and the terrain (`None`: Jensen's uniform sky), and their terms for the
    /// current sun.
    sky: Option<sky_terms::SkyTerms>,
    sun_sky: Option<sky_terms::SunSky>,
    /// Under `turbidity = "fit"`, the candidate of `sun_sky.by_turbidity` this frame's rows use
    /// ([`turbidity`]); `None`: the configured turbidity.
    turbidity_pick: Option<usize>,
    /// Time of the last frame that updated the smoother.
    last_update: Option<DateTime<FixedOffset>>,
    rows: [ChannelRows; 3],
    lit: Vec<bool>,
    bounce_only: Vec<[f64; 3]>,
    rho_over_pi: Vec<[f64; 3]>,
    drawn: Vec<u32>,
    states: Vec<([f32; 3], PixelState)>,
    noise_floor: f64,
    /// This frame's read noise in radiance (`noise`; 0: relative weights only).
    read_noise: f64,
    stats: SetupStats,
    /// The scene's lamps and their terms on the pool ([`lamps`]); `None` without lamps.
    lamps: Option<lamps::LampColumns>,
    /// This frame's lamps: which are fitted, and their reports.
    lamp_frame: Option<lamps::LampFrame>,
    /// Pool entry of each usable row.
    entries: Vec<u32>,
    /// At twilight ([`sky_band`]): each usable row's horizon-band coefficient per channel.
    band_rows: Vec<[f64; 3]>,
    /// This frame's horizon band.
    band: sky_band::BandFrame,
    /// The band's ratio to the sky's shape carried from the earlier twilight frames (the prior
    /// of [`sky_band`]'s "At night"); `None` before the first or after the sun rose past the band.
    band_track: Option<sky_band::BandTrack>,
    /// The frame's sun elevation, degrees (the clock of the band's prior).
    sun_elevation_deg: f64,
    /// Per-surface outlier flags carried across frames ([`surface_flags`]); `None` when off.
    flags: Option<surface_flags::SurfaceFlags>,
    /// This frame's flag report, from the draw to the update.
    flag_report: Option<surface_flags::SurfaceFlagsReport>,
    /// On a frame whose sun is up but unseen (`Pd` held or unobservable): the `Pd` of its fit's
    /// model of the shadowed rows (the fitted bounce's, the held one, or 0).
    flag_pd: Option<[f64; 3]>,
}

fn luma(v: &[f64; 3]) -> f64 {
    v[0] * LUMA[0] + v[1] * LUMA[1] + v[2] * LUMA[2]
}

impl Estimator {
    /// Sets up the estimator for a scene: builds the pixel map and the pool.
    /// With `[[lights]]`, their models are read and their terms traced on the pool ([`lamps`]).
    pub fn new(scene: &Scene, ray_scene: Arc<RayScene>) -> Result<Self, EstimateError> {
        let lamps = crate::lamps::Lamp::load_all(&scene.root.join(crate::scene::MANIFEST_FILE), &scene.lights)?;
        let mut est = Self::with_camera(scene.estimator.clone(), scene.observer, scene.geo, &scene.camera, ray_scene)?;
        est.set_lamps(lamps);
        Ok(est)
    }

    /// A new estimator for `scene` on this one's ray scene, with no temporal state: the same
    /// estimates again from the first frame it is given (the lamps' pre-pass of
    /// `run::augment`, [`hindsight`]).
    pub fn fresh(&self, scene: &Scene) -> Result<Self, EstimateError> {
        Self::new(scene, self.scene.clone())
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
        let sky = sky_terms::SkyTerms::build(&pool, &scene, &config.sky).map_err(EstimateError::Sky)?;
        let pool_ms = t.elapsed().as_secs_f64() * 1e3;
        let stats = SetupStats {
            diffuse_pixels: map.diffuse_pixels,
            candidate_pixels: candidates,
            pool_entries: pool.len(),
            pixel_map_ms,
            pool_ms,
        };
        let flags = config.surface_flags.then(|| surface_flags::SurfaceFlags::new(pool.len()));
        Ok(Self {
            config,
            observer,
            geo,
            scene,
            map,
            pool,
            sun: None,
            sun_terms: rebuild::SunTerms::default(),
            sun_timings: rebuild::SunTimings::default(),
            smoother: Smoother::default(),
            detector: ChangeDetector::default(),
            last_split: None,
            last_smoothed: None,
            overcast_sky: false,
            t0: None,
            last_update: None,
            sky,
            sun_sky: None,
            turbidity_pick: None,
            rows: Default::default(),
            lit: Vec::new(),
            bounce_only: Vec::new(),
            rho_over_pi: Vec::new(),
            drawn: Vec::new(),
            states: Vec::new(),
            noise_floor: HDR_NOISE_FLOOR_REL,
            read_noise: 0.0,
            stats,
            lamps: None,
            lamp_frame: None,
            entries: Vec::new(),
            band_rows: Vec::new(),
            band: sky_band::BandFrame::default(),
            band_track: None,
            sun_elevation_deg: 0.0,
            flags,
            flag_report: None,
            flag_pd: None,
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

    /// The last frame's usable rows, for diagnostics: the pool entry of each row and the rows of
    /// each channel (`a` the sky's column, `b` the sun's, `y` the observations as fitted).
    pub fn frame_rows(&self) -> (&[u32], &[ChannelRows; 3]) {
        (&self.entries, &self.rows)
    }

    /// The last frame's horizon-band coefficients per fitted row (`sky_band`; empty when the band
    /// was not a column).
    pub fn frame_band_rows(&self) -> &[[f64; 3]] {
        &self.band_rows
    }

    /// The pixels (row-major indices) of the pool entries flagged by [`surface_flags`] (empty
    /// when they are off), for diagnostics.
    pub fn flagged_pixels(&self) -> Vec<u32> {
        let Some(f) = self.flags.as_ref() else { return Vec::new() };
        (0..self.pool.len()).filter(|&e| f.is_flagged(e)).map(|e| self.pool.pixel[e]).collect()
    }

    /// The current sun state, after the first frame.
    pub fn sun_state(&self) -> Option<&SunState> {
        self.sun.as_ref()
    }

    /// The last frame that measured `Pd` with the sun up found no direct sun (smoothed `Pd` below
    /// `no_sun_ratio` of `Pa`): the sky is taken as uniform (see `sky_terms`). Frames that did not
    /// measure it (the sun set, or `Pd` unobservable or held) leave the verdict as it was: a sun
    /// at or below the horizon says nothing about cloud, and its twilight sky is far from uniform
    /// (on `scenes/dusk` the uniform sky put the paving 15% and the walls 26% off the frames at
    /// 19:10, against 5% and 2–4% with the shaped sky).
    fn overcast(&self) -> bool {
        self.overcast_sky
    }

    /// The sky this frame's model uses (see `sky_terms`: overcast frames use the uniform one).
    fn sky_used(&self) -> crate::scene::settings::SkyShape {
        match (&self.sky, self.overcast()) {
            (Some(_), false) => self.config.sky.shape,
            _ => crate::scene::settings::SkyShape::Uniform,
        }
    }

    /// The sky model of this frame's fit for the report, e.g. `hosek_wilkie T=3` or `uniform`
    /// (`None` under Jensen's configured model, whose reports stay as they were).
    fn sky_model_name(&self, fit: Option<&TurbidityFit>) -> Option<String> {
        self.sky.as_ref()?;
        Some(match self.sky_used() {
            crate::scene::settings::SkyShape::Uniform => "uniform".to_owned(),
            crate::scene::settings::SkyShape::HosekWilkie => {
                format!("hosek_wilkie T={}", fit.map_or(self.config.sky.turbidity.value(), |f| f.chosen))
            }
        })
    }

    /// Sun position and world direction at `time`.
    pub fn sun_at(&self, time: &DateTime<FixedOffset>) -> Result<(SunPosition, Vec3), SunError> {
        let pos = sun_position(&self.observer, time)?;
        Ok((pos, self.geo.sun_dir_in_world(&pos)))
    }

    /// The sky terms served with the current sun state (`None` for Jensen's sky).
    pub fn sun_sky(&self) -> Option<&sky_terms::SunSky> {
        self.sun_sky.as_ref()
    }

    /// The last frame's work on the sun-dependent terms (see [`rebuild`]).
    pub fn sun_timings(&self) -> rebuild::SunTimings {
        self.sun_timings
    }

    /// A re-trace of the bounce and sky terms in progress: its sun and the fraction done.
    pub fn retrace_progress(&self) -> Option<(Vec3, f64)> {
        self.sun_terms.retrace_progress(self.pool.len())
    }

    /// Moves the sun-dependent terms on to `dir` ([`rebuild`]); returns whether the direct
    /// terms were rebuilt.
    fn ensure_sun(&mut self, dir: Vec3, above: bool) -> Result<bool, EstimateError> {
        let inp = rebuild::Inputs { map: &self.map, pool: &self.pool, scene: &self.scene, cfg: &self.config, sky: self.sky.as_ref() };
        let (timings, served) = self.sun_terms.update(&inp, dir, above).map_err(EstimateError::Sky)?;
        if let Some((state, sky)) = served {
            self.sun = Some(state);
            self.sun_sky = sky;
        }
        self.sun_timings = timings;
        Ok(timings.direct_rebuilt)
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
        self.sun_elevation_deg = f64::from(dir.normalize_or_zero().y.clamp(-1.0, 1.0)).asin().to_degrees();
        self.noise_floor = match frame.data {
            crate::io::frames::FrameData::Ldr { .. } => LDR_NOISE_FLOOR_REL,
            crate::io::frames::FrameData::Hdr(_) => HDR_NOISE_FLOOR_REL,
        };
        let read_noise = read_noise_of(frame, lin, above);
        self.read_noise = read_noise.map_or(0.0, |r| r.value);
        let rebuilt = self.ensure_sun(dir, above)?;
        let sun_rebuild_ms = self.sun_timings.total_ms();
        let t_start = std::time::Instant::now();

        let mut rng = SmallRng::seed_from_u64(self.config.seed ^ (index as u64).wrapping_mul(0x9e37_79b9_7f4a_7c15));
        let turbidity_fit = self.choose_turbidity(frame, lin, &rng);
        let Gathered { counts, clipped_lit, saturated } = self.gather(frame, lin, &mut rng);

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
            sky: self.sky_used(),
            sky_model: self.sky_model_name(turbidity_fit.as_ref()),
            terrain: self.sky.as_ref().map(|_| self.config.sky.terrain_used()),
            turbidity_fit,
            lamps: Vec::new(),
            read_noise,
            sky_band: None,
            surface_flags: None,
        };

        self.prepare_lamps(time);
        if self.is_dark(time) {
            out.status = Status::DarkFrame;
            out.estimate_ms = t_start.elapsed().as_secs_f64() * 1e3;
            out.smoothed = self.last_smoothed.map(|s| Intensities { pd: [s[0], s[1], s[2]], pa: [s[3], s[4], s[5]] });
            out.lamps = self.lamp_reports();
            self.learn_flags(&mut out, frame, lin);
            return Ok(out);
        }
        self.decide(&mut out, above, clipped_lit, saturated, &mut rng);
        out.lamps = self.lamp_reports();
        out.sky_band = self.band.report.take();
        self.learn_flags(&mut out, frame, lin);
        out.estimate_ms = t_start.elapsed().as_secs_f64() * 1e3;
        self.smooth(&mut out, time, dir);
        Ok(out)
    }
}

/// The read noise of a frame's fit (`noise`): the camera file's number; measured on the frame
/// ([`noise_level`]) under `"auto"`, or when the file gives none and the sun is not above the
/// horizon; else none (the relative fit of `solve`, as before there was a read-noise model).
fn read_noise_of(frame: &Frame, lin: &Linearizer, sun_above: bool) -> Option<ReadNoiseReport> {
    use crate::io::frames::ReadNoise;
    let source = match lin.read_noise_setting() {
        ReadNoise::Given(v) if v > 0.0 => return Some(ReadNoiseReport { source: ReadNoiseSource::File, value: lin.read_noise(), se: None, blocks: None }),
        ReadNoise::Given(_) => return None,
        ReadNoise::Unknown if sun_above => return None,
        ReadNoise::Unknown => ReadNoiseSource::FrameAtDusk,
        ReadNoise::Auto => ReadNoiseSource::Frame,
    };
    Some(match noise_level::measure(frame, lin) {
        Some(m) => ReadNoiseReport { source, value: m.read_noise, se: Some(m.read_noise_se), blocks: Some(m.blocks) },
        None => ReadNoiseReport { source, value: 0.0, se: None, blocks: Some(0) },
    })
}
