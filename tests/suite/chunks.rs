//! Deterministic chunks (issue 17): `heliar augment --frames A..B` with the whole history as
//! warm-up (the default) writes the sequential run's frames byte for byte, and `heliar merge`
//! joins chunks into the sequential run's folder (EXR bytes, and report lines but for their
//! timings and the compositor's work accounting, which a chunk's first frame pays for the
//! replayed ones: `passes.restored`, `receivers_computed`, `transfer_traced`). A gap or an
//! overlap between chunks is an error naming the chunk; merge refuses to write into a chunk.

use std::collections::BTreeMap;
use std::path::{Path, PathBuf};
use std::process::{Command, Output};

fn scene() -> PathBuf {
    Path::new(env!("CARGO_MANIFEST_DIR")).join("scenes/courtyard")
}

fn scratch(name: &str) -> PathBuf {
    let d = std::env::temp_dir().join(format!("heliar-chunks-{}-{name}", std::process::id()));
    let _ = std::fs::remove_dir_all(&d);
    std::fs::create_dir_all(&d).unwrap();
    d
}

fn heliar(args: &[&str]) -> Output {
    Command::new(env!("CARGO_BIN_EXE_heliar")).args(args).output().unwrap()
}

fn augment(out: &Path, extra: &[&str]) -> Output {
    let s = scene();
    let (s_str, input, out) = (s.to_str().unwrap(), s.join("frames/hdr"), out.to_str().unwrap());
    let mut a = vec!["augment", s_str, "--input", input.to_str().unwrap(), "--output", out];
    a.extend_from_slice(extra);
    heliar(&a)
}

fn ok(o: Output) -> Output {
    assert!(o.status.success(), "{}", String::from_utf8_lossy(&o.stderr));
    o
}

fn merge(chunks: &[&Path], out: &Path) -> Output {
    let mut a: Vec<&str> = vec!["merge"];
    a.extend(chunks.iter().map(|c| c.to_str().unwrap()));
    a.extend(["--output", out.to_str().unwrap()]);
    heliar(&a)
}

/// Every file of a folder (not the lock), by name.
fn files(dir: &Path) -> BTreeMap<String, Vec<u8>> {
    std::fs::read_dir(dir)
        .unwrap()
        .flatten()
        .filter(|e| e.path().is_file() && !e.file_name().to_string_lossy().starts_with('.'))
        .map(|e| (e.file_name().to_string_lossy().into_owned(), std::fs::read(e.path()).unwrap()))
        .collect()
}

fn exrs(dir: &Path) -> BTreeMap<String, Vec<u8>> {
    files(dir).into_iter().filter(|(n, _)| n.ends_with(".exr")).collect()
}

/// A report value without timings, work accounting and the output's folder.
fn normalise(v: &serde_json::Value) -> serde_json::Value {
    use serde_json::Value;
    match v {
        Value::Object(m) => Value::Object(
            m.iter()
                .filter(|(k, _)| !(k.ends_with("_ms") || *k == "ms" || *k == "timings" || *k == "restored" || *k == "receivers_computed" || *k == "transfer_traced"))
                .map(|(k, v)| match (k.as_str(), v) {
                    ("output", Value::String(p)) => (k.clone(), Value::String(Path::new(p).file_name().unwrap().to_string_lossy().into_owned())),
                    _ => (k.clone(), normalise(v)),
                })
                .collect(),
        ),
        Value::Array(a) => Value::Array(a.iter().map(normalise).collect()),
        x => x.clone(),
    }
}

fn report(dir: &Path) -> Vec<serde_json::Value> {
    std::fs::read_to_string(dir.join("report.jsonl")).unwrap().lines().map(|l| normalise(&serde_json::from_str(l).unwrap())).collect()
}

fn stderr(o: &Output) -> String {
    String::from_utf8_lossy(&o.stderr).into_owned()
}

