//! The estimator learns the lamps (issue 16 §3): synthetic worlds lit by sun, sky and lamps of
//! known scale `k`, frames rendered with the model `ρ/π·(c·Pa + (s·cos + b)·Pd + Σ k·(E·V + B))`
//! (lamp irradiance from `lamps::model`, visibility by shadow rays, `c`, `b` and the lamp bounce
//! `B` with 256 paths against the pool's 64), and the `[[lights]]` errors of `scene.toml`.

use crate::common::*;
use glam::{DVec3, Vec3};
use heliar::estimate::lamp_bounce::bounce_irradiance;
use heliar::estimate::{EstimatorConfig, FrameEstimate, LampStatus, Status};
use heliar::geometry::ambient::{TransportQuality, transport};
use heliar::io::frames::{Linearizer, Response};
use heliar::io::image::LinearImage;
use heliar::lamps::Lamp;
use heliar::scene::lights::world_from_lamp;
use heliar::scene::{Light, LightKind, Scene, Schedule};
use rand::{Rng, SeedableRng, rngs::SmallRng};
use std::f32::consts::PI;
use std::path::Path;

const PD: [f32; 3] = [3.0, 2.8, 2.5];
const PA: [f32; 3] = [0.6, 0.7, 0.9];
/// A sodium-orange lamp's true scale (model cd → scaled radiance).
const K: [f32; 3] = [0.9, 0.6, 0.25];
/// The night sky: a tenth of a lux-like unit, against lamp light of order 1 on the lit ground.
const PA_NIGHT: [f32; 3] = [0.01, 0.012, 0.02];

fn night() -> chrono::DateTime<chrono::FixedOffset> {
    t("2024-12-21T21:00:00+01:00")
}

/// 32-bit float frames without a clip level.
fn hdr() -> Linearizer {
    Linearizer::new(&Response::Linear, 1.0, 1.0, Some(f32::INFINITY))
}

/// A point lamp of `cd` candela at `position`, with its prior `scale` and `schedule`.
fn point_lamp(name: &str, position: Vec3, cd: f64, schedule: Schedule) -> Lamp {
    let light = Light {
        name: name.into(),
        field: "lights[0]".into(),
        kind: LightKind::Point { intensity_cd: cd },
        position: position.as_dvec3(),
        world_from_lamp: world_from_lamp(DVec3::NEG_Y, 0.0).unwrap(),
        scale: 1.0,
        schedule,
    };
    Lamp::load(Path::new("scene.toml"), &light).unwrap()
}

/// Where the street lamp stands in a world built for sun direction `l`: 3.5 m up, beside the
/// box, on the camera's side of the view centre (`world` puts the camera along `perp`).
fn lamp_position(l: Vec3, side: f32) -> Vec3 {
    let lh = Vec3::new(l.x, 0.0, l.z).try_normalize().unwrap_or(Vec3::X);
    let perp = lh.cross(Vec3::Y);
    -lh * 3.0 + perp * (2.0 + side) + Vec3::Y * 3.5
}

