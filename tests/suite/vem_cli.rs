//! The `heliar vem` and `heliar bench vem` commands and the `gen-vem` generator.

use std::path::{Path, PathBuf};
use std::process::Command;

fn run(exe: &str, args: &[&str]) -> (bool, String, String) {
    let out = Command::new(exe).args(args).current_dir(env!("CARGO_MANIFEST_DIR")).output().unwrap();
    (out.status.success(), String::from_utf8_lossy(&out.stdout).into(), String::from_utf8_lossy(&out.stderr).into())
}

fn heliar(args: &[&str]) -> (bool, String, String) {
    run(env!("CARGO_BIN_EXE_heliar"), args)
}

fn temp_dir(name: &str) -> PathBuf {
    let d = std::env::temp_dir().join(format!("heliar-vemcli-{name}-{}", std::process::id()));
    std::fs::create_dir_all(&d).unwrap();
    d
}

fn s(p: &Path) -> &str {
    p.to_str().unwrap()
}

#[test]
fn generated_sequence_to_json_lines() {
    let dir = temp_dir("gen");
    let (ok, _, err) = run(env!("CARGO_BIN_EXE_gen-vem"), &["--out", s(&dir), "--size", "64", "--frames", "10"]);
    assert!(ok, "{err}");
    for seq in ["outdoor", "lamp"] {
        let d = dir.join(seq);
        assert!(d.join("calib/fisheye.toml").is_file() && d.join("truth.csv").is_file());
        assert_eq!(std::fs::read_dir(d.join("frames")).unwrap().count(), 10);
    }
    let out = dir.join("lights.jsonl");
    let d = dir.join("outdoor");
    let (ok, _, err) = heliar(&[
        "vem", "--input", s(&d.join("frames")), "--calib", s(&d.join("calib/fisheye.toml")), "--lights", "24", "--clusters", "6",
        "--output", s(&out),
    ]);
    assert!(ok, "{err}");
    assert!(err.contains("median decomposition per frame"), "{err}");
    let text = std::fs::read_to_string(&out).unwrap();
    assert!(!text.contains("null"), "no NaN anywhere");
    let truth: Vec<f64> = std::fs::read_to_string(d.join("truth.csv")).unwrap().lines().skip(1).map(|l| l.split(',').nth(5).unwrap().parse().unwrap()).collect();
    let lines: Vec<serde_json::Value> = text.lines().map(|l| serde_json::from_str(l).unwrap()).collect();
    assert_eq!(lines.len(), 10);
    for (i, v) in lines.iter().enumerate() {
        assert_eq!(v["frame"], i);
        assert_eq!(v["status"], "ok");
        // Zero phase by default on files: each line's lights describe its own frame.
        assert_eq!(v["delay_frames"], 0);
        assert_eq!(v["describes_frame"], i);
        let lights = v["lights"].as_array().unwrap();
        assert_eq!(lights.len(), 24);
        // The samples' indices 0, 1, …, then the peaks' (the sun, by default) from 2³⁰ on.
        for (k, l) in lights.iter().enumerate() {
            let i = l["index"].as_u64().unwrap();
            assert!(i == k as u64 || i >= heliar::vem::peaks::PEAK_INDEX_BASE as u64, "light {k}: index {i}");
            let d: Vec<f64> = l["dir"].as_array().unwrap().iter().map(|x| x.as_f64().unwrap()).collect();
            assert!((d.iter().map(|x| x * x).sum::<f64>() - 1.0).abs() < 1e-5 && d[1] >= -1e-6);
            assert!(l["rgb"].as_array().unwrap().iter().all(|c| c.as_f64().unwrap() >= 0.0));
        }
        assert!(v["clusters"].as_array().unwrap().len() <= 6);
        // The frame's power against the generator's truth (64-pixel fisheye): within 2%.
        let p = v["power"].as_f64().unwrap();
        assert!((p - truth[i]).abs() < 0.02 * truth[i], "frame {i}: {p} vs {}", truth[i]);
    }
    // The paper's causal filter: frame t's lights describe frame t − 4; the minimum-phase one
    // (live's) describes frame t − 1.
    for (mode, delay) in [("causal", 4usize), ("min-phase", 1)] {
        let (ok, _, err) = heliar(&["vem", "--input", s(&d.join("frames")), "--calib", s(&d.join("calib/fisheye.toml")), "--lights", "24", "--temporal", mode, "--output", s(&out)]);
        assert!(ok, "{err}");
        assert!(err.contains("filter delay") && err.contains("causal"), "{err}");
        for (i, l) in std::fs::read_to_string(&out).unwrap().lines().enumerate() {
            let v: serde_json::Value = serde_json::from_str(l).unwrap();
            assert_eq!((v["frame"].as_u64(), v["delay_frames"].as_u64(), v["describes_frame"].as_u64()), (Some(i as u64), Some(delay as u64), Some(i.saturating_sub(delay) as u64)));
        }
    }
    std::fs::remove_dir_all(&dir).ok();
}

