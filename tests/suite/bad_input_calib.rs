//! Bad input to the calibration tool (issue 12): marks the glTF extras make, exposure times
//! that do not bracket, photometric fits that do not fit, outputs over inputs or outside the
//! scene, chessboard folders with odd views, and pose pairs OpenCV cannot use. Each refusal
//! asserts a non-zero exit, a message that names the file, field or view, and that no input
//! changed (hashed before and after).
#![cfg(feature = "opencv")]

use crate::common::{hashes, s};
use std::path::{Path, PathBuf};
use std::process::Command;

fn bundled() -> PathBuf {
    Path::new(env!("CARGO_MANIFEST_DIR")).join("scenes/courtyard")
}

fn scratch(name: &str) -> PathBuf {
    let d = std::env::temp_dir().join(format!("heliar-badcalib-{name}-{}", std::process::id()));
    let _ = std::fs::remove_dir_all(&d);
    std::fs::create_dir_all(&d).unwrap();
    d
}

/// A small scene at `d/scene`: the bundled proxy and camera, no frames, no environment map.
fn small_scene(d: &Path) -> PathBuf {
    let scene = d.join("scene");
    std::fs::create_dir_all(scene.join("calib")).unwrap();
    std::fs::copy(bundled().join("proxy.glb"), scene.join("proxy.glb")).unwrap();
    std::fs::copy(bundled().join("calib/camera.toml"), scene.join("calib/camera.toml")).unwrap();
    std::fs::write(
        scene.join("scene.toml"),
        "name = \"small\"\n\n[place]\nlatitude_deg = 57.0488\nlongitude_deg = 9.9217\n\n[proxy]\nfile = \"proxy.glb\"\n\n[camera]\nfile = \"calib/camera.toml\"\n",
    )
    .unwrap();
    scene
}

fn calib(args: &[&str]) -> (bool, String, String) {
    let out = Command::new(env!("CARGO_BIN_EXE_heliar-calib")).args(args).current_dir(env!("CARGO_MANIFEST_DIR")).output().unwrap();
    (out.status.success(), String::from_utf8_lossy(&out.stdout).into(), String::from_utf8_lossy(&out.stderr).into())
}

/// Runs `args`, expecting a refusal whose message holds every one of `words`, with `watched`
/// (files or folders) unchanged.
fn refused(args: &[&str], words: &[&str], watched: &[&Path]) -> String {
    let before: Vec<_> = watched.iter().map(|p| hashes(p)).collect();
    let (ok, _, err) = calib(args);
    assert!(!ok, "{args:?} succeeded: {err}");
    for w in words {
        assert!(err.contains(w), "{args:?}: the message does not name '{w}': {err}");
    }
    for (p, b) in watched.iter().zip(before) {
        assert_eq!(hashes(p), b, "{args:?} changed {}", p.display());
    }
    err
}

