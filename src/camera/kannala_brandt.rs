//! The Kannala–Brandt generic fisheye lens (Kannala & Brandt 2004/2006, the paper's [KB04],
//! cited in Havran §5.1), the lens of the VEM capture camera.
//!
//! # Model
//! In the camera frame (OpenCV: `+X` right, `+Y` down, `+Z` along the optical axis) a direction
//! `(x, y, z)` at angle `θ = atan2(√(x²+y²), z)` from the axis and azimuth `ψ = atan2(y, x)`
//! lands at
//!
//! ```text
//! θ_d = θ · (1 + k1·θ² + k2·θ⁴ + k3·θ⁶ + k4·θ⁸)
//! u = fx · θ_d · cos ψ + cx,   v = fy · θ_d · sin ψ + cy
//! ```
//!
//! the same polynomial as OpenCV's `cv::fisheye` (which writes it with `θ = atan(r)` and so stops
//! at 90°); here `θ` comes from the 3D direction, so lenses wider than 180° work. `k = 0` is the
//! equidistant fisheye. Directions beyond `max_theta` are outside the calibrated field of view.
//! [`KannalaBrandt::unproject`] inverts `θ_d(θ)` by Newton's method; [`KannalaBrandt::validate`]
//! checks that `θ_d` is strictly increasing up to `max_theta`, so the inverse is unique.

use super::Intrinsics;
use glam::{DVec2, DVec3};

/// Newton tolerance on `θ_d`, radians.
const NEWTON_TOL: f64 = 1e-12;
/// Newton iterations allowed.
const NEWTON_MAX_ITERS: usize = 30;
/// Steps of the monotonicity check over `[0, max_theta]`.
const MONOTONE_STEPS: usize = 2000;

/// Kannala–Brandt coefficients and the calibrated field of view.
#[derive(Clone, Debug, PartialEq)]
pub struct KannalaBrandt {
    /// `k1 … k4`.
    pub k: [f64; 4],
    /// Largest angle from the optical axis the calibration covers, radians.
    pub max_theta: f64,
}

impl KannalaBrandt {
    /// `θ_d(θ)` and its derivative.
    #[inline]
    pub fn distort_theta(&self, theta: f64) -> (f64, f64) {
        let [k1, k2, k3, k4] = self.k;
        let t2 = theta * theta;
        let poly = 1.0 + t2 * (k1 + t2 * (k2 + t2 * (k3 + t2 * k4)));
        let dpoly = 1.0 + t2 * (3.0 * k1 + t2 * (5.0 * k2 + t2 * (7.0 * k3 + t2 * 9.0 * k4)));
        (theta * poly, dpoly)
    }

    /// The `θ` with `θ_d(θ) = theta_d` in `[0, max_theta]`, or `None`.
    pub fn undistort_theta(&self, theta_d: f64) -> Option<f64> {
        if !(theta_d >= 0.0) {
            return None;
        }
        let mut t = theta_d.min(self.max_theta);
        for _ in 0..NEWTON_MAX_ITERS {
            let (f, df) = self.distort_theta(t);
            let r = f - theta_d;
            if r.abs() < NEWTON_TOL {
                break;
            }
            if !(df > 0.0) {
                return None;
            }
            t = (t - r / df).clamp(0.0, self.max_theta * 1.05);
        }
        let (f, _) = self.distort_theta(t);
        ((f - theta_d).abs() < 1e-9 && t <= self.max_theta + 1e-9).then_some(t)
    }

    /// Pixel coordinates (through `k`'s focal lengths and principal point) of a camera-frame
    /// direction; `None` beyond `max_theta`.
    pub fn pixel_from_dir(&self, k: &Intrinsics, d: DVec3) -> Option<DVec2> {
        let rxy = (d.x * d.x + d.y * d.y).sqrt();
        let theta = rxy.atan2(d.z);
        if !(theta <= self.max_theta) {
            return None;
        }
        if rxy < 1e-15 {
            return Some(DVec2::new(k.cx, k.cy));
        }
        let (td, _) = self.distort_theta(theta);
        Some(DVec2::new(k.fx * td * d.x / rxy + k.cx, k.fy * td * d.y / rxy + k.cy))
    }

