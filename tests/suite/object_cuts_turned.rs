//! The visibility cuts for a turned object (issue 15 §1, "a turning sign"; `heliar::cuts::rotate`):
//! a frame where the courtyard's statue moved *and turned* about the vertical takes its ambient
//! and the ground's contact shadow from the cuts, nothing traced, and is checked against the
//! re-traced path: the same scene with the statue placed and turned there from the start
//! (per-pixel transfer and `c_v`, `b_v` traced there), as `object_cuts` does for translation.

use crate::common::*;
use crate::object_cuts::{augment3, block, edit, lum, object_hits, object_pixels, rel_rmse};
use heliar::io::image::LinearImage;
use heliar::scene::Scene;

/// Still for two frames at the manifest's placement (25°), then moved 0.7 m along x and 0.6 m
/// along z and turned by `turn` degrees about the vertical (frames 10 s apart).
fn turn_keys(turn: f64) -> String {
    format!(
        "[[virtual_objects.motion.keyframes]]\ntime = 0.0\ntranslation = [-1.9, 0, 0]\nrotation_y_deg = 25\n\
         [[virtual_objects.motion.keyframes]]\ntime = 10.0\ntranslation = [-1.9, 0, 0]\nrotation_y_deg = 25\n\
         [[virtual_objects.motion.keyframes]]\ntime = 20.0\ntranslation = [-1.2, 0, 0.6]\nrotation_y_deg = {}\n",
        25.0 + turn
    )
}

const STATUE: &str = "[[virtual_objects]]\nfile = \"objects/statue.glb\"\ntranslation = [-1.9, 0, 0]\nrotation_y_deg = 25\nscale = 1.0\n";

/// Errors of the turned frame against the placed-and-turned reference: (object pixels, contact
/// region, contact pixels, the cuts frame's composite ms).
fn turned_errors(turn: f64, bare: &[LinearImage], outs: &std::path::Path) -> (f64, f64, usize, f64) {
    let tag = format!("turn{}", turn as i64);
    let moving = scratch_courtyard(&format!("cuts-{tag}-moving"));
    edit(&moving, "scale = 1.0\n", &format!("scale = 1.0\n{}\n", turn_keys(turn)));
    let placed = scratch_courtyard(&format!("cuts-{tag}-placed"));
    edit(&placed, "translation = [-1.9, 0, 0]\nrotation_y_deg = 25", &format!("translation = [-1.2, 0, 0.6]\nrotation_y_deg = {}", 25.0 + turn));
    let (a, lines) = augment3(&moving, &outs.join(format!("{tag}-moving")));
    let (b, _) = augment3(&placed, &outs.join(format!("{tag}-placed")));
    let passes = &lines[2]["passes"];
    // The turned frame ran the cuts and traced nothing: the receivers along the motion (turned
    // poses included) got `c`, `b` at set-up, the objects' transfer is dropped, not re-traced.
    assert!(passes["ran"].as_array().unwrap().iter().any(|p| p == "visibility_cuts"), "{turn}°: {passes}");
    assert_eq!(passes["receivers_computed"].as_u64(), Some(0), "{turn}°: {passes}");
    assert_eq!(passes["transfer_traced"].as_u64(), Some(0), "{turn}°: {passes}");
    let scene_b = Scene::load(&placed).unwrap();
    let pixels = object_pixels(&scene_b);
    assert!(pixels.len() > 300, "{} object pixels", pixels.len());
    let err = rel_rmse(&a[2], &b[2], &pixels);
    let w = scene_b.camera.intrinsics.width;
    let objects_b = block(&object_hits(&scene_b), w, false);
    let darker = |img: &LinearImage, i: usize| 1.0 - lum(img.data[i]) / lum(bare[2].data[i]).max(1e-9);
    let contact: Vec<usize> = (0..bare[2].data.len()).filter(|&i| !objects_b[i] && darker(&b[2], i) > 0.01).collect();
    let contact_err = rel_rmse(&a[2], &b[2], &contact);
    let mean = |img: &LinearImage| contact.iter().map(|&i| darker(img, i)).sum::<f64>() / contact.len().max(1) as f64;
    let (cuts_ms, composite_ms) = (passes["timings"]["cuts_ms"].as_f64().unwrap(), lines[2]["composite_ms"].as_f64().unwrap());
    eprintln!(
        "turned {turn}°: object pixels {} relative RMSE {err:.4}; contact region {} pixels, mean darkening cuts {:.4} re-traced {:.4}, relative RMSE {contact_err:.4}; composite {composite_ms:.0} ms of which cuts {cuts_ms:.0} ms",
        pixels.len(),
        contact.len(),
        mean(&a[2]),
        mean(&b[2])
    );
    assert!(mean(&a[2]) > 0.5 * mean(&b[2]), "{turn}°: the ground under the new place must darken");
    for d in [&moving, &placed] {
        std::fs::remove_dir_all(d).ok();
    }
    (err, contact_err, contact.len(), composite_ms)
}

