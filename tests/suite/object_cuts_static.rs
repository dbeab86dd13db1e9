//! Issue 15 §3's last two checks of the visibility cuts against references:
//! - **the static case**: "when nothing moves, the cuts and the existing per-pixel transfer agree
//!   within 2% over object pixels". The statue steps away on frame 1 and back to its placement on
//!   frame 2 (keyframes), so frame 2 shows it where the scene places it with its ambient from the
//!   cuts (the frame loop serves every frame after a move from them), through `heliar augment` as
//!   users get it; the reference is the same frame of the default static render (per-pixel traced
//!   transfer, `render::object_transfer`);
//! - **an object passing under the wall's sky shadow**: the statue moves from open paving to the
//!   foot of the courtyard's free-standing concrete wall (the proxy's `wall`, 2.4 m high), where
//!   the wall hides a large part of its sky; its ambient then needs the proxy's visibility field
//!   (`cuts::proxy_field`), which the test also shows by running without it. Checked against the
//!   statue placed there from the start and traced, over its pixels (≤ 5%) and its contact region
//!   (≤ 8%), as `object_cuts` does for open ground.

use crate::common::*;
use crate::object_cuts::{augment3, block, edit, lum, object_hits, object_pixels, rel_rmse};
use heliar::geometry::raycast::RayScene;
use heliar::io::image::LinearImage;
use heliar::scene::Scene;

/// The statue's manifest placement (`scenes/courtyard/scene.toml`).
const PLACED: &str = "[-1.9, 0, 0]";
/// Open paving, 0.92 m from the placement (where `object_cuts` slides it).
const AWAY: &str = "[-1.2, 0, 0.6]";
/// Open paving in front of the wall, 1.7 m east of its face.
const OPEN: &str = "[-0.6, 0, 0.9]";
/// At the foot of the free-standing wall (x from −3.2 to −2.8, z from −1.5 to 1.5, 2.4 m high):
/// the statue turned 25° reaches 0.465 m from its centre along x, so its box ends 0.085 m from
/// the wall's east face (the face the camera sees).
const AT_WALL: &str = "[-2.25, 0, 0.3]";

/// Keyframes at 0, 10 and 20 s (the courtyard's frames 0, 1, 2), unturned from the placement.
fn keys(at: [&str; 3]) -> String {
    at.iter()
        .enumerate()
        .map(|(k, t)| format!("[[virtual_objects.motion.keyframes]]\ntime = {}.0\ntranslation = {t}\nrotation_y_deg = 25\n", 10 * k))
        .collect()
}

const STATUE: &str = "[[virtual_objects]]\nfile = \"objects/statue.glb\"\ntranslation = [-1.9, 0, 0]\nrotation_y_deg = 25\nscale = 1.0\n";

/// The report's reason for skipping pass `name` on `line`.
fn skipped(line: &serde_json::Value, name: &str) -> Option<String> {
    line["passes"]["skipped"].as_array()?.iter().find(|s| s["pass"] == name).and_then(|s| s["reason"].as_str().map(str::to_owned))
}

/// Frame 2 was served by the cuts and traced nothing (the objects' transfer dropped, not
/// re-traced; the receivers along the motion got `c`, `b` at set-up).
fn assert_cuts_served(line: &serde_json::Value) {
    let passes = &line["passes"];
    assert!(passes["ran"].as_array().unwrap().iter().any(|p| p == "visibility_cuts"), "{passes}");
    assert!(skipped(line, "object_transfer").is_some_and(|r| r.contains("visibility cuts")), "{passes}");
    assert_eq!(passes["receivers_computed"].as_u64(), Some(0), "{passes}");
    assert_eq!(passes["transfer_traced"].as_u64(), Some(0), "{passes}");
}

/// The statue's interior pixels split by what they show (the centre ray's hit on the placed
/// statue): the sphere (above the pedestal's 0.6 m) and the pedestal.
fn sphere_and_pedestal(scene: &Scene, pixels: &[usize]) -> (Vec<usize>, Vec<usize>) {
    let w = scene.camera.intrinsics.width;
    let statue = RayScene::new(scene.virtual_objects[0].mesh.clone());
    pixels.iter().partition(|&&i| {
        let Some((o, d)) = scene.camera.pixel_ray(i as u32 % w, i as u32 / w) else { return false };
        statue.intersect(o.as_vec3(), d.as_vec3(), f32::MAX).is_some_and(|h| h.point.y > 0.6)
    })
}

