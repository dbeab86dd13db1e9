//! Bad input to scene loading, the camera models and the command line (issue 12). Each case
//! asserts an error (or a non-zero exit), a message that names the file or option and the field,
//! and that no file of the scene or of the inputs changed (hashed before and after).

use crate::common::{hashes, heliar_status as heliar, s};
use heliar::scene::Scene;
use std::path::{Path, PathBuf};

fn bundled() -> PathBuf {
    Path::new(env!("CARGO_MANIFEST_DIR")).join("scenes/courtyard")
}

/// A fresh folder holding a copy of the courtyard's small files at `courtyard/` (frames are empty
/// stand-ins: the loader lists them, it does not decode them). Returns (folder, scene).
fn scratch(name: &str) -> (PathBuf, PathBuf) {
    let d = std::env::temp_dir().join(format!("heliar-badin-{name}-{}", std::process::id()));
    let _ = std::fs::remove_dir_all(&d);
    let dst = d.join("courtyard");
    for sub in ["calib", "frames/hdr", "frames/ldr", "objects"] {
        std::fs::create_dir_all(dst.join(sub)).unwrap();
    }
    for f in ["scene.toml", "proxy.glb", "calib/camera.toml", "env.exr", "truth.csv", "objects/statue.glb", "objects/robot.glb"] {
        std::fs::copy(bundled().join(f), dst.join(f)).unwrap();
    }
    for i in 0..12 {
        std::fs::write(dst.join(format!("frames/hdr/frame_{i:03}.exr")), b"").unwrap();
        std::fs::write(dst.join(format!("frames/ldr/frame_{i:03}.png")), b"").unwrap();
    }
    (d, dst)
}

fn edit(path: &Path, from: &str, to: &str) {
    let s = std::fs::read_to_string(path).unwrap();
    assert!(s.contains(from), "{} has no '{from}'", path.display());
    std::fs::write(path, s.replacen(from, to, 1)).unwrap();
}

/// Loads `scene` expecting an error; checks that nothing under `root` changed.
fn load_err(root: &Path, scene: &Path) -> String {
    let before = hashes(root);
    let e = Scene::load(scene).expect_err("must be rejected").to_string();
    assert_eq!(hashes(root), before, "loading changed a file");
    e
}

#[test]
fn folding_distortion_is_refused_naming_the_camera_file() {
    let (d, scene) = scratch("distortion");
    edit(&scene.join("calib/camera.toml"), "distortion = [-0.08,", "distortion = [-50.0,");
    let e = load_err(&d, &scene);
    assert!(e.contains("camera.toml") && e.contains("distortion") && e.contains("folds"), "{e}");
    // The command line says the same and exits non-zero.
    let before = hashes(&d);
    let (ok, err) = heliar(&["estimate", s(&scene)]);
    assert!(!ok && err.contains("camera.toml") && err.contains("distortion"), "{err}");
    assert_eq!(hashes(&d), before);
    std::fs::remove_dir_all(&d).ok();
}

#[test]
fn sun_options_have_the_limits_of_the_manifest() {
    for (args, option) in [
        (&["--lat", "10", "--lon", "10", "--elevation", "1e12"][..], "--elevation"),
        (&["--lat", "95", "--lon", "10"][..], "--lat"),
        (&["--lat", "10", "--lon", "NaN"][..], "--lon"),
        (&["--lat", "10", "--lon", "10", "--pressure=-3"][..], "--pressure"),
        (&["--lat", "10", "--lon", "10", "--temperature", "-300"][..], "--temperature"),
        (&["--lat", "10", "--lon", "10", "--delta-t", "inf"][..], "--delta-t"),
    ] {
        let mut a = vec!["sun", "--time", "2024-06-21T12:00:00+02:00"];
        a.extend_from_slice(args);
        let (ok, err) = heliar(&a);
        assert!(!ok && err.contains(option) && err.contains("place."), "{args:?}: {err}");
    }
    // A CSV row with an impossible elevation names the file, the row and the column; the CSV is
    // left alone.
    let (d, _) = scratch("sun-csv");
    let csv = d.join("in.csv");
    std::fs::write(&csv, "lat,lon,time,elevation_m\n57.0,9.9,2024-06-21T12:00:00+02:00,1e12\n").unwrap();
    let before = hashes(&d);
    let (ok, err) = heliar(&["sun", "--csv", s(&csv)]);
    assert!(!ok && err.contains("in.csv") && err.contains("row 2") && err.contains("elevation_m"), "{err}");
    assert_eq!(hashes(&d), before);
    // The manifest says the same through the same check.
    let scene = d.join("courtyard");
    edit(&scene.join("scene.toml"), "elevation_m = 8", "elevation_m = 1e12");
    let e = load_err(&d, &scene);
    assert!(e.contains("scene.toml") && e.contains("place.elevation_m"), "{e}");
    std::fs::remove_dir_all(&d).ok();
}

