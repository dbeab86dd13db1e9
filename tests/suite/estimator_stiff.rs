//! The stiff and extreme cases of the estimator (issue: foundation §4). Every case states what
//! must come out; none may give NaN, negative intensities or an arbitrary split.

use crate::common::*;
use heliar::estimate::{EstimatorConfig, Fallback, FrameEstimate, Status};
use heliar::io::frames::{Linearizer, Response};
use rand::{Rng, SeedableRng, rngs::SmallRng};

const PD: [f32; 3] = [3.0, 2.8, 2.5];
const PA: [f32; 3] = [0.6, 0.7, 0.9];

/// 32-bit float frames without a clip level: the cases below span values up to 4e5.
fn hdr() -> Linearizer {
    Linearizer::new(&Response::Linear, 1.0, 1.0, Some(f32::INFINITY))
}

/// The default HDR linearisation (half-float frames: 65504 and above is clipped).
fn half() -> Linearizer {
    Linearizer::new(&Response::Linear, 1.0, 1.0, None)
}

/// Nothing in a report is NaN, and every intensity is non-negative.
fn sane(e: &FrameEstimate) {
    for v in [e.pd, e.pa, e.total_irradiance].into_iter().flatten() {
        assert!(v.iter().all(|x| x.is_finite() && *x >= 0.0), "{e:?}");
    }
    for v in [e.pd_se, e.pa_se].into_iter().flatten() {
        assert!(v.iter().all(|x| !x.is_nan() && *x >= 0.0), "{e:?}");
    }
    if let Some(c) = e.condition_number {
        assert!(c >= 1.0 && !c.is_nan());
    }
    // The JSON line is valid JSON (no NaN tokens).
    let line = serde_json::to_string(e).unwrap();
    assert!(serde_json::from_str::<serde_json::Value>(&line).is_ok());
}

/// Prints the worst relative errors, so margins against the 3% tolerances can be read off
/// `cargo test -- --nocapture`.
fn show(name: &str, e: &FrameEstimate, pd: [f32; 3], pa: [f32; 3]) {
    let f = |v: Option<[f64; 3]>, t| v.map(|v| format!("{:.2}%", 100.0 * rel_err(v, t))).unwrap_or("-".into());
    eprintln!("{name}: status {:?}, Pd err {}, Pa err {}, κ {:?}", e.status, f(e.pd, pd), f(e.pa, pa), e.condition_number);
}

fn run_one(spec: WorldSpec, time: &chrono::DateTime<chrono::FixedOffset>, pd: [f32; 3], pa: [f32; 3]) -> FrameEstimate {
    let l = sun_dir(time);
    let w = world(spec, l);
    let img = render(&w, l, pd, pa, 0.01, 1);
    let mut est = estimator(&w, EstimatorConfig::default());
    let e = est.estimate(0, time, &frame(img), &hdr()).unwrap();
    sane(&e);
    show(&format!("{spec:?}"), &e, pd, pa);
    e
}

#[test]
fn nominal_scene_is_recovered() {
    let e = run_one(WorldSpec::default(), &afternoon(), PD, PA);
    assert_eq!(e.status, Status::Ok, "{e:?}");
    assert!(rel_err(e.pd.unwrap(), PD) < 0.03, "{e:?}");
    assert!(rel_err(e.pa.unwrap(), PA) < 0.03, "{e:?}");
    // Conditioning is reported and moderate for a scene with light and shadow.
    let c = e.condition_number.unwrap();
    assert!(c > 1.0 && c < 10.0, "condition {c}");
}

#[test]
fn all_sunlit_on_one_plane_is_not_split_arbitrarily() {
    // Open ground only: every sample lit, same normal, same c → Pd and Pa are inseparable.
    let spec = WorldSpec { wall: None, occluder: false, ..Default::default() };
    let time = afternoon();
    let e = run_one(spec, &time, PD, PA);
    assert_eq!(e.status, Status::SunNotSeparable, "{e:?}");
    assert!(e.condition_number.unwrap() > 12.0);
    assert_eq!(e.fallback, Some(Fallback::TotalIrradiance));
    assert!(e.pd.is_none() && e.pa.is_none());
    // What is reported is the irradiance on the ground: Pa·1 + Pd·cos(zenith).
    let cos = sun_dir(&time).y;
    let total = e.total_irradiance.unwrap();
    for c in 0..3 {
        let want = PA[c] + PD[c] * cos;
        assert!((total[c] - want as f64).abs() < 0.02 * want as f64, "{total:?} vs {want}");
    }
}

