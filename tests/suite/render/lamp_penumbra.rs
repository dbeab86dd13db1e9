//! The penumbra of a lamp with an area (issue 16 §3: real lamps are not points; the luminous
//! opening of an IES or LDT file, `Lamp::emitter_radius_m`): the objects' lamp shadow on the
//! real ground through the composite's ratio `L₁ / L₀` (as in `lamp_ground`) against a CPU
//! reference whose visibility is the fraction of the lamp's disc seen from each pixel's surface
//! point, by 256 shadow rays to points spread over the disc (facing the point, a round lamp).
//! The GPU's penumbra is PCSS (`spot_soft_visibility`, shaders/common/lamp_spots.wgsl): a blocker
//! search, then a box filter of the penumbra's width, so it is an approximation of the disc's
//! visibility whose error is measured here, next to the hard shadow's.

use super::lamps::{K, config, setup};
use super::support::*;
use glam::Vec3;
use heliar::geometry::raycast::{RAY_EPSILON_M, RayScene};
use heliar::lamps::model::Model;
use heliar::lamps::{Goniometric, Lamp, PhotometricType, Symmetry};
use heliar::lighting::{LampScales, Lighting};
use heliar::render::VideoFrame;
use heliar::render::frame::pass;
use heliar::render::lamps::LampOptions;
use heliar::scene::lights::world_from_lamp;
use heliar::scene::{Light, LightKind, Schedule};
use std::path::PathBuf;

/// Sky light at night, as in `lamp_ground`: the lamp's share decides the darkening.
const PA: f32 = 0.3;
const VIDEO: f32 = 0.5;
/// The lamp's opening: a disc of 0.25 m radius 3.9 m from the objects' shadow (a large
/// luminaire, so the penumbra spans many pixels at 320 × 240).
const RADIUS_M: f64 = 0.25;
/// Shadow rays per pixel over the disc (16 rings × 16 sectors).
const DISC_RAYS: usize = 16;
/// Mean error of `output / video` over the penumbra's pixels (the disc 5–95% visible, 1 852
/// pixels) allowed with the penumbra on. PCSS's box filter against the disc's exact visibility,
/// one mean blocker depth per pixel and the map's texels: measured 0.039, against 0.147 for the
/// hard shadow of the lamp's centre.
const MAX_PENUMBRA_ERROR: f64 = 0.05;
/// Umbra (3 464 pixels; measured 0.0033: the box filter reaches a little past the penumbra's
/// inner edge, which the disc does not) and lit pixels (59 560; measured 0.0001).
const MAX_UMBRA_ERROR: f64 = 0.006;
const MAX_LIT_ERROR: f64 = 0.001;

fn night() -> Lighting {
    Lighting { sun_dir: Vec3::Y, above_horizon: false, pd: Vec3::ZERO, pa: Vec3::splat(PA), sky: heliar::lighting::FrameSky::Declared, lamps: LampScales::from_slice(&[K]) }
}

/// A broad downlight of 600 cd out to 80° from its aim, with an opening of [`RADIUS_M`].
fn area_lamp(position: Vec3, at: Vec3) -> Lamp {
    let v: Vec<f64> = (0..=18).map(|i| i as f64 * 5.0).collect();
    let table = Goniometric::from_fn(PhotometricType::C, Symmetry::Rotational, &[0.0], &v, |_, v| if v <= 80.0 { 600.0 } else { 600.0 * (90.0 - v) / 10.0 }).expect("table");
    let light = Light {
        name: "lamp".into(),
        field: "lights[0]".into(),
        kind: LightKind::Ies { path: PathBuf::from("lamp.ies") },
        position: position.as_dvec3(),
        world_from_lamp: world_from_lamp((at - position).as_dvec3(), 0.0).expect("aim"),
        scale: 1.0,
        schedule: Schedule::Always,
    };
    Lamp { light, model: Model::Table(table.with_opening(RADIUS_M)) }
}

/// The fraction of the disc of `radius` at `centre`, facing `p`, that `p` sees past `scenes`.
fn disc_visibility(p: Vec3, n: Vec3, centre: Vec3, radius: f32, scenes: &[&RayScene]) -> f32 {
    let axis = (centre - p).normalize();
    let u = axis.any_orthonormal_vector();
    let w = axis.cross(u);
    let o = p + n * RAY_EPSILON_M;
    let mut seen = 0;
    for ring in 0..DISC_RAYS {
        for sector in 0..DISC_RAYS {
            // Equal-area rings, sectors offset per ring.
            let r = radius * ((ring as f32 + 0.5) / DISC_RAYS as f32).sqrt();
            let phi = std::f32::consts::TAU * (sector as f32 + 0.5 * (ring % 2) as f32) / DISC_RAYS as f32;
            let q = centre + r * (phi.cos() * u + phi.sin() * w);
            let d = q - o;
            let dist = d.length();
            let l = d / dist;
            if n.dot(l) > 0.0 && !scenes.iter().any(|s| s.occluded(o, l, dist - 0.02)) {
                seen += 1;
            }
        }
    }
    seen as f32 / (DISC_RAYS * DISC_RAYS) as f32
}

