//! The lamps on the GPU (issue 16 §2): the compositor's lamp term against a CPU reference at the
//! same surface points — the lamp's irradiance from `lamps::model` (the CPU core, not the GPU
//! code), times the glTF BRDF written again in Rust (`support::brdf_cos`), times the visibility
//! of the lamp by shadow rays against the proxy and the objects — at night (no sun, `Pa = Pd =
//! 0`, zero probes), so the lamp term is all there is on the objects.

use super::support::*;
use glam::Vec3;
use heliar::geometry::raycast::{RAY_EPSILON_M, RayScene};
use heliar::geometry::{Material, Mesh};
use heliar::io::image::LinearImage;
use heliar::lamps::Lamp;
use heliar::lamps::lightfield::{FilterGrid, LightField};
use heliar::lamps::model::Model;
use heliar::lighting::{LampScales, Lighting};
use heliar::render::frame::pass;
use heliar::render::lamps::LampOptions;
use heliar::render::{CompositorConfig, Compositor, VideoFrame};
use heliar::scene::lights::world_from_lamp;
use heliar::scene::{Light, LightKind, Schedule};
use std::path::{Path, PathBuf};

/// Mean absolute error allowed over the compared pixels, as a fraction of the range of the
/// reference values: the shading test's 1 % (issue 4 §6). What is left between the two paths is
/// the rasteriser's interpolated position and normal against the ray cast's, half-float layers
/// and light-field texels (2⁻¹¹ relative), and f32 against f64.
const MAX_MEAN_ERROR_OF_RANGE: f64 = 0.01;
/// A shadowed pixel may keep this fraction of the mean lit radiance (shadow-map bias lets a
/// sliver of light through at grazing angles; a missed shadow keeps all of it).
const MAX_SHADOWED_FRACTION: f32 = 0.02;
/// The lamp's scale `k` (model units → scene radiance).
pub(super) const K: [f32; 3] = [0.02, 0.018, 0.012];

fn material(rgb: [f32; 3], roughness: f32, name: &str) -> Material {
    Material { name: name.into(), base_color: [rgb[0], rgb[1], rgb[2], 1.0], base_color_texture: None, metallic: 0.0, roughness }
}

/// A ball and a block on the yard's ground; `plate` adds a small virtual plate high over the
/// ball (an occluder for a lamp above).
fn objects(plate: bool) -> Vec<(String, Mesh)> {
    let mut o = vec![
        ("ball".into(), icosphere(Vec3::new(-1.0, 0.6, 0.3), 0.5, 2, material([0.7, 0.6, 0.5], 0.8, "clay"), "ball")),
        ("block".into(), cube(Vec3::new(0.2, 0.0, -0.6), Vec3::new(0.8, 0.8, 0.0), material([0.5, 0.6, 0.7], 0.5, "paint"), "block")),
    ];
    if plate {
        o.push(("plate".into(), cube(Vec3::new(-1.25, 2.0, 0.05), Vec3::new(-0.75, 2.05, 0.55), material([0.3; 3], 0.9, "slate"), "plate")));
    }
    o
}

pub(super) fn setup(plate: bool, eye: [f64; 3]) -> Setup {
    Setup { camera: camera(eye, [-0.6, 0.6, 0.0], 320, 240, [0.0; 5]), proxy: yard_proxy(), objects: objects(plate) }
}

fn light(kind: LightKind, position: Vec3, at: Vec3) -> Light {
    let aim = (at - position).as_dvec3();
    Light { name: "lamp".into(), field: "lights[0]".into(), kind, position: position.as_dvec3(), world_from_lamp: world_from_lamp(aim, 0.0).unwrap(), scale: 1.0, schedule: Schedule::Always }
}

pub(super) fn spot(position: Vec3, at: Vec3) -> Lamp {
    Lamp::load(Path::new("scene.toml"), &light(LightKind::Spot { intensity_cd: 600.0, inner_deg: 20.0, outer_deg: 45.0 }, position, at)).unwrap()
}

fn night(k: [f32; 3]) -> Lighting {
    Lighting { sun_dir: Vec3::Y, above_horizon: false, pd: Vec3::ZERO, pa: Vec3::ZERO, sky: heliar::lighting::FrameSky::Declared, lamps: LampScales::from_slice(&[k]) }
}

