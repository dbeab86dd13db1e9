//! The dusk scene (`gen-courtyard --dusk DIR`): the courtyard at sunset and after, lit by the
//! setting sun, the twilight sky and a street lamp that switches on (issue 16, Granier's setting:
//! real light sources in the footage).
//!
//! - **Time and sun**: Aalborg (57.05° N) on 2024-09-22 from 19:00 to 19:50 CEST, a frame every
//!   10 min; the sun's apparent elevation falls from ≈ +1.6° to ≈ −5° (civil twilight).
//! - **Sky**: a Hosek–Wilkie sky of turbidity 3 for a sun at least 2° up; below 2° (frames 0–1,
//!   the sun 1.6° and 0.75° up, as well as after sunset) the shape of a sun 2° up at the sun's
//!   azimuth (the model is not defined for a sun below the horizon; a real twilight sky is
//!   brightest toward the set sun as this one is). heliar's estimator uses the sun's own shape,
//!   lifted onto the horizon once it has set: on frames 1–5 the two skies differ (the walls get
//!   2–11% more sky light than the estimator's model says, the paving 2–3% less), which is most
//!   of the estimator's low lamp scale on this scene (`docs/measurements.md`, "Why the dusk
//!   lamp's `k` came out low"). `Pa` (the sky's irradiance on an unoccluded
//!   horizontal surface) falls as `10^(h/3)` with the elevation `h` in degrees — about a factor of
//!   100 over civil twilight, as measured twilight illuminance does — and turns bluer.
//!   `Pd` follows the winter scenes' Beer–Lambert sun (`winter::sun_irradiance`) while `h > 0` and
//!   is 0 after sunset. Terrain beyond the world (rays that leave below the horizon) has albedo
//!   0.15.
//! - **The lamp**: a disc of radius 0.15 m, 4 m above the paving, facing down, radiance
//!   `L₀ cos² θ` ([`DiscLamp`]). It is off in frame 0 and on from frame 1 (sun, sky and lamp
//!   together at dusk). `lamps/street.ies` is its far-field table (`I₀ cos³ θ`, 5° steps), as a
//!   goniophotometer would record it, in the frames' units: the true lamp scale `k` is 1 when on.
//!   The scene declares it as an `ies` light with that schedule; near the lamp the disc's size
//!   makes the truth depart from the far field (0.3% at 4 m, 3% at 1 m), as a real luminaire does.
//!
//! Frames come from the importance-sampled tracer of `sky_render.rs` with the courtyard's true
//! albedo texture, wet patch, unmodelled person, lens distortion and sensor noise (HDR only).
//! `truth.csv` adds a `lamp_k` column. `reference/` holds frames 1 (dusk: sun, sky and lamp) and
//! 4 (night: sky and lamp) with the statue physically present, rendered twice with different
//! seeds for the noise floor.

use super::sky_render::{DiscLamp, Lighting, SkyLight, render_env, render_region_with_lamp};
use super::statue::WithStatue;
use super::winter::sun_irradiance;
use super::{Args, Courtyard, NOISE_ABS, NOISE_REL, STATUE_FILE, STATUE_ROTATION_Y_DEG, STATUE_TRANSLATION, normal, write};
use anyhow::{Context, Result};
use glam::{DVec3, Vec3};
use heliar::geometry::raycast::RayScene;
use heliar::io::image::{ExrPrecision, LinearImage};
use heliar::render::reference::{Classes, Crop, composite_error};
use heliar::sky::hosek::HosekSky;
use heliar::sun::{GeoFrame, Observer, sun_position};
use rand::{SeedableRng, rngs::SmallRng};
use std::fmt::Write as _;
use std::path::Path;
use std::time::Instant;