/// The statue's interior pixels split by whether the sun reaches the point they show (frame 2's
/// sun, `sun_dir` of the report line; the proxy and the statue as occluders).
fn sunlit_and_shaded(scene: &Scene, pixels: &[usize], line: &serde_json::Value) -> (Vec<usize>, Vec<usize>) {
    let w = scene.camera.intrinsics.width;
    let s: Vec<f32> = line["sun_dir"].as_array().unwrap().iter().map(|v| v.as_f64().unwrap() as f32).collect();
    let sun = glam::Vec3::new(s[0], s[1], s[2]);
    let mut world = scene.proxy.clone();
    world.append(&scene.virtual_objects[0].mesh);
    let world = RayScene::new(world);
    let statue = RayScene::new(scene.virtual_objects[0].mesh.clone());
    pixels.iter().partition(|&&i| {
        let Some((o, d)) = scene.camera.pixel_ray(i as u32 % w, i as u32 / w) else { return false };
        statue.intersect(o.as_vec3(), d.as_vec3(), f32::MAX).is_some_and(|h| !world.occluded(h.point + h.normal * 1e-3, sun, f32::MAX))
    })
}

/// Per class of pixels (`(name, pixels)`), its count, relative RMSE, mean signed error and its
/// share of the whole set's squared error (`Σ(a − r)²` over the class `/ Σr²` over `all`: the
/// shares of disjoint classes add up to the total's square), for the test's output.
fn breakdown(a: &LinearImage, reference: &LinearImage, all: &[usize], classes: &[(&str, &[usize])]) -> String {
    let den: f64 = all.iter().map(|&i| lum(reference.data[i]).powi(2)).sum();
    let share = |px: &[usize]| px.iter().map(|&i| (lum(a.data[i]) - lum(reference.data[i])).powi(2)).sum::<f64>() / den.max(1e-30);
    classes
        .iter()
        .map(|(name, px)| format!("{name} {} px {:.4} (mean {:+.4}, share {:.5})", px.len(), rel_rmse(a, reference, px), mean_bias(a, reference, px), share(px)))
        .collect::<Vec<_>>()
        .join("; ")
}

/// The pixels of `a` that are also in `b`.
fn both(a: &[usize], b: &[usize]) -> Vec<usize> {
    a.iter().copied().filter(|i| b.contains(i)).collect()
}

/// Mean relative luminance error (signed) of `a` against `reference` over `pixels`.
fn mean_bias(a: &LinearImage, reference: &LinearImage, pixels: &[usize]) -> f64 {
    pixels.iter().map(|&i| lum(a.data[i]) / lum(reference.data[i]).max(1e-9) - 1.0).sum::<f64>() / pixels.len().max(1) as f64
}

/// Ground the placed statue darkens by more than 1% against the bare courtyard (`bare`), its own
/// pixels grown by 2 px left out.
fn contact_region(scene: &Scene, placed: &LinearImage, bare: &LinearImage) -> Vec<usize> {
    let objects = block(&object_hits(scene), scene.camera.intrinsics.width, false);
    (0..bare.data.len()).filter(|&i| !objects[i] && 1.0 - lum(placed.data[i]) / lum(bare.data[i]).max(1e-9) > 0.01).collect()
}

