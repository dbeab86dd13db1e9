//! The frame's fit and its status (Jensen §3.1 with the trust rules of the crate docs): a
//! two-parameter fit when sunlit and shadowed samples separate `Pd` from `Pa`; otherwise `Pa`
//! alone, with the bounce of the held `Pd` subtracted, a held split, or the total irradiance
//! ([`Fallback`]). Then the temporal smoothing and the change detection.

use super::smoother::ChangeReason;
use super::noise::fit_channel;
use super::solve::{COND_CAP, ChannelFit, ChannelRows};
use super::{DARK_FRACTION, DARK_MAX_GAP_S, Estimator, Fallback, FrameEstimate, Intensities, LUMA, MIN_LIT_SAMPLES, Status, luma};
use chrono::{DateTime, FixedOffset};
use glam::Vec3;
use rand::rngs::SmallRng;

impl Estimator {
    /// Fits the rows gathered for `out` and sets its values, status and fallback.
    pub(super) fn decide(&mut self, out: &mut FrameEstimate, above: bool, clipped_lit: usize, saturated: bool, rng: &mut SmallRng) {
        let counts = out.samples;
        let held_pd = self.last_smoothed.map(|s| [s[0], s[1], s[2]]);
        if counts.usable < self.config.min_samples.max(3) {
            out.status = if saturated { Status::Saturated } else { Status::TooFewSamples };
        } else if !above {
            // Night: no direct sun; fit Pa alone.
            let fits = self.fit_channels(false, rng);
            self.fill_pa_only(out, &fits);
            out.pd = Some([0.0; 3]);
            out.pd_se = Some([0.0; 3]);
            out.status = Status::Night;
        } else if counts.lit < MIN_LIT_SAMPLES {
            // No sunlit samples: Pa is observable, Pd is not (directly). Shadowed samples still
            // receive sun light bounced off lit proxy surfaces (the `b` column). Where that bounce
            // varies enough across the samples, a two-parameter fit separates it and Pa is
            // unbiased; otherwise the bounce of the held Pd is subtracted, or, with nothing held,
            // Pa absorbs it (reported as such through the status).
            let bounce_fit = self.fit_channels(true, rng).filter(|f| {
                f.iter().all(|c| c.condition <= self.config.max_condition && c.pd_se.is_finite())
                    && luma(&f.map(|c| c.pa_se)) < 0.1 * luma(&f.map(|c| c.pa))
            });
            match bounce_fit {
                Some(f) => {
                    self.flag_pd = Some(f.map(|c| c.pd));
                    self.fill_pa_only(out, &Some(f));
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
                    let fits = self.fit_channels(false, rng);
                    self.fill_pa_only(out, &fits);
                    self.flag_pd = Some(held_pd.unwrap_or([0.0; 3]));
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
            let fits = self.fit_channels(true, rng);
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
                    self.separable_fallback(out, rng);
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
    }

    /// Whether the gathered samples are a dark frame: all black, or darker than `DARK_FRACTION`
    /// of what the smoothed lighting predicts for them (`y ≈ a·Pa + b·Pd`, luminance summed over
    /// the samples), within `DARK_MAX_GAP_S` of the last update.
    pub(super) fn is_dark(&self, time: &DateTime<FixedOffset>) -> bool {
        let n = self.rows[0].len();
        if n == 0 {
            return false;
        }
        let observed: f64 = (0..3).map(|c| LUMA[c] * self.rows[c].y.iter().sum::<f64>()).sum();
        if observed <= 0.0 {
            return true;
        }
        let (Some(s), Some(last)) = (self.last_smoothed, self.last_update) else { return false };
        let gap_s = (*time - last).num_milliseconds().unsigned_abs() as f64 * 1e-3;
        if gap_s > DARK_MAX_GAP_S {
            return false;
        }
        let predicted: f64 = (0..3)
            .map(|c| {
                let r = &self.rows[c];
                LUMA[c] * (0..n).map(|i| r.a[i] * s[c + 3] + r.b[i] * s[c]).sum::<f64>()
            })
            .sum();
        predicted > 0.0 && observed < DARK_FRACTION * predicted
    }

    /// Smooths the frame's values over time and decides whether later stages relight.
    pub(super) fn smooth(&mut self, out: &mut FrameEstimate, time: &DateTime<FixedOffset>, dir: Vec3) {
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
        let mut lamps = std::mem::take(&mut out.lamps);
        self.smooth_lamps(&mut lamps, t_s);
        out.lamps = lamps;
        if let Some(s) = self.smoother.update(t_s, self.config.smoothing_rate_per_sqrt_s, meas) {
            self.last_smoothed = Some(s);
            if observed_pd && out.sun.above_horizon && out.status != Status::Night {
                self.overcast_sky = luma(&[s[0], s[1], s[2]]) < self.config.no_sun_ratio * luma(&[s[3], s[4], s[5]]);
            }
            out.smoothed = Some(Intensities { pd: [s[0], s[1], s[2]], pa: [s[3], s[4], s[5]] });
            self.last_update = Some(*time);
            out.change = self.detector.check(dir, s, self.config.relight_threshold, self.config.relight_sun_deg);
            out.relight = out.change != ChangeReason::Unchanged;
        }
    }

    fn fit_channels(&mut self, two: bool, rng: &mut SmallRng) -> Option<[ChannelFit; 3]> {
        if self.lamps_in_fit() {
            return self.fit_channels_lamps(two, rng);
        }
        if self.band.on {
            // With the twilight band (`super::sky_band`); when it is dropped, without it.
            if let Some(fits) = self.fit_channels_band(two, rng) {
                return Some(fits);
            }
            if self.band.on {
                return None;
            }
        }
        let (fl, rn) = (self.noise_floor, self.read_noise);
        let f0 = fit_channel(&self.rows[0], &self.lit, two, fl, rn, rng)?;
        let f1 = fit_channel(&self.rows[1], &self.lit, two, fl, rn, rng)?;
        let f2 = fit_channel(&self.rows[2], &self.lit, two, fl, rn, rng)?;
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
        self.subtract_fitted_lamps();
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
                    if let Some(f) = fit_channel(&z, &self.lit, false, self.noise_floor, self.read_noise, rng) {
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
                    if let Some(f) = fit_channel(&z, &self.lit, false, self.noise_floor, self.read_noise, rng) {
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