#[test]
fn inseparable_frame_holds_the_last_split() {
    // Frame 0 sees light and shadow; in frame 1 everything but the sunlit ground is unusable
    // (NaN), and the light dimmed by 20% at the same ratio: the held split gives both back.
    let time = afternoon();
    let l = sun_dir(&time);
    let w = world(WorldSpec::default(), l);
    let mut est = estimator(&w, EstimatorConfig::default());
    let e0 = est.estimate(0, &time, &frame(render(&w, l, PD, PA, 0.01, 1)), &hdr()).unwrap();
    assert_eq!(e0.status, Status::Ok);
    let (pd1, pa1) = (PD.map(|v| v * 0.8), PA.map(|v| v * 0.8));
    let mut img = render(&w, l, pd1, pa1, 0.01, 2);
    let lit = lit_mask(&w, l);
    for (i, p) in img.data.iter_mut().enumerate() {
        // Keep only sunlit, upward-facing pixels (the ground).
        let up = w.camera.pixel_ray(i as u32 % W, i as u32 / W).and_then(|(o, d)| w.ray.intersect(o.as_vec3(), d.as_vec3(), f32::MAX)).is_some_and(|h| h.normal.y > 0.9);
        if !(lit[i] && up) {
            *p = [f32::NAN; 3];
        }
    }
    let e1 = est.estimate(1, &time, &frame(img), &hdr()).unwrap();
    sane(&e1);
    assert_eq!(e1.status, Status::SunNotSeparable, "{e1:?}");
    assert_eq!(e1.fallback, Some(Fallback::HeldSplit));
    assert!(rel_err(e1.pd.unwrap(), pd1) < 0.03, "{e1:?}");
    assert!(rel_err(e1.pa.unwrap(), pa1) < 0.03, "{e1:?}");
}

#[test]
fn all_samples_in_shadow_give_pa_and_an_unobservable_pd() {
    let time = afternoon();
    let l = sun_dir(&time);
    let w = world(WorldSpec::default(), l);
    let lit = lit_mask(&w, l);
    let mut img = render(&w, l, PD, PA, 0.01, 3);
    for (i, p) in img.data.iter_mut().enumerate() {
        if lit[i] {
            *p = [f32::NAN; 3];
        }
    }
    let mut est = estimator(&w, EstimatorConfig::default());
    let e = est.estimate(0, &time, &frame(img.clone()), &hdr()).unwrap();
    sane(&e);
    assert_eq!(e.status, Status::SunNotSeparable, "{e:?}");
    assert_eq!(e.fallback, Some(Fallback::PdUnobservable));
    assert!(e.pd.is_none());
    // Shadowed ground still gets sun light bounced off the lit box and wall; where that bounce
    // varies across the samples it is fitted separately, so Pa is not biased by it.
    assert!(rel_err(e.pa.unwrap(), PA) < 0.03, "{e:?}");

    // With a previous frame, Pd is held and its bounce removed: Pa within 3%.
    let mut est = estimator(&w, EstimatorConfig::default());
    est.estimate(0, &time, &frame(render(&w, l, PD, PA, 0.01, 4)), &hdr()).unwrap();
    let e = est.estimate(1, &time, &frame(img), &hdr()).unwrap();
    assert_eq!(e.fallback, Some(Fallback::HeldPd));
    assert!(rel_err(e.pa.unwrap(), PA) < 0.03, "{e:?}");
    assert!(rel_err(e.pd.unwrap(), PD) < 0.03, "{e:?}");
}

#[test]
fn grazing_sun_two_degrees_above_the_horizon() {
    // The ground sees the sun at cos ≈ 0.035; the wall faces it. Pd comes from the wall.
    let time = time_at_elevation(2.0);
    let e = run_one(WorldSpec::default(), &time, PD, PA);
    assert_eq!(e.status, Status::Ok, "{e:?}");
    assert!(rel_err(e.pd.unwrap(), PD) < 0.03, "{e:?}");
    assert!(rel_err(e.pa.unwrap(), PA) < 0.03, "{e:?}");
}

#[test]
fn sun_exactly_on_the_horizon_plane_gives_no_nan() {
    // Apparent elevation 0.05°: the ground is lit edge-on (cos ≈ 0.001).
    let time = time_at_elevation(0.05);
    let e = run_one(WorldSpec::default(), &time, PD, PA);
    assert!(matches!(e.status, Status::Ok | Status::SunNotSeparable), "{e:?}");
    assert!(rel_err(e.pa.unwrap(), PA) < 0.05, "{e:?}");
}