#[test]
fn negative_or_nan_intensities_are_refused_naming_the_option() {
    let (d, scene) = scratch("relight-neg");
    let out = d.join("relit.exr");
    let before = hashes(&d);
    for (pd, pa, option) in [("-1,-1,-1", "-1,-1,-1", "--pd"), ("1,1,1", "0.5,NaN,0.5", "--pa"), ("1,-0.1,1", "1,1,1", "--pd")] {
        let (ok, err) = heliar(&["relight", s(&scene), &format!("--pd={pd}"), &format!("--pa={pa}"), "-o", s(&out)]);
        assert!(!ok && err.contains(option), "{pd} {pa}: {err}");
        let (ok, err) = heliar(&["irradiance", s(&scene), "--at", "0,1,0", "--normal", "0,1,0", &format!("--pd={pd}"), &format!("--pa={pa}")]);
        assert!(!ok && err.contains(option), "{pd} {pa}: {err}");
    }
    // Refused before the bake: no map written, nothing baked into the scene.
    assert!(!out.exists());
    assert_eq!(hashes(&d), before);
    std::fs::remove_dir_all(&d).ok();
}

#[test]
fn estimate_samples_follow_the_manifest_rule() {
    let (d, scene) = scratch("samples");
    let out = d.join("est.jsonl");
    let before = hashes(&d);
    for n in ["0", "2"] {
        let (ok, err) = heliar(&["estimate", s(&scene), "--samples", n, "-o", s(&out)]);
        assert!(!ok && err.contains("--samples") && err.contains("at least 3"), "{err}");
    }
    assert!(!out.exists());
    assert_eq!(hashes(&d), before);
    // The manifest refuses the same value under its own name.
    edit(&scene.join("scene.toml"), "[envmap]", "[estimator]\nsamples = 2\n\n[envmap]");
    let e = load_err(&d, &scene);
    assert!(e.contains("scene.toml") && e.contains("estimator.samples"), "{e}");
    std::fs::remove_dir_all(&d).ok();
}

#[test]
fn outputs_over_inputs_or_scene_files_are_refused() {
    let (d, scene) = scratch("outputs");
    let csv = d.join("in.csv");
    std::fs::write(&csv, "lat,lon,time\n57.0,9.9,2024-06-21T12:00:00+02:00\n").unwrap();
    let before = hashes(&d);
    let frame = scene.join("frames/hdr/frame_000.exr");
    for (args, named) in [
        (vec!["estimate", s(&scene), "-o", &format!("{}/scene.toml", s(&scene))], "scene.toml"),
        (vec!["estimate", s(&scene), "--plot", &format!("{}/truth.csv", s(&scene))], "truth.csv"),
        (vec!["relight", s(&scene), "--pd", "1,1,1", "--pa", "1,1,1", "-o", &format!("{}/env.exr", s(&scene))], "env.exr"),
        (vec!["sun", "--csv", s(&csv), "--output", s(&csv)], "in.csv"),
        (vec!["sun", "--csv", s(&csv), "--output", &format!("{}/../in.csv", s(&scene))], "in.csv"),
        (vec!["vem", "--input", s(&frame), "-o", s(&frame)], "frame_000.exr"),
        (vec!["bench", "estimate", s(&scene), "--csv", &format!("{}/truth.csv", s(&scene))], "truth.csv"),
    ] {
        let (ok, err) = heliar(&args);
        assert!(!ok && err.contains(named) && err.contains("--force"), "{args:?}: {err}");
        assert_eq!(hashes(&d), before, "{args:?} changed a file");
    }
    // A new output is written whole, with no temporary file left beside it.
    let out = d.join("out/sun.csv");
    let (ok, err) = heliar(&["sun", "--csv", s(&csv), "--output", s(&out)]);
    assert!(ok, "{err}");
    assert!(std::fs::read_to_string(&out).unwrap().lines().count() == 2);
    assert_eq!(std::fs::read_dir(d.join("out")).unwrap().count(), 1);
    // --force lets the user overwrite on purpose.
    let (ok, err) = heliar(&["sun", "--csv", s(&csv), "--output", s(&csv), "--force"]);
    assert!(ok, "{err}");
    assert!(std::fs::read_to_string(&csv).unwrap().contains("zenith_deg"));
    std::fs::remove_dir_all(&d).ok();
}

