//! The filter's design (Havran §3.3): the paper's 9 taps at 21 Hz, and an equiripple
//! (Parks–McClellan / Remez exchange) low-pass for other capture rates. See the parent module
//! for the choice of band edges and order.

/// The paper's 9 taps at 21 Hz, as printed (sum 1.09245).
pub const PAPER_TAPS_21HZ: [f64; 9] = [0.06216, 0.01296, -0.13816, 0.28315, 0.65223, 0.28315, -0.13816, 0.01296, 0.06216];
/// The capture rate the paper's taps were designed for.
pub const PAPER_RATE_HZ: f64 = 21.0;
/// Pass-band edge of the designed filter (reproduces the paper's taps at 21 Hz).
pub const DESIGN_PASS_HZ: f64 = 5.9;
/// Stop-band edge of the designed filter.
pub const DESIGN_STOP_HZ: f64 = 8.05;
/// Largest filter order the design uses (65 taps, above ≈ 170 Hz capture).
pub const MAX_ORDER: usize = 64;
/// Largest difference, over `[0, 10.5]` Hz, between the designed and the paper's (normalised)
/// amplitude responses at 21 Hz that the tests accept (measured: 0.004).
pub const PAPER_RESPONSE_TOLERANCE: f64 = 0.005;
/// Errors designing a filter.
#[derive(Debug, thiserror::Error, PartialEq)]
pub enum TemporalError {
    /// The capture rate is not a positive number.
    #[error("capture rate {0} Hz is not a positive number")]
    BadRate(f64),
    /// The Remez exchange did not converge.
    #[error("the equiripple design for {rate_hz} Hz did not converge")]
    NoConvergence {
        /// The capture rate.
        rate_hz: f64,
    },
}

/// An FIR low-pass with unit DC gain: symmetric (linear phase) as designed, or its
/// minimum-phase version.
#[derive(Clone, Debug, PartialEq)]
pub struct FirDesign {
    /// The taps, summing to 1 (tap `k` weighs the frame `k` frames before the newest when the
    /// filter runs causally).
    pub taps: Vec<f64>,
    /// The capture rate it is meant for.
    pub rate_hz: f64,
}

impl FirDesign {
    /// The paper's filter, normalised to unit DC gain.
    pub fn paper() -> Self {
        let s: f64 = PAPER_TAPS_21HZ.iter().sum();
        Self { taps: PAPER_TAPS_21HZ.iter().map(|w| w / s).collect(), rate_hz: PAPER_RATE_HZ }
    }

    /// The filter for a capture rate: the paper's at 21 Hz, an equiripple design otherwise (see
    /// the module docs).
    pub fn for_rate(rate_hz: f64) -> Result<Self, TemporalError> {
        if !(rate_hz.is_finite() && rate_hz > 0.0) {
            return Err(TemporalError::BadRate(rate_hz));
        }
        if (rate_hz - PAPER_RATE_HZ).abs() < 1e-9 {
            return Ok(Self::paper());
        }
        Self::design(rate_hz)
    }

    /// The equiripple design for a capture rate (also at 21 Hz, to compare with the paper).
    pub fn design(rate_hz: f64) -> Result<Self, TemporalError> {
        if !(rate_hz.is_finite() && rate_hz > 0.0) {
            return Err(TemporalError::BadRate(rate_hz));
        }
        let nyquist = rate_hz / 2.0;
        let (order, pass, stop) = if DESIGN_STOP_HZ < 0.95 * nyquist {
            let order = (2 * ((4.0 * rate_hz / PAPER_RATE_HZ).round() as usize)).clamp(2, MAX_ORDER);
            (order, DESIGN_PASS_HZ / rate_hz, DESIGN_STOP_HZ / rate_hz)
        } else {
            (8, DESIGN_PASS_HZ / PAPER_RATE_HZ, DESIGN_STOP_HZ / PAPER_RATE_HZ)
        };
        let h = remez_lowpass(order, pass, stop).ok_or(TemporalError::NoConvergence { rate_hz })?;
        let s: f64 = h.iter().sum();
        Ok(Self { taps: h.iter().map(|w| w / s).collect(), rate_hz })
    }

