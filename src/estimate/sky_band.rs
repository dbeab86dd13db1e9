//! The twilight horizon band: a second sky column while the sun is below the horizon or within
//! [`TWILIGHT_BAND_MAX_SUN_ELEVATION_DEG`] of it (issue 13's "small basis of shapes with NNLS
//! scales", issue 16 §4).
//!
//! The Hošek–Wilkie model is fitted for suns above the horizon; below it the estimator (and the
//! renderer, `crate::sky::hosek`) keep the shape of a sun on the horizon at its azimuth, a
//! convention. A real twilight sky is brighter toward the horizon than a uniform one (the
//! twilight arch: light scattered along long, low paths), by an amount that no convention
//! pins down. A surface that sees much horizon (a wall over an open street) then gets more sky
//! light per unit `Pa` than the model says, and one that sees mostly the zenith (the paving of a
//! courtyard) less; a single `Pa` sits between them and over-predicts the paving's sky, where a
//! lamp shines, so the lamp's `k` comes out low (`docs/measurements.md`, "Why the dusk lamp's
//! `k` came out low").
//!
//! Here the model becomes `Pa_s·S_HW + P_b·S_band`, with `S_band` the horizon band of
//! [`crate::sky::basis`] (`e^{−μ/sin w}`, `w` = [`TWILIGHT_BAND_WIDTH_DEG`], the basis's
//! recommended width, not fitted) normalised to unit irradiance on an unoccluded horizontal
//! surface. Its column is `ρ/π·E_band` with `E_band` summed over the same open directions of the
//! proxy as the sky's `E_shape` (`super::sky_terms`: one visibility, one quadrature; the band's
//! light after a bounce off the proxy is left out, not measured).
//! Both scales are non-negative (NNLS): the band can only add horizon light, which is the
//! direction real twilight skies depart in.
//!
//! # What is reported, and what the renderer uses
//! The renderer's sky has one shape (its transfer, probes and receivers trace the Hošek–Wilkie
//! sky of the frame's sun, `crate::sky::radiance`), so the fit is mapped back to that shape: the
//! reported `Pa` is the scale of the one-shape sky that puts the same sky light on the frame's
//! samples as the fit, `Pa = Pa_s + r·P_b` with `r = Σ_i h_i / Σ_i a_i` per channel (the band's
//! column over the shape's, summed over the fitted rows; 1.2–1.3 on `scenes/dusk`), its standard
//! error from the fit's covariance at that `r`. `Pa` keeps its meaning for the renderer (the
//! horizontal irradiance of the sky it draws), and the surfaces the camera sees, on which the
//! composite's ratios are taken, get the fitted sky light on the whole. What this gives up: the
//! split between surfaces that see much horizon and those that see little, which the renderer
//! cannot draw; and `Pa` is no longer the horizontal irradiance of the fitted two-shape sky
//! (`Pa_s + P_b`), which in a courtyard is an extrapolation to an open horizon no sample sees
//! (on `scenes/dusk`, mean error over five seeds 2.6–4.7% on frames 1–3 and 10–24% on the night
//! frames 4–5, against 1.6–2.7% and 6–16% for the sample equivalent and 0.7–2.1% and 3–14%
//! without the band; `docs/measurements.md`). The split is reported per frame (`sky_band`:
//! `P_b`, its standard error, `Pa_s`, `r`, the band column's condition number) for a renderer
//! that draws it.
//!
//! # At night: the band's ratio carried from frame to frame
//! The band's split is well determined while the sky is bright (the ratio `β = P_b/Pa_s` to
//! ±0.01–0.03 on `scenes/dusk`'s frames 1–2) and poorly once it is 1–3% of sunset's and the
//! lamp carries the samples (±0.15–0.2 on frame 4, ±0.4–1.5 on frame 5). There the free column
//! wandered (`β` 0–0.87 on frame 4 and up to 6.7 on frame 5 over five seeds, where the
//! generator's sky, fitted by the same two shapes, has 0.13–0.17 on every frame from 2 on) and
//! took `Pa` with it (mean error 6.2% and 16.3% on frames 4–5), and it soaked up light the
//! proxy does not model (below).
//!
//! The twilight sky is a function of the sun's depression (Hošek–Wilkie's and every twilight
//! model's parameter; the sky's shape, not its brightness, is what `β` describes), so the
//! earlier frames' `β` is a prior for this one. A scalar Kalman filter per channel
//! (as `super::smoother`, with the sun's elevation for the clock): between frames the ratio may
//! drift by `(1 + β)·|Δh|/w`, `Δh` the sun's change of elevation and `w` the band's width
//! (a sun that moves by a whole band width may change the band's share of the sky by as much as
//! the sky); the frame's own `β` and its variance (delta method on the free fit's covariance)
//! are the measurement; the combination `β̂` is fixed for the frame and the sky becomes one
//! column `a + β̂·h` (status `prior`; the reported `Pa = Pa_s·(1 + r·β̂)`). The standard errors
//! of `Pa`, `Pd` and every `k` add, in quadrature, their change when the fit is repeated at
//! `β̂ + σ_β̂`. The first twilight frame has no prior and keeps the free fit; a frame past
//! twilight resets the filter. `[estimator.sky] twilight_band_prior = false` fits the band
//! freely on every frame.
//!
//! What it does on `scenes/dusk` (five seeds, `docs/measurements.md`, "The twilight band's
//! ratio carried to the night"): `Pa`'s mean error on frames 3–5 is 2.5, 4.5, 13.9% (free band
//! 2.7, 6.2, 16.3%; no band 2.1, 3.1, 13.8%); `k` on frames 1–3 is as with the free band and
//! on frame 4 lower (mean 0.921 against 0.938): the free band had lifted it by absorbing the
//! darker wet patch and the person under the lamp, which the proxy does not model. The
//! per-sample refit (`tests/suite/estimate_dusk_rows.rs`) finds the same with the band fixed
//! at the generator's own ratio (0.923), and 0.972 with those rows made exact.
//!
//! # Conditioning
//! On an open horizontal surface both columns are 1: only walls and partly occluded ground tell
//! them apart. When the band column's condition number against the others exceeds
//! `max_condition` on any channel (no walls among the samples, say), the band is dropped for the
//! frame (status `dropped`, with the reason) and the fit is the one-shape fit, as without it.