#[test]
fn unmark_overrides_the_gltf_extras_in_the_manifest() {
    let d = scratch("unmark");
    let scene = small_scene(&d);
    let proxy = hashes(&scene.join("proxy.glb"));
    let diffuse = |dir: &Path| heliar::scene::Scene::load(dir).unwrap().proxy.nodes.iter().filter(|n| n.diffuse).map(|n| n.name.clone()).collect::<Vec<_>>();
    assert!(diffuse(&scene).contains(&"ground".to_string()), "the extras mark the ground");
    // Unmarking a node the extras mark works: the override goes into the manifest, the proxy is
    // left alone, and the command says where the mark came from.
    let (ok, out, err) = calib(&["mark", s(&scene), "--unmark", "--node", "ground"]);
    assert!(ok, "{err}");
    assert!(err.contains("glTF extras") && err.contains("not_diffuse_nodes") && err.contains("scene.toml"), "{err}");
    assert!(!out.contains("ground") && !diffuse(&scene).contains(&"ground".to_string()), "{out}");
    let m = std::fs::read_to_string(scene.join("scene.toml")).unwrap();
    assert!(m.contains("not_diffuse_nodes = [\"ground\"]"), "{m}");
    assert_eq!(hashes(&scene.join("proxy.glb")), proxy);
    // Marking it again removes the override.
    let (ok, _, err) = calib(&["mark", s(&scene), "--node", "ground"]);
    assert!(ok, "{err}");
    assert!(diffuse(&scene).contains(&"ground".to_string()));
    let m = std::fs::read_to_string(scene.join("scene.toml")).unwrap();
    assert!(m.contains("not_diffuse_nodes = []") && !m.contains("diffuse_nodes = [\"ground\"]"), "{m}");
    // Unmarking every surface is refused (a scene needs one), naming the field; nothing changes.
    refused(&["mark", s(&scene), "--unmark", "--node", "ground", "--node", "north_building", "--node", "west_building"], &["scene.toml", "diffuse"], &[&scene]);
    // A name in both lists is refused on load, naming the field.
    let both = "name = \"small\"\n\n[place]\nlatitude_deg = 57.0\nlongitude_deg = 9.9\n\n[proxy]\nfile = \"proxy.glb\"\ndiffuse_nodes = [\"wall\"]\nnot_diffuse_nodes = [\"wall\"]\n\n[camera]\nfile = \"calib/camera.toml\"\n";
    std::fs::write(scene.join("scene.toml"), both).unwrap();
    let e = heliar::scene::Scene::load(&scene).unwrap_err().to_string();
    assert!(e.contains("proxy.not_diffuse_nodes") && e.contains("wall"), "{e}");
    std::fs::remove_dir_all(&d).ok();
}

/// Three bracketed exposures of a gradient, `dir/e{i}.png`.
fn bracket(dir: &Path) -> Vec<PathBuf> {
    let (w, h) = (48u32, 32u32);
    [0.004f32, 0.016, 0.064]
        .iter()
        .enumerate()
        .map(|(i, t)| {
            let data: Vec<u8> = (0..h).flat_map(|_| (0..w).flat_map(move |x| [heliar::io::image::srgb_u8_from_linear(8.0 * t * 0.02 * 10f32.powf(2.5 * x as f32 / w as f32)); 3])).collect();
            let p = dir.join(format!("e{i}.png"));
            image::save_buffer(&p, &data, w, h, image::ExtendedColorType::Rgb8).unwrap();
            p
        })
        .collect()
}

fn join(paths: &[PathBuf]) -> String {
    paths.iter().map(|p| p.to_str().unwrap()).collect::<Vec<_>>().join(",")
}

#[test]
fn hdr_refuses_exposure_times_that_do_not_bracket() {
    let d = scratch("hdr-times");
    let imgs = bracket(&d);
    let out = d.join("out/merged.exr");
    for (times, named) in [("0.004,0.004,0.016", ["e0.png", "e1.png", "0.004"]), ("0.016,0.004,0.016", ["e0.png", "e2.png", "0.016"]), ("0.004,0,0.016", ["e1.png", "0 s", "positive"])] {
        refused(&["hdr", "--images", &join(&imgs), "--times", times, "-o", s(&out)], &named, &[&d]);
        assert!(!out.exists() && !d.join("out").exists());
    }
    refused(&["hdr", "--images", &join(&imgs), "--times", "0.004,0.016", "-o", s(&out)], &["2 times for 3 exposures"], &[&d]);
    std::fs::remove_dir_all(&d).ok();
}

/// An equidistant fisheye calibration at `dir/fisheye.toml`.
fn fisheye_calib(dir: &Path) -> PathBuf {
    let f = 100.0 / 95f64.to_radians();
    let p = dir.join("fisheye.toml");
    std::fs::write(
        &p,
        format!(
            "width = 200\nheight = 200\nfx = {f}\nfy = {f}\ncx = 99.5\ncy = 99.5\nk = [0.0, 0.0, 0.0, 0.0]\nmax_theta_deg = 95.0\n\n\
             [orientation]\noptical_axis = [0.0, 0.0, -1.0]\nimage_up = [0.0, 1.0, 0.0]\n\n[response]\nkind = \"linear\"\nexposure = 1.0\n"
        ),
    )
    .unwrap();
    p
}