pub(super) const START: &str = "2024-09-22T19:00:00+02:00";
/// When the environment map was captured: the same afternoon, the lamp off.
const CAPTURE: &str = "2024-09-22T15:00:00+02:00";
pub(super) const FRAMES: usize = 6;
/// Seconds between frames (10 min).
pub(super) const INTERVAL_S: f64 = 600.0;
/// The lamp is on from this frame on.
pub(super) const LAMP_ON_FRAME: usize = 1;
const TURBIDITY: f64 = 3.0;
/// The sky's shape once the sun has set: the Hosek–Wilkie sky of a sun this high.
const TWILIGHT_SHAPE_ELEVATION_DEG: f64 = 2.0;
pub(super) const TERRAIN_ALBEDO: f32 = 0.15;
/// Green `Pa` at sunset (`h = 0`); `Pa ∝ 10^(h/3)`.
const PA_GREEN_SUNSET: f32 = 0.12;
/// Sky colour per unit green `Pa`, at sunset and (bluer) at −6°.
const PA_TINT_SUNSET: [f32; 3] = [0.95, 1.0, 1.15];
const PA_TINT_DEEP: [f32; 3] = [0.70, 1.0, 1.55];
/// Green `Pa` of the afternoon the map was captured.
const PA_GREEN_CAPTURE: f32 = 0.45;
/// The lamp: disc centre (world metres), radius, intensity on the axis (frame units, k = 1).
pub(super) const LAMP_CENTRE: [f32; 3] = [0.0, 4.0, 2.0];
const LAMP_RADIUS_M: f32 = 0.15;
const LAMP_INTENSITY: f32 = 0.8;
pub(super) const FRAME_SPP: u32 = 64;
/// Seed of frame `i`'s render: `FRAME_SEED + i` (its sensor noise draws from `3000 + i`).
pub(super) const FRAME_SEED: u64 = 300;
const ENV_SPP: u32 = 32;
const ENV_WIDTH: u32 = 256;
const ENV_CENTRE: [f32; 3] = [0.0, 1.5, 2.0];
const REFERENCE_SPP: u32 = 1024;
pub(super) const REFERENCE_FRAMES: [usize; 2] = [1, 4];
const REFERENCE_SEEDS: [u64; 2] = [5101, 5301];

pub(super) fn lamp() -> DiscLamp {
    DiscLamp { centre: Vec3::from(LAMP_CENTRE), radius: LAMP_RADIUS_M, intensity: LAMP_INTENSITY }
}

/// One frame's sun, sky and lamp.
pub(super) struct Moment {
    time: chrono::DateTime<chrono::FixedOffset>,
    pub(super) sun: Vec3,
    azimuth_deg: f64,
    elevation_deg: f64,
    pub(super) sky: SkyLight,
    pub(super) pd: Vec3,
    pub(super) pa: Vec3,
    pub(super) lamp_k: f32,
}

/// `Pa` at apparent elevation `h_deg` (module docs).
fn twilight_pa(h_deg: f64) -> Vec3 {
    let green = PA_GREEN_SUNSET * 10f32.powf((h_deg.min(3.0) / 3.0) as f32);
    let t = ((-h_deg / 6.0).clamp(0.0, 1.0)) as f32;
    Vec3::from(PA_TINT_SUNSET).lerp(Vec3::from(PA_TINT_DEEP), t) * green
}

/// The sky's shape for a sun at `sun`: its own while it is at least 2° up, else that of a sun 2° up
/// at its azimuth (module docs).
fn sky_for(sun: Vec3) -> Result<SkyLight> {
    let floor = TWILIGHT_SHAPE_ELEVATION_DEG.to_radians().sin() as f32;
    let shape_sun = if sun.y >= floor {
        sun
    } else {
        let flat = Vec3::new(sun.x, 0.0, sun.z).try_normalize().unwrap_or(Vec3::X);
        (flat * (1.0 - floor * floor).sqrt() + Vec3::Y * floor).normalize()
    };
    let terrain = [f64::from(TERRAIN_ALBEDO); 3];
    Ok(SkyLight::new(HosekSky::new(shape_sun, TURBIDITY, terrain).context("Hosek sky")?))
}

pub(super) fn moment_at(time: chrono::DateTime<chrono::FixedOffset>, observer: &Observer, geo: &GeoFrame, lamp_k: f32) -> Result<Moment> {
    let pos = sun_position(observer, &time)?;
    let sun = geo.sun_dir_in_world(&pos);
    let h = pos.apparent_elevation_deg();
    let pd = if h > 0.0 { sun_irradiance(h) } else { Vec3::ZERO };
    Ok(Moment { time, sun, azimuth_deg: pos.azimuth_deg, elevation_deg: h, sky: sky_for(sun)?, pd, pa: twilight_pa(h), lamp_k })
}

