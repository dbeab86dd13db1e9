//! Solar position (NREL SPA) and the sun's direction in the scene frame.
//!
//! Positions come from the `solar-positioning` crate's implementation of the NREL Solar Position
//! Algorithm (Reda & Andreas 2004; ±0.0003° over years −2000..6000), with atmospheric refraction
//! from pressure and temperature. The test below checks it against the worked example in the SPA
//! report (Table A5.1). Jensen §3.1 takes the sun direction from such a model and only estimates
//! intensities.
//!
//! ΔT (TT − UT1) is estimated from the date (Espenak–Meeus polynomials) unless the scene gives it.

use chrono::{DateTime, FixedOffset};
use glam::{DVec3, Vec3};
use solar_positioning::{Location, RefractionCorrection, SolarPositions, delta_t};

/// Standard sea-level pressure, the default for refraction.
pub const DEFAULT_PRESSURE_MBAR: f64 = 1013.25;
/// Default air temperature for refraction.
pub const DEFAULT_TEMPERATURE_C: f64 = 15.0;

/// Errors from the solar position model.
#[derive(Debug, thiserror::Error)]
pub enum SunError {
    /// The time, place or atmosphere is outside what SPA accepts.
    #[error("solar position for {what}: {message}")]
    Model {
        /// Which input was being evaluated.
        what: String,
        /// What the model said.
        message: String,
    },
}

/// Where the sun is seen from.
#[derive(Clone, Copy, Debug, PartialEq, serde::Serialize, serde::Deserialize)]
pub struct Observer {
    /// Latitude, degrees, positive north.
    pub latitude_deg: f64,
    /// Longitude, degrees, positive east.
    pub longitude_deg: f64,
    /// Height above sea level, metres.
    pub elevation_m: f64,
    /// Air pressure for refraction, millibar.
    pub pressure_mbar: f64,
    /// Air temperature for refraction, °C.
    pub temperature_c: f64,
    /// ΔT = TT − UT1 in seconds; estimated from the date when `None`.
    pub delta_t_s: Option<f64>,
}

impl Observer {
    /// An observer with standard atmosphere and estimated ΔT.
    pub fn new(latitude_deg: f64, longitude_deg: f64, elevation_m: f64) -> Self {
        Self {
            latitude_deg,
            longitude_deg,
            elevation_m,
            pressure_mbar: DEFAULT_PRESSURE_MBAR,
            temperature_c: DEFAULT_TEMPERATURE_C,
            delta_t_s: None,
        }
    }
}

impl Observer {
    /// Checks that this is a place on Earth with an atmosphere SPA can refract through:
    /// `Err((field, message))` with the field named as in `scene.toml`'s `[place]`. The scene loader
    /// and the command line (`heliar sun`) both check with this.
    pub fn validate(&self) -> Result<(), (&'static str, String)> {
        if !(self.latitude_deg.is_finite() && self.latitude_deg.abs() <= 90.0) {
            return Err(("latitude_deg", format!("{} is not in [-90, 90]", self.latitude_deg)));
        }
        if !(self.longitude_deg.is_finite() && self.longitude_deg.abs() <= 180.0) {
            return Err(("longitude_deg", format!("{} is not in [-180, 180]", self.longitude_deg)));
        }
        if !(self.elevation_m.is_finite() && self.elevation_m > -500.0 && self.elevation_m < 9000.0) {
            return Err(("elevation_m", format!("{} m is not a place on Earth", self.elevation_m)));
        }
        if !(self.pressure_mbar.is_finite() && self.pressure_mbar > 0.0 && self.pressure_mbar <= 2000.0) {
            return Err(("pressure_mbar", "must be in (0, 2000]".into()));
        }
        if !(self.temperature_c.is_finite() && self.temperature_c > -273.0 && self.temperature_c <= 100.0) {
            return Err(("temperature_c", "must be in (-273, 100]".into()));
        }
        if self.delta_t_s.is_some_and(|d| !d.is_finite()) {
            return Err(("delta_t_s", "must be a finite number of seconds".into()));
        }
        Ok(())
    }
}

/// Topocentric solar position.
#[derive(Clone, Copy, Debug, PartialEq, serde::Serialize)]
pub struct SunPosition {
    /// Topocentric zenith angle without refraction, degrees.
    pub zenith_deg: f64,
    /// Zenith angle with atmospheric refraction (where the sun appears), degrees.
    pub apparent_zenith_deg: f64,
    /// Azimuth, degrees clockwise from north in `[0, 360)`.
    pub azimuth_deg: f64,
}

impl SunPosition {
    /// True when the centre of the sun's apparent disc is above the horizon.
    pub fn above_horizon(&self) -> bool {
        self.apparent_zenith_deg < 90.0
    }

    /// Apparent elevation above the horizon, degrees.
    pub fn apparent_elevation_deg(&self) -> f64 {
        90.0 - self.apparent_zenith_deg
    }
}

