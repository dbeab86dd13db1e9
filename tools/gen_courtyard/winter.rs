//! The winter scenes (`gen-courtyard --winter DIR`): the courtyard on a December morning under a
//! Hosek–Wilkie sky, with light from below the horizon.
//!
//! Two scene folders, `DIR/snow` and `DIR/asphalt`, differ only in the terrain: the proxy's
//! ground ends 15 m from the origin, and beyond it (not in the proxy) lies flat terrain of albedo
//! 0.8 (snow) or 0.08 (asphalt) out to 2 km, then the same albedo as distant terrain
//! (`sky_render.rs`). The sky is Hosek–Wilkie RGB at turbidity 3 with the terrain's albedo as its
//! ground albedo; the sun follows Aalborg (57.05° N) on 2024-12-10 from 10:00 to 12:00 (apparent
//! elevation ≈ 5.4° → 10°; at 57° N in December the sun never gets higher than ≈ 10°).
//!
//! Truth (`truth.csv`): `Pa` is the sky's irradiance on an unoccluded horizontal surface (the
//! Hosek sky above the horizon, the sun excluded: the crate's definition), the model's absolute
//! irradiance times one constant that makes frame 0's green `Pa` [`PA_GREEN_FRAME0`], so `Pa`
//! follows the sky's brightening as the sun climbs. `Pd` is the sun's irradiance on a surface
//! facing it: a Beer–Lambert transmittance `PD_TOP · e^{−τ·m}` with per-channel optical depths
//! [`TAU`] (Rayleigh, ozone and a clean-air aerosol near 610, 550 and 465 nm) and the Kasten–Young
//! (1989) air mass `m` of the apparent elevation, so the low sun is warm. The extra columns give the
//! terrain albedo and the sun's apparent elevation.
//!
//! Frames come from the importance-sampled tracer of `sky_render.rs` with the courtyard's true
//! albedo texture, wet patch, unmodelled person, lens distortion and sensor noise (HDR only).
//! `reference/` holds frames 0 and 3 with the statue physically present, rendered twice with
//! different seeds (`reference/` and `reference/second_seed/`); the relative RMSE between the two
//! (the noise floor, √2 × one render's noise) is printed and written into `reference.toml`.

use super::sky_render::{Lighting, SkyLight, render_env, render_region};
use super::statue::WithStatue;
use super::{Args, Courtyard, NOISE_ABS, NOISE_REL, STATUE_FILE, STATUE_ROTATION_Y_DEG, STATUE_TRANSLATION, normal, write};
use anyhow::{Context, Result};
use glam::{DVec3, Vec3};
use heliar::geometry::raycast::RayScene;
use heliar::geometry::{Material, Mesh};
use heliar::io::image::{ExrPrecision, LinearImage};
use heliar::render::reference::{Classes, Crop, composite_error};
use heliar::sky::hosek::HosekSky;
use heliar::sun::{GeoFrame, Observer, sun_position};
use rand::{SeedableRng, rngs::SmallRng};
use std::fmt::Write as _;
use std::path::Path;
use std::time::Instant;

/// A terrain variant.
struct Variant {
    name: &'static str,
    albedo: [f32; 3],
    words: &'static str,
}

const VARIANTS: [Variant; 2] = [
    Variant { name: "snow", albedo: [0.80, 0.80, 0.82], words: "bright snow (albedo 0.8)" },
    Variant { name: "asphalt", albedo: [0.08, 0.08, 0.08], words: "dark asphalt (albedo 0.08)" },
];

const START: &str = "2024-12-10T10:00:00+01:00";
const FRAMES: usize = 4;
/// Seconds between frames (40 min).
const INTERVAL_S: f64 = 2400.0;
const TURBIDITY: f64 = 3.0;
/// Half-size of the proxy's square ground.
const PROXY_GROUND_HALF_M: f32 = 15.0;
/// Half-size of the terrain mesh beyond it.
const TERRAIN_HALF_M: f32 = 2000.0;
/// Green `Pa` of frame 0; sets the one scale between the sky model's units and the frames'.
const PA_GREEN_FRAME0: f32 = 0.30;
/// Sun irradiance above the atmosphere (frame units).
const PD_TOP: [f32; 3] = [5.0, 5.0, 5.0];
/// Vertical optical depth per channel (module docs).
const TAU: [f32; 3] = [0.14, 0.17, 0.23];
/// Samples per pixel of the frames (sky and sun together, importance sampled).
const FRAME_SPP: u32 = 64;
/// Samples per texel of the environment map.
const ENV_SPP: u32 = 32;
/// Environment map width (height is half).
const ENV_WIDTH: u32 = 256;
/// Samples per pixel of each reference render.
const REFERENCE_SPP: u32 = 512;
/// Frames rendered again with the statue: the lowest and the highest sun.
const REFERENCE_FRAMES: [usize; 2] = [0, 3];
/// Seeds of the two reference renders.
const REFERENCE_SEEDS: [u64; 2] = [7001, 9001];
const ENV_CENTRE: [f32; 3] = [0.0, 1.5, 2.0];

