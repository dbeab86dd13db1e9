//! Where frames come from: a folder of PNG/EXR frames, a video file or a camera, behind one
//! trait, and how a user's input options become a source with its clock and photometry.
//!
//! A [`FrameSource`] reads frames in order. Files report their frame count and rate; the live
//! window paces them at that rate and treats their end as the end of the input, while a camera
//! paces itself and a missing frame is a loss. [`resolve_input`] turns the options every front
//! end shares (`--input`/`--camera`, `--sequence`, `--start`, `--fps`, `--exposure`) into an
//! [`Input`]: what to open, the [`FrameClock`], the photometric calibration and, for a scene
//! sequence, the known lighting.

use super::clock::FrameClock;
use crate::io::frames::{Frame, Photometry, list_frame_files};
use crate::scene::{Scene, Sequence, Truth, parse_time};
use anyhow::{Context, Result, anyhow, bail};
use std::path::{Path, PathBuf};

/// Extensions read as video files.
pub const VIDEO_EXTENSIONS: [&str; 9] = ["mp4", "mkv", "avi", "mov", "webm", "m4v", "mpg", "mpeg", "ts"];

/// The extension of `p`, lower case.
pub fn extension(p: &Path) -> Option<String> {
    p.extension().and_then(|e| e.to_str()).map(str::to_ascii_lowercase)
}

/// True when `p` names a video file by its extension.
pub fn is_video_path(p: &Path) -> bool {
    extension(p).is_some_and(|e| VIDEO_EXTENSIONS.contains(&e.as_str()))
}

/// One frame read from a source.
#[derive(Clone, Debug)]
pub struct SourceFrame {
    /// The decoded frame.
    pub frame: Frame,
    /// Timestamp from the start of the source, ms, when the source has one.
    pub ts_ms: Option<f64>,
    /// What it is, for messages and reports (a file path, or "VIDEO frame N").
    pub label: String,
}

/// A source of frames, read in order.
pub trait FrameSource: Send {
    /// What it reads, for messages.
    fn label(&self) -> String;
    /// The next frame; `None` at the end of a file, or when a camera gave no frame.
    fn read(&mut self) -> Result<Option<SourceFrame>>;
    /// Passes over the next frame (a chunk's frames before its warm-up); false at the end.
    /// Sources that can move on without decoding (folders) do.
    fn skip(&mut self) -> Result<bool> {
        Ok(self.read()?.is_some())
    }
    /// Frame rate to pace reading at (files), or `None` for a source that paces itself (cameras).
    fn pace_fps(&self) -> Option<f64>;
    /// True for files and folders: the end of the frames is the end of the input, not a loss.
    fn is_file(&self) -> bool;
    /// Frames in the source, when known.
    fn len(&self) -> Option<usize> {
        None
    }
    /// The file stem an output of frame `index` is named after.
    fn stem(&self, index: usize) -> String {
        format!("frame_{index:05}")
    }
}

/// Opens (and reopens) a source.
pub type Opener = Box<dyn FnMut() -> Result<Box<dyn FrameSource>> + Send>;

/// A folder of PNG/EXR frames, sorted by name, paced at `fps`.
pub struct FolderSource {
    dir: PathBuf,
    files: Vec<PathBuf>,
    next: usize,
    fps: f64,
}

impl FolderSource {
    /// Lists the folder's frames.
    pub fn open(dir: &Path, fps: f64) -> Result<Self> {
        let files = list_frame_files(dir)?;
        if files.is_empty() {
            bail!("{}: no .png or .exr frames", dir.display());
        }
        if !(fps.is_finite() && fps > 0.0) {
            bail!("{}: frame rate {fps} must be positive", dir.display());
        }
        Ok(Self { dir: dir.to_owned(), files, next: 0, fps })
    }

    /// The frame files in order.
    pub fn files(&self) -> &[PathBuf] {
        &self.files
    }
}

