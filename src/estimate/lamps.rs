//! The estimator learns the lamps (issue 16 §3): lamp light on the samples is one more known-shape
//! term of Jensen's model (§3.1), `y = ρ/π·(c·Pa + (s·cos + b)·Pd) + Σ_i k_i·g_i`, with
//! `g_i = ρ/π · E_i · V_i`: `E_i` the irradiance of lamp `i`'s model at the sample
//! ([`crate::lamps::model`]; Granier Eq. 14 for light fields), `V_i` the proxy's visibility from
//! the sample to the lamp (a shadow ray in the estimator's ray scene) and `k_i` the unknown scale
//! from the model's units to the frame's.
//!
//! # How it works
//! - **Once** ([`LampColumns::build`]): `g_i` of every pool entry (lamps and proxy do not move;
//!   the bounce makes `heliar estimate scenes/dusk` (4096 entries, 64 paths, 2 shared cores)
//!   take 4.1 s instead of 1.6 s, once per run),
//!   and each entry's lamp *band*: octaves below the brightest entry of its summed prior lamp
//!   light. Censoring (`gather`) groups samples by band too, so the pixels a lamp saturates
//!   censor their own octave, not the whole surface: within a band the lamp light is modelled,
//!   not unknown texture.
//! - **Per frame** ([`Estimator::prepare_lamps`]): a lamp off by its schedule is left out
//!   (`off`); one whose light reaches fewer than [`MIN_LAMP_SAMPLES`] usable samples keeps its
//!   prior `k` (`unreached`; its light on those few is taken off `y`); the others are columns of
//!   the robust NNLS ([`super::solve_multi`]) beside `Pa` and `Pd`.
//! - **Separability** ([`Estimator::fit_channels_lamps`]): a lamp column whose condition number
//!   against the others exceeds `max_condition` cannot be told apart. Two or more such lamps
//!   (lighting the same surfaces) are merged into one column at their prior ratio and fitted
//!   together; a lamp still inseparable (from the sun and sky) keeps its prior and its light is
//!   taken off `y`. Their status is `not_separable` with the condition number and the reason.
//!
//! Without `[[lights]]`, or with every lamp off or unreached, none of this runs and the estimator
//! is the two-column one, bit for bit.
//!
//! # Accuracy
//! On `scenes/dusk` (`docs/measurements.md`, "Why the dusk lamp's `k` came out low") `g` matches
//! the generator's lamp light within 2% on the samples within 6 m of the lamp's foot, and with
//! every sample's light made the model's the fit leaves `k` within 6% (the sensor noise). `k`
//! comes out 0.70–0.99 on frames 1–3 because the generator's twilight sky differs from the
//! model's (the walls 2–11% brighter, the paving 2–3% darker per unit `Pa`) while the lamp is
//! 2–20% of the samples' light; rows the proxy does not model (a person between a sample and the
//! lamp, a wet patch) cost another ≈ 0.02 each and are within the read noise per pixel, so the
//! robust fit cannot reject them one by one. The twilight horizon band ([`super::sky_band`]), a
//! second sky column that absorbs most of the shape's error, lifts the mean `k` over seeds 0–4
//! on frames 1–5 from 0.80, 0.85, 0.87, 0.90, 1.00 to 0.95, 0.97, 0.92, 0.94, 1.01
//! (`docs/measurements.md`, "A horizon band in the twilight sky's fit"). The surface flags
//! ([`super::surface_flags`]) learn the person and the wet patch on the bright frames and leave
//! them out of the night's draws: with the band's ratio carried, the mean over the seeds on
//! frames 2–5 goes from 0.967, 0.920, 0.921, 1.003 to 0.977, 0.968, 0.993, 1.014
//! (`docs/measurements.md`, "Per-surface outlier flags carried from the bright frames").

