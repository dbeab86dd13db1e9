//! How well the sky basis can be fitted: condition numbers of the design whose columns are the
//! shapes' irradiances on the estimator's samples.
//!
//! # How it works
//! For samples `i` (a normal and a visibility) and shapes `k`, the design is
//! `C_ik = E_k(n_i, V_i)` ([`super::quadrature::irradiance`]), optionally with the sun's column
//! `s_i·max(n_i·l, 0)`. With unit-norm columns the Gram matrix `G = CᵀC` has ones on the
//! diagonal and the shapes' cosine similarities off it; its condition number `λ_max/λ_min`
//! (cyclic Jacobi eigenvalues) bounds how much a relative model error can move the fitted
//! weights, and `√(λ_max/λ_min)` is the condition of the design itself, the quantity heliar's
//! estimator reports and caps (`max_condition = 12`, `estimate::solve`).
//!
//! # Measured (`cargo test --lib sky::conditioning -- --nocapture` prints every combination)
//! Sample sets from infinite walls (`tests.rs`): *ground* is 12 horizontal points beside a wall
//! to the N, E, S or W at distance/height 0.5, 1, 2; *walls* is vertical walls facing N, E, S, W,
//! open and with an opposite building (distance/height 2); *mixed* is both (20 samples). Sun
//! azimuth 150°. Shapes: U uniform, C circumsolar (width), H horizon 12°, P Preetham T = 3.
//! Design condition (√ of the unit-column Gram's), on the mixed set, sky shapes alone / with the
//! sun's column:
//!
//! | basis | 60° | 45° | 30° | 20° | 15° | 8° | 3° |
//! |---|---|---|---|---|---|---|---|
//! | U | 1 / 6.4 | 1 / 4.2 | 1 / 3.0 | 1 / 2.0 | 1 / 2.0 | 1 / 1.6 | 1 / 1.4 |
//! | U+C25 | 6.8 / 17.4 | 5.4 / 13.3 | 3.8 / 14.7 | 3.0 / 10.0 | 2.8 / 6.5 | 2.4 / 5.9 | 2.3 / 5.6 |
//! | U+C15 | 6.4 / 17.7 | 4.9 / 14.1 | 3.2 / 20.0 | 2.5 / 10.8 | 2.2 / 6.8 | 1.9 / 7.1 | 1.8 / 7.9 |
//! | U+C40 | 8.3 / 18.5 | 6.8 / 14.1 | 5.2 / 13.8 | 4.3 / 10.7 | 4.0 / 7.6 | 3.6 / 6.5 | 3.4 / 5.9 |
//! | U+H12 | 3.4 / 13.2 | 3.4 / 6.0 | 3.4 / 4.3 | 3.4 / 3.9 | 3.4 / 4.1 | 3.4 / 4.4 | 3.4 / 4.7 |
//! | U+C25+H12 | 12.7 / 19.5 | 7.5 / 15.1 | 4.9 / 16.6 | 4.2 / 11.6 | 4.1 / 7.9 | 4.1 / 8.0 | 4.2 / 8.1 |
//! | U+P3 | 20.7 / 29.3 | 14.2 / 25.8 | 10.8 / 28.4 | 9.8 / 28.0 | 9.6 / 22.2 | 9.6 / 22.7 | 9.9 / 22.9 |
//! | U+C25+H12+P3 | 84 / 101 | 104 / 121 | 130 / 163 | 181 / 198 | 211 / 230 | 205 / 235 | 160 / 210 |
//!
//! The ground set alone gives 67–113 for any basis with H (and 16–26 with C alone): occlusion by
//! walls separates the shapes only a little. The walls set alone gives 6–8 for U+C25+H12 without
//! the sun, 9–58 with it (worst for a high sun, where walls see the circumsolar sky and the sun
//! alike). The recommendation drawn from these numbers is in [`super::basis`] ("Conditioning and
//! the recommended basis"); an estimator should still check the condition on its own samples
//! with [`conditioning`] and drop the circumsolar, then the horizon shape, above its cap.

