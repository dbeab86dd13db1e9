//! The quadratic "bellq" basis on the sampling plane (Granier Eq. 6), its compactly supported
//! dual used as the acquisition filter, the filter grid, and Gauss–Legendre rules.
//!
//! # How it works
//! `φ(x) = 1 − 2x²` for `|x| ≤ ½`, `2(|x| − 1)²` for `½ < |x| ≤ 1`, 0 beyond (Eq. 6): C¹,
//! support `[−1, 1]`, `∫φ = 1`, and the integer shifts sum to one (partition of unity). A filter
//! position `(m, n)` of a grid with spacing `h` has `Φ_mn(u, v) = φ((u − u_m)/h) φ((v − v_n)/h)`,
//! support `2h × 2h` and `∫Φ_mn = h²`.
//!
//! The measurement needs a dual `φ'` with `∫ φ'(x) φ(x − n) dx = δ_n` (Granier §2: then Eq. 2
//! collapses to Eq. 4). We take `φ'(x) = Σ_{|j| ≤ 3} c_|j| φ(2x − j)`, support `[−2, 2]` (a
//! filter four spacings wide, as the paper's 20 mm filters at 5 mm spacing), with the four
//! coefficients fixed by biorthogonality for `n = 0, 1, 2` and by `c₀ + 2c₂ = 1`, which makes the
//! shifted duals sum to one as well (so a source that is uniform over a filter region is measured
//! exactly). The filter has negative lobes, so measured images can be negative.

use glam::DVec2;
use std::sync::OnceLock;

/// Eq. 6: the bellq basis function.
pub fn bellq(x: f64) -> f64 {
    let a = x.abs();
    if a <= 0.5 {
        1.0 - 2.0 * a * a
    } else if a <= 1.0 {
        2.0 * (a - 1.0) * (a - 1.0)
    } else {
        0.0
    }
}

/// The dual filter `φ'` (module docs); support `[−2, 2]`.
pub fn bellq_dual(x: f64) -> f64 {
    let c = dual_coefficients();
    (-3i32..=3).map(|j| c[j.unsigned_abs() as usize] * bellq(2.0 * x - j as f64)).sum()
}

/// The coefficients `c₀…c₃` of [`bellq_dual`].
pub fn dual_coefficients() -> &'static [f64; 4] {
    static C: OnceLock<[f64; 4]> = OnceLock::new();
    C.get_or_init(|| {
        // Row n (0..3): Σ_k c_k ∫ (φ(2x−k) + φ(2x+k) for k > 0) φ(x − n) dx = δ_n0.
        // Row 3: c₀ + 2c₂ = 1. All integrands are piecewise polynomials of degree 4 with breaks
        // at multiples of ¼: three Gauss points per quarter cell integrate them exactly.
        let rule = gauss_legendre(3);
        let mut a = [[0.0; 4]; 4];
        let mut b = [0.0; 4];
        for (n, row) in a.iter_mut().take(3).enumerate() {
            for (k, cell) in row.iter_mut().enumerate() {
                let f = |x: f64| {
                    let pair = if k == 0 { bellq(2.0 * x) } else { bellq(2.0 * x - k as f64) + bellq(2.0 * x + k as f64) };
                    pair * bellq(x - n as f64)
                };
                *cell = integrate_cells(&f, -3.0, 4.0, 28, &rule);
            }
        }
        b[0] = 1.0;
        a[3] = [1.0, 0.0, 2.0, 0.0];
        b[3] = 1.0;
        solve4(a, b)
    })
}

/// `∫_lo^hi f` over `cells` equal cells with a Gauss rule on each.
fn integrate_cells(f: &dyn Fn(f64) -> f64, lo: f64, hi: f64, cells: usize, rule: &[(f64, f64)]) -> f64 {
    let w = (hi - lo) / cells as f64;
    (0..cells).map(|i| rule.iter().map(|&(x, wt)| wt * 0.5 * w * f(lo + w * (i as f64 + 0.5 + 0.5 * x))).sum::<f64>()).sum()
}