impl FrameSource for FolderSource {
    fn label(&self) -> String {
        self.dir.display().to_string()
    }
    fn read(&mut self) -> Result<Option<SourceFrame>> {
        let Some(p) = self.files.get(self.next) else { return Ok(None) };
        let ts = self.next as f64 * 1e3 / self.fps;
        self.next += 1;
        Ok(Some(SourceFrame { frame: Frame::load(p)?, ts_ms: Some(ts), label: p.display().to_string() }))
    }
    fn skip(&mut self) -> Result<bool> {
        let more = self.next < self.files.len();
        self.next += more as usize;
        Ok(more)
    }
    fn pace_fps(&self) -> Option<f64> {
        Some(self.fps)
    }
    fn is_file(&self) -> bool {
        true
    }
    fn len(&self) -> Option<usize> {
        Some(self.files.len())
    }
    fn stem(&self, index: usize) -> String {
        self.files.get(index).and_then(|p| p.file_stem()).map(|s| s.to_string_lossy().into_owned()).unwrap_or_else(|| format!("frame_{index:05}"))
    }
}

/// Frames handed over in memory, in order (the Python package's arrays, tests), timestamped by
/// index at `fps`.
pub struct MemorySource {
    frames: std::collections::VecDeque<Frame>,
    next: usize,
    fps: f64,
}

impl MemorySource {
    /// The frames `frames`, at `fps` frames per second.
    pub fn new(frames: Vec<Frame>, fps: f64) -> Result<Self> {
        positive_fps(fps, "frame rate")?;
        Ok(Self { frames: frames.into(), next: 0, fps })
    }

    /// Adds a frame after the others.
    pub fn push(&mut self, frame: Frame) {
        self.frames.push_back(frame);
    }
}

impl FrameSource for MemorySource {
    fn label(&self) -> String {
        "frames in memory".into()
    }
    fn read(&mut self) -> Result<Option<SourceFrame>> {
        let Some(frame) = self.frames.pop_front() else { return Ok(None) };
        let i = self.next;
        self.next += 1;
        Ok(Some(SourceFrame { frame, ts_ms: Some(i as f64 * 1e3 / self.fps), label: format!("memory frame {i}") }))
    }
    fn pace_fps(&self) -> Option<f64> {
        Some(self.fps)
    }
    fn is_file(&self) -> bool {
        true
    }
    fn len(&self) -> Option<usize> {
        Some(self.next + self.frames.len())
    }
}

/// A video file (container timestamps), paced at its frame rate or a given one.
#[cfg(feature = "opencv")]
pub struct VideoFileSource {
    video: crate::io::video::VideoSource,
    path: PathBuf,
    fps: f64,
    next: usize,
}

#[cfg(feature = "opencv")]
impl VideoFileSource {
    /// Opens `path`; `fps` overrides the container's rate (needed when it gives none).
    pub fn open(path: &Path, fps: Option<f64>) -> Result<Self> {
        let video = crate::io::video::VideoSource::open_file(path)?;
        let fps = match fps.or((video.fps() > 0.0).then_some(video.fps())) {
            Some(f) if f.is_finite() && f > 0.0 => f,
            _ => bail!("{}: the container gives no frame rate: give --fps", path.display()),
        };
        Ok(Self { video, path: path.to_owned(), fps, next: 0 })
    }

    /// The frame size the container announces (0×0 when it does not).
    pub fn size(&self) -> (u32, u32) {
        self.video.size()
    }
}

#[cfg(feature = "opencv")]
impl FrameSource for VideoFileSource {
    fn label(&self) -> String {
        self.video.label().display().to_string()
    }
    fn read(&mut self) -> Result<Option<SourceFrame>> {
        let i = self.next;
        let Some((frame, ts)) = self.video.read()? else { return Ok(None) };
        self.next += 1;
        Ok(Some(SourceFrame { frame, ts_ms: ts.is_finite().then_some(ts), label: format!("{} frame {i}", self.path.display()) }))
    }
    fn pace_fps(&self) -> Option<f64> {
        Some(self.fps)
    }
    fn is_file(&self) -> bool {
        true
    }
    fn len(&self) -> Option<usize> {
        self.video.frame_count().map(|n| n as usize)
    }
}