/// Condition numbers of one design (module docs).
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Conditioning {
    /// `λ_max/λ_min` of the Gram matrix of unit-norm columns (∞ when singular).
    pub gram: f64,
    /// `√gram`: the design's condition, as the estimator reports it.
    pub design: f64,
    /// `λ_max/λ_min` of the Gram matrix of the raw columns (shapes normalised to unit
    /// horizontal irradiance, so the scales are comparable).
    pub gram_raw: f64,
}

/// Sweeps of the cyclic Jacobi method (a K ≤ 8 matrix converges in 5–6).
const JACOBI_SWEEPS: usize = 30;
/// Off-diagonal magnitude relative to the diagonal at which Jacobi stops.
const JACOBI_TOLERANCE: f64 = 1e-15;

/// Eigenvalues of the symmetric matrix `a` (row-major `k × k`), ascending, by cyclic Jacobi
/// rotations (Golub & Van Loan, *Matrix Computations*, "Jacobi Methods" in ch. 8).
pub fn symmetric_eigenvalues(mut a: Vec<Vec<f64>>) -> Vec<f64> {
    let k = a.len();
    for _ in 0..JACOBI_SWEEPS {
        let off: f64 = (0..k).flat_map(|i| (0..k).filter(move |&j| j != i).map(move |j| (i, j))).map(|(i, j)| a[i][j] * a[i][j]).sum();
        let diag: f64 = (0..k).map(|i| a[i][i] * a[i][i]).sum();
        if off <= JACOBI_TOLERANCE * JACOBI_TOLERANCE * diag.max(f64::MIN_POSITIVE) {
            break;
        }
        for p in 0..k {
            for q in p + 1..k {
                if a[p][q] == 0.0 {
                    continue;
                }
                let theta = (a[q][q] - a[p][p]) / (2.0 * a[p][q]);
                let t = theta.signum() / (theta.abs() + (theta * theta + 1.0).sqrt());
                let t = if theta == 0.0 { 1.0 } else { t };
                let (c, s) = (1.0 / (t * t + 1.0).sqrt(), t / (t * t + 1.0).sqrt());
                // A ← A·J (columns p, q), then A ← Jᵀ·A (rows p, q).
                for row in a.iter_mut() {
                    let (arp, arq) = (row[p], row[q]);
                    row[p] = c * arp - s * arq;
                    row[q] = s * arp + c * arq;
                }
                let (head, tail) = a.split_at_mut(q);
                for (apr, aqr) in head[p].iter_mut().zip(tail[0].iter_mut()) {
                    let (x, y) = (*apr, *aqr);
                    *apr = c * x - s * y;
                    *aqr = s * x + c * y;
                }
            }
        }
    }
    let mut ev: Vec<f64> = (0..k).map(|i| a[i][i]).collect();
    ev.sort_by(f64::total_cmp);
    ev
}

fn ratio(ev: &[f64]) -> f64 {
    match (ev.first(), ev.last()) {
        (Some(&lo), Some(&hi)) if lo > 0.0 && hi.is_finite() => hi / lo,
        _ => f64::INFINITY,
    }
}

/// Condition numbers of the design `rows[i][k]` (module docs). A zero column makes it singular.
pub fn conditioning(rows: &[Vec<f64>]) -> Conditioning {
    let k = rows.first().map_or(0, Vec::len);
    let gram_of = |scale: &[f64]| -> Vec<Vec<f64>> {
        (0..k).map(|a| (0..k).map(|b| rows.iter().map(|r| r[a] * scale[a] * r[b] * scale[b]).sum()).collect()).collect()
    };
    let norms: Vec<f64> = (0..k).map(|a| rows.iter().map(|r| r[a] * r[a]).sum::<f64>().sqrt()).collect();
    let gram_raw = ratio(&symmetric_eigenvalues(gram_of(&vec![1.0; k])));
    if norms.iter().any(|n| n.is_nan() || *n <= 0.0) {
        return Conditioning { gram: f64::INFINITY, design: f64::INFINITY, gram_raw };
    }
    let inv: Vec<f64> = norms.iter().map(|n| 1.0 / n).collect();
    let gram = ratio(&symmetric_eigenvalues(gram_of(&inv)));
    Conditioning { gram, design: gram.sqrt(), gram_raw }
}

#[cfg(test)]
mod tests;