/// A one-triangle glTF whose buffer is at `uri`, and the buffer's bytes.
fn triangle_gltf(uri: &str) -> (String, Vec<u8>) {
    let bin: Vec<u8> = [0.0f32, 0.0, 0.0, 1.0, 0.0, 0.0, 0.0, 1.0, 0.0].iter().flat_map(|f| f.to_le_bytes()).collect();
    let json = format!(
        r#"{{"asset":{{"version":"2.0"}},"scene":0,"scenes":[{{"nodes":[0]}}],"nodes":[{{"mesh":0}}],
        "meshes":[{{"primitives":[{{"attributes":{{"POSITION":0}}}}]}}],
        "accessors":[{{"bufferView":0,"componentType":5126,"count":3,"type":"VEC3","min":[0,0,0],"max":[1,1,0]}}],
        "bufferViews":[{{"buffer":0,"byteLength":36}}],"buffers":[{{"byteLength":36,"uri":"{uri}"}}]}}"#
    );
    (json, bin)
}

fn base64(bytes: &[u8]) -> String {
    const A: &[u8; 64] = b"ABCDEFGHIJKLMNOPQRSTUVWXYZabcdefghijklmnopqrstuvwxyz0123456789+/";
    let mut out = String::new();
    for c in bytes.chunks(3) {
        let n = (c[0] as u32) << 16 | (*c.get(1).unwrap_or(&0) as u32) << 8 | *c.get(2).unwrap_or(&0) as u32;
        for k in 0..4 {
            out.push(if k <= c.len() { A[(n >> (18 - 6 * k) & 63) as usize] as char } else { '=' });
        }
    }
    out
}

#[test]
fn manifest_paths_outside_the_scene_are_refused() {
    let (d, scene) = scratch("outside");
    std::fs::create_dir_all(d.join("outside")).unwrap();
    std::fs::copy(scene.join("proxy.glb"), d.join("outside/proxy.glb")).unwrap();
    std::fs::copy(scene.join("objects/statue.glb"), d.join("outside/statue.glb")).unwrap();
    let manifest = scene.join("scene.toml");
    let original = std::fs::read_to_string(&manifest).unwrap();
    let abs = d.join("outside/proxy.glb");
    for (from, to, field) in [
        ("file = \"proxy.glb\"", format!("file = \"{}\"", s(&abs)), "proxy.file"),
        ("file = \"objects/statue.glb\"", "file = \"../../../x.glb\"".to_string(), "virtual_objects[0].file"),
        ("file = \"objects/statue.glb\"", "file = \"../outside/statue.glb\"".to_string(), "virtual_objects[0].file"),
        ("file = \"env.exr\"", "file = \"/etc/passwd\"".to_string(), "envmap.file"),
        ("truth = \"truth.csv\"", "truth = \"../in.csv\"".to_string(), "sequences[0].truth"),
        ("dir = \"frames/hdr\"", "dir = \"..\"".to_string(), "sequences[0].dir"),
    ] {
        std::fs::write(&manifest, original.replacen(from, &to, 1)).unwrap();
        let e = load_err(&d, &scene);
        assert!(e.contains("scene.toml") && e.contains(field) && e.contains("outside the scene folder"), "{to}: {e}");
    }
    // The explicit option reads it; so does the command line's flag.
    std::fs::write(&manifest, original.replacen("file = \"proxy.glb\"", &format!("file = \"{}\"", s(&abs)), 1)).unwrap();
    let before = hashes(&d);
    assert!(Scene::load_with(&scene, &heliar::scene::LoadOptions { allow_outside_scene: true }).is_ok());
    let (ok, err) = heliar(&["sun", "--scene", s(&scene), "--time", "2024-06-21T12:00:00+02:00"]);
    assert!(!ok && err.contains("proxy.file") && err.contains("--allow-outside-scene"), "{err}");
    let (ok, err) = heliar(&["sun", "--scene", s(&scene), "--time", "2024-06-21T12:00:00+02:00", "--allow-outside-scene"]);
    assert!(ok, "{err}");
    assert_eq!(hashes(&d), before);
    // A symlink out of the scene is outside too.
    std::fs::write(&manifest, &original).unwrap();
    #[cfg(unix)]
    {
        std::fs::remove_file(scene.join("objects/statue.glb")).unwrap();
        std::os::unix::fs::symlink(d.join("outside/statue.glb"), scene.join("objects/statue.glb")).unwrap();
        let e = load_err(&d, &scene);
        assert!(e.contains("virtual_objects[0].file") && e.contains("outside"), "{e}");
    }
    std::fs::remove_dir_all(&d).ok();
}