pub(super) fn config() -> CompositorConfig {
    let mut c = CompositorConfig::from_estimator_settings(&Default::default());
    c.occlusion_rays = 0;
    c.transfer_paths = 0;
    c
}

fn render(s: &Setup, lamp: &Lamp, options: LampOptions, k: [f32; 3]) -> (Vec<[f32; 3]>, heliar::render::frame::PassReport, Compositor) {
    let mut comp = s.compositor(config());
    comp.set_lamps(std::slice::from_ref(lamp), options).expect("lamps");
    let (w, h) = (s.camera.intrinsics.width, s.camera.intrinsics.height);
    let video = VideoFrame { width: w, height: h, rgba: vec![[0.0, 0.0, 0.0, 1.0]; (w * h) as usize] };
    let (frame, report) = comp.render(&video, &night(k)).expect("render");
    (frame.image.data, report, comp)
}

/// One virtual pixel of the reference: the lamp's radiance there and whether the lamp sees it.
struct Expected {
    index: usize,
    radiance: Vec3,
    visible: bool,
    tri: u32,
}

/// The reference radiance `k·E·f(v, l)` of every virtual pixel (`E` from `lamps::model`, which
/// holds the `cos θ` that `brdf_cos` holds too, so it is divided out once).
fn expected(s: &Setup, lamp: &Lamp, k: [f32; 3]) -> Vec<Expected> {
    let r = reference(s, Vec3::Y);
    let proxy = RayScene::new(s.proxy.clone());
    let scenes: Vec<RayScene> = s.objects.iter().map(|(_, m)| RayScene::new(m.clone())).collect();
    let eye = s.camera.pose.translation.as_vec3();
    let to = lamp.light.position.as_vec3();
    let mut out = Vec::new();
    for (i, p) in r.iter().enumerate() {
        if p.kind != 2 {
            continue;
        }
        let mesh = &s.objects[p.object].1;
        let m = &mesh.materials[mesh.tri_material[(p.tri % 1_000_000) as usize] as usize];
        let base = Vec3::new(m.base_color[0], m.base_color[1], m.base_color[2]);
        let (n, v) = (p.normal, (eye - p.point).normalize());
        let d = to - p.point;
        let dist = d.length();
        let l = d / dist;
        let o = p.point + n * RAY_EPSILON_M;
        let visible = n.dot(l) > 0.0 && !proxy.occluded(o, l, dist - 0.02) && !scenes.iter().any(|sc| sc.occluded(o, l, dist - 0.02));
        let e = lamp.irradiance(p.point.as_dvec3(), n.as_dvec3());
        let f = brdf_cos(base, m.metallic, m.roughness, n, v, l) / n.dot(l).max(1e-6);
        let radiance = Vec3::new(k[0] * e[0] as f32, k[1] * e[1] as f32, k[2] * e[2] as f32) * f;
        out.push(Expected { index: i, radiance: if visible { radiance } else { Vec3::ZERO }, visible, tri: p.tri });
    }
    out
}

/// Pixels next to a change of triangle or of lamp visibility (left out of the comparison).
fn boundary(s: &Setup, exp: &[Expected]) -> Vec<bool> {
    let (w, h) = (s.camera.intrinsics.width, s.camera.intrinsics.height);
    let mut class = vec![(u32::MAX, false); (w * h) as usize];
    for e in exp {
        class[e.index] = (e.tri, e.visible);
    }
    edges(w, h, &class)
}

/// Mean absolute error over the lit interior pixels, per channel, as a fraction of the range;
/// and the mean lit radiance.
fn compare(label: &str, got: &[[f32; 3]], exp: &[Expected], skip: &[bool]) -> (f64, Vec3) {
    let lit: Vec<&Expected> = exp.iter().filter(|e| e.visible && !skip[e.index] && e.radiance.max_element() > 0.0).collect();
    assert!(lit.len() > 1500, "{label}: only {} lit interior pixels", lit.len());
    let mut worst = 0.0f64;
    for c in 0..3 {
        let (lo, hi) = lit.iter().fold((f32::MAX, f32::MIN), |(a, b), e| (a.min(e.radiance[c]), b.max(e.radiance[c])));
        let mean = lit.iter().map(|e| (got[e.index][c] - e.radiance[c]).abs() as f64).sum::<f64>() / lit.len() as f64;
        let rel = mean / (hi - lo) as f64;
        eprintln!("{label}: channel {c}: {} pixels, range {lo:.4}..{hi:.4}, mean error {mean:.5} = {:.3}% of the range", lit.len(), 100.0 * rel);
        worst = worst.max(rel);
    }
    let mean = lit.iter().map(|e| e.radiance).sum::<Vec3>() / lit.len() as f32;
    (worst, mean)
}

