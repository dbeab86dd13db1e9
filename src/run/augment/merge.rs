//! Joining chunks (`heliar merge`): the outputs of `augment --frames A..B` runs become one
//! output with one report (frames in order, no gaps, no duplicates) and one summary.
//!
//! - **Folders** merge into a folder: the frames are hard links where the file system allows,
//!   else copies, each through a temporary file and a rename.
//! - **Videos** (`--output A-B.mkv` chunks) merge into one video: every chunk's frames are
//!   decoded in order and encoded into a temporary file beside the output, renamed over it when
//!   complete, at the chunks' input frame rate (`fps_in` of their summaries, which must agree).
//!   With lossless FFV1 (`.mkv`) chunks the merged frames are the sequential run's frames, code
//!   for code; `.mp4` chunks would be decoded and encoded a second time, so chunks should be
//!   `.mkv` whatever the merged container is. A chunk whose video holds more or fewer frames than
//!   its report lists is an error naming it.
//!
//! The chunks may be given in any order; they are sorted by their first frame. A chunk that was
//! interrupted or stopped by an error, a gap between two chunks, an overlap, and folders mixed
//! with videos are errors that name the chunk. The merged summary adds the chunks' counts and
//! wall times and recomputes the stage timings from the report's per-frame times; no contact
//! sheet is written.

use crate::io::guard::OutputGuard;
use crate::run::sink::{OutputLock, Outputs, StageTime};
use anyhow::{Context, Result, bail};
use serde_json::{Map, Value};
use std::path::{Path, PathBuf};

/// What to merge.
#[derive(Clone, Debug)]
pub struct MergeOptions {
    /// The chunks' output folders.
    pub chunks: Vec<PathBuf>,
    /// The merged output folder.
    pub output: PathBuf,
    /// Write even where the output would overwrite a chunk.
    pub force: bool,
}

/// What a merge wrote.
#[derive(Clone, Debug)]
pub struct MergeOutcome {
    /// The frames merged: `first..end`.
    pub frames: std::ops::Range<usize>,
    /// The merged outputs.
    pub outputs: Outputs,
    /// Frames hard-linked (the others were copied).
    pub linked: usize,
}

/// One chunk read back: its report lines and summary.
struct Chunk {
    /// The chunk's output folder, or its video file.
    dir: PathBuf,
    video: bool,
    first: usize,
    lines: Vec<Map<String, Value>>,
    summary: Map<String, Value>,
}

impl Chunk {
    fn end(&self) -> usize {
        self.first + self.lines.len()
    }

    fn describe(&self) -> String {
        format!("{} (frames {}..{})", self.dir.display(), self.first, self.end())
    }

    /// Reads a chunk's report and summary, checking its frames follow each other and the run
    /// ended normally.
    fn read(dir: &Path) -> Result<Self> {
        let out = Outputs::of(dir)?;
        let text = std::fs::read_to_string(&out.report).with_context(|| format!("{}: reading the chunk's report", out.report.display()))?;
        let mut lines = Vec::new();
        for (n, line) in text.lines().enumerate() {
            let v: Value = serde_json::from_str(line).with_context(|| format!("{} line {}: not a JSON report line", out.report.display(), n + 1))?;
            let Value::Object(m) = v else { bail!("{} line {}: not a JSON object", out.report.display(), n + 1) };
            lines.push(m);
        }
        let frame = |n: usize, m: &Map<String, Value>| -> Result<usize> {
            m.get("frame").and_then(Value::as_u64).map(|f| f as usize).with_context(|| format!("{} line {}: field `frame` missing or not a frame number", out.report.display(), n + 1))
        };
        let Some(head) = lines.first() else { bail!("{}: the chunk has no frames (empty report)", out.report.display()) };
        let first = frame(0, head)?;
        for (n, m) in lines.iter().enumerate() {
            let f = frame(n, m)?;
            if f != first + n {
                bail!("{} line {}: frame {f} where frame {} was expected (the report's frames must follow each other)", out.report.display(), n + 1, first + n);
            }
        }
        let stext = std::fs::read_to_string(&out.summary).with_context(|| format!("{}: reading the chunk's summary", out.summary.display()))?;
        let Ok(Value::Object(summary)) = serde_json::from_str::<Value>(&stext) else { bail!("{}: not a JSON summary", out.summary.display()) };
        let chunk = Self { dir: dir.to_owned(), video: out.video, first, lines, summary };
        if chunk.summary.get("interrupted").and_then(Value::as_bool) == Some(true) {
            bail!("chunk {}: the run was interrupted (`augment --resume` with the same --frames finishes it)", chunk.describe());
        }
        if let Some(e) = chunk.summary.get("error").and_then(Value::as_str) {
            bail!("chunk {}: the run stopped early: {e}", chunk.describe());
        }
        if let Some(c) = chunk.summary.get("chunk")
            && let Some(end) = c.get("end").and_then(Value::as_u64)
            && (end as usize) > chunk.end()
            && chunk.summary.get("input_frames").and_then(Value::as_u64).is_none_or(|n| (n as usize) > chunk.end())
        {
            bail!("chunk {}: the run was asked for frames {first}..{end} but wrote {}", chunk.describe(), chunk.lines.len());
        }
        Ok(chunk)
    }
}

