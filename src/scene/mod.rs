//! Scene folders: the manifest, the real proxy and virtual objects (glTF), the calibrated camera,
//! the place and its geographic frame, frame sequences and their times.
//!
//! The format is documented for scene authors in `scenes/README.md`. [`Scene::load`] validates
//! everything it reads and names the file and field of the first problem it finds.

pub mod gltf;
pub mod lights;
pub mod limits;
mod load;
mod manifest;
pub mod motion;
mod motion_load;
mod paths;
pub mod settings;

pub use lights::{Light, LightKind, LightSpec, Schedule};
pub use paths::LoadOptions;
use paths::Within;
pub use manifest::{AlbedoSource, CameraFile, EnvMapSpec, GridSpec, KeyTimeValue, KeyframeSpec, Manifest, MotionSpec, PoseSpec, READ_NOISE_AUTO, ReadNoiseSpec, ResponseSpec, SequenceSpec, TimeSpec, VirtualObjectSpec};

use settings::{BakeConfig, EstimatorConfig};
use crate::geometry::Mesh;
use crate::io::IoError;
use crate::io::frames::Photometry;
use crate::io::frames::Response;
use crate::sun::{GeoFrame, Observer};
use crate::camera::{Camera, Intrinsics, Pose};
use chrono::{DateTime, FixedOffset};
use glam::DVec3;
use std::path::{Path, PathBuf};

/// Name of the manifest file inside a scene folder.
pub const MANIFEST_FILE: &str = "scene.toml";

