//! The terrain's albedo measured on the environment map (`terrain_albedo = "map"` in
//! `[estimator.sky]`; issue 13 §2, "take its albedo from the environment map's texels below the
//! horizon that the proxy does not cover").
//!
//! The map shows, below the horizon and past the proxy's edge, the distant terrain that the
//! estimator's model lights surfaces with from below ([`crate::sky::terrain`]: flat, Lambertian,
//! lit by the same sun and sky, `L_t = ρ_t/π·(Pa + max(l_y, 0)·Pd)`). Inverting that formula
//! texel by texel is Jensen §3.2's inverse rendering (`ρ = π·L / E`) applied to the terrain
//! instead of the proxy: [`crate::sky::terrain::estimate_albedo`] takes the solid-angle-weighted
//! median of `π·L / E` over the texels at least 2° below the horizon that no proxy ray hits
//! (the bake's hit buffers).
//!
//! `E` needs the lighting at capture, which the bake estimates on the map itself (step 3 of
//! [`super`]), and that estimate's model contains the terrain: a bright terrain assumed dark
//! pushes its light into `Pa`. The two are therefore iterated — lighting with the current albedo
//! (first the default), albedo from that lighting — until no channel moves by more than
//! [`CONVERGED`] (at most [`MAX_PASSES`] passes; on the winter scenes two or three). A manifest
//! that gives `capture_pd`/`capture_pa` needs one.
//!
//! When the map gives no estimate (no `[envmap]` file, too few uncovered texels below the horizon,
//! no light on the terrain at capture, or no lighting at capture) the albedo is
//! [`DEFAULT_TERRAIN_ALBEDO`] with source `fallback` and a note that says why.

use super::steps::{capture_lighting, hit_buffers};
use super::{BakeError, BakeInfo, SKY};
use crate::camera::View;
use crate::estimate::EstimatorConfig;
use crate::geometry::raycast::RayScene;
use crate::io::image::LinearImage;
use crate::scene::Scene;
use crate::scene::settings::{DEFAULT_TERRAIN_ALBEDO, ResolvedTerrain, TerrainAlbedo, TerrainSource};
use crate::sky::terrain::{AlbedoFallback, AlbedoSettings, CaptureLighting, EquirectView, estimate_albedo};
use glam::DVec3;
use std::path::Path;
use std::sync::Arc;

/// Passes of (lighting at capture, albedo) at most.
pub const MAX_PASSES: usize = 4;
/// The passes stop when no channel of the albedo moves by more than this.
pub const CONVERGED: f32 = 0.005;

/// The default albedo with `note` saying why the map gave none.
pub fn fallback(note: String) -> ResolvedTerrain {
    ResolvedTerrain { albedo_rgb: DEFAULT_TERRAIN_ALBEDO, source: TerrainSource::Fallback, texels: 0, note: Some(note) }
}