use super::pool::Pool;
use super::report::{LampReport, LampStatus};
use super::solve::{ChannelFit, COND_CAP};
use super::smoother::LampSmoother;
use super::noise::robust_fit_noise;
use super::solve_multi::MultiFit;
use super::{Estimator, luma};
pub use super::lamp_bounce::LAMP_CLEARANCE_M;
use super::lamp_bounce::{bounce_irradiance, direct_irradiance};
use crate::geometry::ambient::TransportQuality;
use crate::geometry::raycast::RayScene;
use crate::lamps::Lamp;
use chrono::{DateTime, FixedOffset};
use rand::rngs::SmallRng;
use rayon::prelude::*;

/// Usable samples a lamp's light must reach before its `k` is fitted.
pub const MIN_LAMP_SAMPLES: usize = 5;
/// Most lamp bands (octaves) told apart for censoring.
const MAX_BAND: u8 = 60;

/// The lamps and their terms on the pool.
pub struct LampColumns {
    lamps: Vec<Lamp>,
    /// Per lamp, per pool entry: `g = ρ/π·E·V` per channel.
    g: Vec<Vec<[f64; 3]>>,
    /// Per pool entry: 0 without lamp light, else 1 + octaves below the brightest entry.
    pub(super) band: Vec<u8>,
    /// Time of the first frame (schedules in seconds count from it).
    start: Option<DateTime<FixedOffset>>,
    /// Per lamp, its `k` over time.
    smoothers: Vec<LampSmoother>,
}

/// A lamp's place in this frame's fit.
#[derive(Clone, Debug, PartialEq)]
pub(super) struct LampFrame {
    /// Lamps that are columns of the fit.
    fit: Vec<usize>,
    /// The report of every lamp (statuses before the fit; the fit overwrites them).
    pub reports: Vec<LampReport>,
}

impl LampColumns {
    /// `g` and the bands of every pool entry (`scene`: the proxy, for visibility and the bounce;
    /// `bounce`: the paths of the lamps' interreflected light `B` and the seed, `None` for
    /// direct light only). Parallel over the pool; every entry's `B` is a pure function of its
    /// seed, so the columns do not depend on the thread count.
    pub fn build(lamps: Vec<Lamp>, pool: &Pool, scene: &RayScene, bounce: Option<(TransportQuality, u64)>) -> Self {
        let g: Vec<Vec<[f64; 3]>> = lamps
            .iter()
            .enumerate()
            .map(|(j, lamp)| {
                (0..pool.len())
                    .into_par_iter()
                    .map(|e| {
                        let (p, n) = (pool.point[e], pool.normal[e]);
                        let mut irr = direct_irradiance(lamp, scene, p, n);
                        if let Some((q, seed)) = bounce {
                            let s = seed.wrapping_add(pool.pixel[e] as u64) ^ (j as u64 + 1).wrapping_mul(0x9e37_79b9_7f4a_7c15);
                            let b = bounce_irradiance(lamp, scene, p, n, q, s);
                            irr = std::array::from_fn(|c| irr[c] + b[c]);
                        }
                        let rho = pool.albedo[e] / std::f32::consts::PI;
                        [rho.x as f64 * irr[0], rho.y as f64 * irr[1], rho.z as f64 * irr[2]]
                    })
                    .collect()
            })
            .collect();
        let light: Vec<f64> = (0..pool.len()).map(|e| lamps.iter().zip(&g).map(|(l, g)| l.light.scale * luma(&g[e])).sum()).collect();
        let brightest = light.iter().copied().fold(0.0, f64::max);
        let band = light.iter().map(|&v| if v > 0.0 { 1 + ((brightest / v).log2().floor().max(0.0) as u8).min(MAX_BAND) } else { 0 }).collect();
        let smoothers = vec![LampSmoother::default(); lamps.len()];
        Self { lamps, g, band, start: None, smoothers }
    }

    /// The lamps.
    pub fn lamps(&self) -> &[Lamp] {
        &self.lamps
    }

    /// `g` of lamp `j` at pool entry `e`.
    pub fn g(&self, j: usize, e: usize) -> [f64; 3] {
        self.g[j][e]
    }
}

fn report(lamp: &Lamp, status: LampStatus, samples: usize, reason: Option<String>) -> LampReport {
    LampReport { name: lamp.light.name.clone(), status, k: [lamp.light.scale; 3], k_se: None, k_smoothed: None, k_hindsight: None, samples, condition_number: None, reason }
}

