//! `[[lights]]` of `scene.toml`: real light sources placed in the world (issue 16 §1), as plain
//! validated data. The light models themselves (IES/EULUMDAT tables, light fields, analytic
//! lights) are built from these values by `lamps::model`, so `scene` never imports `lamps`.
//!
//! ```toml
//! [[lights]]
//! name = "street lamp"          # optional; reports use it (default "lights[i]")
//! kind = "ies"                  # ies | lightfield | spot | point
//! profile = "lamps/street.ies"  # kind = "ies": an IES LM-63 (.ies) or EULUMDAT (.ldt) file
//! # folder = "lamps/torch"      # kind = "lightfield": a light-field folder (lightfield.toml + EXR)
//! # intensity_cd = 800.0        # kind = "spot" / "point": intensity on the axis / everywhere
//! # inner_deg = 20.0            # kind = "spot": full intensity inside this half-angle …
//! # outer_deg = 35.0            #   … and none outside this one (smoothstep between)
//! position = [2.0, 4.5, -1.0]   # world metres: the luminaire's photometric centre
//! aim = [0.0, -1.0, 0.0]        # world direction of the luminaire's main axis (−Z of its frame)
//! roll_deg = 0.0                # turn of its C0 plane (+X) about the aim, see below
//! scale = 1.0                   # prior of the lamp's scale k (model units → scene radiance)
//! schedule = "always"           # or a list of on/off intervals:
//! # schedule = [{ on = "2024-06-21T21:30:00+02:00", off = "2024-06-21T23:00:00+02:00" },
//! #             { on = 120.0 }]   # numbers: seconds from the first frame of the run
//! ```
//!
//! # The pose
//! The luminaire frame is the one of `lamps` (`−Z` the main emission axis, `+X` the C0 plane,
//! `+Y` the C90 plane). In the world frame (`+Y` up): `−Z` of the lamp points along `aim`; with
//! `roll_deg = 0` its `+X` is the world `+X` projected onto the plane across the aim (world `−Z`
//! when the aim is along `±X`); `roll_deg` then turns `+X` about the lamp's `+Z` (right-handed:
//! counter-clockwise seen from above for a lamp aimed down). A street lamp aimed straight down
//! with `roll_deg = 0` has its C0 plane along world `+X` and C90 along world `−Z`.
//!
//! # The schedule
//! `"always"` (the default), or intervals `[on, off)`: a lamp is on at a frame's time when any
//! interval holds it. `on` or `off` may be left out (on since ever, on for ever). Times are RFC
//! 3339 with an offset (quoted or as TOML date-times), or numbers: seconds from the first frame
//! the run estimates.

use super::paths::Within;
use super::{SceneError, finite3, invalid, parse_time};
use chrono::{DateTime, FixedOffset};
use glam::{DMat3, DVec3};
use serde::{Deserialize, Serialize};
use std::path::{Path, PathBuf};

/// Aims closer than this (|cos|) to the world `±X` take their C0 reference from world `−Z`.
const AIM_ALONG_X_COS: f64 = 0.999;

fn down() -> [f64; 3] {
    [0.0, -1.0, 0.0]
}

fn one() -> f64 {
    1.0
}

/// `[[lights]]` as written.
#[derive(Clone, Debug, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct LightSpec {
    /// Name in reports.
    pub name: Option<String>,
    /// `ies`, `lightfield`, `spot` or `point`.
    pub kind: String,
    /// IES or EULUMDAT file (kind `ies`), relative to the scene folder.
    pub profile: Option<String>,
    /// Light-field folder (kind `lightfield`), relative to the scene folder.
    pub folder: Option<String>,
    /// Intensity, cd (kinds `spot`, `point`).
    pub intensity_cd: Option<f64>,
    /// Inner cone half-angle, degrees (kind `spot`).
    pub inner_deg: Option<f64>,
    /// Outer cone half-angle, degrees (kind `spot`).
    pub outer_deg: Option<f64>,
    /// World position, metres.
    pub position: [f64; 3],
    /// World direction of the main axis (default straight down).
    #[serde(default = "down")]
    pub aim: [f64; 3],
    /// Turn of the C0 plane about the aim, degrees.
    #[serde(default)]
    pub roll_deg: f64,
    /// Prior scale `k`.
    #[serde(default = "one")]
    pub scale: f64,
    /// `"always"` or a list of `{ on, off }` intervals.
    pub schedule: Option<toml::Value>,
}