#[test]
fn sun_below_the_horizon_is_night() {
    let time = t("2024-12-21T23:00:00+01:00");
    let e = run_one(WorldSpec::default(), &time, PD, PA);
    assert_eq!(e.status, Status::Night, "{e:?}");
    assert!(!e.sun.above_horizon);
    assert_eq!(e.pd, Some([0.0; 3]));
    assert!(rel_err(e.pa.unwrap(), PA) < 0.03, "{e:?}");
}

#[test]
fn overcast_gives_zero_not_negative_direct_light() {
    let e = run_one(WorldSpec::default(), &afternoon(), [0.0; 3], [1.5, 1.6, 1.7]);
    assert_eq!(e.status, Status::NoDirectSun, "{e:?}");
    let pd = e.pd.unwrap();
    assert!(pd.iter().all(|&v| v >= 0.0 && v < 0.02 * 1.6), "{pd:?}");
    assert!(rel_err(e.pa.unwrap(), [1.5, 1.6, 1.7]) < 0.03, "{e:?}");
}

#[test]
fn clipped_pixels_are_left_out_and_partly_clipped_surfaces_censored() {
    let time = afternoon();
    let l = sun_dir(&time);
    // A bright ground whose sunlit part clips at 0.4, while the wall (≈ 0.28) and every shadow
    // stay below.
    let w = world(WorldSpec { ground: [0.6, 0.56, 0.5], ..Default::default() }, l);
    let img = render(&w, l, PD, PA, 0.01, 5);
    let lin = Linearizer::new(&Response::Linear, 1.0, 1.0, Some(0.4));
    let mut est = estimator(&w, EstimatorConfig::default());
    let e = est.estimate(0, &time, &frame(img.clone()), &lin).unwrap();
    sane(&e);
    assert!(e.samples.clipped > 50, "{:?}", e.samples);
    assert!(rel_err(e.pd.unwrap(), PD) < 0.03, "{e:?}");
    assert!(rel_err(e.pa.unwrap(), PA) < 0.03, "{e:?}");
    // Everything clipped: saturated, and no NaN.
    let lin = Linearizer::new(&Response::Linear, 1.0, 1.0, Some(1e-6));
    let e = est.estimate(1, &time, &frame(img), &lin).unwrap();
    sane(&e);
    assert_eq!(e.status, Status::Saturated, "{e:?}");
}

#[test]
fn thirty_percent_outliers() {
    let time = afternoon();
    let l = sun_dir(&time);
    let w = world(WorldSpec::default(), l);
    let mut img = render(&w, l, PD, PA, 0.01, 6);
    let mut rng = SmallRng::seed_from_u64(9);
    for p in img.data.iter_mut() {
        if rng.random_bool(0.3) {
            let k = if rng.random_bool(0.5) { rng.random_range(0.1..0.6) } else { rng.random_range(1.6..5.0) };
            *p = p.map(|v| v * k);
        }
    }
    let mut est = estimator(&w, EstimatorConfig::default());
    let e = est.estimate(0, &time, &frame(img), &hdr()).unwrap();
    sane(&e);
    assert_eq!(e.status, Status::Ok);
    assert!(rel_err(e.pd.unwrap(), PD) < 0.03, "{e:?}");
    assert!(rel_err(e.pa.unwrap(), PA) < 0.03, "{e:?}");
    assert!(e.samples.inliers < e.samples.usable * 8 / 10, "{:?}", e.samples);
}

#[test]
fn albedo_near_zero() {
    let spec = WorldSpec { ground: [0.004, 0.003, 0.002], wall: Some([0.005, 0.004, 0.003]), ..Default::default() };
    let e = run_one(spec, &afternoon(), PD, PA);
    assert_eq!(e.status, Status::Ok, "{e:?}");
    assert!(rel_err(e.pd.unwrap(), PD) < 0.03, "{e:?}");
    assert!(rel_err(e.pa.unwrap(), PA) < 0.03, "{e:?}");
}

