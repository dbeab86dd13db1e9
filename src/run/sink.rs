//! Where a run's results go: the output frames (a folder of PNG/EXR files, or a video), the
//! per-frame JSON report beside them, the contact sheet, and the per-stage timings of the
//! summary.
//!
//! An output is either a folder (`DIR/` with `report.jsonl`, `summary.json`,
//! `contact_sheet.png` inside) or a video file (`OUT.mp4` with `OUT.report.jsonl`,
//! `OUT.summary.json` and `OUT.contact_sheet.png` beside it). A resumed video run writes a
//! partial file and renames it over the output when it is closed, so the earlier output stays
//! whole until the new one is complete.

use super::source::{VIDEO_EXTENSIONS, extension};
use crate::io::frames::{Frame, FrameData, Photometry};
use crate::io::image::{Rgb8, write_contact_sheet};
use crate::render::VideoFrame;
#[cfg(feature = "opencv")]
use crate::render::output::encode_rgb8;
use crate::render::output::{OutputKind, write_frame};
use crate::report::median;
use anyhow::{Context, Result, bail};
use serde::Serialize;
use std::path::{Path, PathBuf};

/// Extensions the video writer supports.
pub const VIDEO_OUT_EXTENSIONS: [&str; 3] = ["mp4", "mkv", "avi"];

/// Output image format of a folder.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Format {
    /// 8/16-bit PNG through the camera response.
    Png,
    /// Camera-linear OpenEXR.
    Exr,
}

/// The file kind of an output frame: the requested format, else the input's (EXR for HDR
/// footage, PNG for LDR).
pub fn output_kind(format: Option<Format>, frame: &Frame) -> OutputKind {
    match (format, &frame.data) {
        (Some(Format::Exr), _) | (None, FrameData::Hdr(_)) => OutputKind::Exr,
        _ => OutputKind::Png,
    }
}

/// Where the output and its reports go.
#[derive(Clone, Debug)]
pub struct Outputs {
    /// The folder, or the video file.
    pub target: PathBuf,
    /// The output is a video file.
    pub video: bool,
    /// The per-frame JSON lines.
    pub report: PathBuf,
    /// The run's summary.
    pub summary: PathBuf,
    /// The contact sheet.
    pub sheet: PathBuf,
}

impl Outputs {
    /// The outputs of `path`: a video file by its extension, else a folder.
    pub fn of(path: &Path) -> Result<Self> {
        let video = extension(path).is_some_and(|e| VIDEO_EXTENSIONS.contains(&e.as_str()));
        if !video {
            return Ok(Self { target: path.to_owned(), video, report: path.join("report.jsonl"), summary: path.join("summary.json"), sheet: path.join("contact_sheet.png") });
        }
        let ext = extension(path).unwrap_or_default();
        if !VIDEO_OUT_EXTENSIONS.contains(&ext.as_str()) {
            bail!("{}: videos are written as .mp4, .mkv or .avi", path.display());
        }
        if !cfg!(feature = "opencv") {
            bail!("{}: writing video needs heliar built with `--features opencv` (or give an output folder)", path.display());
        }
        let stem = path.file_stem().map(|s| s.to_string_lossy().into_owned()).unwrap_or_else(|| "out".into());
        let beside = |suffix: &str| path.with_file_name(format!("{stem}.{suffix}"));
        Ok(Self { target: path.to_owned(), video, report: beside("report.jsonl"), summary: beside("summary.json"), sheet: beside("contact_sheet.png") })
    }

    /// The folder the outputs are in.
    pub fn parent(&self) -> PathBuf {
        if self.video { self.target.parent().map(Path::to_owned).unwrap_or_default() } else { self.target.clone() }
    }
}

/// An output claimed by one run: a lock file beside the outputs holds the run's process id, and
/// a second run into the same output is refused while that process lives. The lock goes when
/// the run ends (a run killed with SIGKILL leaves it; the next run sees the process is gone and
/// takes it over).
pub struct OutputLock {
    path: PathBuf,
}

impl OutputLock {
    /// The lock file of `out`: `DIR/.heliar.lock` for a folder, `OUT.mp4.lock` beside a video.
    pub fn path_of(out: &Outputs) -> PathBuf {
        if out.video {
            let name = out.target.file_name().map(|n| n.to_string_lossy().into_owned()).unwrap_or_default();
            out.target.with_file_name(format!(".{name}.lock"))
        } else {
            out.target.join(".heliar.lock")
        }
    }

