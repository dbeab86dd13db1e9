//! The offline bake (Jensen §4.1): from the HDR environment map and the real proxy, the hit
//! buffers, normal, weighted-ambient and albedo environment maps.
//!
//! # How it works
//! 1. **Hit buffers.** For each texel a ray from the capture centre finds the proxy point the
//!    texel shows, its facing normal and its node; texels that see no geometry are sky. (Jensen
//!    renders the normal map in two passes as a GPU workaround; here normals come straight from the
//!    geometry.)
//! 2. **Weighted-ambient map `c`.** Per surface texel, [`crate::geometry::ambient::transport`] path
//!    traces the irradiance from a uniform white upper-hemisphere sky of unit horizontal irradiance,
//!    with interreflections between proxy surfaces (`bake.ambient.paths` cosine-weighted paths, at
//!    most `bake.ambient.max_bounces` bounces; default 256 and 4). This replaces the radiosity
//!    rendering the paper suggests.
//! 3. **Lighting at capture.** The estimator runs on the environment map itself, as an equirect
//!    view from the capture centre at the capture time, and gives `Pd`, `Pa` and the sun direction
//!    `l` ([`crate::estimate::Estimator::with_view`]). A manifest that knows them
//!    (`capture_pd`, `capture_pa`) skips this. With `terrain_albedo = "map"` the terrain's albedo
//!    is measured first, on the map's texels below the horizon past the proxy, iterated with this
//!    estimate ([`terrain`]; recorded in `bake.json` as `terrain`).
//! 4. **Albedo map, by inverse rendering.** `ρ = π·L / (c·Pa + (s·max(n·l,0) + b)·Pd)` per channel,
//!    with `s` the texel's sun visibility and `b` its sun bounce at capture (the estimator's model,
//!    Jensen §4.2 plus the bounce term). Under a shaped sky or with terrain (`[estimator.sky]`,
//!    the scene's one sky) `c` and `b` are those of the capture sun's sky: the uniform `c` of step
//!    2 plus the change the shape and the terrain bring along the bounce paths
//!    ([`crate::sky::radiance::ShapeMinusUniform`]); the map itself stays Jensen's `c`, which the
//!    relight corrects the same way for each sun. Texels whose denominator is below
//!    [`MIN_DENOMINATOR_REL`]` · Pa` or whose result is implausible (`ρ > `[`MAX_ALBEDO`], negative or
//!    NaN) are flagged and filled from valid neighbours of the same node (repeated 8-neighbour
//!    averaging, wrapping at the seam); a node with no valid texel falls back to its base colour.
//!    With `envmap.albedo = "gltf"` the base colour is used everywhere instead.
//! 5. **Outputs** under `<scene>/baked/`: `albedo.exr`, `normal.exr`, `ambient.exr`,
//!    `geometry.exr` (hit position in RGB, node index + 1 in A, 0 for sky), PNG previews, and
//!    `bake.json` (settings, input hashes, counts, lighting at capture, timings). A bake whose
//!    input hashes match `bake.json` is loaded instead of recomputed.

pub use crate::scene::settings::BakeConfig;
use crate::estimate::{EstimateError, Status};
use crate::geometry::raycast::RayScene;
use crate::geometry::sampling::sphere_fibonacci;
use crate::io::IoError;
use crate::io::image::{ExrPrecision, LinearImage};
use crate::camera::View;
use crate::scene::{AlbedoSource, Scene};
use glam::{DVec3, Vec3};
use serde::{Deserialize, Serialize};
use std::path::{Path, PathBuf};
use steps::{Hits, Inversion, capture_lighting, fill_flagged, hit_buffers};

mod steps;
pub mod orientation;
pub mod terrain;

/// Texels whose inverse-rendering denominator is below this fraction of `Pa` are flagged: they
/// receive almost no light, so their radiance says nothing about their albedo.
pub const MIN_DENOMINATOR_REL: f32 = 0.02;
/// Albedos above this are physically implausible and flagged.
pub const MAX_ALBEDO: f32 = 1.0;
/// Fraction of back-face hits above which a point counts as inside closed geometry.
pub const INSIDE_FRACTION: f32 = 0.5;
/// Version of the bake format; part of the cache key.
const BAKE_FORMAT: u32 = 1;
/// Node value of sky texels.
pub const SKY: u32 = u32::MAX;

