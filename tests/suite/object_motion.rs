//! Virtual objects that move (issue 15 §1): keyframes and glTF node animations in the scene
//! format against closed forms, their bad input, and the frame loop and `heliar precompute`
//! with a moving object.

use crate::common::*;
use glam::{Mat4, Quat, Vec3};
use heliar::scene::Scene;
use std::path::Path;

/// Tolerance of poses computed in f32 over metre-sized scenes: a few ulps of 10 m.
const POSE_TOL: f32 = 1e-5;

fn edit(dir: &Path, from: &str, to: &str) {
    let p = dir.join("scene.toml");
    let s = std::fs::read_to_string(&p).unwrap();
    assert!(s.contains(from), "scene.toml has no '{from}'");
    std::fs::write(&p, s.replacen(from, to, 1)).unwrap();
}

/// The courtyard's statue with `motion` (TOML lines after `[virtual_objects.motion]` or its
/// keyframe tables) appended to its `[[virtual_objects]]` table.
fn with_motion(name: &str, motion: &str) -> std::path::PathBuf {
    let d = scratch_courtyard(name);
    edit(&d, "scale = 1.0\n", &format!("scale = 1.0\n{motion}\n"));
    d
}

fn load_err(d: &Path) -> String {
    let e = Scene::load(d).expect_err("must be rejected").to_string();
    std::fs::remove_dir_all(d).ok();
    e
}

const TWO_KEYS: &str = "[[virtual_objects.motion.keyframes]]\ntime = 0.0\ntranslation = [-1.9, 0, 0]\nrotation_y_deg = 0\n\
                        [[virtual_objects.motion.keyframes]]\ntime = 20.0\ntranslation = [0.1, 0, 1.0]\nrotation_y_deg = 90\n";

#[test]
fn keyframes_interpolate_to_closed_forms() {
    let d = with_motion("motion-keys", TWO_KEYS);
    let scene = Scene::load(&d).unwrap();
    let obj = &scene.virtual_objects[0];
    let m = &obj.motion.as_ref().expect("a motion").motion;
    // Midpoint of a straight move, and half of a 90° turn by slerp.
    let (t, r) = m.translation_rotation_at(10.0);
    assert!((t - Vec3::new(-0.9, 0.0, 0.5)).length() < POSE_TOL, "{t}");
    assert!((r.angle_between(Quat::IDENTITY).to_degrees() - 45.0).abs() < 1e-3);
    // A quarter of the way: slerp at s = 1/4 turns 22.5° about +y exactly.
    let (_, r) = m.translation_rotation_at(5.0);
    assert!((r.angle_between(Quat::from_rotation_y(22.5f32.to_radians()))).abs() < 1e-4);
    // The keys hold outside their span, and the loaded mesh stands at the first key.
    assert_eq!(m.translation_rotation_at(-3.0).0, Vec3::new(-1.9, 0.0, 0.0));
    assert_eq!(m.translation_rotation_at(99.0).0, Vec3::new(0.1, 0.0, 1.0));
    let rest = &obj.motion.as_ref().unwrap().rest;
    for (p, q) in obj.mesh.positions.iter().zip(&rest.positions) {
        assert!((*p - (*q + Vec3::new(-1.9, 0.0, 0.0))).length() < POSE_TOL);
    }
    std::fs::remove_dir_all(&d).ok();
}

#[test]
fn rfc3339_keyframes_count_from_the_first_key() {
    let keys = "[[virtual_objects.motion.keyframes]]\ntime = \"2024-06-21T15:30:10+02:00\"\ntranslation = [0, 0, 0]\n\
                [[virtual_objects.motion.keyframes]]\ntime = 2024-06-21T15:30:30+02:00\ntranslation = [2, 0, 0]\n";
    let d = with_motion("motion-rfc", keys);
    let scene = Scene::load(&d).unwrap();
    let m = &scene.virtual_objects[0].motion.as_ref().unwrap().motion;
    let start = t("2024-06-21T15:30:00+02:00");
    // Frame at 15:30:20 is 10 s after the first key: halfway.
    let secs = m.seconds_at(&t("2024-06-21T15:30:20+02:00"), &start);
    assert!((secs - 10.0).abs() < 1e-9);
    assert!((m.translation_rotation_at(secs).0 - Vec3::new(1.0, 0.0, 0.0)).length() < POSE_TOL);
    std::fs::remove_dir_all(&d).ok();
}

