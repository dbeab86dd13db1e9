//! The virtual objects' lamp shadows on real ground (issue 16 §3; `render::lamps::ground`): the
//! composite's differential darkening of the footage against a CPU reference at every real
//! pixel — `video · L₁ / L₀` with `L₀ = c·Pa + k·E·V^proxy`, `L₁ = c_v·Pa + k·E·V^proxy·V^objects`,
//! `E` from `lamps::model` (the CPU core) and the visibilities by shadow rays against the proxy
//! and the objects — at night (sun below the horizon, `Pd = 0`) with some sky light `Pa`, so
//! the lamp's share decides the darkening. `c` and `c_v` are the compositor's own (the
//! receivers' path-traced factors, tested elsewhere), and so are the lamp's light after a bounce
//! `k·B`, `k·B_v` (`render::lamps::ground_bounce`, against a quadrature in its unit tests) that
//! join `L₀` and `L₁`, so what is compared is the lamp's direct part and the sum.

use super::lamps::{K, SHADOW_EDGE_PX, config, setup, spot};
use super::support::*;
use glam::Vec3;
use heliar::geometry::raycast::{RAY_EPSILON_M, RayScene};
use heliar::lighting::{LampScales, Lighting};
use heliar::render::VideoFrame;
use heliar::render::frame::{Darkening, pass};
use heliar::render::lamps::LampOptions;

/// The sky's irradiance at night: about a third of the lamp's `k·E` under it, so the lamp
/// shadow keeps roughly a quarter of the footage (a clear darkening, far from 0 and 1).
const PA: f32 = 0.3;
/// The footage: a flat grey, so the output is the ratio times it.
const VIDEO: f32 = 0.5;
/// Mean error of `output / video` allowed over the interior pixels of each class (shadowed by
/// the objects, lit). Both paths evaluate the same spot model and read the same `c`, `c_v`;
/// what differs is f32 against f64 and the receivers' point and normal in float textures
/// (measured: a mean below 1e-5 over 3180 shadowed and 59622 lit pixels, none off by 2 %),
/// so 0.2 % is a wide margin that still catches a lamp share off
/// by more than a percent of the footage.
const MAX_MEAN_RATIO_ERROR: f64 = 0.002;
/// Interior pixels whose ratio may differ by more than [`PIXEL_RATIO_TOLERANCE`]: the maps'
/// texels (1 cm at 256² over the objects' box, about 4 cm on the ground at this distance)
/// against the exact shadow rays leave a few stragglers past [`SHADOW_EDGE_PX`].
const MAX_OFF_SHARE: f64 = 0.01;
const PIXEL_RATIO_TOLERANCE: f32 = 0.02;

fn night(pa: f32, k: [f32; 3]) -> Lighting {
    Lighting { sun_dir: Vec3::Y, above_horizon: false, pd: Vec3::ZERO, pa: Vec3::splat(pa), sky: heliar::lighting::FrameSky::Declared, lamps: LampScales::from_slice(&[k]) }
}

/// One real pixel of the reference: its expected ratio, whether the objects block the lamp.
struct Expected {
    index: usize,
    ratio: Vec3,
    shadowed: bool,
}

/// The lamp at (2.5, 3, 0) aimed over the objects toward the wall: the ball and the block cast
/// their shadows onto the ground in front of the wall, in view of the camera.
fn scene() -> (Setup, heliar::lamps::Lamp) {
    (setup(false, [0.6, 2.4, 3.4]), spot(Vec3::new(2.5, 3.0, 0.0), Vec3::new(-0.5, 0.0, 0.0)))
}