/// Errors of the bake.
#[derive(Debug, thiserror::Error)]
pub enum BakeError {
    /// The scene has no `[envmap]` section.
    #[error("{path}: the scene has no [envmap] section; the bake needs its capture centre and time")]
    NoEnvMap {
        /// The manifest.
        path: PathBuf,
    },
    /// The capture centre lies inside closed proxy geometry.
    #[error("{path}: field `envmap.capture_center`: {centre:?} is inside the proxy geometry ({percent:.0}% of the rays from it hit back faces)")]
    CentreInside {
        /// The manifest.
        path: PathBuf,
        /// The centre.
        centre: [f64; 3],
        /// Back-face hit percentage.
        percent: f32,
    },
    /// The environment map cannot give the lighting at capture.
    #[error(
        "{path}: the estimator could not separate sun and sky on the environment map at capture (status {status:?}); \
         set `albedo = \"gltf\"` in [envmap] to take the albedo from the proxy instead"
    )]
    CaptureLighting {
        /// The environment map.
        path: PathBuf,
        /// The estimator's status.
        status: Status,
    },
    /// A baked file is missing or unreadable.
    #[error(transparent)]
    Io(#[from] IoError),
    /// `bake.json` could not be written or read.
    #[error("{path}: {message}")]
    Info {
        /// The file.
        path: PathBuf,
        /// What went wrong.
        message: String,
    },
    /// The estimator failed.
    #[error(transparent)]
    Estimate(#[from] EstimateError),
}

/// Counts and measurements of a bake (`bake.json`).
#[derive(Clone, Debug, Default, PartialEq, Serialize, Deserialize)]
pub struct BakeInfo {
    /// Format version.
    pub format: u32,
    /// blake3 of all inputs (see [`cache_key`]).
    pub key: String,
    /// Map size.
    pub width: u32,
    /// Map size.
    pub height: u32,
    /// Capture centre.
    pub centre: [f64; 3],
    /// Albedo source.
    pub albedo_source: AlbedoSource,
    /// Texels that show the proxy.
    pub surface_texels: usize,
    /// Texels that show sky.
    pub sky_texels: usize,
    /// Non-finite or negative texels of the input map replaced by 0.
    pub sanitized_texels: usize,
    /// Albedo texels flagged and filled from neighbours.
    pub filled_from_neighbours: usize,
    /// Albedo texels flagged and set to their node's base colour (no valid neighbour).
    pub filled_from_base_colour: usize,
    /// Sun direction at capture, world.
    pub capture_sun_dir: [f32; 3],
    /// `Pd` at capture, from the estimator on the map.
    pub capture_pd: [f64; 3],
    /// `Pa` at capture.
    pub capture_pa: [f64; 3],
    /// The estimator's status on the map (`None` when the manifest gave the lighting or the
    /// albedo came from glTF).
    pub capture_status: Option<Status>,
    /// Settings used.
    pub config: Option<BakeConfig>,
    /// Wall time per stage, ms.
    pub timings_ms: Vec<(String, f64)>,
    /// How well the captured map's bright sky matches where the proxy leaves the sky open, as
    /// read and at the best turn ([`orientation`]); `None` without a map or without both classes.
    #[serde(default)]
    pub orientation: Option<orientation::Orientation>,
    /// Under `terrain_albedo = "map"`: the terrain albedo the inversion used and where it came
    /// from ([`terrain`]); absent otherwise.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub terrain: Option<crate::scene::settings::ResolvedTerrain>,
}

/// The baked maps, in memory. Vectors are row-major `width × height`.
#[derive(Clone, Debug)]
pub struct Baked {
    /// Map width.
    pub width: u32,
    /// Map height.
    pub height: u32,
    /// Capture centre.
    pub centre: Vec3,
    /// Node index per texel, [`SKY`] for sky.
    pub node: Vec<u32>,
    /// Hit position per texel (zero for sky).
    pub position: Vec<Vec3>,
    /// Facing normal per texel (zero for sky).
    pub normal: Vec<Vec3>,
    /// Weighted-ambient factor per texel (zero for sky).
    pub ambient: Vec<Vec3>,
    /// Linear albedo per texel (zero for sky).
    pub albedo: Vec<Vec3>,
    /// Counts and settings.
    pub info: BakeInfo,
}

/// Progress reports: `(stage, done, total)`.
pub type Progress<'a> = &'a (dyn Fn(&str, u64, u64) + Sync);

fn hash_file(h: &mut blake3::Hasher, path: &Path) -> Result<(), IoError> {
    let bytes = std::fs::read(path).map_err(|source| IoError::File { path: path.to_owned(), source })?;
    h.update(&(bytes.len() as u64).to_le_bytes());
    h.update(&bytes);
    Ok(())
}

/// The cache key of a scene's bake: blake3 over the environment map and proxy files and every
/// setting the bake reads.
pub fn cache_key(scene: &Scene) -> Result<String, BakeError> {
    let mpath = scene.root.join(crate::scene::MANIFEST_FILE);
    let env = scene.manifest.envmap.as_ref().ok_or(BakeError::NoEnvMap { path: mpath.clone() })?;
    let mut h = blake3::Hasher::new();
    h.update(&BAKE_FORMAT.to_le_bytes());
    h.update(env!("CARGO_PKG_VERSION").as_bytes());
    if let Some(f) = &env.file {
        hash_file(&mut h, &scene.root.join(f))?;
    }
    hash_file(&mut h, &scene.root.join(&scene.manifest.proxy.file))?;
    let mut settings = serde_json::json!({
        "env": env, "bake": scene.bake, "place": scene.manifest.place,
        "diffuse": scene.manifest.proxy.diffuse_nodes, "estimator": scene.estimator,
    });
    // Only when set, so the keys of scenes without the override stay what they were.
    if !scene.manifest.proxy.not_diffuse_nodes.is_empty() {
        settings["not_diffuse"] = serde_json::json!(scene.manifest.proxy.not_diffuse_nodes);
    }
    // Bakes whose inversion sees the scene's sky (a shaped sky or terrain) differ from the ones
    // before it did; Jensen's model keeps its keys.
    if !scene.estimator.sky.sky_model().is_uniform() {
        settings["inversion_sky"] = serde_json::json!(2);
    }
    h.update(settings.to_string().as_bytes());
    Ok(h.finalize().to_hex().to_string())
}

/// Runs the bake. `progress` is called from worker threads.
pub fn bake(scene: &Scene, ray: std::sync::Arc<RayScene>, progress: Progress) -> Result<Baked, BakeError> {
    bake_with_map(scene, ray, None, progress)
}

/// Runs the bake with `map` in place of the scene's environment map file (for resolution
/// sweeps); `None` reads the file.
pub fn bake_with_map(scene: &Scene, ray: std::sync::Arc<RayScene>, map: Option<LinearImage>, progress: Progress) -> Result<Baked, BakeError> {
    let mpath = scene.root.join(crate::scene::MANIFEST_FILE);
    let env = scene.manifest.envmap.as_ref().ok_or(BakeError::NoEnvMap { path: mpath.clone() })?;
    let cfg = &scene.bake;
    let mut info = BakeInfo { format: BAKE_FORMAT, key: cache_key(scene)?, config: Some(cfg.clone()), albedo_source: env.albedo, ..Default::default() };
    let mut timer = std::time::Instant::now();
    let mut lap = |info: &mut BakeInfo, name: &str| {
        info.timings_ms.push((name.to_owned(), timer.elapsed().as_secs_f64() * 1e3));
        timer = std::time::Instant::now();
    };
    let centre = DVec3::from(env.capture_center);
    info.centre = env.capture_center;

    // The captured map (sanitised) or just a size.
    let captured: Option<(LinearImage, PathBuf)> = match (&env.file, map) {
        (Some(f), Some(mut img)) => {
            info.sanitized_texels = img.sanitize();
            Some((img, scene.root.join(f)))
        }
        (Some(f), None) => {
            let p = scene.root.join(f);
            let mut img = LinearImage::read_exr(&p)?;
            info.sanitized_texels = img.sanitize();
            Some((img, p))
        }
        (None, _) => None,
    };
    let (w, h) = match (&captured, env.resolution) {
        (Some((img, _)), _) => (img.width, img.height),
        (None, Some([w, h])) => (w, h),
        (None, None) => (256, 128),
    };
    info.width = w;
    info.height = h;

    // The centre must be outside closed geometry.
    let probe_dirs = sphere_fibonacci(256);
    if let Some(f) = ray.back_face_fraction(centre.as_vec3(), &probe_dirs)
        && f > INSIDE_FRACTION
    {
        return Err(BakeError::CentreInside { path: mpath, centre: env.capture_center, percent: 100.0 * f });
    }

    // 1. Hit buffers.
    let n = (w * h) as usize;
    let view = View::Equirect { centre, width: w, height: h };
    let Hits { node, position, normal, base } = hit_buffers(&ray, &view, n);
    info.surface_texels = node.iter().filter(|&&k| k != SKY).count();
    info.sky_texels = n - info.surface_texels;
    if let Some((img, _)) = &captured {
        info.orientation = orientation::check(&node, img);
    }
    lap(&mut info, "hit buffers");

    // The terrain's albedo, when it is to come from the map.
    let (estimator, terrain_used) = terrain::bake_settings(scene, &ray, captured.as_ref().map(|(img, path)| (img, path.as_path())))?;
    info.terrain = terrain_used;

    // 2. Weighted ambient.
    let ambient = steps::weighted_ambient(&ray, &node, &position, &normal, cfg, progress);
    lap(&mut info, "weighted ambient");

    // 3–4. Albedo.
    let albedo = match (&captured, env.albedo) {
        (Some((img, path)), AlbedoSource::Inverse) => {
            let (pd, pa, l, sun_above) = capture_lighting(scene, &estimator, &ray, view, img, path, &mut info)?;
            lap(&mut info, "lighting at capture");
            let hits = Hits { node, position, normal, base };
            let sky = estimator.sky.sky_model();
            let inv = Inversion { ray: &ray, hits: &hits, ambient: &ambient, cfg, sky: &sky, progress };
            let (mut rho, valid) = inv.run(img, pd, pa, l, sun_above);
            let (from_neighbours, from_base) = fill_flagged(&mut rho, &valid, &hits.node, &hits.base, w, h);
            info.filled_from_neighbours = from_neighbours;
            info.filled_from_base_colour = from_base;
            lap(&mut info, "albedo inversion");
            let Hits { node, position, normal, .. } = hits;
            return Ok(Baked { width: w, height: h, centre: centre.as_vec3(), node, position, normal, ambient, albedo: rho, info });
        }
        _ => {
            info.albedo_source = AlbedoSource::Gltf;
            base.clone()
        }
    };
    Ok(Baked { width: w, height: h, centre: centre.as_vec3(), node, position, normal, ambient, albedo, info })
}

const FILES: [&str; 5] = ["albedo.exr", "normal.exr", "ambient.exr", "geometry.exr", "bake.json"];

impl Baked {
    /// Writes the maps, previews and `bake.json` into `dir` (created). Every file is written
    /// into a private temporary folder first and renamed into place, `bake.json` last, so a
    /// reader (another process baking the same scene, or an interrupted run) never sees a
    /// half-written file, and a bake whose `bake.json` is present is complete.
    pub fn save(&self, dir: &Path) -> Result<(), BakeError> {
        let tmp = dir.join(format!(".tmp-{}-{:?}", std::process::id(), std::thread::current().id()).replace(['(', ')'], ""));
        let result = self.save_files(&tmp).and_then(|names| {
            for name in names {
                let (from, to) = (tmp.join(name), dir.join(name));
                std::fs::rename(&from, &to).map_err(|source| IoError::File { path: to.clone(), source })?;
            }
            Ok(())
        });
        std::fs::remove_dir_all(&tmp).ok();
        result
    }

    fn save_files(&self, dir: &Path) -> Result<[&'static str; 8], BakeError> {
        std::fs::create_dir_all(dir).map_err(|source| IoError::File { path: dir.to_owned(), source })?;
        let img = |v: &[Vec3]| LinearImage { width: self.width, height: self.height, data: v.iter().map(|p| p.to_array()).collect() };
        img(&self.albedo).write_exr(&dir.join("albedo.exr"), ExrPrecision::Float)?;
        img(&self.normal).write_exr(&dir.join("normal.exr"), ExrPrecision::Float)?;
        img(&self.ambient).write_exr(&dir.join("ambient.exr"), ExrPrecision::Float)?;
        let ids: Vec<f32> = self.node.iter().map(|&k| if k == SKY { 0.0 } else { (k + 1) as f32 }).collect();
        img(&self.position).write_exr_with_alpha(&ids, &dir.join("geometry.exr"))?;
        img(&self.albedo).write_png_srgb(&dir.join("albedo.png"), 1.0)?;
        img(&self.ambient).write_png_srgb(&dir.join("ambient.png"), 1.0)?;
        let shown: Vec<Vec3> = self.normal.iter().map(|n| if *n == Vec3::ZERO { Vec3::ZERO } else { *n * 0.5 + 0.5 }).collect();
        // The normal preview stores n·½ + ½ directly as sRGB-encoded colour, as normal maps do.
        let enc: Vec<Vec3> = shown.iter().map(|v| v.map(crate::io::image::linear_from_srgb)).collect();
        img(&enc).write_png_srgb(&dir.join("normal.png"), 1.0)?;
        let p = dir.join("bake.json");
        let text = serde_json::to_string_pretty(&self.info).map_err(|e| BakeError::Info { path: p.clone(), message: e.to_string() })?;
        std::fs::write(&p, text).map_err(|source| IoError::File { path: p.clone(), source })?;
        Ok(["albedo.exr", "normal.exr", "ambient.exr", "geometry.exr", "albedo.png", "ambient.png", "normal.png", "bake.json"])
    }

    /// Loads a bake from `dir`; `Ok(None)` when `bake.json` is absent or from another format.
    pub fn load(dir: &Path) -> Result<Option<Baked>, BakeError> {
        let p = dir.join("bake.json");
        let Ok(text) = std::fs::read_to_string(&p) else { return Ok(None) };
        let Ok(info) = serde_json::from_str::<BakeInfo>(&text) else { return Ok(None) };
        if info.format != BAKE_FORMAT || FILES.iter().any(|f| !dir.join(f).exists()) {
            return Ok(None);
        }
        let vec3 = |img: LinearImage| -> Vec<Vec3> { img.data.into_iter().map(Vec3::from).collect() };
        let albedo = vec3(LinearImage::read_exr(&dir.join("albedo.exr"))?);
        let normal = vec3(LinearImage::read_exr(&dir.join("normal.exr"))?);
        let ambient = vec3(LinearImage::read_exr(&dir.join("ambient.exr"))?);
        let (geo, ids) = LinearImage::read_exr_with_alpha(&dir.join("geometry.exr"))?;
        let n = (info.width * info.height) as usize;
        if [albedo.len(), normal.len(), ambient.len(), geo.data.len()].iter().any(|&k| k != n) {
            return Err(BakeError::Info { path: dir.to_owned(), message: format!("baked maps are not all {}×{}", info.width, info.height) });
        }
        let node = ids.iter().map(|&a| if a < 0.5 { SKY } else { (a - 1.0).round() as u32 }).collect();
        Ok(Some(Baked {
            width: info.width,
            height: info.height,
            centre: DVec3::from(info.centre).as_vec3(),
            node,
            position: vec3(geo),
            normal,
            ambient,
            albedo,
            info,
        }))
    }
}

/// The scene's bake folder.
pub fn bake_dir(scene: &Scene) -> PathBuf {
    scene.root.join("baked")
}

/// Loads the scene's bake when its inputs are unchanged, otherwise bakes and saves. Returns the
/// maps and whether they came from the cache.
pub fn bake_cached(scene: &Scene, ray: std::sync::Arc<RayScene>, force: bool, progress: Progress) -> Result<(Baked, bool), BakeError> {
    let dir = bake_dir(scene);
    let key = cache_key(scene)?;
    if !force && let Some(b) = Baked::load(&dir)? && b.info.key == key {
        return Ok((b, true));
    }
    let b = bake(scene, ray, progress)?;
    b.save(&dir)?;
    Ok((b, false))
}
