//! `heliar augment` on video files (feature `opencv`): a short video written by the test goes in,
//! a video comes out with the same frame count and rate; an interrupted run (SIGTERM) closes its
//! container and report consistently and `--resume` completes it; bad input gets a clear error
//! and keeps what was written.
#![cfg(feature = "opencv")]

use heliar::io::frames::{Frame, FrameData};
use heliar::io::video::{VideoSink, VideoSource};
use std::path::{Path, PathBuf};
use std::process::{Command, Stdio};

const START: &str = "2024-06-21T15:30:00+02:00";

fn root() -> PathBuf {
    PathBuf::from(env!("CARGO_MANIFEST_DIR"))
}

fn scratch(name: &str) -> PathBuf {
    let d = std::env::temp_dir().join(format!("heliar-augvid-{name}-{}", std::process::id()));
    std::fs::remove_dir_all(&d).ok();
    std::fs::create_dir_all(&d).unwrap();
    d
}

fn heliar(args: &[&str]) -> (bool, String) {
    let out = Command::new(env!("CARGO_BIN_EXE_heliar")).args(args).current_dir(root()).output().unwrap();
    (out.status.success(), String::from_utf8_lossy(&out.stderr).into())
}

fn rgb8(f: &Frame) -> Vec<u8> {
    match &f.data {
        FrameData::Ldr { bits: 8, codes } => codes.iter().map(|&c| c as u8).collect(),
        _ => panic!("expected 8-bit frames"),
    }
}

/// The courtyard's 8-bit LDR frames as a lossless (FFV1) video, `repeat` times over.
fn courtyard_video(path: &Path, fps: f64, repeat: usize) -> Vec<Vec<u8>> {
    let dir = root().join("scenes/courtyard/frames/ldr");
    let frames: Vec<Vec<u8>> = (0..12).map(|i| rgb8(&Frame::load(&dir.join(format!("frame_{i:03}.png"))).unwrap())).collect();
    let mut sink = VideoSink::create(path, fps, 320, 240).unwrap();
    let mut all = Vec::new();
    for _ in 0..repeat {
        for f in &frames {
            sink.write_rgb8(f).unwrap();
            all.push(f.clone());
        }
    }
    sink.finish().unwrap();
    all
}

fn read_all(path: &Path) -> (Vec<Vec<u8>>, f64) {
    let mut v = VideoSource::open_file(path).unwrap();
    let fps = v.fps();
    let mut out = Vec::new();
    while let Some((f, _)) = v.read().unwrap() {
        out.push(rgb8(&f));
    }
    (out, fps)
}

fn report_lines(path: &Path) -> Vec<serde_json::Value> {
    std::fs::read_to_string(path).unwrap().lines().map(|l| serde_json::from_str(l).unwrap()).collect()
}

/// Pixels outside the box around the statue, its shadow and the ≈ 2.5 m where it changes the sky
/// light of real surfaces, and left of the robot that crosses the right of the view (x ≥ 160: its
/// cut field reaches about 5 m); the same region as the image-sequence CLI test.
fn far_from_objects(x: usize, y: usize) -> bool {
    !((40..240).contains(&x) && (40..200).contains(&y)) && x < 160
}