/// The model image for the sun toward `l` (`pd` only when it is up), the sky `pa` and the lamps
/// at their true scales, with uniform multiplicative noise of relative half-width `noise`·√3.
fn render_lit(w: &World, l: Vec3, pd: [f32; 3], pa: [f32; 3], lamps: &[(&Lamp, [f32; 3])], noise: f32, seed: u64) -> LinearImage {
    let q = TransportQuality { paths: 256, max_bounces: 4 };
    let up = l.y > 0.0;
    let mut rng = SmallRng::seed_from_u64(seed);
    LinearImage::from_fn(W, H, |x, y| {
        let Some((o, d)) = w.camera.pixel_ray(x, y) else { return [0.0; 3] };
        let Some(hit) = w.ray.intersect(o.as_vec3(), d.as_vec3(), f32::MAX) else { return [0.0; 3] };
        let rho = w.ray.albedo(&hit);
        let tr = transport(&w.ray, hit.point, hit.normal, up.then_some(l), q, 7_000_000 + (y * W + x) as u64);
        let cos = hit.normal.dot(l).max(0.0);
        let s = if up && cos > 0.0 && w.ray.sees_direction(hit.point, hit.normal, l) { 1.0 } else { 0.0 };
        let mut e = tr.c * Vec3::from(pa) + if up { (Vec3::splat(s * cos) + tr.b) * Vec3::from(pd) } else { Vec3::ZERO };
        for (lamp, k) in lamps {
            let to = lamp.light.position.as_vec3() - hit.point;
            let dist = to.length();
            let seen = !w.ray.occluded(hit.point + hit.normal * 1e-3, to / dist, dist - 0.02);
            let mut irr = if seen { lamp.irradiance(hit.point.as_dvec3(), hit.normal.as_dvec3()) } else { [0.0; 3] };
            // The lamp's light reflected by the world (the pool traces it with 64 paths).
            let b = bounce_irradiance(lamp, &w.ray, hit.point, hit.normal, q, 9_000_000 + (y * W + x) as u64);
            irr = std::array::from_fn(|c| irr[c] + b[c]);
            e += Vec3::new(irr[0] as f32, irr[1] as f32, irr[2] as f32) * Vec3::from(*k);
        }
        let n = 1.0 + noise * (rng.random::<f32>() * 2.0 - 1.0) * 1.732;
        (rho / PI * e * n).to_array()
    })
}

fn config() -> EstimatorConfig {
    EstimatorConfig { pool_size: 3000, ..EstimatorConfig::default() }
}

fn k_err(e: &FrameEstimate, i: usize, truth: [f32; 3]) -> f64 {
    rel_err(e.lamps[i].k, truth)
}

fn show(name: &str, e: &FrameEstimate) {
    eprintln!("{name}: status {:?}, Pd {:?}, Pa {:?}, κ {:?}, samples {:?}", e.status, e.pd, e.pa, e.condition_number, e.samples);
    for l in &e.lamps {
        eprintln!("  lamp {}: {:?} k {:?} ± {:?} on {} samples, κ {:?}, {:?}", l.name, l.status, l.k, l.k_se, l.samples, l.condition_number, l.reason);
    }
}

#[test]
fn k_is_recovered_at_night_without_and_with_noise() {
    let time = night();
    let l = sun_dir(&time);
    assert!(l.y < 0.0, "the sun must be down");
    let w = world(WorldSpec::default(), l);
    let lamp = point_lamp("street", lamp_position(l, 0.0), 40.0, Schedule::Always);
    for (noise, tol) in [(0.0, 0.01), (0.02, 0.05)] {
        let mut est = estimator(&w, config());
        est.set_lamps(vec![lamp.clone()]);
        let img = render_lit(&w, l, PD, PA_NIGHT, &[(&lamp, K)], noise, 11);
        let e = est.estimate(0, &time, &frame(img), &hdr()).unwrap();
        show(&format!("night, noise {noise}"), &e);
        assert_eq!(e.status, Status::Night);
        assert_eq!(e.lamps.len(), 1);
        assert_eq!(e.lamps[0].status, LampStatus::Fitted, "{e:?}");
        assert!(e.lamps[0].samples >= 100, "{e:?}");
        // Without noise what is left is the pool's 64-path `c` against the frames' 256-path
        // one, on a sky 50× dimmer than the lamp: 1%. With 2% pixel noise over ~500 samples, 5%.
        assert!(k_err(&e, 0, K) < tol, "k {:?} vs {K:?}", e.lamps[0].k);
        let se = e.lamps[0].k_se.unwrap();
        assert!(se.iter().zip(K).all(|(s, k)| *s >= 0.0 && *s < 0.05 * k as f64), "{se:?}");
        // The JSON line carries the lamp.
        let line = serde_json::to_string(&e).unwrap();
        assert!(line.contains("\"lamps\":[{\"name\":\"street\",\"status\":\"fitted\",\"k\":["), "{line}");
    }
}

