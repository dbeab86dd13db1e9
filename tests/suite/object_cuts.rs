//! The visibility cuts per frame (issue 15 §2): a frame where the courtyard's statue moved by
//! translation takes its ambient and the ground's contact shadow from the cuts, and is checked
//! against the re-traced path: the same scene with the statue placed at the new spot from the
//! start (per-pixel transfer and `c_v`, `b_v` traced there).

use crate::common::*;
use heliar::geometry::raycast::RayScene;
use heliar::io::image::LinearImage;
use heliar::scene::Scene;
use std::path::{Path, PathBuf};

/// Still for two frames at the manifest's placement, then moved 0.7 m along x and 0.6 m along z
/// without turning (the courtyard's frames are 10 s apart).
const SLIDE_KEYS: &str = "[[virtual_objects.motion.keyframes]]\ntime = 0.0\ntranslation = [-1.9, 0, 0]\nrotation_y_deg = 25\n\
                          [[virtual_objects.motion.keyframes]]\ntime = 10.0\ntranslation = [-1.9, 0, 0]\nrotation_y_deg = 25\n\
                          [[virtual_objects.motion.keyframes]]\ntime = 20.0\ntranslation = [-1.2, 0, 0.6]\nrotation_y_deg = 25\n";

pub(crate) fn edit(dir: &Path, from: &str, to: &str) {
    let p = dir.join("scene.toml");
    let s = std::fs::read_to_string(&p).unwrap();
    assert!(s.contains(from), "scene.toml has no '{from}'");
    std::fs::write(&p, s.replacen(from, to, 1)).unwrap();
}

/// `heliar augment` of the courtyard's first three HDR frames of `scene` into `out`; the frames
/// and the report's lines.
pub(crate) fn augment3(scene: &Path, out: &Path) -> (Vec<LinearImage>, Vec<serde_json::Value>) {
    augment3_with(scene, out, &[])
}

/// [`augment3`] with further `heliar augment` arguments.
pub(crate) fn augment3_with(scene: &Path, out: &Path, extra: &[&str]) -> (Vec<LinearImage>, Vec<serde_json::Value>) {
    let input = Path::new(env!("CARGO_MANIFEST_DIR")).join("scenes/courtyard/frames/hdr");
    let o = std::process::Command::new(env!("CARGO_BIN_EXE_heliar"))
        .args(["augment", s(scene), "--input", s(&input), "--output", s(out), "--format", "exr"])
        .args(["--start", "2024-06-21T15:30:00+02:00", "--fps", "0.1", "--max-frames", "3"])
        .args(extra)
        .output()
        .unwrap();
    assert!(o.status.success(), "{}", String::from_utf8_lossy(&o.stderr));
    let mut names: Vec<PathBuf> = std::fs::read_dir(out).unwrap().flatten().map(|e| e.path()).filter(|p| p.extension().is_some_and(|x| x == "exr")).collect();
    names.sort();
    let frames = names.iter().map(|p| LinearImage::read_exr(p).unwrap()).collect();
    let report = std::fs::read_to_string(out.join("report.jsonl")).unwrap();
    (frames, report.lines().map(|l| serde_json::from_str(l).unwrap()).collect())
}

pub(crate) fn lum(p: [f32; 3]) -> f64 {
    (0.2126 * p[0] + 0.7152 * p[1] + 0.0722 * p[2]) as f64
}

/// Per footage pixel: its centre ray meets one of the virtual objects of `scene` (at their
/// placements) before the proxy.
pub(crate) fn object_hits(scene: &Scene) -> Vec<bool> {
    let k = &scene.camera.intrinsics;
    let (w, h) = (k.width, k.height);
    let objects: Vec<RayScene> = scene.virtual_objects.iter().map(|v| RayScene::new(v.mesh.clone())).collect();
    let proxy = RayScene::new(scene.proxy.clone());
    (0..w * h)
        .map(|i| {
            let Some((o, d)) = scene.camera.pixel_ray(i % w, i / w) else { return false };
            let (o, d) = (o.as_vec3(), d.as_vec3());
            let nearest = objects.iter().filter_map(|s| s.intersect(o, d, f32::MAX)).map(|a| a.t).fold(f32::INFINITY, f32::min);
            nearest.is_finite() && proxy.intersect(o, d, f32::MAX).is_none_or(|b| nearest < b.t)
        })
        .collect()
}

