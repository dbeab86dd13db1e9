//! The Preetham–Shirley–Smits daylight model: "A practical analytic model for daylight"
//! (SIGGRAPH 1999), the sky part (§3.2 "Skylight Model" and Appendix A.2).
//!
//! # How it works
//! The sky's luminance `Y` and chromaticity `x`, `y` each follow the Perez et al. (1993)
//! all-weather distribution
//!
//! `F(θ, γ) = (1 + A·e^{B/cos θ}) · (1 + C·e^{D·γ} + E·cos²γ)`
//!
//! of the view's zenith angle `θ` and its angle `γ` to the sun, scaled so that the zenith takes
//! its measured value: `Y(θ, γ) = Y_z · F(θ, γ) / F(0, θ_s)`, the same for `x` and `y`. The
//! five coefficients of each channel are linear in the turbidity `T` (Appendix A.2, the table of
//! "distribution coefficients"). The zenith luminance (kcd/m²) is
//! `Y_z = (4.0453 T − 4.9710) tan χ − 0.2155 T + 2.4192` with `χ = (4/9 − T/120)(π − 2θ_s)`, and the
//! zenith chromaticities are cubic in `θ_s` and quadratic in `T` (Appendix A.2). The chromaticity
//! goes to CIE XYZ (`X = xY/y`, `Z = (1 − x − y)Y/y`) and then to linear Rec.709 / sRGB primaries,
//! D65 white (IEC 61966-2-1 matrix).
//!
//! Validity: the fits were made for clear to hazy skies; this implementation accepts
//! [`TURBIDITY_MIN`] ≤ T ≤ [`TURBIDITY_MAX`]. Below about T = 1.2 the coefficient `B` of `Y` turns
//! positive and `e^{B/cos θ}` diverges at the horizon; at larger `T` the zenith luminance of a sun
//! on the horizon turns negative (T > 11.2). The sun below the horizon is handled as the
//! [module](super) says (lifted onto it). The paper prints −0.03202 for the third entry of the
//! middle row of the `x_z` matrix; some codes use −0.03203; the paper's value is used here.

use super::{ShapeSun, SkyError, sky_angles};
use glam::Vec3;
use std::f64::consts::PI;

/// Smallest turbidity accepted (see the module docs).
pub const TURBIDITY_MIN: f64 = 2.0;
/// Largest turbidity accepted (see the module docs).
pub const TURBIDITY_MAX: f64 = 10.0;

/// The view's `cos θ` is clamped to at least this in the Perez `e^{B/cos θ}` term, so the
/// horizon itself (`cos θ = 0`) gives the term's limit 0 without a division by zero.
const MIN_COS_THETA: f64 = 1e-6;

/// Coefficients `(A, B, C, D, E)` of one Perez distribution.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Perez {
    /// Horizon darkening or brightening.
    pub a: f64,
    /// Its gradient.
    pub b: f64,
    /// Circumsolar intensity.
    pub c: f64,
    /// Circumsolar width (negative).
    pub d: f64,
    /// Back-scattered light.
    pub e: f64,
}

impl Perez {
    /// The Perez `F(θ, γ)` (Preetham §3.2), from `cos θ` (clamped to the horizon) and `γ` in radians.
    pub fn eval(&self, cos_theta: f64, gamma: f64) -> f64 {
        let ct = cos_theta.max(MIN_COS_THETA);
        let cg = gamma.cos();
        (1.0 + self.a * (self.b / ct).exp()) * (1.0 + self.c * (self.d * gamma).exp() + self.e * cg * cg)
    }

    /// Coefficients linear in turbidity: `rows[k] = (slope, intercept)` of A, B, C, D, E.
    fn linear_in_turbidity(rows: [(f64, f64); 5], t: f64) -> Self {
        let f = |k: usize| rows[k].0 * t + rows[k].1;
        Self { a: f(0), b: f(1), c: f(2), d: f(3), e: f(4) }
    }
}

/// Distribution coefficients of the luminance `Y`, `(slope, intercept)` in `T` (Appendix A.2).
const PEREZ_Y: [(f64, f64); 5] = [(0.1787, -1.4630), (-0.3554, 0.4275), (-0.0227, 5.3251), (0.1206, -2.5771), (-0.0670, 0.3703)];
/// Distribution coefficients of the chromaticity `x` (Appendix A.2).
const PEREZ_X: [(f64, f64); 5] = [(-0.0193, -0.2592), (-0.0665, 0.0008), (-0.0004, 0.2125), (-0.0641, -0.8989), (-0.0033, 0.0452)];
/// Distribution coefficients of the chromaticity `y` (Appendix A.2).
const PEREZ_YC: [(f64, f64); 5] = [(-0.0167, -0.2608), (-0.0950, 0.0092), (-0.0079, 0.2102), (-0.0441, -1.6537), (-0.0109, 0.0529)];

