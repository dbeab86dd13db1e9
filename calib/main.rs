//! `heliar-calib`: the calibration tool. It prepares a scene folder that `heliar` accepts:
//! camera intrinsics and distortion from chessboards, the camera pose against the proxy, the
//! marking of diffuse estimation surfaces, and HDR environment maps from bracketed exposures.
//! Every step validates its input, and a scene is never left half-valid (see `edit.rs`).

mod edit;
mod ops;
mod ui;

use anyhow::{Context, Result, bail};
use clap::{Parser, Subcommand};
use glam::DVec2;
use heliar::opencv_calib::Rgb8;
use heliar::opencv_calib::chessboard::{calibrate_fisheye, calibrate_pinhole};
use heliar::opencv_calib::pose::solve_pose;
use heliar::scene::Scene;
use ops::intrinsics::ViewSource;
use std::path::PathBuf;

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
    /// Photometric calibration of a VEM camera: a log-response fit `c = a + b·ln Y` from gray
    /// patches (Havran et al. 2005, §5.1), optionally written into calib/fisheye.toml.
    Photometric(PhotometricArgs),
    /// The calibration app: all of the above with the mouse (needs a display).
    Ui(UiArgs),
}

#[derive(clap::Args)]
struct UiArgs {
    /// Scene folder to open.
    scene: Option<PathBuf>,
    /// Let Save and Export write over their inputs and over files of a scene (the scene edits
    /// themselves, Save pose and marking, need no flag).
    #[arg(long)]
    force: bool,
}

fn main() {
    let cli = Cli::parse();
    let r = match cli.command {
        Command::Intrinsics(a) => intrinsics(a),
        Command::Pose(a) => pose(a),
        Command::Mark(a) => mark(a),
        Command::Hdr(a) => hdr(a),
        Command::New(a) => new_scene(a),
        Command::Photometric(a) => photometric(a),
        Command::Ui(a) => ui::run(a.scene, a.force),
    };
    if let Err(e) = r {
        eprintln!("error: {e:#}");
        std::process::exit(1);
    }
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
    /// Write the output even over one of the inputs or an existing file of a scene (e.g. a
    /// scene's calib/camera.toml: `pose` and the app's Save edit a scene's camera file safely).
    #[arg(long)]
    force: bool,
}

fn intrinsics(a: IntrinsicsArgs) -> Result<()> {
    let board = ops::intrinsics::parse_board(&a.board, a.square_mm).context("--board/--square-mm")?;
    let source = match (&a.images, &a.video) {
        (Some(dir), None) => ViewSource::Images(dir.clone()),
        (None, Some(v)) => ViewSource::Video { path: v.clone(), every: a.every },
        _ => bail!("give --images DIR or --video FILE"),
    };
    if let Some(out) = &a.output {
        let input = a.images.as_ref().or(a.video.as_ref()).map(PathBuf::as_path);
        edit::check_output(out, &input.into_iter().collect::<Vec<_>>(), a.force).context("--output")?;
    }
    let found = ops::intrinsics::collect_views(&source, &board)?;
    for skip in &found.skipped {
        eprintln!("warning: skipped {skip}");
    }
    let (w, h) = found.size;
    let views = &found.corners;
    eprintln!("board found in {} of {} views ({} skipped, at least {} needed)", views.len(), found.seen, found.skipped.len(), heliar::opencv_calib::chessboard::MIN_VIEWS);
    let (lo, hi) = found.half_windows.iter().fold((i32::MAX, i32::MIN), |(lo, hi), &x| (lo.min(x), hi.max(x)));
    eprintln!(
        "sub-pixel corner window (cornerSubPix): half-size {} px ({} of the smallest square side, clamped to [{}, {}])",
        if lo == hi { lo.to_string() } else { format!("{lo}–{hi}") },
        heliar::opencv_calib::chessboard::SUBPIX_WINDOW_FRACTION,
        heliar::opencv_calib::chessboard::SUBPIX_HALF_WINDOW_MIN,
        heliar::opencv_calib::chessboard::SUBPIX_HALF_WINDOW_MAX
    );
    if a.fisheye {
        let c = calibrate_fisheye(views, &board, w, h)?;
        println!("{}", serde_json::to_string_pretty(&ops::intrinsics::fisheye_json(w, h, &c))?);
        return Ok(());
    }
    let c = calibrate_pinhole(views, &board, w, h, a.k3)?;
    let warnings = ops::intrinsics::warnings(&c);
    println!("{}", serde_json::to_string_pretty(&ops::intrinsics::pinhole_json(w, h, &c))?);
    for warning in warnings {
        eprintln!("warning: {warning}");
    }
    if let Some(out) = &a.output {
        let existing = ops::intrinsics::read_camera_file(out)?;
        let text = ops::intrinsics::camera_toml_with_intrinsics(existing.as_deref(), out, w, h, &c)?;
        edit::write_atomic(out, text.as_bytes())?;
        eprintln!("wrote {} (RMS {:.3} px over {} views)", out.display(), c.rms_px, c.views);
    }
    Ok(())
}

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
    /// Write the overlay even over one of the inputs.
    #[arg(long)]
    force: bool,
    /// Write the pose even when the scene's camera file (camera.file) lies outside the scene
    /// folder.
    #[arg(long)]
    allow_outside_scene: bool,
}