#[test]
fn gltf_uris_must_stay_in_the_scene() {
    let (d, scene) = scratch("gltf-uri");
    let deep = scene.join("objects/deep");
    std::fs::create_dir_all(&deep).unwrap();
    edit(&scene.join("scene.toml"), "file = \"objects/statue.glb\"", "file = \"objects/deep/tri.gltf\"");
    let (_, bin) = triangle_gltf("");
    std::fs::write(d.join("x.bin"), &bin).unwrap();
    std::fs::write(deep.join("tri.bin"), &bin).unwrap();
    for (uri, named) in [
        ("../../../x.bin".to_string(), "buffers[0].uri"),
        ("..%2F..%2F..%2Fx.bin".to_string(), "buffers[0].uri"),
        (format!("file://{}", s(&d.join("x.bin"))), "file://"),
        (s(&d.join("x.bin")).to_string(), "absolute"),
    ] {
        std::fs::write(deep.join("tri.gltf"), triangle_gltf(&uri).0).unwrap();
        let e = load_err(&d, &scene);
        assert!(e.contains("tri.gltf") && e.contains(named), "{uri}: {e}");
    }
    // Inside the scene, as a file or a data: URI, it loads.
    for uri in ["tri.bin".to_string(), format!("data:application/octet-stream;base64,{}", base64(&bin))] {
        std::fs::write(deep.join("tri.gltf"), triangle_gltf(&uri).0).unwrap();
        let s = Scene::load(&scene).unwrap_or_else(|e| panic!("{uri}: {e}"));
        // The file's one triangle (area ½ m² at the courtyard's scale 1), which the loader may
        // split into several (`geometry::subdivide`): their areas add up to it.
        let m = &s.virtual_objects[0].mesh;
        let area: f32 = (0..m.triangles.len() as u32).map(|t| 0.5 * m.double_area(t)).sum();
        assert!(!m.triangles.is_empty() && (area - 0.5).abs() < 1e-5, "{uri}: {} triangles, {area} m²", m.triangles.len());
    }
    std::fs::remove_dir_all(&d).ok();
}

#[test]
fn probe_grids_over_the_cap_are_refused_before_allocation() {
    let (d, scene) = scratch("grid");
    edit(&scene.join("scene.toml"), "spacing_m = 1.0", "spacing_m = 0.001");
    let e = load_err(&d, &scene);
    assert!(e.contains("scene.toml") && e.contains("irradiance.spacing_m") && e.contains("12001×2901×12001") && e.contains("MAX_PROBES"), "{e}");
    // Within the probe cap but not the transfer's: 0.1 m over the courtyard's region at 65536
    // directions.
    edit(&scene.join("scene.toml"), "spacing_m = 0.001", "spacing_m = 0.1");
    edit(&scene.join("scene.toml"), "[envmap]", "[bake]\nprobe_directions = 65536\n\n[envmap]");
    let e = load_err(&d, &scene);
    assert!(e.contains("irradiance.spacing_m") && e.contains("GiB") && e.contains("MAX_TRANSFER_BYTES"), "{e}");
    // The command line stops at load, before any bake.
    let before = hashes(&d);
    let (ok, err) = heliar(&["bake", s(&scene)]);
    assert!(!ok && err.contains("irradiance.spacing_m"), "{err}");
    assert_eq!(hashes(&d), before);
    std::fs::remove_dir_all(&d).ok();
}