/// Sorted chunks must cover one run of frames: a gap or an overlap names both chunks.
fn check_contiguous(chunks: &[Chunk]) -> Result<()> {
    for w in chunks.windows(2) {
        let (a, b) = (&w[0], &w[1]);
        if b.first > a.end() {
            bail!("gap: frames {}..{} are in no chunk, between chunk {} and chunk {}", a.end(), b.first, a.describe(), b.describe());
        }
        if b.first < a.end() {
            bail!("overlap: chunk {} repeats frames {}..{} of chunk {}", b.describe(), b.first, a.end().min(b.end()), a.describe());
        }
    }
    Ok(())
}

/// Links (else copies) `src` to `dst` through a temporary file and a rename. True when linked.
fn place(src: &Path, dst: &Path) -> Result<bool> {
    let tmp = crate::io::temp_path_for(dst);
    let _ = std::fs::remove_file(&tmp);
    let linked = std::fs::hard_link(src, &tmp).is_ok();
    if !linked {
        std::fs::copy(src, &tmp).with_context(|| format!("copying {} to {}", src.display(), tmp.display()))?;
    }
    std::fs::rename(&tmp, dst).map_err(|e| {
        let _ = std::fs::remove_file(&tmp);
        anyhow::Error::new(e).context(format!("renaming {} to {}", tmp.display(), dst.display()))
    })?;
    Ok(linked)
}

/// `a += b` for the numbers of two count trees (summaries' `counts`).
fn add_counts(a: &mut Value, b: &Value) {
    match (a, b) {
        (Value::Object(a), Value::Object(b)) => {
            for (k, v) in b {
                match a.get_mut(k) {
                    Some(x) => add_counts(x, v),
                    None => {
                        a.insert(k.clone(), v.clone());
                    }
                }
            }
        }
        (a @ Value::Number(_), Value::Number(b)) => {
            if let (Some(x), Some(y)) = (a.as_u64(), b.as_u64()) {
                *a = Value::from(x + y);
            }
        }
        _ => {}
    }
}

/// The stage timings of the merged report, from its per-frame times.
fn stages_of(lines: &[Map<String, Value>]) -> Result<Value> {
    let mut stages = Map::new();
    for (name, field) in [("decode", "decode_ms"), ("estimate", "estimate_ms"), ("relight", "relight"), ("composite", "composite_ms"), ("encode", "encode_ms")] {
        let mut st = StageTime::default();
        for l in lines {
            let v = if field == "relight" { l.get("relight").and_then(|r| r.get("ms")) } else { l.get(field) };
            st.add(v.and_then(Value::as_f64).unwrap_or(0.0));
        }
        st.finish();
        stages.insert(name.into(), serde_json::to_value(&st)?);
    }
    Ok(Value::Object(stages))
}