#[test]
fn black_frames_report_dark_and_bad_input_names_the_file() {
    let dir = temp_dir("dark");
    let frames = dir.join("frames");
    std::fs::create_dir_all(&frames).unwrap();
    for i in 0..3 {
        heliar::io::image::LinearImage::new(360, 90).write_exr(&frames.join(format!("{i}.exr")), heliar::io::image::ExrPrecision::Half).unwrap();
    }
    let (ok, out, err) = heliar(&["vem", "--input", s(&frames), "--lights", "8"]);
    assert!(ok, "{err}");
    for l in out.lines() {
        let v: serde_json::Value = serde_json::from_str(l).unwrap();
        assert_eq!(v["status"], "dark");
        assert_eq!(v["lights"].as_array().unwrap().len(), 0);
        assert_eq!(v["filtered_power"], 0.0);
    }
    assert!(!out.contains("null"));
    // A calibration with a bad field, and a frame of the wrong size.
    let calib = dir.join("fisheye.toml");
    std::fs::write(&calib, "width = 64\nheight = 64\nfx = -1.0\nfy = 20.0\ncx = 32\ncy = 32\n[orientation]\nrvec_camera_from_world = [0.0, 0.0, 0.0]\n").unwrap();
    let (ok, _, err) = heliar(&["vem", "--input", s(&frames), "--calib", s(&calib), "--lights", "8"]);
    assert!(!ok && err.contains("fisheye.toml") && err.contains("fx"), "{err}");
    std::fs::write(&calib, "width = 64\nheight = 64\nfx = 20.0\nfy = 20.0\ncx = 32\ncy = 32\n[orientation]\nrvec_camera_from_world = [0.0, 0.0, 0.0]\n").unwrap();
    let (ok, _, err) = heliar(&["vem", "--input", s(&frames), "--calib", s(&calib), "--lights", "8"]);
    assert!(!ok && err.contains("0.exr") && err.contains("64×64"), "{err}");
    let (ok, _, err) = heliar(&["vem", "--input", s(&frames), "--lights", "0"]);
    assert!(!ok && err.contains("lights"), "{err}");
    std::fs::remove_dir_all(&dir).ok();
}

#[test]
fn bench_vem_writes_tables_and_plots() {
    let dir = temp_dir("bench");
    let prefix = dir.join("b");
    let (ok, out, err) = heliar(&["bench", "vem", "--repeats", "1", "--normals", "16", "--out", s(&prefix)]);
    assert!(ok, "{err}");
    assert!(out.contains("irradiance error") && out.contains("temporal coherence"), "{out}");
    let csv = std::fs::read_to_string(dir.join("b_error.csv")).unwrap();
    assert_eq!(csv.lines().count(), 10);
    assert!(csv.starts_with("lights,havran_err_pct"));
    assert!(dir.join("b_error.svg").is_file() && dir.join("b_coherence.svg").is_file());
    let coh = std::fs::read_to_string(dir.join("b_coherence.csv")).unwrap();
    assert_eq!(coh.lines().count(), 1 + 4 * 5 * 7); // N × changes × samplers (with both cuts)
    std::fs::remove_dir_all(&dir).ok();
}

