//! Generates the bundled `courtyard` scene: proxy glTF, camera calibration, an HDR environment map,
//! an HDR and a clipped LDR frame sequence in which a cloud passes the sun, and the true `Pd`/`Pa`
//! of every frame.
//!
//! It also writes a virtual object (`objects/statue.glb`, placed by the manifest's
//! `[[virtual_objects]]`) and reference frames of a few instants with that object physically
//! present (`reference/`): its own glTF material, its shadow on the real ground, the wall's
//! shadow on it, interreflection both ways. The compositor's end-to-end test compares its output
//! with them. The object and references are added without changing any other output file.
//! A second object, a small delivery robot (`objects/robot.glb`, `robot.rs`), crosses the yard
//! along keyframes in the manifest (issue 15 §5); the references leave it out (they are cropped
//! around the statue, which it never reaches). `--objects-only` writes just the two objects.
//!
//! Frames are rendered by an independent path tracer (`render.rs`) with effects the estimator's
//! model leaves out: interreflection (up to 12 bounces), spatially varying true albedo (±8%
//! around the proxy's base colour, and a darker wet patch), an unmodelled person and its shadow,
//! anti-aliased edges, lens distortion, sensor noise, and in the LDR variant sRGB quantisation and
//! clipping. Everything is seeded: the same command writes the same files.
//!
//! `cargo run --release --bin gen-courtyard -- --out scenes/courtyard`

mod dusk;
mod dusk_parts;
mod render;
mod robot;
mod sky_render;
mod statue;
mod winter;

use anyhow::{Context, Result};
use clap::Parser;
use glam::{DVec3, Vec2, Vec3};
use heliar::geometry::raycast::RayScene;
use heliar::geometry::{Material, Mesh};
use heliar::io::image::{ExrPrecision, LinearImage, srgb_u8_from_linear};
use heliar::camera::{Camera, Intrinsics, Pose};
use heliar::sun::{GeoFrame, Observer, sun_position};
use rand::{SeedableRng, rngs::SmallRng};
use rand_distr_free::normal;
use render::TrueAlbedo;
use statue::{render_references, statue_local};
use std::fmt::Write as _;
use std::path::{Path, PathBuf};

/// Standard normal samples by Box–Muller (a few lines; no extra crate).
mod rand_distr_free {
    use rand::Rng;
    pub fn normal(rng: &mut impl Rng) -> f32 {
        let u1: f32 = rng.random::<f32>().max(1e-12);
        let u2: f32 = rng.random();
        (-2.0 * u1.ln()).sqrt() * (2.0 * std::f32::consts::PI * u2).cos()
    }
}

#[derive(Parser)]
#[command(about = "Generate the bundled courtyard scene")]
struct Args {
    /// Output scene folder.
    #[arg(long, default_value = "scenes/courtyard")]
    out: PathBuf,
    /// Frame width.
    #[arg(long, default_value_t = 320)]
    width: u32,
    /// Frame height.
    #[arg(long, default_value_t = 240)]
    height: u32,
    /// Number of frames.
    #[arg(long, default_value_t = 12)]
    frames: usize,
    /// Seconds between frames.
    #[arg(long, default_value_t = 10.0)]
    interval_s: f64,
    /// Samples per pixel of the sky basis (the sun basis uses half).
    #[arg(long, default_value_t = 256)]
    spp: u32,
    /// Environment map width (height is half).
    #[arg(long, default_value_t = 256)]
    env_width: u32,
    /// Samples per pixel of the reference frames' sky basis (the sun basis uses half); 0 skips them.
    /// 4096 leaves ≈ 1.5% per-pixel noise on the statue (measured against 1024).
    #[arg(long, default_value_t = 4096)]
    reference_spp: u32,
    /// Write the winter scenes instead of the courtyard, into DIR/snow and DIR/asphalt: a
    /// Hosek–Wilkie sky, a low December sun and distant terrain beyond a proxy ground that ends
    /// 15 m away (`winter.rs`). Of the other options only --width and --height apply.
    #[arg(long, value_name = "DIR")]
    winter: Option<PathBuf>,
    /// Write the dusk scene instead of the courtyard, into DIR: sunset and twilight with a street
    /// lamp that switches on (`dusk.rs`). Of the other options only --width and --height apply.
    #[arg(long, value_name = "DIR")]
    dusk: Option<PathBuf>,
    /// Write the dusk scene's reference frames split by light (sky, sun, lamp) into DIR, at
    /// --spp samples per pixel (`dusk_parts.rs`); nothing else is written.
    #[arg(long, value_name = "DIR")]
    dusk_parts: Option<PathBuf>,
    /// Write the dusk frames (frames/hdr, the whole view, no statue) split by light (sky, sun,
    /// lamp) into DIR with the frames' own seeds and samples, so that the parts add up to each
    /// frame before its sensor noise (`dusk_parts.rs`); nothing else is written.
    #[arg(long, value_name = "DIR")]
    dusk_frame_parts: Option<PathBuf>,
    /// Write only the courtyard's virtual objects (`objects/statue.glb`, `objects/robot.glb`) into
    /// --out; nothing else is written.
    #[arg(long)]
    objects_only: bool,
}