/// What a light is.
#[derive(Clone, Debug, PartialEq)]
pub enum LightKind {
    /// Far-field photometry from an IES (`.ies`) or EULUMDAT (`.ldt`) file.
    Ies {
        /// The file.
        path: PathBuf,
    },
    /// A Granier light-field folder.
    LightField {
        /// The folder.
        dir: PathBuf,
    },
    /// An analytic spot along the luminaire's `−Z`.
    Spot {
        /// On-axis intensity, cd.
        intensity_cd: f64,
        /// Inner half-angle, degrees.
        inner_deg: f64,
        /// Outer half-angle, degrees.
        outer_deg: f64,
    },
    /// An isotropic point.
    Point {
        /// Intensity, cd.
        intensity_cd: f64,
    },
}

/// A moment of a schedule.
#[derive(Clone, Copy, Debug, PartialEq)]
pub enum Instant {
    /// An absolute time.
    Time(DateTime<FixedOffset>),
    /// Seconds from the first frame of the run.
    SecondsFromStart(f64),
}

impl Instant {
    fn seconds_after(&self, start: &DateTime<FixedOffset>) -> f64 {
        match self {
            Instant::Time(t) => (*t - *start).num_microseconds().map_or(f64::NAN, |us| us as f64 * 1e-6),
            Instant::SecondsFromStart(s) => *s,
        }
    }
}

/// When a light is on.
#[derive(Clone, Debug, PartialEq)]
pub enum Schedule {
    /// Always on.
    Always,
    /// On within any of these `[on, off)` intervals (`None`: unbounded).
    Intervals(Vec<(Option<Instant>, Option<Instant>)>),
}

impl Schedule {
    /// Whether the light is on at `time`, for a run whose first frame was at `start`.
    pub fn is_on(&self, time: &DateTime<FixedOffset>, start: &DateTime<FixedOffset>) -> bool {
        match self {
            Schedule::Always => true,
            Schedule::Intervals(list) => {
                let t = Instant::Time(*time).seconds_after(start);
                list.iter().any(|(on, off)| on.is_none_or(|on| t >= on.seconds_after(start)) && off.is_none_or(|off| t < off.seconds_after(start)))
            }
        }
    }
}

/// A validated light.
#[derive(Clone, Debug, PartialEq)]
pub struct Light {
    /// Name in reports.
    pub name: String,
    /// Where it is in the manifest (`lights[i]`), for messages.
    pub field: String,
    /// What it is.
    pub kind: LightKind,
    /// World position, metres.
    pub position: DVec3,
    /// Columns: the luminaire's `+X`, `+Y`, `+Z` in the world frame.
    pub world_from_lamp: DMat3,
    /// Prior scale `k`.
    pub scale: f64,
    /// When it is on.
    pub schedule: Schedule,
}

impl Light {
    /// A point of the world in the luminaire frame.
    pub fn lamp_from_world_point(&self, p: DVec3) -> DVec3 {
        self.world_from_lamp.transpose() * (p - self.position)
    }

    /// A direction of the world in the luminaire frame.
    pub fn lamp_from_world_dir(&self, d: DVec3) -> DVec3 {
        self.world_from_lamp.transpose() * d
    }
}

