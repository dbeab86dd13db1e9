//! Bad scene input gets an error naming the file and the field, never a panic.

use heliar::io::frames::Frame;
use heliar::scene::Scene;
use std::path::{Path, PathBuf};

/// A copy of the bundled scene's small files in a fresh temp folder (frames are empty stand-ins:
/// the loader lists them, it does not decode them).
fn scratch(name: &str) -> PathBuf {
    let src = Path::new(env!("CARGO_MANIFEST_DIR")).join("scenes/courtyard");
    let dst = std::env::temp_dir().join(format!("heliar-scene-{name}-{}", std::process::id()));
    let _ = std::fs::remove_dir_all(&dst);
    for d in ["calib", "frames/hdr", "frames/ldr", "objects"] {
        std::fs::create_dir_all(dst.join(d)).unwrap();
    }
    for f in ["scene.toml", "proxy.glb", "calib/camera.toml", "env.exr", "truth.csv", "objects/statue.glb", "objects/robot.glb"] {
        std::fs::copy(src.join(f), dst.join(f)).unwrap();
    }
    for i in 0..12 {
        std::fs::write(dst.join(format!("frames/hdr/frame_{i:03}.exr")), b"").unwrap();
        std::fs::write(dst.join(format!("frames/ldr/frame_{i:03}.png")), b"").unwrap();
    }
    dst
}

fn edit(dir: &Path, file: &str, from: &str, to: &str) {
    let p = dir.join(file);
    let s = std::fs::read_to_string(&p).unwrap();
    assert!(s.contains(from), "{file} has no '{from}'");
    std::fs::write(&p, s.replacen(from, to, 1)).unwrap();
}

fn err(dir: &Path) -> String {
    let e = Scene::load(dir).expect_err("must be rejected").to_string();
    std::fs::remove_dir_all(dir).ok();
    e
}

#[test]
fn the_copy_loads() {
    let d = scratch("ok");
    let s = Scene::load(&d).unwrap();
    assert_eq!(s.sequences.len(), 2);
    assert_eq!(s.sequences[0].files.len(), 12);
    assert!(s.proxy.nodes.iter().filter(|n| n.diffuse).count() == 3);
    std::fs::remove_dir_all(&d).ok();
}

#[test]
fn missing_scene_folder_and_manifest() {
    let e = Scene::load(Path::new("/nonexistent/scene")).unwrap_err().to_string();
    assert!(e.contains("/nonexistent/scene") && e.contains("not found"), "{e}");
    let d = scratch("nomanifest");
    std::fs::remove_file(d.join("scene.toml")).unwrap();
    let e = err(&d);
    assert!(e.contains("scene.toml") && e.contains("not found"), "{e}");
}

#[test]
fn out_of_range_latitude_names_the_field() {
    let d = scratch("lat");
    edit(&d, "scene.toml", "latitude_deg = 57.0488", "latitude_deg = 97.0");
    let e = err(&d);
    assert!(e.contains("scene.toml") && e.contains("place.latitude_deg"), "{e}");
}

#[test]
fn typo_in_a_field_name_is_caught() {
    let d = scratch("typo");
    edit(&d, "scene.toml", "longitude_deg", "longitud_deg");
    let e = err(&d);
    assert!(e.contains("scene.toml") && e.contains("longitud_deg"), "{e}");
}

#[test]
fn inverted_and_empty_grid_bounds() {
    let d = scratch("grid");
    edit(&d, "scene.toml", "max = [6.0, 3.0, 6.0]", "max = [-7.0, 3.0, 6.0]");
    let e = err(&d);
    assert!(e.contains("irradiance.min/max"), "{e}");
    let d = scratch("grid0");
    edit(&d, "scene.toml", "spacing_m = 1.0", "spacing_m = 0.0");
    assert!(err(&d).contains("irradiance.spacing_m"));
}

#[test]
fn horizontal_north_is_required() {
    let d = scratch("north");
    edit(&d, "scene.toml", "north = [0.0, 0.0, -1.0]", "north = [0.0, 1.0, 0.0]");
    assert!(err(&d).contains("place.north"));
}