fn pose(a: PoseArgs) -> Result<()> {
    let options = heliar::scene::LoadOptions { allow_outside_scene: a.allow_outside_scene };
    let scene = Scene::load_with(&a.scene, &options).with_context(|| format!("loading {}", a.scene.display()))?;
    let (px, world) = ops::pose::read_pairs(&a.pairs)?;
    let k = &scene.camera.intrinsics;
    ops::pose::check_inside(k, &px, &a.pairs.display().to_string())?;
    ops::pose::check_pairs(&px, &world, &a.pairs.display().to_string())?;
    if let Some(img) = &a.image {
        // The overlay is drawn in the camera's pixels: a frame of another size is refused, not
        // rescaled (its header is read, not its pixels).
        let (w, h) = image::image_dimensions(img).with_context(|| format!("--image {}: not a readable image", img.display()))?;
        if (w, h) != (k.width, k.height) {
            bail!("--image {}: {w}×{h} but the camera calibration {} is {}×{} (give a frame of this camera)", img.display(), scene.camera_path.display(), k.width, k.height);
        }
    }
    if !a.dry_run {
        ops::pose::check_camera_inside(&a.scene, &scene, a.allow_outside_scene)?;
    }
    let overlay = a.image.as_ref().map(|_| a.overlay.clone().unwrap_or_else(|| a.pairs.with_extension("overlay.png")));
    if let Some(out) = &overlay {
        let scene_files = [a.scene.join(heliar::scene::MANIFEST_FILE), a.scene.join(&scene.manifest.camera.file), a.scene.join(&scene.manifest.proxy.file)];
        let mut inputs: Vec<&std::path::Path> = vec![&a.pairs];
        inputs.extend(a.image.as_deref());
        inputs.extend(scene_files.iter().map(PathBuf::as_path));
        edit::check_output(out, &inputs, a.force).context("--overlay")?;
    }
    let fit = solve_pose(k, &px, &world)?;
    println!("{}", serde_json::to_string_pretty(&fit)?);
    for warning in ops::pose::warnings(&fit) {
        eprintln!("warning: {warning}");
    }
    if let (Some(img_path), Some(out)) = (&a.image, &overlay) {
        let cam = heliar::camera::Camera { intrinsics: k.clone(), pose: fit.pose() };
        let mut im = image::open(img_path).with_context(|| format!("reading {}", img_path.display()))?.to_rgb8();
        let outline = ops::pose::project_outline(&cam, &ops::pose::outline_edges(&scene.proxy));
        ops::pose::draw_overlay(&mut im, &outline, &px);
        heliar::io::write_via_temp(out, |tmp| im.save(tmp).map_err(anyhow::Error::from)).with_context(|| format!("writing {}", out.display()))?;
        eprintln!("wrote {}", out.display());
    }
    if a.dry_run {
        return Ok(());
    }
    let (_, path) = ops::pose::save_pose(&a.scene, &scene, &fit, a.allow_outside_scene)?;
    eprintln!("updated {} (RMS {:.2} px, max {:.2} px)", path.display(), fit.rms_px, fit.max_px);
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
    /// Unmark instead. A node the proxy's glTF extras mark is unmarked by listing it in the
    /// manifest's `proxy.not_diffuse_nodes` (the proxy file is left alone).
    #[arg(long)]
    unmark: bool,
}

