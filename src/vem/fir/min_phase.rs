//! The low-delay (minimum-phase) version of a linear-phase design, for live input (issue 14,
//! part 4): the same amplitude response with the least delay a causal filter of that length can
//! have.
//!
//! # How it works
//! The transfer function `H(z) = Σ hₖ z⁻ᵏ` of the linear-phase filter has its zeros in
//! reciprocal pairs `z, 1/z̄` (and on the unit circle in the stop band). Replacing every zero
//! outside the unit circle by its reciprocal `1/z̄` changes `|H(e^{iω})|` only by the constant
//! factor `|z|` (Oppenheim & Schafer §5.6, "minimum-phase and all-pass decomposition"), so after
//! renormalising to unit DC gain the amplitude response is the paper's, while all the zeros lie
//! on or inside the circle: the minimum-phase filter. Its delay at DC is the taps' centroid
//! `Σ k·hₖ / Σ hₖ` ([`group_delay_dc`]), against `(taps − 1)/2` for the linear-phase original.
//! The zeros come from the Durand–Kerner (Weierstrass) iteration on the monic polynomial.

/// A complex number (only what the root finder needs).
#[derive(Clone, Copy, Debug, PartialEq)]
struct C(f64, f64);

impl C {
    fn add(self, o: C) -> C {
        C(self.0 + o.0, self.1 + o.1)
    }
    fn sub(self, o: C) -> C {
        C(self.0 - o.0, self.1 - o.1)
    }
    fn mul(self, o: C) -> C {
        C(self.0 * o.0 - self.1 * o.1, self.0 * o.1 + self.1 * o.0)
    }
    fn div(self, o: C) -> C {
        let d = o.0 * o.0 + o.1 * o.1;
        C((self.0 * o.0 + self.1 * o.1) / d, (self.1 * o.0 - self.0 * o.1) / d)
    }
    fn abs(self) -> f64 {
        self.0.hypot(self.1)
    }
}

/// Evaluates the monic polynomial with coefficients `a` (highest power first, `a[0] = 1`).
fn horner(a: &[f64], z: C) -> C {
    a.iter().fold(C(0.0, 0.0), |acc, &c| acc.mul(z).add(C(c, 0.0)))
}

/// Zeros of `Σ hₖ z⁻ᵏ` (Durand–Kerner); `None` if the iteration does not settle.
fn zeros(h: &[f64]) -> Option<Vec<C>> {
    let deg = h.len() - 1;
    if deg == 0 || h[0] == 0.0 {
        return None;
    }
    let a: Vec<f64> = h.iter().map(|c| c / h[0]).collect();
    let scale = 1.0 + a.iter().skip(1).fold(0.0f64, |m, c| m.max(c.abs()));
    let mut z: Vec<C> = (0..deg)
        .map(|k| {
            let t = std::f64::consts::TAU * k as f64 / deg as f64 + 0.4;
            C(0.9 * t.cos(), 0.9 * t.sin())
        })
        .collect();
    for _ in 0..2000 {
        let mut moved = 0.0f64;
        for i in 0..deg {
            let den = (0..deg).filter(|&j| j != i).fold(C(1.0, 0.0), |p, j| p.mul(z[i].sub(z[j])));
            if den.abs() < 1e-300 {
                z[i] = z[i].add(C(1e-6, 1e-6));
                continue;
            }
            let step = horner(&a, z[i]).div(den);
            z[i] = z[i].sub(step);
            moved = moved.max(step.abs());
        }
        if moved < 1e-14 * scale {
            break;
        }
    }
    let ok = z.iter().all(|&r| r.0.is_finite() && r.1.is_finite() && horner(&a, r).abs() < 1e-8 * scale * (1.0 + r.abs()).powi(deg as i32));
    ok.then_some(z)
}

/// The minimum-phase taps with the same amplitude response as `h`, unit DC gain; `None` when the
/// zeros cannot be found or the result has no DC gain.
pub fn minimum_phase(h: &[f64]) -> Option<Vec<f64>> {
    let z = zeros(h)?;
    // Π (x − zᵢ) with every zero inside or on the unit circle, expanded (highest power first).
    let mut p = vec![C(1.0, 0.0)];
    for r in z {
        let r = if r.abs() > 1.0 { C(1.0, 0.0).div(C(r.0, -r.1)) } else { r };
        let mut next = vec![C(0.0, 0.0); p.len() + 1];
        for (k, &c) in p.iter().enumerate() {
            next[k] = next[k].add(c);
            next[k + 1] = next[k + 1].sub(c.mul(r));
        }
        p = next;
    }
    let taps: Vec<f64> = p.iter().map(|c| c.0).collect();
    let sum: f64 = taps.iter().sum();
    (sum.abs() > 1e-9 && taps.iter().all(|t| t.is_finite())).then(|| taps.iter().map(|t| t / sum).collect())
}

/// Delay at DC, frames: the taps' centroid `Σ k·hₖ / Σ hₖ` (tap 0 on the newest frame).
pub fn group_delay_dc(h: &[f64]) -> f64 {
    let s: f64 = h.iter().sum();
    h.iter().enumerate().map(|(k, w)| k as f64 * w).sum::<f64>() / s
}

/// Amplitude `|Σ hₖ e^{−iωk}|` at normalised frequency `f` (cycles per sample), any taps.
pub fn magnitude(h: &[f64], f: f64) -> f64 {
    let w = std::f64::consts::TAU * f;
    let (re, im) = h.iter().enumerate().fold((0.0, 0.0), |(re, im), (k, c)| (re + c * (w * k as f64).cos(), im - c * (w * k as f64).sin()));
    re.hypot(im)
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::vem::fir::FirDesign;

    #[test]
    fn minimum_phase_keeps_the_amplitude_and_cuts_the_delay() {
        for design in [FirDesign::paper(), FirDesign::for_rate(30.0).unwrap(), FirDesign::for_rate(60.0).unwrap()] {
            let h = &design.taps;
            let m = minimum_phase(h).unwrap();
            assert_eq!(m.len(), h.len());
            assert!((m.iter().sum::<f64>() - 1.0).abs() < 1e-12);
            // Same amplitude at every frequency (closed form: reflection scales |H| by a constant,
            // removed by the unit DC gain), to rounding of the root finder.
            for i in 0..=200 {
                let f = 0.5 * i as f64 / 200.0;
                assert!((magnitude(&m, f) - magnitude(h, f)).abs() < 1e-6, "{} Hz: {} vs {}", f * design.rate_hz, magnitude(&m, f), magnitude(h, f));
            }
            let (lin, min) = (group_delay_dc(h), group_delay_dc(&m));
            assert!((lin - (h.len() - 1) as f64 / 2.0).abs() < 1e-9);
            assert!(min < 0.5 * lin, "{} Hz: delay {min} vs {lin}", design.rate_hz);
        }
    }
}