/// A glTF with two nodes (`mover`, `other`) and one animation whose channels are `channels`
/// (JSON), over a buffer of key times [0, 4] s, translations [0,0,0] → [2,0,0], rotations
/// identity → 90° about +y, and scales 1 → 2.
fn write_anim_gltf(dir: &Path, channels: &str, samplers_interp: &str) {
    let mut bin = Vec::new();
    let f = |bin: &mut Vec<u8>, v: &[f32]| v.iter().for_each(|x| bin.extend(x.to_le_bytes()));
    f(&mut bin, &[0.0, 4.0]);
    f(&mut bin, &[0.0, 0.0, 0.0, 2.0, 0.0, 0.0]);
    let h = std::f32::consts::FRAC_1_SQRT_2;
    f(&mut bin, &[0.0, 0.0, 0.0, 1.0, 0.0, h, 0.0, h]);
    f(&mut bin, &[1.0, 1.0, 1.0, 2.0, 2.0, 2.0]);
    std::fs::write(dir.join("objects/anim.bin"), &bin).unwrap();
    let json = format!(
        r#"{{"asset":{{"version":"2.0"}},"scene":0,"scenes":[{{"nodes":[0,1]}}],
        "nodes":[{{"name":"mover"}},{{"name":"other","translation":[0,1,0]}}],
        "buffers":[{{"uri":"anim.bin","byteLength":{}}}],
        "bufferViews":[{{"buffer":0,"byteOffset":0,"byteLength":8}},{{"buffer":0,"byteOffset":8,"byteLength":24}},
                       {{"buffer":0,"byteOffset":32,"byteLength":32}},{{"buffer":0,"byteOffset":64,"byteLength":24}}],
        "accessors":[{{"bufferView":0,"componentType":5126,"count":2,"type":"SCALAR","min":[0],"max":[4]}},
                     {{"bufferView":1,"componentType":5126,"count":2,"type":"VEC3"}},
                     {{"bufferView":2,"componentType":5126,"count":2,"type":"VEC4"}},
                     {{"bufferView":3,"componentType":5126,"count":2,"type":"VEC3"}}],
        "animations":[{{"name":"drive","channels":[{channels}],
          "samplers":[{{"input":0,"output":1{samplers_interp}}},{{"input":0,"output":2}},{{"input":0,"output":3}}]}}]}}"#,
        bin.len()
    );
    std::fs::write(dir.join("objects/anim.gltf"), json).unwrap();
}

const TR_CHANNELS: &str = r#"{"sampler":0,"target":{"node":0,"path":"translation"}},{"sampler":1,"target":{"node":0,"path":"rotation"}}"#;

#[test]
fn gltf_node_animation_is_read_and_placed_by_the_manifest() {
    let d = with_motion("motion-gltf", "[virtual_objects.motion]\ngltf = \"objects/anim.gltf\"\n");
    write_anim_gltf(&d, TR_CHANNELS, "");
    let scene = Scene::load(&d).unwrap();
    let m = &scene.virtual_objects[0].motion.as_ref().unwrap().motion;
    // The manifest's placement P = T(-1.9, 0, 0)·R_y(25°) (scale 1), then the node's motion.
    let p = Mat4::from_rotation_translation(Quat::from_rotation_y(25f32.to_radians()), Vec3::new(-1.9, 0.0, 0.0));
    let mid = p * Mat4::from_rotation_translation(Quat::from_rotation_y(45f32.to_radians()), Vec3::new(1.0, 0.0, 0.0));
    assert!(m.world_from_rest(2.0).abs_diff_eq(mid, POSE_TOL), "{:?}", m.world_from_rest(2.0));
    // At the first key the object stands exactly where the manifest alone puts it.
    let still = Scene::load(&with_motion("motion-gltf-still", "")).unwrap();
    for (a, b) in scene.virtual_objects[0].mesh.positions.iter().zip(&still.virtual_objects[0].mesh.positions) {
        assert!((*a - *b).length() < POSE_TOL);
    }
    std::fs::remove_dir_all(&d).ok();
    std::fs::remove_dir_all(&still.root).ok();
}