/// Under `terrain_albedo = "map"` (the default), measures the albedo on the scene's environment
/// map and stores it in `scene.estimator.sky.resolved_terrain`, so that the estimator, the bake
/// and the renderer use it; returns it (`None`: the scene gives a number, nothing to do). An
/// unreadable map is an error; a map that gives no estimate is the fallback with a note.
///
/// The measurement (about 2 s in a release build on a 1024×512 map) is cached in
/// `baked/terrain.json` under the bake's input key ([`super::cache_key`]: the map and proxy
/// files and every setting), so a scene pays it once. A missing, stale or unreadable cache file
/// is measured again; one that cannot be written (a read-only scene) is not an error, and the
/// note says so.
pub fn resolve_scene(scene: &mut Scene, ray: &Arc<RayScene>) -> Result<Option<ResolvedTerrain>, BakeError> {
    if scene.estimator.sky.terrain_albedo != TerrainAlbedo::Map {
        return Ok(None);
    }
    if let Some(r) = &scene.estimator.sky.resolved_terrain {
        return Ok(Some(r.clone()));
    }
    let mpath = scene.root.join(crate::scene::MANIFEST_FILE);
    let r = match scene.manifest.envmap.as_ref().and_then(|e| e.file.as_ref()) {
        None => fallback(format!("{}: terrain_albedo = \"map\" needs an [envmap] file to measure the terrain on", mpath.display())),
        Some(f) => {
            let key = cache_key(scene, ray)?;
            let cache = super::bake_dir(scene).join(CACHE_FILE);
            match read_cache(&cache, &key) {
                Some(mut r) => {
                    r.note = Some(format!("{}; read from {}", r.note.as_deref().unwrap_or("measured"), cache.display()));
                    r
                }
                None => {
                    let path = scene.root.join(f);
                    let mut img = LinearImage::read_exr(&path)?;
                    img.sanitize();
                    let mut r = from_map(scene, ray, &img, &path)?;
                    if let Err(e) = write_cache(&cache, &key, &r) {
                        let note = r.note.take().unwrap_or_default();
                        r.note = Some(format!("{note}; not cached ({e})"));
                    }
                    r
                }
            }
        }
    };
    scene.estimator.sky.resolved_terrain = Some(r.clone());
    Ok(Some(r))
}

/// The key of [`resolve_scene`]'s cache: the bake's key (the map and proxy files, every setting)
/// and the geometry the rays see, which a caller may have changed after loading.
fn cache_key(scene: &Scene, ray: &RayScene) -> Result<String, BakeError> {
    let mut h = blake3::Hasher::new();
    h.update(super::cache_key(scene)?.as_bytes());
    let mesh = ray.mesh();
    for p in &mesh.positions {
        for v in p.to_array() {
            h.update(&v.to_le_bytes());
        }
    }
    for t in &mesh.triangles {
        for i in t {
            h.update(&i.to_le_bytes());
        }
    }
    h.update(format!("{:?}{:?}{:?}{:?}", mesh.tri_material, mesh.tri_node, mesh.materials, mesh.nodes).as_bytes());
    Ok(h.finalize().to_hex().to_string())
}

/// The cache of [`resolve_scene`] in the bake folder.
pub const CACHE_FILE: &str = "terrain.json";

/// What `terrain.json` holds: the bake's input key and the albedo measured under it.
#[derive(serde::Serialize, serde::Deserialize)]
struct Cached {
    key: String,
    terrain: ResolvedTerrain,
}

/// The cached albedo when `path` holds one for `key` (anything else is a miss).
fn read_cache(path: &Path, key: &str) -> Option<ResolvedTerrain> {
    let text = std::fs::read_to_string(path).ok()?;
    let c: Cached = serde_json::from_str(&text).ok()?;
    let valid = c.terrain.albedo_rgb.iter().all(|a| a.is_finite() && (0.0..=1.0).contains(a));
    (c.key == key && valid).then_some(c.terrain)
}

/// Writes the cache through a temporary file and a rename.
fn write_cache(path: &Path, key: &str, terrain: &ResolvedTerrain) -> Result<(), String> {
    if let Some(dir) = path.parent() {
        std::fs::create_dir_all(dir).map_err(|e| format!("{}: {e}", dir.display()))?;
    }
    let text = serde_json::to_string_pretty(&Cached { key: key.to_owned(), terrain: terrain.clone() }).map_err(|e| e.to_string())?;
    crate::io::write_atomic(path, text.as_bytes()).map_err(|e| e.to_string())
}