impl Estimator {
    /// Sets the lamps the estimator fits (replacing any); traces their terms on the pool.
    pub fn set_lamps(&mut self, lamps: Vec<Lamp>) {
        let bounce = self.config.sun_bounce.then_some((self.config.bounce, self.config.seed));
        self.lamps = (!lamps.is_empty()).then(|| LampColumns::build(lamps, &self.pool, &self.scene, bounce));
    }

    /// The lamps and their terms on the pool, when the scene has any.
    pub fn lamp_columns(&self) -> Option<&LampColumns> {
        self.lamps.as_ref()
    }

    /// Decides which lamps this frame fits (module docs); the light of lamps kept at their
    /// prior is taken off the rows.
    pub(super) fn prepare_lamps(&mut self, time: &DateTime<FixedOffset>) {
        self.lamp_frame = None;
        let Some(lc) = self.lamps.as_mut() else { return };
        let start = *lc.start.get_or_insert(*time);
        let n = self.entries.len();
        let mut frame = LampFrame { fit: Vec::new(), reports: Vec::with_capacity(lc.lamps.len()) };
        for (j, lamp) in lc.lamps.iter().enumerate() {
            if !lamp.light.schedule.is_on(time, &start) {
                frame.reports.push(report(lamp, LampStatus::Off, 0, Some(format!("off at {} by its schedule", time.to_rfc3339()))));
                continue;
            }
            let samples = self.entries.iter().filter(|&&e| luma(&lc.g[j][e as usize]) > 0.0).count();
            if samples >= MIN_LAMP_SAMPLES {
                frame.fit.push(j);
                frame.reports.push(report(lamp, LampStatus::NotFitted, samples, Some("the frame was not fitted".into())));
                continue;
            }
            let reason = format!("its light reaches {samples} of the frame's {n} usable samples (fewer than {MIN_LAMP_SAMPLES}): kept at its prior scale");
            frame.reports.push(report(lamp, LampStatus::Unreached, samples, Some(reason)));
            for (i, &e) in self.entries.iter().enumerate() {
                let g = lc.g[j][e as usize];
                for c in 0..3 {
                    self.rows[c].y[i] -= lamp.light.scale * g[c];
                }
            }
        }
        self.lamp_frame = Some(frame);
    }

    /// Whether this frame's fit has lamp columns.
    pub(super) fn lamps_in_fit(&self) -> bool {
        self.lamp_frame.as_ref().is_some_and(|f| !f.fit.is_empty())
    }

    /// Lamp `j`'s column of the frame's rows, channel `c`, times `w`.
    fn lamp_column(&self, j: usize, c: usize, w: f64, out: &mut [f64]) {
        let Some(lc) = self.lamps.as_ref() else { return };
        for (i, &e) in self.entries.iter().enumerate() {
            out[i] += w * lc.g[j][e as usize][c];
        }
    }

    /// One fit per channel of `Pa` (and `Pd` when `two`) and the groups' multipliers; `held`
    /// lamps' prior light is taken off `y`.
    fn fit_groups(&self, two: bool, groups: &[Vec<usize>], held: &[(usize, f64)], rng: &mut SmallRng) -> Option<[MultiFit; 3]> {
        let lc = self.lamps.as_ref()?;
        let n = self.entries.len();
        let prior = |j: usize| lc.lamps[j].light.scale;
        let mut fits: [MultiFit; 3] = Default::default();
        for c in 0..3 {
            let r = &self.rows[c];
            let (a, band) = self.sky_columns(c);
            let mut cols = vec![a];
            if two {
                cols.push(r.b.clone());
            }
            for g in groups {
                let mut col = vec![0.0; n];
                for &j in g {
                    self.lamp_column(j, c, prior(j), &mut col);
                }
                cols.push(col);
            }
            cols.extend(band);
            let mut y = r.y.clone();
            let mut off = vec![0.0; n];
            for &(j, _) in held {
                self.lamp_column(j, c, prior(j), &mut off);
            }
            y.iter_mut().zip(&off).for_each(|(y, o)| *y -= o);
            fits[c] = robust_fit_noise(&cols, &y, self.noise_floor, self.read_noise, rng)?;
        }
        Some(fits)
    }

