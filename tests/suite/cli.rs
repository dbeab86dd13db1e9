//! The `heliar` command line: `sun` (single and batch), `estimate`, `bake`, `relight`, `irradiance`.

use crate::common;

use std::path::Path;
use std::process::Command;

fn heliar(args: &[&str]) -> (bool, String, String) {
    let out = Command::new(env!("CARGO_BIN_EXE_heliar")).args(args).current_dir(env!("CARGO_MANIFEST_DIR")).output().unwrap();
    (out.status.success(), String::from_utf8_lossy(&out.stdout).into(), String::from_utf8_lossy(&out.stderr).into())
}

#[test]
fn sun_reproduces_the_spa_worked_example() {
    let (ok, out, err) = heliar(&[
        "sun", "--lat", "39.742476", "--lon", "-105.1786", "--elevation", "1830.14", "--pressure", "820",
        "--temperature", "11", "--delta-t", "67", "--time", "2003-10-17T12:30:30-07:00",
    ]);
    assert!(ok, "{err}");
    let v: serde_json::Value = serde_json::from_str(&out).unwrap();
    // Published: topocentric zenith 50.11162°, azimuth 194.34024° (Reda & Andreas, Table A5.1).
    assert!((v["apparent_zenith_deg"].as_f64().unwrap() - 50.11162).abs() < 1e-4, "{v}");
    assert!((v["azimuth_deg"].as_f64().unwrap() - 194.34024).abs() < 1e-4, "{v}");
    assert!(v["zenith_deg"].as_f64().unwrap() > 50.11162);
    assert_eq!(v["above_horizon"], true);
    assert!(v.get("dir_world").is_none());
}

#[test]
fn sun_with_a_scene_gives_the_direction_in_its_frame() {
    let (ok, out, err) = heliar(&["sun", "--scene", "scenes/courtyard", "--time", "2024-06-21T15:30:00+02:00"]);
    assert!(ok, "{err}");
    let v: serde_json::Value = serde_json::from_str(&out).unwrap();
    let d: Vec<f64> = v["dir_world"].as_array().unwrap().iter().map(|x| x.as_f64().unwrap()).collect();
    let zen = v["apparent_zenith_deg"].as_f64().unwrap().to_radians();
    let az = v["azimuth_deg"].as_f64().unwrap().to_radians();
    assert!((d.iter().map(|x| x * x).sum::<f64>() - 1.0).abs() < 1e-6);
    assert!((d[1] - zen.cos()).abs() < 1e-6);
    // North is -Z and east +X in the courtyard.
    assert!((d[0] - zen.sin() * az.sin()).abs() < 1e-6 && (d[2] + zen.sin() * az.cos()).abs() < 1e-6, "{d:?}");
}

#[test]
fn sun_batch_csv() {
    let dir = std::env::temp_dir().join(format!("heliar-cli-{}", std::process::id()));
    std::fs::create_dir_all(&dir).unwrap();
    let input = dir.join("in.csv");
    std::fs::write(
        &input,
        "lat,lon,time,elevation_m\n39.742476,-105.1786,2003-10-17T12:30:30-07:00,1830.14\n57.05,9.92,2024-12-21T00:00:00+01:00\n",
    )
    .unwrap();
    let output = dir.join("out.csv");
    let (ok, _, err) = heliar(&["sun", "--csv", input.to_str().unwrap(), "--output", output.to_str().unwrap()]);
    assert!(ok, "{err}");
    let text = std::fs::read_to_string(&output).unwrap();
    let rows: Vec<Vec<&str>> = text.lines().map(|l| l.split(',').collect()).collect();
    assert_eq!(rows[0], ["lat", "lon", "time", "elevation_m", "zenith_deg", "apparent_zenith_deg", "azimuth_deg", "above_horizon"]);
    assert_eq!(rows.len(), 3);
    assert_eq!(rows[1][3], "1830.14");
    assert_eq!(rows[2][7], "false");
    // A bad row names the file and the row.
    std::fs::write(&input, "39.7,-105.2,yesterday\n").unwrap();
    let (ok, _, err) = heliar(&["sun", "--csv", input.to_str().unwrap()]);
    assert!(!ok && err.contains("in.csv") && err.contains("row 1"), "{err}");
    std::fs::remove_dir_all(&dir).ok();
}

#[test]
fn estimate_writes_one_json_line_per_frame() {
    let out = std::env::temp_dir().join(format!("heliar-est-{}.jsonl", std::process::id()));
    let (ok, _, err) = heliar(&["estimate", "scenes/courtyard", "--sequence", "ldr", "--output", out.to_str().unwrap()]);
    assert!(ok, "{err}");
    assert!(err.contains("Pd error vs truth"), "{err}");
    let text = std::fs::read_to_string(&out).unwrap();
    let lines: Vec<serde_json::Value> = text.lines().map(|l| serde_json::from_str(l).unwrap()).collect();
    assert_eq!(lines.len(), 12);
    for (i, l) in lines.iter().enumerate() {
        assert_eq!(l["frame"], i);
        for key in ["time", "sun", "status", "pd", "pa", "pd_se", "pa_se", "residual_rms", "condition_number", "samples", "relight"] {
            assert!(l.get(key).is_some(), "line {i} lacks {key}");
        }
        assert!(l["error"]["pd"].as_f64().unwrap() < 0.03);
    }
    std::fs::remove_file(&out).ok();
    // A missing scene is an error naming it, with a non-zero exit.
    let (ok, _, err) = heliar(&["estimate", "scenes/nowhere"]);
    assert!(!ok && err.contains("scenes/nowhere"), "{err}");
    assert!(Path::new(env!("CARGO_MANIFEST_DIR")).join("scenes/courtyard/scene.toml").exists());
}

