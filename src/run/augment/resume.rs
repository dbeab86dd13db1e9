//! Resuming an interrupted `augment`: the frames already written are kept (the report cut back
//! to the last whole line whose frame exists; a video's frames copied into a partial file), the
//! temporaries of a killed run removed, and the session replayed over the kept frames.

use super::AugmentOptions;
use crate::io::frames::{Frame, Linearizer};
use crate::run::Observer;
use crate::run::clock::ClockCheck;
use crate::run::session::OutdoorSession;
use crate::run::sink::{FrameWriter, Outputs, Thumbs, output_kind, thumb_of};
use crate::run::source::{FrameSource, Input};
use crate::scene::Scene;
use anyhow::{Context, Result, bail};
use std::path::Path;

/// Frames of an earlier run that can be kept: leading report lines `frame = first, first + 1, …`
/// that parse and whose output file exists (folders), capped by `frames_in_video` (videos). The
/// report is cut back to them.
fn resume_point(out: &Outputs, first: usize, frames_in_video: Option<usize>) -> Result<usize> {
    let text = match std::fs::read_to_string(&out.report) {
        Ok(t) => t,
        Err(e) if e.kind() == std::io::ErrorKind::NotFound => return Ok(0),
        Err(e) => return Err(e).with_context(|| format!("reading {}", out.report.display())),
    };
    let mut keep = 0usize;
    let mut bytes = 0usize;
    for line in text.split_inclusive('\n') {
        if !line.ends_with('\n') {
            break;
        }
        let Ok(v) = serde_json::from_str::<serde_json::Value>(line) else { break };
        if v["frame"].as_u64() != Some((first + keep) as u64) {
            break;
        }
        if !out.video && !v["output"].as_str().is_some_and(|p| Path::new(p).exists()) {
            break;
        }
        keep += 1;
        bytes += line.len();
    }
    if let Some(n) = frames_in_video
        && n < keep
    {
        keep = n;
        bytes = text.split_inclusive('\n').take(n).map(str::len).sum();
    }
    crate::io::write_via_temp(&out.report, |tmp| std::fs::write(tmp, &text.as_bytes()[..bytes]).map_err(anyhow::Error::from))
        .with_context(|| format!("cutting {} back to {keep} frames", out.report.display()))?;
    Ok(keep)
}

/// Removes the temporary files an interrupted run left in its output folder (a frame written
/// through a temporary file when SIGKILL came: `io::temp_path_for` names them `.NAME.PID.tmp.EXT`).
fn remove_temporaries(dir: &Path) {
    let Ok(entries) = std::fs::read_dir(dir) else { return };
    for e in entries.flatten() {
        let name = e.file_name().to_string_lossy().into_owned();
        if name.starts_with('.') && name.contains(".tmp") && e.path().is_file() {
            let _ = std::fs::remove_file(e.path());
        }
    }
}

/// What a resume keeps: the frames already written (`first..done`), and the output's writer.
pub(super) struct Resumed {
    pub done: usize,
    pub writer: FrameWriter,
}

/// Opens the output for the `kept` frames: the folder, or a video (a resumed one copies the
/// earlier frames into a partial file that replaces the output when closed).
#[cfg_attr(not(feature = "opencv"), allow(unused_variables))]
fn open_writer(out: &Outputs, opts: &AugmentOptions, input: &Input, scene: &Scene, kept: std::ops::Range<usize>, old: Option<&mut Box<dyn FrameSource>>, thumbs: &mut Thumbs) -> Result<FrameWriter> {
    if !out.video {
        return Ok(FrameWriter::Dir { dir: opts.output.clone(), format: opts.format });
    }
    #[cfg(feature = "opencv")]
    {
        let partial = (!kept.is_empty()).then(|| {
            let ext = crate::run::source::extension(&out.target).unwrap_or_default();
            out.target.with_extension(format!("partial.{ext}"))
        });
        let path = partial.clone().unwrap_or_else(|| out.target.clone());
        let k = &scene.camera.intrinsics;
        let mut sink = crate::io::video::VideoSink::create(&path, input.fps, k.width, k.height).with_context(|| format!("{}: cannot write the output video", path.display()))?;
        if let Some(v) = old {
            for (n, i) in kept.clone().enumerate() {
                let Some(f) = v.read()? else { bail!("{}: ended after {n} frames while copying {}", out.target.display(), kept.len()) };
                let rgb: Vec<u8> = match &f.frame.data {
                    crate::io::frames::FrameData::Ldr { codes, .. } => codes.iter().map(|&c| c as u8).collect(),
                    crate::io::frames::FrameData::Hdr(_) => bail!("{}: unexpected HDR frame from a video", out.target.display()),
                };
                sink.write_rgb8(&rgb)?;
                thumbs.push(i, &thumb_of(&f.frame, &input.photometry));
            }
        }
        Ok(FrameWriter::Video { sink, target: out.target.clone(), partial })
    }
    #[cfg(not(feature = "opencv"))]
    bail!("{}: writing video needs heliar built with `--features opencv`", out.target.display())
}