    /// Claims `out`, or says which run holds it.
    pub fn acquire(out: &Outputs) -> Result<Self> {
        let path = Self::path_of(out);
        for _ in 0..2 {
            match std::fs::OpenOptions::new().write(true).create_new(true).open(&path) {
                Ok(mut f) => {
                    use std::io::Write;
                    writeln!(f, "{}", std::process::id()).with_context(|| format!("writing the lock {}", path.display()))?;
                    return Ok(Self { path });
                }
                Err(e) if e.kind() == std::io::ErrorKind::AlreadyExists => {
                    let holder = std::fs::read_to_string(&path).ok().and_then(|t| t.trim().parse::<u32>().ok());
                    match holder {
                        Some(pid) if process_alive(pid) => bail!(
                            "{}: another heliar run (process {pid}) is writing this output; wait for it to end, or give another output (lock: {})",
                            out.target.display(),
                            path.display()
                        ),
                        _ => {
                            // The run that held it is gone (killed): take the lock over.
                            std::fs::remove_file(&path).with_context(|| format!("removing the stale lock {}", path.display()))?;
                        }
                    }
                }
                Err(e) => return Err(e).with_context(|| format!("creating the lock {}", path.display())),
            }
        }
        bail!("{}: could not take the lock {}", out.target.display(), path.display())
    }
}

impl Drop for OutputLock {
    fn drop(&mut self) {
        let _ = std::fs::remove_file(&self.path);
    }
}

/// True when process `pid` runs (Linux: its `/proc` entry, not a zombie; elsewhere every holder
/// counts as alive, so a stale lock must be removed by hand). A killed run whose parent died too
/// (a Ray worker, a job runner) can stay a zombie when nothing reaps it: it writes nothing more,
/// so its lock is stale.
fn process_alive(pid: u32) -> bool {
    if pid == std::process::id() {
        return true;
    }
    if !cfg!(target_os = "linux") {
        return true;
    }
    match std::fs::read_to_string(format!("/proc/{pid}/stat")) {
        // The state is the first field after the command name, which ends at the last ')'.
        Ok(stat) => !matches!(stat.rsplit_once(')').and_then(|(_, rest)| rest.trim_start().chars().next()), Some('Z' | 'X')),
        Err(_) => false,
    }
}

/// Writes output frames: files in a folder, or a video.
pub enum FrameWriter {
    /// A folder of frames named after the input's frames.
    Dir {
        /// The folder.
        dir: PathBuf,
        /// The requested format (default: the input's).
        format: Option<Format>,
    },
    /// A video file.
    #[cfg(feature = "opencv")]
    Video {
        /// The writer.
        sink: crate::io::video::VideoSink,
        /// The output.
        target: PathBuf,
        /// Written here and renamed to the target when finished (a resumed run).
        partial: Option<PathBuf>,
    },
}

impl FrameWriter {
    /// Writes frame `index` (named `stem` in a folder): the composite `image` (scene radiance,
    /// of relative `precision`) of the footage `frame` (linearised as `video`). Returns what was
    /// written, for the report.
    #[allow(clippy::too_many_arguments)]
    #[cfg_attr(not(feature = "opencv"), allow(unused_variables))]
    pub fn write(&mut self, index: usize, stem: &str, image: &crate::io::image::LinearImage, precision: f32, video: &VideoFrame, frame: &Frame, photometry: &Photometry) -> Result<String> {
        match self {
            FrameWriter::Dir { dir, format } => {
                let kind = output_kind(*format, frame);
                let p = dir.join(format!("{stem}.{}", kind.extension()));
                crate::io::write_via_temp(&p, |tmp| write_frame(tmp, kind, image, precision, video, frame, photometry))?;
                Ok(p.display().to_string())
            }
            #[cfg(feature = "opencv")]
            FrameWriter::Video { sink, target, .. } => {
                sink.write_rgb8(&encode_rgb8(image, precision, video, frame, photometry))?;
                Ok(format!("{} frame {index}", target.display()))
            }
        }
    }

    /// Closes the output (a video's container; the partial file renamed over the target).
    pub fn finish(&mut self) -> Result<()> {
        #[cfg(feature = "opencv")]
        if let FrameWriter::Video { sink, target, partial } = self {
            sink.finish()?;
            if let Some(p) = partial.take() {
                std::fs::rename(&p, &*target).with_context(|| format!("renaming {} to {}", p.display(), target.display()))?;
            }
        }
        Ok(())
    }
}

