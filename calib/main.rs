//! `heliar-calib`: the calibration tool. It prepares a scene folder that `heliar` accepts:
//! camera intrinsics and distortion from chessboards, the camera pose against the proxy, the
//! marking of diffuse estimation surfaces, and HDR environment maps from bracketed exposures.
//! Every step validates its input, and a scene is never left half-valid (see `edit.rs`).

mod edit;

use anyhow::{Context, Result, bail};
use clap::{Parser, Subcommand};
use edit::{FileSource, create_scene, edit_scene};
use glam::{DVec2, DVec3};
use heliar::calib::Rgb8;
use heliar::calib::chessboard::{Board, calibrate_fisheye, calibrate_pinhole, detect_corners};
use heliar::calib::hdr::{merge_debevec, remove_reflection};
use heliar::calib::pose::solve_pose;
use heliar::io::image::ExrPrecision;
use heliar::scene::Scene;
use std::path::{Path, PathBuf};

#[derive(Parser)]
#[command(name = "heliar-calib", version, about = "Prepare heliar scene folders: camera, pose, diffuse surfaces, HDR environment maps")]
struct Cli {
    #[command(subcommand)]
    command: Command,
}

#[derive(Subcommand)]
enum Command {
    /// Intrinsics and lens distortion from chessboard images or a video.
    Intrinsics(IntrinsicsArgs),
    /// Camera pose from 2D–3D point pairs (solvePnP); updates the scene's camera file.
    Pose(PoseArgs),
    /// Mark (or unmark) proxy nodes as diffuse estimation surfaces, by name or by clicking a pixel.
    Mark(MarkArgs),
    /// Merge bracketed exposures into an HDR image (Debevec), optionally removing a lens reflection.
    Hdr(HdrArgs),
    /// Create a new scene folder from a proxy, a camera file and the place.
    New(NewArgs),
}

fn main() {
    let cli = Cli::parse();
    let r = match cli.command {
        Command::Intrinsics(a) => intrinsics(a),
        Command::Pose(a) => pose(a),
        Command::Mark(a) => mark(a),
        Command::Hdr(a) => hdr(a),
        Command::New(a) => new_scene(a),
    };
    if let Err(e) = r {
        eprintln!("error: {e:#}");
        std::process::exit(1);
    }
}

fn parse_board(s: &str, square_mm: f64) -> Result<Board> {
    let (c, r) = s.split_once(['x', 'X']).with_context(|| format!("--board '{s}': expected COLSxROWS inner corners, e.g. 9x6"))?;
    let (cols, rows): (u32, u32) = (c.trim().parse()?, r.trim().parse()?);
    if cols < 3 || rows < 3 {
        bail!("--board '{s}': at least 3×3 inner corners");
    }
    if !(square_mm.is_finite() && square_mm > 0.0) {
        bail!("--square-mm must be positive");
    }
    Ok(Board { cols, rows, square_m: square_mm / 1000.0 })
}

#[derive(clap::Args)]
struct IntrinsicsArgs {
    /// Folder of chessboard images (PNG/JPEG).
    #[arg(long, conflicts_with = "video")]
    images: Option<PathBuf>,
    /// A video of the chessboard.
    #[arg(long)]
    video: Option<PathBuf>,
    /// With --video, use every N-th frame.
    #[arg(long, default_value_t = 10)]
    every: u64,
    /// Inner corners, COLSxROWS.
    #[arg(long)]
    board: String,
    /// Square side, millimetres.
    #[arg(long)]
    square_mm: f64,
    /// Fit the Kannala–Brandt fisheye model instead of Brown–Conrady.
    #[arg(long)]
    fisheye: bool,
    /// Also fit the sixth-order radial term k3 (very wide lenses, with views covering the corners).
    #[arg(long)]
    k3: bool,
    /// Camera file to write (its pose and response are kept when it exists).
    #[arg(long, short)]
    output: Option<PathBuf>,
}