#[test]
fn bench_vem_sun_compares_samplers_median_cut_and_peaks() {
    let dir = temp_dir("bench-sun");
    let prefix = dir.join("b");
    let (ok, out, err) = heliar(&["bench", "vem", "--what", "sun", "--normals", "16", "--out", s(&prefix)]);
    assert!(ok, "{err}");
    assert!(out.contains("sun-dominated sequence") && out.contains("64 upper-hemisphere normals"), "{out}");
    let csv = std::fs::read_to_string(dir.join("b_sun.csv")).unwrap();
    assert!(csv.starts_with("lights,variant,err_mean_pct,err_p95_pct,err_max_pct,ms_per_frame,excess_flicker_rms_pct"), "{csv}");
    assert!(csv.contains(",motion_median_deg,motion_p95_deg"), "{csv}");
    assert_eq!(csv.lines().count(), 1 + 3 * 8);
    assert!(csv.contains(",median_cut,") && csv.contains(",havran+peaks,") && csv.contains(",coherent_cut+peaks,"));
    assert!(out.contains("overcast sequence") && out.contains("indoor sequence"), "{out}");
    std::fs::remove_dir_all(&dir).ok();
}

#[test]
fn median_cut_and_peaks_from_the_command_line() {
    let dir = temp_dir("mc");
    let (ok, _, err) = run(env!("CARGO_BIN_EXE_gen-vem"), &["--out", s(&dir), "--size", "64", "--frames", "6"]);
    assert!(ok, "{err}");
    let d = dir.join("outdoor");
    let (frames, calib) = (d.join("frames"), d.join("calib/fisheye.toml"));
    let lines = |args: &[&str]| -> Vec<serde_json::Value> {
        let mut a = vec!["vem", "--input", s(&frames), "--calib", s(&calib), "--lights", "24"];
        a.extend_from_slice(args);
        let (ok, out, err) = heliar(&a);
        assert!(ok, "{args:?}: {err}");
        out.lines().map(|l| serde_json::from_str(l).unwrap()).collect()
    };
    for v in lines(&["--sampler", "median-cut"]) {
        let l = v["lights"].as_array().unwrap();
        assert_eq!(l.len(), 24);
        let y: f64 = l.iter().map(|l| {
            let c: Vec<f64> = l["rgb"].as_array().unwrap().iter().map(|x| x.as_f64().unwrap()).collect();
            0.2126 * c[0] + 0.7152 * c[1] + 0.0722 * c[2]
        }).sum();
        let p = v["power"].as_f64().unwrap();
        assert!((y - p).abs() < 1e-3 * p, "{y} vs {p}");
    }
    let is_peak = |l: &serde_json::Value| l["index"].as_u64().unwrap() >= 1 << 30;
    // Peaks are the coherent cut's default: the sun gets a light of its own, with its radius.
    let with_peaks = lines(&[]);
    let sun_lights = with_peaks.iter().filter(|v| v["lights"].as_array().unwrap().iter().any(is_peak)).count();
    assert!(sun_lights >= 4, "the sun of the generated sky is a peak: {sun_lights} of 6 frames");
    assert!(with_peaks.iter().all(|v| v["lights"].as_array().unwrap().len() == 24));
    for l in with_peaks.iter().flat_map(|v| v["lights"].as_array().unwrap().iter().filter(|l| is_peak(l))) {
        let r = l["radius"].as_f64().unwrap();
        assert!(r > 0.0 && r < 5f64.to_radians(), "a 64-pixel sun is a few degrees at most: {r}");
    }
    assert!(lines(&["--no-peaks"]).iter().all(|v| !v["lights"].as_array().unwrap().iter().any(|l| is_peak(l) || l.get("radius").is_some())));
    let (ok, _, err) = heliar(&["vem", "--input", s(&frames), "--calib", s(&calib), "--peaks", "--no-peaks"]);
    assert!(!ok && err.contains("--no-peaks"), "{err}");
    // Peaks with a glossy set: `H` (the lines' lights) keeps N lights and the sun.
    let glossy = lines(&["--glossy-lights", "48"]);
    assert!(glossy.iter().all(|v| v["lights"].as_array().unwrap().len() == 24));
    assert!(glossy.iter().filter(|v| v["lights"].as_array().unwrap().iter().any(is_peak)).count() >= 4);
    std::fs::remove_dir_all(&dir).ok();
}

