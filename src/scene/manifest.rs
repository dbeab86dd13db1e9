//! The serde shape of `scene.toml` and `calib/camera.toml` (documented in `scenes/README.md`).

use super::{SceneError, invalid, parse_time};
use super::settings::{BakeConfig, EstimatorConfig};
use chrono::{DateTime, FixedOffset};
use serde::{Deserialize, Serialize};
use std::path::Path;

/// A time written either as a TOML string or a TOML offset date-time.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
#[serde(untagged)]
pub enum TimeValue {
    /// `"2024-06-21T14:00:00+02:00"`
    Text(String),
    /// `2024-06-21T14:00:00+02:00` (unquoted)
    Toml(toml::value::Datetime),
}

impl std::fmt::Display for TimeValue {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        match self {
            TimeValue::Text(s) => f.write_str(s),
            TimeValue::Toml(d) => write!(f, "{d}"),
        }
    }
}

/// `scene.toml`.
#[derive(Clone, Debug, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct Manifest {
    /// Scene name.
    pub name: String,
    /// Free text.
    #[serde(default)]
    pub description: String,
    /// Where the scene is.
    pub place: PlaceSpec,
    /// The real proxy.
    pub proxy: ProxySpec,
    /// The camera calibration file.
    pub camera: CameraRef,
    /// Virtual objects to insert.
    #[serde(default)]
    pub virtual_objects: Vec<VirtualObjectSpec>,
    /// The HDR environment map.
    pub envmap: Option<EnvMapSpec>,
    /// The irradiance-volume grid.
    pub irradiance: Option<GridSpec>,
    /// Frame sequences.
    #[serde(default)]
    pub sequences: Vec<SequenceSpec>,
    /// Estimator settings (defaults when absent).
    pub estimator: Option<EstimatorConfig>,
    /// Bake, relighting and irradiance-volume settings (defaults when absent).
    pub bake: Option<BakeConfig>,
    /// Real light sources (`scene::lights`).
    #[serde(default, skip_serializing_if = "Vec::is_empty")]
    pub lights: Vec<super::lights::LightSpec>,
}

fn default_north() -> [f64; 3] {
    [0.0, 0.0, -1.0]
}
fn default_pressure() -> f64 {
    crate::sun::DEFAULT_PRESSURE_MBAR
}
fn default_temperature() -> f64 {
    crate::sun::DEFAULT_TEMPERATURE_C
}

/// `[place]`.
#[derive(Clone, Debug, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct PlaceSpec {
    /// Degrees, positive north.
    pub latitude_deg: f64,
    /// Degrees, positive east.
    pub longitude_deg: f64,
    /// Metres above sea level.
    #[serde(default)]
    pub elevation_m: f64,
    /// World-frame direction of geographic north (horizontal), default `[0, 0, -1]`.
    #[serde(default = "default_north")]
    pub north: [f64; 3],
    /// Air pressure for refraction.
    #[serde(default = "default_pressure")]
    pub pressure_mbar: f64,
    /// Air temperature for refraction.
    #[serde(default = "default_temperature")]
    pub temperature_c: f64,
    /// ΔT = TT − UT1 in seconds (estimated when absent).
    pub delta_t_s: Option<f64>,
}

/// `[proxy]`.
#[derive(Clone, Debug, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct ProxySpec {
    /// glTF file of the real proxy, relative to the scene folder.
    pub file: String,
    /// Node names to mark as diffuse estimation surfaces, besides those marked in the glTF extras.
    #[serde(default)]
    pub diffuse_nodes: Vec<String>,
    /// Node names that are *not* diffuse estimation surfaces although the glTF extras mark them
    /// (how `heliar-calib mark --unmark` overrides the extras without editing the proxy).
    #[serde(default, skip_serializing_if = "Vec::is_empty")]
    pub not_diffuse_nodes: Vec<String>,
}

/// `[camera]`.
#[derive(Clone, Debug, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct CameraRef {
    /// Camera calibration file, relative to the scene folder (e.g. `calib/camera.toml`).
    pub file: String,
}

fn one() -> f64 {
    1.0
}

/// `[[virtual_objects]]`.
#[derive(Clone, Debug, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct VirtualObjectSpec {
    /// glTF file, relative to the scene folder.
    pub file: String,
    /// World position of the object's origin, metres.
    #[serde(default)]
    pub translation: [f64; 3],
    /// Rotation about +Y, degrees (counter-clockwise seen from above).
    #[serde(default)]
    pub rotation_y_deg: f64,
    /// Uniform scale.
    #[serde(default = "one")]
    pub scale: f64,
    /// How the object moves over the sequence (absent: it stands still).
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub motion: Option<MotionSpec>,
}