#[test]
fn a_spot_lamps_object_shadow_darkens_the_ground_by_its_share() {
    let (s, lamp) = scene();
    let (w, h) = (s.camera.intrinsics.width, s.camera.intrinsics.height);
    let mut comp = s.compositor(config());
    comp.set_lamps(std::slice::from_ref(&lamp), LampOptions::default()).expect("lamps");
    let video = VideoFrame { width: w, height: h, rgba: vec![[VIDEO, VIDEO, VIDEO, 1.0]; (w * h) as usize] };
    let (frame, report) = comp.render(&video, &night(PA, K)).expect("render");
    assert!(report.ran(pass::LAMP_GROUND), "{report:?}");
    let got = frame.image.data;

    let r = reference(&s, Vec3::Y);
    let proxy = RayScene::new(s.proxy.clone());
    let objects: Vec<RayScene> = s.objects.iter().map(|(_, m)| RayScene::new(m.clone())).collect();
    let rec = comp.receivers();
    let to = lamp.light.position.as_vec3();
    let k = Vec3::from(K);
    let gb = comp.ground_bounce().expect("the lamps' bounce at the receivers is traced with lamp_ground");
    let mut exp = Vec::new();
    for (i, p) in r.iter().enumerate().filter(|(_, p)| p.kind == 1) {
        let d = to - p.point;
        let dist = d.length();
        let l = d / dist;
        let o = p.point + p.normal * RAY_EPSILON_M;
        let facing = p.normal.dot(l) > 0.0;
        let v_proxy = facing && !proxy.occluded(o, l, dist - 0.02);
        let v_objects = !objects.iter().any(|sc| sc.occluded(o, l, dist - 0.02));
        let e = lamp.irradiance(p.point.as_dvec3(), p.normal.as_dvec3());
        let share = k * Vec3::new(e[0] as f32, e[1] as f32, e[2] as f32) * if v_proxy { 1.0 } else { 0.0 };
        let c = Vec3::from_slice(&rec.ambient[i][..3]);
        let c_v = if rec.ambient_with[i][3] > 0.5 { Vec3::from_slice(&rec.ambient_with[i][..3]) } else { c };
        let (bounce, bounce_v) = (Vec3::from_slice(&gb.without[i][..3]), Vec3::from_slice(&gb.with[i][..3]));
        let l0 = c * PA + share + bounce;
        let l1 = c_v * PA + if v_objects { share } else { Vec3::ZERO } + bounce_v;
        exp.push(Expected { index: i, ratio: l1 / l0, shadowed: v_proxy && !v_objects && share.max_element() > 0.0 });
    }
    // The objects' lamp shadow is where the bounce was traced, and the lit wall and ground send
    // it some light: in the shadow, `k·B_v` is what is left of the lamp.
    let shadowed: Vec<&Expected> = exp.iter().filter(|e| e.shadowed).collect();
    let traced = shadowed.iter().filter(|e| gb.with[e.index][3] > 0.5).count();
    assert_eq!(traced, shadowed.len(), "lamp-shadowed pixels without the lamps' bounce");
    let lit_bounce = shadowed.iter().filter(|e| gb.with[e.index][1] > 0.0).count();
    assert!(lit_bounce * 10 >= shadowed.len() * 9, "{lit_bounce} of {} shadowed pixels get bounced lamp light", shadowed.len());

    // Left out: pixels next to a change of surface (real/virtual, triangle) or within
    // SHADOW_EDGE_PX of a change of the lamp's visibility.
    let mut class = vec![(u32::MAX, false); (w * h) as usize];
    for (p, c) in r.iter().zip(class.iter_mut()) {
        c.0 = p.tri;
    }
    for e in &exp {
        class[e.index].1 = e.shadowed;
    }
    let surface_edge = edges(w, h, &class.iter().map(|c| c.0).collect::<Vec<_>>());
    let near_change = |i: usize| {
        let (x, y) = ((i as u32 % w) as i64, (i as u32 / w) as i64);
        (-SHADOW_EDGE_PX..=SHADOW_EDGE_PX).any(|dy| {
            (-SHADOW_EDGE_PX..=SHADOW_EDGE_PX).any(|dx| {
                let (u, v) = (x + dx, y + dy);
                u >= 0 && v >= 0 && u < w as i64 && v < h as i64 && class[(v * w as i64 + u) as usize].1 != class[i].1
            })
        })
    };
    for (label, shadowed) in [("shadowed by the objects", true), ("lit", false)] {
        let interior: Vec<&Expected> = exp.iter().filter(|e| e.shadowed == shadowed && !surface_edge[e.index] && !near_change(e.index)).collect();
        assert!(interior.len() > 400, "{label}: only {} interior pixels", interior.len());
        let errs: Vec<f32> = interior.iter().map(|e| ((Vec3::from(got[e.index]) / VIDEO) - e.ratio).abs().max_element()).collect();
        let mean = errs.iter().map(|&x| x as f64).sum::<f64>() / errs.len() as f64;
        let off = errs.iter().filter(|&&x| x > PIXEL_RATIO_TOLERANCE).count();
        let mean_ratio = interior.iter().map(|e| e.ratio.y as f64).sum::<f64>() / interior.len() as f64;
        eprintln!("{label}: {} pixels, mean expected ratio {mean_ratio:.3}, mean error {mean:.5}, {off} off by more than {PIXEL_RATIO_TOLERANCE}", interior.len());
        assert!(mean < MAX_MEAN_RATIO_ERROR, "{label}: mean ratio error {mean:.5}");
        assert!((off as f64) <= MAX_OFF_SHARE * interior.len() as f64, "{label}: {off} of {} pixels off", interior.len());
        if shadowed {
            // The lamp's share is most of the light there: a deep shadow, not the sky's c_v/c.
            assert!(mean_ratio < 0.5, "the lamp shadow keeps {mean_ratio:.3} of the footage");
        }
    }
}