    /// [`Estimator::fit_channels`] with the frame's lamp columns (module docs): the fits of
    /// `Pa` and `Pd`, with each lamp's result in the frame's lamp reports.
    pub(super) fn fit_channels_lamps(&mut self, two: bool, rng: &mut SmallRng) -> Option<[ChannelFit; 3]> {
        let frame = self.lamp_frame.clone()?;
        let max_cond = self.config.max_condition;
        self.band.fixed = None;
        let mut groups: Vec<Vec<usize>> = frame.fit.iter().map(|&j| vec![j]).collect();
        let mut held: Vec<(usize, f64)> = Vec::new();
        // The largest condition number of the columns merged, before the merge.
        let mut merged: Option<f64> = None;
        let base = 1 + two as usize;
        let fits = loop {
            let fits = self.fit_groups(two, &groups, &held, rng)?;
            // The twilight band goes first when it cannot be told apart (`super::sky_band`).
            if self.band.on && self.band.fixed.is_none() && !self.band_kept(&fits, base + groups.len()) {
                continue;
            }
            let kappa = |k: usize| fits.iter().map(|f| f.column_condition[base + k]).fold(1.0, f64::max);
            let bad: Vec<usize> = (0..groups.len()).filter(|&k| kappa(k) > max_cond).collect();
            if bad.is_empty() {
                break fits;
            }
            if bad.len() >= 2 && merged.is_none() {
                merged = Some(bad.iter().map(|&k| kappa(k)).fold(1.0, f64::max));
                let joined: Vec<usize> = bad.iter().flat_map(|&k| groups[k].clone()).collect();
                groups = (0..groups.len()).filter(|k| !bad.contains(k)).map(|k| groups[k].clone()).chain([joined]).collect();
                continue;
            }
            for &k in &bad {
                held.extend(groups[k].iter().map(|&j| (j, kappa(k))));
            }
            groups = (0..groups.len()).filter(|k| !bad.contains(k)).map(|k| groups[k].clone()).collect();
        };
        if self.band.on && self.band_prior_applies(&fits, base + groups.len()) {
            // The band's ratio from the earlier frames and this one (`super::sky_band`, "At
            // night"): fitted again with the sky as one column, and once more at `β + σ_β` for
            // the share of `k`'s standard error that the ratio's uncertainty carries.
            let kappa = fits.iter().map(|f| f.column_condition[base + groups.len()]).fold(1.0, f64::max);
            let fixed = self.fit_groups(two, &groups, &held, rng)?;
            let plus = self.fit_at_ratio_plus_se(|e, rng| e.fit_groups(two, &groups, &held, rng), rng);
            self.record_lamps(&fixed, &groups, &held, base, merged.unwrap_or(COND_CAP));
            if let Some(plus) = &plus {
                self.widen_lamp_se(&fixed, plus, &groups, base);
            }
            return Some(self.band_channels_fixed(&fixed, plus.as_ref(), two, kappa));
        }
        self.record_lamps(&fits, &groups, &held, base, merged.unwrap_or(COND_CAP));
        if self.band.on {
            return Some(self.band_channels(&fits, two, base + groups.len()));
        }
        Some(std::array::from_fn(|c| {
            let f = &fits[c];
            f.channel(two, f.column_condition[..base].iter().copied().fold(1.0, f64::max))
        }))
    }