/// glTF buffers and images given as `data:` URIs longer than the loader's cap are refused before
/// they are decoded, with an error naming the file, the field and the cap.
#[test]
fn gltf_data_uris_over_the_cap_are_refused() {
    use heliar::scene::gltf::MAX_DATA_URI_BYTES;
    let (d, scene) = scratch("gltf-data-cap");
    let deep = scene.join("objects/deep");
    std::fs::create_dir_all(&deep).unwrap();
    edit(&scene.join("scene.toml"), "file = \"objects/statue.glb\"", "file = \"objects/deep/tri.gltf\"");
    // One byte over the cap (the URI's text after `data:`; base64 of zero bytes).
    let head = "application/octet-stream;base64,";
    let over = format!("data:{head}{}", "A".repeat(MAX_DATA_URI_BYTES + 1 - head.len()));
    let (json, bin) = triangle_gltf(&over);
    std::fs::write(deep.join("tri.gltf"), &json).unwrap();
    let cap = MAX_DATA_URI_BYTES.to_string();
    let e = load_err(&d, &scene);
    assert!(e.contains("tri.gltf") && e.contains("buffers[0].uri") && e.contains(&cap) && e.contains("cap"), "{}", &e[..e.len().min(400)]);
    assert!(e.contains(&(MAX_DATA_URI_BYTES + 1).to_string()), "the URI's size is named: {}", &e[..e.len().min(400)]);
    // The same for an image: the buffer is a file inside the scene, the image a huge data: URI.
    std::fs::write(deep.join("tri.bin"), &bin).unwrap();
    let (json, _) = triangle_gltf("tri.bin");
    let with_image = json.replacen("\"buffers\"", &format!("\"images\":[{{\"uri\":\"data:image/png;base64,{}\"}}],\"buffers\"", "A".repeat(MAX_DATA_URI_BYTES)), 1);
    std::fs::write(deep.join("tri.gltf"), with_image).unwrap();
    let e = load_err(&d, &scene);
    assert!(e.contains("tri.gltf") && e.contains("images[0].uri") && e.contains(&cap), "{}", &e[..e.len().min(400)]);
    // The command line says the same, exits non-zero and leaves the scene alone.
    let before = hashes(&d);
    let (ok, err) = heliar(&["sun", "--scene", s(&scene), "--time", "2024-06-21T12:00:00+02:00"]);
    assert!(!ok && err.contains("images[0].uri") && err.contains(&cap), "{}", &err[..err.len().min(400)]);
    assert_eq!(hashes(&d), before);
    std::fs::remove_dir_all(&d).ok();
}

#[test]
fn messages_name_what_failed() {
    // A failed EXR write says it was the write, with the path and the OS's reason.
    let (d, _) = scratch("messages");
    let before = hashes(&d);
    let p = d.join("no/such/folder/out.exr");
    let e = heliar::io::image::LinearImage::new(4, 2).write_exr(&p, heliar::io::image::ExrPrecision::Float).unwrap_err().to_string();
    assert!(e.contains("out.exr") && e.contains("writing the OpenEXR image failed") && e.contains("No such file"), "{e}");
    assert!(!e.contains("not a readable"), "{e}");
    // A zero optical axis is named as the optical axis, not as image_up.
    let lens = d.join("fisheye.toml");
    std::fs::write(&lens, "width = 64\nheight = 64\nfx = 20.0\nfy = 20.0\ncx = 31.5\ncy = 31.5\n[orientation]\noptical_axis = [0.0, 0.0, 0.0]\nimage_up = [0.0, 0.0, -1.0]\n").unwrap();
    let before_lens = hashes(&d);
    let e = heliar::vem::capture::lens_file::FisheyeCalib::load(&lens).unwrap_err().to_string();
    assert!(e.contains("fisheye.toml") && e.contains("orientation.optical_axis") && !e.contains("image_up"), "{e}");
    assert_eq!(hashes(&d), before_lens);
    assert_eq!(before.len() + 1, before_lens.len());
    std::fs::remove_dir_all(&d).ok();
}