#[test]
fn an_unmoved_statue_lit_by_the_cuts_matches_its_traced_transfer() {
    let outs = std::env::temp_dir().join(format!("heliar-cuts-static-out-{}", std::process::id()));
    // Frame 1 away, frame 2 back at the placement: frame 2 is the static scene lit by the cuts.
    let back = scratch_courtyard("cuts-static-back");
    edit(&back, "scale = 1.0\n", &format!("scale = 1.0\n{}\n", keys([PLACED, AWAY, PLACED])));
    let still = scratch_courtyard("cuts-static-still");
    let bare = scratch_courtyard("cuts-static-bare");
    edit(&bare, STATUE, "");
    let (a, lines) = augment3(&back, &outs.join("back"));
    let (b, still_lines) = augment3(&still, &outs.join("still"));
    let (n, _) = augment3(&bare, &outs.join("bare"));
    assert_cuts_served(&lines[2]);
    // The reference is the default static render: its transfer traced, no cuts.
    let still_passes = &still_lines[2]["passes"];
    assert!(!still_passes["ran"].as_array().unwrap().iter().any(|p| p == "visibility_cuts"), "{still_passes}");
    assert!(skipped(&still_lines[2], "object_transfer").is_none_or(|r| !r.contains("visibility cuts")), "{still_passes}");
    let scene = Scene::load(&still).unwrap();
    // The statue stands where the scene places it (the motion's last key is the placement).
    let posed = {
        let s = Scene::load(&back).unwrap();
        let m = s.virtual_objects[0].motion.clone().unwrap();
        heliar::scene::motion::posed(&m.rest, m.motion.world_from_rest(20.0))
    };
    let placed = &scene.virtual_objects[0].mesh;
    assert_eq!(posed.positions.len(), placed.positions.len());
    let drift = posed.positions.iter().zip(&placed.positions).map(|(p, q)| (*p - *q).length()).fold(0.0f32, f32::max);
    assert!(drift < 1e-5, "frame 2's statue is {drift} m off its placement");

    let pixels = object_pixels(&scene);
    assert!(pixels.len() > 300, "{} object pixels", pixels.len());
    let err = rel_rmse(&a[2], &b[2], &pixels);
    let (sphere, pedestal) = sphere_and_pedestal(&scene, &pixels);
    let (lit, shaded) = sunlit_and_shaded(&scene, &pixels, &still_lines[2]);
    let contact = contact_region(&scene, &b[2], &n[2]);
    let contact_err = rel_rmse(&a[2], &b[2], &contact);
    let passes = &lines[2]["passes"];
    eprintln!(
        "static case: {} object pixels, relative RMSE {err:.4} (mean {:+.4}); contact region {} px {contact_err:.4}; frame 2 composite {:.0} ms, cuts {:.0} ms (traced reference: {:.0} ms)",
        pixels.len(),
        mean_bias(&a[2], &b[2], &pixels),
        contact.len(),
        lines[2]["composite_ms"].as_f64().unwrap_or(0.0),
        passes["timings"]["cuts_ms"].as_f64().unwrap_or(0.0),
        still_lines[2]["composite_ms"].as_f64().unwrap_or(0.0),
    );
    let classes = [("sphere", &sphere[..]), ("pedestal", &pedestal[..]), ("sunlit", &lit[..]), ("shaded", &shaded[..])];
    eprintln!("static case by class: {}", breakdown(&a[2], &b[2], &pixels, &classes));
    let (sp, pe) = (both(&sphere, &shaded), both(&pedestal, &shaded));
    eprintln!("static case, shaded: {}", breakdown(&a[2], &b[2], &pixels, &[("sphere", &sp[..]), ("pedestal", &pe[..])]));
    assert!(err <= STATIC_TOLERANCE, "relative RMSE {err:.4} over {} object pixels", pixels.len());
    assert!(contact.len() > 100 && contact_err <= STATIC_CONTACT_TOLERANCE, "relative RMSE {contact_err:.4} over {} contact pixels", contact.len());
    for d in [&back, &still, &bare, &outs] {
        std::fs::remove_dir_all(d).ok();
    }
}

/// Share of the cosine-weighted upper hemisphere at `p` (normal +y) that `proxy` hides, over a
/// spherical Fibonacci set of `n` directions.
fn sky_hidden(proxy: &RayScene, p: glam::Vec3, n: usize) -> f64 {
    let golden = std::f32::consts::PI * (3.0 - 5f32.sqrt());
    let (mut hidden, mut all) = (0.0, 0.0);
    for k in 0..n {
        let y = 1.0 - (k as f32 + 0.5) / n as f32;
        let r = (1.0 - y * y).sqrt();
        let d = glam::Vec3::new(r * (golden * k as f32).cos(), y, r * (golden * k as f32).sin());
        all += y as f64;
        if proxy.occluded(p + d * 1e-3, d, f32::MAX) {
            hidden += y as f64;
        }
    }
    hidden / all
}