/// Zenith chromaticity `x_z = [T², T, 1] · M · [θ_s³, θ_s², θ_s, 1]ᵀ` (Appendix A.2).
const ZENITH_X: [[f64; 4]; 3] = [[0.00166, -0.00375, 0.00209, 0.0], [-0.02903, 0.06377, -0.03202, 0.00394], [0.11693, -0.21196, 0.06052, 0.25886]];
/// Zenith chromaticity `y_z` (Appendix A.2).
const ZENITH_Y: [[f64; 4]; 3] = [[0.00275, -0.00610, 0.00317, 0.0], [-0.04214, 0.08970, -0.04153, 0.00516], [0.15346, -0.26756, 0.06670, 0.26688]];

/// CIE XYZ → linear Rec.709 (sRGB primaries, D65), IEC 61966-2-1.
const REC709_FROM_XYZ: [[f64; 3]; 3] = [[3.2404542, -1.5371385, -0.4985314], [-0.9692660, 1.8760108, 0.0415560], [0.0556434, -0.2040259, 1.0572252]];

/// Zenith luminance `Y_z` in kcd/m² for turbidity `t` and solar zenith angle `theta_s` (radians).
pub fn zenith_luminance_kcd(t: f64, theta_s: f64) -> f64 {
    let chi = (4.0 / 9.0 - t / 120.0) * (PI - 2.0 * theta_s);
    (4.0453 * t - 4.9710) * chi.tan() - 0.2155 * t + 2.4192
}

/// Zenith chromaticity `(x_z, y_z)` for turbidity `t` and solar zenith angle `theta_s` (radians).
pub fn zenith_chromaticity(t: f64, theta_s: f64) -> (f64, f64) {
    let th = [theta_s.powi(3), theta_s * theta_s, theta_s, 1.0];
    let tv = [t * t, t, 1.0];
    let form = |m: &[[f64; 4]; 3]| (0..3).map(|r| tv[r] * (0..4).map(|c| m[r][c] * th[c]).sum::<f64>()).sum::<f64>();
    (form(&ZENITH_X), form(&ZENITH_Y))
}

/// Linear Rec.709 RGB of chromaticity `(x, y)` and luminance `big_y` (same unit as `big_y`);
/// zero for `y ≤ 0`.
pub fn rec709_from_xyy(x: f64, y: f64, big_y: f64) -> [f64; 3] {
    if y <= 0.0 {
        return [0.0; 3];
    }
    let xyz = [x * big_y / y, big_y, (1.0 - x - y) * big_y / y];
    REC709_FROM_XYZ.map(|row| row[0] * xyz[0] + row[1] * xyz[1] + row[2] * xyz[2])
}

/// A Preetham sky for one sun position and turbidity.
#[derive(Clone, Debug, PartialEq)]
pub struct PreethamSky {
    turbidity: f64,
    sun: ShapeSun,
    /// Perez coefficients of `Y`, `x`, `y`.
    perez: [Perez; 3],
    /// Zenith values `Y_z` (kcd/m²), `x_z`, `y_z` divided by `F(0, θ_s)` of their channel.
    zenith_over_f0: [f64; 3],
}

impl PreethamSky {
    /// The sky of sun direction `sun_dir_world` (world frame, toward the sun; a sun below the
    /// horizon is lifted onto it) and `turbidity` in [[`TURBIDITY_MIN`], [`TURBIDITY_MAX`]].
    pub fn new(sun_dir_world: Vec3, turbidity: f64) -> Result<Self, SkyError> {
        if !(TURBIDITY_MIN..=TURBIDITY_MAX).contains(&turbidity) {
            return Err(SkyError::Turbidity { model: "preetham", value: turbidity, min: TURBIDITY_MIN, max: TURBIDITY_MAX });
        }
        let sun = ShapeSun::from_dir(sun_dir_world)?;
        let t = turbidity;
        let perez = [PEREZ_Y, PEREZ_X, PEREZ_YC].map(|rows| Perez::linear_in_turbidity(rows, t));
        let theta_s = sun.zenith_rad();
        let (xz, yz) = zenith_chromaticity(t, theta_s);
        let zenith = [zenith_luminance_kcd(t, theta_s), xz, yz];
        // The zenith direction sees the sun at γ = θ_s.
        let zenith_over_f0 = std::array::from_fn(|k| zenith[k] / perez[k].eval(1.0, theta_s));
        Ok(Self { turbidity, sun, perez, zenith_over_f0 })
    }