/// A camera (by index) or a stream (by URL).
#[cfg(feature = "opencv")]
pub struct CameraSource {
    video: crate::io::video::VideoSource,
    next: usize,
}

#[cfg(feature = "opencv")]
impl CameraSource {
    /// Opens `spec`: a camera index (`0`) or a stream URL.
    pub fn open(spec: &str) -> Result<Self> {
        Ok(Self { video: crate::io::video::VideoSource::open_camera(spec)?, next: 0 })
    }
}

#[cfg(feature = "opencv")]
impl FrameSource for CameraSource {
    fn label(&self) -> String {
        self.video.label().display().to_string()
    }
    fn read(&mut self) -> Result<Option<SourceFrame>> {
        let i = self.next;
        let Some((frame, ts)) = self.video.read()? else { return Ok(None) };
        self.next += 1;
        Ok(Some(SourceFrame { frame, ts_ms: ts.is_finite().then_some(ts), label: format!("{} frame {i}", self.label()) }))
    }
    fn pace_fps(&self) -> Option<f64> {
        None
    }
    fn is_file(&self) -> bool {
        false
    }
}

/// The input options every front end shares.
#[derive(Clone, Debug, Default)]
pub struct InputOptions {
    /// A folder of frames or a video file.
    pub input: Option<PathBuf>,
    /// A camera index or stream URL (instead of `input`).
    pub camera: Option<String>,
    /// The scene sequence whose exposure (and start time) to borrow.
    pub sequence: Option<String>,
    /// Time of the first frame (RFC 3339): files count from it; a camera's wall clock is
    /// shifted so that it starts there.
    pub start: Option<String>,
    /// Frame rate of a folder (or overriding a video's).
    pub fps: Option<f64>,
    /// Exposure overriding the calibration.
    pub exposure: Option<f32>,
    /// Seconds added to a camera's wall clock.
    pub time_offset_s: f64,
    /// Play a file again from the start when it ends (the live window).
    pub looped: bool,
}

/// What an input is.
#[derive(Clone, Debug, PartialEq)]
pub enum InputKind {
    /// A folder of PNG/EXR frames.
    Folder(PathBuf),
    /// A video file.
    Video(PathBuf),
    /// A camera index or stream URL.
    Camera(String),
}

/// A resolved input: what to open and how to read its frames.
#[derive(Clone, Debug)]
pub struct Input {
    /// What to open.
    pub kind: InputKind,
    /// For messages and summaries.
    pub label: String,
    /// Frames, when known before reading.
    pub count: Option<usize>,
    /// Frame rate (the output video's rate; the pace of files in the live window).
    pub fps: f64,
    /// The time of every frame.
    pub clock: FrameClock,
    /// How frames are linearised.
    pub photometry: Photometry,
    /// Known lighting per frame (a scene sequence with a truth file).
    pub truth: Option<Vec<Truth>>,
    /// The scene sequence the input is, when it is one.
    pub sequence: Option<String>,
}

/// The scene sequence named `name` (or the first).
pub fn pick_sequence<'a>(scene: &'a Scene, name: Option<&str>) -> Result<&'a Sequence> {
    scene.sequence(name).ok_or_else(|| match name {
        Some(n) => anyhow!(
            "{}: no sequence named '{n}' (have: {})",
            scene.root.join(crate::scene::MANIFEST_FILE).display(),
            scene.sequences.iter().map(|s| s.name.as_str()).collect::<Vec<_>>().join(", ")
        ),
        None => anyhow!("{}: the scene has no [[sequences]]", scene.root.join(crate::scene::MANIFEST_FILE).display()),
    })
}

fn positive_fps(fps: f64, what: &str) -> Result<f64> {
    if !(fps.is_finite() && fps > 0.0) {
        bail!("{what} {fps}: must be a positive number of frames per second");
    }
    Ok(fps)
}