/// The far-field table of the lamp as an IES LM-63-2002 file (absolute photometry, candela in
/// the frames' units; rotationally symmetric: one horizontal angle).
fn ies_text() -> String {
    let l = lamp();
    let angles: Vec<f64> = (0..=18).map(|i| f64::from(i) * 5.0).collect();
    let cd: Vec<String> = angles.iter().map(|a| format!("{:.6}", l.far_field(a.to_radians().cos() as f32))).collect();
    let list = |v: &[String]| v.chunks(10).map(|c| c.join(" ")).collect::<Vec<_>>().join("\n");
    format!(
        "IESNA:LM-63-2002\n[TEST] gen-courtyard --dusk\n[MANUFAC] heliar synthetic goniophotometer\n[LUMINAIRE] street lamp, disc emitter r = {LAMP_RADIUS_M} m, L0 cos^2\n\
         TILT=NONE\n1 -1 1 {} 1 1 2 {d} {d} 0\n1 1 60\n{}\n0\n{}\n",
        angles.len(),
        list(&angles.iter().map(|a| format!("{a}")).collect::<Vec<_>>()),
        list(&cd),
        d = 2.0 * LAMP_RADIUS_M,
    )
}

/// Writes the dusk scene into `out`.
pub fn run(args: &Args, out: &Path) -> Result<()> {
    let clock = Instant::now();
    for d in ["calib", "frames/hdr", "lamps"] {
        std::fs::create_dir_all(out.join(d))?;
    }
    let (proxy, extra) = super::build_geometry();
    heliar::scene::gltf::save_glb(&proxy, &out.join("proxy.glb"))?;
    let mut world = proxy.clone();
    world.append(&extra);
    let scene = RayScene::new(world);
    let truth_albedo = Courtyard { ground_tris: 2 };
    let cam = super::camera_sized(args.width, args.height);
    let (w, h) = (args.width, args.height);
    let observer = Observer::new(super::LAT, super::LON, super::ELEV);
    let geo = GeoFrame::default();
    let terrain = Vec3::splat(TERRAIN_ALBEDO);
    write(&out.join("lamps/street.ies"), &ies_text())?;

    // The environment map: the afternoon of the same day, the lamp off, the sun splatted in.
    let cap = moment_at(chrono::DateTime::parse_from_rfc3339(CAPTURE)?, &observer, &geo, 0.0)?;
    let cap_pa = twilight_pa(90.0) / twilight_pa(90.0).y * PA_GREEN_CAPTURE;
    let light0 = Lighting { sun: cap.sun, sky: &cap.sky, terrain_albedo: terrain, lamp: None };
    let (ew, eh) = (ENV_WIDTH, ENV_WIDTH / 2);
    let (esky, esun) = render_env(&scene, &truth_albedo, Vec3::from(ENV_CENTRE), ew, eh, &light0, ENV_SPP, 21);
    let mut env = LinearImage::new(ew, eh);
    for (i, p) in env.data.iter_mut().enumerate() {
        *p = (esky[i] * cap_pa + esun[i] * cap.pd).to_array();
    }
    let (sx, sy) = heliar::geometry::equirect::texel_from_dir(cap.sun, ew, eh);
    let (sx, sy) = ((sx as u32).min(ew - 1), (sy as u32).min(eh - 1));
    let omega = heliar::geometry::equirect::texel_solid_angle(sy, ew, eh);
    env.set(sx, sy, (Vec3::from(env.get(sx, sy)) + cap.pd / omega).to_array());
    env.write_exr(&out.join("env.exr"), ExrPrecision::Half)?;
    eprintln!("dusk: environment map (sun {:.1}° up) in {:.0} s", cap.elevation_deg, clock.elapsed().as_secs_f64());

    let t0 = chrono::DateTime::parse_from_rfc3339(START)?;
    let frames = (0..FRAMES)
        .map(|i| {
            let time = t0 + chrono::Duration::seconds((i as f64 * INTERVAL_S) as i64);
            moment_at(time, &observer, &geo, if i >= LAMP_ON_FRAME { 1.0 } else { 0.0 })
        })
        .collect::<Result<Vec<_>>>()?;
    let mut truth = String::from("frame,time,pd_r,pd_g,pd_b,pa_r,pa_g,pa_b,sun_azimuth_deg,sun_apparent_zenith_deg,lamp_k\n");
    let mut previews = Vec::new();
    for (i, f) in frames.iter().enumerate() {
        let light = Lighting { sun: f.sun, sky: &f.sky, terrain_albedo: terrain, lamp: Some(lamp()) };
        let px = render_region_with_lamp(&scene, &truth_albedo, &cam, &light, FRAME_SPP, FRAME_SEED + i as u64, (0, 0, w, h));
        let mut rng = SmallRng::seed_from_u64(3000 + i as u64);
        let data = px
            .iter()
            .map(|(s, d, l)| {
                let clean = *s * f.pa + *d * f.pd + *l * f.lamp_k;
                std::array::from_fn(|c| (clean[c] + (NOISE_REL * clean[c] + NOISE_ABS) * normal(&mut rng)).max(0.0))
            })
            .collect();
        let img = LinearImage { width: w, height: h, data };
        img.write_exr(&out.join(format!("frames/hdr/frame_{i:03}.exr")), ExrPrecision::Half)?;
        if i == 0 || i + 1 == frames.len() {
            previews.push(img);
        }
        let (pd, pa) = (f.pd, f.pa);
        writeln!(truth, "{i},{},{},{},{},{},{},{},{:.6},{:.6},{}", f.time.to_rfc3339(), pd.x, pd.y, pd.z, pa.x, pa.y, pa.z, f.azimuth_deg, 90.0 - f.elevation_deg, f.lamp_k)?;
        eprintln!("dusk: frame {i} (sun {:.2}°, Pd {pd:.3}, Pa {pa:.4}, lamp {}) at {:.0} s", f.elevation_deg, f.lamp_k, clock.elapsed().as_secs_f64());
    }
    write(&out.join("truth.csv"), &truth)?;
    // preview.png: the first and last frames side by side at half size, brightened for the night.
    let sheet = LinearImage::from_fn(w * 2 + 4, h, |x, y| if x < w { previews[0].get(x, y) } else if x < w + 4 { [1.0; 3] } else { previews[1].get(x - w - 4, y) });
    sheet.resized(w + 2, h / 2).write_png_srgb(&out.join("preview.png"), 8.0)?;
    write_manifests(out, &cam, frames[LAMP_ON_FRAME].time)?;
    let floor = write_references(out, &cam, &proxy, &extra, &truth_albedo, &frames, terrain)?;
    eprintln!("dusk: written in {:.0} s; reference noise floor {floor}", clock.elapsed().as_secs_f64());
    Ok(())
}

