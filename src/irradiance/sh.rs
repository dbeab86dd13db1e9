//! Real spherical harmonics of order 2 (9 coefficients), projection and irradiance.
//!
//! Basis (Sloan, "Stupid Spherical Harmonics Tricks", with the world axes x, y, z of the unit
//! direction), in this order:
//! `Y00 = 0.282095`, `Y1-1 = 0.488603·y`, `Y10 = 0.488603·z`, `Y11 = 0.488603·x`,
//! `Y2-2 = 1.092548·xy`, `Y2-1 = 1.092548·yz`, `Y20 = 0.315392·(3z² − 1)`, `Y21 = 1.092548·xz`,
//! `Y22 = 0.546274·(x² − y²)`.
//!
//! Irradiance from radiance coefficients `L_lm` is `E(n) = Σ Â_l·L_lm·Y_lm(n)` with the clamped
//! cosine's zonal coefficients `Â₀ = π`, `Â₁ = 2π/3`, `Â₂ = π/4` (Ramamoorthi & Hanrahan 2001, "An
//! Efficient Representation for Irradiance Environment Maps").

use glam::Vec3;
use std::f32::consts::PI;

/// Number of coefficients.
pub const N: usize = 9;

/// The cosine-lobe convolution factor of each coefficient (`Â_l` by band).
pub const COSINE_LOBE: [f32; N] = [PI, 2.0 * PI / 3.0, 2.0 * PI / 3.0, 2.0 * PI / 3.0, PI / 4.0, PI / 4.0, PI / 4.0, PI / 4.0, PI / 4.0];

/// The 9 basis functions at unit direction `d`.
#[inline]
pub fn basis(d: Vec3) -> [f32; N] {
    let (x, y, z) = (d.x, d.y, d.z);
    [
        0.282_095,
        0.488_603 * y,
        0.488_603 * z,
        0.488_603 * x,
        1.092_548 * x * y,
        1.092_548 * y * z,
        0.315_392 * (3.0 * z * z - 1.0),
        1.092_548 * x * z,
        0.546_274 * (x * x - y * y),
    ]
}

/// RGB coefficients.
pub type ShRgb = [[f32; 3]; N];

/// Evaluates `Σ c_lm·Y_lm(d)` per channel.
#[inline]
pub fn eval(c: &ShRgb, d: Vec3) -> Vec3 {
    let y = basis(d);
    let mut out = Vec3::ZERO;
    for k in 0..N {
        out += Vec3::from(c[k]) * y[k];
    }
    out
}

/// Radiance coefficients → irradiance coefficients (multiplies by `Â_l`).
pub fn irradiance_from_radiance(l: &ShRgb) -> ShRgb {
    std::array::from_fn(|k| l[k].map(|v| v * COSINE_LOBE[k]))
}

/// Irradiance of a uniform sky of horizontal irradiance `pa` over the upper hemisphere (no
/// light below the horizon), as irradiance SH coefficients. Closed form:
/// `E(n) = pa·(1 + n_y)/2`, which lies in bands 0 and 1 exactly.
pub fn uniform_upper_sky(pa: Vec3) -> ShRgb {
    let mut c = [[0.0; 3]; N];
    // (1 + y)/2 = ½·Y00/0.282095 + ½·Y1-1/0.488603
    c[0] = (pa * (0.5 / 0.282_095)).to_array();
    c[1] = (pa * (0.5 / 0.488_603)).to_array();
    c
}

#[cfg(test)]
mod tests {
    use super::*;

    /// Uniform sphere directions on a fine stratified grid (z = 1 − 2u, φ = 2πv).
    fn sphere_grid(n: usize) -> impl Iterator<Item = Vec3> {
        (0..n * n).map(move |k| {
            let (i, j) = (k % n, k / n);
            let z = 1.0 - 2.0 * (i as f32 + 0.5) / n as f32;
            let phi = 2.0 * PI * (j as f32 + 0.5) / n as f32;
            let r = (1.0 - z * z).max(0.0).sqrt();
            Vec3::new(r * phi.cos(), r * phi.sin(), z)
        })
    }

    #[test]
    fn basis_is_orthonormal() {
        let n = 200;
        let w = 4.0 * PI / (n * n) as f32;
        let mut g = [[0.0f64; N]; N];
        for d in sphere_grid(n) {
            let y = basis(d);
            for a in 0..N {
                for b in 0..N {
                    g[a][b] += (y[a] * y[b] * w) as f64;
                }
            }
        }
        for a in 0..N {
            for b in 0..N {
                let want = if a == b { 1.0 } else { 0.0 };
                assert!((g[a][b] - want).abs() < 2e-3, "<Y{a},Y{b}> = {}", g[a][b]);
            }
        }
    }

    #[test]
    fn constant_radiance_gives_pi_times_radiance_everywhere() {
        // A constant radiance L over the sphere gives the irradiance E = π·L for every normal.
        let n = 200;
        let w = 4.0 * PI / (n * n) as f32;
        let mut l = [[0.0f32; 3]; N];
        for d in sphere_grid(n) {
            let y = basis(d);
            for k in 0..N {
                l[k][0] += y[k] * w; // radiance 1
            }
        }
        let e = irradiance_from_radiance(&l);
        for d in [Vec3::Y, Vec3::X, Vec3::new(0.3, -0.5, 0.81).normalize()] {
            assert!((eval(&e, d).x - PI).abs() < 1e-2, "{}", eval(&e, d).x);
        }
    }

    #[test]
    fn uniform_upper_sky_closed_form() {
        let pa = Vec3::new(0.6, 0.7, 0.9);
        let c = uniform_upper_sky(pa);
        assert!((eval(&c, Vec3::Y) - pa).abs().max_element() < 1e-5);
        assert!((eval(&c, Vec3::X) - pa * 0.5).abs().max_element() < 1e-5);
        assert!(eval(&c, Vec3::NEG_Y).abs().max_element() < 1e-5);
        // The same from projecting the radiance Pa/π on the upper hemisphere and convolving:
        // band-2 terms of the hemisphere step are small but non-zero; irradiance agrees within 3%.
        let n = 256;
        let w = 4.0 * PI / (n * n) as f32;
        let mut l = [[0.0f32; 3]; N];
        for d in sphere_grid(n) {
            if d.y > 0.0 {
                let y = basis(d);
                for k in 0..N {
                    for ch in 0..3 {
                        l[k][ch] += y[k] * w * pa[ch] / PI;
                    }
                }
            }
        }
        let e = irradiance_from_radiance(&l);
        for d in [Vec3::Y, Vec3::X, Vec3::new(0.5, 0.5, 0.7).normalize()] {
            let want = pa * (1.0 + d.y) / 2.0;
            assert!(((eval(&e, d) - want) / pa).abs().max_element() < 0.03, "{d}: {} vs {want}", eval(&e, d));
        }
    }
}