#[test]
fn image_headers_are_checked_before_decoding() {
    use heliar::io::frames::Frame;
    use heliar::io::image::{ExrPrecision, LinearImage};
    let (d, scene) = scratch("headers");
    // A 1×1 frame where the camera says 320×240.
    LinearImage::new(1, 1).write_exr(&scene.join("frames/hdr/frame_000.exr"), ExrPrecision::Half).unwrap();
    // Headers wider than the cap, PNG and EXR.
    let wide_png = scene.join("frames/ldr/frame_000.png");
    image::save_buffer(&wide_png, &vec![0u8; 16385 * 3], 16385, 1, image::ExtendedColorType::Rgb8).unwrap();
    let wide_exr = d.join("wide.exr");
    LinearImage::new(16385, 1).write_exr(&wide_exr, ExrPrecision::Half).unwrap();
    let before = hashes(&d);
    let (ok, err) = heliar(&["estimate", s(&scene), "--sequence", "hdr"]);
    assert!(!ok && err.contains("frame_000.exr") && err.contains("1×1") && err.contains("320×240"), "{err}");
    let (ok, err) = heliar(&["estimate", s(&scene), "--sequence", "ldr"]);
    assert!(!ok && err.contains("frame_000.png") && err.contains("16385×1") && err.contains("cap"), "{err}");
    for p in [&wide_png, &wide_exr] {
        let e = Frame::load(p).unwrap_err().to_string();
        assert!(e.contains(p.file_name().unwrap().to_str().unwrap()) && e.contains("16385×1") && e.contains("not decoded"), "{e}");
    }
    let e = LinearImage::read_exr(&wide_exr).unwrap_err().to_string();
    assert!(e.contains("wide.exr") && e.contains("cap"), "{e}");
    let e = Frame::load_sized(&scene.join("frames/hdr/frame_000.exr"), 320, 240).unwrap_err().to_string();
    assert!(e.contains("frame_000.exr") && e.contains("1×1"), "{e}");
    assert_eq!(hashes(&d), before);
    std::fs::remove_dir_all(&d).ok();
}

/// Property tests: the manifest parser and the frame linearisation never panic; bad values are
/// errors (or invalid pixels), good ones are not.
mod props {
    use super::*;
    use heliar::io::frames::{Frame, FrameData, Linearizer, PixelState, Response};
    use heliar::io::image::{ExrPrecision, LinearImage};
    use proptest::prelude::*;

    const NASTY: &[&str] = &[
        "-1", "0", "1e308", "-1e308", "nan", "inf", "-inf", "\"\"", "[]", "[1.0, 2.0]", "[nan, 0.0, 0.0]", "\"../x\"", "\"/etc/passwd\"",
        "{}", "true", "18446744073709551616", "-0.0", "1e-300", "\"2024-13-45T99:00:00+02:00\"",
    ];

    /// `text` with the value of its `line`-th `key = value` line replaced by `value`.
    fn replace_value(text: &str, line: usize, value: &str) -> String {
        let assignments: Vec<usize> = text.lines().enumerate().filter(|(_, l)| l.contains(" = ") && !l.trim_start().starts_with('#')).map(|(i, _)| i).collect();
        let target = assignments[line % assignments.len()];
        text.lines()
            .enumerate()
            .map(|(i, l)| if i == target { format!("{} = {value}\n", l.split(" = ").next().unwrap_or("")) } else { format!("{l}\n") })
            .collect()
    }

