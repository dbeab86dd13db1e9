//! Turbidity chosen by residual (issue 13 §1: "choose turbidity by residual and then fit the
//! scales"; `turbidity = "fit"` in `[estimator.sky]`).
//!
//! Hošek & Wilkie (2012, "An Analytic Model for Full Spectral Sky-Dome Radiance", §4) shape the
//! clear sky by one atmospheric parameter, the turbidity `T`: low `T` gives a deep-blue sky with a
//! tight circumsolar glow, high `T` a hazy one, brighter toward the horizon. The estimator's
//! ambient column depends on it ([`super::sky_terms`]), `Pd` and `Pa` do not. For every candidate
//! of [`crate::scene::settings::FIT_TURBIDITIES`] the frame's samples (one draw, the same for all)
//! are fitted with that candidate's column, and the candidate whose fit leaves the smallest
//! robust residual is kept; the frame is then estimated with it exactly as with a fixed turbidity
//! (same draw, same fit, so its status, condition number and standard errors are the ones the
//! estimator always reports, and a fit that chooses `T` gives the bits of `turbidity = T`).
//!
//! **The robust residual** of a candidate measures its lack of fit, not the noise: the samples are
//! grouped by proxy surface and sun state (sunlit or shadowed: the groups the sky's shape treats
//! differently, e.g. a wall facing a low sun against one facing away), the median of each
//! group's signed relative residual `(y − a·Pa − b·Pd) / y` of the candidate's two-parameter fit
//! ([`super::solve::robust_fit`]) is taken, and the residual is the sample-weighted RMS of those
//! medians, weighted by luminance over the channels. Within a group the pixel noise and the
//! albedo texture average out (a median of tens of samples), and the medians ignore the outliers
//! the fit down-weights (people, wet patches); what remains is how far the candidate's sky puts
//! each surface off (the lack-of-fit term of a regression with replicated groups). Relative, so
//! bright sunlit groups do not outweigh shadowed ones. Groups of fewer than
//! [`MIN_GROUP_SAMPLES`] are left out. Lamps (`[[lights]]`) are left out of the choice; the
//! final fit includes them as always.

use super::solve::{median_in_place, robust_fit};
use super::{Estimator, LUMA, MIN_LIT_SAMPLES};
use crate::io::frames::{Frame, Linearizer};
use rand::rngs::SmallRng;
use serde::Serialize;

/// Denominator floor of the relative residual, as a fraction of the channel's mean radiance (a
/// black sample must not give an infinite ratio).
const MIN_Y_REL: f64 = 1e-3;
/// Samples a group needs for its median to count (module docs).
const MIN_GROUP_SAMPLES: usize = 8;

/// The turbidity a frame chose, and why.
#[derive(Clone, Debug, PartialEq, Serialize)]
pub struct TurbidityFit {
    /// The turbidity kept.
    pub chosen: f64,
    /// Its robust residual (relative, luminance-weighted median; module docs).
    pub residual: f64,
    /// Every candidate as `(turbidity, residual)`; `null`: too few samples to fit it.
    pub candidates: Vec<(f64, Option<f64>)>,
}

impl Estimator {
    /// Under `turbidity = "fit"`, fits every candidate on the draw that `rng` gives and selects
    /// the best for the frame's own gather (`turbidity_pick`). `None`, and no pick, when there is
    /// nothing to choose: a fixed turbidity, a uniform (overcast) frame, a sun below the horizon,
    /// or too few usable or sunlit samples for any candidate.
    pub(super) fn choose_turbidity(&mut self, frame: &Frame, lin: &Linearizer, rng: &SmallRng) -> Option<TurbidityFit> {
        self.turbidity_pick = None;
        let ts: Vec<f64> = self.sun_sky.as_ref().map_or_else(Vec::new, |s| s.by_turbidity.iter().map(|(t, _)| *t).collect());
        if ts.is_empty() || self.overcast() || !self.sun.as_ref().is_some_and(|s| s.above_horizon) {
            return None;
        }
        let mut candidates = Vec::with_capacity(ts.len());
        let mut best: Option<(usize, f64)> = None;
        for (i, &t) in ts.iter().enumerate() {
            self.turbidity_pick = Some(i);
            let mut r = rng.clone();
            let g = self.gather(frame, lin, &mut r);
            let enough = g.counts.usable >= self.config.min_samples.max(3) && g.counts.lit >= MIN_LIT_SAMPLES;
            let residual = if enough { self.robust_residual(&mut r) } else { None };
            if let Some(v) = residual
                && best.is_none_or(|(_, b)| v < b)
            {
                best = Some((i, v));
            }
            candidates.push((t, residual));
        }
        self.turbidity_pick = best.map(|(i, _)| i);
        let (i, residual) = best?;
        Some(TurbidityFit { chosen: ts[i], residual, candidates })
    }

    /// The robust residual of a two-parameter fit of the gathered rows (module docs).
    fn robust_residual(&self, rng: &mut SmallRng) -> Option<f64> {
        // Row indices per (proxy node, sunlit) group, in order of first appearance.
        let mut groups: Vec<((u32, bool), Vec<usize>)> = Vec::new();
        for (k, (&e, &lit)) in self.entries.iter().zip(&self.lit).enumerate() {
            let key = (self.pool.node[e as usize], lit);
            match groups.iter_mut().find(|g| g.0 == key) {
                Some(g) => g.1.push(k),
                None => groups.push((key, vec![k])),
            }
        }
        groups.retain(|g| g.1.len() >= MIN_GROUP_SAMPLES);
        if groups.is_empty() {
            return None;
        }
        let mut total = 0.0;
        let mut rel = Vec::new();
        for (c, rows) in self.rows.iter().enumerate() {
            let f = robust_fit(rows, &self.lit, true, self.noise_floor, rng)?;
            let mean = rows.y.iter().map(|v| v.abs()).sum::<f64>() / rows.len().max(1) as f64;
            let floor = (MIN_Y_REL * mean).max(f64::MIN_POSITIVE);
            let (mut sq, mut weight) = (0.0, 0.0);
            for (_, ks) in &groups {
                rel.clear();
                rel.extend(ks.iter().map(|&k| (rows.y[k] - rows.a[k] * f.pa - rows.b[k] * f.pd) / rows.y[k].abs().max(floor)));
                let m = median_in_place(&mut rel);
                sq += ks.len() as f64 * m * m;
                weight += ks.len() as f64;
            }
            total += LUMA[c] * (sq / weight).sqrt();
        }
        total.is_finite().then_some(total)
    }
}