/// The estimator settings the bake uses: the scene's, with `terrain_albedo = "map"` measured on
/// `captured` (the map and its path) unless the caller measured it already; and the terrain for
/// `bake.json` (`None` unless `"map"`).
pub(super) fn bake_settings(scene: &Scene, ray: &Arc<RayScene>, captured: Option<(&LinearImage, &Path)>) -> Result<(EstimatorConfig, Option<ResolvedTerrain>), BakeError> {
    let mut estimator = scene.estimator.clone();
    if estimator.sky.terrain_albedo != TerrainAlbedo::Map {
        return Ok((estimator, None));
    }
    if estimator.sky.resolved_terrain.is_none() {
        let mpath = scene.root.join(crate::scene::MANIFEST_FILE);
        estimator.sky.resolved_terrain = Some(match captured {
            Some((img, path)) => from_map(scene, ray, img, path)?,
            None => fallback(format!("{}: terrain_albedo = \"map\" needs an [envmap] file to measure the terrain on", mpath.display())),
        });
    }
    let used = estimator.sky.terrain_used();
    Ok((estimator, Some(used)))
}

/// The albedo measured on `img` (the scene's map, read from `path`), module docs.
pub fn from_map(scene: &Scene, ray: &Arc<RayScene>, img: &LinearImage, path: &Path) -> Result<ResolvedTerrain, BakeError> {
    let mpath = scene.root.join(crate::scene::MANIFEST_FILE);
    let env = scene.manifest.envmap.as_ref().ok_or(BakeError::NoEnvMap { path: mpath })?;
    let (w, h) = (img.width, img.height);
    let view = View::Equirect { centre: DVec3::from(env.capture_center), width: w, height: h };
    let open_below: Vec<bool> = hit_buffers(ray, &view, (w * h) as usize).node.iter().map(|&k| k == SKY).collect();
    let settings = AlbedoSettings { fallback_rgb: DEFAULT_TERRAIN_ALBEDO, ..AlbedoSettings::default() };
    let mut config = scene.estimator.clone();
    let mut albedo = DEFAULT_TERRAIN_ALBEDO;
    let (mut texels, mut passes) = (0, 0);
    while passes < MAX_PASSES {
        passes += 1;
        config.sky.resolved_terrain = Some(ResolvedTerrain { albedo_rgb: albedo, source: TerrainSource::Map, texels, note: None });
        let (pd, pa, l, _) = match capture_lighting(scene, &config, ray, view, img, path, &mut BakeInfo::default()) {
            Ok(v) => v,
            Err(e @ BakeError::CaptureLighting { .. }) => return Ok(fallback(format!("terrain_albedo = \"map\": no lighting at capture to measure the terrain with ({e})"))),
            Err(e) => return Err(e),
        };
        let capture = CaptureLighting { pd: pd.map(|v| v as f32), pa: pa.map(|v| v as f32), sun_dir_world: l };
        let texels_view = EquirectView { width: w, height: h, texels: &img.data };
        let est = estimate_albedo(texels_view, &open_below, capture, &settings).map_err(|e| BakeError::Info { path: path.to_owned(), message: e.to_string() })?;
        if let Some(why) = est.fallback {
            let reason = match why {
                AlbedoFallback::TooFewTexels => format!(
                    "{}: only {} texels lie {}° or more below the horizon where the proxy does not cover them ({} needed)",
                    path.display(),
                    est.texels_used,
                    settings.min_depression_deg,
                    settings.min_texels
                ),
                AlbedoFallback::NoCaptureLight(c) => format!("{}: the terrain received no light at capture (channel {c})", path.display()),
            };
            return Ok(fallback(format!("terrain_albedo = \"map\": {reason}; using the default {DEFAULT_TERRAIN_ALBEDO:?}")));
        }
        let moved = (0..3).map(|c| (est.albedo_rgb[c] - albedo[c]).abs()).fold(0.0f32, f32::max);
        (albedo, texels) = (est.albedo_rgb, est.texels_used);
        if moved <= CONVERGED {
            break;
        }
    }
    let note = format!("median of {texels} texels of {} below the horizon past the proxy; {passes} passes with the lighting at capture", path.display());
    Ok(ResolvedTerrain { albedo_rgb: albedo, source: TerrainSource::Map, texels, note: Some(note) })
}
