//! The fisheye calibration file (`calib/fisheye.toml`, documented for scene authors in
//! `scenes/README.md`): Kannala–Brandt intrinsics, the lens orientation in the world frame, and the
//! photometric response of its frames.
//!
//! Every problem is reported with the file and the field (`fisheye.toml: field \`k\`: …`);
//! unknown fields are errors.

use crate::camera::{Camera, Intrinsics, Lens};
use super::photometric::{FitReport, LogResponse, Patch, PatchRole};
use crate::io::frames::Response;
use crate::io::frames::Photometry;
use crate::camera::Pose;
use glam::DVec3;
use serde::Deserialize;
use std::path::{Path, PathBuf};

/// Errors reading a fisheye calibration.
#[derive(Debug, thiserror::Error)]
pub enum LensFileError {
    /// A file does not exist.
    #[error("{path}: file not found")]
    Missing {
        /// The file.
        path: PathBuf,
    },
    /// A file could not be read.
    #[error("{path}: {source}")]
    Read {
        /// The file.
        path: PathBuf,
        /// The OS error.
        source: std::io::Error,
    },
    /// The TOML is malformed or has a missing, unknown or mistyped field.
    #[error("{path}: {message}")]
    Parse {
        /// The file.
        path: PathBuf,
        /// The parser's message (names the field and line).
        message: String,
    },
    /// A field has a value that cannot be used.
    #[error("{path}: field `{field}`: {message}")]
    Invalid {
        /// The file.
        path: PathBuf,
        /// Dotted field name.
        field: String,
        /// What is wrong.
        message: String,
    },
}

fn invalid(path: &Path, field: &str, message: impl Into<String>) -> LensFileError {
    LensFileError::Invalid { path: path.to_owned(), field: field.to_owned(), message: message.into() }
}

fn read_text(path: &Path) -> Result<String, LensFileError> {
    std::fs::read_to_string(path).map_err(|source| match source.kind() {
        std::io::ErrorKind::NotFound => LensFileError::Missing { path: path.to_owned() },
        _ => LensFileError::Read { path: path.to_owned(), source },
    })
}

fn default_max_theta() -> f64 {
    90.0
}
fn default_kind() -> String {
    "linear".into()
}
fn one() -> f32 {
    1.0
}
fn default_saturation() -> f32 {
    0.98
}
fn default_code_max() -> f64 {
    255.0
}

/// `calib/fisheye.toml`.
#[derive(Clone, Debug, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct FisheyeFile {
    /// Image width, pixels.
    pub width: u32,
    /// Image height, pixels.
    pub height: u32,
    /// Focal length, pixels per radian.
    pub fx: f64,
    /// Focal length, pixels per radian.
    pub fy: f64,
    /// Principal point.
    pub cx: f64,
    /// Principal point.
    pub cy: f64,
    /// Kannala–Brandt `k1 … k4` (default 0: equidistant).
    #[serde(default)]
    pub k: [f64; 4],
    /// Calibrated field of view: largest angle from the optical axis, degrees (default 90).
    #[serde(default = "default_max_theta")]
    pub max_theta_deg: f64,
    /// Lens orientation in the world frame.
    pub orientation: OrientationSpec,
    /// Photometric response (default: linear HDR values, exposure 1).
    #[serde(default)]
    pub response: ResponseFile,
}

/// `[orientation]`: either `optical_axis` and `image_up`, or `rvec_camera_from_world`.
#[derive(Clone, Debug, Deserialize, Default)]
#[serde(deny_unknown_fields)]
pub struct OrientationSpec {
    /// World direction of the optical axis (camera `+Z`).
    pub optical_axis: Option<[f64; 3]>,
    /// World direction toward the top of the image (camera `−Y`).
    pub image_up: Option<[f64; 3]>,
    /// OpenCV Rodrigues vector of `camera_from_world`.
    pub rvec_camera_from_world: Option<[f64; 3]>,
}

/// `[response]`.
#[derive(Clone, Debug, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct ResponseFile {
    /// `linear | srgb | gamma | log | table`.
    #[serde(default = "default_kind")]
    pub kind: String,
    /// Camera linear value per unit scene radiance.
    #[serde(default = "one")]
    pub exposure: f32,
    /// LDR codes at or above this fraction of full scale are clipped.
    #[serde(default = "default_saturation")]
    pub saturation: f32,
    /// HDR values at or above this are clipped.
    pub hdr_clip: Option<f32>,
    /// For `gamma`.
    pub gamma: Option<f32>,
    /// For `log`: CSV of gray patches `code,luminance[,fit|check]` (relative to this file).
    pub patches: Option<String>,
    /// For `log`: the code that means full scale (255 for 8-bit frames, 65535 for 16-bit).
    #[serde(default = "default_code_max")]
    pub code_max: f64,
    /// For `log` without patches: the fitted `c = a + b·ln Y` (normalised codes).
    pub a: Option<f64>,
    /// See `a`.
    pub b: Option<f64>,
    /// For `table`: CSV with rows `r,g,b` (or one value) of relative linear exposure at evenly
    /// spaced codes from 0 to full scale, e.g. recovered from bracketed exposures.
    pub table: Option<String>,
}