/// The merged summary: the first chunk's, with the totals of all.
fn summary_of(chunks: &[Chunk], lines: &[Map<String, Value>], out: &Outputs) -> Result<Value> {
    let mut s = chunks[0].summary.clone();
    let sum = |key: &str| -> f64 { chunks.iter().filter_map(|c| c.summary.get(key).and_then(Value::as_f64)).sum() };
    let (this_run, wall) = (sum("frames_this_run"), sum("wall_s"));
    s.insert("output".into(), out.target.display().to_string().into());
    s.insert("frames_written".into(), lines.len().into());
    s.insert("frames_this_run".into(), (this_run as u64).into());
    s.insert("resumed_after".into(), 0.into());
    s.insert("wall_s".into(), wall.into());
    s.insert("frames_per_second".into(), (if wall > 0.0 { this_run / wall } else { 0.0 }).into());
    let mut counts = Value::Object(Map::new());
    for c in chunks {
        if let Some(v) = c.summary.get("counts") {
            add_counts(&mut counts, v);
        }
    }
    s.insert("counts".into(), counts);
    s.insert("stages".into(), stages_of(lines)?);
    s.remove("chunk");
    let parts: Vec<Value> = chunks
        .iter()
        .map(|c| serde_json::json!({ "dir": c.dir.display().to_string(), "frames": [c.first, c.end()], "warmup": c.summary.get("chunk").and_then(|k| k.get("warmup")).cloned() }))
        .collect();
    s.insert("chunks".into(), parts.into());
    Ok(Value::Object(s))
}

/// Merges the chunks (see the module docs).
pub fn merge(opts: &MergeOptions) -> Result<MergeOutcome> {
    if opts.chunks.is_empty() {
        bail!("merge: no chunks given");
    }
    let out = Outputs::of(&opts.output)?;
    let inputs: Vec<&Path> = opts.chunks.iter().map(PathBuf::as_path).collect();
    let guard = OutputGuard::new(None, &inputs, opts.force);
    if out.video { guard.check_file(&out.target)? } else { guard.check_dir(&out.target)? }
    for f in [&out.report, &out.summary] {
        guard.check_file(f)?;
    }
    let mut chunks = opts.chunks.iter().map(|d| Chunk::read(d)).collect::<Result<Vec<_>>>()?;
    chunks.sort_by_key(|c| c.first);
    check_contiguous(&chunks)?;
    check_kinds(&chunks, &out)?;
    std::fs::create_dir_all(out.parent()).with_context(|| format!("{}: cannot create the output folder", out.parent().display()))?;
    let _lock = OutputLock::acquire(&out)?;
    let (lines, linked) = if out.video { (join_videos(&chunks, &out)?, 0) } else { link_frames(&chunks, &out)? };
    let mut text = String::new();
    for l in &lines {
        text.push_str(&serde_json::to_string(l)?);
        text.push('\n');
    }
    crate::io::write_atomic(&out.report, text.as_bytes())?;
    let summary = summary_of(&chunks, &lines, &out)?;
    crate::io::write_atomic(&out.summary, serde_json::to_string_pretty(&summary)?.as_bytes())?;
    let first = chunks[0].first;
    Ok(MergeOutcome { frames: first..first + lines.len(), outputs: out, linked })
}

/// Folders merge into a folder and videos into a video; a mix names the first odd chunk.
fn check_kinds(chunks: &[Chunk], out: &Outputs) -> Result<()> {
    let Some(odd) = chunks.iter().find(|c| c.video != out.video) else { return Ok(()) };
    if out.video {
        bail!(
            "chunk {} is a folder of frames: a video output is merged from video chunks (`augment --frames A..B --output A-B.mkv`); give an output folder to merge folders",
            odd.describe()
        );
    }
    bail!("chunk {} is a video: video chunks merge into a video (e.g. `--output merged.mkv`), not into a folder", odd.describe())
}

/// The folder chunks' frames placed in the output folder; their report lines, renamed.
fn link_frames(chunks: &[Chunk], out: &Outputs) -> Result<(Vec<Map<String, Value>>, usize)> {
    let (mut lines, mut linked) = (Vec::new(), 0);
    for c in chunks {
        for l in &c.lines {
            let given = l.get("output").and_then(Value::as_str).with_context(|| format!("chunk {}: frame {}: field `output` missing", c.dir.display(), l["frame"]))?;
            let name = Path::new(given).file_name().with_context(|| format!("chunk {}: frame {}: `output` {given} names no file", c.dir.display(), l["frame"]))?;
            let src = c.dir.join(name);
            if !src.is_file() {
                bail!("chunk {}: frame {}: {} is missing", c.dir.display(), l["frame"], src.display());
            }
            let dst = out.target.join(name);
            linked += place(&src, &dst)? as usize;
            let mut l = l.clone();
            l.insert("output".into(), dst.display().to_string().into());
            lines.push(l);
        }
    }
    Ok((lines, linked))
}