    proptest! {
        #![proptest_config(ProptestConfig { cases: 48, failure_persistence: None, ..ProptestConfig::default() })]

        #[test]
        fn manifest_and_camera_values_never_panic(file in 0usize..2, line in 0usize..64, nasty in 0usize..NASTY.len(), junk in "[ -~]{0,12}") {
            let (d, scene) = scratch("prop-manifest");
            let name = ["scene.toml", "calib/camera.toml"][file];
            let p = scene.join(name);
            let text = std::fs::read_to_string(&p).unwrap();
            let value = if line % 5 == 4 { junk.as_str() } else { NASTY[nasty] };
            std::fs::write(&p, replace_value(&text, line, value)).unwrap();
            let before = hashes(&d);
            // Either it loads or the error names a file.
            if let Err(e) = Scene::load(&scene) {
                let e = e.to_string();
                prop_assert!(e.contains(".toml") || e.contains(".glb") || e.contains(".csv") || e.contains(".exr") || e.contains("courtyard"), "{e}");
            }
            prop_assert_eq!(hashes(&d), before);
            std::fs::remove_dir_all(&d).ok();
        }

        #[test]
        fn random_bytes_as_a_manifest_are_an_error(bytes in proptest::collection::vec(any::<u8>(), 0..256)) {
            let (d, scene) = scratch("prop-bytes");
            std::fs::write(scene.join("scene.toml"), &bytes).unwrap();
            let e = Scene::load(&scene).expect_err("random bytes are not a manifest").to_string();
            prop_assert!(e.contains("scene.toml"), "{e}");
            std::fs::remove_dir_all(&d).ok();
        }

        #[test]
        fn hdr_frames_with_nan_inf_masks_linearise_without_panics(
            pixels in proptest::collection::vec((0u8..6, -6.0f32..6.0, -6.0f32..6.0, -6.0f32..6.0), 1..48),
            exposure_exp in -6.0f32..6.0,
            clip in proptest::option::of(1e-6f32..1e6),
        ) {
            // Scale 1e-6 … 1e6, with NaN, ±Inf and negative values masked in.
            let data: Vec<[f32; 3]> = pixels.iter().map(|&(mask, r, g, b)| {
                let v = [r, g, b].map(|e| 10f32.powf(e));
                match mask {
                    0 => [f32::NAN, v[1], v[2]],
                    1 => [v[0], f32::INFINITY, v[2]],
                    2 => [v[0], v[1], -v[2]],
                    3 => [v[0], f32::NEG_INFINITY, v[2]],
                    _ => v,
                }
            }).collect();
            let n = data.len() as u32;
            let img = LinearImage { width: n, height: 1, data: data.clone() };
            let lin = Linearizer::new(&Response::Linear, 10f32.powf(exposure_exp), 0.98, clip);
            // In memory and through an EXR file: the same states.
            let dir = std::env::temp_dir().join(format!("heliar-prop-frames-{}", std::process::id()));
            std::fs::create_dir_all(&dir).unwrap();
            let path = dir.join("f.exr");
            img.write_exr(&path, ExrPrecision::Float).unwrap();
            let loaded = Frame::load_sized(&path, n, 1).unwrap();
            for frame in [Frame { width: n, height: 1, data: FrameData::Hdr(img) }, loaded] {
                for (i, p) in data.iter().enumerate() {
                    let (v, state) = lin.radiance(&frame, i);
                    let bad = p.iter().any(|c| !c.is_finite() || *c < 0.0);
                    prop_assert_eq!(state == PixelState::Invalid, bad, "{:?} -> {:?}", p, state);
                    if state == PixelState::Ok {
                        prop_assert!(v.iter().all(|c| c.is_finite() && *c >= 0.0), "{:?} -> {:?}", p, v);
                    }
                }
                prop_assert!(lin.linear_image(&frame).data.iter().all(|p| p.iter().all(|c| !c.is_nan())));
            }
            std::fs::remove_dir_all(&dir).ok();
        }

        #[test]
        fn ldr_codes_linearise_without_panics(codes in proptest::collection::vec(any::<u16>(), 3..96), sixteen in any::<bool>(), gamma in 0.1f32..5.0, exposure_exp in -6.0f32..6.0) {
            let bits = if sixteen { 16 } else { 8 };
            let codes: Vec<u16> = codes.iter().map(|&c| if sixteen { c } else { c % 256 }).take(codes.len() / 3 * 3).collect();
            let n = (codes.len() / 3) as u32;
            let frame = Frame { width: n, height: 1, data: FrameData::Ldr { bits, codes: codes.clone() } };
            for response in [Response::Srgb, Response::Linear, Response::Gamma(gamma), Response::Table(vec![[0.0; 3], [0.2, 0.3, 0.4], [1.0; 3]])] {
                let lin = Linearizer::new(&response, 10f32.powf(exposure_exp), 0.98, None);
                for i in 0..n as usize {
                    let (v, state) = lin.radiance(&frame, i);
                    prop_assert!(state != PixelState::Invalid);
                    prop_assert!(v.iter().all(|c| c.is_finite() && *c >= 0.0), "{:?}", v);
                }
            }
        }
    }
}