#[test]
fn ground_shadows_need_the_differential_model_and_a_lit_lamp_and_say_why() {
    // Under Jensen's normal-aware darkening, and with the lamp off, the pass is skipped with its
    // reason and the real pixels are those of a compositor without lamps, to the bit.
    let (s, lamp) = scene();
    let (w, h) = (s.camera.intrinsics.width, s.camera.intrinsics.height);
    let video = VideoFrame { width: w, height: h, rgba: (0..w * h).map(|i| [0.1 + (i % w) as f32 * 1e-3, 0.2, 0.3, 1.0]).collect() };
    let r = reference(&s, Vec3::Y);
    // Real pixels next to a virtual one take some of the object's (lamp-lit) colour.
    let kind_edge = edges(w, h, &r.iter().map(|p| p.kind).collect::<Vec<_>>());
    for (label, darkening, k, why) in [("normal-aware", Darkening::Normal, K, "differential"), ("off", Darkening::Differential, [0.0; 3], "off")] {
        let mut plain = s.compositor(config());
        plain.set_darkening(darkening);
        let (want, _) = plain.render(&video, &Lighting { lamps: LampScales::NONE, ..night(PA, k) }).unwrap();
        let mut comp = s.compositor(config());
        comp.set_darkening(darkening);
        comp.set_lamps(std::slice::from_ref(&lamp), LampOptions::default()).unwrap();
        let (got, report) = comp.render(&video, &night(PA, k)).unwrap();
        let reason = report.skip_reason(pass::LAMP_GROUND).unwrap_or_else(|| panic!("{label}: lamp_ground not skipped: {report:?}"));
        assert!(reason.contains(why), "{label}: {reason}");
        let changed = (0..(w * h) as usize).filter(|&i| r[i].kind == 1 && !kind_edge[i] && got.image.data[i] != want.image.data[i]).count();
        assert_eq!(changed, 0, "{label}: {changed} real pixels changed");
    }
}

#[test]
fn objects_moved_by_the_cuts_keep_the_traced_lamp_bounce_without_their_share() {
    // The visibility cuts move the objects without tracing against them (issue 15 §2). The lamps'
    // bounce at the receivers, traced with the objects at their first place, is kept, not traced
    // again with the objects' stale BVH; their share of it is dropped (`B_v = B`), so the ground
    // they left gets back the bounce they blocked.
    let (s, lamp) = scene();
    let (w, h) = (s.camera.intrinsics.width, s.camera.intrinsics.height);
    let mut comp = s.compositor(config());
    comp.set_lamps(std::slice::from_ref(&lamp), LampOptions::default()).expect("lamps");
    let video = VideoFrame { width: w, height: h, rgba: vec![[VIDEO, VIDEO, VIDEO, 1.0]; (w * h) as usize] };
    comp.render(&video, &night(PA, K)).expect("first frame");
    let (trace_ms, without) = {
        let gb = comp.ground_bounce().expect("traced with lamp_ground");
        // The objects block some of the bounce at first (else the check below says nothing).
        let blocked = gb.with.iter().zip(&gb.without).filter(|(a, b)| a[1] < 0.99 * b[1]).count();
        assert!(blocked > 100, "only {blocked} receivers lose bounced lamp light to the objects");
        (gb.trace_ms, gb.without.clone())
    };
    let moved: Vec<(String, heliar::geometry::Mesh)> = s
        .objects
        .iter()
        .enumerate()
        .map(|(i, (name, m))| {
            let mut m = m.clone();
            if i == 0 {
                m.positions.iter_mut().for_each(|p| *p += Vec3::new(0.0, 0.0, 0.4));
            }
            (name.clone(), m)
        })
        .collect();
    let objects: Vec<(String, &heliar::geometry::Mesh)> = moved.iter().map(|(n, m)| (n.clone(), m)).collect();
    let flags: Vec<bool> = (0..objects.len()).map(|i| i == 0).collect();
    // Every field reaches every object (10 m): no object keeps a trace (`compositor::kept`).
    let reach = vec![10.0; objects.len()];
    comp.move_objects_with_cuts(&objects, &flags, &[], Box::new(|q: &[(Vec3, Vec3)]| vec![1.0; q.len()]), &reach).expect("move");
    let (_, report) = comp.render(&video, &night(PA, K)).expect("moved frame");
    assert!(report.ran(pass::LAMP_GROUND), "{report:?}");
    let gb = comp.ground_bounce().expect("kept across the move");
    assert_eq!(gb.trace_ms.to_bits(), trace_ms.to_bits(), "the bounce was traced again");
    assert!(gb.without == without, "the proxy's bounce changed");
    assert!(gb.with == gb.without, "the objects' share of the bounce is kept after a move by the cuts");
}