#[test]
fn video_in_video_out_keeps_frames_rate_and_untouched_pixels() {
    let d = scratch("roundtrip");
    let input = d.join("in.mkv");
    let frames = courtyard_video(&input, 5.0, 1);
    let output = d.join("out.mkv");
    let (ok, err) = heliar(&["augment", "scenes/courtyard", "--input", input.to_str().unwrap(), "--output", output.to_str().unwrap(), "--start", START, "--exposure", "3.5"]);
    assert!(ok, "{err}");
    let (got, fps) = read_all(&output);
    assert_eq!(got.len(), 12);
    assert!((fps - 5.0).abs() < 1e-6, "frame rate {fps}");
    // Lossless in and out: far from the statue the codes are the input's own; near it they are not.
    for (k, (a, b)) in frames.iter().zip(&got).enumerate() {
        let mut changed = 0;
        for i in 0..320 * 240 {
            if a[3 * i..3 * i + 3] != b[3 * i..3 * i + 3] {
                assert!(!far_from_objects(i % 320, i / 320), "frame {k}: pixel {} {} changed far from the objects", i % 320, i / 320);
                changed += 1;
            }
        }
        assert!(changed > 300, "frame {k}: only {changed} pixels changed");
    }
    let lines = report_lines(&d.join("out.report.jsonl"));
    assert_eq!(lines.len(), 12);
    // Container timestamps: 0.2 s apart from --start.
    assert_eq!(lines[5]["time"].as_str().unwrap(), "2024-06-21T15:30:01+02:00");
    assert_eq!(lines[0]["relight"]["ran"], true);
    assert_eq!(lines[0]["relight"]["source"], "irradiance_volume");
    let s: serde_json::Value = serde_json::from_str(&std::fs::read_to_string(d.join("out.summary.json")).unwrap()).unwrap();
    assert_eq!(s["frames_written"], 12);
    assert_eq!(s["interrupted"], false);
    assert!(s["counts"]["statuses"].as_object().unwrap().values().map(|v| v.as_u64().unwrap()).sum::<u64>() == 12, "{s}");
    assert!(s["stages"]["composite"]["median_ms"].as_f64().unwrap() > 0.0);
    assert!(d.join("out.contact_sheet.png").exists());
    // Image-sequence output from the same video.
    let dir_out = d.join("frames");
    let (ok, err) = heliar(&["augment", "scenes/courtyard", "--input", input.to_str().unwrap(), "--output", dir_out.to_str().unwrap(), "--start", START, "--exposure", "3.5", "--max-frames", "2"]);
    assert!(ok, "{err}");
    assert!(dir_out.join("frame_00001.png").exists() && !dir_out.join("frame_00002.png").exists());
    assert_eq!(report_lines(&dir_out.join("report.jsonl")).len(), 2);
    std::fs::remove_dir_all(&d).ok();
}