impl Default for ResponseFile {
    fn default() -> Self {
        Self {
            kind: default_kind(),
            exposure: 1.0,
            saturation: default_saturation(),
            hdr_clip: None,
            gamma: None,
            patches: None,
            code_max: default_code_max(),
            a: None,
            b: None,
            table: None,
        }
    }
}

/// A loaded fisheye calibration.
#[derive(Clone, Debug)]
pub struct FisheyeCalib {
    /// The file it came from.
    pub path: PathBuf,
    /// Lens and orientation.
    pub camera: Camera,
    /// Response, exposure and clipping of its frames.
    pub photometry: Photometry,
    /// The logarithmic response and its fit, for `kind = "log"`.
    pub log_response: Option<(LogResponse, Option<FitReport>)>,
}

fn finite3(path: &Path, field: &str, v: [f64; 3]) -> Result<DVec3, LensFileError> {
    let d = DVec3::from(v);
    if d.is_finite() { Ok(d) } else { Err(invalid(path, field, "must be finite numbers")) }
}

impl FisheyeCalib {
    /// Reads and validates a calibration file.
    pub fn load(path: &Path) -> Result<Self, LensFileError> {
        let text = read_text(path)?;
        let f: FisheyeFile = toml::from_str(&text).map_err(|e| LensFileError::Parse { path: path.to_owned(), message: e.to_string() })?;
        let intrinsics = Intrinsics::kannala_brandt(f.width, f.height, f.fx, f.fy, f.cx, f.cy, f.k, f.max_theta_deg.to_radians());
        intrinsics.validate().map_err(|(field, msg)| invalid(path, field, msg))?;
        let o = &f.orientation;
        let world_from_camera = match (o.optical_axis, o.image_up, o.rvec_camera_from_world) {
            (Some(axis), Some(up), None) => {
                let (axis, up) = (finite3(path, "orientation.optical_axis", axis)?, finite3(path, "orientation.image_up", up)?);
                if axis.try_normalize().is_none() {
                    return Err(invalid(path, "orientation.optical_axis", "is zero (give the direction the lens looks along)"));
                }
                Pose::look_at(DVec3::ZERO, axis, up)
                    .ok_or_else(|| invalid(path, "orientation.image_up", "is zero or parallel to the optical axis"))?
                    .rotation
            }
            (None, None, Some(r)) => Pose::from_rvec_tvec(finite3(path, "orientation.rvec_camera_from_world", r)?, DVec3::ZERO).rotation,
            _ => {
                return Err(invalid(
                    path,
                    "orientation",
                    "give either optical_axis and image_up, or rvec_camera_from_world",
                ));
            }
        };
        let (photometry, log_response) = load_response(path, &f.response)?;
        Ok(Self { path: path.to_owned(), camera: Camera { intrinsics, pose: Pose::rotation_only(world_from_camera) }, photometry, log_response })
    }
}

type LoadedResponse = (Photometry, Option<(LogResponse, Option<FitReport>)>);

fn load_response(path: &Path, r: &ResponseFile) -> Result<LoadedResponse, LensFileError> {
    if !(r.exposure.is_finite() && r.exposure > 0.0) {
        return Err(invalid(path, "response.exposure", "must be positive"));
    }
    if !(r.saturation > 0.0 && r.saturation <= 1.0) {
        return Err(invalid(path, "response.saturation", "must be in (0, 1]"));
    }
    if r.hdr_clip.is_some_and(|c| !(c > 0.0)) {
        return Err(invalid(path, "response.hdr_clip", "must be positive"));
    }
    let dir = path.parent().unwrap_or(Path::new("."));
    let mut log = None;
    let response = match r.kind.as_str() {
        "linear" => Response::Linear,
        "srgb" => Response::Srgb,
        "gamma" => {
            let g = r.gamma.unwrap_or(2.2);
            if !(g.is_finite() && g > 0.0) {
                return Err(invalid(path, "response.gamma", "must be positive"));
            }
            Response::Gamma(g)
        }
        "log" => {
            let (lr, report) = match (&r.patches, r.a, r.b) {
                (Some(file), None, None) => {
                    if !(r.code_max.is_finite() && r.code_max > 0.0) {
                        return Err(invalid(path, "response.code_max", "must be positive"));
                    }
                    let ppath = dir.join(file);
                    let patches = read_patches(&ppath, r.code_max)?;
                    let (lr, rep) = LogResponse::fit(&patches).map_err(|m| invalid(&ppath, "rows", m))?;
                    (lr, Some(rep))
                }
                (None, Some(a), Some(b)) => {
                    if !(a.is_finite() && b.is_finite() && b > 0.0) {
                        return Err(invalid(path, "response.b", "a must be finite and b positive"));
                    }
                    (LogResponse { a, b }, None)
                }
                _ => return Err(invalid(path, "response.patches", "kind = \"log\" needs either a patches file or both a and b")),
            };
            log = Some((lr, report));
            lr.response()
        }
        "table" => {
            let file = r.table.as_deref().ok_or_else(|| invalid(path, "response.table", "kind = \"table\" needs a table file"))?;
            Response::Table(read_table(&dir.join(file))?)
        }
        other => return Err(invalid(path, "response.kind", format!("'{other}' is not one of linear, srgb, gamma, log, table"))),
    };
    Ok((Photometry { response, exposure: r.exposure, saturation: r.saturation, hdr_clip: r.hdr_clip, read_noise: crate::io::frames::ReadNoise::Unknown }, log))
}

