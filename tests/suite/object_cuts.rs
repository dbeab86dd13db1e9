//! The visibility cuts per frame (issue 15 §2): a frame where the courtyard's statue moved by
//! translation takes its ambient and the ground's contact shadow from the cuts, and is checked
//! against the re-traced path: the same scene with the statue placed at the new spot from the
//! start (per-pixel transfer and `c_v`, `b_v` traced there).

use crate::common::*;
use glam::Vec3;
use heliar::geometry::raycast::RayScene;
use heliar::io::image::LinearImage;
use heliar::scene::Scene;
use std::path::{Path, PathBuf};

/// Still for two frames at the manifest's placement, then moved 0.7 m along x and 0.6 m along z
/// without turning (the courtyard's frames are 10 s apart).
const SLIDE_KEYS: &str = "[[virtual_objects.motion.keyframes]]\ntime = 0.0\ntranslation = [-1.9, 0, 0]\nrotation_y_deg = 25\n\
                          [[virtual_objects.motion.keyframes]]\ntime = 10.0\ntranslation = [-1.9, 0, 0]\nrotation_y_deg = 25\n\
                          [[virtual_objects.motion.keyframes]]\ntime = 20.0\ntranslation = [-1.2, 0, 0.6]\nrotation_y_deg = 25\n";
const OLD_PLACE: Vec3 = Vec3::new(-1.9, 0.0, 0.0);
const NEW_PLACE: Vec3 = Vec3::new(-1.2, 0.0, 0.6);

fn edit(dir: &Path, from: &str, to: &str) {
    let p = dir.join("scene.toml");
    let s = std::fs::read_to_string(&p).unwrap();
    assert!(s.contains(from), "scene.toml has no '{from}'");
    std::fs::write(&p, s.replacen(from, to, 1)).unwrap();
}

/// `heliar augment` of the courtyard's first three HDR frames of `scene` into `out`; the frames
/// and the report's lines.
fn augment3(scene: &Path, out: &Path) -> (Vec<LinearImage>, Vec<serde_json::Value>) {
    let input = Path::new(env!("CARGO_MANIFEST_DIR")).join("scenes/courtyard/frames/hdr");
    let o = std::process::Command::new(env!("CARGO_BIN_EXE_heliar"))
        .args(["augment", s(scene), "--input", s(&input), "--output", s(out), "--format", "exr"])
        .args(["--start", "2024-06-21T15:30:00+02:00", "--fps", "0.1", "--max-frames", "3"])
        .output()
        .unwrap();
    assert!(o.status.success(), "{}", String::from_utf8_lossy(&o.stderr));
    let mut names: Vec<PathBuf> = std::fs::read_dir(out).unwrap().flatten().map(|e| e.path()).filter(|p| p.extension().is_some_and(|x| x == "exr")).collect();
    names.sort();
    let frames = names.iter().map(|p| LinearImage::read_exr(p).unwrap()).collect();
    let report = std::fs::read_to_string(out.join("report.jsonl")).unwrap();
    (frames, report.lines().map(|l| serde_json::from_str(l).unwrap()).collect())
}

fn lum(p: [f32; 3]) -> f64 {
    (0.2126 * p[0] + 0.7152 * p[1] + 0.0722 * p[2]) as f64
}

/// Footage pixels whose centre ray meets the statue of `scene` (at its placement) before the
/// proxy, and whose four neighbours do too (silhouette pixels mix in the footage).
fn object_pixels(scene: &Scene) -> Vec<usize> {
    let k = &scene.camera.intrinsics;
    let (w, h) = (k.width, k.height);
    let statue = RayScene::new(scene.virtual_objects[0].mesh.clone());
    let proxy = RayScene::new(scene.proxy.clone());
    let hit: Vec<bool> = (0..w * h)
        .map(|i| {
            let Some((o, d)) = scene.camera.pixel_ray(i % w, i / w) else { return false };
            let (o, d) = (o.as_vec3(), d.as_vec3());
            match statue.intersect(o, d, f32::MAX) {
                Some(a) => proxy.intersect(o, d, f32::MAX).is_none_or(|b| a.t < b.t),
                None => false,
            }
        })
        .collect();
    let at = |x: i64, y: i64| x >= 0 && y >= 0 && x < w as i64 && y < h as i64 && hit[(y * w as i64 + x) as usize];
    (0..(w * h) as usize)
        .filter(|&i| {
            let (x, y) = ((i as u32 % w) as i64, (i as u32 / w) as i64);
            at(x, y) && at(x - 1, y) && at(x + 1, y) && at(x, y - 1) && at(x, y + 1)
        })
        .collect()
}

