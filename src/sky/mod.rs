//! Sky models whose shape follows the sun, and the light that comes from below the horizon.
//!
//! heliar's outdoor model has a uniform sky of radiance `Pa/π` over the upper hemisphere and no
//! light from below the horizon. Real skies are brighter near the sun and toward the horizon, and
//! distant terrain (snow, a street beyond the proxy) lights surfaces from below. This module holds
//! the pieces that replace those assumptions; it is a leaf (glam, [`crate::geometry::equirect`] and
//! [`crate::geometry::sampling`] only):
//!
//! - [`preetham`]: the Preetham–Shirley–Smits (1999) analytic daylight model (Perez function with
//!   turbidity-dependent coefficients, xyY → linear Rec.709).
//! - [`hosek`]: the Hosek–Wilkie (2012) sky-dome model, RGB variant, with the authors' coefficient
//!   tables (`hosek_data/`, BSD licence kept with the data).
//! - [`basis`]: the sky heliar's estimator fits: a few sun-following shapes (uniform,
//!   circumsolar, horizon band, optionally Preetham), each normalised to unit irradiance on an
//!   unoccluded horizontal surface, so fitted weights add up to `Pa`.
//! - [`conditioning`]: condition numbers of the basis over typical sample sets (the basis
//!   recommendation rests on them).
//! - [`quadrature`]: deterministic cosine-weighted direction sets and the irradiance of every
//!   shape (and of the region below the horizon) on a normal with a visibility callback.
//! - [`radiance`]: the one sky every path tracer of the crate sees when a path leaves the
//!   proxy (the uniform or Hošek–Wilkie sky above the horizon, the terrain below).
//! - [`terrain`]: distant Lambertian terrain lit by the same sun and sky, linear in `Pa` and `Pd`,
//!   and its albedo estimated from an environment map.
//!
//! # Conventions shared by the models
//! World frame +Y up (crate docs). A sky is defined over the upper hemisphere only: every
//! `radiance` returns 0 for directions with `y < 0` (light from below is [`terrain`]'s), and 0 for a
//! zero, NaN or infinite direction (documented finite output, so a stray direction in a hot loop
//! cannot poison a sum). Directions need not be normalised.
//!
//! **Sun below the horizon.** The analytic models are fitted to a sun above the horizon (their
//! formulas take the solar elevation to a fractional power or a tangent and go NaN or negative
//! below it). A sun direction with `y < 0` is therefore lifted onto the horizon at the same
//! azimuth before the shape is built ([`ShapeSun`]); the model reports it through
//! [`ShapeSun::below_horizon`]. A sun straight below (no azimuth) is lifted toward `−Z`. The sun's
//! own light (`Pd`) is not part of any sky; terrain lit by a sun below the horizon receives none.

pub mod basis;
pub mod conditioning;
pub mod hosek;
mod hosek_data;
pub mod preetham;
pub mod quadrature;
pub mod radiance;
pub mod terrain;

use glam::{DVec3, Vec3};

/// Smallest squared length a direction may have before it counts as zero.
const MIN_DIR_LENGTH_SQUARED: f64 = 1e-24;

/// Errors of the sky models. Messages name the argument that was wrong.
#[derive(Debug, thiserror::Error, PartialEq)]
pub enum SkyError {
    /// A direction argument was zero, NaN or infinite.
    #[error("sky: {what} must be a finite, non-zero direction, got {value:?}")]
    BadDirection {
        /// Which argument (`sun_dir_world`, …).
        what: &'static str,
        /// The value given.
        value: [f32; 3],
    },
    /// Turbidity outside the range a model was fitted for.
    #[error("sky: {model} turbidity must be in [{min}, {max}], got {value}")]
    Turbidity {
        /// The model (`preetham`, `hosek`).
        model: &'static str,
        /// The value given.
        value: f64,
        /// Smallest valid value.
        min: f64,
        /// Largest valid value.
        max: f64,
    },
    /// A ground or terrain albedo outside `[0, 1]` or not finite.
    #[error("sky: {what} must be in [0, 1] per channel, got {value:?}")]
    Albedo {
        /// Which argument.
        what: &'static str,
        /// The value given.
        value: [f64; 3],
    },
    /// A numeric parameter of a specification is out of its range.
    #[error("sky: {field} {reason}, got {value}")]
    Parameter {
        /// The field (`SkyBasisSpec::circumsolar_width_deg`, …).
        field: &'static str,
        /// What it must be.
        reason: &'static str,
        /// The value given.
        value: f64,
    },
    /// Buffer sizes that do not agree (an image and its mask, weights and a basis).
    #[error("sky: {what}: expected {expected} entries, got {got}")]
    Size {
        /// Which buffer.
        what: &'static str,
        /// Entries needed.
        expected: usize,
        /// Entries given.
        got: usize,
    },
}