/// The rotation of the module docs: `−Z` of the lamp along `aim`, `+X` from world `+X` (or `−Z`)
/// turned by `roll_deg` about the lamp's `+Z`. `None` for a zero aim.
pub fn world_from_lamp(aim: DVec3, roll_deg: f64) -> Option<DMat3> {
    let z = (-aim).try_normalize()?;
    let reference = if z.dot(DVec3::X).abs() > AIM_ALONG_X_COS { DVec3::NEG_Z } else { DVec3::X };
    let x0 = (reference - z * reference.dot(z)).normalize();
    let y0 = z.cross(x0);
    let (s, c) = roll_deg.to_radians().sin_cos();
    let x = x0 * c + y0 * s;
    Some(DMat3::from_cols(x, z.cross(x), z))
}

fn number(m: &Path, field: &str, v: Option<f64>, kind: &str) -> Result<f64, SceneError> {
    let v = v.ok_or_else(|| invalid(m, field, format!("kind = \"{kind}\" needs it")))?;
    if !v.is_finite() {
        return Err(invalid(m, field, format!("{v} must be finite")));
    }
    Ok(v)
}

fn kind(within: &Within, m: &Path, f: &dyn Fn(&str) -> String, s: &LightSpec) -> Result<LightKind, SceneError> {
    let unused = |name: &str, present: bool| if present { Err(invalid(m, &f(name), format!("does not apply to kind = \"{}\"", s.kind))) } else { Ok(()) };
    let file = |name: &str, rel: &Option<String>| -> Result<PathBuf, SceneError> {
        let rel = rel.as_deref().ok_or_else(|| invalid(m, &f(name), format!("kind = \"{}\" needs it", s.kind)))?;
        let p = within.join(m, &f(name), rel)?;
        if !p.exists() {
            return Err(invalid(m, &f(name), format!("no such file or folder: {}", p.display())));
        }
        Ok(p)
    };
    let analytic = matches!(s.kind.as_str(), "spot" | "point");
    unused("intensity_cd", !analytic && s.intensity_cd.is_some())?;
    unused("inner_deg", s.kind != "spot" && s.inner_deg.is_some())?;
    unused("outer_deg", s.kind != "spot" && s.outer_deg.is_some())?;
    unused("profile", s.kind != "ies" && s.profile.is_some())?;
    unused("folder", s.kind != "lightfield" && s.folder.is_some())?;
    let intensity = |s: &LightSpec| -> Result<f64, SceneError> {
        let v = number(m, &f("intensity_cd"), s.intensity_cd, &s.kind)?;
        if v < 0.0 {
            return Err(invalid(m, &f("intensity_cd"), format!("{v} must be ≥ 0")));
        }
        Ok(v)
    };
    Ok(match s.kind.as_str() {
        "ies" => {
            let path = file("profile", &s.profile)?;
            let ext = path.extension().and_then(|e| e.to_str()).map(str::to_ascii_lowercase);
            if !matches!(ext.as_deref(), Some("ies" | "ldt")) {
                return Err(invalid(m, &f("profile"), format!("{} is neither an .ies nor an .ldt file", path.display())));
            }
            if !path.is_file() {
                return Err(invalid(m, &f("profile"), format!("{} is not a file", path.display())));
            }
            LightKind::Ies { path }
        }
        "lightfield" => {
            let dir = file("folder", &s.folder)?;
            if !dir.is_dir() {
                return Err(invalid(m, &f("folder"), format!("{} is not a folder", dir.display())));
            }
            LightKind::LightField { dir }
        }
        "point" => LightKind::Point { intensity_cd: intensity(s)? },
        "spot" => {
            let intensity_cd = intensity(s)?;
            let inner_deg = number(m, &f("inner_deg"), s.inner_deg, "spot")?;
            let outer_deg = number(m, &f("outer_deg"), s.outer_deg, "spot")?;
            if !(0.0 <= inner_deg && inner_deg <= outer_deg && outer_deg <= 180.0) {
                return Err(invalid(m, &f("inner_deg/outer_deg"), format!("{inner_deg}°, {outer_deg}°: need 0 ≤ inner ≤ outer ≤ 180")));
            }
            LightKind::Spot { intensity_cd, inner_deg, outer_deg }
        }
        other => return Err(invalid(m, &f("kind"), format!("'{other}' is not one of ies, lightfield, spot, point"))),
    })
}