use super::solve::ChannelFit;
use super::solve_multi::MultiFit;
use super::Estimator;
use crate::sky::SkyError;
use crate::sky::basis::{RECOMMENDED_HORIZON_WIDTH_DEG, SkyBasis, SkyBasisSpec};
use glam::Vec3;
use serde::Serialize;

/// The band is a column while the sun is below the horizon or at most this high, degrees (the
/// Hošek–Wilkie data start at the horizon; its shape at 0–3° is still the twilight's).
pub const TWILIGHT_BAND_MAX_SUN_ELEVATION_DEG: f32 = 3.0;
/// E-folding elevation of the band, degrees ([`crate::sky::basis`]'s recommended horizon band).
pub const TWILIGHT_BAND_WIDTH_DEG: f64 = RECOMMENDED_HORIZON_WIDTH_DEG;

/// The band's basis: shape 1 is the band (shape 0 the uniform sky, unused).
pub(super) fn band_shape() -> Result<SkyBasis, SkyError> {
    SkyBasis::new(Vec3::Y, &SkyBasisSpec { circumsolar_width_deg: None, horizon_width_deg: Some(TWILIGHT_BAND_WIDTH_DEG), preetham_turbidity: None })
}

/// Whether the sun toward `l` (world frame, y up) is at twilight.
pub(super) fn at_twilight(l: Vec3) -> bool {
    let l = l.normalize_or_zero();
    l.y < TWILIGHT_BAND_MAX_SUN_ELEVATION_DEG.to_radians().sin()
}

/// Whether the band was part of the frame's fit.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Serialize)]
#[serde(rename_all = "snake_case")]
pub enum SkyBandStatus {
    /// Fitted: the reported `Pa` is `Pa_s + r·P_b` (module docs).
    Fitted,
    /// Left out: the column could not be told apart from the others.
    Dropped,
    /// Fitted at a ratio to the shape combined from the frame's own fit and the earlier frames'
    /// (module docs, "At night"): the sky is one column `a + β·h`.
    Prior,
}

/// The band's ratio `β = P_b/Pa_s` per channel, with its standard error.
#[derive(Clone, Copy, Debug, PartialEq, Serialize)]
pub struct BandRatio {
    /// `β` per channel.
    pub ratio: [f64; 3],
    /// Its standard error.
    pub ratio_se: [f64; 3],
}

/// How a [`SkyBandStatus::Prior`] frame's ratio came about (module docs, "At night").
#[derive(Clone, Debug, PartialEq, Serialize)]
pub struct BandPriorReport {
    /// The earlier frames' ratio, carried to this frame's sun (its drift added).
    pub prior: BandRatio,
    /// This frame's own ratio (the free two-column fit).
    pub frame: BandRatio,
    /// Their inverse-variance combination, at which the sky's column is fitted.
    pub used: BandRatio,
}