/// The sun direction a sky shape is built from: unit, at or above the horizon.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct ShapeSun {
    /// Unit direction toward the sun used by the shape (world frame, `y ≥ 0`).
    pub dir: DVec3,
    /// Solar elevation of [`Self::dir`], radians, in `[0, π/2]`.
    pub elevation_rad: f64,
    /// The given sun was below the horizon and has been lifted onto it (module docs).
    pub below_horizon: bool,
}

impl ShapeSun {
    /// Validates `sun_dir_world` (finite, non-zero) and lifts a sun below the horizon onto it.
    pub fn from_dir(sun_dir_world: Vec3) -> Result<Self, SkyError> {
        let d = unit_dir(sun_dir_world).ok_or(SkyError::BadDirection { what: "sun_dir_world", value: sun_dir_world.to_array() })?;
        if d.y >= 0.0 {
            return Ok(Self { dir: d, elevation_rad: d.y.clamp(0.0, 1.0).asin(), below_horizon: false });
        }
        let horizontal = DVec3::new(d.x, 0.0, d.z);
        let dir = if horizontal.length_squared() > MIN_DIR_LENGTH_SQUARED { horizontal.normalize() } else { DVec3::NEG_Z };
        Ok(Self { dir, elevation_rad: 0.0, below_horizon: true })
    }

    /// Solar zenith angle, radians, in `[0, π/2]`.
    pub fn zenith_rad(&self) -> f64 {
        std::f64::consts::FRAC_PI_2 - self.elevation_rad
    }
}

/// `dir` normalised in double precision, or `None` when it is zero, NaN or infinite.
pub(crate) fn unit_dir(dir: Vec3) -> Option<DVec3> {
    let d = dir.as_dvec3();
    let l2 = d.length_squared();
    (d.is_finite() && l2 > MIN_DIR_LENGTH_SQUARED && l2.is_finite()).then(|| d / l2.sqrt())
}

/// The view zenith angle's cosine and the angle to the sun `γ` of a view direction, or `None` for
/// an invalid direction or one below the horizon (where no sky is defined).
pub(crate) fn sky_angles(dir: Vec3, sun: DVec3) -> Option<(f64, f64)> {
    let v = unit_dir(dir)?;
    (v.y >= 0.0).then(|| (v.y, v.dot(sun).clamp(-1.0, 1.0).acos()))
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn sun_above_the_horizon_is_kept() {
        let s = ShapeSun::from_dir(Vec3::new(0.0, 1.0, -1.0)).unwrap();
        assert!(!s.below_horizon);
        assert!((s.elevation_rad - std::f64::consts::FRAC_PI_4).abs() < 1e-7);
        assert!((s.dir.length() - 1.0).abs() < 1e-12);
    }

    #[test]
    fn sun_below_is_lifted_onto_the_horizon_at_its_azimuth() {
        let s = ShapeSun::from_dir(Vec3::new(3.0, -1.0, 4.0)).unwrap();
        assert!(s.below_horizon && s.elevation_rad == 0.0);
        assert!((s.dir - DVec3::new(0.6, 0.0, 0.8)).length() < 1e-7, "{:?}", s.dir);
        let nadir = ShapeSun::from_dir(Vec3::NEG_Y).unwrap();
        assert_eq!(nadir.dir, DVec3::NEG_Z);
    }

    #[test]
    fn invalid_sun_directions_are_errors() {
        for d in [Vec3::ZERO, Vec3::new(f32::NAN, 1.0, 0.0), Vec3::new(0.0, f32::INFINITY, 0.0)] {
            let e = ShapeSun::from_dir(d).unwrap_err();
            assert!(matches!(e, SkyError::BadDirection { what: "sun_dir_world", .. }), "{e}");
        }
    }

    #[test]
    fn sky_angles_reject_below_and_invalid() {
        let sun = DVec3::Y;
        assert!(sky_angles(Vec3::new(0.0, -0.1, 1.0), sun).is_none());
        assert!(sky_angles(Vec3::new(f32::NAN, 0.5, 0.0), sun).is_none());
        let (mu, gamma) = sky_angles(Vec3::new(1.0, 1.0, 0.0), sun).unwrap();
        assert!((mu - 0.5f64.sqrt()).abs() < 1e-7 && (gamma - std::f64::consts::FRAC_PI_4).abs() < 1e-7);
    }
}