/// Numbers of a CSV line, `None` for blank, comment and header lines.
fn csv_numbers(line: &str) -> Option<Vec<&str>> {
    let line = line.trim();
    if line.is_empty() || line.starts_with('#') || line.chars().next().is_some_and(|c| c.is_alphabetic()) {
        return None;
    }
    Some(line.split(',').map(str::trim).collect())
}

/// Reads gray patches `code,luminance[,fit|check]` (codes normalised by `code_max`).
pub fn read_patches(path: &Path, code_max: f64) -> Result<Vec<Patch>, LensFileError> {
    let text = read_text(path)?;
    let mut out = Vec::new();
    for (i, line) in text.lines().enumerate() {
        let Some(f) = csv_numbers(line) else { continue };
        let field = format!("line {}", i + 1);
        let num = |s: &str| s.parse::<f64>().ok().filter(|v| v.is_finite());
        let (code, lum) = match (f.first().and_then(|s| num(s)), f.get(1).and_then(|s| num(s))) {
            (Some(c), Some(l)) => (c, l),
            _ => return Err(invalid(path, &field, "expected `code,luminance[,fit|check]`")),
        };
        let role = match f.get(2).copied() {
            None | Some("") | Some("fit") => PatchRole::Fit,
            Some("check") => PatchRole::Check,
            Some(other) => return Err(invalid(path, &field, format!("role '{other}' is not fit or check"))),
        };
        out.push(Patch { code: code / code_max, luminance: lum, role });
    }
    Ok(out)
}

fn read_table(path: &Path) -> Result<Vec<[f32; 3]>, LensFileError> {
    let text = read_text(path)?;
    let mut rows = Vec::new();
    for (i, line) in text.lines().enumerate() {
        let Some(f) = csv_numbers(line) else { continue };
        let vals: Result<Vec<f32>, _> = f.iter().map(|s| s.parse::<f32>()).collect();
        let row = match vals.as_deref() {
            Ok([v]) => [*v; 3],
            Ok([r, g, b]) => [*r, *g, *b],
            _ => return Err(invalid(path, &format!("line {}", i + 1), "expected 1 or 3 comma-separated numbers")),
        };
        if row.iter().any(|v| !(v.is_finite() && *v >= 0.0)) {
            return Err(invalid(path, &format!("line {}", i + 1), "values must be finite and non-negative"));
        }
        rows.push(row);
    }
    if rows.len() < 2 {
        return Err(invalid(path, "rows", "a response table needs at least 2 rows"));
    }
    for c in 0..3 {
        if rows.windows(2).any(|w| w[1][c] < w[0][c]) {
            return Err(invalid(path, "rows", format!("channel {c} is not monotone non-decreasing")));
        }
    }
    Ok(rows)
}

/// The text of a calibration file for `camera` with a linear HDR response (what the generator
/// writes).
pub fn fisheye_toml(camera: &Camera, comment: &str) -> String {
    let l = &camera.intrinsics;
    let (k, max_theta) = match &l.lens {
        Lens::KannalaBrandt(kb) => (kb.k, kb.max_theta),
        Lens::BrownConrady(_) => ([0.0; 4], std::f64::consts::FRAC_PI_2),
    };
    let axis = camera.pose.rotation.z_axis;
    let up = -camera.pose.rotation.y_axis;
    format!(
        "# {comment}\n# Kannala–Brandt fisheye calibration (format: scenes/README.md, \"Fisheye calibration\").\n\
         width = {}\nheight = {}\nfx = {}\nfy = {}\ncx = {}\ncy = {}\nk = [{}, {}, {}, {}]\nmax_theta_deg = {}\n\n\
         [orientation]\noptical_axis = [{}, {}, {}]\nimage_up = [{}, {}, {}]\n\n[response]\nkind = \"linear\"\nexposure = 1.0\n",
        l.width, l.height, l.fx, l.fy, l.cx, l.cy, k[0], k[1], k[2], k[3], max_theta.to_degrees(),
        axis.x, axis.y, axis.z, up.x, up.y, up.z
    )
}