/// Evenly spaced thumbnails of a run of unknown length for the contact sheet: keeps at most
/// `2·keep` frames, halving them (every other one) and doubling the stride when full.
pub struct Thumbs {
    keep: usize,
    stride: usize,
    width: u32,
    items: Vec<(usize, Rgb8)>,
}

impl Thumbs {
    /// At most `2·keep` thumbnails, each at most `width` pixels wide.
    pub fn new(keep: usize, width: u32) -> Self {
        Self { keep: keep.max(1), stride: 1, width, items: Vec::new() }
    }
    /// True when frame `index` would be kept.
    pub fn wants(&self, index: usize) -> bool {
        index.is_multiple_of(self.stride)
    }
    /// Adds frame `index` (shrunk to the thumbnail width) when it is wanted.
    pub fn push(&mut self, index: usize, img: &Rgb8) {
        if !self.wants(index) {
            return;
        }
        self.items.push((index, img.shrink_to(self.width)));
        if self.items.len() >= 2 * self.keep {
            self.stride *= 2;
            let s = self.stride;
            self.items.retain(|(k, _)| k.is_multiple_of(s));
        }
    }
    /// Writes the contact sheet, `columns` wide.
    pub fn write(&self, path: &Path, columns: u32) -> Result<()> {
        let tiles: Vec<Rgb8> = self.items.iter().map(|(_, t)| t.clone()).collect();
        Ok(crate::io::write_via_temp(path, |tmp| write_contact_sheet(tmp, &tiles, columns, 4))?)
    }
}

/// A thumbnail of an output frame read back (resumed runs).
pub fn thumb_of(frame: &Frame, photometry: &Photometry) -> Rgb8 {
    match &frame.data {
        FrameData::Ldr { bits: 8, codes } => Rgb8 { width: frame.width, height: frame.height, data: codes.iter().map(|&c| c as u8).collect() },
        FrameData::Ldr { codes, .. } => Rgb8 { width: frame.width, height: frame.height, data: codes.iter().map(|&c| (c >> 8) as u8).collect() },
        FrameData::Hdr(img) => {
            let mut lin = img.clone();
            lin.data.iter_mut().for_each(|p| *p = p.map(|c| c / photometry.exposure));
            Rgb8::from_radiance(&lin, photometry)
        }
    }
}

/// Per-stage timing, ms per frame.
#[derive(Clone, Debug, Default, Serialize)]
pub struct StageTime {
    /// Total over the run, seconds.
    pub total_s: f64,
    /// Median per frame, ms.
    pub median_ms: f64,
    /// Mean per frame, ms.
    pub mean_ms: f64,
    #[serde(skip)]
    samples: Vec<f64>,
}

impl StageTime {
    /// Adds one frame's time.
    pub fn add(&mut self, ms: f64) {
        self.samples.push(ms);
    }
    /// Computes the totals from the frames added.
    pub fn finish(&mut self) {
        let n = self.samples.len().max(1) as f64;
        let sum: f64 = self.samples.iter().sum();
        self.total_s = sum / 1e3;
        self.mean_ms = sum / n;
        self.median_ms = if self.samples.is_empty() { 0.0 } else { median(&self.samples) };
    }
}

#[cfg(all(test, target_os = "linux"))]
mod tests {
    use super::process_alive;
    use std::process::Command;
    use std::time::{Duration, Instant};

    #[test]
    fn a_running_process_holds_its_lock_and_a_zombie_does_not() {
        let mut running = Command::new("sleep").arg("30").spawn().expect("sleep");
        assert!(process_alive(running.id()));
        let mut done = Command::new("true").spawn().expect("true");
        let stat = format!("/proc/{}/stat", done.id());
        // Not reaped yet: `/proc` keeps the entry, in state Z, until `wait`.
        let t = Instant::now();
        while !std::fs::read_to_string(&stat).is_ok_and(|s| s.rsplit_once(')').is_some_and(|(_, r)| r.trim_start().starts_with('Z'))) {
            assert!(t.elapsed() < Duration::from_secs(10), "`true` did not exit");
            std::thread::sleep(Duration::from_millis(10));
        }
        assert!(std::path::Path::new(&stat).exists(), "the zombie still has its /proc entry");
        assert!(!process_alive(done.id()), "a zombie holds no lock");
        done.wait().expect("reap");
        assert!(!process_alive(done.id()));
        running.kill().ok();
        running.wait().ok();
    }
}