fn instant(m: &Path, field: &str, v: &toml::Value) -> Result<Instant, SceneError> {
    match v {
        toml::Value::Integer(i) => Ok(Instant::SecondsFromStart(*i as f64)),
        toml::Value::Float(x) if x.is_finite() => Ok(Instant::SecondsFromStart(*x)),
        toml::Value::String(s) => Ok(Instant::Time(parse_time(m, field, s)?)),
        toml::Value::Datetime(d) => Ok(Instant::Time(parse_time(m, field, &d.to_string())?)),
        other => Err(invalid(m, field, format!("{other} is neither seconds from the start nor an RFC 3339 time"))),
    }
}

fn schedule(m: &Path, field: &str, v: Option<&toml::Value>) -> Result<Schedule, SceneError> {
    let list = match v {
        None => return Ok(Schedule::Always),
        Some(toml::Value::String(s)) if s == "always" => return Ok(Schedule::Always),
        Some(toml::Value::Array(list)) => list,
        Some(other) => return Err(invalid(m, field, format!("{other} is neither \"always\" nor a list of {{ on, off }} intervals"))),
    };
    let mut out = Vec::with_capacity(list.len());
    for (j, item) in list.iter().enumerate() {
        let fj = format!("{field}[{j}]");
        let table = item.as_table().ok_or_else(|| invalid(m, &fj, "must be a table { on = …, off = … }"))?;
        if let Some(k) = table.keys().find(|k| !matches!(k.as_str(), "on" | "off")) {
            return Err(invalid(m, &format!("{fj}.{k}"), "unknown field (expected on, off)"));
        }
        let on = table.get("on").map(|v| instant(m, &format!("{fj}.on"), v)).transpose()?;
        let off = table.get("off").map(|v| instant(m, &format!("{fj}.off"), v)).transpose()?;
        let backwards = match (on, off) {
            (Some(Instant::Time(a)), Some(Instant::Time(b))) => b <= a,
            (Some(Instant::SecondsFromStart(a)), Some(Instant::SecondsFromStart(b))) => b <= a,
            (None, None) => return Err(invalid(m, &fj, "give on, off or both")),
            _ => false,
        };
        if backwards {
            return Err(invalid(m, &format!("{fj}.off"), "must come after on"));
        }
        out.push((on, off));
    }
    Ok(Schedule::Intervals(out))
}

/// Most `[[lights]]` a scene may declare: what a frame's lighting carries a scale for
/// (`crate::lighting::MAX_LAMPS`, the same number). A scene with more is refused rather than
/// having its last lamps go dark without a word.
pub const MAX_LIGHTS: usize = 64;