    /// The turbidity.
    pub fn turbidity(&self) -> f64 {
        self.turbidity
    }

    /// The sun the shape uses (lifted onto the horizon when it was below).
    pub fn sun(&self) -> ShapeSun {
        self.sun
    }

    /// `(x, y, Y)` of view direction `dir` (`Y` in kcd/m²), or `None` below the horizon or for an
    /// invalid direction.
    pub fn xyy(&self, dir: Vec3) -> Option<[f64; 3]> {
        let (mu, gamma) = sky_angles(dir, self.sun.dir)?;
        let v: [f64; 3] = std::array::from_fn(|k| self.zenith_over_f0[k] * self.perez[k].eval(mu, gamma));
        Some([v[1], v[2], v[0]])
    }

    /// Luminance in kcd/m² along `dir`; 0 below the horizon or for an invalid direction.
    pub fn luminance_kcd(&self, dir: Vec3) -> f64 {
        self.xyy(dir).map_or(0.0, |v| v[2])
    }

    /// Linear Rec.709 radiance along `dir` (luminance unit kcd/m²: `Y` of the result is
    /// [`Self::luminance_kcd`]); 0 below the horizon or for an invalid direction.
    pub fn radiance_rgb(&self, dir: Vec3) -> [f32; 3] {
        self.xyy(dir).map_or([0.0; 3], |[x, y, l]| rec709_from_xyy(x, y, l).map(|c| c as f32))
    }

