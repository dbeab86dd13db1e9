//! The estimator against the bundled courtyard, whose frames were path traced by an independent
//! renderer (tools/gen_courtyard) with interreflection, albedo texture, an unmodelled person, a wet
//! patch, lens distortion and noise, and in the LDR variant sRGB quantisation and clipping.

use heliar::estimate::{Estimator, Status};
use heliar::estimate::smoother::ChangeReason;
use heliar::geometry::raycast::RayScene;
use heliar::io::frames::Frame;
use heliar::report::lighting_error;
use heliar::scene::Scene;
use std::path::Path;
use std::sync::Arc;

fn run(sequence: &str) -> Vec<(heliar::estimate::FrameEstimate, f64, f64)> {
    let scene = Scene::load(&Path::new(env!("CARGO_MANIFEST_DIR")).join("scenes/courtyard")).unwrap();
    let seq = scene.sequence(Some(sequence)).unwrap().clone();
    let truth = seq.truth.clone().expect("truth file");
    let mut est = Estimator::new(&scene, Arc::new(RayScene::new(scene.proxy.clone()))).unwrap();
    let lin = seq.photometry.linearizer();
    seq.files
        .iter()
        .enumerate()
        .map(|(i, p)| {
            let e = est.estimate(i, &seq.times[i], &Frame::load(p).unwrap(), &lin).unwrap();
            let (ed, ea) = lighting_error(&e.pd.unwrap(), &e.pa.unwrap(), &truth[i].pd, &truth[i].pa);
            eprintln!("{sequence} frame {i}: {:?} Pd err {:.2}% Pa err {:.2}%", e.status, 100.0 * ed, 100.0 * ea);
            (e, ed, ea)
        })
        .collect()
}

/// The acceptance: within 3% of the truth on every frame (error metric of
/// `heliar::report`), HDR and clipped LDR alike.
#[test]
fn recovers_the_truth_within_three_percent() {
    for seq in ["hdr", "ldr"] {
        let r = run(seq);
        assert_eq!(r.len(), 12);
        for (i, (e, ed, ea)) in r.iter().enumerate() {
            assert!(*ed < 0.03 && *ea < 0.03, "{seq} frame {i}: Pd {ed} Pa {ea}: {e:?}");
            assert!(matches!(e.status, Status::Ok | Status::NoDirectSun), "{seq} frame {i}: {e:?}");
        }
        // The mean is well inside the bound (measured ≈ 0.7%).
        let mean = r.iter().map(|x| x.1 + x.2).sum::<f64>() / (2.0 * r.len() as f64);
        assert!(mean < 0.015, "{seq}: mean error {mean}");
    }
}

#[test]
fn the_cloud_is_seen_and_drives_relighting() {
    let r = run("hdr");
    // Frame 6: the sun is behind the cloud (true Pd/Pa ≈ 4% in luminance).
    assert_eq!(r[6].0.status, Status::NoDirectSun, "{:?}", r[6].0);
    // Clear frames 0–2 differ by < 0.5%: no relight after the first.
    assert_eq!(r[0].0.change, ChangeReason::FirstFrame);
    assert!(!r[1].0.relight, "{:?}", r[1].0);
    // While the cloud moves in and out the lighting changes by far more than 2% per frame.
    for i in 4..=8 {
        assert!(r[i].0.relight, "frame {i}: {:?}", r[i].0);
    }
    // The LDR variant clips the sunlit paving: clipped samples are counted and the partly clipped
    // surface censored.
    let l = run("ldr");
    assert!(l[0].0.samples.clipped > 50 && l[0].0.samples.censored > 0, "{:?}", l[0].0.samples);
}

/// Errors (mean Pd, mean Pa, worst of both) of the estimator on a winter scene (a Hošek–Wilkie
/// sky with a low sun and terrain beyond the proxy, rendered by the generator's own tracer) with
/// the given sky in the model.
fn winter(variant: &str, sky: heliar::scene::settings::SkyTermsConfig) -> (f64, f64, f64) {
    let mut scene = Scene::load(&Path::new(env!("CARGO_MANIFEST_DIR")).join("scenes/winter").join(variant)).unwrap();
    scene.estimator.sky = sky;
    let seq = scene.sequences[0].clone();
    let truth = seq.truth.clone().expect("truth file");
    let mut est = Estimator::new(&scene, Arc::new(RayScene::new(scene.proxy.clone()))).unwrap();
    let lin = seq.photometry.linearizer();
    let (mut sd, mut sa, mut worst) = (0.0, 0.0, 0.0f64);
    for (i, p) in seq.files.iter().enumerate() {
        let e = est.estimate(i, &seq.times[i], &Frame::load(p).unwrap(), &lin).unwrap();
        let (ed, ea) = lighting_error(&e.pd.unwrap(), &e.pa.unwrap(), &truth[i].pd, &truth[i].pa);
        sd += ed;
        sa += ea;
        worst = worst.max(ed).max(ea);
    }
    let n = seq.files.len() as f64;
    (sd / n, sa / n, worst)
}

/// Issue 13: on a real-shaped sky with a sun 5–10° high, the default model (Hošek–Wilkie shape,
/// terrain of albedo 0.2 beyond the proxy, 512 quadrature directions; the truth's terrain is 0.8
/// or 0.08) recovers `Pd` and `Pa` several times better than Jensen's uniform sky. Measured by
/// `heliar estimate` (mean Pd / mean Pa / worst): default 2.4% / 2.7% / 7.3% (snow) and
/// 1.2% / 1.9% / 3.9% (asphalt); uniform 24% / 22% / 30% and 22% / 21% / 29%.
#[test]
fn a_low_winter_sun_under_a_real_sky_is_recovered_with_the_sky_model() {
    use heliar::scene::settings::SkyTermsConfig;
    for variant in ["snow", "asphalt"] {
        let (d, a, worst) = winter(variant, SkyTermsConfig::default());
        let (ud, ua, _) = winter(variant, SkyTermsConfig::jensen());
        eprintln!("{variant}: sky model Pd {:.1}% Pa {:.1}% worst {:.1}%; uniform Pd {:.1}% Pa {:.1}%", 100.0 * d, 100.0 * a, 100.0 * worst, 100.0 * ud, 100.0 * ua);
        assert!(d < 0.035 && a < 0.04 && worst < 0.09, "{variant}: Pd {d} Pa {a} worst {worst}");
        assert!(ud > 3.0 * d && ua > 2.0 * a, "{variant}: the uniform sky should be clearly worse: Pd {ud} Pa {ua}");
    }
}