#[test]
fn a_spot_lamp_at_night_matches_the_cpu_model() {
    let s = setup(false, [1.2, 1.7, 2.8]);
    let lamp = spot(Vec3::new(0.8, 3.5, 2.5), Vec3::new(-0.5, 0.4, 0.0));
    let (got, report, _) = render(&s, &lamp, LampOptions::default(), K);
    assert!(report.ran(pass::LAMP_SHADOWS) && report.ran(pass::LAMP_TERM), "{report:?}");
    let exp = expected(&s, &lamp, K);
    let (err, _) = compare("spot", &got, &exp, &boundary(&s, &exp));
    assert!(err < MAX_MEAN_ERROR_OF_RANGE, "mean error {:.3}% of the range", 100.0 * err);
}

#[test]
fn occluders_between_lamp_and_object_darken_exactly_the_pixels_behind_them() {
    // A lamp straight above the ball, the virtual plate between them; and a lamp behind the real
    // wall (x ≈ −3), whose top cuts the ball's light. Both: shadowed pixels dark, the
    // others the reference's.
    for (label, lamp, eye) in [
        ("virtual plate", spot(Vec3::new(-1.0, 4.0, 0.3), Vec3::new(-1.0, 0.0, 0.3)), [0.8, 2.4, 2.4]),
        ("real wall", spot(Vec3::new(-4.0, 4.0, 0.3), Vec3::new(-1.0, 0.6, 0.3)), [-1.0, 1.6, 3.0]),
    ] {
        let s = setup(true, eye);
        let (got, _, _) = render(&s, &lamp, LampOptions::default(), K);
        let exp = expected(&s, &lamp, K);
        let skip = boundary(&s, &exp);
        let (err, mean) = compare(label, &got, &exp, &skip);
        assert!(err < MAX_MEAN_ERROR_OF_RANGE, "{label}: mean error {:.3}% of the range", 100.0 * err);
        // Pixels facing the lamp, in its light, that the reference finds occluded.
        let lum = |v: Vec3| v.dot(Vec3::new(0.2126, 0.7152, 0.0722));
        let blocked: Vec<usize> = blocked_pixels(&s, &lamp, &exp, &skip);
        let bright = blocked.iter().filter(|&&i| lum(Vec3::from(got[i])) > MAX_SHADOWED_FRACTION * lum(mean)).count();
        eprintln!("{label}: {} occluded pixels, {bright} brighter than {MAX_SHADOWED_FRACTION} of the mean lit {:.4}", blocked.len(), lum(mean));
        assert!(blocked.len() > 100, "{label}: only {} occluded pixels facing the lamp", blocked.len());
        assert!(bright * 100 <= blocked.len(), "{label}: {bright} of {} occluded pixels are lit", blocked.len());
    }
}

/// Pixels of an occluded region this close to a lit one are left out of the shadow check: the
/// map's texels (about 1 cm on the ball at 256² over the objects' box) and its normal offset of
/// 1.5 texels move the edge by up to two pixels of this camera (1.2 cm at 3 m).
pub(super) const SHADOW_EDGE_PX: i64 = 3;
/// Surfaces this close to grazing (`n·l`) are left out too: on a faceted sphere the reference's
/// shadow rays from the terminator hit the neighbouring facets, which the map's offsets clear.
const MIN_SHADOW_COS: f32 = 0.05;

