//! Real light sources on the CPU: far-field photometry (IES, EULUMDAT), analytic point and spot
//! lights, and the measured near-field light fields of Granier, Goesele, Heidrich and Seidel,
//! *Interactive Visualization of Complex Real-World Light Sources*, Pacific Graphics 2003
//! (`../shared/papers/granier-2003-complex-light-sources.txt`, "Granier" below).
//!
//! - [`photometry`]: IES LM-63 and EULUMDAT readers into one [`Goniometric`] table.
//! - [`analytic`]: [`PointLight`] and [`SpotLight`].
//! - [`lightfield`]: the near-field representation (Granier §2–3): folder format, the bellq basis
//!   (Eq. 6), the exact reconstruction (Eq. 5), the textured-spot-light approximation (Eq. 14),
//!   the synthetic acquisition and the approximation-error curves.
//! - [`model`]: a scene's `[[lights]]` with their models, irradiance at world points.
//! - [`storage`]: signed RGBE (Granier §4.2), RGB9E5 and half float encodings and their errors.
//!
//! This is the CPU core: the references the GPU pass (`render::lamps`, Granier §3.2, §4) and the
//! estimator (`estimate::lamps`) are checked against.
//!
//! # The luminaire frame
//! Every light is described in its own right-handed frame, metres: **`−Z` is the main emission
//! axis** (nadir of a street lamp, the optical axis of a torch), `+X` is the C0 plane of a
//! photometric file (its length axis), `+Y` the C90 plane. A pose in the world frame (`+Y` up,
//! see the crate docs) places it in a scene. For a light field the sampling plane `S` is `z = 0`
//! with `(u, v) = (x, y)` and the measurement plane `M` is `z = −d` with `(s, t) = (x, y)`.
//!
//! # Units
//! Photometric files give candela (lm/sr); [`FarField::irradiance_at`] is then illuminance (lx).
//! Light fields carry whatever unit their images have (heliar's scaled radiance); what matters is
//! that the scale is the same for every filter position.

pub mod analytic;
pub mod lightfield;
pub mod model;
pub mod photometry;
pub mod storage;
pub mod visibility;

pub use analytic::{AnalyticLightError, PointLight, SpotLight};
pub use model::{Lamp, LampError};
pub use photometry::{Goniometric, IesFile, LdtFile, PhotometricType, PhotometryError, Symmetry};

use glam::DVec3;

/// Points closer to a far-field light than this (metres) get no light: the direction and the
/// `1/r²` are undefined at the light itself, and no far-field model holds that close.
pub const MIN_FAR_FIELD_DISTANCE_M: f64 = 1e-6;

/// A light described by its intensity per direction (a point source in the far field).
pub trait FarField {
    /// Intensity (cd) toward the unit direction `dir_in_lamp` (luminaire frame).
    fn intensity_cd(&self, dir_in_lamp: DVec3) -> f64;

    /// Irradiance `E = I(ω) cos θ / r²` at `point_in_lamp` on a surface of unit normal
    /// `normal_in_lamp`, with `ω` the direction from the light to the point, `r` their distance
    /// and `θ` the angle between the normal and the direction back to the light. Zero for a
    /// surface facing away, and within [`MIN_FAR_FIELD_DISTANCE_M`] of the light.
    fn irradiance_at(&self, point_in_lamp: DVec3, normal_in_lamp: DVec3) -> f64 {
        let r = point_in_lamp.length();
        if r.is_nan() || r < MIN_FAR_FIELD_DISTANCE_M {
            return 0.0;
        }
        let dir = point_in_lamp / r;
        let cos_theta = -normal_in_lamp.dot(dir);
        if cos_theta <= 0.0 {
            return 0.0;
        }
        self.intensity_cd(dir) * cos_theta / (r * r)
    }
}

impl FarField for Goniometric {
    fn intensity_cd(&self, dir_in_lamp: DVec3) -> f64 {
        Goniometric::intensity_cd(self, dir_in_lamp)
    }
}
