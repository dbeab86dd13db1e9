//! A lamp's scale in hindsight: the forward–backward (Rauch–Tung–Striebel) smoother of `k` for
//! recorded footage, where every frame's estimate may use the frames after it as well as those
//! before (issue 16 §3: `k_i` within 5%).
//!
//! # Why
//! The forward filter ([`super::smoother::LampSmoother`]) can only average the frames it has
//! seen. On the frame where a lamp switches on it has one fit, and at dusk that fit is the least
//! certain of the run: the sky is still hundreds of times brighter than the lamp on most samples,
//! so `k` has a standard error of 10–14% there (the bundled dusk scene, frame 1), against 3% an
//! hour later. A luminaire's scale is steady once it is on, so in a recording the later frames
//! say what the first one could not. `heliar augment` (file in, file out) therefore estimates the
//! whole span first, runs this backward pass, and renders every frame with the result; the live
//! window keeps the forward filter, since it cannot look ahead.
//!
//! # The model and the pass
//! The forward filter is a random walk `k_{t+1} = k_t + w_t`, `Var w_t = Q_t` (the lamp's rate
//! `q·k̄·√Δt`, squared), with each frame's fit as a measurement. Per channel, with `x_t`, `P_t`
//! its filtered value and variance and `P⁻_{t+1} = P_t + Q_t` the variance it predicted for the
//! next frame, the backward pass is
//!
//! `C_t = P_t / P⁻_{t+1}`,  `x̂_t = x_t + C_t·(x̂_{t+1} − x_t)`,
//!
//! from `x̂_T = x_T` at the last frame of a run (Rauch, Tung & Striebel 1965; Särkkä, *Bayesian
//! Filtering and Smoothing*, §8.2, with the random walk's transition of 1). With `Q = 0` every
//! frame of a run gets the run's inverse-variance mean; with a large `Q` the frames keep their own
//! fits. A run ends where the forward filter restarts, so nothing crosses a switch-off or a
//! departure beyond the robust band (a dimming step, a warm-up): those are different states of
//! the luminaire. Frames of a run that were on but not fitted (unreached, not separable) before
//! its first fit take the first fitted frame's value in hindsight; frames that are off have none.
//!
//! The pass replays the forward filter from the reports, so its last frame of each run equals the
//! forward `k_smoothed`, and its cost is a few operations per lamp and frame.

use super::report::LampReport;
use super::smoother::{LampFilterState, LampSmoother};
use super::LampStatus;
use crate::scene::Scene;
use std::collections::BTreeMap;

/// One frame of a lamp's track, as the forward filter takes it.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct TrackPoint {
    /// The frame's time, s (any origin; only differences count).
    pub time_s: f64,
    /// The lamp is on by its schedule.
    pub on: bool,
    /// The lamp's prior scale.
    pub prior: f64,
    /// The frame's fit `(k, k_se)`, `None` when `k` was not fitted.
    pub meas: Option<([f64; 3], [f64; 3])>,
}

impl TrackPoint {
    /// The point of a frame's report on one lamp, as `estimate::lamps` feeds its forward filter.
    pub fn of_report(time_s: f64, prior: f64, r: &LampReport) -> Self {
        Self { time_s, on: r.status != LampStatus::Off, prior, meas: measurement(r) }
    }
}

/// The forward filter's measurement in a report: the fitted `k` with its standard errors (an
/// infinite one taken as huge), `None` when the frame did not fit it.
pub(super) fn measurement(r: &LampReport) -> Option<([f64; 3], [f64; 3])> {
    match (r.status, r.k_se) {
        (LampStatus::Fitted, Some(se)) => Some((r.k, se.map(|s| if s.is_finite() { s } else { f64::MAX.sqrt() }))),
        _ => None,
    }
}