#[test]
fn a_statue_moved_under_the_walls_sky_shadow_takes_it_from_the_proxy_field() {
    let outs = std::env::temp_dir().join(format!("heliar-cuts-wall-out-{}", std::process::id()));
    let moving = scratch_courtyard("cuts-wall-moving");
    edit(&moving, "scale = 1.0\n", &format!("scale = 1.0\n{}\n", keys([OPEN, OPEN, AT_WALL])));
    let placed = scratch_courtyard("cuts-wall-placed");
    edit(&placed, &format!("translation = {PLACED}"), &format!("translation = {AT_WALL}"));
    let bare = scratch_courtyard("cuts-wall-bare");
    edit(&bare, STATUE, "");
    // The same motion with cuts that have no proxy field: the wall's sky shadow left out.
    let no_field = scratch_courtyard("cuts-wall-nofield");
    edit(&no_field, "scale = 1.0\n", &format!("scale = 1.0\n{}\n", keys([OPEN, OPEN, AT_WALL])));
    {
        let scene = Scene::load(&no_field).unwrap();
        let ray = RayScene::new(scene.proxy.clone());
        let opts = heliar::run::precompute::PrecomputeOptions::frame_loop();
        heliar::run::precompute::precompute(&scene, &ray, &opts, &heliar::cuts::no_progress).unwrap();
        let path = heliar::run::precompute::cuts_path(&scene);
        let mut cuts = heliar::cuts::file::read(&path).unwrap();
        assert!(cuts.proxy.is_some(), "the frame loop's cuts carry the proxy field");
        cuts.proxy = None;
        heliar::cuts::file::write(&path, &cuts).unwrap();
    }
    let scene = Scene::load(&placed).unwrap();
    // The wall's sky shadow where the statue stands: the paving between it and the wall, and
    // at its open place, as the proxy hides the sky there (cosine-weighted, 4 096 directions).
    let proxy = RayScene::new(scene.proxy.clone());
    let (lo, hi) = scene.virtual_objects[0].mesh.bounds().unwrap();
    let foot = glam::Vec3::new(lo.x - 0.04, 0.01, (lo.z + hi.z) / 2.0);
    let side = glam::Vec3::new(lo.x, 1.05, 0.3);
    let open = glam::Vec3::new(-0.6 - 0.47, 0.01, 0.9);
    let (at_foot, at_side, at_open) = (sky_hidden(&proxy, foot, 4096), sky_hidden(&proxy, side, 4096), sky_hidden(&proxy, open, 4096));
    eprintln!("wall: box {lo}..{hi}, {:.3} m from the wall; the proxy hides {at_foot:.3} of the sky at the foot between them, {at_side:.3} at the sphere's wall side, {at_open:.3} beside the open place", lo.x + 2.8);
    assert!(lo.x > -2.8 && lo.x < -2.6, "the statue's box starts at x = {} (the wall's face: −2.8)", lo.x);
    assert!(at_foot > 0.5 && at_side > 0.45 && at_open < 0.3, "the wall hides {at_foot:.3} / {at_side:.3} of the sky at the statue, {at_open:.3} in the open");

    let (a, lines) = augment3(&moving, &outs.join("moving"));
    let (b, _) = augment3(&placed, &outs.join("placed"));
    let (n, _) = augment3(&bare, &outs.join("bare"));
    let (f, f_lines) = augment3(&no_field, &outs.join("nofield"));
    assert_cuts_served(&lines[2]);
    assert_cuts_served(&f_lines[2]);

    let pixels = object_pixels(&scene);
    assert!(pixels.len() > 300, "{} object pixels", pixels.len());
    let err = rel_rmse(&a[2], &b[2], &pixels);
    let err_no_field = rel_rmse(&f[2], &b[2], &pixels);
    let (sphere, pedestal) = sphere_and_pedestal(&scene, &pixels);
    let (lit, shaded) = sunlit_and_shaded(&scene, &pixels, &lines[2]);
    let contact = contact_region(&scene, &b[2], &n[2]);
    let contact_err = rel_rmse(&a[2], &b[2], &contact);
    let darker = |img: &LinearImage, i: usize| 1.0 - lum(img.data[i]) / lum(n[2].data[i]).max(1e-9);
    let mean = |img: &LinearImage| contact.iter().map(|&i| darker(img, i)).sum::<f64>() / contact.len().max(1) as f64;
    let passes = &lines[2]["passes"];
    eprintln!(
        "wall: {} object pixels, relative RMSE {err:.4} (mean {:+.4}), without the proxy field {err_no_field:.4} (mean {:+.4}); \
         contact region {} px, relative RMSE {contact_err:.4} (without the field {:.4}), mean darkening cuts {:.4} traced {:.4}; frame 2 composite {:.0} ms, cuts {:.0} ms",
        pixels.len(),
        mean_bias(&a[2], &b[2], &pixels),
        mean_bias(&f[2], &b[2], &pixels),
        contact.len(),
        rel_rmse(&f[2], &b[2], &contact),
        mean(&a[2]),
        mean(&b[2]),
        lines[2]["composite_ms"].as_f64().unwrap_or(0.0),
        passes["timings"]["cuts_ms"].as_f64().unwrap_or(0.0),
    );
    let classes = [("sphere", &sphere[..]), ("pedestal", &pedestal[..]), ("sunlit", &lit[..]), ("shaded", &shaded[..])];
    eprintln!("wall by class: {}", breakdown(&a[2], &b[2], &pixels, &classes));
    eprintln!("wall by class, without the proxy field: {}", breakdown(&f[2], &b[2], &pixels, &classes));
    assert!(contact.len() > 100, "{} contact pixels", contact.len());
    assert!(err <= OBJECT_TOLERANCE, "relative RMSE {err:.4} over {} object pixels", pixels.len());
    assert!(contact_err <= CONTACT_TOLERANCE, "relative RMSE {contact_err:.4} over the contact region");
    // Without the proxy field the cuts give the statue the sky the wall hides (measured 7.5%
    // against 4.74%, too bright by 6.3% on average against 2.2% too dark; 17.9% against 9.9%
    // before `cuts::local_sun`).
    assert!(err < 0.75 * err_no_field, "without the proxy field {err_no_field:.4}, with it {err:.4}");
    for d in [&moving, &placed, &bare, &no_field, &outs] {
        std::fs::remove_dir_all(d).ok();
    }
}