const START: &str = "2024-06-21T15:30:00+02:00";
const LAT: f64 = 57.0488;
const LON: f64 = 9.9217;
const ELEV: f64 = 8.0;
/// Nominal clear-sky sun irradiance (scaled radiance units).
const PD0: [f32; 3] = [3.2, 3.0, 2.7];
/// Nominal sky irradiance on a horizontal surface.
const PA0: [f32; 3] = [0.55, 0.62, 0.80];
/// Relative sensor noise (shot-noise-like) and absolute read noise of the HDR frames.
const NOISE_REL: f32 = 0.01;
const NOISE_ABS: f32 = 5e-4;
/// Exposure of the LDR variant: chosen so that the sunlit paving clips.
const LDR_EXPOSURE: f32 = 3.5;
/// The virtual object: file, and its placement in the manifest. It stands east of the
/// free-standing wall, so that at 15:30 the wall's shadow covers its pedestal and the lower half
/// of its sphere while the top is in the sun, and its own shadow falls partly on sunlit paving
/// and partly into the wall's shadow.
const STATUE_FILE: &str = "objects/statue.glb";
const STATUE_TRANSLATION: [f64; 3] = [-1.9, 0.0, 0.0];
const STATUE_ROTATION_Y_DEG: f64 = 25.0;
/// Frames rendered again with the object present: clear sun, the sun behind the cloud, clear again.
const REFERENCE_FRAMES: [usize; 3] = [0, 6, 11];
/// Pixels kept around the object and its shadow in the reference crops.
const REFERENCE_MARGIN_PX: f64 = 6.0;

/// The real proxy and, separately, what is really there but not modelled.
fn build_geometry() -> (Mesh, Mesh) {
    build_geometry_with_ground(40.0)
}

