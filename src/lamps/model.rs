//! A light of the scene (`[[lights]]`, `scene::lights`) with its model: the irradiance it gives
//! any world point and normal, in the model's own units (issue 16 §1). The estimator scales it by
//! an unknown `k` per lamp (`estimate::lamps`).
//!
//! # How it works
//! The world point and normal are taken into the luminaire frame (module docs of [`crate::lamps`])
//! by the light's pose, then:
//! - `ies`, `spot`, `point`: the far field, `E = I(ω) cos θ / r²` ([`FarField::irradiance_at`]),
//!   the same in the three channels;
//! - `lightfield`: the textured spot lights of Granier Eq. 14 (§3.2), each averaging its image
//!   over its filter's support ([`Footprint::Support`] with [`LIGHTFIELD_SUPPORT_POINTS`] Gauss
//!   points), per channel. The exact reconstruction (Eq. 5) is the reference the approximation was
//!   measured against (`lamps::lightfield::curves`); it costs some 30× more per point, and the
//!   estimator evaluates each pool entry once.
//!
//! Visibility (the proxy between the lamp and the point) is not part of the model: the estimator
//! traces it against its ray scene, the compositor's lamp term (`render::lamps`) reads it from
//! shadow maps.

use super::lightfield::reconstruct::Method;
use super::lightfield::{Footprint, LightField, LightFieldError};
use super::{AnalyticLightError, FarField, Goniometric, IesFile, LdtFile, PhotometryError, PointLight, SpotLight};
use crate::scene::{Light, LightKind};
use glam::DVec3;
use std::path::{Path, PathBuf};

/// Gauss points per `h/2` cell of a light field's textured spots (Granier Eq. 14's support mean).
pub const LIGHTFIELD_SUPPORT_POINTS: usize = 2;

/// Errors building a lamp's model. Every message starts with `scene.toml` and the field.
#[derive(Debug, thiserror::Error)]
pub enum LampError {
    /// The IES or EULUMDAT file is unreadable or malformed (the inner message names its line).
    #[error("{}: field `{field}`: {source}", manifest.display())]
    Photometry {
        /// `scene.toml`.
        manifest: PathBuf,
        /// `lights[i].profile`.
        field: String,
        /// The reader's error.
        source: PhotometryError,
    },
    /// The photometric table cannot be expanded.
    #[error("{}: field `{field}`: {}: {message}", manifest.display(), file.display())]
    Table {
        /// `scene.toml`.
        manifest: PathBuf,
        /// `lights[i].profile`.
        field: String,
        /// The photometric file.
        file: PathBuf,
        /// What is wrong.
        message: String,
    },
    /// The light-field folder is unreadable or malformed.
    #[error("{}: field `{field}`: {source}", manifest.display())]
    LightField {
        /// `scene.toml`.
        manifest: PathBuf,
        /// `lights[i].folder`.
        field: String,
        /// The folder's error.
        source: LightFieldError,
    },
    /// An analytic light's parameters are out of range.
    #[error("{}: field `{field}`: {source}", manifest.display())]
    Analytic {
        /// `scene.toml`.
        manifest: PathBuf,
        /// `lights[i]`.
        field: String,
        /// What is wrong.
        source: AnalyticLightError,
    },
}

/// The photometric model of a lamp, in its luminaire frame.
#[derive(Clone, Debug)]
pub enum Model {
    /// A measured far-field table.
    Table(Goniometric),
    /// An isotropic point.
    Point(PointLight),
    /// A spot.
    Spot(SpotLight),
    /// A near-field light field.
    Field(Box<LightField>),
}

/// A placed light with its model.
#[derive(Clone, Debug)]
pub struct Lamp {
    /// The scene's light (name, pose, prior scale, schedule).
    pub light: Light,
    /// Its model.
    pub model: Model,
}

impl Lamp {
    /// The radius of the source's emitting area, metres, for the penumbra of its shadows: the
    /// luminous opening of a measured table (IES/LDT); 0 for the analytic point and spot, and for
    /// a light field, whose filter positions each cast their own shadows (Granier §4).
    pub fn emitter_radius_m(&self) -> f64 {
        match &self.model {
            Model::Table(t) => t.opening_radius_m(),
            Model::Point(_) | Model::Spot(_) | Model::Field(_) => 0.0,
        }
    }

    /// Reads the model of `light` (`manifest`: the `scene.toml` it came from, for messages).
    pub fn load(manifest: &Path, light: &Light) -> Result<Self, LampError> {
        let m = manifest.to_owned();
        let field = |f: &str| format!("{}.{f}", light.field);
        let model = match &light.kind {
            LightKind::Ies { path } => {
                let is_ldt = path.extension().is_some_and(|e| e.eq_ignore_ascii_case("ldt"));
                let perr = |source| LampError::Photometry { manifest: m.clone(), field: field("profile"), source };
                let table = if is_ldt { LdtFile::read(path).map_err(perr)?.goniometric() } else { IesFile::read(path).map_err(perr)?.goniometric() };
                Model::Table(table.map_err(|e| LampError::Table { manifest: m.clone(), field: field("profile"), file: path.clone(), message: e.to_string() })?)
            }
            LightKind::LightField { dir } => {
                let lf = LightField::load(dir).map_err(|source| LampError::LightField { manifest: m.clone(), field: field("folder"), source })?;
                Model::Field(Box::new(lf))
            }
            LightKind::Point { intensity_cd } => {
                Model::Point(PointLight::new(*intensity_cd).map_err(|source| LampError::Analytic { manifest: m.clone(), field: field("intensity_cd"), source })?)
            }
            LightKind::Spot { intensity_cd, inner_deg, outer_deg } => Model::Spot(
                SpotLight::new(*intensity_cd, DVec3::NEG_Z, *inner_deg, *outer_deg).map_err(|source| LampError::Analytic { manifest: m.clone(), field: light.field.clone(), source })?,
            ),
        };
        Ok(Self { light: light.clone(), model })
    }