/// Keeps what an earlier run of frames `first..` wrote (the session is replayed over it by
/// [`catch_up`]).
pub(super) fn resume(out: &Outputs, opts: &AugmentOptions, input: &Input, scene: &Scene, first: usize, thumbs: &mut Thumbs, obs: &mut dyn Observer) -> Result<Resumed> {
    let mut old: Option<Box<dyn FrameSource>> = None;
    let in_video = if !out.video {
        None
    } else if out.target.exists() {
        #[cfg(feature = "opencv")]
        {
            let v = crate::run::source::VideoFileSource::open(&out.target, Some(input.fps.max(1e-3))).with_context(|| format!("{}: the earlier output cannot be read to resume", out.target.display()))?;
            let n = v.len();
            old = Some(Box::new(v));
            Some(n.unwrap_or(usize::MAX))
        }
        #[cfg(not(feature = "opencv"))]
        Some(0)
    } else {
        Some(0)
    };
    if !out.video {
        remove_temporaries(&out.target);
    }
    let keep = resume_point(out, first, in_video)?;
    if keep > 0 {
        obs.note(&format!("resuming after frame {}: {keep} frames kept", first + keep - 1));
    } else {
        obs.note(&format!("note: nothing to resume in {}: starting from frame {first}", out.report.display()));
    }
    let writer = open_writer(out, opts, input, scene, first..first + keep, old.as_mut(), thumbs)?;
    Ok(Resumed { done: first + keep, writer })
}

/// Brings the session up to frame `done` without writing: the input's frames before `from`
/// are passed over, frames `from..done` replayed ([`OutdoorSession::replay`]: estimate,
/// relights, the compositor's decisions). Frames from `first` on exist in the output already
/// (a resumed run): their thumbnails are read back for the contact sheet.
#[allow(clippy::too_many_arguments)]
pub(super) fn catch_up(
    (from, first, done): (usize, usize, usize),
    out: &Outputs,
    opts: &AugmentOptions,
    input: &Input,
    source: &mut dyn FrameSource,
    session: &mut OutdoorSession,
    lin: &Linearizer,
    thumbs: &mut Thumbs,
    clock: &mut ClockCheck,
    obs: &mut dyn Observer,
) -> Result<()> {
    for i in 0..from {
        if !source.skip()? {
            bail!("{}: the input has {i} frames; the run starts at frame {first}", input.label);
        }
    }
    if done <= from {
        return Ok(());
    }
    let what = if first > from { "warming up on the frames before the chunk, then replaying those written" } else { "replaying the frames written" };
    obs.start(&format!("{what} (estimate, relight, decisions)"), Some(done - from), 0);
    for i in from..done {
        let Some(f) = source.read()? else { bail!("{}: the input has {i} frames; the run needs {done} (frame {first} on, after {} of warm-up)", input.label, first - from) };
        let t = input.clock.time(i, f.ts_ms, None)?;
        clock.check(i, t);
        session.replay(i, &t, &f.frame, lin).with_context(|| f.label.clone())?;
        if i >= first && !out.video {
            let p = opts.output.join(format!("{}.{}", source.stem(i), output_kind(opts.format, &f.frame).extension()));
            if thumbs.wants(i)
                && let Ok(fr) = Frame::load(&p)
            {
                thumbs.push(i, &thumb_of(&fr, &input.photometry));
            }
        }
        obs.advance();
    }
    obs.finish();
    Ok(())
}

/// Opens the output of a run that starts from its first frame `first` (saying so when it
/// replaces an earlier run).
pub(super) fn fresh(out: &Outputs, opts: &AugmentOptions, input: &Input, scene: &Scene, first: usize, thumbs: &mut Thumbs, obs: &mut dyn Observer) -> Result<Resumed> {
    if out.report.exists() {
        obs.note(&format!("note: overwriting the earlier run in {} (--resume continues one instead)", out.target.display()));
    }
    Ok(Resumed { done: first, writer: open_writer(out, opts, input, scene, first..first, None, thumbs)? })
}