#[test]
fn a_turned_frame_takes_ambient_and_contact_shadow_from_the_cuts() {
    let outs = std::env::temp_dir().join(format!("heliar-cuts-turned-out-{}", std::process::id()));
    let bare = scratch_courtyard("cuts-turned-bare");
    edit(&bare, STATUE, "");
    let (n, _) = augment3(&bare, &outs.join("bare"));
    // The re-trace path for the same 90° turn (a file that is not a cuts file), for its time.
    let retrace = scratch_courtyard("cuts-turned-retrace");
    edit(&retrace, "scale = 1.0\n", &format!("scale = 1.0\n{}\n", turn_keys(90.0)));
    std::fs::create_dir_all(retrace.join("baked")).unwrap();
    std::fs::write(retrace.join("baked/cuts.bin"), b"not a cuts file").unwrap();
    let (_, r_lines) = augment3(&retrace, &outs.join("retrace"));
    let r_ms = r_lines[2]["composite_ms"].as_f64().unwrap();
    eprintln!("re-trace path, turned 90°: composite {r_ms:.0} ms, receivers computed {}", r_lines[2]["passes"]["receivers_computed"]);
    for turn in [90.0, 37.0] {
        let (err, contact_err, contact, _ms) = turned_errors(turn, &n, &outs);
        assert!(contact > 100, "{turn}°: {contact} contact pixels");
        assert!(err <= OBJECT_TOLERANCE, "{turn}°: relative RMSE {err:.4} over the object pixels");
        assert!(contact_err <= CONTACT_TOLERANCE, "{turn}°: relative RMSE {contact_err:.4} over the contact region");
    }
    for d in [&bare, &retrace, &outs] {
        std::fs::remove_dir_all(d).ok();
    }
}

/// Relative RMSE allowed over the statue's pixels against the traced transfer of the statue
/// placed and turned there: issue 15 §3's 5%, as for translation (`object_cuts`). Measured 2.4%
/// at 90° and 3.0% at 37° with the statue's light on itself and the split edges (4.9% and 4.4%
/// before them).
const OBJECT_TOLERANCE: f64 = 0.05;
/// Relative RMSE allowed over the contact region (issue 15 §3 asks ≤ 8%). Measured 6.3% at 90°,
/// 6.9% at 37° (translation alone: 6.2%) with `c·V`, `b·V`; 1.94% and 2.40% with the receivers'
/// own light by direction, the statue's reflected light and its near field traced
/// (`cuts::receiver_light`; the receivers' light is traced in the turned statue's frame). Times
/// on the same run (2 shared cores, debug build with optimisation): the turned frame composites
/// in 620–710 ms, of which the cuts 520–630 ms; the re-trace path's turned frame in 2.4–3.0 s.
const CONTACT_TOLERANCE: f64 = 0.04;