    /// Irradiance at the world point `p` on a surface of world unit normal `n` (model units per
    /// channel; no visibility).
    pub fn irradiance(&self, p: DVec3, n: DVec3) -> [f64; 3] {
        let (x, nl) = (self.light.lamp_from_world_point(p), self.light.lamp_from_world_dir(n));
        match &self.model {
            Model::Table(t) => [t.irradiance_at(x, nl); 3],
            Model::Point(l) => [l.irradiance_at(x, nl); 3],
            Model::Spot(l) => [l.irradiance_at(x, nl); 3],
            Model::Field(lf) => lf.irradiance(Method::Spots(Footprint::Support(LIGHTFIELD_SUPPORT_POINTS)), x, nl),
        }
    }

    /// Builds every light of a scene.
    pub fn load_all(manifest: &Path, lights: &[Light]) -> Result<Vec<Self>, LampError> {
        lights.iter().map(|l| Self::load(manifest, l)).collect()
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::scene::Schedule;
    use crate::scene::lights::world_from_lamp;

    fn light(kind: LightKind, position: DVec3, aim: DVec3) -> Light {
        Light { name: "l".into(), field: "lights[0]".into(), kind, position, world_from_lamp: world_from_lamp(aim, 0.0).unwrap(), scale: 1.0, schedule: Schedule::Always }
    }

    #[test]
    fn a_posed_point_and_spot_follow_the_inverse_square_law() {
        let l = light(LightKind::Point { intensity_cd: 400.0 }, DVec3::new(1.0, 4.0, 2.0), DVec3::NEG_Y);
        let lamp = Lamp::load(Path::new("scene.toml"), &l).unwrap();
        // 4 m straight below on the ground: E = 400 / 16
        assert!((lamp.irradiance(DVec3::new(1.0, 0.0, 2.0), DVec3::Y)[0] - 25.0).abs() < 1e-12);
        // 3 m off to the side: r = 5, cos θ = 4/5
        assert!((lamp.irradiance(DVec3::new(4.0, 0.0, 2.0), DVec3::Y)[1] - 400.0 * 0.8 / 25.0).abs() < 1e-12);
        // a spot aimed along world +X lights a wall at x = 3 facing −X, and not the ground below
        let s = light(LightKind::Spot { intensity_cd: 900.0, inner_deg: 10.0, outer_deg: 20.0 }, DVec3::new(0.0, 1.0, 0.0), DVec3::X);
        let spot = Lamp::load(Path::new("scene.toml"), &s).unwrap();
        assert!((spot.irradiance(DVec3::new(3.0, 1.0, 0.0), DVec3::NEG_X)[2] - 100.0).abs() < 1e-12);
        assert_eq!(spot.irradiance(DVec3::new(0.0, 0.0, 0.0), DVec3::Y), [0.0; 3]);
    }

    #[test]
    fn a_posed_light_field_is_its_textured_spots_in_the_luminaire_frame() {
        use crate::io::image::LinearImage;
        use crate::lamps::lightfield::FilterGrid;
        let grid = FilterGrid { counts: [3, 3], spacing_m: 0.01 };
        // a ramp across s, so the pose's mapping of world to (s, t) shows in the values
        let img = LinearImage::from_fn(32, 32, |x, _| [1.0 + x as f32 * 0.05, 2.0, 0.5]);
        let lf = LightField::new(grid, 0.5, [2.0, 2.0], vec![img; 9], Path::new("<test>")).unwrap();
        let mut l = light(LightKind::Point { intensity_cd: 1.0 }, DVec3::new(0.5, 3.0, -1.0), DVec3::new(0.2, -1.0, 0.1));
        l.kind = LightKind::LightField { dir: PathBuf::from("<memory>") };
        let lamp = Lamp { light: l.clone(), model: Model::Field(Box::new(lf.clone())) };
        let (p, n) = (DVec3::new(1.1, 0.0, -0.4), DVec3::Y);
        let want = lf.irradiance(Method::Spots(Footprint::Support(LIGHTFIELD_SUPPORT_POINTS)), l.lamp_from_world_point(p), l.lamp_from_world_dir(n));
        let got = lamp.irradiance(p, n);
        assert!(want[0] > 0.0 && want[0] != want[1]);
        assert_eq!(got, want);
        // far away it is a point source: 20 m down the tilted axis, facing the lamp, each of the 9
        // spots gives E' / 20² with the green E' = 2 everywhere (filter offsets of 1 cm move
        // δ by 1e-7 relative), so the pose put the axis where the light field's is
        let axis = l.world_from_lamp * DVec3::NEG_Z;
        let foot = l.position + axis * 20.0;
        let far = lamp.irradiance(foot, -axis)[1];
        assert!((far * 400.0 / (9.0 * 2.0) - 1.0).abs() < 0.01, "{far}");
    }

    #[test]
    fn a_missing_profile_names_the_manifest_and_field() {
        let l = light(LightKind::Ies { path: PathBuf::from("/nonexistent/street.ies") }, DVec3::ZERO, DVec3::NEG_Y);
        let e = Lamp::load(Path::new("/s/scene.toml"), &l).unwrap_err().to_string();
        assert!(e.starts_with("/s/scene.toml: field `lights[0].profile`: /nonexistent/street.ies"), "{e}");
    }
}