/// Interior virtual pixels that face the lamp, get light from its model, and are occluded,
/// away from lit pixels and grazing angles.
fn blocked_pixels(s: &Setup, lamp: &Lamp, exp: &[Expected], skip: &[bool]) -> Vec<usize> {
    let r = reference(s, Vec3::Y);
    let w = s.camera.intrinsics.width as i64;
    let lit: std::collections::HashSet<i64> = exp.iter().filter(|e| e.visible).map(|e| e.index as i64).collect();
    let near_lit = |i: i64| (-SHADOW_EDGE_PX..=SHADOW_EDGE_PX).any(|dy| (-SHADOW_EDGE_PX..=SHADOW_EDGE_PX).any(|dx| lit.contains(&(i + dy * w + dx))));
    exp.iter()
        .filter(|e| !e.visible && !skip[e.index] && !near_lit(e.index as i64))
        .filter(|e| {
            let p = &r[e.index];
            let l = (lamp.light.position.as_vec3() - p.point).normalize();
            p.normal.dot(l) > MIN_SHADOW_COS && lamp.irradiance(p.point.as_dvec3(), p.normal.as_dvec3()).iter().any(|&x| x > 0.0)
        })
        .map(|e| e.index)
        .collect()
}

/// An `n`×`n` light field whose images are ramps (so the lookups' places show in the values),
/// 30 cm from its sampling plane.
fn ramp_field(n: usize) -> Lamp {
    let grid = FilterGrid { counts: [n, n], spacing_m: 0.02 };
    let img = |k: usize| LinearImage::from_fn(48, 48, move |x, y| [1.0 + x as f32 * 0.04 + k as f32 * 0.1, 2.0 - y as f32 * 0.02, 0.5 + (x + y) as f32 * 0.01]);
    let lf = LightField::new(grid, 0.3, [0.8, 0.8], (0..n * n).map(img).collect(), Path::new("<test>")).unwrap();
    let mut l = light(LightKind::Point { intensity_cd: 1.0 }, Vec3::new(-0.4, 3.0, 1.2), Vec3::new(-0.6, 0.4, 0.0));
    l.kind = LightKind::LightField { dir: PathBuf::from("<memory>") };
    Lamp { light: l, model: Model::Field(Box::new(lf)) }
}

#[test]
fn a_light_field_lamp_is_its_textured_spots() {
    // The GPU with the CPU model's support mean (2 Gauss points per h/2 cell): nine textured
    // spots, each with its own shadow map, against `lamps::model` (Eq. 14) — the visibility of
    // the reference is the lamp centre's, the GPU's each spot's; they differ only at shadow
    // edges, which are left out.
    let s = setup(false, [1.2, 1.7, 2.8]);
    let lamp = ramp_field(3);
    let k = [0.05, 0.04, 0.06];
    let options = LampOptions { support_points: 2, ..LampOptions::default() };
    let (got, report, _) = render(&s, &lamp, options, k);
    assert!(report.ran(pass::LAMP_TERM), "{report:?}");
    let exp = expected(&s, &lamp, k);
    let (err, _) = compare("light field", &got, &exp, &boundary(&s, &exp));
    assert!(err < MAX_MEAN_ERROR_OF_RANGE, "mean error {:.3}% of the range", 100.0 * err);
}

#[test]
fn lamps_that_are_off_or_out_of_reach_change_nothing_and_say_why() {
    // Without lamps, with a lamp off (k = 0) and with a spot aimed away from the objects, the
    // frame is the same to the bit, and the lamp term says why it did not run; a scene without
    // lamps reports nothing of them.
    let s = setup(false, [1.2, 1.7, 2.8]);
    let (w, h) = (320, 240);
    let video = VideoFrame { width: w, height: h, rgba: (0..w * h).map(|i| [0.1 + (i % w) as f32 * 1e-3, 0.2, 0.3, 1.0]).collect() };
    let day = Lighting { sun_dir: courtyard_sun(), above_horizon: true, pd: Vec3::splat(3.0), pa: Vec3::new(0.55, 0.62, 0.8), sky: heliar::lighting::FrameSky::Declared, lamps: LampScales::from_slice(&[K]) };
    let mut plain = s.compositor(config());
    let (want, r0) = plain.render(&video, &Lighting { lamps: LampScales::NONE, ..day }).unwrap();
    assert!(r0.ran.iter().chain(r0.skipped.iter().map(|x| &x.pass)).all(|p| !p.starts_with("lamp")), "{r0:?}");
    let cases = [
        ("off", spot(Vec3::new(0.8, 3.5, 2.5), Vec3::new(-0.5, 0.4, 0.0)), [0.0; 3], "off"),
        ("away", spot(Vec3::new(0.8, 3.5, 2.5), Vec3::new(0.8, 8.0, 2.5)), K, "cone"),
    ];
    for (label, lamp, k, why) in cases {
        let mut comp = s.compositor(config());
        comp.set_lamps(&[lamp], LampOptions::default()).unwrap();
        let (got, r) = comp.render(&video, &Lighting { lamps: LampScales::from_slice(&[k]), ..day }).unwrap();
        let reason = r.skip_reason(pass::LAMP_TERM).unwrap_or_else(|| panic!("{label}: lamp term not skipped: {r:?}"));
        assert!(reason.contains(why), "{label}: {reason}");
        assert!(r.skip_reason(pass::LAMP_SHADOWS).is_some(), "{label}: {r:?}");
        assert!(got.image.data == want.image.data, "{label}: the frame changed");
    }
}