fn intrinsics(a: IntrinsicsArgs) -> Result<()> {
    let board = parse_board(&a.board, a.square_mm)?;
    let mut views = Vec::new();
    let mut size: Option<(u32, u32)> = None;
    let mut seen = 0usize;
    let mut add = |img: Rgb8, label: String| -> Result<()> {
        seen += 1;
        match size {
            Some(s) if s != (img.width, img.height) => bail!("{label}: {}×{} but earlier views are {}×{}", img.width, img.height, s.0, s.1),
            _ => size = Some((img.width, img.height)),
        }
        match detect_corners(&img, &board)? {
            Some(c) => views.push(c),
            None => eprintln!("{label}: board not found, skipped"),
        }
        Ok(())
    };
    match (&a.images, &a.video) {
        (Some(dir), None) => {
            let mut files: Vec<PathBuf> = std::fs::read_dir(dir)
                .with_context(|| format!("reading {}", dir.display()))?
                .filter_map(|e| e.ok().map(|e| e.path()))
                .filter(|p| p.extension().and_then(|e| e.to_str()).is_some_and(|e| ["png", "jpg", "jpeg"].contains(&e.to_ascii_lowercase().as_str())))
                .collect();
            files.sort();
            for f in files {
                add(Rgb8::open(&f)?, f.display().to_string())?;
            }
        }
        (None, Some(v)) => {
            let mut src = heliar::io::video::VideoSource::open_file(v)?;
            let mut i = 0u64;
            while let Some((frame, _)) = src.read()? {
                if i % a.every.max(1) == 0 {
                    let heliar::io::frames::FrameData::Ldr { codes, .. } = &frame.data else { unreachable!("video frames are 8-bit") };
                    let img = Rgb8 { width: frame.width, height: frame.height, data: codes.iter().map(|&c| c as u8).collect() };
                    add(img, format!("{} frame {i}", v.display()))?;
                }
                i += 1;
            }
        }
        _ => bail!("give --images DIR or --video FILE"),
    }
    let (w, h) = size.context("no images")?;
    eprintln!("board found in {} of {seen} views", views.len());
    if a.fisheye {
        let c = calibrate_fisheye(&views, &board, w, h)?;
        println!("{}", serde_json::to_string_pretty(&serde_json::json!({"model": "kannala_brandt", "width": w, "height": h, "result": c}))?);
        return Ok(());
    }
    let c = calibrate_pinhole(&views, &board, w, h, a.k3)?;
    if c.coverage < 0.6 {
        eprintln!("warning: the corners cover {:.0}% of the image; distortion near the edges is extrapolated (add views with the board near the corners)", 100.0 * c.coverage);
    }
    println!("{}", serde_json::to_string_pretty(&serde_json::json!({"model": "brown_conrady", "width": w, "height": h, "result": c}))?);
    if c.rms_px > 1.0 {
        eprintln!("warning: RMS reprojection error {:.2} px is high (good calibrations are below 0.5 px)", c.rms_px);
    }
    if let Some(out) = &a.output {
        let mut doc: toml_edit::DocumentMut = match std::fs::read_to_string(out) {
            Ok(t) => t.parse().with_context(|| format!("{}: not valid TOML", out.display()))?,
            Err(_) => DEFAULT_CAMERA.parse()?,
        };
        doc["width"] = toml_edit::value(w as i64);
        doc["height"] = toml_edit::value(h as i64);
        for (k, v) in [("fx", c.fx), ("fy", c.fy), ("cx", c.cx), ("cy", c.cy)] {
            doc[k] = toml_edit::value(v);
        }
        let mut arr = toml_edit::Array::new();
        for k in c.distortion {
            arr.push(k);
        }
        doc["distortion"] = toml_edit::value(arr);
        edit::write_atomic(out, doc.to_string().as_bytes())?;
        eprintln!("wrote {} (RMS {:.3} px over {} views)", out.display(), c.rms_px, c.views);
    }
    Ok(())
}

const DEFAULT_CAMERA: &str = "# Camera calibration (heliar-calib). Set the pose with `heliar-calib pose`.\nwidth = 0\nheight = 0\nfx = 0.0\nfy = 0.0\ncx = 0.0\ncy = 0.0\ndistortion = [0.0, 0.0, 0.0, 0.0, 0.0]\n\n[pose]\nposition = [0.0, 1.6, 0.0]\nlook_at = [0.0, 1.6, -1.0]\nup = [0.0, 1.0, 0.0]\n\n[response]\nkind = \"srgb\"\nexposure = 1.0\nsaturation = 0.98\n";

