//! Bad input to the frame loop (issue 12): outputs over inputs, two runs into one output, clocks
//! that stand still, and a live run whose frames or source fail. Each case asserts a non-zero
//! exit (or an error), a message that names the file or frame, and that no input or scene file
//! changed (hashed before and after).

use crate::common::{hashes, heliar_status as heliar, s};
use heliar::geometry::raycast::RayScene;
use heliar::gpu::{Gpu, GpuOptions};
use heliar::render::{Compositor, CompositorConfig};
use heliar::run::augment::{AugmentOptions, augment};
use heliar::run::clock::FrameClock;
use heliar::run::outdoor::OutdoorStage;
use heliar::run::session::OutdoorSession;
use heliar::run::source::{InputOptions, resolve_input};
use heliar::scene::Scene;
use std::path::{Path, PathBuf};
use std::process::Command;
use std::sync::Arc;
use std::sync::atomic::AtomicUsize;

fn bundled() -> PathBuf {
    Path::new(env!("CARGO_MANIFEST_DIR")).join("scenes/courtyard")
}

fn scratch(name: &str) -> PathBuf {
    let d = std::env::temp_dir().join(format!("heliar-badrun-{name}-{}", std::process::id()));
    let _ = std::fs::remove_dir_all(&d);
    std::fs::create_dir_all(&d).unwrap();
    d
}

fn copy_dir(from: &Path, to: &Path) {
    std::fs::create_dir_all(to).unwrap();
    for e in std::fs::read_dir(from).unwrap().flatten() {
        let (p, q) = (e.path(), to.join(e.file_name()));
        if e.file_name() == "baked" {
            continue;
        }
        if p.is_dir() { copy_dir(&p, &q) } else { std::fs::copy(&p, &q).map(|_| ()).unwrap() }
    }
}

/// A copy of the bundled courtyard (its bake left out: the commands here use the uniform sky).
fn scene_copy(name: &str) -> (PathBuf, PathBuf) {
    let d = scratch(name);
    let scene = d.join("courtyard");
    copy_dir(&bundled(), &scene);
    (d, scene)
}

#[test]
fn augment_refuses_to_write_over_its_input_or_the_scene() {
    let (d, scene) = scene_copy("over-input");
    let before = hashes(&scene);
    let frames = scene.join("frames/ldr");
    // The input folder itself; the scene folder (which holds the input); a folder holding both.
    for (out, what) in [(frames.clone(), "is the input"), (scene.clone(), "overlaps"), (d.clone(), "overlaps")] {
        let (ok, err) = heliar(&["augment", s(&scene), "--input", s(&frames), "--output", s(&out), "--ambient", "uniform", "--transfer-paths", "0", "--max-frames", "1"]);
        assert!(!ok, "augment into {} succeeded", out.display());
        assert!(err.contains(what) && err.contains("--force"), "{}: {err}", out.display());
    }
    assert_eq!(hashes(&scene), before, "a refused run changed the scene or its input");
    std::fs::remove_dir_all(&d).ok();
}

#[test]
fn a_second_run_into_a_locked_output_is_refused_and_a_stale_lock_is_taken_over() {
    let (d, scene) = scene_copy("lock");
    let out = d.join("out");
    std::fs::create_dir_all(&out).unwrap();
    let lock = out.join(".heliar.lock");
    // This test's own process holds the output: alive, so the run must wait for it.
    std::fs::write(&lock, format!("{}\n", std::process::id())).unwrap();
    let args = |o: &Path| vec!["augment".to_owned(), s(&scene).into(), "--input".into(), s(&scene.join("frames/ldr")).into(), "--output".into(), s(o).into(), "--ambient".into(), "uniform".into(), "--transfer-paths".into(), "0".into(), "--max-frames".into(), "1".into()];
    let run = |o: &Path| {
        let out = Command::new(env!("CARGO_BIN_EXE_heliar")).args(args(o)).output().unwrap();
        (out.status.success(), String::from_utf8_lossy(&out.stderr).into_owned())
    };
    let (ok, err) = run(&out);
    assert!(!ok && err.contains("another heliar run") && err.contains(&std::process::id().to_string()), "{err}");
    assert!(lock.exists(), "the refused run removed someone else's lock");
    assert!(!out.join("report.jsonl").exists(), "the refused run wrote a report");
    // A lock left by a process that is gone (a SIGKILL'd run) is taken over, and released.
    std::fs::write(&lock, "4194000\n").unwrap();
    let (ok, err) = run(&out);
    assert!(ok, "{err}");
    assert!(!lock.exists(), "the lock stayed after the run");
    assert_eq!(std::fs::read_to_string(out.join("report.jsonl")).unwrap().lines().count(), 1);
    std::fs::remove_dir_all(&d).ok();
}

