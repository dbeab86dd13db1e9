//! Analytic lights for tests and quick set-ups: an isotropic point and a spot with a smooth
//! falloff, behind the same [`FarField`] interface as the measured tables.
//!
//! # How it works
//! A point light has the same intensity `I₀` in every direction (flux `4π I₀`). A spot light has
//! `I(ω) = I₀ · S((cos ψ − cos ψ_o) / (cos ψ_i − cos ψ_o))` with `ψ` the angle between `ω` and the
//! spot axis, `ψ_i ≤ ψ_o` the inner and outer cone half-angles and `S(x) = x²(3 − 2x)` on
//! `[0, 1]` (clamped) the smoothstep: full intensity inside the inner cone, none outside the
//! outer one, and a C¹ ramp between. Because `S` is integrated in `μ = cos ψ`, where the ramp is
//! linear, and `∫₀¹ S = ½`, the flux has the closed form
//! `Φ = 2π I₀ [(1 − cos ψ_i) + ½ (cos ψ_i − cos ψ_o)]`.

use super::FarField;
use glam::DVec3;

/// Errors building an analytic light.
#[derive(Debug, Clone, PartialEq, thiserror::Error)]
pub enum AnalyticLightError {
    /// The intensity is negative, NaN or infinite.
    #[error("light intensity {0} cd must be finite and ≥ 0")]
    Intensity(f64),
    /// The cone angles are not `0 ≤ inner ≤ outer ≤ 180°`, or not finite.
    #[error("spot cone half-angles inner {inner_deg}°, outer {outer_deg}° must satisfy 0 ≤ inner ≤ outer ≤ 180°")]
    Cone {
        /// Inner half-angle.
        inner_deg: f64,
        /// Outer half-angle.
        outer_deg: f64,
    },
    /// The axis is zero or not finite.
    #[error("spot axis {0:?} must be a finite non-zero vector")]
    Axis([f64; 3]),
}

/// An isotropic point light.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct PointLight {
    intensity_cd: f64,
}

impl PointLight {
    /// A point light of intensity `intensity_cd` in every direction.
    pub fn new(intensity_cd: f64) -> Result<Self, AnalyticLightError> {
        if !intensity_cd.is_finite() || intensity_cd < 0.0 {
            return Err(AnalyticLightError::Intensity(intensity_cd));
        }
        Ok(Self { intensity_cd })
    }

    /// Luminous flux `4π I₀` (lm).
    pub fn flux_lm(&self) -> f64 {
        4.0 * std::f64::consts::PI * self.intensity_cd
    }
}

impl FarField for PointLight {
    fn intensity_cd(&self, _dir_in_lamp: DVec3) -> f64 {
        self.intensity_cd
    }
}

/// A spot light: a cone around an axis with a smoothstep falloff.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct SpotLight {
    intensity_cd: f64,
    axis: DVec3,
    cos_inner: f64,
    cos_outer: f64,
}

impl SpotLight {
    /// A spot of on-axis intensity `intensity_cd` along `axis_in_lamp` (normalised here; the
    /// luminaire frame's nadir `−Z` is the usual choice), full inside `inner_deg`, dark past
    /// `outer_deg`. `inner_deg == outer_deg` gives a hard edge.
    pub fn new(intensity_cd: f64, axis_in_lamp: DVec3, inner_deg: f64, outer_deg: f64) -> Result<Self, AnalyticLightError> {
        if !intensity_cd.is_finite() || intensity_cd < 0.0 {
            return Err(AnalyticLightError::Intensity(intensity_cd));
        }
        if !(inner_deg.is_finite() && outer_deg.is_finite() && 0.0 <= inner_deg && inner_deg <= outer_deg && outer_deg <= 180.0) {
            return Err(AnalyticLightError::Cone { inner_deg, outer_deg });
        }
        let len = axis_in_lamp.length();
        if !len.is_finite() || len == 0.0 {
            return Err(AnalyticLightError::Axis(axis_in_lamp.to_array()));
        }
        Ok(Self { intensity_cd, axis: axis_in_lamp / len, cos_inner: inner_deg.to_radians().cos(), cos_outer: outer_deg.to_radians().cos() })
    }