#[derive(clap::Args)]
struct PoseArgs {
    /// Scene folder.
    scene: PathBuf,
    /// CSV of point pairs `u,v,x,y,z` (pixel, world metres), header allowed.
    #[arg(long)]
    pairs: PathBuf,
    /// A frame to draw the proxy's edges on, as feedback.
    #[arg(long)]
    image: Option<PathBuf>,
    /// Where the overlay goes (default: beside the pairs file).
    #[arg(long)]
    overlay: Option<PathBuf>,
    /// Only report; do not change the scene.
    #[arg(long)]
    dry_run: bool,
}

fn read_pairs(path: &Path) -> Result<(Vec<DVec2>, Vec<DVec3>)> {
    let text = std::fs::read_to_string(path).with_context(|| format!("reading {}", path.display()))?;
    let (mut px, mut world) = (Vec::new(), Vec::new());
    for (i, line) in text.lines().enumerate() {
        let l = line.trim();
        if l.is_empty() || l.starts_with('#') {
            continue;
        }
        let v: Result<Vec<f64>, _> = l.split(',').map(|s| s.trim().parse::<f64>()).collect();
        match v {
            Ok(v) if v.len() == 5 && v.iter().all(|x| x.is_finite()) => {
                px.push(DVec2::new(v[0], v[1]));
                world.push(DVec3::new(v[2], v[3], v[4]));
            }
            _ if i == 0 => continue, // header
            _ => bail!("{}: line {}: expected u,v,x,y,z (five finite numbers)", path.display(), i + 1),
        }
    }
    Ok((px, world))
}

fn pose(a: PoseArgs) -> Result<()> {
    let scene = Scene::load(&a.scene).with_context(|| format!("loading {}", a.scene.display()))?;
    let (px, world) = read_pairs(&a.pairs)?;
    let k = &scene.camera.intrinsics;
    if let Some((i, p)) = px.iter().enumerate().find(|(_, p)| p.x < -0.5 || p.y < -0.5 || p.x > k.width as f64 - 0.5 || p.y > k.height as f64 - 0.5) {
        bail!("{}: pair {}: pixel ({}, {}) is outside the {}×{} image", a.pairs.display(), i + 1, p.x, p.y, k.width, k.height);
    }
    let fit = solve_pose(k, &px, &world)?;
    println!("{}", serde_json::to_string_pretty(&fit)?);
    if fit.rms_px > 3.0 {
        eprintln!("warning: RMS reprojection error {:.1} px: check the pairs (a swapped point?)", fit.rms_px);
    }
    if let Some(img_path) = &a.image {
        let cam = heliar::scene::camera::Camera { intrinsics: k.clone(), pose: fit.pose() };
        let out = a.overlay.clone().unwrap_or_else(|| a.pairs.with_extension("overlay.png"));
        draw_overlay(img_path, &cam, &scene.proxy, &px, &out)?;
        eprintln!("wrote {}", out.display());
    }
    if a.dry_run {
        return Ok(());
    }
    let rel = PathBuf::from(&scene.manifest.camera.file);
    let text = std::fs::read_to_string(a.scene.join(&rel))?;
    let mut doc: toml_edit::DocumentMut = text.parse()?;
    let mut pose = toml_edit::Table::new();
    let arr = |v: [f64; 3]| {
        let mut a = toml_edit::Array::new();
        for x in v {
            a.push(x);
        }
        toml_edit::value(a)
    };
    pose["rvec_camera_from_world"] = arr(fit.rvec_camera_from_world);
    pose["tvec_camera_from_world"] = arr(fit.tvec_camera_from_world);
    doc["pose"] = toml_edit::Item::Table(pose);
    edit_scene(&a.scene, &[(rel.clone(), doc.to_string().into_bytes())])?;
    eprintln!("updated {} (RMS {:.2} px, max {:.2} px)", a.scene.join(rel).display(), fit.rms_px, fit.max_px);
    Ok(())
}