/// The scene sequence whose frames are the folder `dir`, if any.
fn sequence_of_folder<'a>(scene: &'a Scene, dir: &Path) -> Option<&'a Sequence> {
    let want = std::fs::canonicalize(dir).ok()?;
    scene.sequences.iter().find(|s| s.files.first().and_then(|f| f.parent()).and_then(|d| std::fs::canonicalize(d).ok()).as_deref() == Some(want.as_path()))
}

/// Resolves the input options against `scene`. A folder that is one of the scene's sequences
/// brings its times, exposure and truth; other folders need `--start` and `--fps`; a video's
/// times are its container timestamps from `--start` (default: the borrowed or first
/// sequence's start, with a note on stderr); a camera reads the wall clock.
pub fn resolve_input(scene: &Scene, o: &InputOptions) -> Result<Input> {
    let borrowed = o.sequence.as_deref().map(|n| pick_sequence(scene, Some(n)).context("--sequence")).transpose()?;
    let photometry = borrowed.map(|s| s.photometry.clone()).unwrap_or_else(|| scene.photometry.clone());
    let start = o.start.as_deref().map(|s| parse_time(Path::new("--start"), "start", s)).transpose()?;
    if let Some(f) = o.fps {
        positive_fps(f, "--fps")?;
    }
    let mut input = match (&o.input, &o.camera) {
        (Some(p), None) if p.is_dir() => folder_input(scene, p, o, start, photometry)?,
        (Some(p), None) if p.exists() => video_input(scene, p, o, borrowed, start, photometry)?,
        (Some(p), None) => bail!("{}: input not found", p.display()),
        (None, Some(spec)) => Input {
            kind: InputKind::Camera(spec.clone()),
            label: spec.clone(),
            count: None,
            fps: o.fps.unwrap_or(0.0),
            clock: FrameClock::wall(start, o.time_offset_s),
            photometry,
            truth: None,
            sequence: None,
        },
        _ => bail!("give exactly one of --input and --camera"),
    };
    if let Some(e) = o.exposure {
        if !(e.is_finite() && e > 0.0) {
            bail!("--exposure {e}: must be positive");
        }
        input.photometry.exposure = e;
    }
    Ok(input)
}

fn folder_input(scene: &Scene, dir: &Path, o: &InputOptions, start: Option<chrono::DateTime<chrono::FixedOffset>>, photometry: Photometry) -> Result<Input> {
    std::fs::canonicalize(dir).with_context(|| format!("{}: input folder not readable", dir.display()))?;
    let files = list_frame_files(dir)?;
    if files.is_empty() {
        bail!("{}: no .png or .exr frames", dir.display());
    }
    let (label, count) = (dir.display().to_string(), Some(files.len()));
    let kind = InputKind::Folder(dir.to_owned());
    match (sequence_of_folder(scene, dir), start) {
        (Some(s), None) => {
            if s.times.len() != files.len() {
                bail!("{}: {} frames but the sequence has {} times", dir.display(), files.len(), s.times.len());
            }
            let clock = FrameClock::List { times: s.times.clone(), looped: o.looped };
            let fps = o.fps.or(clock.nominal_fps()).unwrap_or(1.0);
            Ok(Input { kind, label, count, fps, clock, photometry: s.photometry.clone(), truth: s.truth.clone(), sequence: Some(s.name.clone()) })
        }
        (_, Some(t0)) => {
            let fps = o.fps.ok_or_else(|| anyhow!("--start needs --fps for a folder of frames"))?;
            Ok(Input { kind, label, count, fps, clock: FrameClock::Start { t0, fps }, photometry, truth: None, sequence: None })
        }
        (None, None) => bail!("{} is not one of the scene's sequences: give --start and --fps", dir.display()),
    }
}

