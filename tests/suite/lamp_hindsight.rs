//! The lamps' scale in hindsight (`estimate::hindsight`, issue 16 §3: "`k_i` within 5%"): on the
//! dusk courtyard the lamp switches on at frame 1, where the sky is still bright and one fit has a
//! standard error of 10–14%; smoothed forward and backward over the recording, every frame's `k`
//! is within the issue's 5% of the truth's 1, for the estimator's seeds 0–4. `heliar augment`
//! runs that pass before it renders (and says so in its summary), `heliar estimate --hindsight`
//! reports it.

use crate::common::{heliar_status, s};
use heliar::estimate::Estimator;
use heliar::estimate::hindsight::LampHindsight;
use heliar::geometry::raycast::RayScene;
use heliar::io::frames::Frame;
use heliar::scene::Scene;
use std::path::{Path, PathBuf};
use std::sync::Arc;

/// The issue's bound on `k`, per channel, on every frame with the lamp on. Measured (2026-12-05,
/// debug): largest error over frames 1–5 and the channels 2.6% (seed 0), 3.7%, 3.3%, 3.1%, 2.8%
/// (seeds 1–4); the forward filter alone gives up to 25.7% on frame 1 (seed 0: 1.216, 1.149,
/// 1.257) and 23.3% (seed 1).
const K_TOL: f64 = 0.05;

fn dusk() -> PathBuf {
    Path::new(env!("CARGO_MANIFEST_DIR")).join("scenes/dusk")
}

#[test]
fn the_dusk_lamp_in_hindsight_is_within_five_percent_on_every_frame_and_seed() {
    let mut scene = Scene::load(&dusk()).unwrap();
    let seq = scene.sequences[0].clone();
    let lin = seq.photometry.linearizer();
    let frames: Vec<Frame> = seq.files.iter().map(|p| Frame::load(p).unwrap()).collect();
    let ray = Arc::new(RayScene::new(scene.proxy.clone()));
    // As the commands do (`terrain_albedo = "map"`: measured on the environment map once).
    heliar::envmap::bake::terrain::resolve_scene(&mut scene, &ray).unwrap();
    let mut forward_worst: f64 = 0.0;
    for seed in 0..5 {
        scene.estimator.seed = seed;
        let mut est = Estimator::new(&scene, ray.clone()).unwrap();
        let estimates: Vec<_> = frames.iter().enumerate().map(|(i, f)| est.estimate(i, &seq.times[i], f, &lin).unwrap()).collect();
        let ts = |i: usize| (seq.times[i] - seq.times[0]).num_milliseconds() as f64 / 1e3;
        let h = LampHindsight::from_reports(&scene, estimates.iter().map(|e| (e.frame, ts(e.frame), &e.lamps[..])));
        assert_eq!(h.frames(), frames.len());
        for mut e in estimates {
            h.apply(e.frame, &mut e.lamps);
            let lamp = &e.lamps[0];
            if e.frame == 0 {
                // Off by its schedule: no k in hindsight either.
                assert_eq!(lamp.k_hindsight, None);
                continue;
            }
            let k = lamp.k_hindsight.expect("a k in hindsight while on");
            let fwd = lamp.k_smoothed.expect("the forward filter's k");
            eprintln!("seed {seed} frame {}: fit {:?}, forward {fwd:?}, hindsight {k:?}", e.frame, lamp.k);
            forward_worst = fwd.iter().fold(forward_worst, |m, v| m.max((v - 1.0).abs()));
            for c in 0..3 {
                assert!((k[c] - 1.0).abs() < K_TOL, "seed {seed} frame {}: channel {c} k {:.3} against 1", e.frame, k[c]);
            }
            // The last frame has no later frame: hindsight is the forward filter there.
            if e.frame == frames.len() - 1 {
                assert_eq!(k, fwd);
            }
        }
    }
    // The pass is what brings frame 1 in: the forward filter alone misses the bound there.
    assert!(forward_worst > 0.15, "forward filter's worst error {forward_worst}");
}

/// A scratch copy of a bundled scene (the runs write no cache into the checkout).
fn scratch_copy(name: &str, src: &Path) -> PathBuf {
    let dst = std::env::temp_dir().join(format!("heliar-{name}-{}", std::process::id()));
    let _ = std::fs::remove_dir_all(&dst);
    let copy = std::process::Command::new("cp").args(["-r", s(src), s(&dst)]).status().unwrap();
    assert!(copy.success());
    let _ = std::fs::remove_dir_all(dst.join("baked"));
    dst
}