/// The band's ratio carried across frames (module docs, "At night").
#[derive(Clone, Copy, Debug, PartialEq)]
pub(super) struct BandTrack {
    ratio: [f64; 3],
    var: [f64; 3],
    sun_elevation_deg: f64,
}

/// The ratio's drift while the sun moves by `d_elev_deg`: `(1 + β)·|Δh|/w` per channel, `w` the
/// band's width (module docs, "At night").
fn drift(ratio: f64, d_elev_deg: f64) -> f64 {
    (1.0 + ratio.max(0.0)) * d_elev_deg.abs() / TWILIGHT_BAND_WIDTH_DEG
}

/// `β = x_b/x_0` and its variance from a fit's covariance (delta method); an unfitted shape
/// (`x_0 ≤ 0`) or a singular design gives an infinite variance.
fn ratio_of_fit(f: &MultiFit, col: usize) -> (f64, f64) {
    let p = f.x.len();
    let (x0, xb) = (f.x[0], f.x[col]);
    let cov = |i: usize, j: usize| f.covariance.get(i * p + j).copied().unwrap_or(f64::INFINITY);
    if !(x0 > 0.0) {
        return (0.0, f64::INFINITY);
    }
    let beta = xb / x0;
    let var = (cov(col, col) - 2.0 * beta * cov(0, col) + beta * beta * cov(0, 0)) / (x0 * x0);
    (beta, if var.is_finite() { var.max(0.0) } else { f64::INFINITY })
}

/// The inverse-variance combination of `(β, var)` pairs.
fn combine(a: (f64, f64), b: (f64, f64)) -> (f64, f64) {
    match (a.1.is_finite() && a.1 > 0.0, b.1.is_finite() && b.1 > 0.0) {
        (true, true) => {
            let (wa, wb) = (1.0 / a.1, 1.0 / b.1);
            ((wa * a.0 + wb * b.0) / (wa + wb), 1.0 / (wa + wb))
        }
        (true, false) => a,
        (false, true) => b,
        // Both exact (zero variance) or both unknown: the earlier frames' value.
        (false, false) => a,
    }
}

/// The band's part of a frame report (module docs).
#[derive(Clone, Debug, PartialEq, Serialize)]
pub struct SkyBandReport {
    /// Fitted or dropped.
    pub status: SkyBandStatus,
    /// The band's e-folding elevation, degrees.
    pub width_deg: f64,
    /// `P_b` per channel (its horizontal irradiance; 0 when dropped).
    pub scale: [f64; 3],
    /// Its standard error.
    pub scale_se: [f64; 3],
    /// `Pa_s`, the Hošek–Wilkie shape's weight (the reported `Pa` is `Pa_s + r·P_b`).
    pub shape_pa: [f64; 3],
    /// The band column's condition number against the others (largest over the channels).
    pub condition_number: f64,
    /// `r` per channel: the band's light on the frame's samples per unit of the shape's.
    pub sample_ratio: [f64; 3],
    /// Why it was dropped.
    #[serde(skip_serializing_if = "Option::is_none")]
    pub reason: Option<String>,
    /// Under [`SkyBandStatus::Prior`]: the earlier frames' ratio, this frame's, and the one used.
    #[serde(skip_serializing_if = "Option::is_none")]
    pub prior: Option<BandPriorReport>,
}

/// This frame's band: whether its column is in the fit, and the report.
#[derive(Clone, Debug, Default, PartialEq)]
pub(super) struct BandFrame {
    /// The band's column is in the frame's fits.
    pub on: bool,
    /// The last fit's report (`None` when the band was never on this frame).
    pub report: Option<SkyBandReport>,
    /// The ratio `β` at which the band is merged into the sky's column (`a + β·h`), and its
    /// standard error; `None`: the band is a free column.
    pub fixed: Option<([f64; 3], [f64; 3])>,
    /// The report of the ratio's prior, when `fixed`.
    pub prior: Option<BandPriorReport>,
}

impl Estimator {
    /// The band's column of the frame's rows, channel `c`.
    pub(super) fn band_column(&self, c: usize) -> Vec<f64> {
        self.band_rows.iter().map(|b| b[c]).collect()
    }