/// Renders the reference frames twice, writes them, and returns the noise floor per frame.
fn write_references(out: &Path, cam: &heliar::camera::Camera, proxy: &heliar::geometry::Mesh, extra: &heliar::geometry::Mesh, real: &Courtyard, frames: &[Moment], terrain: Vec3) -> Result<String> {
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
    // The shadow that matters at night is the lamp's: the crop covers the directions toward it.
    let (lo, hi) = statue.bounds().context("the statue has no triangles")?;
    let toward_lamp = (Vec3::from(LAMP_CENTRE) - (lo + hi) * 0.5).normalize();
    let region = super::statue::reference_crop(cam, &statue, &[toward_lamp])?;
    let mut renders: Vec<[LinearImage; 2]> = Vec::new();
    let mut names = Vec::new();
    for &i in &REFERENCE_FRAMES {
        let f = &frames[i];
        let light = Lighting { sun: f.sun, sky: &f.sky, terrain_albedo: terrain, lamp: Some(lamp()) };
        let pair = REFERENCE_SEEDS.map(|seed| {
            let px = render_region_with_lamp(&scene, &surfaces, cam, &light, REFERENCE_SPP, seed + i as u64, region);
            LinearImage { width: region.2, height: region.3, data: px.iter().map(|(s, d, l)| (*s * f.pa + *d * f.pd + *l * f.lamp_k).to_array()).collect() }
        });
        let name = format!("frame_{i:03}.exr");
        pair[0].write_exr(&out.join("reference").join(&name), ExrPrecision::Half)?;
        pair[1].write_exr(&out.join("reference/second_seed").join(&name), ExrPrecision::Half)?;
        names.push(name);
        renders.push(pair);
    }
    let loaded = heliar::scene::Scene::load(out).with_context(|| format!("loading {}", out.display()))?;
    let objects = RayScene::new(loaded.virtual_objects.first().context("the scene has no virtual object")?.mesh.clone());
    let proxy_scene = RayScene::new(loaded.proxy.clone());
    let crop = Crop { x: region.0, y: region.1, width: region.2, height: region.3 };
    let mut floors = Vec::new();
    for (k, _) in REFERENCE_FRAMES.iter().enumerate() {
        // Shadow classes toward the lamp (a directional stand-in for the point light).
        let classes = Classes::new(&loaded, &objects, &proxy_scene, crop, toward_lamp);
        let full = LinearImage::from_fn(cam.intrinsics.width, cam.intrinsics.height, |x, y| {
            if x >= crop.x && y >= crop.y && x < crop.x + crop.width && y < crop.y + crop.height { renders[k][0].get(x - crop.x, y - crop.y) } else { [0.0; 3] }
        });
        let e = composite_error(&classes, &full, &renders[k][1]);
        floors.push(format!("frame {}: {:.4} (object {:.4}, shadow {:.4}, {} px)", REFERENCE_FRAMES[k], e.object_and_shadow, e.object, e.shadow, e.pixels));
    }
    let floor = floors.join("; ");
    write(
        &out.join("reference/reference.toml"),
        &format!(
            "# Reference frames of the dusk courtyard with the statue ({STATUE_FILE}) physically present, written by\n\
             # gen-courtyard --dusk: the same camera, true albedo, sun, sky, lamp and terrain as frames/hdr, path traced\n\
             # by the generator's own renderer without sensor noise. second_seed/ holds the same frames rendered with\n\
             # other seeds. Noise floor, relative RMSE between the two renders over the object and its shadow toward the\n\
             # lamp (heliar::render::reference; one render's own noise is this / √2): {floor}.\n\
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
fn write_manifests(out: &Path, cam: &heliar::camera::Camera, lamp_on: chrono::DateTime<chrono::FixedOffset>) -> Result<()> {
    let k = &cam.intrinsics;
    write(
        &out.join("calib/camera.toml"),
        &format!(
            "# Camera calibration of the dusk courtyard (written by gen-courtyard --dusk; see scenes/README.md).\n\
             width = {}\nheight = {}\nfx = {}\nfy = {}\ncx = {}\ncy = {}\n\
             distortion = {:?}  # k1, k2, p1, p2, k3\n\n\
             [pose]\nposition = [4.5, 1.7, 9.0]\nlook_at = [-2.5, 0.6, -4.0]\nup = [0.0, 1.0, 0.0]\n\n\
             [response]\nkind = \"srgb\"\nexposure = 1.0\nsaturation = 0.98\n\
             read_noise = {}  # the frames' read noise (standard deviation, linear units; clipped at 0)\n",
            k.width, k.height, k.fx, k.fy, k.cx, k.cy, k.distortion().copied().unwrap_or_default(), NOISE_ABS
        ),
    )?;
    let [tx, ty, tz] = STATUE_TRANSLATION;
    let [ex, ey, ez] = ENV_CENTRE;
    let [lx, ly, lz] = LAMP_CENTRE;
    write(
        &out.join("scene.toml"),
        &format!(
            r#"# The dusk courtyard (written by gen-courtyard --dusk; see scenes/README.md).
name = "dusk"
description = "The courtyard at sunset and after (sun +1.6 to -5 degrees): the setting sun, a twilight sky that dims a hundredfold, and a street lamp that switches on at the second frame. The lamp is a disc emitter; lamps/street.ies is its far-field table. Rendered by the generator's own path tracer."

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

[[lights]]
name = "street lamp"
kind = "ies"
profile = "lamps/street.ies"
position = [{lx}, {ly}, {lz}]
aim = [0.0, -1.0, 0.0]
scale = 1.0
schedule = [{{ on = "{on}" }}]

[envmap]
file = "env.exr"
capture_center = [{ex}, {ey}, {ez}]
capture_time = "{CAPTURE}"

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
            lat = super::LAT,
            lon = super::LON,
            elev = super::ELEV,
            on = lamp_on.to_rfc3339(),
            fps = 1.0 / INTERVAL_S,
        ),
    )
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn twilight_dims_a_hundredfold_and_turns_blue() {
        let (up, deep) = (twilight_pa(0.0), twilight_pa(-6.0));
        assert!((up.y / deep.y - 100.0).abs() < 1e-2, "{}", up.y / deep.y);
        assert!(deep.z / deep.x > up.z / up.x);
    }

    #[test]
    fn ies_table_is_the_discs_far_field() {
        let t = ies_text();
        assert!(t.starts_with("IESNA:LM-63-2002") && t.contains("TILT=NONE"));
        // 0.8 cd on the axis, 0.8·cos³60° = 0.1 at 60°, 0 at 90°.
        assert!(t.contains("0.800000") && t.contains("0.100000") && t.trim_end().ends_with("0.000000"));
    }
}