/// [`build_geometry`] with a square proxy ground of half-size `ground_half_m` around the origin.
fn build_geometry_with_ground(ground_half_m: f32) -> (Mesh, Mesh) {
    let mut proxy = Mesh::default();
    let paving = proxy.add_material(Material::diffuse("paving", [0.32, 0.30, 0.27]));
    let brick = proxy.add_material(Material::diffuse("brick", [0.34, 0.17, 0.12]));
    let plaster = proxy.add_material(Material::diffuse("plaster", [0.62, 0.60, 0.55]));
    let concrete = proxy.add_material(Material::diffuse("concrete", [0.45, 0.45, 0.43]));
    let ground = proxy.add_node("ground", true);
    let north = proxy.add_node("north_building", true);
    let west = proxy.add_node("west_building", true);
    let wall = proxy.add_node("wall", false);
    let g = ground_half_m;
    proxy.push_quad(Vec3::new(-g, 0.0, -g), Vec3::Z * (2.0 * g), Vec3::X * (2.0 * g), ground, paving);
    proxy.push_box(Vec3::new(-12.0, 0.0, -14.0), Vec3::new(12.0, 9.0, -8.0), north, brick, true);
    proxy.push_box(Vec3::new(-14.0, 0.0, -8.0), Vec3::new(-8.0, 6.0, 8.0), west, plaster, true);
    proxy.push_box(Vec3::new(-3.2, 0.0, -1.5), Vec3::new(-2.8, 2.4, 1.5), wall, concrete, true);

    let mut extra = Mesh::default();
    let cloth = extra.add_material(Material::diffuse("person", [0.12, 0.11, 0.10]));
    let person = extra.add_node("person", false);
    extra.push_box(Vec3::new(1.6, 0.0, 1.0), Vec3::new(2.1, 1.75, 1.35), person, cloth, true);
    (proxy, extra)
}

/// True albedo: the base colour with ±8% value noise on 0.3 m cells, and a wet patch (×0.55)
/// of radius 0.9 m on the ground.
struct Courtyard {
    ground_tris: usize,
}

fn hash3(x: i32, y: i32, z: i32) -> f32 {
    let mut h = (x as u32).wrapping_mul(0x8da6_b343) ^ (y as u32).wrapping_mul(0xd816_3841) ^ (z as u32).wrapping_mul(0xcb1a_b31f);
    h ^= h >> 13;
    h = h.wrapping_mul(0x5bd1_e995);
    h ^= h >> 15;
    (h & 0xffff) as f32 / 65535.0
}

fn value_noise(p: Vec3) -> f32 {
    let q = p / 0.3;
    let f = q.floor();
    let t = q - f;
    let (i, j, k) = (f.x as i32, f.y as i32, f.z as i32);
    let mut acc = 0.0;
    for dz in 0..2 {
        for dy in 0..2 {
            for dx in 0..2 {
                let w = (if dx == 1 { t.x } else { 1.0 - t.x }) * (if dy == 1 { t.y } else { 1.0 - t.y }) * (if dz == 1 { t.z } else { 1.0 - t.z });
                acc += w * hash3(i + dx, j + dy, k + dz);
            }
        }
    }
    acc
}

impl TrueAlbedo for Courtyard {
    fn albedo(&self, tri: u32, p: Vec3, base: Vec3) -> Vec3 {
        let mut a = base * (1.0 + 0.16 * (value_noise(p) - 0.5));
        if (tri as usize) < self.ground_tris && Vec2::new(p.x - 2.5, p.z - 4.2).length() < 0.9 {
            a *= 0.55;
        }
        a
    }
}

fn camera() -> Camera {
    let intrinsics = Intrinsics::brown_conrady(0, 0, 0.0, 0.0, 0.0, 0.0, [-0.08, 0.012, 0.0005, -0.0003, 0.0]);
    let pose = Pose::look_at(DVec3::new(4.5, 1.7, 9.0), DVec3::new(-2.5, 0.6, -4.0), DVec3::Y).expect("valid look-at");
    Camera { intrinsics, pose }
}

/// [`camera`] with intrinsics for `w × h` frames.
fn camera_sized(w: u32, h: u32) -> Camera {
    let mut cam = camera();
    let f = 0.8125 * w as f64; // ≈ 63° horizontal field of view
    cam.intrinsics = Intrinsics::brown_conrady(w, h, f, f * 1.002, w as f64 / 2.0 + 1.2, h as f64 / 2.0 - 1.1, *cam.intrinsics.distortion().unwrap_or(&[0.0; 5]));
    cam
}

/// Cloud transmission of the sun for frame `i` of `n`: clear, then a cloud passes (minimum 1%).
fn cloud(i: usize, n: usize) -> f32 {
    let mid = (n / 2) as f32;
    let width = (n as f32 / 7.0).max(0.8);
    1.0 - 0.99 * (-((i as f32 - mid) / width).powi(2)).exp()
}