/// Relative RMSE of `a` against `reference` over `pixels` (luminance).
fn rel_rmse(a: &LinearImage, reference: &LinearImage, pixels: &[usize]) -> f64 {
    let (mut num, mut den) = (0.0, 0.0);
    for &i in pixels {
        let (x, r) = (lum(a.data[i]), lum(reference.data[i]));
        num += (x - r) * (x - r);
        den += r * r;
    }
    (num / den.max(1e-30)).sqrt()
}

/// The footage pixel of the ground `margin` metres beyond the statue's foot (its vertices within
/// 5 cm of the ground, placed at `place`) in direction `dir` (horizontal, unit).
fn ground_pixel(scene: &Scene, place: Vec3, dir: Vec3, margin: f32) -> (u32, u32) {
    let mesh = &scene.virtual_objects[0].mesh;
    // `scene` is the placed one: its statue stands at NEW_PLACE.
    let foot = mesh.positions.iter().filter(|p| p.y < 0.05).map(|p| (*p - NEW_PLACE).dot(dir)).fold(0.0f32, f32::max);
    let p = place + dir * (foot + margin);
    let proxy = RayScene::new(scene.proxy.clone());
    let ground = proxy.intersect(p + Vec3::Y * 5.0, -Vec3::Y, f32::MAX).expect("ground beside the statue").point;
    let uv = scene.camera.project_world(ground.as_dvec3()).expect("in view");
    (uv.x.round() as u32, uv.y.round() as u32)
}

/// Of the horizontal directions within 90° of `away`, the one closest to the sun `sun`'s
/// azimuth (ground there lies outside the statue's sun shadow when it can).
fn sunward(away: Vec3, sun: Vec3) -> Vec3 {
    let away = Vec3::new(away.x, 0.0, away.z).normalize();
    (-4..=4)
        .map(|k| glam::Quat::from_rotation_y(k as f32 * std::f32::consts::FRAC_PI_8) * away)
        .max_by(|a, b| a.dot(sun).total_cmp(&b.dot(sun)))
        .unwrap()
}

fn block_mean(img: &LinearImage, (x, y): (u32, u32)) -> f64 {
    let mut sum = 0.0;
    for dy in -1i64..=1 {
        for dx in -1i64..=1 {
            let (xx, yy) = ((x as i64 + dx) as u32, (y as i64 + dy) as u32);
            sum += lum(img.data[(yy * img.width + xx) as usize]);
        }
    }
    sum / 9.0
}