#[test]
fn scene_compositing_writes_frames_report_and_contact_sheet() {
    // 14 generated frames over the bundled courtyard (12 footage frames): footage backgrounds,
    // then the VEM seen through the camera.
    let dir = temp_dir("scene");
    let (ok, _, err) = run(env!("CARGO_BIN_EXE_gen-vem"), &["--out", s(&dir), "--size", "64", "--frames", "14"]);
    assert!(ok, "{err}");
    let d = dir.join("outdoor");
    let out = dir.join("composited");
    let (ok, _, err) = heliar(&[
        "vem", "--scene", "scenes/courtyard", "--input", s(&d.join("frames")), "--calib", s(&d.join("calib/fisheye.toml")), "--lights", "64",
        "--output", s(&out),
    ]);
    assert!(ok, "{err}");
    for i in 0..14 {
        let img = image::open(out.join(format!("frame_{i:04}.png"))).unwrap();
        assert_eq!((img.width(), img.height()), (320, 240));
    }
    assert!(out.join("contact_sheet.png").is_file());
    let lines: Vec<serde_json::Value> = std::fs::read_to_string(out.join("frames.jsonl")).unwrap().lines().map(|l| serde_json::from_str(l).unwrap()).collect();
    assert_eq!(lines.len(), 14);
    for (i, v) in lines.iter().enumerate() {
        let r = &v["render"];
        assert_eq!(r["background"], if i < 12 { "footage" } else { "environment" }, "frame {i}");
        let ran: Vec<&str> = r["ran"].as_array().unwrap().iter().map(|p| p.as_str().unwrap()).collect();
        assert_eq!(ran, ["shadow_atlas", "depth_prepass", "receivers", "shading", "composite", "tonemap"]);
        assert!(r["shadow_maps"].as_u64().unwrap() >= 1 && r["shadow_maps"].as_u64().unwrap() <= 72);
        assert!(r["timings"]["total_ms"].as_f64().unwrap() > 0.0);
        assert_eq!(v["lights"].as_array().unwrap().len(), 64);
    }
    let report: serde_json::Value = serde_json::from_str(&std::fs::read_to_string(out.join("report.json")).unwrap()).unwrap();
    assert_eq!(report["frames"], 14);
    assert_eq!(report["receivers"], "proxy");
    assert_eq!(report["passes_run"]["shading"], 14);
    assert_eq!(report["median_lights"], 64.0);
    assert!(report["median_shadow_maps"].as_f64().unwrap() >= 1.0);
    // Without --scene, --output is still the JSON-lines file.
    let (ok, _, err) = heliar(&["vem", "--input", s(&d.join("frames")), "--calib", s(&d.join("calib/fisheye.toml")), "--output", s(&dir.join("l.jsonl"))]);
    assert!(ok && dir.join("l.jsonl").is_file(), "{err}");
    std::fs::remove_dir_all(&dir).ok();
}

#[test]
fn dark_frames_skip_the_shadow_pass_with_a_reason() {
    let dir = temp_dir("scenedark");
    let frames = dir.join("frames");
    std::fs::create_dir_all(&frames).unwrap();
    for i in 0..2 {
        heliar::io::image::LinearImage::new(360, 90).write_exr(&frames.join(format!("{i}.exr")), heliar::io::image::ExrPrecision::Half).unwrap();
    }
    let out = dir.join("out");
    let (ok, _, err) = heliar(&["vem", "--scene", "scenes/courtyard", "--input", s(&frames), "--lights", "8", "--output", s(&out)]);
    assert!(ok, "{err}");
    for l in std::fs::read_to_string(out.join("frames.jsonl")).unwrap().lines() {
        let v: serde_json::Value = serde_json::from_str(l).unwrap();
        assert_eq!(v["status"], "dark");
        let skipped = v["render"]["skipped"].as_array().unwrap();
        let atlas = skipped.iter().find(|s| s["pass"] == "shadow_atlas").expect("shadow pass skipped");
        assert!(atlas["reason"].as_str().unwrap().contains("dark"), "{atlas}");
    }
    let report = std::fs::read_to_string(out.join("report.json")).unwrap();
    assert!(report.contains("the lights carry no power (status dark)"), "{report}");
    let (ok, _, err) = heliar(&["vem", "--scene", "scenes/courtyard", "--input", s(&frames)]);
    assert!(!ok && err.contains("--output"), "{err}");
    std::fs::remove_dir_all(&dir).ok();
}