#[test]
fn one_dark_channel() {
    // No blue light at all: blue comes out as exactly zero, the other channels as usual.
    let (pd, pa) = ([3.0, 2.8, 0.0], [0.6, 0.7, 0.0]);
    let e = run_one(WorldSpec::default(), &afternoon(), pd, pa);
    assert_eq!(e.status, Status::Ok, "{e:?}");
    let (epd, epa) = (e.pd.unwrap(), e.pa.unwrap());
    assert!(epd[2] == 0.0 && epa[2] == 0.0, "{e:?}");
    for c in 0..2 {
        assert!((epd[c] / pd[c] as f64 - 1.0).abs() < 0.03 && (epa[c] / pa[c] as f64 - 1.0).abs() < 0.03, "{e:?}");
    }
}

#[test]
fn hdr_values_from_1e_minus_4_to_1e5() {
    let time = afternoon();
    let l = sun_dir(&time);
    // Overall scale: the same scene at 1e-4 and 1e5 gives the same relative answer.
    let w = world(WorldSpec::default(), l);
    let base = render(&w, l, PD, PA, 0.01, 7);
    let mut answers = Vec::new();
    for k in [1e-4f32, 1.0, 1e5] {
        let mut img = base.clone();
        img.data.iter_mut().for_each(|p| *p = p.map(|v| v * k));
        let mut est = estimator(&w, EstimatorConfig::default());
        let e = est.estimate(0, &time, &frame(img), &hdr()).unwrap();
        sane(&e);
        answers.push((e.pd.unwrap().map(|v| v / k as f64), e.pa.unwrap().map(|v| v / k as f64)));
    }
    for (pd, pa) in &answers {
        assert!(rel_err(*pd, PD) < 0.03 && rel_err(*pa, PA) < 0.03, "{answers:?}");
        for c in 0..3 {
            assert!((pd[c] / answers[1].0[c] - 1.0).abs() < 1e-3 && (pa[c] / answers[1].1[c] - 1.0).abs() < 1e-3, "{answers:?}");
        }
    }
    // One frame spanning 1e-4 … 1e5: a near-black tile in shadow next to bright sunlit ground.
    let spec = WorldSpec { ground: [0.5, 0.5, 0.5], dark_tile: Some([2e-8, 2e-8, 2e-8]), ..Default::default() };
    let w = world(spec, l);
    let (pd, pa) = ([4e5f32, 4e5, 4e5], [6e4f32, 6e4, 6e4]);
    let img = render(&w, l, pd, pa, 0.01, 8);
    let max = img.data.iter().map(|p| p[0]).fold(0.0f32, f32::max);
    let min = img.data.iter().map(|p| p[0]).filter(|v| *v > 0.0).fold(f32::MAX, f32::min);
    assert!(max > 1e4 && min < 1e-3, "range {min} … {max}");
    let mut est = estimator(&w, EstimatorConfig::default());
    let e = est.estimate(0, &time, &frame(img), &hdr()).unwrap();
    sane(&e);
    assert_eq!(e.status, Status::Ok, "{e:?}");
    assert!(rel_err(e.pd.unwrap(), pd) < 0.03 && rel_err(e.pa.unwrap(), pa) < 0.03, "{e:?}");
}

#[test]
fn nan_and_inf_pixels_are_skipped() {
    let time = afternoon();
    let l = sun_dir(&time);
    let w = world(WorldSpec::default(), l);
    let mut img = render(&w, l, PD, PA, 0.01, 10);
    let mut rng = SmallRng::seed_from_u64(11);
    for p in img.data.iter_mut() {
        let u: f32 = rng.random();
        if u < 0.1 {
            p[rng.random_range(0..3)] = f32::NAN;
        } else if u < 0.15 {
            p[1] = f32::INFINITY;
        } else if u < 0.17 {
            p[0] = f32::NEG_INFINITY;
        } else if u < 0.19 {
            p[2] = -1.0;
        }
    }
    let mut est = estimator(&w, EstimatorConfig::default());
    let e = est.estimate(0, &time, &frame(img), &hdr()).unwrap();
    sane(&e);
    assert!(e.samples.invalid > 50, "{:?}", e.samples);
    assert!(rel_err(e.pd.unwrap(), PD) < 0.03 && rel_err(e.pa.unwrap(), PA) < 0.03, "{e:?}");
}

