//! Synthetic worlds and frames for the estimator tests.
//!
//! Frames are rendered with the estimator's own model, `ρ/π·(c·Pa + (s·cos + b)·Pd)`, using
//! independent Monte Carlo integrals (more paths, other seeds) and 1% multiplicative noise. The
//! courtyard test uses the independently path-traced bundled scene instead.

#![allow(dead_code)]

use chrono::{DateTime, Duration, FixedOffset};
use glam::{DVec3, Vec3};
use heliar::estimate::{EstimatorConfig, Estimator};
use heliar::geometry::ambient::{TransportQuality, transport};
use heliar::geometry::raycast::RayScene;
use heliar::geometry::{Material, Mesh};
use heliar::io::frames::{Frame, FrameData};
use heliar::io::image::LinearImage;
use heliar::camera::{Camera, Intrinsics, Pose};
use heliar::sun::{GeoFrame, Observer, sun_position};
use rand::{Rng, SeedableRng, rngs::SmallRng};
use std::f32::consts::PI;
use std::sync::Arc;

pub const W: u32 = 128;
pub const H: u32 = 96;

pub fn observer() -> Observer {
    Observer::new(57.0488, 9.9217, 8.0)
}

pub fn t(s: &str) -> DateTime<FixedOffset> {
    DateTime::parse_from_rfc3339(s).expect("test time")
}

/// Afternoon of 2024-06-21 in Aalborg: apparent elevation ≈ 49°.
pub fn afternoon() -> DateTime<FixedOffset> {
    t("2024-06-21T15:30:00+02:00")
}

/// The first time after noon of 2024-06-21 at which the apparent solar elevation falls to `deg`.
pub fn time_at_elevation(deg: f64) -> DateTime<FixedOffset> {
    let obs = observer();
    let elev = |tt: &DateTime<FixedOffset>| sun_position(&obs, tt).expect("spa").apparent_elevation_deg();
    let mut lo = t("2024-06-21T13:30:00+02:00");
    let mut hi = lo + Duration::hours(11);
    assert!(elev(&lo) > deg && elev(&hi) < deg);
    for _ in 0..40 {
        let mid = lo + (hi - lo) / 2;
        if elev(&mid) > deg { lo = mid } else { hi = mid }
    }
    lo
}

pub fn sun_dir(time: &DateTime<FixedOffset>) -> Vec3 {
    GeoFrame::default().sun_dir_in_world(&sun_position(&observer(), time).expect("spa"))
}

/// What to put in the test world.
#[derive(Clone, Copy, Debug)]
pub struct WorldSpec {
    /// Albedo of the ground (marked diffuse).
    pub ground: [f32; 3],
    /// Albedo of the sun-facing wall (marked diffuse); `None` for no wall.
    pub wall: Option<[f32; 3]>,
    /// An unmarked 3×4×3 m box at the origin casting a shadow.
    pub occluder: bool,
    /// A dark second ground tile of this albedo under half of the view (marked).
    pub dark_tile: Option<[f32; 3]>,
}

impl Default for WorldSpec {
    fn default() -> Self {
        Self { ground: [0.3, 0.28, 0.25], wall: Some([0.5, 0.4, 0.35]), occluder: true, dark_tile: None }
    }
}

pub struct World {
    pub ray: Arc<RayScene>,
    pub camera: Camera,
}