/// The lights of `heliar vem` on one equirect frame, and its stderr.
fn lights_of(file: &Path, extra: &[&str], out: &Path) -> (Vec<(glam::Vec3, f64)>, String) {
    let mut args = vec!["vem", "--input", s(file), "--lights", "64", "--output", s(out)];
    args.extend_from_slice(extra);
    let (ok, _, err) = heliar(&args);
    assert!(ok, "{err}");
    let v: serde_json::Value = serde_json::from_str(std::fs::read_to_string(out).unwrap().lines().next().unwrap()).unwrap();
    let lights = v["lights"].as_array().unwrap().iter().map(|l| {
        let d: Vec<f32> = l["dir"].as_array().unwrap().iter().map(|x| x.as_f64().unwrap() as f32).collect();
        (glam::Vec3::new(d[0], d[1], d[2]), l["rgb"][1].as_f64().unwrap())
    });
    (lights.collect(), err)
}

#[test]
fn yaw_turns_a_rotated_equirect_map_back_and_the_layout_is_printed() {
    use heliar::io::image::{ExrPrecision, LinearImage};
    let dir = temp_dir("yaw");
    // A sky with no symmetry in azimuth and a bright patch at azimuth 30°, elevation 40°.
    let (w, h) = (720u32, 360u32);
    let patch = glam::Vec3::new(30f32.to_radians().sin() * 40f32.to_radians().cos(), 40f32.to_radians().sin(), -30f32.to_radians().cos() * 40f32.to_radians().cos());
    let sky = |x: u32, y: u32| {
        let d = heliar::geometry::equirect::dir_from_texel_centre(x, y, w, h);
        let g = 1.0 + d.y.max(0.0) + 0.5 * (d.x + 0.3 * d.z).max(0.0) + if d.dot(patch) > 0.995 { 200.0 } else { 0.0 };
        [g, 0.8 * g, 0.6 * g]
    };
    LinearImage::from_fn(w, h, sky).write_exr(&dir.join("north.exr"), ExrPrecision::Float).unwrap();
    let (base, err) = lights_of(&dir.join("north.exr"), &[], &dir.join("north.jsonl"));
    assert!(err.contains("layout: 720×360 frames read as 2:1 equirect maps") && err.contains("north (−Z) at the centre column"), "{err}");
    // Rotated by k columns: column x of the file shows what the north-up map has at x + k, so
    // its centre column looks toward azimuth k·360°/W; --yaw that angle gives the same lights.
    // One polar texel is 1° (360×90 map): the lights must agree within one texel.
    for k in [90u32, 25, 697] {
        let name = format!("k{k}.exr");
        LinearImage::from_fn(w, h, |x, y| sky((x + k) % w, y)).write_exr(&dir.join(&name), ExrPrecision::Float).unwrap();
        let yaw = format!("{}", k as f64 * 360.0 / w as f64);
        let (turned, err) = lights_of(&dir.join(&name), &["--yaw", &yaw], &dir.join("k.jsonl"));
        assert!(err.contains(&format!("--yaw {yaw}°")), "{err}");
        assert_eq!(turned.len(), base.len());
        let worst = base.iter().zip(&turned).map(|(a, b)| a.0.angle_between(b.0).to_degrees()).fold(0.0f32, f32::max);
        let power = |l: &[(glam::Vec3, f64)]| l.iter().map(|x| x.1).sum::<f64>();
        assert!(worst < 1.0, "k = {k}: a light moved {worst}°");
        assert!((power(&turned) / power(&base) - 1.0).abs() < 1e-3, "k = {k}");
        // Without the yaw the rotated map's lights are elsewhere.
        if k == 90 {
            let (plain, _) = lights_of(&dir.join(&name), &[], &dir.join("k.jsonl"));
            let moved = base.iter().zip(&plain).map(|(a, b)| a.0.angle_between(b.0).to_degrees()).fold(0.0f32, f32::max);
            assert!(moved > 10.0, "{moved}");
        }
    }
    let (ok, _, err) = heliar(&["vem", "--input", s(&dir.join("north.exr")), "--yaw", "NaN", "--output", s(&dir.join("x.jsonl"))]);
    assert!(!ok && err.contains("--yaw") && err.contains("finite"), "{err}");
    std::fs::remove_dir_all(&dir).ok();
}