#[test]
fn a_lamp_switched_on_mid_sequence() {
    let t0 = night();
    let l = sun_dir(&t0);
    let w = world(WorldSpec::default(), l);
    // on from 2 s after the first frame
    let schedule = Schedule::Intervals(vec![(Some(heliar::scene::lights::Instant::SecondsFromStart(2.0)), None)]);
    let lamp = point_lamp("street", lamp_position(l, 0.0), 40.0, schedule);
    let mut est = estimator(&w, config());
    est.set_lamps(vec![lamp.clone()]);
    for i in 0..4 {
        let time = t0 + chrono::Duration::seconds(i);
        let on = i >= 2;
        let lamps: Vec<(&Lamp, [f32; 3])> = if on { vec![(&lamp, K)] } else { vec![] };
        let img = render_lit(&w, l, PD, PA_NIGHT, &lamps, 0.01, 20 + i as u64);
        let e = est.estimate(i as usize, &time, &frame(img), &hdr()).unwrap();
        show(&format!("frame {i}"), &e);
        // the sky alone, then sky and lamp: Pa within 5% throughout (1% noise)
        assert!(rel_err(e.pa.unwrap(), PA_NIGHT) < 0.05, "{e:?}");
        if on {
            assert_eq!(e.lamps[0].status, LampStatus::Fitted, "{e:?}");
            assert!(k_err(&e, 0, K) < 0.05, "{e:?}");
            // The smoother restarts at the switch-on: its first value is the first fit, and the
            // blend of the fits after it stays within the fits' 5%.
            let ks = e.lamps[0].k_smoothed.expect("smoothed k while on");
            if i == 2 {
                assert_eq!(ks, e.lamps[0].k);
            }
            assert!(rel_err(ks, K) < 0.05, "{ks:?}");
        } else {
            assert_eq!(e.lamps[0].status, LampStatus::Off, "{e:?}");
            assert_eq!(e.lamps[0].k_smoothed, None, "an off lamp has no smoothed k");
            assert_eq!(e.lamps[0].k, [1.0; 3], "an off lamp reports its prior");
            assert!(e.lamps[0].reason.as_deref().unwrap().contains("schedule"));
        }
    }
}

#[test]
fn a_lamp_that_saturates_its_pixels() {
    let time = night();
    let l = sun_dir(&time);
    let w = world(WorldSpec::default(), l);
    let lamp = point_lamp("street", lamp_position(l, 0.0), 40.0, Schedule::Always);
    let mut img = render_lit(&w, l, PD, PA_NIGHT, &[(&lamp, K)], 0.01, 31);
    // The sensor clips at the 80th percentile of the red channel: the pool of light around the
    // lamp's foot is lost.
    let mut red: Vec<f32> = img.data.iter().map(|p| p[0]).filter(|v| *v > 0.0).collect();
    red.sort_by(f32::total_cmp);
    let clip = red[red.len() * 4 / 5];
    img.data.iter_mut().for_each(|p| p.iter_mut().for_each(|c| *c = c.min(clip)));
    let lin = Linearizer::new(&Response::Linear, 1.0, 1.0, Some(clip));
    let mut est = estimator(&w, config());
    est.set_lamps(vec![lamp.clone()]);
    let e = est.estimate(0, &time, &frame(img), &lin).unwrap();
    show("saturated", &e);
    assert!(e.samples.clipped >= 10, "the clip level must cut into the samples: {:?}", e.samples);
    assert_eq!(e.lamps[0].status, LampStatus::Fitted, "{e:?}");
    // Clipped samples are dropped and their octave of lamp light censored; the rest fit k.
    assert!(k_err(&e, 0, K) < 0.05, "{e:?}");
}

