//! An interrupted and resumed `heliar augment` gives the same frames as an uninterrupted one,
//! byte for byte (issue 12): a run stopped by `--max-frames`, by SIGINT, by SIGTERM (both finish
//! the frame in hand and close the output) and by SIGKILL (nothing is closed: the report may end
//! in a torn line, the lock is left behind), each at a different frame, then `--resume`. The
//! replay keeps every cache as an uninterrupted run has it (`render::compositor::replay`), so
//! the EXR files after the resume point must equal the uninterrupted run's.

use std::collections::BTreeMap;
use std::path::{Path, PathBuf};
use std::process::{Command, Stdio};
use std::time::{Duration, Instant};

fn scene() -> PathBuf {
    Path::new(env!("CARGO_MANIFEST_DIR")).join("scenes/courtyard")
}

fn scratch() -> PathBuf {
    let d = std::env::temp_dir().join(format!("heliar-interrupt-{}", std::process::id()));
    let _ = std::fs::remove_dir_all(&d);
    std::fs::create_dir_all(&d).unwrap();
    d
}

fn args(out: &Path, extra: &[&str]) -> Vec<String> {
    let s = scene();
    let mut a: Vec<String> = ["augment", s.to_str().unwrap(), "--input", s.join("frames/hdr").to_str().unwrap(), "--output", out.to_str().unwrap()]
        .iter()
        .map(|x| x.to_string())
        .collect();
    a.extend(extra.iter().map(|x| x.to_string()));
    a
}

fn run(out: &Path, extra: &[&str]) {
    let o = Command::new(env!("CARGO_BIN_EXE_heliar")).args(args(out, extra)).output().unwrap();
    assert!(o.status.success(), "{}", String::from_utf8_lossy(&o.stderr));
}

/// The EXR frames of an output folder, by name.
fn frames(dir: &Path) -> BTreeMap<String, Vec<u8>> {
    std::fs::read_dir(dir)
        .unwrap()
        .flatten()
        .filter(|e| e.path().extension().is_some_and(|x| x == "exr") && !e.file_name().to_string_lossy().starts_with('.'))
        .map(|e| (e.file_name().to_string_lossy().into_owned(), std::fs::read(e.path()).unwrap()))
        .collect()
}

fn lines(out: &Path) -> usize {
    std::fs::read_to_string(out.join("report.jsonl")).map_or(0, |t| t.lines().filter(|l| l.ends_with('}')).count())
}

/// Starts a run, sends `signal` once `after` frames are in the report, and waits for the end.
fn interrupt(out: &Path, signal: &str, after: usize) {
    let mut child = Command::new(env!("CARGO_BIN_EXE_heliar")).args(args(out, &[])).stdout(Stdio::null()).stderr(Stdio::null()).spawn().unwrap();
    let t = Instant::now();
    while lines(out) < after {
        assert!(t.elapsed() < Duration::from_secs(600), "no {after} frames after 10 minutes");
        if child.try_wait().unwrap().is_some() {
            panic!("the run ended before frame {after}");
        }
        std::thread::sleep(Duration::from_millis(20));
    }
    let ok = Command::new("kill").args([&format!("-{signal}"), &child.id().to_string()]).status().unwrap().success();
    assert!(ok, "kill -{signal}");
    let status = child.wait().unwrap();
    assert!(!status.success(), "{signal}: the run should not report success");
}

#[test]
fn interrupted_and_resumed_runs_give_the_uninterrupted_frames_byte_for_byte() {
    let d = scratch();
    let whole = d.join("whole");
    run(&whole, &[]);
    let want = frames(&whole);
    assert_eq!(want.len(), 12);
    // (how the run stops, at which frame); each stop at a different point of the sequence, so
    // the resume point falls before, inside and after the cloud and the transfer's retraces.
    let cases: [(&str, usize); 4] = [("max-frames", 5), ("INT", 3), ("TERM", 8), ("KILL", 6)];
    for (how, at) in cases {
        let out = d.join(format!("stop-{how}"));
        match how {
            "max-frames" => run(&out, &["--max-frames", &at.to_string()]),
            signal => interrupt(&out, signal, at),
        }
        let kept = lines(&out);
        assert!(kept >= at.min(12) && kept < 12, "{how}: {kept} frames before the resume");
        run(&out, &["--resume"]);
        let got = frames(&out);
        assert_eq!(got.keys().collect::<Vec<_>>(), want.keys().collect::<Vec<_>>(), "{how}: frame files");
        let differ: Vec<&String> = want.keys().filter(|k| got[*k] != want[*k]).collect();
        assert!(differ.is_empty(), "{how} at frame {kept}: these frames differ from the uninterrupted run: {differ:?}");
        assert_eq!(lines(&out), 12, "{how}: report lines");
        assert!(!out.join(".heliar.lock").exists(), "{how}: the lock stayed");
        let leftovers: Vec<String> = std::fs::read_dir(&out).unwrap().flatten().map(|e| e.file_name().to_string_lossy().into_owned()).filter(|n| n.contains(".tmp")).collect();
        assert!(leftovers.is_empty(), "{how}: temporary files left: {leftovers:?}");
    }
    std::fs::remove_dir_all(&d).ok();
}