#[cfg(test)]
mod tests {
    use super::*;

    fn dir(name: &str) -> PathBuf {
        let d = std::env::temp_dir().join(format!("heliar-calib-{name}-{}", std::process::id()));
        std::fs::create_dir_all(&d).unwrap();
        d
    }

    #[test]
    fn written_calibration_loads_back() {
        let d = dir("rt");
        let cam = Camera::equidistant_up(256, 180.0);
        let p = d.join("fisheye.toml");
        std::fs::write(&p, fisheye_toml(&cam, "test")).unwrap();
        let c = FisheyeCalib::load(&p).unwrap();
        assert!((c.camera.intrinsics.fx - cam.intrinsics.fx).abs() < 1e-9);
        let max_theta = |c: &Camera| match &c.intrinsics.lens {
            Lens::KannalaBrandt(kb) => kb.max_theta,
            Lens::BrownConrady(_) => f64::NAN,
        };
        assert!((max_theta(&c.camera) - max_theta(&cam)).abs() < 1e-12);
        assert!(c.camera.pose.rotation.abs_diff_eq(cam.pose.rotation, 1e-12));
        assert_eq!(c.photometry.response, Response::Linear);
        std::fs::remove_dir_all(&d).ok();
    }

    #[test]
    fn errors_name_the_file_and_field() {
        let d = dir("err");
        let p = d.join("fisheye.toml");
        let base = "width = 64\nheight = 64\nfx = 20.0\nfy = 20.0\ncx = 31.5\ncy = 31.5\n";
        let cases: &[(&str, &str)] = &[
            ("[orientation]\noptical_axis = [0.0, 1.0, 0.0]\n", "orientation"),
            ("[orientation]\noptical_axis = [0.0, 1.0, 0.0]\nimage_up = [0.0, 2.0, 0.0]\n", "orientation.image_up"),
            ("[orientation]\noptical_axis = [0.0, 0.0, 0.0]\nimage_up = [0.0, 0.0, -1.0]\n", "orientation.optical_axis"),
            ("k = [-0.5, 0.0, 0.0, 0.0]\n[orientation]\nrvec_camera_from_world = [0.0, 0.0, 0.0]\n", "`k`"),
            ("[orientation]\nrvec_camera_from_world = [0.0, 0.0, 0.0]\n[response]\nkind = \"log\"\n", "response.patches"),
            ("[orientation]\nrvec_camera_from_world = [0.0, 0.0, 0.0]\n[response]\nkind = \"magic\"\n", "response.kind"),
            ("[orientation]\nrvec_camera_from_world = [0.0, 0.0, 0.0]\n[response]\nkind = \"log\"\npatches = \"p.csv\"\n", "p.csv"),
            ("[orientation]\nrvec_camera_from_world = [0.0, 0.0, 0.0]\nbogus = 1\n", "bogus"),
        ];
        for (extra, want) in cases {
            std::fs::write(&p, format!("{base}{extra}")).unwrap();
            let e = FisheyeCalib::load(&p).unwrap_err().to_string();
            assert!(e.contains("fisheye.toml") || e.contains("p.csv"), "{e}");
            assert!(e.contains(want), "want {want}: {e}");
        }
        // A log response fitted from patches, with a bad row named by line.
        std::fs::write(d.join("p.csv"), "code,luminance,role\n30,0.1\n90,10\n150,1000\n200,x\n").unwrap();
        std::fs::write(&p, format!("{base}[orientation]\nrvec_camera_from_world = [0.0, 0.0, 0.0]\n[response]\nkind = \"log\"\npatches = \"p.csv\"\n")).unwrap();
        let e = FisheyeCalib::load(&p).unwrap_err().to_string();
        assert!(e.contains("p.csv") && e.contains("line 5"), "{e}");
        std::fs::write(d.join("p.csv"), "code,luminance,role\n30,0.1\n90,10\n150,1000\n120,100,check\n").unwrap();
        let c = FisheyeCalib::load(&p).unwrap();
        let (lr, rep) = c.log_response.unwrap();
        assert!(lr.b > 0.0 && rep.unwrap().check_max_rel_error.is_some());
        std::fs::remove_dir_all(&d).ok();
    }
}