#[test]
fn bake_relight_and_irradiance_commands() {
    let dst = common::scratch_courtyard("cli-bake");
    let d = dst.to_str().unwrap();
    let (ok, _, err) = heliar(&["bake", d]);
    assert!(ok, "{err}");
    assert!(err.contains("baked 256×128"), "{err}");
    let (ok, _, err) = heliar(&["bake", d]);
    assert!(ok && err.contains("up to date"), "{err}");
    let out = dst.join("relit.exr");
    let (ok, json, err) = heliar(&["relight", d, "--pd", "1,1,1", "--pa", "0.5,0.5,0.5", "--time", "2024-06-21T15:30:00+02:00", "-o", out.to_str().unwrap()]);
    assert!(ok, "{err}");
    let v: serde_json::Value = serde_json::from_str(&json).unwrap();
    assert!(v["sunlit_texels"].as_u64().unwrap() > 1000);
    let img = heliar::io::image::LinearImage::read_exr(&out).unwrap();
    // Zenith texels are sky: Pa/π.
    assert!((img.get(0, 0)[0] - 0.5 / std::f32::consts::PI).abs() < 1e-5);
    // Irradiance on an upward normal at the top of the grid, in the open, under a sky-only light:
    // at most Pa (buildings hide some sky) and well above half of it.
    let (ok, json, err) = heliar(&["irradiance", d, "--at", "2,2.9,3", "--normal", "0,1,0", "--pd", "0,0,0", "--pa", "1,1,1"]);
    assert!(ok, "{err}");
    let v: serde_json::Value = serde_json::from_str(&json).unwrap();
    let e = v["irradiance"][0].as_f64().unwrap();
    assert!(e > 0.6 && e <= 1.01, "{v}");
    assert_eq!(v["path"], "linear");
    let (ok, _, err) = heliar(&["irradiance", d, "--at", "2,x,3", "--normal", "0,1,0"]);
    assert!(!ok && err.contains("--at"), "{err}");
    std::fs::remove_dir_all(&dst).ok();
}

#[test]
fn augment_writes_frames_a_report_and_a_contact_sheet() {
    // Three LDR frames copied to a folder that is not a scene sequence (times from --start/--fps).
    let dir = std::env::temp_dir().join(format!("heliar-aug-{}", std::process::id()));
    let (input, output) = (dir.join("in"), dir.join("out"));
    std::fs::create_dir_all(&input).unwrap();
    let src = Path::new(env!("CARGO_MANIFEST_DIR")).join("scenes/courtyard/frames/ldr");
    for i in [0, 1, 2] {
        std::fs::copy(src.join(format!("frame_{i:03}.png")), input.join(format!("frame_{i:03}.png"))).unwrap();
    }
    let args = [
        "augment", "scenes/courtyard", "--input", input.to_str().unwrap(), "--output", output.to_str().unwrap(),
        "--start", "2024-06-21T15:30:00+02:00", "--fps", "0.1", "--exposure", "3.5",
    ];
    let (ok, _, err) = heliar(&args);
    assert!(ok, "{err}");
    let report = std::fs::read_to_string(output.join("report.jsonl")).unwrap();
    let lines: Vec<serde_json::Value> = report.lines().map(|l| serde_json::from_str(l).unwrap()).collect();
    assert_eq!(lines.len(), 3);
    // The robot's visibility cuts (it has a motion) run first, then the volumes.
    let ran = lines[0]["passes"]["ran"].as_array().unwrap();
    assert!(ran.iter().any(|p| p == "visibility_cuts") && ran.iter().any(|p| p == "volume_build"), "{ran:?}");
    assert_eq!(lines[0]["relight"]["ran"], true);
    assert!(lines[1]["passes"]["skipped"].as_array().is_some());
    assert!(output.join("contact_sheet.png").exists());
    // PNG in, PNG out through the camera response; pixels far from the statue (beyond its shadow
    // and the ≈ 2.5 m around it where it takes sky light from the real surfaces) and from the
    // robot (which crosses the right of the view, x ≥ 160, its cut field reaching about 5 m: the
    // ground it reaches projects to x ≥ 166 on frame 0) are the input's own codes, the statue's
    // pixels are not.
    let a = image::open(input.join("frame_000.png")).unwrap().to_rgb8();
    let b = image::open(output.join("frame_000.png")).unwrap().to_rgb8();
    assert_eq!(a.dimensions(), b.dimensions());
    let changed: Vec<(u32, u32)> = a.enumerate_pixels().filter(|(x, y, p)| b.get_pixel(*x, *y) != *p).map(|(x, y, _)| (x, y)).collect();
    assert!(changed.len() > 300, "{} pixels changed", changed.len());
    let far: Vec<&(u32, u32)> = changed.iter().filter(|&&(x, y)| !((40..240).contains(&x) && (40..200).contains(&y)) && x < 160).collect();
    assert!(far.is_empty(), "pixels far from the statue changed: {} of them, e.g. {:?}", far.len(), &far[..far.len().min(10)]);
    // A folder that is not a sequence, without --start, is refused with a reason.
    let (ok, _, err) = heliar(&["augment", "scenes/courtyard", "--input", input.to_str().unwrap(), "--output", output.to_str().unwrap()]);
    assert!(!ok && err.contains("--start"), "{err}");
    std::fs::remove_dir_all(&dir).ok();
}