fn write(path: &Path, text: &str) -> Result<()> {
    std::fs::write(path, text).with_context(|| format!("writing {}", path.display()))
}

fn main() -> Result<()> {
    let args = Args::parse();
    if let Some(dir) = &args.dusk_frame_parts {
        return dusk_parts::run_frames(&args, dir);
    }
    if let Some(dir) = &args.dusk_parts {
        return dusk_parts::run(&args, dir);
    }
    if let Some(dir) = &args.dusk {
        return dusk::run(&args, dir);
    }
    if let Some(dir) = &args.winter {
        return winter::run(&args, dir);
    }
    let out = &args.out;
    if args.objects_only {
        return write_objects(out);
    }
    for d in ["calib", "frames/hdr", "frames/ldr"] {
        std::fs::create_dir_all(out.join(d))?;
    }
    let (proxy, extra) = build_geometry();
    let ground_tris = 2;
    heliar::scene::gltf::save_glb(&proxy, &out.join("proxy.glb"))?;
    let mut world = proxy.clone();
    world.append(&extra);
    let scene = RayScene::new(world);
    let truth_albedo = Courtyard { ground_tris };

    let cam = camera_sized(args.width, args.height);
    let (w, h) = (args.width, args.height);

    let observer = Observer::new(LAT, LON, ELEV);
    let geo = GeoFrame::default();
    let t0 = chrono::DateTime::parse_from_rfc3339(START)?;

    let env_centre = Vec3::new(0.0, 1.5, 2.0);
    render_env_map(&args, &scene, &truth_albedo, env_centre, &observer, &geo, t0)?;

    let (times, previews) = render_frames(&args, &scene, &truth_albedo, &cam, &observer, &geo, t0)?;

    // The virtual objects, and reference frames with the statue physically present.
    write_objects(out)?;
    let statue_path = out.join(STATUE_FILE);
    let placement = glam::Mat4::from_scale_rotation_translation(
        Vec3::ONE,
        glam::Quat::from_rotation_y((STATUE_ROTATION_Y_DEG as f32).to_radians()),
        DVec3::from(STATUE_TRANSLATION).as_vec3(),
    );
    let (statue, _) = heliar::scene::gltf::load_gltf(&statue_path, placement, &[])?;
    if args.reference_spp > 0 {
        render_references(out, &args, &cam, &proxy, &extra, &statue, &truth_albedo, &times, &observer, &geo)?;
    }
    // preview.png: the first frame and the frame with the sun behind the cloud, side by side.
    let sheet = LinearImage::from_fn(w * previews.len() as u32 + 4 * (previews.len() as u32 - 1), h, |x, y| {
        let k = x / (w + 4);
        let xi = x % (w + 4);
        if xi >= w { [1.0; 3] } else { previews[k as usize].get(xi, y) }
    });
    sheet.write_png_srgb(&out.join("preview.png"), 2.0)?;

    write_camera(out, &cam)?;
    write_manifest(out, &args, env_centre)?;
    eprintln!("wrote {}", out.display());
    Ok(())
}