/// Draws the proxy's triangle edges (projected with the solved pose) and the clicked points.
fn draw_overlay(img: &Path, cam: &heliar::scene::camera::Camera, proxy: &heliar::geometry::Mesh, clicks: &[DVec2], out: &Path) -> Result<()> {
    let mut im = image::open(img).with_context(|| format!("reading {}", img.display()))?.to_rgb8();
    let (w, h) = (im.width() as i64, im.height() as i64);
    let mut plot = |x: f64, y: f64, c: [u8; 3]| {
        let (x, y) = (x.round() as i64, y.round() as i64);
        if x >= 0 && y >= 0 && x < w && y < h {
            im.put_pixel(x as u32, y as u32, image::Rgb(c));
        }
    };
    for t in &proxy.triangles {
        for e in 0..3 {
            let (a, b) = (proxy.positions[t[e] as usize].as_dvec3(), proxy.positions[t[(e + 1) % 3] as usize].as_dvec3());
            for s in 0..=200 {
                let p = a + (b - a) * (s as f64 / 200.0);
                if let Some(uv) = cam.project_world(p) {
                    plot(uv.x, uv.y, [255, 220, 0]);
                }
            }
        }
    }
    for c in clicks {
        for d in -3..=3 {
            plot(c.x + d as f64, c.y, [255, 0, 0]);
            plot(c.x, c.y + d as f64, [255, 0, 0]);
        }
    }
    im.save(out).with_context(|| format!("writing {}", out.display()))?;
    Ok(())
}

#[derive(clap::Args)]
struct MarkArgs {
    /// Scene folder.
    scene: PathBuf,
    /// Node names.
    #[arg(long)]
    node: Vec<String>,
    /// Pixels `u,v` of the camera image: the proxy node each one sees is marked.
    #[arg(long, allow_hyphen_values = true)]
    pixel: Vec<String>,
    /// Unmark instead (only nodes listed in the manifest can be unmarked; glTF extras stay).
    #[arg(long)]
    unmark: bool,
}

fn mark(a: MarkArgs) -> Result<()> {
    let scene = Scene::load(&a.scene).with_context(|| format!("loading {}", a.scene.display()))?;
    let ray = heliar::geometry::raycast::RayScene::new(scene.proxy.clone());
    let mut names = a.node.clone();
    for s in &a.pixel {
        let (u, v) = s.split_once(',').with_context(|| format!("--pixel '{s}': expected u,v"))?;
        let (u, v): (f64, f64) = (u.trim().parse()?, v.trim().parse()?);
        let (o, d) = scene.camera.ray_at(DVec2::new(u, v)).with_context(|| format!("--pixel {s}: outside the lens model"))?;
        let hit = ray.intersect(o.as_vec3(), d.as_vec3(), f32::MAX).with_context(|| format!("--pixel {s}: sees no proxy geometry"))?;
        let node = &scene.proxy.nodes[scene.proxy.tri_node[hit.tri as usize] as usize].name;
        eprintln!("pixel {s} sees node '{node}'");
        names.push(node.clone());
    }
    if names.is_empty() {
        bail!("give --node NAME or --pixel U,V");
    }
    for n in &names {
        if !scene.proxy.nodes.iter().any(|x| x.name == *n) {
            bail!("{}: no node named '{n}' (have: {})", scene.manifest.proxy.file, scene.proxy.nodes.iter().map(|x| x.name.as_str()).collect::<Vec<_>>().join(", "));
        }
    }
    let mpath = a.scene.join(heliar::scene::MANIFEST_FILE);
    let mut doc: toml_edit::DocumentMut = std::fs::read_to_string(&mpath)?.parse()?;
    let mut list: Vec<String> = scene.manifest.proxy.diffuse_nodes.clone();
    for n in names {
        if a.unmark {
            list.retain(|x| *x != n);
        } else if !list.contains(&n) {
            list.push(n);
        }
    }
    let mut arr = toml_edit::Array::new();
    for n in &list {
        arr.push(n.as_str());
    }
    doc["proxy"]["diffuse_nodes"] = toml_edit::value(arr);
    let s = edit_scene(&a.scene, &[(PathBuf::from(heliar::scene::MANIFEST_FILE), doc.to_string().into_bytes())])?;
    println!("{}", serde_json::to_string(&s.proxy.nodes.iter().filter(|n| n.diffuse).map(|n| &n.name).collect::<Vec<_>>())?);
    Ok(())
}