/// Kasten & Young (1989) relative air mass at apparent elevation `h_deg`.
pub(super) fn air_mass(h_deg: f64) -> f64 {
    1.0 / (h_deg.to_radians().sin() + 0.50572 * (h_deg + 6.07995).powf(-1.6364))
}

/// The true `Pd` at apparent elevation `h_deg` (module docs).
pub(super) fn sun_irradiance(h_deg: f64) -> Vec3 {
    let m = air_mass(h_deg) as f32;
    Vec3::from(std::array::from_fn::<f32, 3, _>(|c| PD_TOP[c] * (-TAU[c] * m).exp()))
}

/// The proxy (ground ending at 15 m) and the unmodelled world: the person and the terrain ring.
fn geometry(variant: &Variant) -> (Mesh, Mesh) {
    let (proxy, mut extra) = super::build_geometry_with_ground(PROXY_GROUND_HALF_M);
    let ground = extra.add_material(Material::diffuse(variant.name, variant.albedo));
    let node = extra.add_node("terrain", false);
    let (g, r) = (PROXY_GROUND_HALF_M, TERRAIN_HALF_M);
    // Four strips around the proxy's square, facing up (u × v = +Y).
    extra.push_quad(Vec3::new(-r, 0.0, -r), Vec3::Z * (r - g), Vec3::X * (2.0 * r), node, ground);
    extra.push_quad(Vec3::new(-r, 0.0, g), Vec3::Z * (r - g), Vec3::X * (2.0 * r), node, ground);
    extra.push_quad(Vec3::new(-r, 0.0, -g), Vec3::Z * (2.0 * g), Vec3::X * (r - g), node, ground);
    extra.push_quad(Vec3::new(g, 0.0, -g), Vec3::Z * (2.0 * g), Vec3::X * (r - g), node, ground);
    (proxy, extra)
}

/// One frame's sun and sky.
struct Moment {
    time: chrono::DateTime<chrono::FixedOffset>,
    sun: Vec3,
    azimuth_deg: f64,
    elevation_deg: f64,
    sky: SkyLight,
    pd: Vec3,
    pa: Vec3,
}

fn instants(variant: &Variant, observer: &Observer, geo: &GeoFrame) -> Result<Vec<Moment>> {
    let t0 = chrono::DateTime::parse_from_rfc3339(START)?;
    let mut out: Vec<Moment> = Vec::new();
    let mut scale = None;
    for i in 0..FRAMES {
        let time = t0 + chrono::Duration::seconds((i as f64 * INTERVAL_S) as i64);
        let pos = sun_position(observer, &time)?;
        let sun = geo.sun_dir_in_world(&pos);
        let hosek = HosekSky::new(sun, TURBIDITY, variant.albedo.map(f64::from)).context("Hosek sky")?;
        let sky = SkyLight::new(hosek);
        let eh = sky.horizontal_irradiance();
        let k = *scale.get_or_insert(PA_GREEN_FRAME0 / eh.y);
        let h = pos.apparent_elevation_deg();
        out.push(Moment { time, sun, azimuth_deg: pos.azimuth_deg, elevation_deg: h, sky, pd: sun_irradiance(h), pa: eh * k });
    }
    Ok(out)
}

/// Writes both scenes into `dir`.
pub fn run(args: &Args, dir: &Path) -> Result<()> {
    let start = Instant::now();
    for v in &VARIANTS {
        write_variant(args, &dir.join(v.name), v)?;
    }
    eprintln!("wrote the winter scenes into {} in {:.0} s", dir.display(), start.elapsed().as_secs_f64());
    Ok(())
}