/// Every value of `key` anywhere in a JSON value.
fn values_of(v: &serde_json::Value, key: &str, out: &mut Vec<u64>) {
    match v {
        serde_json::Value::Object(m) => m.iter().for_each(|(k, x)| {
            if k == key {
                out.extend(x.as_u64());
            }
            values_of(x, key, out);
        }),
        serde_json::Value::Array(a) => a.iter().for_each(|x| values_of(x, key, out)),
        _ => {}
    }
}

/// Issue 13 part 4: the sun moves 0.5° per frame (frames 2 minutes apart from the sequence's own
/// start), so the receivers' `b` and the objects' `R_d` are re-traced a slice per frame all the
/// time; a run stopped in the middle of a re-trace or after a swap resumes to the uninterrupted
/// frames, byte for byte, and no frame after the first traces more paths than its budget.
///
/// The courtyard has 5344 receiver pixels (512 paths each with the objects) and 667 transfer
/// pixels (512 paths). With 2¹⁸ paths per frame the receivers' re-trace takes 11 frames and the
/// transfer's 2, so the stops at 3 and 7 fall inside a receivers' job and on both sides of
/// transfer swaps, and the receivers swap after the resume; with 2¹⁹ the receivers swap at frame 6
/// (a swap the replay passes) and the transfer is traced whole every frame.
#[test]
fn a_run_resumed_during_and_after_a_sliced_retrace_gives_the_uninterrupted_frames() {
    // Not `scratch()`: the other test removes that folder when it ends.
    let d = std::env::temp_dir().join(format!("heliar-interrupt-sliced-{}", std::process::id()));
    let _ = std::fs::remove_dir_all(&d);
    std::fs::create_dir_all(&d).unwrap();
    // The last case also slices the estimator's sun-bounce re-trace (2¹⁴ paths per frame, the
    // live window's default), whose schedule the replay must repeat as well.
    for (budget, estimator) in [(1u64 << 18, 0u64), (1 << 19, 0), (1 << 19, 1 << 14)] {
        let (b, e) = (budget.to_string(), estimator.to_string());
        let fast = ["--sequence", "hdr", "--start", "2024-06-21T15:30:00+02:00", "--fps", "0.008333333", "--trace-paths-per-frame", b.as_str(), "--estimator-trace-paths-per-frame", e.as_str()];
        let whole = d.join(format!("whole-{budget}-{estimator}"));
        run(&whole, &fast);
        let want = frames(&whole);
        assert_eq!(want.len(), 12);
        // Paths per frame from the report: receivers with the objects (differential model: two
        // integrals of the estimator's 256 bounce paths), transfer pixels of 512 paths.
        let report = std::fs::read_to_string(whole.join("report.jsonl")).unwrap();
        let mut retraced = 0;
        for (i, line) in report.lines().enumerate().skip(1) {
            let v: serde_json::Value = serde_json::from_str(line).unwrap();
            let (mut rc, mut tt) = (Vec::new(), Vec::new());
            values_of(&v, "receivers_computed", &mut rc);
            values_of(&v, "transfer_traced", &mut tt);
            let (rc, tt) = (rc.iter().sum::<u64>(), tt.iter().sum::<u64>());
            assert!(rc * 512 <= budget && tt * 512 <= budget, "budget {budget}, frame {i}: {rc} receiver pixels, {tt} transfer pixels");
            retraced += usize::from(rc > 0);
        }
        assert!(retraced >= 10, "budget {budget}: the receivers are re-traced on most frames ({retraced} of 11)");
        for at in [3, 7] {
            let out = d.join(format!("stop-{budget}-{estimator}-{at}"));
            let n = at.to_string();
            let mut first: Vec<&str> = fast.to_vec();
            first.extend(["--max-frames", n.as_str()]);
            run(&out, &first);
            let mut again: Vec<&str> = fast.to_vec();
            again.push("--resume");
            run(&out, &again);
            let got = frames(&out);
            let differ: Vec<&String> = want.keys().filter(|k| got.get(*k) != want.get(*k)).collect();
            assert!(differ.is_empty(), "budget {budget}, estimator {estimator}, resumed at frame {at}: these frames differ from the uninterrupted run: {differ:?}");
        }
    }
    std::fs::remove_dir_all(&d).ok();
}