/// Per real pixel: the reference ratio and the disc's visibility past the objects.
fn expected(s: &Setup, lamp: &Lamp, comp: &heliar::render::Compositor) -> Vec<(usize, Vec3, f32)> {
    let r = reference(s, Vec3::Y);
    let proxy = RayScene::new(s.proxy.clone());
    let objects: Vec<RayScene> = s.objects.iter().map(|(_, m)| RayScene::new(m.clone())).collect();
    let mut both: Vec<&RayScene> = objects.iter().collect();
    both.push(&proxy);
    let rec = comp.receivers();
    let centre = lamp.light.position.as_vec3();
    let k = Vec3::from(K);
    r.iter()
        .enumerate()
        .filter(|(_, p)| p.kind == 1)
        .map(|(i, p)| {
            let e = lamp.irradiance(p.point.as_dvec3(), p.normal.as_dvec3());
            let e = k * Vec3::new(e[0] as f32, e[1] as f32, e[2] as f32);
            let v_proxy = disc_visibility(p.point, p.normal, centre, RADIUS_M as f32, &[&proxy]);
            let v_both = disc_visibility(p.point, p.normal, centre, RADIUS_M as f32, &both);
            let c = Vec3::from_slice(&rec.ambient[i][..3]);
            let c_v = if rec.ambient_with[i][3] > 0.5 { Vec3::from_slice(&rec.ambient_with[i][..3]) } else { c };
            let ratio = (c_v * PA + e * v_both) / (c * PA + e * v_proxy);
            (i, ratio, if v_proxy > 0.0 { v_both / v_proxy } else { 1.0 })
        })
        .collect()
}

#[test]
fn an_area_lamps_object_shadow_has_the_penumbra_of_its_disc() {
    let s = setup(false, [0.6, 2.4, 3.4]);
    let lamp = area_lamp(Vec3::new(2.5, 3.0, 0.0), Vec3::new(-0.5, 0.0, 0.0));
    assert_eq!(lamp.emitter_radius_m(), RADIUS_M);
    let (w, h) = (s.camera.intrinsics.width, s.camera.intrinsics.height);
    let video = VideoFrame { width: w, height: h, rgba: vec![[VIDEO, VIDEO, VIDEO, 1.0]; (w * h) as usize] };
    // The lamps' bounce is left out of both sides: what is compared is the direct light's visibility.
    let options = |soft| LampOptions { bounce: false, ground_bounce: false, soft_shadows: soft, ..LampOptions::default() };
    let mut runs = Vec::new();
    for soft in [true, false] {
        let mut comp = s.compositor(config());
        comp.set_lamps(std::slice::from_ref(&lamp), options(soft)).expect("lamps");
        let (frame, report) = comp.render(&video, &night()).expect("render");
        assert!(report.ran(pass::LAMP_GROUND), "{report:?}");
        runs.push((frame.image.data, comp));
    }
    let exp = expected(&s, &lamp, &runs[0].1);
    // Pixels whose surface changes nearby (ground to wall, real to virtual) are left out.
    let r = reference(&s, Vec3::Y);
    let surface_edge = edges(w, h, &r.iter().map(|p| p.tri).collect::<Vec<_>>());
    let err = |data: &[[f32; 3]], (i, ratio, _): &(usize, Vec3, f32)| ((Vec3::from(data[*i]) / VIDEO) - *ratio).abs().max_element() as f64;
    let mean = |v: &[f64]| v.iter().sum::<f64>() / v.len().max(1) as f64;
    let classes: [(&str, fn(f32) -> bool); 3] = [("penumbra", |v| v > 0.05 && v < 0.95), ("umbra", |v| v == 0.0), ("lit", |v| v == 1.0)];
    let mut measured = Vec::new();
    for (label, class) in classes {
        let px: Vec<&(usize, Vec3, f32)> = exp.iter().filter(|e| class(e.2) && !surface_edge[e.0]).collect();
        assert!(px.len() > 150, "{label}: only {} pixels", px.len());
        let soft = mean(&px.iter().map(|e| err(&runs[0].0, e)).collect::<Vec<_>>());
        let hard = mean(&px.iter().map(|e| err(&runs[1].0, e)).collect::<Vec<_>>());
        eprintln!("{label}: {} pixels, mean |ratio error| soft {soft:.4}, hard {hard:.4}", px.len());
        measured.push((label, soft, hard));
    }
    let (_, soft, hard) = measured[0];
    assert!(soft < MAX_PENUMBRA_ERROR, "penumbra: {soft:.4}");
    assert!(soft < 0.5 * hard, "the penumbra is no closer to the disc's ({soft:.4}) than the hard shadow ({hard:.4})");
    assert!(measured[1].1 < MAX_UMBRA_ERROR, "umbra: {:.5}", measured[1].1);
    assert!(measured[2].1 < MAX_LIT_ERROR, "lit: {:.5}", measured[2].1);
}