/// Pixels where `hit` holds for all (`all`) or any (`!all`) of the 5×5 block around them: the
/// statue's interior (silhouette pixels mix in the footage), or the statue grown by 2 pixels.
pub(crate) fn block(hit: &[bool], w: u32, all: bool) -> Vec<bool> {
    let h = hit.len() as i64 / w as i64;
    let at = |x: i64, y: i64| x >= 0 && y >= 0 && x < w as i64 && y < h && hit[(y * w as i64 + x) as usize];
    (0..hit.len() as i64)
        .map(|i| {
            let (x, y) = (i % w as i64, i / w as i64);
            let mut cells = (-2..=2).flat_map(|dy| (-2..=2).map(move |dx| (dx, dy)));
            if all { cells.all(|(dx, dy)| at(x + dx, y + dy)) } else { cells.any(|(dx, dy)| at(x + dx, y + dy)) }
        })
        .collect()
}

/// The statue's interior pixels.
pub(crate) fn object_pixels(scene: &Scene) -> Vec<usize> {
    let w = scene.camera.intrinsics.width;
    block(&object_hits(scene), w, true).iter().enumerate().filter(|(_, h)| **h).map(|(i, _)| i).collect()
}

/// Relative RMSE of `a` against `reference` over `pixels` (luminance).
pub(crate) fn rel_rmse(a: &LinearImage, reference: &LinearImage, pixels: &[usize]) -> f64 {
    let (mut num, mut den) = (0.0, 0.0);
    for &i in pixels {
        let (x, r) = (lum(a.data[i]), lum(reference.data[i]));
        num += (x - r) * (x - r);
        den += r * r;
    }
    (num / den.max(1e-30)).sqrt()
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
    let bare = scratch_courtyard("cuts-bare");
    edit(&bare, "[[virtual_objects]]\nfile = \"objects/statue.glb\"\ntranslation = [-1.9, 0, 0]\nrotation_y_deg = 25\nscale = 1.0\n", "");
    let (n, _) = augment3(&bare, &outs.join("bare"));

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
    assert!(pixels.len() > 300, "{} object pixels", pixels.len());
    let err = rel_rmse(&a[2], &b[2], &pixels);
    eprintln!("object pixels: {} ; relative RMSE of the cuts' frame against the re-traced one: {:.4}", pixels.len(), err);
    let r_skip = r_lines[2]["passes"]["skipped"].as_array().unwrap().iter().find(|s| s["pass"] == "visibility_cuts").cloned().unwrap();
    assert!(r_skip["reason"].as_str().unwrap().contains("cuts.bin") && r_skip["reason"].as_str().unwrap().contains("re-traced"), "{r_skip}");
    let r_err = rel_rmse(&r[2], &b[2], &pixels);
    let r_ms = r_lines[2]["composite_ms"].as_f64().unwrap();
    eprintln!("re-trace path: moved frame composite {r_ms:.0} ms; relative RMSE over the object pixels {r_err:.4}");
    assert!(err <= OBJECT_TOLERANCE, "relative RMSE {err:.4} over {} object pixels", pixels.len());

    // Contact shadow, against a run with no statue (the footage where nothing darkens it):
    // the region the re-traced placement darkens by more than 1% (its contact and sun shadow,
    // the statue's own pixels grown by 2 px left out) darkens with the cuts too, within
    // CONTACT_TOLERANCE; where the statue stood before (the still run darkens it by more than 1%,
    // the new place by less than 0.2%) the numbers are printed (see below).
    let w = scene_b.camera.intrinsics.width;
    let objects_b = block(&object_hits(&scene_b), w, false);
    let objects_c = block(&object_hits(&Scene::load(&still).unwrap()), w, false);
    let darker = |img: &LinearImage, i: usize| 1.0 - lum(img.data[i]) / lum(n[2].data[i]).max(1e-9);
    let contact: Vec<usize> = (0..n[2].data.len()).filter(|&i| !objects_b[i] && !objects_c[i] && darker(&b[2], i) > 0.01).collect();
    // Ground more than 1.5 m from the new place (beyond it the coarse field of the frame loop,
    // 8 spheres × 16², no longer blurs the new place's occlusion outward; see the medians below).
    let proxy = RayScene::new(scene_b.proxy.clone());
    let new_place = glam::Vec3::new(-1.2, 0.0, 0.6);
    let far_from_new = |i: usize| {
        let Some((o, d)) = scene_b.camera.pixel_ray(i as u32 % w, i as u32 / w) else { return false };
        proxy.intersect(o.as_vec3(), d.as_vec3(), f32::MAX).is_some_and(|h| (h.point - new_place).with_y(0.0).length() > 1.5)
    };
    let left: Vec<usize> = (0..n[2].data.len()).filter(|&i| !objects_b[i] && !objects_c[i] && darker(&c[2], i) > 0.01 && darker(&b[2], i).abs() < 0.002 && far_from_new(i)).collect();
    let mean = |img: &LinearImage, px: &[usize]| px.iter().map(|&i| darker(img, i)).sum::<f64>() / px.len().max(1) as f64;
    let contact_err = rel_rmse(&a[2], &b[2], &contact);
    eprintln!(
        "contact region: {} pixels, mean darkening cuts {:.4}, re-traced {:.4}, re-trace path {:.4}; relative RMSE cuts {contact_err:.4}, re-trace path {:.4}",
        contact.len(),
        mean(&a[2], &contact),
        mean(&b[2], &contact),
        mean(&r[2], &contact),
        rel_rmse(&r[2], &b[2], &contact)
    );
    eprintln!(
        "left region: {} pixels, mean darkening still {:.4}, cuts {:.4}, re-traced {:.4}, re-trace path {:.4}",
        left.len(),
        mean(&c[2], &left),
        mean(&a[2], &left),
        mean(&b[2], &left),
        mean(&r[2], &left)
    );
    assert!(contact.len() > 100, "{} contact and {} left pixels", contact.len(), left.len());
    assert!(mean(&a[2], &contact) > 0.5 * mean(&b[2], &contact), "the ground under the new place must darken");
    assert!(contact_err <= CONTACT_TOLERANCE, "relative RMSE {contact_err:.4} over the contact region");
    // The median pixel (the mean carries a few pixels between the two places that the cuts
    // darken for the new place and the trace does not: the field is clamped to its innermost
    // sphere there, 1.2 r, which overstates the occlusion close to the statue).
    let median = |img: &LinearImage, px: &[usize]| {
        let mut v: Vec<f64> = px.iter().map(|&i| darker(img, i)).collect();
        v.sort_by(f64::total_cmp);
        v[v.len() / 2]
    };
    eprintln!("left region medians: still {:.4}, cuts {:.4}", median(&c[2], &left), median(&a[2], &left));
    // The ground the statue left recovers to the bare footage, as the re-traced placement's does
    // (median −0.01%). With `c·V` the cuts darkened it by ≈ 4% (median) for the new place 1.5 m
    // away, where the trace finds < 0.2%; with each receiver's own light by direction and the
    // statue's reflected light (`cuts::receiver_light`) measured: median 0.00%, mean −0.37%
    // (the still run darkens it by 5.3%).
    assert!(left.len() > 20, "{} left pixels", left.len());
    assert!(median(&a[2], &left).abs() < 0.01 && mean(&a[2], &left).abs() < 0.01, "the ground the statue left must recover");
    for d in [&moving, &placed, &still, &retrace, &bare, &outs] {
        std::fs::remove_dir_all(d).ok();
    }
}

/// Relative RMSE allowed over the statue's pixels against the traced transfer: issue 15 §3's 5%.
/// Measured 2.3% (debug build, lavapipe) since the light the statue reflects onto itself
/// (`cuts::self_bounce`) and the split long edges (`geometry::subdivide`); 5.6% before them, when
/// the pedestal's two-triangle top put the contact shadow between its vertices and the cuts left
/// out the sunlit pedestal's light on the sphere's underside.
const OBJECT_TOLERANCE: f64 = 0.05;
/// Relative RMSE allowed over the contact region (issue 15 §3 asks ≤ 8%). Measured 6.2% while each
/// receiver lost its share of the whole sky's light (`c·V`, `b·V`); 2.17% with the receivers'
/// own light by direction, the statue's reflected light and its near field traced
/// (`cuts::receiver_light`, `cuts::receivers::near_cut`; mean darkening 7.05% against the
/// trace's 8.67%, debug build). The bound keeps two points of margin under the issue's.
const CONTACT_TOLERANCE: f64 = 0.04;