#[test]
fn sigterm_closes_the_video_and_resume_completes_it() {
    let d = scratch("interrupt");
    let input = d.join("in.mkv");
    let frames = courtyard_video(&input, 10.0, 4);
    let n = frames.len();
    let output = d.join("out.mkv");
    let report = d.join("out.report.jsonl");
    let args = ["augment", "scenes/courtyard", "--input", input.to_str().unwrap(), "--output", output.to_str().unwrap(), "--start", START, "--exposure", "3.5"];
    let child = Command::new(env!("CARGO_BIN_EXE_heliar")).args(args).current_dir(root()).stdout(Stdio::null()).stderr(Stdio::piped()).spawn().unwrap();
    // Wait for the first frame in the report, then ask it to stop.
    let t0 = std::time::Instant::now();
    while std::fs::read_to_string(&report).map(|s| s.lines().count()).unwrap_or(0) < 2 {
        assert!(t0.elapsed().as_secs() < 600, "no frame written in 10 minutes");
        std::thread::sleep(std::time::Duration::from_millis(5));
    }
    let kill = Command::new("kill").args(["-TERM", &child.id().to_string()]).status().unwrap();
    assert!(kill.success());
    let out = child.wait_with_output().unwrap();
    let err = String::from_utf8_lossy(&out.stderr);
    assert_eq!(out.status.code(), Some(130), "{err}");
    assert!(err.contains("--resume"), "{err}");
    // The container is closed and plays; the report lists exactly its frames.
    let (got, _) = read_all(&output);
    let lines = report_lines(&report);
    assert!(got.len() >= 2 && got.len() < n, "{} of {n} frames", got.len());
    assert_eq!(lines.len(), got.len());
    let s: serde_json::Value = serde_json::from_str(&std::fs::read_to_string(d.join("out.summary.json")).unwrap()).unwrap();
    assert_eq!(s["interrupted"], true);
    assert_eq!(s["frames_written"].as_u64().unwrap() as usize, got.len());
    // Resume: the frames written are kept bit for bit (lossless container), the rest follow.
    let (ok, err) = heliar(&[&args[..], &["--resume"]].concat());
    assert!(ok, "{err}");
    let (all, fps) = read_all(&output);
    assert_eq!(all.len(), n);
    assert!((fps - 10.0).abs() < 1e-6);
    for (k, f) in got.iter().enumerate() {
        assert!(all[k] == *f, "frame {k} changed on resume");
    }
    let lines = report_lines(&report);
    assert_eq!(lines.len(), n);
    for (k, l) in lines.iter().enumerate() {
        assert_eq!(l["frame"].as_u64().unwrap() as usize, k);
    }
    assert!(!output.with_extension("partial.mkv").exists());
    // The estimator was replayed over the frames kept: every line of the resumed run's report
    // has the lighting of an uninterrupted run of the same video (a fresh estimator at the first
    // resumed frame would restart its temporal smoothing there and differ).
    let whole = d.join("whole.mkv");
    let (ok, err) = heliar(&[&args[..4], &["--output", whole.to_str().unwrap()], &args[6..]].concat());
    assert!(ok, "{err}");
    let reference = report_lines(&d.join("whole.report.jsonl"));
    assert_eq!(reference.len(), n);
    for (k, (a, b)) in lines.iter().zip(&reference).enumerate() {
        assert_eq!(a["status"], b["status"], "frame {k}");
        for key in ["pd", "pa"] {
            let (x, y) = (a[key].as_array().unwrap(), b[key].as_array().unwrap());
            for c in 0..3 {
                let (x, y) = (x[c].as_f64().unwrap(), y[c].as_f64().unwrap());
                assert!((x - y).abs() <= 1e-6 * y.abs().max(1e-3), "frame {k} {key}: resumed {x}, uninterrupted {y}");
            }
        }
    }
    std::fs::remove_dir_all(&d).ok();
}