/// Recorded frames all stamped with one time: the run warns and names them, or with the strict
/// clock stops at the first.
#[test]
fn frame_times_that_do_not_increase_are_named_or_refused() {
    let (d, scene_dir) = scene_copy("clock");
    let scene = Scene::load(&scene_dir).unwrap();
    let ray = Arc::new(RayScene::new(scene.proxy.clone()));
    let mut input = resolve_input(&scene, &InputOptions { input: Some(scene_dir.join("frames/ldr")), ..Default::default() }).unwrap();
    let t0 = scene.sequences[1].times[0];
    input.clock = FrameClock::List { times: vec![t0; 12], looped: false };
    let gpu = Arc::new(Gpu::new(GpuOptions { samples: 1 }).expect("a GPU adapter (lavapipe or llvmpipe)"));
    let config = CompositorConfig { transfer_paths: 0, ..CompositorConfig::for_scene(&scene) };
    let session = || {
        let est = heliar::estimate::Estimator::new(&scene, ray.clone()).unwrap();
        let comp = Compositor::for_scene(gpu.clone(), &scene, ray.clone(), config.clone()).unwrap();
        OutdoorSession::new(OutdoorStage::new(est, Box::new(heliar::irradiance::sources::UniformSky::for_scene(&scene))), comp)
    };
    #[derive(Default)]
    struct Notes(Vec<String>);
    impl heliar::run::Observer for Notes {
        fn note(&mut self, m: &str) {
            self.0.push(m.to_owned());
        }
    }
    let opts = |out: &str, strict_clock| AugmentOptions { output: d.join(out), format: None, resume: false, max_frames: Some(4), frames: None, warmup: None, sheet_columns: 4, force: false, strict_clock, hindsight: true };
    let stop = AtomicUsize::new(0);
    let mut notes = Notes::default();
    let done = augment(&scene, &input, &mut session(), &opts("warn", false), &mut notes, &stop).unwrap();
    assert!(done.error.is_none(), "{:?}", done.error);
    let w = notes.0.iter().find(|n| n.contains("does not increase")).unwrap_or_else(|| panic!("no clock warning in {:?}", notes.0));
    assert!(w.contains("frames 1–3"), "{w}");
    let strict = augment(&scene, &input, &mut session(), &opts("strict", true), &mut Notes::default(), &stop).unwrap();
    let e = format!("{:#}", strict.error.expect("the strict clock stops the run"));
    assert!(e.contains("frame 1") && e.contains("--strict"), "{e}");
    assert_eq!(strict.summary.frames_written, 1, "the frame before the stuck one is kept");
    std::fs::remove_dir_all(&d).ok();
}

#[cfg(feature = "opencv")]
#[test]
fn live_without_a_window_fails_on_frames_of_the_wrong_size_and_on_a_source_that_never_comes() {
    let d = scratch("live");
    let frames = d.join("small");
    std::fs::create_dir_all(&frames).unwrap();
    for i in 0..3 {
        image::save_buffer(frames.join(format!("f{i}.png")), &[128u8; 8 * 6 * 3], 8, 6, image::ExtendedColorType::Rgb8).unwrap();
    }
    let (ok, err) = heliar(&["live", s(&bundled()), "--input", s(&frames), "--start", "2024-06-21T15:30:00+02:00", "--fps", "20", "--ambient", "uniform", "--transfer-paths", "0", "--headless-frames", "3"]);
    assert!(!ok, "wrong-size frames gave exit 0: {err}");
    assert!(err.contains("8×6") && err.contains("frames failed") && !err.contains("NaN"), "{err}");
    // A camera that is not there: the headless run gives up after --retry-for.
    let t = std::time::Instant::now();
    let (ok, err) = heliar(&["live", s(&bundled()), "--camera", "7", "--ambient", "uniform", "--transfer-paths", "0", "--headless-frames", "2", "--retry-for", "2"]);
    assert!(!ok && err.contains("--retry-for"), "{err}");
    assert!(t.elapsed().as_secs_f64() < 60.0, "took {:?}", t.elapsed());
    std::fs::remove_dir_all(&d).ok();
}

/// A footage frame of another size than the camera's (a 1×1 frame among the courtyard's):
/// `vem --scene` refuses before rendering anything, naming the file and both sizes, instead of
/// putting the environment (or a rescaled frame) behind the objects.
#[test]
fn vem_over_footage_refuses_a_frame_of_another_size() {
    let (d, scene) = scene_copy("vem-size");
    let small = scene.join("frames/hdr/frame_005.exr");
    heliar::io::image::LinearImage::new(1, 1).write_exr(&small, heliar::io::image::ExrPrecision::Half).unwrap();
    let capture = Path::new(env!("CARGO_MANIFEST_DIR")).join("scenes/vem/outdoor");
    let (before, before_capture) = (hashes(&scene), hashes(&capture));
    let out = d.join("out");
    let (ok, err) = heliar(&["vem", "--scene", s(&scene), "--input", s(&capture.join("frames")), "--calib", s(&capture.join("calib/fisheye.toml")), "--lights", "8", "--output", s(&out)]);
    assert!(!ok, "a 1×1 footage frame gave exit 0: {err}");
    assert!(err.contains("frame_005.exr") && err.contains("1×1") && err.contains("320×240") && err.contains("camera.toml"), "{err}");
    assert!(!out.join("frame_0000.png").exists(), "frames were written before the refusal");
    assert_eq!(hashes(&scene), before, "the refused run changed the scene");
    assert_eq!(hashes(&capture), before_capture, "the refused run changed the capture");
    std::fs::remove_dir_all(&d).ok();
}