fn mark(a: MarkArgs) -> Result<()> {
    let scene = Scene::load(&a.scene).with_context(|| format!("loading {}", a.scene.display()))?;
    let rays = heliar::geometry::raycast::RayScene::new(scene.proxy.clone());
    let mut names = a.node.clone();
    for s in &a.pixel {
        let (u, v) = s.split_once(',').with_context(|| format!("--pixel '{s}': expected u,v"))?;
        let (u, v): (f64, f64) = (u.trim().parse().with_context(|| format!("--pixel '{s}'"))?, v.trim().parse().with_context(|| format!("--pixel '{s}'"))?);
        let node = &scene.proxy.nodes[ops::mark::node_at_pixel(&scene, &rays, DVec2::new(u, v)).with_context(|| format!("--pixel {s}"))?].name;
        eprintln!("pixel {s} sees node '{node}'");
        names.push(node.clone());
    }
    if names.is_empty() {
        bail!("give --node NAME or --pixel U,V");
    }
    for n in &names {
        ops::mark::node_index(&scene, n)?;
    }
    let extras = ops::mark::marked_by_extras(&scene)?;
    let by_extras = |n: &str| extras.iter().any(|x| x == n);
    let (list, not) = ops::mark::updated_lists(&scene, &names, a.unmark, by_extras);
    let manifest = a.scene.join(heliar::scene::MANIFEST_FILE);
    let not = (not != scene.manifest.proxy.not_diffuse_nodes).then_some(not);
    let s = ops::mark::set_marks(&a.scene, &list, not.as_deref()).with_context(|| format!("{}: not changed", manifest.display()))?;
    for n in &names {
        let now = s.proxy.nodes.iter().any(|x| x.name == *n && x.diffuse);
        match (a.unmark, now) {
            (true, false) if by_extras(n) => eprintln!(
                "unmarked '{n}': the glTF extras of {} mark it; the override is recorded in {} as proxy.not_diffuse_nodes (mark it again to undo)",
                scene.manifest.proxy.file,
                manifest.display()
            ),
            (true, false) => eprintln!("unmarked '{n}'"),
            (true, true) => eprintln!("warning: '{n}' is still marked: it inherits the mark of a parent node (unmark that one)"),
            (false, _) => eprintln!("marked '{n}'"),
        }
    }
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
    /// The back shot's bracketed exposures (same times): with --fisheye, the front (--images) and
    /// back shots are merged and stitched into an equirect environment map in the world frame.
    #[arg(long, value_delimiter = ',', requires = "fisheye")]
    back: Vec<PathBuf>,
    /// Fisheye calibration (calib/fisheye.toml: Kannala–Brandt lens, the front shot's orientation).
    #[arg(long, requires = "back")]
    fisheye: Option<PathBuf>,
    /// Width of the stitched equirect map (height = width / 2).
    #[arg(long, default_value_t = 1024)]
    width: u32,
    /// Write the outputs even over one of the inputs or an existing file of a scene.
    #[arg(long)]
    force: bool,
}