/// The frame rate of the video chunks: their inputs' (`fps_in`), which must agree.
#[cfg_attr(not(feature = "opencv"), allow(dead_code))]
fn chunk_fps(chunks: &[Chunk]) -> Result<f64> {
    let fps_of = |c: &Chunk| -> Result<f64> {
        c.summary.get("fps_in").and_then(Value::as_f64).filter(|f| f.is_finite() && *f > 0.0).with_context(|| format!("chunk {}: its summary has no input frame rate (`fps_in`)", c.describe()))
    };
    let fps = fps_of(&chunks[0])?;
    for c in &chunks[1..] {
        let f = fps_of(c)?;
        if (f - fps).abs() > 1e-9 * fps {
            bail!("chunk {} was made at {f} frames/s, chunk {} at {fps}: chunks of one clip share its rate", c.describe(), chunks[0].describe());
        }
    }
    Ok(fps)
}

/// The video chunks' frames encoded, in order, into `out.target` (through a temporary file and
/// a rename); their report lines, with `output` naming the merged video.
#[cfg(feature = "opencv")]
fn join_videos(chunks: &[Chunk], out: &Outputs) -> Result<Vec<Map<String, Value>>> {
    let fps = chunk_fps(chunks)?;
    let tmp = crate::io::temp_path_for(&out.target);
    let _ = std::fs::remove_file(&tmp);
    if let Err(e) = encode_chunks(chunks, &tmp, fps) {
        let _ = std::fs::remove_file(&tmp);
        return Err(e);
    }
    std::fs::rename(&tmp, &out.target).map_err(|e| {
        let _ = std::fs::remove_file(&tmp);
        anyhow::Error::new(e).context(format!("renaming {} to {}", tmp.display(), out.target.display()))
    })?;
    let mut lines = Vec::new();
    for c in chunks {
        for (k, l) in c.lines.iter().enumerate() {
            let mut l = l.clone();
            l.insert("output".into(), format!("{} frame {}", out.target.display(), c.first + k).into());
            lines.push(l);
        }
    }
    Ok(lines)
}

#[cfg(not(feature = "opencv"))]
fn join_videos(_chunks: &[Chunk], out: &Outputs) -> Result<Vec<Map<String, Value>>> {
    bail!("{}: merging videos needs heliar built with `--features opencv`", out.target.display())
}

/// Decodes every chunk's frames (exactly as many as its report lists) into one video at `path`.
#[cfg(feature = "opencv")]
fn encode_chunks(chunks: &[Chunk], path: &Path, fps: f64) -> Result<()> {
    use crate::io::frames::FrameData;
    use crate::io::video::{VideoSink, VideoSource};
    let mut sink: Option<(VideoSink, (u32, u32))> = None;
    for c in chunks {
        let mut v = VideoSource::open_file(&c.dir).with_context(|| format!("chunk {}: its video cannot be read", c.describe()))?;
        for n in 0..c.lines.len() {
            let Some((f, _)) = v.read().with_context(|| format!("chunk {}: decoding frame {n}", c.describe()))? else {
                bail!("chunk {}: its video ends after {n} frames, but its report lists {}", c.describe(), c.lines.len())
            };
            let FrameData::Ldr { codes, .. } = &f.data else { bail!("chunk {}: frame {n} is not an 8-bit video frame", c.describe()) };
            let rgb: Vec<u8> = codes.iter().map(|&c| c as u8).collect();
            let (s, size) = match &mut sink {
                Some(s) => s,
                None => sink.insert((VideoSink::create(path, fps, f.width, f.height)?, (f.width, f.height))),
            };
            if *size != (f.width, f.height) {
                bail!("chunk {}: its frames are {}×{}, the first chunk's {}×{}: chunks of one clip share its size", c.describe(), f.width, f.height, size.0, size.1);
            }
            s.write_rgb8(&rgb)?;
        }
        if v.read().ok().flatten().is_some() {
            bail!("chunk {}: its video holds more than the {} frames its report lists", c.describe(), c.lines.len());
        }
    }
    if let Some((mut s, _)) = sink {
        s.finish()?;
    }
    Ok(())
}