/// A statue that moves and turns from frame 2 on (frames 10 s apart): its cuts serve every move.
const MOTION_KEYS: &str = "[[virtual_objects.motion.keyframes]]\ntime = 0.0\ntranslation = [-1.9, 0, 0]\nrotation_y_deg = 25\n\
                           [[virtual_objects.motion.keyframes]]\ntime = 10.0\ntranslation = [-1.9, 0, 0]\nrotation_y_deg = 25\n\
                           [[virtual_objects.motion.keyframes]]\ntime = 20.0\ntranslation = [-1.2, 0, 0.6]\nrotation_y_deg = 70\n\
                           [[virtual_objects.motion.keyframes]]\ntime = 50.0\ntranslation = [-0.6, 0, 1.0]\nrotation_y_deg = 115\n\
                           [[virtual_objects.motion.keyframes]]\ntime = 110.0\ntranslation = [-1.5, 0, 1.2]\nrotation_y_deg = 160\n";

/// With moving objects, the first frame computes the receivers' `c`, `b` along the whole motion
/// (`Compositor::reach_motion`) for its sun; a resumed run replays that (owed for the first
/// frame's sun, paid by the first frame rendered), with the objects' moves (`c_v`, `b_v`
/// forgotten) and the cuts' `c_v`, `b_v` at each replayed frame's poses owed in order, so its
/// frames equal the uninterrupted run's byte for byte: resumed before the moves, in the cloud
/// (frames 4–8, the sun nearly gone at 6) and at frame 9, while the receivers' sun re-trace runs
/// in slices of 32 pixels a frame (from frame 7 on). Without the owed visibility, stops at 4 and
/// 6 differ; without serving the cuts' `c_v` during a re-trace (the uninterrupted run kept
/// frame 6's contact shadow while the statue moved), the stop at 9 differs on frames 9–11.
#[test]
fn a_resumed_run_with_moving_objects_gives_the_uninterrupted_frames() {
    let d = scratch().join("motion");
    let scene = crate::common::scratch_courtyard("interrupt-motion");
    let p = scene.join("scene.toml");
    let m = std::fs::read_to_string(&p).unwrap();
    assert!(m.contains("scale = 1.0\n"));
    std::fs::write(&p, m.replacen("scale = 1.0\n", &format!("scale = 1.0\n{MOTION_KEYS}\n"), 1)).unwrap();
    let input = scene_dir_frames();
    let go = |out: &Path, extra: &[&str]| {
        let o = Command::new(env!("CARGO_BIN_EXE_heliar"))
            .args(["augment", scene.to_str().unwrap(), "--input", input.to_str().unwrap(), "--output", out.to_str().unwrap(), "--start", "2024-06-21T15:30:00+02:00", "--fps", "0.1"])
            .args(extra)
            .output()
            .unwrap();
        assert!(o.status.success(), "{}", String::from_utf8_lossy(&o.stderr));
    };
    let whole = d.join("whole");
    go(&whole, &[]);
    let want = frames(&whole);
    assert_eq!(want.len(), 12);
    // The uninterrupted run's first frame computed `c`, `b` along the motion, the moved frames
    // up to the cloud none; from frame 7 on, with the sun back and moved past the rebuild angle
    // since frame 0, the receivers' bounce is re-traced in per-frame slices of 32 pixels.
    let report = std::fs::read_to_string(whole.join("report.jsonl")).unwrap();
    let computed: Vec<u64> = report.lines().map(|l| serde_json::from_str::<serde_json::Value>(l).unwrap()["passes"]["receivers_computed"].as_u64().unwrap_or(0)).collect();
    assert!(computed[0] > 0 && computed[2..7].iter().all(|c| *c == 0) && computed[7..].iter().all(|c| *c > 0), "receivers computed per frame: {computed:?}");
    for at in [2usize, 6, 9] {
        let out = d.join(format!("stop-{at}"));
        go(&out, &["--max-frames", &at.to_string()]);
        go(&out, &["--resume"]);
        let got = frames(&out);
        assert_eq!(got.keys().collect::<Vec<_>>(), want.keys().collect::<Vec<_>>(), "resumed at {at}: frame files");
        let differ: Vec<&String> = want.keys().filter(|k| got[*k] != want[*k]).collect();
        assert!(differ.is_empty(), "resumed at frame {at}: these frames differ from the uninterrupted run: {differ:?}");
    }
    std::fs::remove_dir_all(&d).ok();
    std::fs::remove_dir_all(&scene).ok();
}

fn scene_dir_frames() -> PathBuf {
    scene().join("frames/hdr")
}