/// Relative RMSE allowed over the unmoved statue's pixels against its traced transfer: issue 15
/// §3's 2%. Measured 7.35% (+4.7% on average) while the cuts lit the statue with the relit map's
/// surface texels as distant light (the pedestal in the wall's sun shadow got the sunlit paving
/// the capture point sees); 2.22% with the proxy's light taken per vertex and coarse direction
/// (`cuts::local_sun`) and the bounce sources' sun shadow traced against the proxy, the sphere's
/// shaded underside 8.0% (the pedestal top's sunlit corners lit it across the sphere's shadow);
/// 1.86% (mean −0.1%; the underside 4.9%) with the sun traced at each hit of the self-bounce
/// gather (`cuts::bounce::FrameCuts::self_bounce_rows`), 1.89% with the proxy field's grid
/// points inside the wall left out of its lookups (the statue's west side had neighbours there). Debug build, the frame loop's cuts
/// (`S = 2^10`, 8 × 16² fields, proxy field on the `[irradiance]` box at 1 m); runs repeat to
/// the digits shown. What is left: the pedestal +1.8% on average (the paving's `c` at its foot
/// does not know the statue hides its sky) and the sphere's lowest pixel row (Gouraud between
/// its dark bottom vertex and the ring above; docs/measurements.md, "The sun at the
/// self-bounce's hits").
const STATIC_TOLERANCE: f64 = 0.02;
/// Relative RMSE allowed over the statue's pixels at the wall: issue 15 §3's 5%. Measured 9.93%
/// while the map's surface texels lit it (17.9% without the proxy field), 4.74% with
/// `cuts::local_sun` (7.5% without the proxy field; its wall side 6–15% too dark: it blended
/// toward the proxy field's grid points inside the wall), 3.82% (mean +2.0%) with those points
/// left out of the lookups (`cuts::proxy_field`; docs/measurements.md, "Grid points inside the
/// wall"). Debug build, deterministic.
const OBJECT_TOLERANCE: f64 = 0.05;
/// Relative RMSE allowed over the contact region at the wall (issue 15 §3 asks 8%). Measured 11.1%
/// while a receiver lost the share of the *whole* sky's light the statue hides (the cuts
/// darkened the ground half as much as the trace, mean 6.0% against 11.6%: the wall already
/// hides half of that sky, so the statue takes twice the share of what is left); 7.19% with each
/// receiver's light by direction as it sees it (`cuts::receiver_light`); 2.95% with the statue's
/// reflected light added and the ground closer to it than its field's innermost sphere traced
/// against it (`cuts::receivers::near_cut`: the field saw the statue from 1.2 r there), mean
/// darkening 11.4% against the trace's 11.6%; 3.40% (darkening 10.8%) with the proxy field's
/// grid points inside the wall left out of its lookups. Debug build, deterministic.
const CONTACT_TOLERANCE: f64 = 0.04;
/// Relative RMSE allowed over the unmoved statue's contact region (issue 15 §3 asks 8%; measured
/// 6.5% with `c·V`, `b·V`, 2.49% with `cuts::receiver_light` and `near_cut`).
const STATIC_CONTACT_TOLERANCE: f64 = 0.04;