    /// After a fit whose column `col` is the band: keeps it (`true`) when its condition number
    /// is within `max_condition` on every channel, else turns the band off for the frame and
    /// records why (`false`: the caller fits again without it).
    pub(super) fn band_kept(&mut self, fits: &[MultiFit; 3], col: usize) -> bool {
        let kappa = fits.iter().map(|f| f.column_condition[col]).fold(1.0, f64::max);
        if kappa <= self.config.max_condition {
            return true;
        }
        self.band.on = false;
        self.band.report = Some(SkyBandReport {
            status: SkyBandStatus::Dropped,
            width_deg: TWILIGHT_BAND_WIDTH_DEG,
            scale: [0.0; 3],
            scale_se: [0.0; 3],
            shape_pa: [0.0; 3],
            condition_number: kappa,
            sample_ratio: [0.0; 3],
            reason: Some(format!("the horizon band cannot be told apart from the other light on these samples (κ = {kappa:.3} > max_condition): one sky shape")),
            prior: None,
        });
        false
    }

    /// Per channel, the band's light on the frame's rows per unit of the shape's (`r`).
    fn band_ratio(&self) -> [f64; 3] {
        std::array::from_fn(|c| {
            let a: f64 = self.rows[c].a.iter().sum();
            let h: f64 = self.band_rows.iter().map(|b| b[c]).sum();
            if a > 0.0 { h / a } else { 1.0 }
        })
    }

    /// The channel fits of `Pa` (`Pa_s + r·P_b`, module docs) and `Pd` (when `two`) from fits whose
    /// last column `col` is the band, and the band's report. The condition number is `Pd`'s
    /// against the others (the band's own against `Pa_s` is [`Self::band_kept`]'s test).
    pub(super) fn band_channels(&mut self, fits: &[MultiFit; 3], two: bool, col: usize) -> [ChannelFit; 3] {
        let p = fits[0].x.len();
        let ratio = self.band_ratio();
        let out = std::array::from_fn(|c| {
            let f = &fits[c];
            let r = ratio[c];
            let cov = |i: usize, j: usize| f.covariance.get(i * p + j).copied().unwrap_or(f64::INFINITY);
            let var = cov(0, 0) + r * r * cov(col, col) + 2.0 * r * cov(0, col);
            let mut ch = f.channel(two, if two { f.column_condition[1] } else { 1.0 });
            ch.pa = f.x[0] + r * f.x[col];
            ch.pa_se = if var.is_finite() { var.max(0.0).sqrt() } else { f64::INFINITY };
            ch
        });
        self.band.report = Some(SkyBandReport {
            status: SkyBandStatus::Fitted,
            width_deg: TWILIGHT_BAND_WIDTH_DEG,
            scale: std::array::from_fn(|c| fits[c].x[col]),
            scale_se: std::array::from_fn(|c| fits[c].se[col]),
            shape_pa: std::array::from_fn(|c| fits[c].x[0]),
            condition_number: fits.iter().map(|f| f.column_condition[col]).fold(1.0, f64::max),
            sample_ratio: ratio,
            reason: None,
            prior: None,
        });
        out
    }

    /// The sky's columns of channel `c`: the shape's `a` (`a + β·h` when the band's ratio is
    /// fixed) and, when the band is a free column, its own.
    pub(super) fn sky_columns(&self, c: usize) -> (Vec<f64>, Option<Vec<f64>>) {
        let a = &self.rows[c].a;
        match (self.band.on, self.band.fixed) {
            (true, Some((beta, _))) => (a.iter().zip(&self.band_rows).map(|(a, h)| a + beta[c] * h[c]).collect(), None),
            (true, None) => (a.clone(), Some(self.band_column(c))),
            (false, _) => (a.clone(), None),
        }
    }

    /// After a free fit whose column `col` is the band (and which [`Self::band_kept`] kept):
    /// with a prior from earlier frames, fixes the band's ratio for this frame at the combination
    /// of the prior and the fit's own (`true`: the caller fits again with
    /// [`Self::sky_columns`]); without one, keeps the free fit (`false`). Either way the carried
    /// ratio becomes this frame's.
    pub(super) fn band_prior_applies(&mut self, fits: &[MultiFit; 3], col: usize) -> bool {
        let own: [(f64, f64); 3] = std::array::from_fn(|c| ratio_of_fit(&fits[c], col));
        let now = self.sun_elevation_deg;
        if !self.config.sky.twilight_band_prior {
            return false;
        }
        let Some(track) = self.band_track else {
            self.band_track = Some(BandTrack { ratio: own.map(|o| o.0), var: own.map(|o| o.1), sun_elevation_deg: now });
            return false;
        };
        let d = now - track.sun_elevation_deg;
        let prior: [(f64, f64); 3] = std::array::from_fn(|c| (track.ratio[c], track.var[c] + drift(track.ratio[c], d).powi(2)));
        let used: [(f64, f64); 3] = std::array::from_fn(|c| combine(prior[c], own[c]));
        let ratio = |v: &[(f64, f64); 3]| BandRatio { ratio: v.map(|o| o.0), ratio_se: v.map(|o| o.1.max(0.0).sqrt()) };
        self.band_track = Some(BandTrack { ratio: used.map(|o| o.0), var: used.map(|o| o.1), sun_elevation_deg: now });
        self.band.fixed = Some((used.map(|o| o.0), used.map(|o| o.1.max(0.0).sqrt())));
        self.band.prior = Some(BandPriorReport { prior: ratio(&prior), frame: ratio(&own), used: ratio(&used) });
        true
    }