#[test]
fn a_moved_frame_takes_ambient_and_contact_shadow_from_the_cuts() {
    let moving = scratch_courtyard("cuts-moving");
    edit(&moving, "scale = 1.0\n", &format!("scale = 1.0\n{SLIDE_KEYS}\n"));
    let placed = scratch_courtyard("cuts-placed");
    edit(&placed, "translation = [-1.9, 0, 0]", "translation = [-1.2, 0, 0.6]");
    let still = scratch_courtyard("cuts-still");
    // The same motion without usable cuts (a file that is not a cuts file): the re-trace path.
    let retrace = scratch_courtyard("cuts-retrace");
    edit(&retrace, "scale = 1.0\n", &format!("scale = 1.0\n{SLIDE_KEYS}\n"));
    std::fs::create_dir_all(retrace.join("baked")).unwrap();
    std::fs::write(retrace.join("baked/cuts.bin"), b"not a cuts file").unwrap();
    let outs = std::env::temp_dir().join(format!("heliar-cuts-out-{}", std::process::id()));
    let (a, lines) = augment3(&moving, &outs.join("moving"));
    let (b, _) = augment3(&placed, &outs.join("placed"));
    let (c, _) = augment3(&still, &outs.join("still"));
    let (r, r_lines) = augment3(&retrace, &outs.join("retrace"));

    // Frames 0 and 1: nothing moved, the cuts did not serve; frame 2: the cuts pass ran.
    let passes = |i: usize| &lines[i]["passes"];
    let skipped = |i: usize, name: &str| passes(i)["skipped"].as_array().unwrap().iter().find(|s| s["pass"] == name).map(|s| s["reason"].as_str().unwrap().to_owned());
    assert!(skipped(1, "visibility_cuts").is_some_and(|r| r.contains("nothing moved")), "{}", passes(1));
    assert!(passes(2)["ran"].as_array().unwrap().iter().any(|p| p == "visibility_cuts"), "{}", passes(2));
    assert!(skipped(2, "object_transfer").is_some_and(|r| r.contains("visibility cuts")), "{}", passes(2));
    let cuts_ms = passes(2)["timings"]["cuts_ms"].as_f64().unwrap();
    let composite_ms = lines[2]["composite_ms"].as_f64().unwrap();
    let receivers_ms = passes(2)["timings"]["receivers_ms"].as_f64().unwrap();
    eprintln!("moved frame: composite {composite_ms:.0} ms, of which cuts {cuts_ms:.0} ms and receivers' c, b {receivers_ms:.0} ms");
    // The moved frame traces nothing: the receivers along the motion got `c`, `b` at set-up
    // and `c_v`, `b_v` come from the cuts; the objects' transfer is dropped, not re-traced.
    assert_eq!(passes(2)["receivers_computed"].as_u64(), Some(0), "{}", passes(2));
    assert_eq!(passes(2)["transfer_traced"].as_u64(), Some(0), "{}", passes(2));
    assert!(cuts_ms > 0.0);

    // Object pixels: the moved statue's ambient from the cuts against the traced transfer of
    // the statue placed there (the sun term, with the same shadow volumes, is common to both).
    let scene_b = Scene::load(&placed).unwrap();
    let pixels = object_pixels(&scene_b);
    assert!(pixels.len() > 500, "{} object pixels", pixels.len());
    let err = rel_rmse(&a[2], &b[2], &pixels);
    eprintln!("object pixels: {} ; relative RMSE of the cuts' frame against the re-traced one: {:.4}", pixels.len(), err);
    let r_skip = r_lines[2]["passes"]["skipped"].as_array().unwrap().iter().find(|s| s["pass"] == "visibility_cuts").cloned().unwrap();
    assert!(r_skip["reason"].as_str().unwrap().contains("cuts.bin") && r_skip["reason"].as_str().unwrap().contains("re-traced"), "{r_skip}");
    let r_err = rel_rmse(&r[2], &b[2], &pixels);
    let r_ms = r_lines[2]["composite_ms"].as_f64().unwrap();
    eprintln!("re-trace path: moved frame composite {r_ms:.0} ms; relative RMSE over the object pixels {r_err:.4}");
    assert!(err <= OBJECT_TOLERANCE, "relative RMSE {err:.4} over {} object pixels", pixels.len());

    // Contact shadow: ground beside the new place (toward the sun, so outside its sun shadow)
    // darkens against the static run, and ground beside the old place recovers; both close to
    // the re-traced placement's values.
    let sun = Vec3::from_array(serde_json::from_value(lines[2]["sun_dir"].clone()).unwrap());
    let (to_new, to_old) = (sunward(NEW_PLACE - OLD_PLACE, sun), sunward(OLD_PLACE - NEW_PLACE, sun));
    for margin in [0.1f32, 0.25] {
        let p_new = ground_pixel(&scene_b, NEW_PLACE, to_new, margin);
        let p_old = ground_pixel(&scene_b, OLD_PLACE, to_old, margin);
        let (an, bn, cn) = (block_mean(&a[2], p_new), block_mean(&b[2], p_new), block_mean(&c[2], p_new));
        let (ao, bo, co) = (block_mean(&a[2], p_old), block_mean(&b[2], p_old), block_mean(&c[2], p_old));
        eprintln!("margin {margin} m: new place {p_new:?}: cuts {an:.5}, re-traced {bn:.5}, static {cn:.5}; old place {p_old:?}: cuts {ao:.5}, re-traced {bo:.5}, static {co:.5}");
        assert!(an < cn && bn < cn, "the ground beside the new place must darken: cuts {an}, re-traced {bn}, before {cn}");
        assert!(ao > co, "the ground the statue left must recover: cuts {ao}, static {co}");
        // The cuts' darkening against the re-traced one.
        let (dark_cuts, dark_ref) = (cn - an, cn - bn);
        assert!((dark_cuts - dark_ref).abs() <= CONTACT_TOLERANCE * dark_ref.max(1e-9), "darkening {dark_cuts} against the re-traced {dark_ref}");
        assert!((ao - bo).abs() <= 0.01 * bo, "the recovered ground {ao} against the re-traced {bo}");
    }
    for d in [&moving, &placed, &still, &retrace, &outs] {
        std::fs::remove_dir_all(d).ok();
    }
}

/// Relative RMSE allowed over the statue's pixels (set from the first measurement; see
/// docs/measurements.md, "Moving objects").
const OBJECT_TOLERANCE: f64 = 0.05;
/// Relative error allowed on a contact shadow's darkening.
const CONTACT_TOLERANCE: f64 = 0.5;