#[test]
fn chunks_with_the_whole_history_as_warm_up_merge_into_the_sequential_run() {
    let d = scratch("merge");
    let whole = d.join("whole");
    ok(augment(&whole, &[]));
    let want = exrs(&whole);
    assert_eq!(want.len(), 12);
    let chunk = |r: &str| d.join(format!("chunk-{r}"));
    let (c0, c1, c2) = (chunk("0..4"), chunk("4..8"), chunk("8..12"));
    for (c, r) in [(&c0, "0..4"), (&c1, "4..8"), (&c2, "8..12")] {
        ok(augment(c, &["--frames", r]));
        let frames: Vec<u64> = report(c).iter().map(|l| l["frame"].as_u64().unwrap()).collect();
        let (a, b) = r.split_once("..").unwrap();
        assert_eq!(frames, (a.parse::<u64>().unwrap()..b.parse().unwrap()).collect::<Vec<_>>(), "chunk {r}: report frames");
        let summary: serde_json::Value = serde_json::from_slice(&std::fs::read(c.join("summary.json")).unwrap()).unwrap();
        assert_eq!(summary["frames_written"], 4, "chunk {r}");
        assert_eq!(summary["chunk"]["warmup"], a.parse::<u64>().unwrap(), "chunk {r}: the default warm-up is the whole history");
    }
    let merged = d.join("merged");
    // Given out of order: merge sorts the chunks by their first frame.
    let o = ok(merge(&[&c2, &c0, &c1], &merged));
    assert!(stderr(&o).contains("merged frames 0..12"), "{}", stderr(&o));
    let got = exrs(&merged);
    assert_eq!(got.keys().collect::<Vec<_>>(), want.keys().collect::<Vec<_>>(), "frame files");
    let differ: Vec<&String> = want.keys().filter(|k| got[*k] != want[*k]).collect();
    assert!(differ.is_empty(), "merged frames differ from the sequential run: {differ:?}");
    let (rw, rm) = (report(&whole), report(&merged));
    assert_eq!(rm.len(), 12);
    for (a, b) in rw.iter().zip(&rm) {
        assert_eq!(a, b, "report line of frame {}", a["frame"]);
    }
    let summary: serde_json::Value = serde_json::from_slice(&std::fs::read(merged.join("summary.json")).unwrap()).unwrap();
    assert_eq!(summary["frames_written"], 12);
    assert_eq!(summary["chunks"].as_array().map(Vec::len), Some(3));
    let statuses: u64 = summary["counts"]["statuses"].as_object().unwrap().values().map(|v| v.as_u64().unwrap()).sum();
    assert_eq!(statuses, 12, "merged counts: {}", summary["counts"]);

    // A gap (4..8 missing) and an overlap (4..8 twice) are errors naming the chunks.
    let before: Vec<_> = [&c0, &c1, &c2].iter().map(|c| files(c)).collect();
    let o = merge(&[&c0, &c2], &d.join("gap"));
    assert!(!o.status.success());
    let e = stderr(&o);
    assert!(e.contains("gap") && e.contains("frames 4..8") && e.contains(c0.to_str().unwrap()) && e.contains(c2.to_str().unwrap()), "{e}");
    assert!(!d.join("gap").exists(), "a refused merge wrote its output");
    let again = d.join("again-4..8");
    std::fs::create_dir_all(&again).unwrap();
    for (n, b) in files(&c1) {
        std::fs::write(again.join(n), b).unwrap();
    }
    let o = merge(&[&c0, &c1, &again, &c2], &d.join("overlap"));
    assert!(!o.status.success());
    let e = stderr(&o);
    assert!(e.contains("overlap") && e.contains(again.to_str().unwrap()) && e.contains("frames 4..8"), "{e}");

    // Merging into (or inside) a chunk is refused, and the chunk's bytes stay as they were.
    for out in [c1.clone(), c1.join("merged")] {
        let o = merge(&[&c0, &c1, &c2], &out);
        assert!(!o.status.success(), "merge into {} succeeded", out.display());
        assert!(stderr(&o).contains(c1.to_str().unwrap()), "{}", stderr(&o));
    }
    let after: Vec<_> = [&c0, &c1, &c2].iter().map(|c| files(c)).collect();
    assert!(before == after, "a refused merge changed a chunk");
    std::fs::remove_dir_all(&d).ok();
}

#[test]
fn an_interrupted_chunk_resumes_into_the_sequential_frames() {
    let d = scratch("resume");
    let whole = d.join("whole");
    ok(augment(&whole, &["--max-frames", "8"]));
    let c = d.join("chunk-4..8");
    ok(augment(&c, &["--frames", "4..8"]));
    // As if stopped after frame 5: two report lines kept, the later frames gone.
    let text = std::fs::read_to_string(c.join("report.jsonl")).unwrap();
    let kept: String = text.split_inclusive('\n').take(2).collect();
    std::fs::write(c.join("report.jsonl"), kept).unwrap();
    for n in ["frame_006.exr", "frame_007.exr"] {
        std::fs::remove_file(c.join(n)).unwrap();
    }
    let o = ok(augment(&c, &["--frames", "4..8", "--resume"]));
    assert!(stderr(&o).contains("resuming after frame 5"), "{}", stderr(&o));
    let (want, got) = (exrs(&whole), exrs(&c));
    assert_eq!(got.len(), 4);
    for (n, b) in &got {
        assert!(want[n] == *b, "{n} differs from the sequential run after the resume");
    }
    let frames: Vec<u64> = report(&c).iter().map(|l| l["frame"].as_u64().unwrap()).collect();
    assert_eq!(frames, vec![4, 5, 6, 7]);
    std::fs::remove_dir_all(&d).ok();
}

#[test]
fn bad_frame_ranges_are_refused_before_any_work() {
    let d = scratch("bad");
    for (args, needle) in [
        (vec!["--frames", "4..4"], "must be after the first frame"),
        (vec!["--frames", "8..3"], "must be after the first frame"),
        (vec!["--frames", "4-8"], "expected A..B"),
        (vec!["--frames", "x..8"], "first frame `x`"),
        (vec!["--warmup", "2"], "--frames"),
        (vec!["--frames", "0..4", "--max-frames", "2"], "--max-frames"),
    ] {
        let o = augment(&d.join("out"), &args);
        assert!(!o.status.success(), "{args:?} succeeded");
        assert!(stderr(&o).contains(needle), "{args:?}: {}", stderr(&o));
        assert!(!d.join("out").exists(), "{args:?}: wrote an output");
    }
}