#[cfg(feature = "opencv")]
fn video_input(scene: &Scene, p: &Path, o: &InputOptions, borrowed: Option<&Sequence>, start: Option<chrono::DateTime<chrono::FixedOffset>>, photometry: Photometry) -> Result<Input> {
    if !is_video_path(p) {
        bail!("{}: not a folder of frames nor a video file (.{})", p.display(), VIDEO_EXTENSIONS.join(", ."));
    }
    let v = VideoFileSource::open(p, o.fps)?;
    let (w, h) = v.size();
    let k = &scene.camera.intrinsics;
    if (w, h) != (k.width, k.height) && (w, h) != (0, 0) {
        bail!("{}: frames are {w}×{h} but the camera calibration {} is {}×{}", p.display(), scene.camera_path.display(), k.width, k.height);
    }
    let fps = v.pace_fps().unwrap_or(0.0);
    let t0 = match (start, borrowed.or(scene.sequences.first())) {
        (Some(t), _) => t,
        (None, Some(seq)) if !seq.times.is_empty() => {
            eprintln!("note: frame times start at sequence '{}''s start {} (give --start for the video's own)", seq.name, seq.times[0].to_rfc3339());
            seq.times[0]
        }
        _ => bail!("{}: give --start (the time of the first frame) for a video", p.display()),
    };
    Ok(Input { kind: InputKind::Video(p.to_owned()), label: p.display().to_string(), count: v.len(), fps, clock: FrameClock::Start { t0, fps }, photometry, truth: None, sequence: None })
}

#[cfg(not(feature = "opencv"))]
fn video_input(_scene: &Scene, p: &Path, _o: &InputOptions, _b: Option<&Sequence>, _s: Option<chrono::DateTime<chrono::FixedOffset>>, _ph: Photometry) -> Result<Input> {
    if is_video_path(p) {
        bail!("{}: video files need heliar built with `--features opencv` (or give a folder of PNG/EXR frames)", p.display());
    }
    bail!("{}: not a folder of frames", p.display())
}

impl Input {
    /// Opens the source.
    pub fn open(&self) -> Result<Box<dyn FrameSource>> {
        match &self.kind {
            InputKind::Folder(d) => Ok(Box::new(FolderSource::open(d, self.fps)?)),
            #[cfg(feature = "opencv")]
            InputKind::Video(p) => Ok(Box::new(VideoFileSource::open(p, Some(self.fps))?)),
            #[cfg(feature = "opencv")]
            InputKind::Camera(spec) => Ok(Box::new(CameraSource::open(spec)?)),
            #[cfg(not(feature = "opencv"))]
            InputKind::Video(p) => bail!("{}: video files need heliar built with `--features opencv`", p.display()),
            #[cfg(not(feature = "opencv"))]
            InputKind::Camera(s) => bail!("camera {s}: cameras need heliar built with `--features opencv`"),
        }
    }

    /// An opener that opens the source again each time it is called (the live capture reopens a
    /// lost camera with it). A camera that is not there yet is retried like a lost one.
    pub fn opener(&self) -> Opener {
        let me = self.clone();
        Box::new(move || me.open())
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::io::frames::FrameData;

    #[test]
    fn a_memory_source_gives_its_frames_in_order_with_times_by_index() {
        let f = |v: u16| Frame { width: 1, height: 1, data: FrameData::Ldr { bits: 8, codes: vec![v; 3] } };
        let mut m = MemorySource::new(vec![f(1), f(2)], 4.0).unwrap();
        m.push(f(3));
        assert_eq!(m.len(), Some(3));
        let got: Vec<(u16, Option<f64>)> = std::iter::from_fn(|| m.read().unwrap())
            .map(|s| match s.frame.data {
                FrameData::Ldr { codes, .. } => (codes[0], s.ts_ms),
                FrameData::Hdr(_) => unreachable!(),
            })
            .collect();
        assert_eq!(got, [(1, Some(0.0)), (2, Some(250.0)), (3, Some(500.0))]);
        assert!(MemorySource::new(vec![], 0.0).is_err());
    }
}