    /// The channel fits of `Pa` and `Pd` from fits whose sky column is `a + β·h` (the band's ratio
    /// fixed, [`Self::band_prior_applies`]): `Pa = Pa_s·(1 + r·β)`, its variance the fit's at
    /// that `β` plus the square of `Pa`'s change in `plus` (the same fit at `β + σ_β`: the
    /// samples' sky light is better known than its split, so `Pa_s` moves against `β`);
    /// `free_kappa` is the free fit's band condition number.
    pub(super) fn band_channels_fixed(&mut self, fits: &[MultiFit; 3], plus: Option<&[MultiFit; 3]>, two: bool, free_kappa: f64) -> [ChannelFit; 3] {
        let (beta, beta_se) = self.band.fixed.unwrap_or(([0.0; 3], [0.0; 3]));
        let ratio = self.band_ratio();
        let out = std::array::from_fn(|c| {
            let f = &fits[c];
            let (pa_s, r) = (f.x[0], ratio[c]);
            let mut ch = f.channel(two, if two { f.column_condition[1] } else { 1.0 });
            ch.pa = pa_s * (1.0 + r * beta[c]);
            let moved = plus.map_or(pa_s * r * beta_se[c], |p| p[c].x[0] * (1.0 + r * (beta[c] + beta_se[c])) - ch.pa);
            ch.pa_se = (f.se[0] * (1.0 + r * beta[c])).hypot(moved);
            if two {
                ch.pd_se = ch.pd_se.hypot(plus.map_or(0.0, |p| p[c].x[1] - f.x[1]));
            }
            ch
        });
        self.band.report = Some(SkyBandReport {
            status: SkyBandStatus::Prior,
            width_deg: TWILIGHT_BAND_WIDTH_DEG,
            scale: std::array::from_fn(|c| beta[c] * fits[c].x[0]),
            scale_se: std::array::from_fn(|c| beta_se[c] * fits[c].x[0]),
            shape_pa: std::array::from_fn(|c| fits[c].x[0]),
            condition_number: free_kappa,
            sample_ratio: ratio,
            reason: None,
            prior: self.band.prior.clone(),
        });
        out
    }

    /// `fit` with the band's fixed ratio one standard error higher (for the standard errors that
    /// the ratio's uncertainty carries).
    pub(super) fn fit_at_ratio_plus_se<T>(&mut self, fit: impl Fn(&Self, &mut rand::rngs::SmallRng) -> Option<T>, rng: &mut rand::rngs::SmallRng) -> Option<T> {
        let (beta, se) = self.band.fixed?;
        self.band.fixed = Some((std::array::from_fn(|c| beta[c] + se[c]), se));
        let out = fit(self, rng);
        self.band.fixed = Some((beta, se));
        out
    }

    /// The fits of [`Self::fit_channels_band`]'s columns with the sky's column from
    /// [`Self::sky_columns`].
    fn fit_sky_columns(&self, two: bool, rng: &mut rand::rngs::SmallRng) -> Option<[MultiFit; 3]> {
        let mut fits: [MultiFit; 3] = Default::default();
        for (c, fit) in fits.iter_mut().enumerate() {
            let r = &self.rows[c];
            let (a, h) = self.sky_columns(c);
            let mut cols = vec![a];
            if two {
                cols.push(r.b.clone());
            }
            cols.extend(h);
            *fit = super::noise::robust_fit_noise(&cols, &r.y, self.noise_floor, self.read_noise, rng)?;
        }
        Some(fits)
    }