/// Solves a 4×4 system by Gaussian elimination with partial pivoting (the system above is well
/// conditioned; a singular one would give non-finite coefficients, caught by the tests).
#[allow(clippy::needless_range_loop)] // row operations read one row while writing another
fn solve4(mut a: [[f64; 4]; 4], mut b: [f64; 4]) -> [f64; 4] {
    for col in 0..4 {
        let p = (col..4).max_by(|&i, &j| a[i][col].abs().total_cmp(&a[j][col].abs())).unwrap_or(col);
        a.swap(col, p);
        b.swap(col, p);
        for r in col + 1..4 {
            let f = a[r][col] / a[col][col];
            for c in col..4 {
                a[r][c] -= f * a[col][c];
            }
            b[r] -= f * b[col];
        }
    }
    let mut x = [0.0; 4];
    for r in (0..4).rev() {
        x[r] = (b[r] - (r + 1..4).map(|c| a[r][c] * x[c]).sum::<f64>()) / a[r][r];
    }
    x
}

/// Gauss–Legendre nodes and weights on `[−1, 1]` (Newton on the Legendre recurrence).
pub fn gauss_legendre(n: usize) -> Vec<(f64, f64)> {
    let n = n.max(1);
    (0..n)
        .map(|i| {
            let mut x = (std::f64::consts::PI * (i as f64 + 0.75) / (n as f64 + 0.5)).cos();
            let mut dp = 1.0;
            for _ in 0..100 {
                let (mut p0, mut p1) = (1.0, x);
                for k in 2..=n {
                    let p2 = ((2 * k - 1) as f64 * x * p1 - (k - 1) as f64 * p0) / k as f64;
                    p0 = p1;
                    p1 = p2;
                }
                let p = if n == 1 { x } else { p1 };
                let pm1 = if n == 1 { 1.0 } else { p0 };
                dp = n as f64 * (x * p - pm1) / (x * x - 1.0);
                let dx = p / dp;
                x -= dx;
                if dx.abs() < 1e-15 {
                    break;
                }
            }
            (x, 2.0 / ((1.0 - x * x) * dp * dp))
        })
        .collect()
}

/// The grid of filter positions on the sampling plane, centred on the axis.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct FilterGrid {
    /// Filter positions along `u` and `v` (`M`, `N`).
    pub counts: [usize; 2],
    /// Spacing `h` between positions (metres).
    pub spacing_m: f64,
}

impl FilterGrid {
    /// Number of filter positions `M·N`.
    pub fn len(&self) -> usize {
        self.counts[0] * self.counts[1]
    }

    /// Whether the grid has no positions.
    pub fn is_empty(&self) -> bool {
        self.len() == 0
    }

    /// Index of position `(m, n)` in image order (`n`-major).
    pub fn index(&self, m: usize, n: usize) -> usize {
        n * self.counts[0] + m
    }

    /// Centre `(u_m, v_n)` of position `(m, n)`: `(m − (M−1)/2) h`, `(n − (N−1)/2) h`.
    pub fn centre(&self, m: usize, n: usize) -> DVec2 {
        let h = self.spacing_m;
        DVec2::new((m as f64 - (self.counts[0] as f64 - 1.0) / 2.0) * h, (n as f64 - (self.counts[1] as f64 - 1.0) / 2.0) * h)
    }

    /// `Φ_mn(u, v)` (dimensionless, peak 1).
    pub fn basis(&self, m: usize, n: usize, uv: DVec2) -> f64 {
        let c = self.centre(m, n);
        bellq((uv.x - c.x) / self.spacing_m) * bellq((uv.y - c.y) / self.spacing_m)
    }

    /// The acquisition filter `φ'((u − u_m)/h) φ'((v − v_n)/h)` (dimensionless transmittance).
    pub fn dual(&self, m: usize, n: usize, uv: DVec2) -> f64 {
        let c = self.centre(m, n);
        bellq_dual((uv.x - c.x) / self.spacing_m) * bellq_dual((uv.y - c.y) / self.spacing_m)
    }

    /// Lower and upper corners of the union of the basis supports.
    pub fn support_bounds(&self) -> (DVec2, DVec2) {
        let h = self.spacing_m;
        let hi = DVec2::new((self.counts[0] as f64 - 1.0) / 2.0 * h + h, (self.counts[1] as f64 - 1.0) / 2.0 * h + h);
        (-hi, hi)
    }