    /// Delay in frames at DC, rounded: `(taps − 1)/2` for a linear-phase design, less for its
    /// [`FirDesign::minimum_phase`] version.
    pub fn delay_frames(&self) -> usize {
        self.group_delay_frames().round().max(0.0) as usize
    }

    /// Delay in frames at DC, the taps' centroid ([`super::min_phase::group_delay_dc`]).
    pub fn group_delay_frames(&self) -> f64 {
        super::min_phase::group_delay_dc(&self.taps)
    }

    /// The minimum-phase filter with this design's amplitude response (the low-delay causal
    /// filter for live input, [`super::min_phase`]).
    pub fn minimum_phase(&self) -> Result<Self, TemporalError> {
        let taps = super::min_phase::minimum_phase(&self.taps).ok_or(TemporalError::NoConvergence { rate_hz: self.rate_hz })?;
        Ok(Self { taps, rate_hz: self.rate_hz })
    }

    /// Whether the taps are symmetric (linear phase, zero phase when centred).
    pub fn is_symmetric(&self) -> bool {
        let n = self.taps.len();
        (0..n / 2).all(|k| (self.taps[k] - self.taps[n - 1 - k]).abs() <= 1e-12 * (1.0 + self.taps[k].abs()))
    }

    /// Zero-phase amplitude response at `f_hz`.
    pub fn response(&self, f_hz: f64) -> f64 {
        amplitude(&self.taps, f_hz / self.rate_hz)
    }
}

/// Zero-phase amplitude of symmetric taps at normalised frequency `f` (cycles per sample).
pub fn amplitude(taps: &[f64], f: f64) -> f64 {
    let m = taps.len() / 2;
    taps[m] + 2.0 * (1..=m).map(|k| taps[m + k] * (std::f64::consts::TAU * f * k as f64).cos()).sum::<f64>()
}