#[test]
fn bad_input_gets_a_clear_error_and_keeps_what_was_written() {
    let d = scratch("bad");
    // Not a video.
    let junk = d.join("junk.mp4");
    std::fs::write(&junk, b"this is not a video container at all").unwrap();
    let (ok, err) = heliar(&["augment", "scenes/courtyard", "--input", junk.to_str().unwrap(), "--output", d.join("o1").to_str().unwrap(), "--start", START]);
    assert!(!ok && err.contains("junk.mp4"), "{err}");
    // Missing input.
    let (ok, err) = heliar(&["augment", "scenes/courtyard", "--input", d.join("nope.mp4").to_str().unwrap(), "--output", d.join("o2").to_str().unwrap(), "--start", START]);
    assert!(!ok && err.contains("nope.mp4") && err.contains("not found"), "{err}");
    // Frame size other than the calibration's.
    let small = d.join("small.mkv");
    let mut sink = VideoSink::create(&small, 5.0, 160, 120).unwrap();
    sink.write_rgb8(&vec![128u8; 160 * 120 * 3]).unwrap();
    sink.finish().unwrap();
    let (ok, err) = heliar(&["augment", "scenes/courtyard", "--input", small.to_str().unwrap(), "--output", d.join("o3").to_str().unwrap(), "--start", START]);
    assert!(!ok && err.contains("160×120") && err.contains("camera.toml"), "{err}");
    // Missing scene file.
    let scene = d.join("scene");
    copy_dir(&root().join("scenes/courtyard"), &scene);
    std::fs::remove_file(scene.join("proxy.glb")).unwrap();
    let (ok, err) = heliar(&["augment", scene.to_str().unwrap(), "--input", small.to_str().unwrap(), "--output", d.join("o4").to_str().unwrap(), "--start", START]);
    assert!(!ok && err.contains("proxy.glb"), "{err}");
    // Unwritable output: a regular file where the output folder should be.
    let blocker = d.join("blocker");
    std::fs::write(&blocker, b"x").unwrap();
    let input = d.join("in.mkv");
    courtyard_video(&input, 5.0, 1);
    let (ok, err) = heliar(&["augment", "scenes/courtyard", "--input", input.to_str().unwrap(), "--output", blocker.join("out.mkv").to_str().unwrap(), "--start", START]);
    assert!(!ok && err.contains("blocker"), "{err}");
    // A corrupt frame in the middle of a sequence: the frames before it are kept and listed.
    let frames = d.join("frames");
    std::fs::create_dir_all(&frames).unwrap();
    for i in 0..4 {
        std::fs::copy(root().join(format!("scenes/courtyard/frames/ldr/frame_{i:03}.png")), frames.join(format!("frame_{i:03}.png"))).unwrap();
    }
    std::fs::write(frames.join("frame_002.png"), b"\x89PNG\r\n\x1a\n broken").unwrap();
    let out = d.join("o5");
    let (ok, err) = heliar(&["augment", "scenes/courtyard", "--input", frames.to_str().unwrap(), "--output", out.to_str().unwrap(), "--start", START, "--fps", "0.1", "--exposure", "3.5"]);
    assert!(!ok && err.contains("frame_002.png") && err.contains("stopped after 2 frames"), "{err}");
    assert!(out.join("frame_000.png").exists() && out.join("frame_001.png").exists());
    assert_eq!(report_lines(&out.join("report.jsonl")).len(), 2);
    let s: serde_json::Value = serde_json::from_str(&std::fs::read_to_string(out.join("summary.json")).unwrap()).unwrap();
    assert!(s["error"].as_str().unwrap().contains("frame_002.png"), "{s}");
    std::fs::remove_dir_all(&d).ok();
}

fn copy_dir(from: &Path, to: &Path) {
    std::fs::create_dir_all(to).unwrap();
    for e in std::fs::read_dir(from).unwrap() {
        let e = e.unwrap();
        let p = e.path();
        if p.file_name().is_some_and(|n| n == "baked") {
            continue;
        }
        if p.is_dir() { copy_dir(&p, &to.join(e.file_name())) } else { std::fs::copy(&p, to.join(e.file_name())).map(|_| ()).unwrap() }
    }
}

/// A report line without its timings, the compositor's work accounting (a chunk's first frame
/// pays for the replayed ones) and the output's path.
fn comparable(v: &serde_json::Value) -> serde_json::Value {
    use serde_json::Value;
    match v {
        Value::Object(m) => Value::Object(
            m.iter()
                .filter(|(k, _)| !(k.ends_with("_ms") || ["ms", "timings", "restored", "receivers_computed", "transfer_traced", "output"].contains(&k.as_str())))
                .map(|(k, v)| (k.clone(), comparable(v)))
                .collect(),
        ),
        Value::Array(a) => Value::Array(a.iter().map(comparable).collect()),
        x => x.clone(),
    }
}