/// Validates `[[lights]]`, naming `lights[i].field` of `scene.toml` (`m`) for the first problem.
pub(super) fn lights(within: &Within, m: &Path, specs: &[LightSpec]) -> Result<Vec<Light>, SceneError> {
    if specs.len() > MAX_LIGHTS {
        return Err(invalid(m, "lights", format!("{} lights are declared; heliar takes at most {MAX_LIGHTS} (merge distant lamps of one kind into fewer, brighter ones)", specs.len())));
    }
    let mut out = Vec::with_capacity(specs.len());
    for (i, s) in specs.iter().enumerate() {
        let f = |name: &str| format!("lights[{i}].{name}");
        let kind = kind(within, m, &f, s)?;
        let position = finite3(m, &f("position"), s.position)?;
        let aim = finite3(m, &f("aim"), s.aim)?;
        if !s.roll_deg.is_finite() {
            return Err(invalid(m, &f("roll_deg"), "must be finite"));
        }
        let world_from_lamp = world_from_lamp(aim, s.roll_deg).ok_or_else(|| invalid(m, &f("aim"), "must be a non-zero direction"))?;
        if !(s.scale.is_finite() && s.scale > 0.0) {
            return Err(invalid(m, &f("scale"), format!("{} must be a positive number", s.scale)));
        }
        let schedule = schedule(m, &f("schedule"), s.schedule.as_ref())?;
        let name = s.name.clone().unwrap_or_else(|| format!("lights[{i}]"));
        if out.iter().any(|l: &Light| l.name == name) {
            return Err(invalid(m, &f("name"), format!("'{name}' names another light too")));
        }
        out.push(Light { name, field: format!("lights[{i}]"), kind, position, world_from_lamp, scale: s.scale, schedule });
    }
    Ok(out)
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn pose_conventions() {
        // Aimed down, no roll: −Z → world −Y, +X → world +X, +Y (C90) → world −Z.
        let r = world_from_lamp(DVec3::NEG_Y, 0.0).unwrap();
        assert!((r * DVec3::NEG_Z - DVec3::NEG_Y).length() < 1e-12);
        assert!((r * DVec3::X - DVec3::X).length() < 1e-12);
        assert!((r * DVec3::Y - DVec3::NEG_Z).length() < 1e-12);
        // a 90° roll turns C0 from world +X to the old C90 (world −Z), counter-clockwise from above
        let r = world_from_lamp(DVec3::NEG_Y, 90.0).unwrap();
        assert!((r * DVec3::X - DVec3::NEG_Z).length() < 1e-12);
        // aim along +X: C0 from world −Z; the rotation stays orthonormal and right-handed
        let r = world_from_lamp(DVec3::X, 0.0).unwrap();
        assert!((r * DVec3::NEG_Z - DVec3::X).length() < 1e-12);
        assert!((r.determinant() - 1.0).abs() < 1e-12 && (r.transpose() * r - DMat3::IDENTITY).abs_diff_eq(DMat3::ZERO, 1e-12));
        assert!(world_from_lamp(DVec3::ZERO, 0.0).is_none());
    }

    #[test]
    fn schedule_intervals() {
        let m = Path::new("scene.toml");
        let v: toml::Value = toml::from_str("s = [{ on = 10.0, off = 20 }, { on = \"2024-06-21T22:00:00+02:00\" }]").unwrap();
        let s = schedule(m, "lights[0].schedule", v.get("s")).unwrap();
        let start = DateTime::parse_from_rfc3339("2024-06-21T21:00:00+02:00").unwrap();
        let at = |secs: i64| start + chrono::Duration::seconds(secs);
        assert!(!s.is_on(&at(9), &start) && s.is_on(&at(10), &start) && s.is_on(&at(19), &start) && !s.is_on(&at(20), &start));
        assert!(!s.is_on(&at(3599), &start) && s.is_on(&at(3600), &start) && s.is_on(&at(90000), &start));
        assert_eq!(schedule(m, "x", None).unwrap(), Schedule::Always);
        let bad: toml::Value = toml::from_str("s = [{ on = 20, off = 10 }]").unwrap();
        let e = schedule(m, "lights[2].schedule", bad.get("s")).unwrap_err().to_string();
        assert!(e.contains("lights[2].schedule[0].off") && e.contains("after on"), "{e}");
        let bad: toml::Value = toml::from_str("s = [{ on = \"dusk\" }]").unwrap();
        let e = schedule(m, "lights[0].schedule", bad.get("s")).unwrap_err().to_string();
        assert!(e.contains("lights[0].schedule[0].on") && e.contains("RFC 3339"), "{e}");
        let bad: toml::Value = toml::from_str("s = \"sometimes\"").unwrap();
        assert!(schedule(m, "lights[0].schedule", bad.get("s")).unwrap_err().to_string().contains("always"));
    }
}