/// Equiripple type-I low-pass of even `order` (`order + 1` taps) with equal pass- and stop-band
/// weights, band edges in cycles per sample (`0 < pass < stop < ½`): the Remez exchange of
/// Parks & McClellan (1972) on a dense grid, with the barycentric form of the interpolant
/// (Oppenheim & Schafer §7.7) so that long filters with a narrow pass band stay well conditioned.
/// `None` if it fails.
pub fn remez_lowpass(order: usize, pass: f64, stop: f64) -> Option<Vec<f64>> {
    if order < 2 || order % 2 != 0 || !(0.0 < pass && pass < stop && stop < 0.5) {
        return None;
    }
    let m = order / 2;
    let n_ext = m + 2;
    let per_band = (32 * (m + 1)).max(512);
    // Grid in x = cos ω (ω ascending), with the desired amplitude.
    let mut grid: Vec<(f64, f64)> = Vec::with_capacity(2 * per_band);
    for i in 0..per_band {
        grid.push(((std::f64::consts::TAU * pass * i as f64 / (per_band - 1) as f64).cos(), 1.0));
    }
    for i in 0..per_band {
        grid.push(((std::f64::consts::TAU * (stop + (0.5 - stop) * i as f64 / (per_band - 1) as f64)).cos(), 0.0));
    }
    // Barycentric weights 1/Π(x_i − x_j), computed in the log domain and rescaled (the formulas
    // only use their ratios): the plain products under- and overflow for long filters.
    let weights = |x: &[f64]| -> Vec<f64> {
        let logs: Vec<(f64, f64)> = (0..x.len())
            .map(|i| {
                (0..x.len()).filter(|&j| j != i).fold((0.0, 1.0), |(l, s), j| {
                    let d = x[i] - x[j];
                    (l - d.abs().max(1e-300).ln(), if d < 0.0 { -s } else { s })
                })
            })
            .collect();
        let top = logs.iter().map(|p| p.0).fold(f64::MIN, f64::max);
        logs.iter().map(|&(l, s)| s * (l - top).exp()).collect()
    };
    let mut ext: Vec<usize> = (0..n_ext).map(|i| i * (grid.len() - 1) / (n_ext - 1)).collect();
    // The current interpolant: nodes, values, barycentric weights.
    let mut interp: (Vec<f64>, Vec<f64>, Vec<f64>) = (vec![], vec![], vec![]);
    let eval = |(xs, cs, bs): &(Vec<f64>, Vec<f64>, Vec<f64>), x: f64| -> f64 {
        let (mut num, mut den) = (0.0, 0.0);
        for k in 0..xs.len() {
            let d = x - xs[k];
            if d.abs() < 1e-14 {
                return cs[k];
            }
            num += bs[k] / d * cs[k];
            den += bs[k] / d;
        }
        num / den
    };
    for _ in 0..100 {
        let x: Vec<f64> = ext.iter().map(|&e| grid[e].0).collect();
        let b = weights(&x);
        let num: f64 = ext.iter().zip(&b).map(|(&e, bi)| bi * grid[e].1).sum();
        let den: f64 = b.iter().enumerate().map(|(i, bi)| if i % 2 == 0 { *bi } else { -bi }).sum();
        let delta = num / den;
        if !delta.is_finite() {
            return None;
        }
        let xs = x[..n_ext - 1].to_vec();
        let cs: Vec<f64> = (0..n_ext - 1).map(|i| grid[ext[i]].1 - if i % 2 == 0 { delta } else { -delta }).collect();
        let bs = weights(&xs);
        interp = (xs, cs, bs);
        let err: Vec<f64> = grid.iter().map(|&(x, d)| eval(&interp, x) - d).collect();
        // Local extrema of the error within each band, band edges included.
        let mut cand = Vec::new();
        for i in 0..grid.len() {
            let same = |j: usize| grid[j].1 == grid[i].1;
            let l = (i > 0 && same(i - 1)).then(|| err[i - 1]);
            let r = (i + 1 < grid.len() && same(i + 1)).then(|| err[i + 1]);
            let e = err[i];
            let is_max = l.is_none_or(|l| e >= l) && r.is_none_or(|r| e >= r);
            let is_min = l.is_none_or(|l| e <= l) && r.is_none_or(|r| e <= r);
            if is_max || is_min {
                cand.push(i);
            }
        }
        // Alternating signs: of consecutive extrema with the same sign keep the larger.
        let mut alt: Vec<usize> = Vec::new();
        for i in cand {
            match alt.last() {
                Some(&last) if (err[i] >= 0.0) == (err[last] >= 0.0) => {
                    if err[i].abs() > err[last].abs() {
                        *alt.last_mut()? = i;
                    }
                }
                _ => alt.push(i),
            }
        }
        while alt.len() > n_ext {
            if err[alt[0]].abs() < err[alt[alt.len() - 1]].abs() {
                alt.remove(0);
            } else {
                alt.pop();
            }
        }
        if alt.len() < n_ext || alt == ext {
            break;
        }
        ext = alt;
    }
    // Taps by frequency sampling of the amplitude at ω_l = 2πl/N, N = order + 1.
    let n = order + 1;
    let a: Vec<f64> = (0..=m).map(|l| eval(&interp, (std::f64::consts::TAU * l as f64 / n as f64).cos())).collect();
    if a.iter().any(|v| !v.is_finite()) {
        return None;
    }
    let h: Vec<f64> = (0..n)
        .map(|i| {
            let k = i as f64 - m as f64;
            (a[0] + 2.0 * (1..=m).map(|l| a[l] * (std::f64::consts::TAU * l as f64 * k / n as f64).cos()).sum::<f64>()) / n as f64
        })
        .collect();
    let sum: f64 = h.iter().sum();
    (h.iter().all(|v| v.is_finite()) && sum.abs() > 1e-9).then_some(h)
}