fn write_variant(args: &Args, out: &Path, variant: &Variant) -> Result<()> {
    let clock = Instant::now();
    std::fs::create_dir_all(out.join("calib"))?;
    std::fs::create_dir_all(out.join("frames/hdr"))?;
    let (proxy, extra) = geometry(variant);
    heliar::scene::gltf::save_glb(&proxy, &out.join("proxy.glb"))?;
    let mut world = proxy.clone();
    world.append(&extra);
    let scene = RayScene::new(world);
    let truth_albedo = Courtyard { ground_tris: 2 };
    let cam = super::camera_sized(args.width, args.height);
    let (w, h) = (args.width, args.height);
    let observer = Observer::new(super::LAT, super::LON, super::ELEV);
    let geo = GeoFrame::default();
    let frames = instants(variant, &observer, &geo)?;
    let terrain = Vec3::from(variant.albedo);

    // Environment map at frame 0, the sun splatted into its texel.
    let f0 = &frames[0];
    let light0 = Lighting { sun: f0.sun, sky: &f0.sky, terrain_albedo: terrain, lamp: None };
    let (ew, eh) = (ENV_WIDTH, ENV_WIDTH / 2);
    let (esky, esun) = render_env(&scene, &truth_albedo, Vec3::from(ENV_CENTRE), ew, eh, &light0, ENV_SPP, 11);
    let mut env = LinearImage::new(ew, eh);
    for (i, p) in env.data.iter_mut().enumerate() {
        *p = (esky[i] * f0.pa + esun[i] * f0.pd).to_array();
    }
    let (sx, sy) = heliar::geometry::equirect::texel_from_dir(f0.sun, ew, eh);
    let (sx, sy) = ((sx as u32).min(ew - 1), (sy as u32).min(eh - 1));
    let omega = heliar::geometry::equirect::texel_solid_angle(sy, ew, eh);
    env.set(sx, sy, (Vec3::from(env.get(sx, sy)) + f0.pd / omega).to_array());
    env.write_exr(&out.join("env.exr"), ExrPrecision::Half)?;
    eprintln!("{}: environment map in {:.0} s", variant.name, clock.elapsed().as_secs_f64());

    let mut truth = String::from("frame,time,pd_r,pd_g,pd_b,pa_r,pa_g,pa_b,sun_azimuth_deg,sun_apparent_zenith_deg,terrain_r,terrain_g,terrain_b\n");
    let mut previews = Vec::new();
    for (i, f) in frames.iter().enumerate() {
        let light = Lighting { sun: f.sun, sky: &f.sky, terrain_albedo: terrain, lamp: None };
        let (sky, sun) = render_region(&scene, &truth_albedo, &cam, &light, FRAME_SPP, 100 + i as u64, (0, 0, w, h));
        let mut rng = SmallRng::seed_from_u64(1000 + i as u64);
        let img = LinearImage {
            width: w,
            height: h,
            data: sky
                .iter()
                .zip(&sun)
                .map(|(s, d)| {
                    let clean = *s * f.pa + *d * f.pd;
                    std::array::from_fn(|c| (clean[c] + (NOISE_REL * clean[c] + NOISE_ABS) * normal(&mut rng)).max(0.0))
                })
                .collect(),
        };
        img.write_exr(&out.join(format!("frames/hdr/frame_{i:03}.exr")), ExrPrecision::Half)?;
        if i == 0 || i + 1 == frames.len() {
            previews.push(img);
        }
        let (pd, pa) = (f.pd, f.pa);
        let t = variant.albedo;
        writeln!(truth, "{i},{},{},{},{},{},{},{},{:.6},{:.6},{},{},{}", f.time.to_rfc3339(), pd.x, pd.y, pd.z, pa.x, pa.y, pa.z, f.azimuth_deg, 90.0 - f.elevation_deg, t[0], t[1], t[2])?;
        eprintln!("{}: frame {i} (sun elevation {:.2}°, Pd {pd:.3}, Pa {pa:.3}) at {:.0} s", variant.name, f.elevation_deg, clock.elapsed().as_secs_f64());
    }
    write(&out.join("truth.csv"), &truth)?;
    // preview.png: the first and last frames side by side, at half size (the folder stays small).
    let sheet = LinearImage::from_fn(w * 2 + 4, h, |x, y| if x < w { previews[0].get(x, y) } else if x < w + 4 { [1.0; 3] } else { previews[1].get(x - w - 4, y) });
    sheet.resized(w + 2, h / 2).write_png_srgb(&out.join("preview.png"), 2.0)?;
    write_manifests(out, variant, &cam)?;
    let floor = write_references(out, &cam, &proxy, &extra, &truth_albedo, &frames, terrain)?;
    eprintln!("{}: written in {:.0} s; reference noise floor (relative RMSE between the two seeds, object and shadow) {floor}", variant.name, clock.elapsed().as_secs_f64());
    Ok(())
}