/// `[virtual_objects.motion]`: keyframes in the manifest, or a glTF node animation (one of the
/// two). See `super::motion` for how a pose is found between keys.
#[derive(Clone, Debug, Default, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct MotionSpec {
    /// Keyframes, in increasing time.
    #[serde(default, skip_serializing_if = "Vec::is_empty")]
    pub keyframes: Vec<KeyframeSpec>,
    /// A glTF file whose node animation moves the object, relative to the scene folder (it may
    /// be the object's own file).
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub gltf: Option<String>,
    /// The animation's name in that file (default: its first animation).
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub animation: Option<String>,
    /// The animated node's name (default: the node the animation's first channel targets).
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub node: Option<String>,
}

/// One keyframe of `[[virtual_objects.motion.keyframes]]`.
#[derive(Clone, Debug, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct KeyframeSpec {
    /// Seconds from the sequence's first frame, or an RFC 3339 time (one kind per motion).
    pub time: KeyTimeValue,
    /// World position of the object's origin at this key, metres.
    pub translation: [f64; 3],
    /// Rotation about +Y at this key, degrees.
    #[serde(default)]
    pub rotation_y_deg: f64,
}

/// A keyframe's time as written.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
#[serde(untagged)]
pub enum KeyTimeValue {
    /// Seconds from the sequence start.
    Seconds(f64),
    /// An RFC 3339 time (quoted or a TOML date-time).
    Time(TimeValue),
}

/// `[envmap]`.
#[derive(Clone, Debug, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct EnvMapSpec {
    /// Equirectangular OpenEXR file, relative to the scene folder. Required unless
    /// `albedo = "gltf"`.
    pub file: Option<String>,
    /// World position where it was captured (or, without a file, the centre of the baked maps).
    pub capture_center: [f64; 3],
    /// When it was captured (RFC 3339 with offset).
    pub capture_time: TimeValue,
    /// Where the albedo map comes from: `inverse` rendering of the captured map (default), or the
    /// proxy's glTF base colour (for scenes without a trusted HDRI).
    #[serde(default)]
    pub albedo: AlbedoSource,
    /// Size of the baked maps `[width, height]` when there is no file (default `[256, 128]`).
    pub resolution: Option<[u32; 2]>,
    /// `Pd` at capture when it is known (measured); otherwise the estimator finds it on the map.
    pub capture_pd: Option<[f64; 3]>,
    /// `Pa` at capture when it is known; give both or neither.
    pub capture_pa: Option<[f64; 3]>,
}

/// Source of the albedo environment map.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq, Serialize, Deserialize)]
#[serde(rename_all = "snake_case")]
pub enum AlbedoSource {
    /// `ρ = π·L / (c·Pa + (s·max(n·l,0) + b)·Pd)` from the captured map (Jensen §4.1).
    #[default]
    Inverse,
    /// The proxy's base colour.
    Gltf,
}

/// `[irradiance]`.
#[derive(Clone, Debug, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct GridSpec {
    /// Lower corner of the region where virtual objects may stand, world metres.
    pub min: [f64; 3],
    /// Upper corner.
    pub max: [f64; 3],
    /// Probe spacing, metres.
    pub spacing_m: f64,
}

/// Frame times: either `start` + `fps` or an explicit `times` list.
#[derive(Clone, Debug, Default)]
pub struct TimeSpec {
    /// Time of the first frame.
    pub start: Option<TimeValue>,
    /// Frames per second.
    pub fps: Option<f64>,
    /// One time per frame.
    pub times: Option<Vec<TimeValue>>,
}

impl TimeSpec {
    /// The time of each of `n` frames.
    pub fn frame_times(&self, path: &Path, field: &str, n: usize) -> Result<Vec<DateTime<FixedOffset>>, SceneError> {
        match (&self.times, &self.start, self.fps) {
            (Some(list), None, None) => {
                if list.len() != n {
                    return Err(invalid(path, field, format!("{} times listed for {n} frames", list.len())));
                }
                list.iter().enumerate().map(|(i, t)| parse_time(path, &format!("{field}[{i}]"), &t.to_string())).collect()
            }
            (None, Some(start), Some(fps)) => {
                if !(fps.is_finite() && fps > 0.0) {
                    return Err(invalid(path, field, format!("fps = {fps} must be positive")));
                }
                let t0 = parse_time(path, field, &start.to_string())?;
                Ok((0..n)
                    .map(|i| t0 + chrono::Duration::nanoseconds((i as f64 / fps * 1e9).round() as i64))
                    .collect())
            }
            _ => Err(invalid(path, field, "give either `times = [...]` or both `start` and `fps`")),
        }
    }
}

/// `[[sequences]]`.
#[derive(Clone, Debug, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct SequenceSpec {
    /// Name used on the command line (`--sequence`).
    pub name: String,
    /// Folder of `.exr`/`.png` frames (sorted by name), relative to the scene folder.
    pub dir: String,
    /// Time of the first frame (with `fps`).
    pub start: Option<TimeValue>,
    /// Frames per second (with `start`).
    pub fps: Option<f64>,
    /// One time per frame (instead of `start` and `fps`).
    pub times: Option<Vec<TimeValue>>,
    /// Exposure of this sequence (overrides the camera file's `response.exposure`).
    pub exposure: Option<f32>,
    /// CSV of known lighting per frame (`frame,time,pd_r,pd_g,pd_b,pa_r,pa_g,pa_b`).
    pub truth: Option<String>,
}