/// Errors loading a scene.
#[derive(Debug, thiserror::Error)]
pub enum SceneError {
    /// A file the scene refers to does not exist.
    #[error("{path}: file not found")]
    Missing {
        /// The missing file.
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
    /// A TOML file is malformed or has a missing, unknown or mistyped field.
    #[error("{path}: {message}")]
    Parse {
        /// The file.
        path: PathBuf,
        /// The parser's message, which names the field and line.
        message: String,
    },
    /// A field has a value heliar cannot use.
    #[error("{path}: field `{field}`: {message}")]
    Invalid {
        /// The file.
        path: PathBuf,
        /// Dotted field name, e.g. `place.latitude_deg`.
        field: String,
        /// What is wrong.
        message: String,
    },
    /// A glTF file is corrupt or unusable.
    #[error("{path}: glTF: {message}")]
    Gltf {
        /// The file.
        path: PathBuf,
        /// What is wrong.
        message: String,
    },
    /// An image or frame file problem.
    #[error(transparent)]
    Io(#[from] IoError),
}

/// Known lighting of one frame (from a scene generator or a measurement).
#[derive(Clone, Copy, Debug, PartialEq, serde::Serialize)]
pub struct Truth {
    /// Sun irradiance on a surface facing the sun (RGB).
    pub pd: [f64; 3],
    /// Sky irradiance on an unoccluded horizontal surface (RGB).
    pub pa: [f64; 3],
}

/// A sequence of frames with their times.
#[derive(Clone, Debug)]
pub struct Sequence {
    /// Name from the manifest.
    pub name: String,
    /// Frame files in order.
    pub files: Vec<PathBuf>,
    /// Capture time of each frame.
    pub times: Vec<DateTime<FixedOffset>>,
    /// Photometric calibration (the camera's, with the sequence's exposure).
    pub photometry: Photometry,
    /// Known lighting per frame, when the sequence has a truth file.
    pub truth: Option<Vec<Truth>>,
}

/// A placed virtual object.
#[derive(Clone, Debug)]
pub struct VirtualObject {
    /// Source file.
    pub path: PathBuf,
    /// Its triangles in world coordinates (for a moving object, where it stands at its
    /// motion's first key).
    pub mesh: Mesh,
    /// How it moves (`None`: it stands still).
    pub motion: Option<motion::ObjectMotion>,
}

impl VirtualObject {
    /// True when the object has a motion.
    pub fn moves(&self) -> bool {
        self.motion.is_some()
    }
}

/// A loaded and validated scene folder.
#[derive(Clone, Debug)]
pub struct Scene {
    /// The scene folder.
    pub root: PathBuf,
    /// The manifest as written.
    pub manifest: Manifest,
    /// Where the scene is on Earth.
    pub observer: Observer,
    /// North, east and up in the world frame.
    pub geo: GeoFrame,
    /// The calibrated camera.
    pub camera: Camera,
    /// The camera file (`calib/camera.toml`), for messages.
    pub camera_path: PathBuf,
    /// The camera's own response and exposure (sequences may override the exposure): how
    /// footage that is not one of the scene's sequences (video files, cameras) is read.
    pub photometry: Photometry,
    /// The real proxy geometry.
    pub proxy: Mesh,
    /// Notes from loading the proxy.
    pub proxy_notes: gltf::LoadNotes,
    /// Virtual objects.
    pub virtual_objects: Vec<VirtualObject>,
    /// Frame sequences.
    pub sequences: Vec<Sequence>,
    /// Estimator settings.
    pub estimator: EstimatorConfig,
    /// Bake, relighting and irradiance-volume settings.
    pub bake: BakeConfig,
    /// Real light sources (`[[lights]]`), validated; their models are built by `lamps::model`.
    pub lights: Vec<Light>,
}

fn read_toml<T: serde::de::DeserializeOwned>(path: &Path) -> Result<T, SceneError> {
    let text = std::fs::read_to_string(path).map_err(|source| match source.kind() {
        std::io::ErrorKind::NotFound => SceneError::Missing { path: path.to_owned() },
        _ => SceneError::Read { path: path.to_owned(), source },
    })?;
    toml::from_str(&text).map_err(|e| SceneError::Parse { path: path.to_owned(), message: e.to_string() })
}

fn invalid(path: &Path, field: &str, message: impl Into<String>) -> SceneError {
    SceneError::Invalid { path: path.to_owned(), field: field.to_owned(), message: message.into() }
}

fn finite3(path: &Path, field: &str, v: [f64; 3]) -> Result<DVec3, SceneError> {
    let d = DVec3::from(v);
    if d.is_finite() { Ok(d) } else { Err(invalid(path, field, "must be finite numbers")) }
}

/// Parses an RFC 3339 time; the field name goes into the error.
pub fn parse_time(path: &Path, field: &str, s: &str) -> Result<DateTime<FixedOffset>, SceneError> {
    DateTime::parse_from_rfc3339(s.trim())
        .map_err(|e| invalid(path, field, format!("'{s}' is not an RFC 3339 time with offset ({e})")))
}

fn load_camera(within: &Within, manifest_path: &Path, file: &str) -> Result<(Camera, CameraFile, PathBuf), SceneError> {
    let path = within.join(manifest_path, "camera.file", file)?;
    if !path.exists() {
        return Err(invalid(manifest_path, "camera.file", format!("{} does not exist", path.display())));
    }
    let cf: CameraFile = read_toml(&path)?;
    let p = path.as_path();
    // Sizes, focal lengths, principal point, and a distortion that is a lens over the whole image.
    let intrinsics = Intrinsics::brown_conrady(cf.width, cf.height, cf.fx, cf.fy, cf.cx, cf.cy, cf.distortion);
    intrinsics.validate().map_err(|(field, message)| invalid(p, field, message))?;
    let pose = match &cf.pose {
        PoseSpec::LookAt { position, look_at, up } => {
            let (pos, tgt, up) = (finite3(p, "pose.position", *position)?, finite3(p, "pose.look_at", *look_at)?, finite3(p, "pose.up", *up)?);
            Pose::look_at(pos, tgt, up)
                .ok_or_else(|| invalid(p, "pose.look_at", "the view direction is zero or parallel to `up`"))?
        }
        PoseSpec::OpenCv { rvec_camera_from_world, tvec_camera_from_world } => Pose::from_rvec_tvec(
            finite3(p, "pose.rvec_camera_from_world", *rvec_camera_from_world)?,
            finite3(p, "pose.tvec_camera_from_world", *tvec_camera_from_world)?,
        ),
    };
    Ok((Camera { intrinsics, pose }, cf, path))
}

fn load_response(within: &Within, camera_path: &Path, spec: &ResponseSpec) -> Result<Response, SceneError> {
    Ok(match spec.kind.as_str() {
        "srgb" => Response::Srgb,
        "linear" => Response::Linear,
        "gamma" => {
            let g = spec.gamma.unwrap_or(2.2);
            if !(g.is_finite() && g > 0.0) {
                return Err(invalid(camera_path, "response.gamma", "must be a positive number"));
            }
            Response::Gamma(g)
        }
        "table" => {
            let file = spec.table.as_deref().ok_or_else(|| invalid(camera_path, "response.table", "kind = \"table\" needs a table file"))?;
            let path = within.join(camera_path, "response.table", file)?;
            let text = std::fs::read_to_string(&path).map_err(|source| match source.kind() {
                std::io::ErrorKind::NotFound => SceneError::Missing { path: path.clone() },
                _ => SceneError::Read { path: path.clone(), source },
            })?;
            let mut rows = Vec::new();
            for (i, line) in text.lines().enumerate() {
                let line = line.trim();
                if line.is_empty() || line.starts_with('#') || line.chars().next().is_some_and(|c| c.is_alphabetic()) {
                    continue;
                }
                let vals: Result<Vec<f32>, _> = line.split(',').map(|s| s.trim().parse::<f32>()).collect();
                let row = match vals.as_deref() {
                    Ok([v]) => [*v; 3],
                    Ok([r, g, b]) => [*r, *g, *b],
                    _ => return Err(invalid(&path, &format!("line {}", i + 1), "expected 1 or 3 comma-separated numbers")),
                };
                if row.iter().any(|v| !v.is_finite() || *v < 0.0) {
                    return Err(invalid(&path, &format!("line {}", i + 1), "values must be finite and non-negative"));
                }
                rows.push(row);
            }
            if rows.len() < 2 {
                return Err(invalid(&path, "rows", "a response table needs at least 2 rows"));
            }
            for c in 0..3 {
                if rows.windows(2).any(|w| w[1][c] < w[0][c]) {
                    return Err(invalid(&path, "rows", format!("channel {c} is not monotone non-decreasing")));
                }
            }
            Response::Table(rows)
        }
        other => {
            return Err(invalid(camera_path, "response.kind", format!("'{other}' is not one of srgb, linear, gamma, table")));
        }
    })
}

fn load_truth(path: &Path, n: usize) -> Result<Vec<Truth>, SceneError> {
    let text = std::fs::read_to_string(path).map_err(|source| match source.kind() {
        std::io::ErrorKind::NotFound => SceneError::Missing { path: path.to_owned() },
        _ => SceneError::Read { path: path.to_owned(), source },
    })?;
    let mut lines = text.lines().filter(|l| !l.trim().is_empty());
    let header: Vec<&str> = lines.next().unwrap_or("").split(',').map(str::trim).collect();
    let col = |name: &str| header.iter().position(|h| *h == name).ok_or_else(|| invalid(path, name, "column missing from the header"));
    let cols: Vec<usize> = ["pd_r", "pd_g", "pd_b", "pa_r", "pa_g", "pa_b"].iter().map(|c| col(c)).collect::<Result<_, _>>()?;
    let mut out = Vec::new();
    for (i, line) in lines.enumerate() {
        let f: Vec<&str> = line.split(',').map(str::trim).collect();
        let mut v = [0.0f64; 6];
        for (k, &c) in cols.iter().enumerate() {
            v[k] = f.get(c).and_then(|s| s.parse().ok()).filter(|x: &f64| x.is_finite()).ok_or_else(|| {
                invalid(path, &format!("row {} column {}", i + 2, header[c]), "not a finite number")
            })?;
        }
        out.push(Truth { pd: [v[0], v[1], v[2]], pa: [v[3], v[4], v[5]] });
    }
    if out.len() != n {
        return Err(invalid(path, "rows", format!("{} rows but the sequence has {n} frames", out.len())));
    }
    Ok(out)
}

impl Scene {
    /// Loads and validates the scene folder `root` (which holds `scene.toml`).
    pub fn load(root: &Path) -> Result<Scene, SceneError> {
        Self::load_with(root, &LoadOptions::default())
    }

    /// [`Scene::load`] with options (files outside the scene folder).
    pub fn load_with(root: &Path, options: &LoadOptions) -> Result<Scene, SceneError> {
        let within = Within::new(root, options);
        let mpath = root.join(MANIFEST_FILE);
        if !root.is_dir() {
            return Err(SceneError::Missing { path: root.to_owned() });
        }
        let manifest: Manifest = read_toml(&mpath)?;
        let m = &mpath;

        let (observer, geo) = load::place(m, &manifest)?;

        // Camera.
        let (camera, camera_file, camera_path) = load_camera(&within, m, &manifest.camera.file)?;
        let response = load_response(&within, &camera_path, &camera_file.response)?;
        let rs = &camera_file.response;
        load::check_response(&camera_path, rs)?;

        let (proxy, proxy_notes) = load::proxy(&within, m, &manifest)?;
        let virtual_objects = load::virtual_objects(&within, m, &manifest)?;
        load::check_envmap_and_grid(&within, m, &manifest)?;
        let sequences = load::sequences(&within, m, &manifest, &response, rs)?;
        let estimator = manifest.estimator.clone().unwrap_or_default();
        estimator.validate().map_err(|(f, msg)| invalid(m, &format!("estimator.{f}"), msg))?;
        let bake = manifest.bake.clone().unwrap_or_default();
        bake.validate().map_err(|(f, msg)| invalid(m, &format!("bake.{f}"), msg))?;
        load::check_probe_budget(m, &manifest, &virtual_objects, &bake)?;
        let lights = lights::lights(&within, m, &manifest.lights)?;

        Ok(Scene {
            root: root.to_owned(),
            manifest,
            observer,
            geo,
            camera,
            photometry: Photometry { response: response.clone(), exposure: rs.exposure, saturation: rs.saturation, hdr_clip: rs.hdr_clip, read_noise: rs.read_noise_setting().unwrap_or(crate::io::frames::ReadNoise::Unknown) },
            camera_path: camera_path.clone(),
            proxy,
            proxy_notes,
            virtual_objects,
            sequences,
            estimator,
            bake,
            lights,
        })
    }

    /// The sequence called `name`, or the first one.
    pub fn sequence(&self, name: Option<&str>) -> Option<&Sequence> {
        match name {
            Some(n) => self.sequences.iter().find(|s| s.name == n),
            None => self.sequences.first(),
        }
    }
}