/// The lamp term's cost per frame against the number of spots, and the spot lamp's error
/// against the CPU reference: `cargo test --release --features opencv --test suite
/// render::lamps::measure -- --ignored --nocapture` (docs/measurements.md).
#[test]
#[ignore]
fn measure_lamp_cost_and_error() {
    let s = setup(false, [1.2, 1.7, 2.8]);
    let (w, h) = (320, 240);
    let video = VideoFrame { width: w, height: h, rgba: vec![[0.0, 0.0, 0.0, 1.0]; (w * h) as usize] };
    let time = |comp: &mut Compositor, l: &Lighting| -> f64 {
        let mut ms: Vec<f64> = (0..7)
            .map(|i| {
                if i % 2 == 0 {
                    comp.invalidate();
                }
                let t = std::time::Instant::now();
                comp.render(&video, l).unwrap();
                t.elapsed().as_secs_f64() * 1e3
            })
            .collect();
        ms.sort_by(f64::total_cmp);
        ms[ms.len() / 2]
    };
    let mut base = s.compositor(config());
    let t0 = time(&mut base, &night([0.0; 3]));
    eprintln!("no lamps: median {t0:.1} ms per frame (7 frames, maps redrawn on every other)");
    for n in [1usize, 4, 16] {
        let side = (n as f64).sqrt().round() as usize;
        let lamps: Vec<Lamp> = (0..n).map(|i| spot(Vec3::new(-1.5 + 0.3 * (i % side) as f32, 3.5, 1.0 + 0.3 * (i / side) as f32), Vec3::new(-0.5, 0.4, 0.0))).collect();
        for shadows in [false, true] {
            let mut comp = s.compositor(config());
            comp.set_lamps(&lamps, LampOptions { shadows, ..LampOptions::default() }).unwrap();
            let t = time(&mut comp, &Lighting { lamps: LampScales::from_slice(&vec![K; n]), ..night(K) });
            eprintln!("{n} spot lamps, shadows {shadows}: median {t:.1} ms, lamp cost {:.1} ms", t - t0);
        }
    }
    for grid in [3usize, 5, 7, 9] {
        for points in [0usize, 1, 2] {
            let lamp = ramp_field(grid);
            let options = LampOptions { support_points: points, ..LampOptions::default() };
            let mut comp = s.compositor(config());
            comp.set_lamps(std::slice::from_ref(&lamp), options).unwrap();
            let t = time(&mut comp, &night([0.05; 3]));
            let (got, _, _) = render(&s, &lamp, options, [0.05; 3]);
            let exp = expected(&s, &lamp, [0.05; 3]);
            let (err, _) = compare("light field", &got, &exp, &boundary(&s, &exp));
            eprintln!("{grid}×{grid} light field, {points} points per cell: median {t:.1} ms, lamp cost {:.1} ms, mean error {:.3}% of the range", t - t0, 100.0 * err);
        }
    }
    let lamp = spot(Vec3::new(0.8, 3.5, 2.5), Vec3::new(-0.5, 0.4, 0.0));
    let (got, _, _) = render(&s, &lamp, LampOptions::default(), K);
    let exp = expected(&s, &lamp, K);
    let (err, _) = compare("spot", &got, &exp, &boundary(&s, &exp));
    eprintln!("spot: mean error {:.3}% of the range", 100.0 * err);
}