    /// The frame's fits without lamp columns and with the band (`None`: the band was dropped or
    /// the rows do not fit; the caller fits without it).
    pub(super) fn fit_channels_band(&mut self, two: bool, rng: &mut rand::rngs::SmallRng) -> Option<[ChannelFit; 3]> {
        self.band.fixed = None;
        let fits = self.fit_sky_columns(two, rng)?;
        let col = 1 + two as usize;
        if !self.band_kept(&fits, col) {
            return None;
        }
        if self.band_prior_applies(&fits, col) {
            let kappa = fits.iter().map(|f| f.column_condition[col]).fold(1.0, f64::max);
            let fixed = self.fit_sky_columns(two, rng)?;
            let plus = self.fit_at_ratio_plus_se(|e, rng| e.fit_sky_columns(two, rng), rng);
            return Some(self.band_channels_fixed(&fixed, plus.as_ref(), two, kappa));
        }
        Some(self.band_channels(&fits, two, col))
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// The band's shape has unit horizontal irradiance (its normalisation) and, per unit of it,
    /// gives an open wall far more light than the uniform sky's ½: the closed form of
    /// `∫ e^{−μ/μ₀}·sinθ·cosφ` over the hemisphere in front of a wall is
    /// `π·∫₀¹ e^{−μ/μ₀}·√(1−μ²) dμ` (midpoint rule here) against the normalisation's
    /// `2π·∫₀¹ e^{−μ/μ₀}·μ dμ`.
    #[test]
    fn the_band_is_normalised_and_favours_walls() {
        let b = band_shape().unwrap();
        let mu0 = TWILIGHT_BAND_WIDTH_DEG.to_radians().sin();
        let m = 200_000;
        let (mut wall, mut horiz) = (0.0, 0.0);
        for i in 0..m {
            let mu = (i as f64 + 0.5) / m as f64;
            let e = (-mu / mu0).exp() / m as f64;
            wall += std::f64::consts::PI * e * (1.0 - mu * mu).sqrt();
            horiz += 2.0 * std::f64::consts::PI * e * mu;
        }
        // along the horizon the normalised radiance is 1/horiz
        let l0 = b.radiance(1, Vec3::new(1.0, 0.0, 0.0)) as f64;
        assert!((l0 * horiz - 1.0).abs() < 1e-4, "{l0} vs 1/{horiz}");
        // an open wall: 2.40 per unit horizontal irradiance (12° band), the uniform sky's 0.5
        let ratio = wall / horiz;
        assert!(ratio > 2.0 && ratio < 2.6, "{ratio}");
        assert!(at_twilight(Vec3::new(0.0, -0.1, -1.0)) && at_twilight(Vec3::new(0.0, 0.03, -1.0)));
        assert!(!at_twilight(Vec3::new(0.0, 0.1, -1.0)));
    }

    /// The prior's parts against their closed forms: the ratio's delta-method variance
    /// `(V_bb − 2β·V_0b + β²·V_00)/x_0²`, the inverse-variance mean, and the drift
    /// `(1 + β)·|Δh|/w`.
    #[test]
    fn the_band_ratio_prior_combines_by_inverse_variance() {
        let f = MultiFit { x: vec![2.0, 0.5], covariance: vec![0.04, 0.01, 0.01, 0.09], ..Default::default() };
        let (beta, var) = ratio_of_fit(&f, 1);
        // β = 0.25; (0.09 − 2·0.25·0.01 + 0.0625·0.04)/4 = 0.021875
        assert!((beta - 0.25).abs() < 1e-15 && (var - 0.021_875).abs() < 1e-15, "{beta} {var}");
        // an unfitted shape tells nothing about the ratio
        let none = MultiFit { x: vec![0.0, 0.5], covariance: vec![0.04, 0.01, 0.01, 0.09], ..Default::default() };
        assert_eq!(ratio_of_fit(&none, 1).1, f64::INFINITY);
        // (0.1/0.01 + 0.3/0.03)/(100 + 33.3…) = 0.15, variance 1/133.3… = 0.0075
        let (m, v) = combine((0.1, 0.01), (0.3, 0.03));
        assert!((m - 0.15).abs() < 1e-15 && (v - 0.0075).abs() < 1e-15, "{m} {v}");
        assert_eq!(combine((0.1, 0.01), (0.7, f64::INFINITY)), (0.1, 0.01));
        assert_eq!(combine((0.1, f64::INFINITY), (0.7, 0.04)), (0.7, 0.04));
        // the sun 1.2° lower with β = 0.2, band 12° wide: 1.2·1.2/12
        assert!((drift(0.2, -1.2) - 0.12).abs() < 1e-15);
    }
}