    /// The positions whose basis support holds `uv`: index ranges along `u` and `v`.
    pub fn active(&self, uv: DVec2) -> (std::ops::Range<usize>, std::ops::Range<usize>) {
        let range = |x: f64, count: usize| {
            let k = x / self.spacing_m + (count as f64 - 1.0) / 2.0;
            let lo = (k - 1.0).ceil().max(0.0) as usize;
            let hi = ((k + 1.0).floor() + 1.0).clamp(0.0, count as f64) as usize;
            lo.min(hi)..hi
        };
        (range(uv.x, self.counts[0]), range(uv.y, self.counts[1]))
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// Midpoint rule with many cells: an independent check of the Gauss integrals.
    fn midpoint(f: impl Fn(f64) -> f64, lo: f64, hi: f64) -> f64 {
        let n = 200_000;
        let w = (hi - lo) / n as f64;
        (0..n).map(|i| f(lo + w * (i as f64 + 0.5))).sum::<f64>() * w
    }

    #[test]
    fn bellq_is_c1_with_unit_integral_and_partition_of_unity() {
        assert_eq!((bellq(0.0), bellq(0.5), bellq(1.0), bellq(1.5)), (1.0, 0.5, 0.0, 0.0));
        // C¹ at the joint x = ½: both pieces have slope −2
        let e = 1e-7;
        assert!(((bellq(0.5 + e) - bellq(0.5 - e)) / (2.0 * e) + 2.0).abs() < 1e-6);
        // midpoint error O(w²) with w = 1e-5: far below 1e-9
        assert!((midpoint(bellq, -1.0, 1.0) - 1.0).abs() < 1e-9);
        for i in 0..=100 {
            let x = i as f64 / 100.0 * 3.0 - 1.5;
            let sum: f64 = (-4..=4).map(|k| bellq(x - k as f64)).sum();
            assert!((sum - 1.0).abs() < 1e-14, "{x}: {sum}");
        }
    }

    #[test]
    fn dual_is_biorthogonal_compact_and_sums_to_one() {
        let c = dual_coefficients();
        assert!(c.iter().all(|v| v.is_finite()), "{c:?}");
        for n in -3..=3 {
            let g = midpoint(|x| bellq_dual(x) * bellq(x - n as f64), -3.0, 3.0);
            // the midpoint rule's O(w²) error on piecewise polynomials with kinks: < 1e-8
            assert!((g - if n == 0 { 1.0 } else { 0.0 }).abs() < 1e-8, "n = {n}: {g}");
        }
        assert_eq!(bellq_dual(2.0), 0.0);
        assert_eq!(bellq_dual(2.3), 0.0);
        for i in 0..=50 {
            let x = i as f64 / 50.0;
            let sum: f64 = (-4..=4).map(|k| bellq_dual(x - k as f64)).sum();
            assert!((sum - 1.0).abs() < 1e-12, "{x}: {sum}");
        }
        // the filter has negative lobes (why the images need a signed storage format)
        assert!((0..400).any(|i| bellq_dual(i as f64 / 100.0 - 2.0) < 0.0));
    }

    #[test]
    fn gauss_legendre_integrates_polynomials_exactly() {
        for n in 1..=8 {
            let rule = gauss_legendre(n);
            for deg in 0..2 * n {
                let got: f64 = rule.iter().map(|&(x, w)| w * x.powi(deg as i32)).sum();
                let want = if deg % 2 == 1 { 0.0 } else { 2.0 / (deg as f64 + 1.0) };
                assert!((got - want).abs() < 1e-13, "n = {n}, x^{deg}: {got}");
            }
        }
    }

    #[test]
    fn grid_centres_supports_and_active_positions() {
        let g = FilterGrid { counts: [5, 3], spacing_m: 0.01 };
        assert_eq!(g.centre(2, 1), DVec2::ZERO);
        assert!((g.centre(0, 0) - DVec2::new(-0.02, -0.01)).length() < 1e-15);
        let (lo, hi) = g.support_bounds();
        assert!((lo - DVec2::new(-0.03, -0.02)).length() < 1e-15 && (hi + lo).length() < 1e-15);
        // every position with a non-zero basis value is in the active ranges, and the basis sums
        // to one inside the grid's interior
        for &(x, y) in &[(0.0, 0.0), (0.013, -0.004), (-0.0299, 0.0199), (0.02, 0.01)] {
            let uv = DVec2::new(x, y);
            let (ru, rv) = g.active(uv);
            let mut sum = 0.0;
            for n in 0..3 {
                for m in 0..5 {
                    let b = g.basis(m, n, uv);
                    assert!(b == 0.0 || (ru.contains(&m) && rv.contains(&n)), "{uv} {m} {n}");
                    sum += b;
                }
            }
            if x.abs() <= 0.02 && y.abs() <= 0.01 {
                assert!((sum - 1.0).abs() < 1e-12);
            }
        }
    }
}