/// Renders the reference frames twice, writes them, and returns the noise floor per frame.
fn write_references(out: &Path, cam: &heliar::camera::Camera, proxy: &Mesh, extra: &Mesh, real: &Courtyard, frames: &[Moment], terrain: Vec3) -> Result<String> {
    std::fs::create_dir_all(out.join("objects"))?;
    std::fs::create_dir_all(out.join("reference/second_seed"))?;
    let statue_path = out.join(STATUE_FILE);
    heliar::scene::gltf::save_glb(&super::statue_local(), &statue_path)?;
    let placement = glam::Mat4::from_scale_rotation_translation(Vec3::ONE, glam::Quat::from_rotation_y((STATUE_ROTATION_Y_DEG as f32).to_radians()), DVec3::from(STATUE_TRANSLATION).as_vec3());
    let (statue, _) = heliar::scene::gltf::load_gltf(&statue_path, placement, &[])?;
    let mut world = proxy.clone();
    world.append(extra);
    let real_tris = world.triangles.len();
    world.append(&statue);
    let scene = RayScene::new(world);
    let surfaces = WithStatue { real, real_tris, statue: &statue };
    let suns: Vec<Vec3> = REFERENCE_FRAMES.iter().map(|&i| frames[i].sun).collect();
    let region = super::statue::reference_crop(cam, &statue, &suns)?;
    let mut renders: Vec<[LinearImage; 2]> = Vec::new();
    let mut names = Vec::new();
    for &i in &REFERENCE_FRAMES {
        let f = &frames[i];
        let light = Lighting { sun: f.sun, sky: &f.sky, terrain_albedo: terrain, lamp: None };
        let pair = REFERENCE_SEEDS.map(|seed| {
            let (sky, sun) = render_region(&scene, &surfaces, cam, &light, REFERENCE_SPP, seed + i as u64, region);
            LinearImage { width: region.2, height: region.3, data: sky.iter().zip(&sun).map(|(s, d)| (*s * f.pa + *d * f.pd).to_array()).collect() }
        });
        let name = format!("frame_{i:03}.exr");
        pair[0].write_exr(&out.join("reference").join(&name), ExrPrecision::Half)?;
        pair[1].write_exr(&out.join("reference/second_seed").join(&name), ExrPrecision::Half)?;
        names.push(name);
        renders.push(pair);
    }
    // The floor through the crate's own metric, on the scene as heliar loads it.
    let loaded = heliar::scene::Scene::load(out).with_context(|| format!("loading {}", out.display()))?;
    let objects = RayScene::new(loaded.virtual_objects.first().context("the scene has no virtual object")?.mesh.clone());
    let proxy_scene = RayScene::new(loaded.proxy.clone());
    let crop = Crop { x: region.0, y: region.1, width: region.2, height: region.3 };
    let mut floors = Vec::new();
    for (k, &i) in REFERENCE_FRAMES.iter().enumerate() {
        let classes = Classes::new(&loaded, &objects, &proxy_scene, crop, frames[i].sun);
        let full = LinearImage::from_fn(cam.intrinsics.width, cam.intrinsics.height, |x, y| {
            if x >= crop.x && y >= crop.y && x < crop.x + crop.width && y < crop.y + crop.height { renders[k][0].get(x - crop.x, y - crop.y) } else { [0.0; 3] }
        });
        let e = composite_error(&classes, &full, &renders[k][1]);
        floors.push(format!("frame {i}: {:.4} (object {:.4}, shadow {:.4}, {} px)", e.object_and_shadow, e.object, e.shadow, e.pixels));
    }
    let floor = floors.join("; ");
    write(
        &out.join("reference/reference.toml"),
        &format!(
            "# Reference frames of the winter courtyard with the statue ({STATUE_FILE}) physically present, written by\n\
             # gen-courtyard --winter: the same camera, true albedo, sky, terrain and lighting as frames/hdr, path traced\n\
             # by the generator's own renderer without sensor noise. second_seed/ holds the same frames rendered with\n\
             # other seeds. Noise floor, relative RMSE between the two renders over the object and its shadow\n\
             # (heliar::render::reference; one render's own noise is this / √2): {floor}.\n\
             frames = {REFERENCE_FRAMES:?}\n\
             files = {names:?}\n\
             crop = {{ x = {}, y = {}, width = {}, height = {} }}\n\
             sky_spp = {REFERENCE_SPP}\n\
             sun_spp = {REFERENCE_SPP}\n",
            region.0, region.1, region.2, region.3
        ),
    )?;
    Ok(floor)
}