    /// Writes the fit's `k` of every lamp into the frame's reports.
    /// `merged_kappa`: the condition number of the merged lamps' own columns before the merge.
    fn record_lamps(&mut self, fits: &[MultiFit; 3], groups: &[Vec<usize>], held: &[(usize, f64)], base: usize, merged_kappa: f64) {
        let Some(lc) = self.lamps.as_ref() else { return };
        let names: Vec<String> = lc.lamps.iter().map(|l| l.light.name.clone()).collect();
        let priors: Vec<f64> = lc.lamps.iter().map(|l| l.light.scale).collect();
        let Some(frame) = self.lamp_frame.as_mut() else { return };
        for (k, g) in groups.iter().enumerate() {
            let kappa = fits.iter().map(|f| f.column_condition[base + k]).fold(1.0, f64::max);
            for &j in g {
                let r = &mut frame.reports[j];
                r.k = std::array::from_fn(|c| fits[c].x[base + k] * priors[j]);
                r.k_se = Some(std::array::from_fn(|c| fits[c].se[base + k] * priors[j]));
                if g.len() == 1 {
                    r.condition_number = Some(kappa);
                    r.status = LampStatus::Fitted;
                    r.reason = None;
                } else {
                    let others: Vec<&str> = g.iter().filter(|&&o| o != j).map(|&o| names[o].as_str()).collect();
                    r.condition_number = Some(merged_kappa);
                    r.status = LampStatus::NotSeparable;
                    r.reason = Some(format!(
                        "lights the same samples as {} (condition number {merged_kappa:.3e} > max_condition): fitted together at their prior ratio (κ of the merged column {kappa:.3})",
                        others.join(", ")
                    ));
                }
            }
        }
        for &(j, kappa) in held {
            let r = &mut frame.reports[j];
            r.k = [priors[j]; 3];
            r.k_se = None;
            r.condition_number = Some(kappa);
            r.status = LampStatus::NotSeparable;
            r.reason = Some(format!("cannot be told apart from the other light on these samples (κ = {kappa:.3} > max_condition): kept at its prior scale"));
        }
    }

    /// Adds to each fitted lamp's standard error the change of its `k` between `fits` and `plus`
    /// (the same fit with the band's ratio one standard error higher), in quadrature.
    fn widen_lamp_se(&mut self, fits: &[MultiFit; 3], plus: &[MultiFit; 3], groups: &[Vec<usize>], base: usize) {
        let Some(lc) = self.lamps.as_ref() else { return };
        let priors: Vec<f64> = lc.lamps.iter().map(|l| l.light.scale).collect();
        let Some(frame) = self.lamp_frame.as_mut() else { return };
        for (k, g) in groups.iter().enumerate() {
            for &j in g {
                if let Some(se) = frame.reports[j].k_se.as_mut() {
                    for c in 0..3 {
                        se[c] = se[c].hypot((plus[c].x[base + k] - fits[c].x[base + k]) * priors[j]);
                    }
                }
            }
        }
    }

    /// Takes the light of every lamp in the fit (at its reported `k`) off the rows, for the
    /// one-parameter fallbacks that have no lamp columns.
    pub(super) fn subtract_fitted_lamps(&mut self) {
        let (Some(lc), Some(frame)) = (self.lamps.as_ref(), self.lamp_frame.as_ref()) else { return };
        for &j in &frame.fit {
            let k = frame.reports[j].k;
            for (i, &e) in self.entries.iter().enumerate() {
                let g = lc.g[j][e as usize];
                for c in 0..3 {
                    self.rows[c].y[i] -= k[c] * g[c];
                }
            }
        }
    }

    /// Smooths every lamp's `k` at `t_s` (seconds since the first frame) into `reports`
    /// ([`LampSmoother`]): a lamp off resets its filter; a fitted one is a measurement.
    pub(super) fn smooth_lamps(&mut self, reports: &mut [LampReport], t_s: f64) {
        let rate = self.config.lamp_smoothing_rate_per_sqrt_s;
        let Some(lc) = self.lamps.as_mut() else { return };
        for ((r, f), lamp) in reports.iter_mut().zip(&mut lc.smoothers).zip(&lc.lamps) {
            let meas = super::hindsight::measurement(r);
            r.k_smoothed = f.update(t_s, rate, r.status != LampStatus::Off, lamp.light.scale, meas);
        }
    }

    /// The frame's lamp reports (empty without lamps).
    pub(super) fn lamp_reports(&mut self) -> Vec<LampReport> {
        self.lamp_frame.take().map(|f| f.reports).unwrap_or_default()
    }
}