#[test]
fn photometric_refuses_to_write_a_fit_that_does_not_fit() {
    let d = scratch("photometric");
    let fcalib = fisheye_calib(&d);
    // Codes that grow with luminance but are nowhere near logarithmic (a clipping camera).
    let patches = d.join("patches.csv");
    std::fs::write(&patches, "5,0.1\n6,1\n7,10\n8,100\n250,1000\n255,10000\n").unwrap();
    let err = refused(&["photometric", "--patches", s(&patches), "--calib", s(&fcalib)], &["patches.csv", "%", "--max-error", "--force", "not written"], &[&d]);
    assert!(err.contains("fit error: up to"), "the error is printed: {err}");
    // A tolerance of its own is honoured, and --force writes the fit anyway, with a warning.
    refused(&["photometric", "--patches", s(&patches), "--calib", s(&fcalib), "--max-error", "50"], &["tolerance of 50%"], &[&d]);
    refused(&["photometric", "--patches", s(&patches), "--max-error", "-1"], &["--max-error"], &[&d]);
    let (ok, _, err) = calib(&["photometric", "--patches", s(&patches), "--calib", s(&fcalib), "--force"]);
    assert!(ok && err.contains("warning"), "{err}");
    assert!(std::fs::read_to_string(&fcalib).unwrap().contains("kind = \"log\""));
    // Without --calib nothing is written: the fit is reported with a warning, and the exit is 0.
    let (ok, _, err) = calib(&["photometric", "--patches", s(&patches)]);
    assert!(ok && err.contains("beyond the tolerance"), "{err}");
    std::fs::remove_dir_all(&d).ok();
}

/// Pairs `u,v,x,y,z` of proxy corners seen through the bundled camera (`dir/pairs.csv`).
fn true_pairs(dir: &Path) -> PathBuf {
    let truth = heliar::scene::Scene::load(&bundled()).unwrap();
    let k = &truth.camera.intrinsics;
    let corners = [
        [-8.0, 0.0, -8.0], [-8.0, 6.0, -8.0], [-2.8, 2.4, 1.5], [-2.8, 0.0, 1.5], [-2.8, 2.4, -1.5], [5.0, 0.0, -8.0],
        [-8.0, 0.0, 4.0], [3.0, 5.0, -8.0], [0.0, 0.0, 0.0], [4.0, 0.0, 3.0], [-8.0, 4.0, -2.0], [8.0, 7.0, -8.0],
    ];
    let mut csv = String::from("u,v,x,y,z\n");
    for c in corners {
        if let Some(uv) = truth.camera.project_world(glam::DVec3::from(c)).filter(|uv| uv.x > 2.0 && uv.y > 2.0 && uv.x < k.width as f64 - 3.0 && uv.y < k.height as f64 - 3.0) {
            csv += &format!("{},{},{},{},{}\n", uv.x, uv.y, c[0], c[1], c[2]);
        }
    }
    let p = dir.join("pairs.csv");
    std::fs::write(&p, csv).unwrap();
    p
}

#[test]
fn commands_refuse_to_write_over_their_inputs() {
    let d = scratch("over-inputs");
    let imgs = bracket(&d);
    let times = "0.004,0.016,0.064";
    // hdr -o onto one of its exposures, directly or through a symlink, or with the response
    // landing on an input.
    refused(&["hdr", "--images", &join(&imgs), "--times", times, "-o", s(&imgs[1])], &["e1.png", "input", "--force"], &[&d]);
    #[cfg(unix)]
    {
        std::os::unix::fs::symlink(&imgs[2], d.join("link.png")).unwrap();
        refused(&["hdr", "--images", &join(&imgs), "--times", times, "-o", s(&d.join("link.png"))], &["link.png", "e2.png"], &[&d]);
    }
    // intrinsics -o onto a file of its image folder.
    refused(&["intrinsics", "--images", s(&d), "--board", "9x6", "--square-mm", "30", "-o", s(&imgs[0])], &["--output", "e0.png"], &[&d]);
    // pose --overlay onto its pairs or onto the scene's camera file.
    let scene = small_scene(&d.join("s"));
    let pairs = true_pairs(&d);
    let frame = bundled().join("frames/ldr/frame_000.png");
    for over in [pairs.clone(), scene.join("calib/camera.toml")] {
        refused(&["pose", s(&scene), "--pairs", s(&pairs), "--image", s(&frame), "--overlay", s(&over)], &["--overlay", over.file_name().unwrap().to_str().unwrap()], &[&d]);
    }
    // With --force the merge goes over the exposure, through a temporary file and a rename
    // (nothing left beside it).
    let (ok, _, err) = calib(&["hdr", "--images", &join(&imgs), "--times", times, "-o", s(&d.join("e9.exr")), "--force"]);
    assert!(ok, "{err}");
    let left: Vec<_> = std::fs::read_dir(&d).unwrap().flatten().map(|e| e.file_name().to_string_lossy().into_owned()).filter(|n| n.contains("tmp")).collect();
    assert!(left.is_empty(), "{left:?}");
    std::fs::remove_dir_all(&d).ok();
}