    /// Luminous flux (lm), in closed form (module docs).
    pub fn flux_lm(&self) -> f64 {
        2.0 * std::f64::consts::PI * self.intensity_cd * ((1.0 - self.cos_inner) + 0.5 * (self.cos_inner - self.cos_outer))
    }
}

impl FarField for SpotLight {
    fn intensity_cd(&self, dir_in_lamp: DVec3) -> f64 {
        let mu = dir_in_lamp.dot(self.axis);
        if mu >= self.cos_inner {
            return self.intensity_cd;
        }
        if mu <= self.cos_outer {
            return 0.0;
        }
        let x = (mu - self.cos_outer) / (self.cos_inner - self.cos_outer);
        self.intensity_cd * x * x * (3.0 - 2.0 * x)
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::lamps::photometry::{Goniometric, PhotometricType, Symmetry};

    #[test]
    fn point_light_inverse_square_and_cosine() {
        let p = PointLight::new(100.0).unwrap();
        // 2 m straight below, surface facing up: E = 100 / 4
        assert!((p.irradiance_at(DVec3::new(0.0, 0.0, -2.0), DVec3::Z) - 25.0).abs() < 1e-12);
        // 60° incidence: cos 60° = ½
        let x = DVec3::new(2.0 * 3f64.sqrt(), 0.0, -2.0);
        assert!((p.irradiance_at(x, DVec3::Z) - 100.0 * 0.5 / 16.0).abs() < 1e-12);
        // a surface facing away gets nothing; the lamp's own position is degenerate → 0
        assert_eq!(p.irradiance_at(DVec3::new(0.0, 0.0, -2.0), -DVec3::Z), 0.0);
        assert_eq!(p.irradiance_at(DVec3::ZERO, DVec3::Z), 0.0);
        assert!(PointLight::new(f64::NAN).is_err() && PointLight::new(-1.0).is_err());
    }

    #[test]
    fn spot_falloff_and_flux_match_a_sampled_table() {
        let s = SpotLight::new(500.0, -DVec3::Z, 20.0, 35.0).unwrap();
        assert_eq!(s.intensity_cd(-DVec3::Z), 500.0);
        assert_eq!(s.intensity_cd(PhotometricType::C.dir_from_angles(0.0, 36.0)), 0.0);
        let mid = s.intensity_cd(PhotometricType::C.dir_from_angles(0.0, 27.5));
        assert!(mid > 0.0 && mid < 500.0);
        // The same spot tabulated every 0.25° (rotational type C table): its exact flux integral
        // of the interpolant differs from the closed form by the linear-interpolation error of the
        // ramp, O(Δγ²) ≈ 1e-5 of the flux here.
        let v: Vec<f64> = (0..=720).map(|i| i as f64 * 0.25).collect();
        let table = Goniometric::from_fn(PhotometricType::C, Symmetry::Rotational, &[0.0], &v, |_, g| s.intensity_cd(PhotometricType::C.dir_from_angles(0.0, g))).unwrap();
        assert!((table.flux_lm() / s.flux_lm() - 1.0).abs() < 1e-4, "{} vs {}", table.flux_lm(), s.flux_lm());
        // a hard-edged full-sphere "spot" is a point light
        let all = SpotLight::new(3.0, DVec3::X, 180.0, 180.0).unwrap();
        assert!((all.flux_lm() - PointLight::new(3.0).unwrap().flux_lm()).abs() < 1e-12);
        assert!(SpotLight::new(1.0, -DVec3::Z, 40.0, 30.0).is_err());
        assert!(SpotLight::new(1.0, DVec3::ZERO, 10.0, 30.0).is_err());
    }
}