#[test]
fn two_lamps_lighting_the_same_surfaces_are_not_separable() {
    let time = night();
    let l = sun_dir(&time);
    let w = world(WorldSpec::default(), l);
    // two lamps 5 cm apart on one pole: their light is the same shape on every surface
    let a = point_lamp("left", lamp_position(l, 0.0), 40.0, Schedule::Always);
    let b = point_lamp("right", lamp_position(l, 0.05), 40.0, Schedule::Always);
    let kb = [0.5, 0.4, 0.2];
    let img = render_lit(&w, l, PD, PA_NIGHT, &[(&a, K), (&b, kb)], 0.01, 41);
    let mut est = estimator(&w, config());
    est.set_lamps(vec![a, b]);
    let e = est.estimate(0, &time, &frame(img), &hdr()).unwrap();
    show("two lamps", &e);
    for (i, other) in [(0, "right"), (1, "left")] {
        let r = &e.lamps[i];
        assert_eq!(r.status, LampStatus::NotSeparable, "{e:?}");
        assert!(r.reason.as_deref().unwrap().contains(other), "{r:?}");
        // the condition number that says so: the two columns before they were merged
        assert!(r.condition_number.unwrap() > EstimatorConfig::default().max_condition, "{r:?}");
    }
    // What is fitted is their sum: together the two lamps give the light of both.
    let sum: [f64; 3] = std::array::from_fn(|c| e.lamps[0].k[c] + e.lamps[1].k[c]);
    let truth: [f32; 3] = std::array::from_fn(|c| K[c] + kb[c]);
    assert!(rel_err(sum, truth) < 0.05, "{sum:?} vs {truth:?}");
    assert!(rel_err(e.pa.unwrap(), PA_NIGHT) < 0.05, "{e:?}");
}

#[test]
fn dusk_with_sun_sky_and_lamp() {
    let time = time_at_elevation(6.0);
    let l = sun_dir(&time);
    let w = world(WorldSpec::default(), l);
    let lamp = point_lamp("street", lamp_position(l, 0.0), 40.0, Schedule::Always);
    // dusk: the sun a tenth of the day's, the sky a fifth
    let (pd, pa) = (PD.map(|v| v * 0.1), PA.map(|v| v * 0.2));
    let img = render_lit(&w, l, pd, pa, &[(&lamp, K)], 0.01, 51);
    // A second lamp under the ground lights no sample: it keeps its prior scale.
    let mut buried = point_lamp("buried", lamp_position(l, 0.0) - Vec3::Y * 5.0, 40.0, Schedule::Always);
    buried.light.scale = 0.3;
    let mut est = estimator(&w, config());
    est.set_lamps(vec![lamp, buried]);
    let e = est.estimate(0, &time, &frame(img), &hdr()).unwrap();
    show("dusk", &e);
    assert_eq!((e.lamps[1].status, e.lamps[1].samples, e.lamps[1].k), (LampStatus::Unreached, 0, [0.3; 3]), "{e:?}");
    assert!(e.lamps[1].reason.as_deref().unwrap().contains("prior"));
    assert_eq!(e.status, Status::Ok, "{e:?}");
    assert!(rel_err(e.pd.unwrap(), pd) < 0.05, "{e:?}");
    assert!(rel_err(e.pa.unwrap(), pa) < 0.05, "{e:?}");
    assert_eq!(e.lamps[0].status, LampStatus::Fitted);
    assert!(k_err(&e, 0, K) < 0.05, "{e:?}");
}

#[test]
fn without_lights_the_report_has_no_lamps() {
    let time = afternoon();
    let l = sun_dir(&time);
    let w = world(WorldSpec::default(), l);
    let mut est = estimator(&w, config());
    est.set_lamps(Vec::new());
    let e = est.estimate(0, &time, &frame(render(&w, l, PD, PA, 0.01, 1)), &hdr()).unwrap();
    assert!(e.lamps.is_empty());
    assert!(!serde_json::to_string(&e).unwrap().contains("lamps"));
}

/// The courtyard's small files with `lights` appended to `scene.toml`.
fn with_lights(name: &str, lights: &str) -> std::path::PathBuf {
    let d = scratch_courtyard(name);
    let m = d.join("scene.toml");
    let text = std::fs::read_to_string(&m).unwrap();
    std::fs::write(&m, format!("{text}\n{lights}")).unwrap();
    d
}

fn load_err(name: &str, lights: &str) -> String {
    let d = with_lights(name, lights);
    let e = Scene::load(&d).expect_err("must be rejected").to_string();
    std::fs::remove_dir_all(&d).ok();
    assert!(e.contains("scene.toml"), "{e}");
    e
}