    /// Unit camera-frame direction of the distorted normalised point `m = ((u − cx)/fx,
    /// (v − cy)/fy)`; `None` outside the calibrated field of view.
    pub fn unproject(&self, m: DVec2) -> Option<DVec3> {
        let td = m.length();
        if td < 1e-15 {
            return Some(DVec3::Z);
        }
        let t = self.undistort_theta(td)?;
        let (s, c) = t.sin_cos();
        Some(DVec3::new(s * m.x / td, s * m.y / td, c))
    }

    /// Checks the coefficients and that `θ_d` increases up to `max_theta`; `Err((field,
    /// message))`.
    pub fn validate(&self) -> Result<(), (&'static str, String)> {
        if self.k.iter().any(|k| !k.is_finite()) {
            return Err(("k", "coefficients must be finite".into()));
        }
        if !(self.max_theta > 0.0 && self.max_theta <= std::f64::consts::PI) {
            return Err(("max_theta_deg", "must be in (0, 180]".into()));
        }
        let mut last = 0.0;
        for i in 1..=MONOTONE_STEPS {
            let t = self.max_theta * i as f64 / MONOTONE_STEPS as f64;
            let (td, d) = self.distort_theta(t);
            if !(d > 0.0 && td > last) {
                return Err((
                    "k",
                    format!("θ_d(θ) stops increasing at θ = {:.1}° (below max_theta_deg): the model cannot be inverted there", t.to_degrees()),
                ));
            }
            last = td;
        }
        Ok(())
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn lenses() -> Vec<Intrinsics> {
        let base = |k, max_deg: f64| Intrinsics::kannala_brandt(640, 600, 190.0, 188.0, 321.3, 298.7, k, max_deg.to_radians());
        vec![base([0.0; 4], 100.0), base([0.02, -0.004, 0.0008, -0.0001], 100.0), base([-0.05, 0.01, -0.002, 0.0001], 95.0)]
    }

    fn max_theta(k: &Intrinsics) -> f64 {
        match &k.lens {
            super::super::Lens::KannalaBrandt(kb) => kb.max_theta,
            _ => unreachable!(),
        }
    }

    #[test]
    fn projection_round_trips() {
        for lens in lenses() {
            lens.validate().unwrap();
            // Directions → pixels → directions.
            for a in 0..60 {
                for b in 0..36 {
                    let theta = max_theta(&lens) * a as f64 / 60.0;
                    let psi = b as f64 * 10f64.to_radians();
                    let d = DVec3::new(theta.sin() * psi.cos(), theta.sin() * psi.sin(), theta.cos());
                    let uv = lens.project(d).unwrap();
                    let back = lens.ray(uv).unwrap();
                    assert!((back - d).length() < 1e-9, "{d} -> {uv} -> {back}");
                }
            }
            // Pixels → directions → pixels, inside the field of view.
            for v in (0..600).step_by(23) {
                for u in (0..640).step_by(29) {
                    let uv = DVec2::new(u as f64, v as f64);
                    if let Some(d) = lens.ray(uv) {
                        assert!((lens.project(d).unwrap() - uv).length() < 1e-7);
                    }
                }
            }
            assert!(lens.project(DVec3::new(0.0, 0.0, -1.0)).is_none());
        }
    }

    #[test]
    fn validation_rejects_a_fold_back() {
        let kb = KannalaBrandt { k: [-0.5, 0.0, 0.0, 0.0], max_theta: 100f64.to_radians() };
        let (field, msg) = kb.validate().unwrap_err();
        assert_eq!(field, "k");
        assert!(msg.contains("stops increasing"), "{msg}");
    }
}
