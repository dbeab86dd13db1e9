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
}

/// This frame's band: whether its column is in the fit, and the report.
#[derive(Clone, Debug, Default, PartialEq)]
pub(super) struct BandFrame {
    /// The band's column is in the frame's fits.
    pub on: bool,
    /// The last fit's report (`None` when the band was never on this frame).
    pub report: Option<SkyBandReport>,
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
        });
        false
    }

    /// The channel fits of `Pa` (`Pa_s + r·P_b`, module docs) and `Pd` (when `two`) from fits whose
    /// last column `col` is the band, and the band's report. The condition number is `Pd`'s
    /// against the others (the band's own against `Pa_s` is [`Self::band_kept`]'s test).
    pub(super) fn band_channels(&mut self, fits: &[MultiFit; 3], two: bool, col: usize) -> [ChannelFit; 3] {
        let p = fits[0].x.len();
        // Per channel, the band's light on the frame's rows per unit of the shape's.
        let ratio: [f64; 3] = std::array::from_fn(|c| {
            let a: f64 = self.rows[c].a.iter().sum();
            let h: f64 = self.band_rows.iter().map(|b| b[c]).sum();
            if a > 0.0 { h / a } else { 1.0 }
        });
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
        });
        out
    }

    /// The frame's fits without lamp columns and with the band (`None`: the band was dropped or
    /// the rows do not fit; the caller fits without it).
    pub(super) fn fit_channels_band(&mut self, two: bool, rng: &mut rand::rngs::SmallRng) -> Option<[ChannelFit; 3]> {
        let mut fits: [MultiFit; 3] = Default::default();
        for (c, fit) in fits.iter_mut().enumerate() {
            let r = &self.rows[c];
            let mut cols = vec![r.a.clone()];
            if two {
                cols.push(r.b.clone());
            }
            cols.push(self.band_column(c));
            *fit = super::noise::robust_fit_noise(&cols, &r.y, self.noise_floor, self.read_noise, rng)?;
        }
        let col = 1 + two as usize;
        if !self.band_kept(&fits, col) {
            return None;
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
}