#[test]
fn scene_lights_parse_and_their_errors_name_the_field() {
    let ok = "[[lights]]\nname = \"street\"\nkind = \"spot\"\nintensity_cd = 500\ninner_deg = 20\nouter_deg = 35\nposition = [1, 4, 0]\n\
              schedule = [{ on = \"2024-06-21T21:30:00+02:00\", off = 3600 }]\n\n[[lights]]\nkind = \"point\"\nintensity_cd = 10\nposition = [0, 3, 0]\nscale = 2.5\n";
    let d = with_lights("lights-ok", ok);
    let s = Scene::load(&d).unwrap();
    assert_eq!(s.lights.len(), 2);
    assert_eq!(s.lights[1].name, "lights[1]");
    assert_eq!(s.lights[1].scale, 2.5);
    assert!(matches!(s.lights[0].kind, LightKind::Spot { outer_deg, .. } if outer_deg == 35.0));
    assert!(matches!(&s.lights[0].schedule, Schedule::Intervals(v) if v.len() == 1));
    assert_eq!(Lamp::load_all(&d.join("scene.toml"), &s.lights).unwrap().len(), 2);
    std::fs::remove_dir_all(&d).ok();

    let e = load_err("lights-nofile", "[[lights]]\nkind = \"ies\"\nprofile = \"lamps/street.ies\"\nposition = [0, 4, 0]\n");
    assert!(e.contains("lights[0].profile") && e.contains("no such file"), "{e}");
    let e = load_err("lights-kind", "[[lights]]\nkind = \"torch\"\nposition = [0, 4, 0]\n");
    assert!(e.contains("lights[0].kind") && e.contains("'torch'"), "{e}");
    let e = load_err("lights-outer", "[[lights]]\nkind = \"spot\"\nintensity_cd = 5\ninner_deg = 10\nposition = [0, 4, 0]\n");
    assert!(e.contains("lights[0].outer_deg") && e.contains("needs it"), "{e}");
    let e = load_err("lights-aim", "[[lights]]\nkind = \"point\"\nintensity_cd = 5\nposition = [0, 4, 0]\naim = [0, 0, 0]\n");
    assert!(e.contains("lights[0].aim"), "{e}");
    let e = load_err("lights-scale", &format!("{ok}\n[[lights]]\nkind = \"point\"\nintensity_cd = 5\nposition = [0, 4, 0]\nscale = -1\n"));
    assert!(e.contains("lights[2].scale") && e.contains("positive"), "{e}");
    let e = load_err("lights-schedule", "[[lights]]\nkind = \"point\"\nintensity_cd = 5\nposition = [0, 4, 0]\nschedule = [{ on = \"dusk\" }]\n");
    assert!(e.contains("lights[0].schedule[0].on") && e.contains("RFC 3339"), "{e}");
    let e = load_err("lights-unknown", "[[lights]]\nkind = \"point\"\nintensity_cd = 5\nposition = [0, 4, 0]\ncolour = 3\n");
    assert!(e.contains("colour"), "{e}");
    // More lamps than a frame's lighting carries a scale for: refused, not left dark.
    let many = |n: usize| (0..n).map(|i| format!("[[lights]]\nkind = \"point\"\nintensity_cd = 5\nposition = [{i}, 4, 0]\n")).collect::<String>();
    let max = heliar::scene::lights::MAX_LIGHTS;
    let e = load_err("lights-many", &many(max + 1));
    assert!(e.contains("`lights`") && e.contains(&format!("{} lights are declared", max + 1)), "{e}");
    let d = with_lights("lights-max", &many(max));
    assert_eq!(Scene::load(&d).unwrap().lights.len(), max);
    std::fs::remove_dir_all(&d).ok();

    // A profile that exists but is not an IES file: the scene loads, the lamp's model names the
    // field and the file's line.
    let d = with_lights("lights-badies", "[[lights]]\nkind = \"ies\"\nprofile = \"street.ies\"\nposition = [0, 4, 0]\n");
    std::fs::write(d.join("street.ies"), "IESNA:LM-63-2002\nTILT=NONE\n1 1000 1 x 1 1 2 0.5 0.5 0\n").unwrap();
    let s = Scene::load(&d).unwrap();
    let e = Lamp::load_all(&d.join("scene.toml"), &s.lights).unwrap_err().to_string();
    assert!(e.contains("scene.toml: field `lights[0].profile`") && e.contains("street.ies:"), "{e}");
    std::fs::remove_dir_all(&d).ok();
}
