//! The estimator's sliced re-trace of its sun-dependent terms (issue 13 part 4,
//! `estimate::rebuild`): after a sun move the direct terms and the sky's shape follow at once, the
//! bounce (with the sky's interreflected part) is re-traced a slice per frame while the old one
//! serves, and the completed re-trace equals a full build for its sun bit for bit.

use crate::common::*;
use chrono::Duration;
use heliar::estimate::pool::SunState;
use heliar::estimate::rebuild::{Inputs, SlowTerms, whole};
use heliar::estimate::sky_terms::{SkyTerms, SunSky};
use heliar::estimate::{Estimator, EstimatorConfig};
use heliar::geometry::ambient::TransportQuality;
use heliar::io::frames::{Linearizer, Response};
use heliar::scene::settings::SkyTermsConfig;
use heliar::sun::GeoFrame;

/// The state's values as bits (`==` on floats would let −0 and +0 pass as equal).
fn state_bits(s: &SunState) -> (Vec<[u32; 3]>, Vec<bool>, Vec<u32>, Vec<u32>, usize) {
    (s.b.iter().map(|v| v.map(f32::to_bits)).collect(), s.lit.clone(), s.valid_lit.clone(), s.valid_unlit.clone(), s.near_shadow_boundary)
}

fn sky_bits(s: &SunSky) -> Vec<Vec<[u32; 3]>> {
    [&s.a, &s.a_overcast, &s.b].iter().map(|v| v.iter().map(|x| x.map(f32::to_bits)).collect()).collect()
}

/// A small configuration: the Hošek–Wilkie sky with terrain, 16 bounce paths, and a budget of
/// 40 entries' bounce per frame.
fn config(budget: u64) -> EstimatorConfig {
    EstimatorConfig {
        pool_size: 400,
        samples: 200,
        bounce: TransportQuality { paths: 16, max_bounces: 2 },
        ambient: TransportQuality { paths: 16, max_bounces: 2 },
        sky: SkyTermsConfig::default(),
        trace_paths_per_frame: budget,
        ..EstimatorConfig::default()
    }
}

/// The full build for the estimator's current direct sun.
fn full(est: &Estimator, world: &World, dir: glam::Vec3) -> (SunState, SunSky) {
    let cfg = est.config();
    let terms = SkyTerms::build(est.pool(), &world.ray, &cfg.sky).expect("sky").expect("not Jensen's");
    let inp = Inputs { map: est.pixel_map(), pool: est.pool(), scene: &world.ray, cfg, sky: Some(&terms) };
    let (state, sky) = whole(&inp, dir, true).expect("whole");
    (state, sky.expect("sky terms"))
}

/// The sky's terms served right after a sun move from `old` to `new`: the new sun's shape, the
/// old sun's interreflected part (traced with the bounce, which follows in slices).
fn sky_after_move(est: &Estimator, world: &World, old: glam::Vec3, new: glam::Vec3) -> SunSky {
    let cfg = est.config();
    let terms = SkyTerms::build(est.pool(), &world.ray, &cfg.sky).expect("sky").expect("not Jensen's");
    let inp = Inputs { map: est.pixel_map(), pool: est.pool(), scene: &world.ray, cfg, sky: Some(&terms) };
    let (slow, _) = SlowTerms::full(&inp, old, true);
    let mut sky = terms.for_sun(est.pool(), new, true).expect("for_sun");
    sky.add_bounced(est.pool(), &slow.sky_bounced, &slow.sky_bounced_fit);
    sky
}