#[test]
fn video_chunks_merge_into_the_sequential_video() {
    let d = scratch("merge");
    let input = d.join("in.mkv");
    courtyard_video(&input, 5.0, 1);
    let run = |out: &Path, frames: Option<&str>| {
        let mut a = vec!["augment", "scenes/courtyard", "--input", input.to_str().unwrap(), "--output", out.to_str().unwrap(), "--start", START, "--exposure", "3.5"];
        if let Some(f) = frames {
            a.extend(["--frames", f]);
        }
        let (ok, err) = heliar(&a);
        assert!(ok, "{err}");
    };
    let (whole, a, b) = (d.join("whole.mkv"), d.join("chunks/000-005.mkv"), d.join("chunks/005-012.mkv"));
    run(&whole, None);
    run(&a, Some("0..5"));
    run(&b, Some("5..12"));
    // `heliar frames` counts what planning needs: the decoded frames of a video.
    let out = Command::new(env!("CARGO_BIN_EXE_heliar")).args(["frames", input.to_str().unwrap()]).output().unwrap();
    let info: serde_json::Value = serde_json::from_slice(&out.stdout).unwrap();
    assert_eq!((info["kind"].as_str(), info["frames"].as_u64(), info["fps"].as_f64()), (Some("video"), Some(12), Some(5.0)), "{info}");
    // Given out of order; merged into a video.
    let merged = d.join("merged.mkv");
    let (ok, err) = heliar(&["merge", b.to_str().unwrap(), a.to_str().unwrap(), "--output", merged.to_str().unwrap()]);
    assert!(ok, "{err}");
    let ((got, fps), (want, _)) = (read_all(&merged), read_all(&whole));
    assert_eq!(got.len(), 12);
    assert!((fps - 5.0).abs() < 1e-6, "frame rate {fps}");
    // FFV1 is lossless, and the chunks replayed the whole history: code for code the sequential run.
    for (k, (g, w)) in got.iter().zip(&want).enumerate() {
        assert!(g == w, "frame {k} differs from the sequential run's");
    }
    let (lm, lw) = (report_lines(&d.join("merged.report.jsonl")), report_lines(&d.join("whole.report.jsonl")));
    assert_eq!(lm.len(), 12);
    for (m, w) in lm.iter().zip(&lw) {
        assert_eq!(comparable(m), comparable(w));
    }
    assert!(lm[7]["output"].as_str().unwrap().ends_with("merged.mkv frame 7"), "{}", lm[7]["output"]);
    let s: serde_json::Value = serde_json::from_str(&std::fs::read_to_string(d.join("merged.summary.json")).unwrap()).unwrap();
    assert_eq!(s["frames_written"], 12);
    // Into another container: the same frame count and rate (MPEG-4 is lossy: not compared code for code).
    let mp4 = d.join("merged.mp4");
    let (ok, err) = heliar(&["merge", a.to_str().unwrap(), b.to_str().unwrap(), "--output", mp4.to_str().unwrap()]);
    assert!(ok, "{err}");
    let (got, fps) = read_all(&mp4);
    assert_eq!(got.len(), 12);
    assert!((fps - 5.0).abs() < 1e-3, "frame rate {fps}");
    // Videos do not merge into a folder, nor folders into a video; nothing is written.
    let (ok, err) = heliar(&["merge", a.to_str().unwrap(), b.to_str().unwrap(), "--output", d.join("folder").to_str().unwrap()]);
    assert!(!ok && err.contains("000-005.mkv") && err.contains("is a video"), "{err}");
    assert!(!d.join("folder/report.jsonl").exists());
    // A chunk whose video lost frames (its report lists 7) is named.
    let short = d.join("chunks/short/005-012.mkv");
    std::fs::create_dir_all(short.parent().unwrap()).unwrap();
    let mut sink = VideoSink::create(&short, 5.0, 320, 240).unwrap();
    for f in read_all(&b).0.iter().take(3) {
        sink.write_rgb8(f).unwrap();
    }
    sink.finish().unwrap();
    for suffix in ["report.jsonl", "summary.json"] {
        std::fs::copy(d.join(format!("chunks/005-012.{suffix}")), d.join(format!("chunks/short/005-012.{suffix}"))).unwrap();
    }
    let bad = d.join("bad.mkv");
    let (ok, err) = heliar(&["merge", a.to_str().unwrap(), short.to_str().unwrap(), "--output", bad.to_str().unwrap()]);
    assert!(!ok && err.contains("short/005-012.mkv") && err.contains("ends after 3 frames"), "{err}");
    assert!(!bad.exists(), "a failed merge leaves no video");
    std::fs::remove_dir_all(&d).ok();
}