#[test]
fn bad_keyframes_name_the_file_and_field() {
    let e = load_err(&with_motion("motion-empty", "[virtual_objects.motion]\n"));
    assert!(e.contains("scene.toml") && e.contains("virtual_objects[0].motion.keyframes") && e.contains("no keyframes"), "{e}");
    let back = TWO_KEYS.replace("time = 20.0", "time = 0.0");
    let e = load_err(&with_motion("motion-order", &back));
    assert!(e.contains("virtual_objects[0].motion.keyframes[1].time") && e.contains("increase"), "{e}");
    let nan = TWO_KEYS.replace("translation = [0.1, 0, 1.0]", "translation = [nan, 0, 1.0]");
    let e = load_err(&with_motion("motion-nan", &nan));
    assert!(e.contains("virtual_objects[0].motion.keyframes[1].translation") && e.contains("finite"), "{e}");
    let mixed = TWO_KEYS.replace("time = 20.0", "time = \"2024-06-21T15:30:30+02:00\"");
    let e = load_err(&with_motion("motion-mixed", &mixed));
    assert!(e.contains("keyframes[1].time") && e.contains("one kind"), "{e}");
}

#[test]
fn bad_gltf_animations_name_the_file_and_channel() {
    let case = |name: &str, channels: &str, extra: &str, interp: &str| {
        let d = with_motion(name, &format!("[virtual_objects.motion]\ngltf = \"objects/anim.gltf\"\n{extra}"));
        write_anim_gltf(&d, channels, interp);
        load_err(&d)
    };
    let e = case("anim-none", "", "", "");
    assert!(e.contains("anim.gltf") && e.contains("no channels, so no keyframes"), "{e}");
    let scale = r#"{"sampler":2,"target":{"node":0,"path":"scale"}}"#;
    let e = case("anim-scale", scale, "", "");
    assert!(e.contains("anim.gltf") && e.contains("channels[0]") && e.contains("only translation and rotation"), "{e}");
    let e = case("anim-other", TR_CHANNELS, "node = \"other\"\n", "");
    assert!(e.contains("anim.gltf") && e.contains("no translation or rotation channel targets node 'other'"), "{e}");
    let e = case("anim-step", TR_CHANNELS, "", r#","interpolation":"STEP""#);
    assert!(e.contains("anim.gltf") && e.contains("channels[0]") && e.contains("LINEAR"), "{e}");
    let e = case("anim-name", TR_CHANNELS, "animation = \"fly\"\n", "");
    assert!(e.contains("anim.gltf") && e.contains("no animation named 'fly'"), "{e}");
}

#[test]
fn a_mesh_with_no_vertices_is_refused() {
    // A moving object whose glTF holds no triangles: the loader names the file.
    let d = with_motion("motion-novert", TWO_KEYS);
    std::fs::write(d.join("objects/statue.glb"), "").unwrap();
    std::fs::write(d.join("objects/empty.gltf"), r#"{"asset":{"version":"2.0"},"scene":0,"scenes":[{"nodes":[0]}],"nodes":[{"name":"n"}]}"#).unwrap();
    edit(&d, "objects/statue.glb", "objects/empty.gltf");
    let e = load_err(&d);
    assert!(e.contains("empty.gltf") && e.contains("no triangles"), "{e}");
    // And the cuts refuse an empty mesh by name.
    let e = heliar::cuts::svc::check_mesh("robot", &heliar::geometry::Mesh::default()).unwrap_err().to_string();
    assert!(e.contains("robot"), "{e}");
}

/// `heliar precompute ARGS`: (success, the JSON summary line, stderr).
fn precompute_cli(args: &[&str]) -> (bool, serde_json::Value, String) {
    let out = std::process::Command::new(env!("CARGO_BIN_EXE_heliar")).arg("precompute").args(args).output().unwrap();
    let stdout = String::from_utf8_lossy(&out.stdout);
    let json = stdout.lines().last().and_then(|l| serde_json::from_str(l).ok()).unwrap_or(serde_json::Value::Null);
    (out.status.success(), json, String::from_utf8_lossy(&out.stderr).into_owned())
}

/// Small cut settings so the test traces in seconds: S = 2^6, 2 spheres × 4², a 3 m proxy grid.
const SMALL: [&str; 6] = ["--levels", "6", "--vcf", "2x4x4", "--proxy-spacing", "3"];

#[test]
fn precompute_skips_a_static_scene_and_caches_a_moving_one() {
    let still = scratch_courtyard("precompute-still");
    let (ok, json, err) = precompute_cli(&[s(&still), SMALL[0], SMALL[1]]);
    assert!(ok, "{err}");
    assert!(json["skipped"].as_str().is_some_and(|r| r.contains("no virtual object") && r.contains("scene.toml")), "{json}");
    assert!(!still.join("baked/cuts.bin").exists());
    std::fs::remove_dir_all(&still).ok();

    let d = with_motion("precompute-moving", TWO_KEYS);
    let mut args = vec![s(&d)];
    args.extend(SMALL);
    let (ok, first, err) = precompute_cli(&args);
    assert!(ok, "{err}");
    assert_eq!(first["cached"], false, "{first}");
    assert_eq!((first["objects"].as_u64(), first["moving"].as_u64()), (Some(1), Some(1)));
    // The proxy grid over the courtyard's [irradiance] box −6..6 × 0.1..3 × −6..6 at 3 m: 5×2×5.
    assert_eq!(first["proxy_points"].as_u64(), Some(50), "{first}");
    let file = d.join("baked/cuts.bin");
    let cuts = heliar::cuts::file::read(&file).unwrap();
    assert_eq!(cuts.objects.len(), 1);
    assert_eq!(cuts.objects[0].svc.cuts.len(), first["vertices"].as_u64().unwrap() as usize);
    // No temporary file is left beside it.
    let names: Vec<String> = std::fs::read_dir(d.join("baked")).unwrap().flatten().map(|e| e.file_name().to_string_lossy().into_owned()).collect();
    assert_eq!(names, vec!["cuts.bin".to_owned()]);
    let stamp = std::fs::metadata(&file).unwrap().modified().unwrap();
    let (ok, second, err) = precompute_cli(&args);
    assert!(ok, "{err}");
    assert_eq!(second["cached"], true, "{second}");
    assert_eq!(second["inputs_hash"], first["inputs_hash"]);
    assert_eq!(std::fs::metadata(&file).unwrap().modified().unwrap(), stamp, "a cache hit must not rewrite the file");
    // A changed setting is a miss.
    let (_, third, _) = precompute_cli(&[s(&d), "--levels", "5", "--vcf", "2x4x4", "--proxy-spacing", "3"]);
    assert_eq!(third["cached"], false, "{third}");
    std::fs::remove_dir_all(&d).ok();
}

/// Keys at 10 s spacing (the courtyard's frames): still for two frames at the manifest's
/// placement, then a move and a turn inside the box, then out of the box (x = 9 m > max 6 m).
const AUGMENT_KEYS: &str = "[[virtual_objects.motion.keyframes]]\ntime = 0.0\ntranslation = [-1.9, 0, 0]\nrotation_y_deg = 25\n\
                            [[virtual_objects.motion.keyframes]]\ntime = 10.0\ntranslation = [-1.9, 0, 0]\nrotation_y_deg = 25\n\
                            [[virtual_objects.motion.keyframes]]\ntime = 20.0\ntranslation = [-1.2, 0, 0.6]\nrotation_y_deg = 60\n\
                            [[virtual_objects.motion.keyframes]]\ntime = 30.0\ntranslation = [9.0, 0, 0]\nrotation_y_deg = 60\n";

/// `heliar augment` of the courtyard's first `frames` HDR frames into `out` (EXR); stderr.
fn augment(scene: &Path, out: &Path, frames: &str) -> String {
    let input = Path::new(env!("CARGO_MANIFEST_DIR")).join("scenes/courtyard/frames/hdr");
    let o = std::process::Command::new(env!("CARGO_BIN_EXE_heliar"))
        .args(["augment", s(scene), "--input", s(&input), "--output", s(out), "--format", "exr"])
        .args(["--start", "2024-06-21T15:30:00+02:00", "--fps", "0.1", "--max-frames", frames])
        .output()
        .unwrap();
    let err = String::from_utf8_lossy(&o.stderr).into_owned();
    assert!(o.status.success(), "{err}");
    err
}

fn exr_frames(dir: &Path) -> Vec<Vec<u8>> {
    let mut names: Vec<_> = std::fs::read_dir(dir).unwrap().flatten().map(|e| e.path()).filter(|p| p.extension().is_some_and(|x| x == "exr")).collect();
    names.sort();
    names.iter().map(|p| std::fs::read(p).unwrap()).collect()
}

#[test]
fn augment_follows_the_motion_and_keeps_static_frames() {
    let still = scratch_courtyard("augment-still");
    let moving = with_motion("augment-moving", AUGMENT_KEYS);
    let outs = std::env::temp_dir().join(format!("heliar-augment-motion-out-{}", std::process::id()));
    let (out_still, out_moving) = (outs.join("still"), outs.join("moving"));
    augment(&still, &out_still, "3");
    let err = augment(&moving, &out_moving, "4");
    let (a, b) = (exr_frames(&out_still), exr_frames(&out_moving));
    assert_eq!((a.len(), b.len()), (3, 4));
    // The object stands at the manifest's placement for frames 0 and 1: bit for bit the static
    // run's frames. Frame 2 has it moved and turned.
    assert!(a[0] == b[0] && a[1] == b[1], "frames where nothing moved must equal the static run's");
    assert!(a[2] != b[2], "the moved object must change frame 2");
    let report = std::fs::read_to_string(out_moving.join("report.jsonl")).unwrap();
    let lines: Vec<serde_json::Value> = report.lines().map(|l| serde_json::from_str(l).unwrap()).collect();
    let moved = |i: usize| lines[i]["passes"]["moved"].as_array().map(|v| v.iter().map(|x| x.as_str().unwrap().to_owned()).collect::<Vec<_>>()).unwrap_or_default();
    assert!(moved(0).is_empty() && moved(1).is_empty(), "{}", lines[1]["passes"]);
    assert_eq!(moved(2), vec!["statue.glb".to_owned()]);
    assert_eq!(moved(3), vec!["statue.glb".to_owned()]);
    let skipped = lines[1]["passes"]["skipped"].as_array().unwrap();
    assert!(skipped.iter().any(|s| s["pass"] == "object_motion" && s["reason"].as_str().unwrap().contains("statue.glb: it has not moved")), "{skipped:?}");
    // The moved frames fall back from the stale transfer, and say so.
    let transfer = lines[2]["passes"]["skipped"].as_array().unwrap().iter().find(|s| s["pass"] == "object_transfer").cloned();
    assert!(transfer.is_some_and(|s| s["reason"].as_str().unwrap().contains("an object moved")), "{}", lines[2]["passes"]);
    // Frame 3 leaves the irradiance box: one warning, in the report and on stderr; the frame is
    // finite everywhere (the probe lookups clamp).
    assert!(lines[3]["passes"]["warnings"][0].as_str().is_some_and(|w| w.contains("leaves the irradiance-volume box")), "{}", lines[3]["passes"]);
    assert_eq!(err.matches("leaves the irradiance-volume box").count(), 1, "{err}");
    let last = std::fs::read_dir(&out_moving).unwrap().flatten().map(|e| e.path()).filter(|p| p.extension().is_some_and(|x| x == "exr")).max().unwrap();
    let img = heliar::io::image::LinearImage::read_exr(&last).unwrap();
    assert!(img.data.iter().flatten().all(|v| v.is_finite()), "a non-finite pixel in {}", last.display());
    for d in [&still, &moving, &outs] {
        std::fs::remove_dir_all(d).ok();
    }
}

#[test]
fn a_held_pose_is_exact_so_the_object_does_not_count_as_moved() {
    use heliar::scene::motion::{Track, slerp_rotation};
    let (a, b) = (Quat::from_rotation_y(25f32.to_radians()), Quat::from_rotation_y(60f32.to_radians()));
    let track = Track { times: vec![0.0, 10.0, 20.0], values: vec![a, a, b] };
    // Between two equal keys and on a key: the key's value bit for bit (slerp is not exact).
    assert_eq!(track.sample(4.2, slerp_rotation), a);
    assert_eq!(track.sample(10.0, slerp_rotation), a);
    assert_eq!(track.sample(20.0, slerp_rotation), b);
    // Halfway between the turns: 42.5° about +y.
    assert!(track.sample(15.0, slerp_rotation).angle_between(Quat::from_rotation_y(42.5f32.to_radians())) < 1e-4);
}