/// The smoothed `k` of every frame of one lamp's track (module docs), `None` where the lamp is
/// off or no frame of its run was fitted. `rate` is the forward filter's
/// (`lamp_smoothing_rate_per_sqrt_s`).
pub fn smooth_track(track: &[TrackPoint], rate: f64) -> Vec<Option<[f64; 3]>> {
    let mut f = LampSmoother::default();
    let states: Vec<Option<LampFilterState>> = track
        .iter()
        .map(|p| {
            f.update(p.time_s, rate, p.on, p.prior, p.meas);
            f.state()
        })
        .collect();
    let mut out: Vec<Option<[f64; 3]>> = vec![None; track.len()];
    for t in (0..track.len()).rev() {
        let next = (t + 1 < track.len()).then(|| (states[t + 1], out[t + 1])).and_then(|(s, o)| Some((s?, o?)));
        out[t] = match (states[t], next) {
            // Filtered, with a later frame of the same run: the backward step.
            (Some(s), Some((n, smoothed))) if n.run == s.run => Some(std::array::from_fn(|c| {
                let gain = s.var[c] / n.pred_var[c];
                let gain = if gain.is_finite() { gain.clamp(0.0, 1.0) } else { 1.0 };
                (s.k[c] + gain * (smoothed[c] - s.k[c])).max(0.0)
            })),
            // The last frame of its run: the filter's own value.
            (Some(s), _) => Some(s.k),
            // On and not yet fitted since the switch-on (the filter has no state only then), with
            // the lamp still on at the next frame: the run that follows, whose first fit is at
            // or after that frame.
            (None, _) if track[t].on && t + 1 < track.len() && track[t + 1].on => out[t + 1],
            (None, _) => None,
        };
    }
    out
}

/// Every lamp's `k` in hindsight over a span of frames, by frame index.
#[derive(Clone, Debug, Default, PartialEq)]
pub struct LampHindsight {
    by_frame: BTreeMap<usize, Vec<Option<[f64; 3]>>>,
}