    /// Zenith luminance `Y_z` in kcd/m² (Preetham Appendix A.2).
    pub fn zenith_luminance_kcd(&self) -> f64 {
        zenith_luminance_kcd(self.turbidity, self.sun.zenith_rad())
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::geometry::sampling::sphere_fibonacci;

    fn sun_at(elevation_deg: f32, azimuth_deg: f32) -> Vec3 {
        let (e, a) = (elevation_deg.to_radians(), azimuth_deg.to_radians());
        Vec3::new(e.cos() * a.sin(), e.sin(), -e.cos() * a.cos())
    }

    #[test]
    fn zenith_takes_the_zenith_formulas() {
        for (elev, t) in [(60.0, 2.0), (30.0, 3.0), (5.0, 6.5), (0.0, 10.0)] {
            let sky = PreethamSky::new(sun_at(elev, 140.0), t).unwrap();
            let [x, y, l] = sky.xyy(Vec3::Y).unwrap();
            let theta_s = (90.0f64 - elev as f64).to_radians();
            let (xz, yz) = zenith_chromaticity(t, theta_s);
            // The sun direction is f32: θ_s carries ~1e-7 rad of rounding.
            let tol = 1e-5;
            assert!((l - zenith_luminance_kcd(t, theta_s)).abs() < tol * l, "{elev} {t}: {l}");
            assert!((x - xz).abs() < tol && (y - yz).abs() < tol, "{x} {y} vs {xz} {yz}");
        }
    }

    #[test]
    fn known_zenith_values() {
        // Y_z by hand: T = 2, θ_s = 0: χ = (4/9 − 1/60)·π = 1.343904, tan χ = 4.331476;
        // Y_z = 3.1196·4.331476 − 0.431 + 2.4192 = 15.50067.
        assert!((zenith_luminance_kcd(2.0, 0.0) - 15.50067).abs() < 1e-4);
        // x_z at θ_s = 0 is the constant column: 0.00394·T + 0.25886 (+0·T²).
        let (xz, yz) = zenith_chromaticity(3.0, 0.0);
        assert!((xz - (0.00394 * 3.0 + 0.25886)).abs() < 1e-12 && (yz - (0.00516 * 3.0 + 0.26688)).abs() < 1e-12);
    }

    #[test]
    fn symmetric_about_the_sun_vertical_plane() {
        let sun = sun_at(25.0, 100.0);
        let sky = PreethamSky::new(sun, 3.0).unwrap();
        // Mirror across the vertical plane through the sun: reflect the horizontal part.
        let h = Vec3::new(sun.x, 0.0, sun.z).normalize();
        for d in sphere_fibonacci(300).into_iter().filter(|d| d.y > 0.0) {
            let dh = Vec3::new(d.x, 0.0, d.z);
            let mirrored = 2.0 * dh.dot(h) * h - dh + Vec3::Y * d.y;
            let (a, b) = (sky.luminance_kcd(d), sky.luminance_kcd(mirrored));
            assert!((a - b).abs() < 1e-5 * a.abs().max(1.0), "{d}: {a} vs {b}");
        }
    }

    #[test]
    fn brightest_near_the_sun_when_clear() {
        for elev in [15.0, 40.0, 70.0] {
            let sun = sun_at(elev, 200.0);
            let sky = PreethamSky::new(sun, 2.5).unwrap();
            let dirs: Vec<Vec3> = sphere_fibonacci(20_000).into_iter().filter(|d| d.y > 0.0).collect();
            let best = dirs.iter().copied().max_by(|a, b| sky.luminance_kcd(*a).total_cmp(&sky.luminance_kcd(*b))).unwrap();
            // Lattice spacing ≈ √(4π/20000) rad ≈ 1.4°: the maximum lies within a few of them.
            let gamma_deg = best.dot(sun).clamp(-1.0, 1.0).acos().to_degrees();
            assert!(gamma_deg < 5.0, "elevation {elev}: maximum {gamma_deg}° from the sun");
            // And a clear sky's brightest part is several times its darkest.
            let darkest = dirs.iter().map(|d| sky.luminance_kcd(*d)).fold(f64::MAX, f64::min);
            assert!(sky.luminance_kcd(best) > 3.0 * darkest, "{} vs {darkest}", sky.luminance_kcd(best));
        }
    }

    #[test]
    fn positive_and_finite_over_the_valid_range() {
        let dirs: Vec<Vec3> = sphere_fibonacci(2000).into_iter().filter(|d| d.y >= 0.0).chain([Vec3::X, Vec3::Z]).collect();
        for t in [TURBIDITY_MIN, 4.0, 7.0, TURBIDITY_MAX] {
            for elev in [0.0, 0.5, 10.0, 45.0, 89.9, 90.0] {
                let sky = PreethamSky::new(sun_at(elev, 30.0), t).unwrap();
                for &d in &dirs {
                    let [x, y, l] = sky.xyy(d).unwrap();
                    assert!(l.is_finite() && l > 0.0, "T {t} elev {elev} {d}: Y = {l}");
                    assert!(x > 0.0 && y > 0.0 && x + y < 1.0, "chromaticity {x} {y}");
                }
            }
        }
    }

    #[test]
    fn white_point_and_rgb_luminance() {
        // D65 (x, y) = (0.3127, 0.3290) is RGB (1, 1, 1)·Y to the matrix's 4 decimals.
        let rgb = rec709_from_xyy(0.3127, 0.3290, 1.0);
        assert!(rgb.iter().all(|c| (c - 1.0).abs() < 2e-3), "{rgb:?}");
        // The sky's RGB has the luminance Y: 0.2126 R + 0.7152 G + 0.0722 B (Rec.709).
        let sky = PreethamSky::new(sun_at(35.0, 0.0), 3.0).unwrap();
        let d = Vec3::new(0.3, 0.6, 0.5);
        let c = sky.radiance_rgb(d);
        let y = 0.2126 * c[0] as f64 + 0.7152 * c[1] as f64 + 0.0722 * c[2] as f64;
        assert!((y - sky.luminance_kcd(d)).abs() < 1e-3 * y, "{y} vs {}", sky.luminance_kcd(d));
        // A clear sky away from the sun is blue.
        let away = sky.radiance_rgb(Vec3::new(0.0, 0.5, 1.0));
        assert!(away[2] > away[1] && away[1] > away[0], "{away:?}");
    }

    #[test]
    fn out_of_range_and_invalid_inputs() {
        for t in [1.9, 10.1, f64::NAN, f64::INFINITY] {
            assert!(matches!(PreethamSky::new(Vec3::Y, t), Err(SkyError::Turbidity { .. })), "{t}");
        }
        assert!(matches!(PreethamSky::new(Vec3::ZERO, 3.0), Err(SkyError::BadDirection { .. })));
        let sky = PreethamSky::new(Vec3::Y, 3.0).unwrap();
        assert_eq!(sky.radiance_rgb(Vec3::new(f32::NAN, 1.0, 0.0)), [0.0; 3]);
        assert_eq!(sky.radiance_rgb(Vec3::ZERO), [0.0; 3]);
        assert_eq!(sky.radiance_rgb(Vec3::NEG_Y), [0.0; 3]);
    }

    #[test]
    fn sun_below_the_horizon_gives_the_horizon_sun_sky() {
        let below = PreethamSky::new(sun_at(-8.0, 250.0), 3.0).unwrap();
        let on = PreethamSky::new(sun_at(0.0, 250.0), 3.0).unwrap();
        assert!(below.sun().below_horizon && !on.sun().below_horizon);
        for d in [Vec3::Y, Vec3::new(0.2, 0.1, 0.9), sun_at(3.0, 250.0)] {
            let (a, b) = (below.luminance_kcd(d), on.luminance_kcd(d));
            assert!((a - b).abs() < 1e-5 * b, "{d}: {a} vs {b}");
        }
    }
}