#[test]
fn fewer_usable_pixels_than_requested() {
    let time = afternoon();
    let l = sun_dir(&time);
    let w = world(WorldSpec::default(), l);
    let img = render(&w, l, PD, PA, 0.01, 12);
    // More samples than the pool holds: all available entries are used.
    let mut est = estimator(&w, EstimatorConfig { samples: 5000, pool_size: 5000, ..Default::default() });
    let e = est.estimate(0, &time, &frame(img.clone()), &hdr()).unwrap();
    sane(&e);
    assert!(e.samples.drawn == e.samples.available && e.samples.drawn < 5000, "{:?}", e.samples);
    assert!(rel_err(e.pd.unwrap(), PD) < 0.03 && rel_err(e.pa.unwrap(), PA) < 0.03, "{e:?}");
    // Almost every pixel invalid: too few samples, nothing fitted, nothing invented.
    let mut bad = img;
    for (i, p) in bad.data.iter_mut().enumerate() {
        if i % 300 != 0 {
            *p = [f32::NAN; 3];
        }
    }
    let mut est = estimator(&w, EstimatorConfig::default());
    let e = est.estimate(0, &time, &frame(bad), &hdr()).unwrap();
    sane(&e);
    assert_eq!(e.status, Status::TooFewSamples, "{e:?}");
    assert!(e.pd.is_none() && e.pa.is_none() && e.smoothed.is_none());
}

/// Issue 12 (1): one black frame (a dropped frame, a lens cap) among normal ones is reported as
/// `dark_frame`, fits nothing and leaves the smoother alone, so the frames after it are right.
/// A frame at 1% of the light (a lens cap with sensor noise) is dark too; the same 1% frame
/// ten minutes after the last update is taken as real (a night, a time-lapse).
#[test]
fn a_dark_frame_does_not_poison_the_smoother() {
    let time = afternoon();
    let l = sun_dir(&time);
    let w = world(WorldSpec::default(), l);
    let img = render(&w, l, PD, PA, 0.01, 1);
    let at = |s: i64| time + chrono::Duration::seconds(s);
    let mut est = estimator(&w, EstimatorConfig::default());
    let e0 = est.estimate(0, &at(0), &frame(img.clone()), &half()).unwrap();
    assert_eq!(e0.status, Status::Ok, "{e0:?}");
    let mut black = img.clone();
    black.data.iter_mut().for_each(|p| *p = [0.0; 3]);
    let e1 = est.estimate(1, &at(1), &frame(black.clone()), &half()).unwrap();
    sane(&e1);
    assert_eq!(e1.status, Status::DarkFrame, "{e1:?}");
    assert_eq!((e1.pd, e1.pa), (None, None));
    assert_eq!(e1.smoothed, e0.smoothed, "the smoothed lighting is held");
    assert!(!e1.relight);
    let mut capped = img.clone();
    capped.data.iter_mut().for_each(|p| *p = p.map(|v| v * 0.01));
    let e2 = est.estimate(2, &at(2), &frame(capped.clone()), &half()).unwrap();
    assert_eq!(e2.status, Status::DarkFrame, "{e2:?}");
    let e3 = est.estimate(3, &at(3), &frame(img.clone()), &half()).unwrap();
    assert_eq!(e3.status, Status::Ok, "{e3:?}");
    let s = e3.smoothed.unwrap();
    assert!(rel_err(s.pd, PD) < 0.03 && rel_err(s.pa, PA) < 0.03, "{e3:?}");
    // Ten minutes later, the same darkness is real light.
    let e4 = est.estimate(4, &at(600), &frame(capped), &half()).unwrap();
    assert_ne!(e4.status, Status::DarkFrame, "{e4:?}");
    // A black first frame has nothing to compare with and is dark all the same.
    let mut fresh = estimator(&w, EstimatorConfig::default());
    let f0 = fresh.estimate(0, &at(0), &frame(black), &half()).unwrap();
    assert_eq!(f0.status, Status::DarkFrame, "{f0:?}");
    assert_eq!(f0.smoothed, None);
}

/// Issue 12 (2): a frame at the half-float maximum everywhere is clipped, not a bright sky.
#[test]
fn a_frame_at_the_half_float_maximum_is_saturated() {
    let time = afternoon();
    let l = sun_dir(&time);
    let w = world(WorldSpec::default(), l);
    let mut img = render(&w, l, PD, PA, 0.01, 1);
    img.data.iter_mut().for_each(|p| *p = [65504.0; 3]);
    let mut est = estimator(&w, EstimatorConfig::default());
    let e = est.estimate(0, &time, &frame(img), &half()).unwrap();
    sane(&e);
    assert_eq!(e.status, Status::Saturated, "{e:?}");
    assert_eq!((e.pd, e.pa), (None, None), "{e:?}");
    assert_eq!(e.samples.clipped, e.samples.drawn);
}