/// The environment map at the first frame's time, clear sky, with the sun splatted into its
/// texel (`env.exr`).
fn render_env_map(args: &Args, scene: &RayScene, truth_albedo: &Courtyard, env_centre: Vec3, observer: &Observer, geo: &GeoFrame, t0: chrono::DateTime<chrono::FixedOffset>) -> Result<()> {
    let out = &args.out;
    let sun0 = geo.sun_dir_in_world(&sun_position(observer, &t0)?);
    let (ew, eh) = (args.env_width, args.env_width / 2);
    eprintln!("rendering {ew}×{eh} environment map");
    let (esky, esun) = render::render_env_basis(scene, truth_albedo, env_centre, ew, eh, sun0, args.spp / 4, 11);
    let mut env = LinearImage::new(ew, eh);
    for (i, p) in env.data.iter_mut().enumerate() {
        let v = esky[i] * Vec3::from(PA0) + esun[i] * Vec3::from(PD0);
        *p = v.to_array();
    }
    let (sx, sy) = heliar::geometry::equirect::texel_from_dir(sun0, ew, eh);
    let (sx, sy) = ((sx as u32).min(ew - 1), (sy as u32).min(eh - 1));
    let omega = heliar::geometry::equirect::texel_solid_angle(sy, ew, eh);
    let prev = Vec3::from(env.get(sx, sy));
    env.set(sx, sy, (prev + Vec3::from(PD0) / omega).to_array());
    env.write_exr(&out.join("env.exr"), ExrPrecision::Half)?;

    Ok(())
}

/// The HDR and LDR frames and `truth.csv`; returns the frame times and two previews (the first
/// frame and the one with the sun behind the cloud).
#[allow(clippy::type_complexity)]
fn render_frames(
    args: &Args,
    scene: &RayScene,
    truth_albedo: &Courtyard,
    cam: &Camera,
    observer: &Observer,
    geo: &GeoFrame,
    t0: chrono::DateTime<chrono::FixedOffset>,
) -> Result<(Vec<chrono::DateTime<chrono::FixedOffset>>, Vec<LinearImage>)> {
    let out = &args.out;
    let (w, h) = (args.width, args.height);
    let sky_spp = args.spp;
    eprintln!("rendering the sky basis ({w}×{h}, {sky_spp} spp)");
    let (sky_basis, _) = render::render_basis(scene, truth_albedo, cam, Vec3::Y, sky_spp, 1);
    let mut previews: Vec<LinearImage> = Vec::new();
    let mut truth = String::from("frame,time,pd_r,pd_g,pd_b,pa_r,pa_g,pa_b,sun_azimuth_deg,sun_apparent_zenith_deg\n");
    let mut times = Vec::new();
    for i in 0..args.frames {
        let t = t0 + chrono::Duration::milliseconds((i as f64 * args.interval_s * 1e3) as i64);
        let pos = sun_position(observer, &t)?;
        let l = geo.sun_dir_in_world(&pos);
        eprintln!("frame {i}: sun az {:.3}° zen {:.3}°", pos.azimuth_deg, pos.apparent_zenith_deg);
        let (_, sun_basis) = render::render_basis(scene, truth_albedo, cam, l, (sky_spp / 2).max(1), 100 + i as u64);
        let m = cloud(i, args.frames);
        let pd = Vec3::from(PD0) * m;
        // Clouds near the sun brighten and whiten the sky a little.
        let pa = Vec3::from(PA0) * (1.0 + 0.25 * (1.0 - m)) + Vec3::splat(0.08 * (1.0 - m));
        let mut rng = SmallRng::seed_from_u64(1000 + i as u64);
        let mut hdr = LinearImage::new(w, h);
        let mut ldr = Vec::with_capacity((w * h * 3) as usize);
        for k in 0..(w * h) as usize {
            let clean = sky_basis[k] * pa + sun_basis[k] * pd;
            let noisy: [f32; 3] = std::array::from_fn(|c| {
                let v = clean[c];
                (v + (NOISE_REL * v + NOISE_ABS) * normal(&mut rng)).max(0.0)
            });
            hdr.data[k] = noisy;
            for c in noisy {
                ldr.push(srgb_u8_from_linear(c * LDR_EXPOSURE));
            }
        }
        hdr.write_exr(&out.join(format!("frames/hdr/frame_{i:03}.exr")), ExrPrecision::Half)?;
        if i == 0 || i == args.frames / 2 {
            previews.push(hdr.clone());
        }
        image::save_buffer(out.join(format!("frames/ldr/frame_{i:03}.png")), &ldr, w, h, image::ExtendedColorType::Rgb8)?;
        writeln!(
            truth,
            "{i},{},{},{},{},{},{},{},{:.6},{:.6}",
            t.to_rfc3339(),
            pd.x,
            pd.y,
            pd.z,
            pa.x,
            pa.y,
            pa.z,
            pos.azimuth_deg,
            pos.apparent_zenith_deg
        )?;
        times.push(t);
    }
    write(&out.join("truth.csv"), &truth)?;

    Ok((times, previews))
}