fn summary(out: &Path) -> serde_json::Value {
    serde_json::from_str(&std::fs::read_to_string(out.join("summary.json")).unwrap()).unwrap()
}

#[test]
fn augment_estimates_the_input_ahead_and_renders_the_lamp_with_its_hindsight_k() {
    let scene = scratch_copy("hindsight-augment", &dusk());
    let frames = scene.join("frames/hdr");
    let run = |out: &Path, extra: &[&str]| {
        let mut args = vec!["augment", s(&scene), "--input", s(&frames), "--output", s(out), "--ambient", "uniform", "--transfer-paths", "0", "--max-frames", "2", "--format", "exr"];
        args.extend_from_slice(extra);
        let (ok, err) = heliar_status(&args);
        assert!(ok, "{err}");
        err
    };
    let (with, without) = (scene.join("out-hindsight"), scene.join("out-forward"));
    let table = run(&with, &[]);
    let h = &summary(&with)["lamp_hindsight"];
    // To the end of the input (6 frames), not to --max-frames.
    assert_eq!(h["ran"], true, "{h}");
    assert_eq!(h["frames"], 6, "{h}");
    assert!(h["reason"].as_str().unwrap().contains("to the end of the input"), "{h}");
    assert!(table.contains("lamps' k in hindsight"), "{table}");
    run(&without, &["--no-hindsight"]);
    let h = &summary(&without)["lamp_hindsight"];
    assert_eq!(h["ran"], false, "{h}");
    assert!(h["reason"].as_str().unwrap().contains("--no-hindsight"), "{h}");
    // Frame 0 has the lamp off: the same either way. Frame 1 has it on, with k 1.216/1.149/1.257
    // forward and about 1 in hindsight: the lamp-lit pixels differ.
    let load = |d: &Path, f: &str| std::fs::read(d.join(f)).unwrap();
    assert!(load(&with, "frame_000.exr") == load(&without, "frame_000.exr"), "frame 0 differs with the lamp off");
    assert!(load(&with, "frame_001.exr") != load(&without, "frame_001.exr"), "frame 1 is the same with and without hindsight");
    // `heliar estimate --hindsight` reports the same k (and, without the flag, none).
    let lines = |extra: &[&str]| {
        let out = scene.join(format!("estimate{}.jsonl", extra.len()));
        let mut args = vec!["estimate", s(&scene), "--output", s(&out)];
        args.extend_from_slice(extra);
        let (ok, err) = heliar_status(&args);
        assert!(ok, "{err}");
        std::fs::read_to_string(&out).unwrap().lines().map(|l| serde_json::from_str::<serde_json::Value>(l).unwrap()).collect::<Vec<_>>()
    };
    let (plain, hind) = (lines(&[]), lines(&["--hindsight"]));
    assert!(plain.iter().all(|l| l["lamps"][0].get("k_hindsight").is_none()));
    let k1 = &hind[1]["lamps"][0]["k_hindsight"];
    for c in 0..3 {
        let v = k1[c].as_f64().unwrap();
        assert!((v - 1.0).abs() < K_TOL, "frame 1 channel {c}: {v}");
    }
    std::fs::remove_dir_all(&scene).ok();
}

#[test]
fn a_scene_without_lamps_skips_the_pass_and_says_why() {
    let scene = scratch_copy("hindsight-nolamps", &Path::new(env!("CARGO_MANIFEST_DIR")).join("scenes/courtyard"));
    // The statue alone: the robot's motion would have its cuts computed first.
    let m = scene.join("scene.toml");
    std::fs::write(&m, crate::common::without_robot(&std::fs::read_to_string(&m).unwrap())).unwrap();
    let src = scene.join("frames/hdr");
    let out = scene.join("out");
    let (ok, err) = heliar_status(&["augment", s(&scene), "--input", s(&src), "--output", s(&out), "--ambient", "uniform", "--transfer-paths", "0", "--max-frames", "1"]);
    assert!(ok, "{err}");
    let h = &summary(&out)["lamp_hindsight"];
    assert_eq!(h["ran"], false, "{h}");
    assert!(h["reason"].as_str().unwrap().contains("no [[lights]]"), "{h}");
    std::fs::remove_dir_all(&scene).ok();
}