#[test]
fn pose_stays_inside_the_scene_folder() {
    let d = scratch("outside");
    let scene = small_scene(&d.join("a"));
    let pairs = true_pairs(&d);
    // camera.file reaching out of the scene with `..`.
    std::fs::create_dir_all(d.join("x")).unwrap();
    std::fs::rename(scene.join("calib/camera.toml"), d.join("x/camera.toml")).unwrap();
    let m = std::fs::read_to_string(scene.join("scene.toml")).unwrap();
    std::fs::write(scene.join("scene.toml"), m.replace("calib/camera.toml", "../../x/camera.toml")).unwrap();
    refused(&["pose", s(&scene), "--pairs", s(&pairs)], &["camera.file", "../../x/camera.toml", "outside the scene folder", "--allow-outside-scene"], &[&d]);
    // …or through a symlinked folder.
    #[cfg(unix)]
    {
        std::fs::write(scene.join("scene.toml"), &m).unwrap();
        std::fs::remove_dir_all(scene.join("calib")).unwrap();
        std::os::unix::fs::symlink(d.join("x"), scene.join("calib")).unwrap();
        refused(&["pose", s(&scene), "--pairs", s(&pairs)], &["camera.file", "outside the scene folder"], &[&d]);
    }
    // Allowed explicitly: the outside file gets the pose, the scene loads with it, and nothing is
    // left beside it.
    let (ok, _, err) = calib(&["pose", s(&scene), "--pairs", s(&pairs), "--allow-outside-scene"]);
    assert!(ok, "{err}");
    assert!(std::fs::read_to_string(d.join("x/camera.toml")).unwrap().contains("rvec_camera_from_world"));
    // (The scene itself reads the outside camera file only when told so.)
    let outside = heliar::scene::LoadOptions { allow_outside_scene: true };
    heliar::scene::Scene::load_with(&scene, &outside).unwrap();
    assert!(heliar::scene::Scene::load(&scene).is_err());
    assert_eq!(std::fs::read_dir(d.join("x")).unwrap().count(), 1);
    std::fs::remove_dir_all(&d).ok();
}

/// Chessboard views through the bundled camera's lens, `dir/v{i}.png` for each of `poses`
/// (tilt x, tilt y, distance); a view through a camera of `size` instead when given.
fn board_views(dir: &Path, poses: &[(f64, f64, f64)], size: Option<(u32, u32)>) -> Vec<PathBuf> {
    use glam::{DMat3, DVec3};
    use heliar::camera::{Camera, Intrinsics, Pose};
    let k = heliar::scene::Scene::load(&bundled()).unwrap().camera.intrinsics;
    let k = match size {
        Some((w, h)) => Intrinsics::brown_conrady(w, h, k.fx, k.fy, w as f64 / 2.0, h as f64 / 2.0, [0.0; 5]),
        None => k,
    };
    let cam = Camera { intrinsics: k, pose: Pose { rotation: DMat3::IDENTITY, translation: DVec3::ZERO } };
    let board = heliar::opencv_calib::chessboard::Board { cols: 9, rows: 6, square_m: 0.03 };
    std::fs::create_dir_all(dir).unwrap();
    poses
        .iter()
        .enumerate()
        .map(|(i, &(ax, ay, dist))| {
            let rot = DMat3::from_rotation_x(ax) * DMat3::from_rotation_y(ay) * DMat3::from_rotation_z(0.1 * i as f64);
            let pose = Pose { rotation: rot, translation: DVec3::new(0.0, 0.0, dist) + rot * DVec3::new(-0.15, -0.1, 0.0) };
            let img = heliar::opencv_calib::chessboard::render_board(&cam, &board, &pose, 2);
            let p = dir.join(format!("v{i}{}.png", if size.is_some() { "_other" } else { "" }));
            image::save_buffer(&p, &img.data, img.width, img.height, image::ExtendedColorType::Rgb8).unwrap();
            p
        })
        .collect()
}