/// The solar position seen by `observer` at `time`.
pub fn sun_position(observer: &Observer, time: &DateTime<FixedOffset>) -> Result<SunPosition, SunError> {
    let err = |e: solar_positioning::Error| SunError::Model {
        what: format!("{} at ({}, {})", time.to_rfc3339(), observer.latitude_deg, observer.longitude_deg),
        message: e.to_string(),
    };
    let dt = match observer.delta_t_s {
        Some(d) => d,
        None => delta_t::estimate_from_date_like(time).map_err(err)?,
    };
    let location = Location { latitude: observer.latitude_deg, longitude: observer.longitude_deg };
    let prepared = SolarPositions::new().for_time(time, dt).map_err(err)?;
    let geometric = prepared.at(location, observer.elevation_m, None).map_err(err)?;
    let refraction = RefractionCorrection::new(observer.pressure_mbar, observer.temperature_c).map_err(err)?;
    let apparent = prepared.at(location, observer.elevation_m, Some(refraction)).map_err(err)?;
    Ok(SunPosition {
        zenith_deg: geometric.zenith_angle(),
        apparent_zenith_deg: apparent.zenith_angle(),
        azimuth_deg: apparent.azimuth(),
    })
}

/// The geographic orientation of a scene's world frame: unit north, east and up vectors.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct GeoFrame {
    /// Geographic north (horizontal).
    pub north: DVec3,
    /// East = north × up.
    pub east: DVec3,
    /// Up (+Y).
    pub up: DVec3,
}

impl Default for GeoFrame {
    fn default() -> Self {
        Self::from_north(DVec3::NEG_Z).unwrap_or(GeoFrame { north: DVec3::NEG_Z, east: DVec3::X, up: DVec3::Y })
    }
}

impl GeoFrame {
    /// The frame for a north direction given in world coordinates. Its vertical part is removed;
    /// `None` if nothing horizontal is left.
    pub fn from_north(north: DVec3) -> Option<Self> {
        let up = DVec3::Y;
        let h = north - up * north.dot(up);
        if !(h.length() > 1e-6) {
            return None;
        }
        let north = h.normalize();
        Some(Self { north, east: north.cross(up), up })
    }

    /// Unit world direction of a point in the sky at `azimuth_deg` (clockwise from north) and
    /// `zenith_deg`.
    pub fn dir_from_az_zenith(&self, azimuth_deg: f64, zenith_deg: f64) -> DVec3 {
        let (sa, ca) = azimuth_deg.to_radians().sin_cos();
        let (sz, cz) = zenith_deg.to_radians().sin_cos();
        (self.north * ca + self.east * sa) * sz + self.up * cz
    }

    /// Azimuth (degrees clockwise from north) and zenith angle (degrees) of a world direction.
    pub fn az_zenith_from_dir(&self, dir: DVec3) -> (f64, f64) {
        let d = dir.normalize();
        let az = d.dot(self.east).atan2(d.dot(self.north)).to_degrees().rem_euclid(360.0);
        (az, d.dot(self.up).clamp(-1.0, 1.0).acos().to_degrees())
    }

    /// Unit world direction toward the sun (apparent position).
    pub fn sun_dir_in_world(&self, sun: &SunPosition) -> Vec3 {
        self.dir_from_az_zenith(sun.azimuth_deg, sun.apparent_zenith_deg).as_vec3()
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// The worked example of the SPA report (Reda & Andreas, NREL/TP-560-34302, Table A5.1):
    /// 2003-10-17 12:30:30 at UTC−7, ΔT = 67 s, 39.742476° N, 105.1786° W, 1830.14 m,
    /// 820 mbar, 11 °C. Published: topocentric zenith 50.11162°, azimuth 194.34024°.
    #[test]
    fn spa_worked_example() {
        let obs = Observer {
            latitude_deg: 39.742476,
            longitude_deg: -105.1786,
            elevation_m: 1830.14,
            pressure_mbar: 820.0,
            temperature_c: 11.0,
            delta_t_s: Some(67.0),
        };
        let t = DateTime::parse_from_rfc3339("2003-10-17T12:30:30-07:00").unwrap();
        let p = sun_position(&obs, &t).unwrap();
        assert!((p.apparent_zenith_deg - 50.11162).abs() < 0.001 * 0.1, "{p:?}");
        assert!((p.azimuth_deg - 194.34024).abs() < 0.001 * 0.1, "{p:?}");
        // Refraction raises the sun: geometric zenith is larger, by about a minute of arc here.
        let refr = p.zenith_deg - p.apparent_zenith_deg;
        assert!(refr > 0.005 && refr < 0.03, "refraction {refr}");
    }

    #[test]
    fn below_horizon_is_reported() {
        let obs = Observer::new(57.0, 10.0, 0.0);
        let t = DateTime::parse_from_rfc3339("2024-12-21T00:00:00+00:00").unwrap();
        let p = sun_position(&obs, &t).unwrap();
        assert!(!p.above_horizon() && p.apparent_zenith_deg > 90.0);
    }

    #[test]
    fn geo_frame_directions() {
        let g = GeoFrame::default();
        assert!((g.dir_from_az_zenith(0.0, 90.0) - DVec3::NEG_Z).length() < 1e-12);
        assert!((g.dir_from_az_zenith(90.0, 90.0) - DVec3::X).length() < 1e-12);
        assert!((g.dir_from_az_zenith(123.0, 0.0) - DVec3::Y).length() < 1e-12);
        let rotated = GeoFrame::from_north(DVec3::new(1.0, 0.3, 0.0)).unwrap();
        assert!((rotated.east - DVec3::Z).length() < 1e-12);
        let d = rotated.dir_from_az_zenith(200.0, 35.0);
        let (az, zen) = rotated.az_zenith_from_dir(d);
        assert!((az - 200.0).abs() < 1e-9 && (zen - 35.0).abs() < 1e-9);
        assert!(GeoFrame::from_north(DVec3::Y).is_none());
    }
}