impl SequenceSpec {
    /// The timing fields.
    pub fn time_spec(&self) -> TimeSpec {
        TimeSpec { start: self.start.clone(), fps: self.fps, times: self.times.clone() }
    }
}

/// `calib/camera.toml`.
#[derive(Clone, Debug, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct CameraFile {
    /// Image width, pixels.
    pub width: u32,
    /// Image height, pixels.
    pub height: u32,
    /// Focal length, pixels.
    pub fx: f64,
    /// Focal length, pixels.
    pub fy: f64,
    /// Principal point, pixels (OpenCV convention).
    pub cx: f64,
    /// Principal point, pixels.
    pub cy: f64,
    /// Brown–Conrady `[k1, k2, p1, p2, k3]`.
    #[serde(default)]
    pub distortion: [f64; 5],
    /// Camera pose.
    pub pose: PoseSpec,
    /// Photometric response.
    #[serde(default)]
    pub response: ResponseSpec,
}

/// `[pose]`: look-at form or OpenCV `solvePnP` form.
#[derive(Clone, Debug, Serialize, Deserialize)]
#[serde(untagged, deny_unknown_fields)]
pub enum PoseSpec {
    /// A camera at `position` looking at `look_at`.
    LookAt {
        /// Camera centre, world.
        position: [f64; 3],
        /// A world point on the optical axis.
        look_at: [f64; 3],
        /// World direction that appears up in the image.
        #[serde(default = "up")]
        up: [f64; 3],
    },
    /// `camera_from_world` as OpenCV's Rodrigues vector and translation.
    OpenCv {
        /// Rodrigues rotation vector.
        rvec_camera_from_world: [f64; 3],
        /// Translation.
        tvec_camera_from_world: [f64; 3],
    },
}

fn up() -> [f64; 3] {
    [0.0, 1.0, 0.0]
}

fn srgb() -> String {
    "srgb".into()
}
fn sat() -> f32 {
    0.98
}
fn exposure_one() -> f32 {
    1.0
}

/// `[response]`.
#[derive(Clone, Debug, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct ResponseSpec {
    /// `srgb` (default), `linear`, `gamma` or `table`.
    #[serde(default = "srgb")]
    pub kind: String,
    /// Exponent for `kind = "gamma"`.
    pub gamma: Option<f32>,
    /// CSV file for `kind = "table"`.
    pub table: Option<String>,
    /// Camera linear value per unit scene radiance.
    #[serde(default = "exposure_one")]
    pub exposure: f32,
    /// LDR codes at or above this fraction of full scale count as clipped.
    #[serde(default = "sat")]
    pub saturation: f32,
    /// HDR values at or above this count as clipped (default: 65504, the half-float maximum).
    pub hdr_clip: Option<f32>,
    /// Standard deviation of the sensor's read noise in linear camera units (after the response
    /// curve, before the exposure), or `"auto"`: measured on each frame; absent: unknown (the
    /// estimator weights rows by their level only while the sun is up, and measures the read
    /// noise on the frame at dusk and night: [`crate::io::frames::ReadNoise::Unknown`]).
    pub read_noise: Option<ReadNoiseSpec>,
}

/// `response.read_noise` as written: a number or a word (only `"auto"` is valid).
#[derive(Clone, Debug, Serialize, Deserialize)]
#[serde(untagged)]
pub enum ReadNoiseSpec {
    /// A standard deviation in linear camera units.
    Value(f32),
    /// A word: `"auto"`.
    Word(String),
}

/// The word that asks for the read noise measured on the frames.
pub const READ_NOISE_AUTO: &str = "auto";

impl ResponseSpec {
    /// The read noise setting; `None` for a bad value (a word other than `"auto"`, a negative or
    /// non-finite number: `load::check_response` says which).
    pub fn read_noise_setting(&self) -> Option<crate::io::frames::ReadNoise> {
        use crate::io::frames::ReadNoise;
        match &self.read_noise {
            None => Some(ReadNoise::Unknown),
            Some(ReadNoiseSpec::Value(v)) if v.is_finite() && *v >= 0.0 => Some(ReadNoise::Given(*v)),
            Some(ReadNoiseSpec::Word(w)) if w == READ_NOISE_AUTO => Some(ReadNoise::Auto),
            Some(_) => None,
        }
    }
}

impl Default for ResponseSpec {
    fn default() -> Self {
        Self { kind: srgb(), gamma: None, table: None, exposure: 1.0, saturation: sat(), hdr_clip: None, read_noise: None }
    }
}