#[test]
fn camera_file_problems() {
    let d = scratch("fx");
    edit(&d, "calib/camera.toml", "fx = ", "fx = -1 #");
    let e = err(&d);
    assert!(e.contains("camera.toml") && e.contains("fx"), "{e}");
    let d = scratch("nofy");
    let p = d.join("calib/camera.toml");
    let s: String = std::fs::read_to_string(&p).unwrap().lines().filter(|l| !l.starts_with("fy")).map(|l| format!("{l}\n")).collect();
    std::fs::write(&p, s).unwrap();
    let e = err(&d);
    assert!(e.contains("camera.toml") && e.contains("fy"), "{e}");
    let d = scratch("pose");
    edit(&d, "calib/camera.toml", "look_at = [-2.5, 0.6, -4.0]", "look_at = [4.5, 5.0, 9.0]");
    let e = err(&d);
    assert!(e.contains("pose.look_at"), "{e}");
    let d = scratch("resp");
    edit(&d, "calib/camera.toml", "kind = \"srgb\"", "kind = \"log\"");
    assert!(err(&d).contains("response.kind"));
}

#[test]
fn corrupt_or_missing_gltf() {
    let d = scratch("glb");
    std::fs::write(d.join("proxy.glb"), b"glTF\x02\0\0\0 this is not a glb").unwrap();
    let e = err(&d);
    assert!(e.contains("proxy.glb") && e.contains("glTF"), "{e}");
    let d = scratch("noglb");
    std::fs::remove_file(d.join("proxy.glb")).unwrap();
    let e = err(&d);
    assert!(e.contains("proxy.file") && e.contains("proxy.glb"), "{e}");
}

#[test]
fn unknown_diffuse_node_name() {
    let d = scratch("diffuse");
    edit(&d, "scene.toml", "file = \"proxy.glb\"", "file = \"proxy.glb\"\ndiffuse_nodes = [\"fountain\"]");
    let e = err(&d);
    assert!(e.contains("fountain") && e.contains("proxy.glb"), "{e}");
}

#[test]
fn frame_times_must_match_the_frames() {
    let d = scratch("times");
    std::fs::remove_file(d.join("frames/hdr/frame_011.exr")).unwrap();
    let e = err(&d);
    // 11 frames now, but the truth file has 12 rows.
    assert!(e.contains("truth.csv") && e.contains("11 frames"), "{e}");
    let d = scratch("times2");
    edit(&d, "scene.toml", "fps = 0.1\ntruth", "times = [\"2024-06-21T15:30:00+02:00\"]\ntruth");
    let e = err(&d);
    assert!(e.contains("sequences[0].times"), "{e}");
    let d = scratch("times3");
    edit(&d, "scene.toml", "start = \"2024-06-21T15:30:00+02:00\"", "start = \"21 June 2024\"");
    let e = err(&d);
    assert!(e.contains("sequences[0].times") && e.contains("RFC 3339"), "{e}");
}

#[test]
fn truth_file_with_garbage() {
    let d = scratch("truth");
    edit(&d, "truth.csv", "\n3,", "\n3,x");
    std::fs::write(d.join("truth.csv"), std::fs::read_to_string(d.join("truth.csv")).unwrap().replacen(",3.05", ",NaN", 1)).unwrap();
    let e = err(&d);
    assert!(e.contains("truth.csv") && e.contains("row"), "{e}");
}

#[test]
fn frame_of_the_wrong_size_and_corrupt_frames() {
    let d = std::env::temp_dir().join(format!("heliar-frames-{}", std::process::id()));
    std::fs::create_dir_all(&d).unwrap();
    let p = d.join("small.png");
    image::save_buffer(&p, &[0u8; 2 * 2 * 3], 2, 2, image::ExtendedColorType::Rgb8).unwrap();
    let f = Frame::load(&p).unwrap();
    let e = f.check_size(&p, 320, 240).unwrap_err().to_string();
    assert!(e.contains("small.png") && e.contains("2×2") && e.contains("320×240"), "{e}");
    let bad = d.join("bad.png");
    std::fs::write(&bad, b"\x89PNG\r\n\x1a\n truncated").unwrap();
    assert!(Frame::load(&bad).unwrap_err().to_string().contains("bad.png"));
    let bad = d.join("bad.exr");
    std::fs::write(&bad, b"v/1\x01 nope").unwrap();
    assert!(Frame::load(&bad).unwrap_err().to_string().contains("bad.exr"));
    assert!(Frame::load(&d.join("none.exr")).unwrap_err().to_string().contains("none.exr"));
    assert!(Frame::load(&d.join("x.jpg")).unwrap_err().to_string().contains("unsupported"));
    std::fs::remove_dir_all(&d).ok();
}