/// Builds the world for sun direction `l`: a wall facing the sun off to the side and a camera
/// looking across so that it sees lit ground, the box's shadow and the lit face of the wall.
pub fn world(spec: WorldSpec, l: Vec3) -> World {
    let mut m = Mesh::default();
    let lh = Vec3::new(l.x, 0.0, l.z).try_normalize().unwrap_or(Vec3::X);
    let perp = lh.cross(Vec3::Y);
    let g = m.add_material(Material::diffuse("ground", spec.ground));
    let ground = m.add_node("ground", true);
    m.push_quad(Vec3::new(-100.0, 0.0, -100.0), Vec3::Z * 200.0, Vec3::X * 200.0, ground, g);
    if let Some(a) = spec.dark_tile {
        let mat = m.add_material(Material::diffuse("tile", a));
        let tile = m.add_node("tile", true);
        // A tile 1 cm above the ground covering the half-plane behind the box along perp.
        m.push_quad(Vec3::new(-30.0, 0.01, -30.0), Vec3::Z * 60.0, Vec3::X * 30.0, tile, mat);
    }
    if spec.occluder {
        let mat = m.add_material(Material::diffuse("box", [0.4, 0.4, 0.4]));
        let b = m.add_node("box", false);
        m.push_box(Vec3::new(-1.5, 0.0, -1.5), Vec3::new(1.5, 4.0, 1.5), b, mat, true);
    }
    if let Some(a) = spec.wall {
        // A wall turned 63° from the sun toward the camera: lit at cos = cos(elevation)/√5.
        let mat = m.add_material(Material::diffuse("wall", a));
        let wn = m.add_node("wall", true);
        let n = (lh + perp * 2.0).normalize();
        let t = n.cross(Vec3::Y);
        let c = lh * 4.0 + perp * 2.0;
        // u = up, v = t gives the normal up × t = n.
        m.push_quad(c - t * 2.5, Vec3::Y * 3.5, t * 5.0, wn, mat);
    }
    // The camera looks across the light (along −perp), so shadows fall sideways in the image.
    let eye = (perp * 8.0 + Vec3::Y * 6.0).as_dvec3();
    let target = -lh * 1.0;
    let pose = Pose::look_at(eye, target.as_dvec3(), DVec3::Y).expect("pose");
    let intrinsics = Intrinsics::brown_conrady(W, H, 64.0, 64.0, W as f64 / 2.0 - 0.5, H as f64 / 2.0 - 0.5, [-0.05, 0.0, 0.0, 0.0, 0.0]);
    World { ray: Arc::new(RayScene::new(m)), camera: Camera { intrinsics, pose } }
}

/// Renders the model image for lighting (`pd`, `pa`) and sun direction `l` (`pd` is ignored when
/// `l` is below the horizon).
pub fn render(world: &World, l: Vec3, pd: [f32; 3], pa: [f32; 3], noise: f32, seed: u64) -> LinearImage {
    let q = TransportQuality { paths: 256, max_bounces: 4 };
    let up = l.y > 0.0;
    let mut rng = SmallRng::seed_from_u64(seed);
    LinearImage::from_fn(W, H, |x, y| {
        let Some((o, d)) = world.camera.pixel_ray(x, y) else { return [0.0; 3] };
        let Some(hit) = world.ray.intersect(o.as_vec3(), d.as_vec3(), f32::MAX) else { return [0.0; 3] };
        let rho = world.ray.albedo(&hit);
        let tr = transport(&world.ray, hit.point, hit.normal, up.then_some(l), q, 7_000_000 + (y * W + x) as u64);
        let cos = hit.normal.dot(l).max(0.0);
        let s = if up && cos > 0.0 && world.ray.sees_direction(hit.point, hit.normal, l) { 1.0 } else { 0.0 };
        let e = tr.c * Vec3::from(pa) + if up { (Vec3::splat(s * cos) + tr.b) * Vec3::from(pd) } else { Vec3::ZERO };
        let v = rho / PI * e;
        let n = 1.0 + noise * (rng.random::<f32>() * 2.0 - 1.0) * 1.732;
        (v * n).to_array()
    })
}

/// Per-pixel sun visibility of the world (for masking tests).
pub fn lit_mask(world: &World, l: Vec3) -> Vec<bool> {
    (0..H)
        .flat_map(|y| (0..W).map(move |x| (x, y)))
        .map(|(x, y)| {
            let Some((o, d)) = world.camera.pixel_ray(x, y) else { return false };
            let Some(hit) = world.ray.intersect(o.as_vec3(), d.as_vec3(), f32::MAX) else { return false };
            hit.normal.dot(l) > 0.05 && world.ray.sees_direction(hit.point, hit.normal, l)
        })
        .collect()
}

pub fn frame(img: LinearImage) -> Frame {
    Frame { width: img.width, height: img.height, data: FrameData::Hdr(img) }
}

/// The estimator for a synthetic world. Those worlds are rendered with Jensen's uniform sky and
/// nothing below the horizon, so the model gets the same (`SkyTermsConfig::jensen`) unless the
/// caller chose another sky.
pub fn estimator(world: &World, mut config: EstimatorConfig) -> Estimator {
    if config.sky == heliar::scene::settings::SkyTermsConfig::default() {
        config.sky = heliar::scene::settings::SkyTermsConfig::jensen();
    }
    Estimator::with_camera(config, observer(), GeoFrame::default(), &world.camera, world.ray.clone()).expect("estimator")
}