#[test]
fn a_completed_sliced_rebuild_equals_a_full_build_bit_for_bit() {
    let t0 = afternoon();
    let world = world(WorldSpec::default(), sun_dir(&t0));
    let img = frame(render(&world, sun_dir(&t0), [3.0, 2.8, 2.5], [0.6, 0.7, 0.9], 0.01, 3));
    let lin = Linearizer::new(&Response::Linear, 1.0, 1.0, Some(f32::INFINITY));
    let mut est = Estimator::with_camera(config(16 * 40), observer(), GeoFrame::default(), &world.camera, world.ray.clone()).expect("estimator");
    let n = est.pool().len();
    assert!(n > 120, "the view has {n} pool entries: too few for several slices");
    est.estimate(0, &t0, &img, &lin).expect("frame 0");
    assert!(est.retrace_progress().is_none(), "the first frame builds everything");
    let (_, dir0) = est.sun_at(&t0).expect("sun");
    // Three minutes later the sun has moved ≈ 0.6°, past the default 0.25°.
    let t1 = t0 + Duration::minutes(3);
    let (_, dir1) = est.sun_at(&t1).expect("sun");
    let e = est.estimate(1, &t1, &img, &lin).expect("frame 1");
    assert!(e.sun_rebuilt, "the direct terms follow the sun at once");
    let (want_state, want_sky) = full(&est, &world, dir1);
    let served = est.sun_state().expect("state");
    assert_eq!(served.lit, want_state.lit, "which entries are sunlit is the new sun's at once");
    assert_eq!(sky_bits(est.sun_sky().expect("sky")), sky_bits(&sky_after_move(&est, &world, dir0, dir1)), "so is the sky's shape");
    assert_ne!(sky_bits(est.sun_sky().expect("sky")), sky_bits(&want_sky), "its interreflected part follows with the bounce");
    assert_ne!(state_bits(served), state_bits(&want_state), "the old bounce still serves");
    let (sun, done) = est.retrace_progress().expect("a re-trace runs");
    assert_eq!(sun, dir1);
    assert!((done - 40.0 / n as f64).abs() < 1e-12, "one slice of 40 entries: {done}");
    // Frames a millisecond apart (the sun does not move past the threshold) finish the job:
    // ⌈n/40⌉ frames in all, this one included.
    let frames = n.div_ceil(40);
    for k in 1..frames {
        assert!(est.retrace_progress().is_some(), "frame {k} of {frames}: the job ended early");
        est.estimate(1 + k, &(t1 + Duration::milliseconds(k as i64)), &img, &lin).expect("frame");
    }
    assert!(est.retrace_progress().is_none(), "the job ends after {frames} frames");
    assert_eq!(state_bits(est.sun_state().expect("state")), state_bits(&want_state));
    assert_eq!(sky_bits(est.sun_sky().expect("sky")), sky_bits(&want_sky));
}

/// With `trace_paths_per_frame = 0` a sun move rebuilds everything in its frame (the behaviour
/// before the slices), and two runs over the same frames take the same steps.
#[test]
fn an_unbounded_budget_rebuilds_whole_and_runs_repeat() {
    let t0 = afternoon();
    let world = world(WorldSpec::default(), sun_dir(&t0));
    let img = frame(render(&world, sun_dir(&t0), [3.0, 2.8, 2.5], [0.6, 0.7, 0.9], 0.01, 3));
    let lin = Linearizer::new(&Response::Linear, 1.0, 1.0, Some(f32::INFINITY));
    let times: Vec<_> = (0..5).map(|k| t0 + Duration::minutes(2 * k)).collect();
    let run = |budget: u64| {
        let mut est = Estimator::with_camera(config(budget), observer(), GeoFrame::default(), &world.camera, world.ray.clone()).expect("estimator");
        let mut out = Vec::new();
        for (i, t) in times.iter().enumerate() {
            let e = est.estimate(i, t, &img, &lin).expect("frame");
            let (_, dir) = est.sun_at(t).expect("sun");
            if budget == 0 {
                assert!(est.retrace_progress().is_none());
                let (s, sky) = full(&est, &world, dir);
                assert_eq!(state_bits(est.sun_state().expect("state")), state_bits(&s), "frame {i}");
                assert_eq!(sky_bits(est.sun_sky().expect("sky")), sky_bits(&sky), "frame {i}");
            }
            out.push((e.pd, e.pa, e.sun_rebuilt, est.retrace_progress().map(|p| p.1)));
        }
        out
    };
    let whole = run(0);
    assert!(whole[1..].iter().all(|r| r.2), "every frame two minutes on moves the sun past 0.25°");
    assert_eq!(run(16 * 40), run(16 * 40), "the sliced schedule depends only on the frames");
}