fn hdr(a: HdrArgs) -> Result<()> {
    ops::hdr::check_times(&a.images, &a.times).context("--images/--times")?;
    if !a.back.is_empty() {
        ops::hdr::check_times(&a.back, &a.times).context("--back/--times")?;
    }
    let inputs: Vec<&std::path::Path> = a.images.iter().chain(&a.back).map(PathBuf::as_path).chain(a.fisheye.as_deref()).collect();
    edit::check_output(&a.output, &inputs, a.force).context("--output")?;
    edit::check_output(&ops::hdr::response_path(&a.output), &inputs, a.force).context("--output (the response beside it)")?;
    let imgs = a.images.iter().map(|p| Rgb8::open(p)).collect::<Result<Vec<_>, _>>()?;
    let reflection = if a.reflection.is_empty() {
        None
    } else {
        let r: [i32; 4] = a.reflection.as_slice().try_into().context("--reflection takes x,y,w,h")?;
        let c: [i32; 4] = a.clean.as_slice().try_into().context("--clean takes x,y,w,h")?;
        Some((r, c))
    };
    let (merged, response) = ops::hdr::merge(&imgs, &a.times, reflection)?;
    let merged = match &a.fisheye {
        None => merged,
        Some(calib) => {
            let fe = heliar::vem::capture::lens_file::FisheyeCalib::load(calib)?;
            let lens = &fe.camera.intrinsics;
            if a.back.len() != a.images.len() {
                bail!("--back has {} exposures but --images has {}: give the same brackets for both shots", a.back.len(), a.images.len());
            }
            let back_imgs = a.back.iter().map(|p| Rgb8::open(p)).collect::<Result<Vec<_>, _>>()?;
            for (p, im) in a.images.iter().chain(&a.back).zip(imgs.iter().chain(&back_imgs)) {
                if (im.width, im.height) != (lens.width, lens.height) {
                    bail!("{}: {}×{} but the fisheye calibration {} is {}×{}", p.display(), im.width, im.height, calib.display(), lens.width, lens.height);
                }
            }
            if a.width < 8 || a.width % 2 != 0 {
                bail!("--width {}: must be an even number ≥ 8", a.width);
            }
            let (back, _) = ops::hdr::merge(&back_imgs, &a.times, reflection).context("merging the back shot")?;
            let project = |d: glam::DVec3| lens.project(d).map(|uv| (uv.x, uv.y));
            let pano = heliar::opencv_calib::hdr::stitch_fisheye_pair(&merged, &back, fe.camera.pose.rotation, a.width, &project);
            eprintln!("stitched front and back into a {}×{} equirect map", a.width, a.width / 2);
            pano
        }
    };
    let rpath = ops::hdr::write_outputs(&a.output, &merged, &response)?;
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
    let n = ops::scene::NewScene {
        proxy: a.proxy.clone(),
        camera: a.camera.clone(),
        latitude_deg: a.lat,
        longitude_deg: a.lon,
        elevation_m: a.elevation,
        north: ops::scene::parse_vec3(&a.north, "--north")?,
        diffuse: a.diffuse.clone(),
    };
    let s = ops::scene::create(&a.out, &n)?;
    eprintln!("created {} ({} proxy triangles, {} diffuse nodes)", a.out.display(), s.proxy.triangles.len(), s.proxy.nodes.iter().filter(|n| n.diffuse).count());
    Ok(())
}

#[derive(clap::Args)]
struct PhotometricArgs {
    /// Gray patches, CSV rows `code,luminance[,fit|check]` (codes as the camera writes them).
    #[arg(long)]
    patches: PathBuf,
    /// The code of full scale (255 for 8-bit, 65535 for 16-bit frames).
    #[arg(long, default_value_t = 255.0)]
    code_max: f64,
    /// Write the fit into this fisheye calibration's [response] (kind = "log", the patches file).
    #[arg(long)]
    calib: Option<PathBuf>,
    /// Largest relative luminance error (percent, over the fit and check patches) of a fit that
    /// is written into --calib.
    #[arg(long, default_value_t = ops::photometric::MAX_FIT_ERROR_PCT, allow_hyphen_values = true)]
    max_error: f64,
    /// Write the fit even when its error exceeds --max-error.
    #[arg(long)]
    force: bool,
}

fn photometric(a: PhotometricArgs) -> Result<()> {
    use heliar::vem::capture::photometric::LogResponse;
    if !(a.code_max.is_finite() && a.code_max > 0.0) {
        bail!("--code-max {}: must be positive", a.code_max);
    }
    if !(a.max_error.is_finite() && a.max_error > 0.0) {
        bail!("--max-error {}: must be a positive percentage", a.max_error);
    }
    let patches = heliar::vem::capture::lens_file::read_patches(&a.patches, a.code_max)?;
    let (fit, report) = LogResponse::fit(&patches).map_err(|m| anyhow::anyhow!("{}: {m}", a.patches.display()))?;
    let v = serde_json::json!({"a": fit.a, "b": fit.b, "report": report, "dynamic_range_decades": (1.0 / fit.b) / std::f64::consts::LN_10});
    println!("{}", serde_json::to_string_pretty(&v)?);
    let worst = ops::photometric::worst_error_pct(&report);
    eprintln!("fit error: up to {worst:.1}% in luminance (tolerance {}%)", a.max_error);
    match &a.calib {
        Some(calib) => {
            ops::photometric::check_fit(&report, a.max_error, &a.patches, a.force)?;
            if !ops::photometric::within(worst, a.max_error) {
                eprintln!("warning: writing a fit beyond the tolerance (--force)");
            }
            let guard = heliar::io::guard::OutputGuard::new(None, &[&a.patches], a.force);
            guard.check_file(calib)?;
            ops::photometric::write_into_calib(calib, &a.patches, a.code_max, &fit)?;
            eprintln!("wrote the log response into {}", calib.display());
        }
        None if !ops::photometric::within(worst, a.max_error) => eprintln!("warning: the fit is beyond the tolerance of {}% (--max-error); it would not be written into a calibration", a.max_error),
        None => {}
    }
    Ok(())
}
