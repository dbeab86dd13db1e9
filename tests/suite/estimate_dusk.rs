//! The estimator on the dusk courtyard (`gen-courtyard --dusk`, issue 16 §3): sunset and civil
//! twilight with a street lamp that switches on at frame 1, rendered by the generator's own path
//! tracer with a disc emitter whose far field is the scene's IES file (`lamps/street.ies`), and
//! with sensor read noise that is ~10% of a lamp-lit pixel at night. The truth (`truth.csv`) has
//! the lamp's scale `k` (1 when on) beside `Pd` and `Pa`.

use heliar::estimate::{Estimator, LampStatus, Status};
use heliar::geometry::raycast::RayScene;
use heliar::io::frames::Frame;
use heliar::report::lighting_error;
use heliar::scene::Scene;
use std::path::Path;
use std::sync::Arc;

/// Largest error of the lamp's fitted scale (luma) against the truth's 1: the estimator's own
/// `k_se` on these frames is 0.06–0.08 (read noise), so 0.15 is ~2σ.
const K_TOL: f64 = 0.15;
/// Largest relative error of `Pa` per frame (the courtyard's daylight target is a few percent;
/// the night frames' sky is 5–100 times dimmer than the lamp on the paving).
const PA_TOL: f64 = 0.15;

/// `lamp_k` of every frame, from the truth file's last column.
fn true_lamp_k(root: &Path) -> Vec<f64> {
    let text = std::fs::read_to_string(root.join("truth.csv")).unwrap();
    let mut lines = text.lines();
    let header: Vec<&str> = lines.next().unwrap().split(',').collect();
    let col = header.iter().position(|h| *h == "lamp_k").expect("lamp_k column");
    lines.map(|l| l.split(',').nth(col).unwrap().parse().unwrap()).collect()
}

/// Frame 0 has its lamp `off`; frames 1–5 must fit `k` within [`K_TOL`] of the truth's 1 and `Pa`
/// within [`PA_TOL`].
///
/// **Fails today, so it is ignored** (run it with `--ignored`): `heliar estimate scenes/dusk`
/// (release, 2026-12-03) gives `k` (luma) 0.00, 0.38, 0.71, 0.55, 0.23 on frames 1–5 and `Pa`
/// 2–38% high, although the model's lamp irradiance matches the frames' lamp light to 0.3% at
/// four paving points (checked against `ρ/π·I cos θ/r²`). The likely cause is the lamp's
/// interreflected light: the estimator's lamp column is direct light only, so `Pa` absorbs the
/// lamp's bounce off the paving and walls and `k` drops to compensate. Weighing the multi-column
/// fit's rows by the predicted instead of the observed level (a known bias under read noise) moved
/// `k` to 0.00, 0.37, 0.67, 0.69, 0.82 and `Pa` to 3–43% high: not the cause, and not kept.
#[test]
#[ignore = "fails: the lamp's scale comes out 0.0-0.8 of the truth on the dusk scene (lamp bounce missing from the model; see the doc comment)"]
fn the_dusk_lamp_is_learned_from_noisy_night_frames() {
    let root = Path::new(env!("CARGO_MANIFEST_DIR")).join("scenes/dusk");
    let scene = Scene::load(&root).unwrap();
    let seq = scene.sequences[0].clone();
    let truth = seq.truth.clone().expect("truth file");
    let lamp_k = true_lamp_k(&root);
    let mut est = Estimator::new(&scene, Arc::new(RayScene::new(scene.proxy.clone()))).unwrap();
    let lin = seq.photometry.linearizer();
    for (i, p) in seq.files.iter().enumerate() {
        let e = est.estimate(i, &seq.times[i], &Frame::load(p).unwrap(), &lin).unwrap();
        let lamp = &e.lamps[0];
        let (_, ea) = lighting_error(&e.pd.unwrap(), &e.pa.unwrap(), &truth[i].pd, &truth[i].pa);
        let k = 0.2126 * lamp.k[0] + 0.7152 * lamp.k[1] + 0.0722 * lamp.k[2];
        eprintln!("frame {i}: {:?}, lamp {:?} k {:?} (luma {k:.3}, truth {}), Pa error {:.1}%", e.status, lamp.status, lamp.k, lamp_k[i], 100.0 * ea);
        if lamp_k[i] == 0.0 {
            assert_eq!(lamp.status, LampStatus::Off, "frame {i}");
            continue;
        }
        assert_eq!(lamp.status, LampStatus::Fitted, "frame {i}: {:?}", lamp.reason);
        if i >= 2 {
            assert_eq!(e.status, Status::Night, "frame {i}: the sun has set");
        }
        assert!((k - 1.0).abs() < K_TOL, "frame {i}: k {k:.3} against 1");
        assert!(ea < PA_TOL, "frame {i}: Pa error {ea}");
    }
}