#[test]
fn intrinsics_skip_odd_views_while_enough_remain() {
    let d = scratch("views");
    let boards = d.join("boards");
    let good = [(0.0, 0.0, 0.7), (0.35, 0.0, 0.75), (-0.35, 0.1, 0.75), (0.0, 0.4, 0.65), (0.1, -0.4, 0.8), (0.3, 0.3, 0.85)];
    let views = board_views(&boards, &good, None);
    // A photo without a board (the first view, blanked), one of another size, one broken JPEG.
    let first = image::open(&views[0]).unwrap().to_rgb8();
    image::RgbImage::from_pixel(first.width(), first.height(), image::Rgb([128, 128, 128])).save(boards.join("blank.png")).unwrap();
    board_views(&boards, &good[..1], Some((400, 300)));
    std::fs::write(boards.join("broken.jpg"), b"\xff\xd8\xff\xe0 not really a jpeg").unwrap();
    let args = ["intrinsics", "--images", s(&boards), "--board", "9x6", "--square-mm", "30"];
    let before = hashes(&boards);
    let (ok, out, err) = calib(&args);
    assert!(ok, "{err}");
    for (name, why) in [("blank.png", "board not found"), ("v0_other.png", "400×300"), ("broken.jpg", "unreadable")] {
        assert!(err.lines().any(|l| l.contains("skipped") && l.contains(name) && l.contains(why)), "{name}: {err}");
    }
    assert!(err.contains("board found in 6 of 9 views") && err.contains("at least 3"), "{err}");
    // The corner window follows the squares' size in pixels, and is said.
    assert!(err.contains("sub-pixel corner window") && err.contains("half-size"), "{err}");
    let v: serde_json::Value = serde_json::from_str(&out).unwrap();
    assert_eq!(v["result"]["views"].as_u64(), Some(6), "{v}");
    assert_eq!(hashes(&boards), before);
    // Too few usable views left: an error naming the minimum and every view skipped.
    for p in &views[2..] {
        std::fs::remove_file(p).unwrap();
    }
    let err = refused(&args, &["2 usable views of 5", "at least 3", "blank.png", "v0_other.png", "broken.jpg"], &[&boards]);
    assert!(!err.contains("panicked"), "{err}");
    std::fs::remove_dir_all(&d).ok();
}

#[test]
fn pose_checks_its_pairs_before_opencv() {
    let d = scratch("pairs");
    let scene = small_scene(&d);
    let pairs = true_pairs(&d);
    let text = std::fs::read_to_string(&pairs).unwrap();
    let rows: Vec<&str> = text.lines().skip(1).collect();
    let bad = d.join("bad.csv");
    let cases: Vec<(String, Vec<&str>)> = vec![
        // The same row twice: the same pixel and the same world point.
        (format!("u,v,x,y,z\n{}\n{}\n{}\n{}\n", rows[0], rows[1], rows[2], rows[1]), vec!["bad.csv", "pairs 2 and 4", "same pixel"]),
        // Distinct pixels for one world point.
        (format!("u,v,x,y,z\n{}\n{}\n{}\n10,10,{}\n", rows[0], rows[1], rows[2], rows[0].splitn(3, ',').nth(2).unwrap()), vec!["bad.csv", "pairs 1 and 4", "same world point"]),
        // World points on one line (a vertical edge).
        ("u,v,x,y,z\n10,10,-8,0,-8\n20,30,-8,1,-8\n30,50,-8,2,-8\n45,80,-8,3.5,-8\n".into(), vec!["bad.csv", "one line"]),
        ("u,v,x,y,z\n10,10,-8,0,-8\n20,30,-8,1,-8\n30,50,-7,2,-8\n".into(), vec!["bad.csv", "3 point pairs", "at least 4"]),
    ];
    for (csv, words) in cases {
        std::fs::write(&bad, csv).unwrap();
        let err = refused(&["pose", s(&scene), "--pairs", s(&bad)], &words, &[&scene, &bad]);
        assert!(!err.contains("Assertion") && !err.contains("OpenCV"), "{err}");
    }
    std::fs::remove_dir_all(&d).ok();
}