/// `calib/camera.toml` and `scene.toml`.
fn write_manifests(out: &Path, variant: &Variant, cam: &heliar::camera::Camera) -> Result<()> {
    let k = &cam.intrinsics;
    write(
        &out.join("calib/camera.toml"),
        &format!(
            "# Camera calibration of the winter courtyard (written by gen-courtyard --winter; see scenes/README.md).\n\
             width = {}\nheight = {}\nfx = {}\nfy = {}\ncx = {}\ncy = {}\n\
             distortion = {:?}  # k1, k2, p1, p2, k3\n\n\
             [pose]\nposition = [4.5, 1.7, 9.0]\nlook_at = [-2.5, 0.6, -4.0]\nup = [0.0, 1.0, 0.0]\n\n\
             [response]\nkind = \"srgb\"\nexposure = 1.0\nsaturation = 0.98\n",
            k.width, k.height, k.fx, k.fy, k.cx, k.cy, k.distortion().copied().unwrap_or_default()
        ),
    )?;
    let [tx, ty, tz] = STATUE_TRANSLATION;
    let [ex, ey, ez] = ENV_CENTRE;
    write(
        &out.join("scene.toml"),
        &format!(
            r#"# The winter courtyard, {name} variant (written by gen-courtyard --winter; see scenes/README.md).
name = "winter_{name}"
description = "The courtyard on a December morning (sun 5-10 degrees high) under a Hosek-Wilkie sky of turbidity 3. The proxy ground ends 15 m away; beyond it lies {words}, which the proxy does not know. Rendered by the generator's own path tracer."

[place]
latitude_deg = {lat}
longitude_deg = {lon}
elevation_m = {elev}
north = [0.0, 0.0, -1.0]

[proxy]
file = "proxy.glb"

[camera]
file = "calib/camera.toml"

[[virtual_objects]]
file = "{STATUE_FILE}"
translation = [{tx}, {ty}, {tz}]
rotation_y_deg = {STATUE_ROTATION_Y_DEG}
scale = 1.0

[envmap]
file = "env.exr"
capture_center = [{ex}, {ey}, {ez}]
capture_time = "{START}"

[irradiance]
min = [-6.0, 0.1, -6.0]
max = [6.0, 3.0, 6.0]
spacing_m = 1.0

[[sequences]]
name = "hdr"
dir = "frames/hdr"
start = "{START}"
fps = {fps}
truth = "truth.csv"
"#,
            name = variant.name,
            words = variant.words,
            lat = super::LAT,
            lon = super::LON,
            elev = super::ELEV,
            fps = 1.0 / INTERVAL_S,
        ),
    )
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn air_mass_and_sun_colour() {
        // Kasten–Young: m(90°) = 0.9997, m(10°) ≈ 5.60, m(5°) ≈ 10.3 (their table).
        assert!((air_mass(90.0) - 1.0).abs() < 1e-3);
        assert!((air_mass(10.0) - 5.60).abs() < 0.02, "{}", air_mass(10.0));
        assert!((air_mass(5.0) - 10.3).abs() < 0.1, "{}", air_mass(5.0));
        // The low sun is warm: red > green > blue, and dimmer at 5° than at 10°.
        let (lo, hi) = (sun_irradiance(5.0), sun_irradiance(10.0));
        assert!(lo.x > lo.y && lo.y > lo.z && hi.y > lo.y);
    }
}