/// Relative error of an RGB estimate against the truth, per channel, worst channel.
pub fn rel_err(est: [f64; 3], truth: [f32; 3]) -> f64 {
    (0..3).map(|c| (est[c] - truth[c] as f64).abs() / (truth[c] as f64).max(1e-30)).fold(0.0, f64::max)
}

/// A copy of the bundled courtyard's small files (no frames, no sequences, and the statue alone:
/// [`without_robot`]) in a fresh temporary folder, so tests that write (bakes, edits) never
/// share a folder.
pub fn scratch_courtyard(name: &str) -> std::path::PathBuf {
    let src = std::path::Path::new(env!("CARGO_MANIFEST_DIR")).join("scenes/courtyard");
    let dst = std::env::temp_dir().join(format!("heliar-{name}-{}", std::process::id()));
    let _ = std::fs::remove_dir_all(&dst);
    std::fs::create_dir_all(dst.join("calib")).expect("temp dir");
    std::fs::create_dir_all(dst.join("objects")).expect("temp dir");
    for f in ["scene.toml", "proxy.glb", "calib/camera.toml", "env.exr", "truth.csv", "objects/statue.glb"] {
        std::fs::copy(src.join(f), dst.join(f)).expect("copy");
    }
    let m = without_robot(&std::fs::read_to_string(dst.join("scene.toml")).expect("manifest"));
    let cut = m.find("[[sequences]]").unwrap_or(m.len());
    std::fs::write(dst.join("scene.toml"), &m[..cut]).expect("manifest");
    dst
}

/// The courtyard's manifest `m` without the robot that crosses the yard (its
/// `[[virtual_objects]]` entry and keyframes): the scratch courtyards hold the statue alone, as
/// the tests written for one object expect; [`scratch_courtyard_with_robot`] keeps it.
pub fn without_robot(m: &str) -> String {
    let Some(start) = m.find("[[virtual_objects]]\n# A delivery robot") else { return m.to_owned() };
    let end = m[start..].find("[estimator").map_or(m.len(), |e| start + e);
    format!("{}{}", &m[..start], &m[end..])
}

/// [`scratch_courtyard`] with the bundled robot crossing the yard (issue 15 §5).
pub fn scratch_courtyard_with_robot(name: &str) -> std::path::PathBuf {
    let dst = scratch_courtyard(name);
    let src = std::path::Path::new(env!("CARGO_MANIFEST_DIR")).join("scenes/courtyard");
    std::fs::copy(src.join("objects/robot.glb"), dst.join("objects/robot.glb")).expect("copy");
    let m = std::fs::read_to_string(src.join("scene.toml")).expect("manifest");
    let cut = m.find("[[sequences]]").unwrap_or(m.len());
    std::fs::write(dst.join("scene.toml"), &m[..cut]).expect("manifest");
    dst
}

/// Hashes of every file under `dir` (or of the file `dir`): the bad-input suites compare them
/// before and after a command to show that it changed no input.
pub fn hashes(dir: &std::path::Path) -> std::collections::BTreeMap<std::path::PathBuf, blake3::Hash> {
    let mut out = std::collections::BTreeMap::new();
    let mut stack = vec![dir.to_owned()];
    while let Some(d) = stack.pop() {
        if d.is_file() {
            out.insert(d.clone(), blake3::hash(&std::fs::read(&d).unwrap()));
            continue;
        }
        for e in std::fs::read_dir(&d).unwrap().flatten() {
            stack.push(e.path());
        }
    }
    out
}

/// `heliar ARGS`: (success, stderr).
pub fn heliar_status(args: &[&str]) -> (bool, String) {
    let out = std::process::Command::new(env!("CARGO_BIN_EXE_heliar")).args(args).output().unwrap();
    (out.status.success(), String::from_utf8_lossy(&out.stderr).into_owned())
}

/// A path as `&str` for an argument list.
pub fn s(p: &std::path::Path) -> &str {
    p.to_str().unwrap()
}