/// `calib/camera.toml`.
fn write_camera(out: &Path, cam: &Camera) -> Result<()> {
    let k = &cam.intrinsics;
    write(
        &out.join("calib/camera.toml"),
        &format!(
            "# Camera calibration of the courtyard scene (written by gen-courtyard).\n\
             # Pinhole + Brown–Conrady distortion, OpenCV conventions; see scenes/README.md.\n\
             width = {}\nheight = {}\nfx = {}\nfy = {}\ncx = {}\ncy = {}\n\
             distortion = {:?}  # k1, k2, p1, p2, k3\n\n\
             [pose]\nposition = [4.5, 1.7, 9.0]\nlook_at = [-2.5, 0.6, -4.0]\nup = [0.0, 1.0, 0.0]\n\n\
             [response]\nkind = \"srgb\"\nexposure = 1.0\nsaturation = 0.98\n",
            k.width, k.height, k.fx, k.fy, k.cx, k.cy, k.distortion().copied().unwrap_or_default()
        ),
    )
}

/// The virtual objects: the statue and the robot that crosses the yard (`robot.rs`).
fn write_objects(out: &Path) -> Result<()> {
    std::fs::create_dir_all(out.join("objects"))?;
    heliar::scene::gltf::save_glb(&statue_local(), &out.join(STATUE_FILE))?;
    heliar::scene::gltf::save_glb(&robot::robot_local(), &out.join(robot::ROBOT_FILE))?;
    Ok(())
}

/// `scene.toml`.
fn write_manifest(out: &Path, args: &Args, env_centre: Vec3) -> Result<()> {
    write(
        &out.join("scene.toml"),
        &format!(
            r#"# The bundled courtyard (written by gen-courtyard; see scenes/README.md for the format).
name = "courtyard"
description = "A paved courtyard between a brick and a plaster building, with a free-standing concrete wall. A cloud passes the sun. Rendered by an independent path tracer with interreflection, albedo texture, an unmodelled person, a wet patch, lens distortion and sensor noise."

[place]
latitude_deg = {LAT}
longitude_deg = {LON}
elevation_m = {ELEV}
north = [0.0, 0.0, -1.0]

[proxy]
file = "proxy.glb"

[camera]
file = "calib/camera.toml"

[[virtual_objects]]
file = "{STATUE_FILE}"
translation = [{}, {}, {}]
rotation_y_deg = {STATUE_ROTATION_Y_DEG}
scale = 1.0

{}
[estimator.sky]
# The generator's sky is uniform and nothing lies below the horizon: Jensen's model.
shape = "uniform"
terrain_albedo = [0.0, 0.0, 0.0]

[envmap]
file = "env.exr"
capture_center = [{}, {}, {}]
capture_time = "{START}"

[irradiance]
min = [-6.0, 0.1, -6.0]
max = [6.0, 3.0, 6.0]
spacing_m = 1.0

[[sequences]]
name = "hdr"
dir = "frames/hdr"
start = "{START}"
fps = {}
truth = "truth.csv"

[[sequences]]
name = "ldr"
dir = "frames/ldr"
start = "{START}"
fps = {}
exposure = {LDR_EXPOSURE}
truth = "truth.csv"
"#,
            STATUE_TRANSLATION[0],
            STATUE_TRANSLATION[1],
            STATUE_TRANSLATION[2],
            robot::robot_manifest(),
            env_centre.x,
            env_centre.y,
            env_centre.z,
            1.0 / args.interval_s,
            1.0 / args.interval_s
        ),
    )
}