impl LampHindsight {
    /// The backward pass over the lamp reports of a span of consecutive frames `(index, time_s,
    /// lamps)` in order, with the scene's lamp priors and rate.
    pub fn from_reports<'a>(scene: &Scene, frames: impl IntoIterator<Item = (usize, f64, &'a [LampReport])>) -> Self {
        let frames: Vec<(usize, f64, &[LampReport])> = frames.into_iter().collect();
        let rate = scene.estimator.lamp_smoothing_rate_per_sqrt_s;
        let lamps = frames.iter().map(|f| f.2.len()).max().unwrap_or(0);
        let tracks: Vec<Vec<Option<[f64; 3]>>> = (0..lamps)
            .map(|j| {
                let prior = scene.lights.get(j).map_or(1.0, |l| l.scale);
                let track: Vec<TrackPoint> = frames
                    .iter()
                    .map(|(_, t, r)| r.get(j).map_or(TrackPoint { time_s: *t, on: false, prior, meas: None }, |r| TrackPoint::of_report(*t, prior, r)))
                    .collect();
                smooth_track(&track, rate)
            })
            .collect();
        let by_frame = frames.iter().enumerate().map(|(n, (i, _, _))| (*i, tracks.iter().map(|t| t[n]).collect())).collect();
        Self { by_frame }
    }

    /// Frames covered.
    pub fn frames(&self) -> usize {
        self.by_frame.len()
    }

    /// Sets `k_hindsight` of frame `index`'s lamp reports (left alone for a frame outside the
    /// span).
    pub fn apply(&self, index: usize, lamps: &mut [LampReport]) {
        if let Some(ks) = self.by_frame.get(&index) {
            for (r, k) in lamps.iter_mut().zip(ks) {
                r.k_hindsight = *k;
            }
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn fit(t: f64, k: f64, se: f64) -> TrackPoint {
        TrackPoint { time_s: t, on: true, prior: 1.0, meas: Some(([k; 3], [se; 3])) }
    }

    #[test]
    fn with_no_drift_every_frame_of_a_run_gets_its_inverse_variance_mean() {
        let fits = [(1.216, 0.112), (0.918, 0.045), (1.003, 0.036), (0.948, 0.035), (1.041, 0.024)];
        let track: Vec<TrackPoint> = fits.iter().enumerate().map(|(i, &(k, se))| fit(600.0 * i as f64, k, se)).collect();
        let s = smooth_track(&track, 0.0);
        let w: f64 = fits.iter().map(|(_, se)| se.powi(-2)).sum();
        let mean = fits.iter().map(|(k, se)| k * se.powi(-2)).sum::<f64>() / w;
        for (t, v) in s.iter().enumerate() {
            let v = v.expect("fitted");
            assert!((v[0] - mean).abs() < 1e-12, "frame {t}: {} vs the mean {mean}", v[0]);
        }
        // The last frame equals the forward filter.
        let mut f = LampSmoother::default();
        let last = track.iter().map(|p| f.update(p.time_s, 0.0, p.on, p.prior, p.meas)).last().flatten().unwrap();
        assert_eq!(s[4], Some(last));
    }

    #[test]
    fn the_backward_pass_matches_the_smoother_of_the_full_linear_model() {
        // A random walk with known Q and R per frame, smoothed by solving the normal equations of
        // the whole chain (the exact posterior mean of a Gaussian chain): the RTS pass gives the
        // same means.
        use crate::scene::settings::LAMP_SMOOTHING_RATE as RATE;
        let z = [1.3, 0.9, 1.1, 0.95, 1.02, 0.99];
        let se = [0.12, 0.05, 0.04, 0.03, 0.03, 0.025];
        let dt = [0.0, 600.0, 300.0, 1200.0, 600.0, 60.0];
        let mut time = 0.0;
        let track: Vec<TrackPoint> = (0..6)
            .map(|i| {
                time += dt[i];
                fit(time, z[i], se[i])
            })
            .collect();
        let s = smooth_track(&track, RATE);
        // The forward filter's Q_t is (q·k̄_t·√Δt)² with k̄ its value at the prediction; take
        // those from the filter itself.
        let mut f = LampSmoother::default();
        let mut q = vec![0.0; 6];
        let mut prev_var = 0.0;
        for (t, p) in track.iter().enumerate() {
            f.update(p.time_s, RATE, true, 1.0, p.meas);
            let st = f.state().unwrap();
            if t > 0 {
                q[t] = st.pred_var[0] - prev_var;
            }
            prev_var = st.var[0];
        }
        // Normal equations: Σ (x_t − z_t)²/R_t + Σ (x_t − x_{t−1})²/Q_t, a symmetric
        // tridiagonal system (diagonal `d`, off-diagonal `o[t]` between t−1 and t), solved by
        // Gaussian elimination down the band and back-substitution.
        let n = 6;
        let (mut d, mut o, mut b) = (vec![0.0; n], vec![0.0; n], vec![0.0; n]);
        for t in 0..n {
            let r = se[t] * se[t];
            d[t] += 1.0 / r;
            b[t] += z[t] / r;
            if t > 0 {
                let w = 1.0 / q[t];
                d[t] += w;
                d[t - 1] += w;
                o[t] = -w;
            }
        }
        for t in 1..n {
            let m = o[t] / d[t - 1];
            d[t] -= m * o[t];
            b[t] -= m * b[t - 1];
        }
        let mut x = vec![0.0; n];
        x[n - 1] = b[n - 1] / d[n - 1];
        for t in (0..n - 1).rev() {
            x[t] = (b[t] - o[t + 1] * x[t + 1]) / d[t];
        }
        for t in 0..n {
            let v = s[t].unwrap()[0];
            assert!((v - x[t]).abs() < 1e-9, "frame {t}: RTS {v} vs the chain's posterior mean {}", x[t]);
        }
        // Frame 0 (the least certain) moved towards the later frames.
        assert!((s[0].unwrap()[0] - 1.0).abs() < (z[0] - 1.0) / 3.0);
    }

    #[test]
    fn runs_do_not_share_across_a_switch_off_or_a_departure_and_unfitted_frames_take_the_run_after() {
        use crate::scene::settings::LAMP_SMOOTHING_RATE as RATE;
        let off = |t: f64| TrackPoint { time_s: t, on: false, prior: 1.0, meas: None };
        let unfitted = |t: f64| TrackPoint { time_s: t, on: true, prior: 1.0, meas: None };
        let track = vec![
            off(0.0),
            unfitted(10.0),
            fit(20.0, 1.2, 0.1),
            fit(30.0, 1.0, 0.02),
            off(40.0),
            fit(50.0, 2.0, 0.02),
            // A dimming step: beyond the robust band, a new run.
            fit(60.0, 0.5, 0.02),
            fit(70.0, 0.52, 0.02),
        ];
        let s = smooth_track(&track, RATE);
        assert_eq!(s[0], None);
        assert_eq!(s[4], None);
        // The unfitted frame after the switch-on takes its run's first smoothed value.
        assert_eq!(s[1], s[2]);
        // Frame 2 is pulled to frame 3's precise fit, not to the later runs.
        let k2 = s[2].unwrap()[0];
        assert!((k2 - 1.0).abs() < 0.02, "{k2}");
        // The run after the switch-off holds only its own frame.
        assert_eq!(s[5], Some([2.0; 3]));
        // The dimmed run averages its two frames and nothing before.
        let (k6, k7) = (s[6].unwrap()[0], s[7].unwrap()[0]);
        assert!((k6 - 0.51).abs() < 0.001 && (k7 - 0.51).abs() < 0.001, "{k6} {k7}");
    }
}