#[derive(clap::Args)]
struct HdrArgs {
    /// The bracketed exposures (same view), comma-separated.
    #[arg(long, value_delimiter = ',', required = true)]
    images: Vec<PathBuf>,
    /// Exposure times in seconds, comma-separated, in the same order.
    #[arg(long, value_delimiter = ',', required = true)]
    times: Vec<f32>,
    /// A lens-frame reflection to remove, x,y,w,h (pixels) …
    #[arg(long, value_delimiter = ',', requires = "clean")]
    reflection: Vec<i32>,
    /// … and the clean rectangle of the same size cloned over it.
    #[arg(long, value_delimiter = ',', requires = "reflection")]
    clean: Vec<i32>,
    /// Output EXR (relative radiance); the recovered response goes beside it as CSV.
    #[arg(long, short)]
    output: PathBuf,
}

fn hdr(a: HdrArgs) -> Result<()> {
    let mut imgs = Vec::new();
    for p in &a.images {
        imgs.push(Rgb8::open(p)?);
    }
    if !a.reflection.is_empty() {
        let r: [i32; 4] = a.reflection.as_slice().try_into().context("--reflection takes x,y,w,h")?;
        let c: [i32; 4] = a.clean.as_slice().try_into().context("--clean takes x,y,w,h")?;
        imgs = imgs.iter().map(|im| remove_reflection(im, r, c)).collect::<Result<_, _>>()?;
    }
    let (merged, response) = merge_debevec(&imgs, &a.times)?;
    if let Some(parent) = a.output.parent().filter(|p| !p.as_os_str().is_empty()) {
        std::fs::create_dir_all(parent)?;
    }
    merged.write_exr(&a.output, ExrPrecision::Float)?;
    let csv: String = std::iter::once("r,g,b\n".to_string()).chain(response.iter().map(|r| format!("{},{},{}\n", r[0], r[1], r[2]))).collect();
    let rpath = a.output.with_extension("response.csv");
    std::fs::write(&rpath, csv)?;
    eprintln!("wrote {} and {}", a.output.display(), rpath.display());
    Ok(())
}

#[derive(clap::Args)]
struct NewArgs {
    /// The scene folder to create (must not exist).
    out: PathBuf,
    /// Proxy glTF.
    #[arg(long)]
    proxy: PathBuf,
    /// Camera file (from `intrinsics`).
    #[arg(long)]
    camera: PathBuf,
    /// Latitude, degrees north.
    #[arg(long, allow_hyphen_values = true)]
    lat: f64,
    /// Longitude, degrees east.
    #[arg(long, allow_hyphen_values = true)]
    lon: f64,
    /// Height above sea level, metres.
    #[arg(long, default_value_t = 0.0, allow_hyphen_values = true)]
    elevation: f64,
    /// World direction of north, x,y,z.
    #[arg(long, default_value = "0,0,-1", allow_hyphen_values = true)]
    north: String,
    /// Diffuse node names.
    #[arg(long, value_delimiter = ',')]
    diffuse: Vec<String>,
}

fn new_scene(a: NewArgs) -> Result<()> {
    let name = a.out.file_name().map(|n| n.to_string_lossy().into_owned()).unwrap_or_else(|| "scene".into());
    let diffuse = a.diffuse.iter().map(|d| format!("\"{d}\"")).collect::<Vec<_>>().join(", ");
    let north: Vec<f64> = a.north.split(',').map(|s| s.trim().parse::<f64>()).collect::<Result<_, _>>().context("--north: three numbers")?;
    if north.len() != 3 {
        bail!("--north: three numbers");
    }
    let manifest = format!(
        "name = \"{name}\"\n\n[place]\nlatitude_deg = {}\nlongitude_deg = {}\nelevation_m = {}\nnorth = [{}, {}, {}]\n\n[proxy]\nfile = \"proxy.glb\"\ndiffuse_nodes = [{diffuse}]\n\n[camera]\nfile = \"calib/camera.toml\"\n",
        a.lat, a.lon, a.elevation, north[0], north[1], north[2]
    );
    let s = create_scene(
        &a.out,
        &[
            (PathBuf::from("scene.toml"), FileSource::Bytes(manifest.into_bytes())),
            (PathBuf::from("proxy.glb"), FileSource::Copy(a.proxy.clone())),
            (PathBuf::from("calib/camera.toml"), FileSource::Copy(a.camera.clone())),
        ],
    )?;
    eprintln!("created {} ({} proxy triangles, {} diffuse nodes)", a.out.display(), s.proxy.triangles.len(), s.proxy.nodes.iter().filter(|n| n.diffuse).count());
    Ok(())
}