/// Outputs the tool writes (`intrinsics -o`, `hdr -o` and its response, `pose --overlay`) do not
/// overwrite an existing file of a scene without `--force`, whichever scene it is (the guard of
/// every heliar command, with the scene found above the output); `pose --image` must be a frame
/// of the camera's size.
#[test]
fn outputs_do_not_overwrite_files_of_a_scene() {
    let d = scratch("scene-files");
    let scene = small_scene(&d);
    let imgs = bracket(&d);
    std::fs::write(scene.join("env.exr"), b"the scene's environment map").unwrap();
    std::fs::write(scene.join("notes.response.csv"), b"kept").unwrap();
    let camera = scene.join("calib/camera.toml");
    let boards = d.join("boards");
    std::fs::create_dir_all(&boards).unwrap();
    refused(&["intrinsics", "--images", s(&boards), "--board", "9x6", "--square-mm", "30", "-o", s(&camera)], &["--output", "camera.toml", "file of the scene", "--force"], &[&d]);
    let times = "0.004,0.016,0.064";
    refused(&["hdr", "--images", &join(&imgs), "--times", times, "-o", s(&scene.join("env.exr"))], &["--output", "env.exr", "file of the scene", "--force"], &[&d]);
    // The response CSV beside a new EXR would land on a scene file.
    refused(&["hdr", "--images", &join(&imgs), "--times", times, "-o", s(&scene.join("notes.exr"))], &["response", "notes.response.csv", "--force"], &[&d]);
    assert!(!scene.join("notes.exr").exists());
    // Through `..` from outside the scene it is the same file.
    let sneaky = d.join("elsewhere/../scene/env.exr");
    refused(&["hdr", "--images", &join(&imgs), "--times", times, "-o", s(&sneaky)], &["file of the scene"], &[&d]);
    // pose --overlay onto a scene file that is not one of its inputs.
    let pairs = true_pairs(&d);
    let frame = bundled().join("frames/ldr/frame_000.png");
    refused(&["pose", s(&scene), "--pairs", s(&pairs), "--image", s(&frame), "--overlay", s(&scene.join("env.exr")), "--dry-run"], &["--overlay", "env.exr", "file of the scene"], &[&d]);
    // A 1×1 (or any other size) --image is refused before the pose is solved, naming both sizes.
    let tiny = d.join("tiny.png");
    image::save_buffer(&tiny, &[7u8; 3], 1, 1, image::ExtendedColorType::Rgb8).unwrap();
    refused(&["pose", s(&scene), "--pairs", s(&pairs), "--image", s(&tiny)], &["tiny.png", "1×1", "320×240", "camera.toml"], &[&d]);
    // New files beside the scene's are allowed, and --force overwrites on purpose (atomically).
    let (ok, _, err) = calib(&["hdr", "--images", &join(&imgs), "--times", times, "-o", s(&scene.join("env2.exr"))]);
    assert!(ok, "{err}");
    let (ok, _, err) = calib(&["hdr", "--images", &join(&imgs), "--times", times, "-o", s(&scene.join("env.exr")), "--force"]);
    assert!(ok, "{err}");
    assert_ne!(std::fs::read(scene.join("env.exr")).unwrap(), b"the scene's environment map");
    std::fs::remove_dir_all(&d).ok();
}
