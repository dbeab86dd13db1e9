//! Video files and cameras through OpenCV's FFMPEG backend (feature `opencv`).
//!
//! [`VideoSource`] decodes frames as 8-bit RGB [`Frame`]s with their container timestamps;
//! [`VideoSink`] encodes RGB frames at a given frame rate (`.mp4`: MPEG-4 Part 2, `.mkv`: lossless
//! FFV1, `.avi`: Motion JPEG) and closes the container properly when finished or dropped, so an
//! interrupted run leaves a playable file.

use super::IoError;
use super::frames::{Frame, FrameData};
use opencv::core::{Mat, Size, Vec3b};
use opencv::prelude::*;
use opencv::videoio::{self, VideoCapture, VideoWriter};
use std::path::{Path, PathBuf};

fn cv_err(path: &Path, e: opencv::Error) -> IoError {
    IoError::Video { path: path.to_owned(), message: e.to_string() }
}

/// A video file or camera being decoded.
pub struct VideoSource {
    cap: VideoCapture,
    label: PathBuf,
    fps: f64,
    size: (u32, u32),
    frames: Option<u64>,
    next_index: u64,
}

impl VideoSource {
    /// Opens a video file (FFMPEG backend).
    pub fn open_file(path: &Path) -> Result<Self, IoError> {
        if !path.exists() {
            return Err(IoError::File { path: path.to_owned(), source: std::io::Error::new(std::io::ErrorKind::NotFound, "no such file") });
        }
        let cap = VideoCapture::from_file(path.to_string_lossy().as_ref(), videoio::CAP_FFMPEG).map_err(|e| cv_err(path, e))?;
        Self::wrap(cap, path.to_owned())
    }

    /// Opens a camera by index, or a stream by URL.
    pub fn open_camera(spec: &str) -> Result<Self, IoError> {
        let label = PathBuf::from(format!("camera {spec}"));
        let cap = match spec.parse::<i32>() {
            Ok(i) => VideoCapture::new(i, videoio::CAP_ANY),
            Err(_) => VideoCapture::from_file(spec, videoio::CAP_FFMPEG),
        }
        .map_err(|e| cv_err(&label, e))?;
        Self::wrap(cap, label)
    }

    fn wrap(cap: VideoCapture, label: PathBuf) -> Result<Self, IoError> {
        if !cap.is_opened().map_err(|e| cv_err(&label, e))? {
            return Err(IoError::Video { path: label, message: "cannot be opened: unreadable, corrupt, or not a video".into() });
        }
        let get = |p: i32| cap.get(p).unwrap_or(0.0);
        let fps = get(videoio::CAP_PROP_FPS);
        let (w, h) = (get(videoio::CAP_PROP_FRAME_WIDTH) as u32, get(videoio::CAP_PROP_FRAME_HEIGHT) as u32);
        let n = get(videoio::CAP_PROP_FRAME_COUNT);
        Ok(Self { cap, label, fps: if fps.is_finite() && fps > 0.0 { fps } else { 0.0 }, size: (w, h), frames: (n > 0.0).then_some(n as u64), next_index: 0 })
    }

    /// Frames per second from the container (0 when unknown).
    pub fn fps(&self) -> f64 {
        self.fps
    }

    /// Frame size from the container.
    pub fn size(&self) -> (u32, u32) {
        self.size
    }

    /// Frame count from the container, when it knows.
    pub fn frame_count(&self) -> Option<u64> {
        self.frames
    }

    /// What this source reads.
    pub fn label(&self) -> &Path {
        &self.label
    }

    /// Skips `n` frames (decoding them; containers seek unreliably).
    pub fn skip(&mut self, n: u64) -> Result<(), IoError> {
        for _ in 0..n {
            if self.read()?.is_none() {
                break;
            }
        }
        Ok(())
    }

    /// Decodes the next frame and its timestamp (ms from the start, from the container, or from
    /// the index and frame rate); `None` at the end.
    pub fn read(&mut self) -> Result<Option<(Frame, f64)>, IoError> {
        let mut m = Mat::default();
        let ok = self.cap.read(&mut m).map_err(|e| cv_err(&self.label, e))?;
        if !ok || m.empty() {
            return Ok(None);
        }
        let ts = self.cap.get(videoio::CAP_PROP_POS_MSEC).unwrap_or(f64::NAN);
        let idx = self.next_index;
        self.next_index += 1;
        let ts = if ts.is_finite() && (ts > 0.0 || idx == 0) { ts } else if self.fps > 0.0 { idx as f64 * 1e3 / self.fps } else { f64::NAN };
        let frame = frame_from_bgr(&m).map_err(|e| cv_err(&self.label, e))?;
        Ok(Some((frame, ts)))
    }
}

/// An 8-bit BGR (or grey) OpenCV image as an RGB frame.
pub fn frame_from_bgr(m: &Mat) -> Result<Frame, opencv::Error> {
    let (w, h) = (m.cols() as u32, m.rows() as u32);
    let mut bgr = Mat::default();
    let src = if m.channels() == 1 {
        opencv::imgproc::cvt_color(m, &mut bgr, opencv::imgproc::COLOR_GRAY2BGR, 0)?;
        &bgr
    } else {
        m
    };
    let src = if src.is_continuous() { src.clone() } else { src.try_clone()? };
    let px: &[Vec3b] = src.data_typed()?;
    let codes = px.iter().flat_map(|p| [p[2] as u16, p[1] as u16, p[0] as u16]).collect();
    Ok(Frame { width: w, height: h, data: FrameData::Ldr { bits: 8, codes } })
}

/// A video file being encoded.
pub struct VideoSink {
    writer: Option<VideoWriter>,
    path: PathBuf,
    size: (u32, u32),
    written: u64,
}

impl VideoSink {
    /// Creates `path` (`.mp4`, `.mkv` or `.avi`) for `width × height` frames at `fps`.
    pub fn create(path: &Path, fps: f64, width: u32, height: u32) -> Result<Self, IoError> {
        let ext = path.extension().and_then(|e| e.to_str()).map(str::to_ascii_lowercase);
        let code = match ext.as_deref() {
            Some("mp4") => ['m', 'p', '4', 'v'],
            Some("mkv") => ['F', 'F', 'V', '1'],
            Some("avi") => ['M', 'J', 'P', 'G'],
            _ => return Err(IoError::UnsupportedFormat { path: path.to_owned() }),
        };
        if !(fps.is_finite() && fps > 0.0) {
            return Err(IoError::Video { path: path.to_owned(), message: format!("frame rate {fps} must be positive") });
        }
        if let Some(parent) = path.parent().filter(|p| !p.as_os_str().is_empty()) {
            std::fs::create_dir_all(parent).map_err(|source| IoError::File { path: parent.to_owned(), source })?;
        }
        let fourcc = VideoWriter::fourcc(code[0], code[1], code[2], code[3]).map_err(|e| cv_err(path, e))?;
        let w = VideoWriter::new_with_backend(path.to_string_lossy().as_ref(), videoio::CAP_FFMPEG, fourcc, fps, Size::new(width as i32, height as i32), true)
            .map_err(|e| cv_err(path, e))?;
        if !w.is_opened().map_err(|e| cv_err(path, e))? {
            return Err(IoError::Video { path: path.to_owned(), message: "cannot be written (folder not writable, or no encoder for this format)".into() });
        }
        Ok(Self { writer: Some(w), path: path.to_owned(), size: (width, height), written: 0 })
    }

    /// Appends one RGB frame (`3 × width × height` bytes).
    pub fn write_rgb8(&mut self, rgb: &[u8]) -> Result<(), IoError> {
        let (w, h) = self.size;
        if rgb.len() != (w * h * 3) as usize {
            return Err(IoError::Video { path: self.path.clone(), message: format!("frame has {} bytes, {w}×{h} RGB needs {}", rgb.len(), w * h * 3) });
        }
        let px: Vec<Vec3b> = rgb.chunks_exact(3).map(|c| Vec3b::from([c[2], c[1], c[0]])).collect();
        let m = Mat::new_rows_cols_with_data(h as i32, w as i32, &px).map_err(|e| cv_err(&self.path, e))?;
        let writer = self.writer.as_mut().ok_or_else(|| IoError::Video { path: self.path.clone(), message: "already finished".into() })?;
        writer.write(&m).map_err(|e| cv_err(&self.path, e))?;
        self.written += 1;
        Ok(())
    }

    /// Frames written so far.
    pub fn written(&self) -> u64 {
        self.written
    }

    /// Closes the container (also done on drop).
    pub fn finish(&mut self) -> Result<(), IoError> {
        if let Some(mut w) = self.writer.take() {
            w.release().map_err(|e| cv_err(&self.path, e))?;
        }
        Ok(())
    }
}

impl Drop for VideoSink {
    fn drop(&mut self) {
        let _ = self.finish();
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn pattern(i: u32, w: u32, h: u32) -> Vec<u8> {
        (0..h).flat_map(|y| (0..w).flat_map(move |x| [((x * 4 + i * 10) % 256) as u8, ((y * 4) % 256) as u8, 128])).collect()
    }

    #[test]
    fn lossless_round_trip_with_frame_rate_and_timestamps() {
        let dir = std::env::temp_dir().join(format!("heliar-video-{}", std::process::id()));
        std::fs::create_dir_all(&dir).unwrap();
        let p = dir.join("t.mkv");
        let (w, h) = (64, 48);
        let mut sink = VideoSink::create(&p, 12.5, w, h).unwrap();
        for i in 0..10 {
            sink.write_rgb8(&pattern(i, w, h)).unwrap();
        }
        sink.finish().unwrap();
        let mut src = VideoSource::open_file(&p).unwrap();
        assert!((src.fps() - 12.5).abs() < 1e-6, "{}", src.fps());
        assert_eq!(src.size(), (w, h));
        let mut n = 0;
        while let Some((f, ts)) = src.read().unwrap() {
            let FrameData::Ldr { codes, .. } = &f.data else { panic!() };
            let want = pattern(n, w, h);
            // FFV1 is lossless, but the encoder stores YUV 4:2:0 or BGR depending on the build;
            // allow the small chroma error of a 4:2:0 round trip.
            let max = codes.iter().zip(&want).map(|(a, b)| (*a as i32 - *b as i32).abs()).max().unwrap();
            assert!(max <= 12, "frame {n}: max error {max}");
            assert!((ts - n as f64 * 80.0).abs() < 1.0, "frame {n}: {ts} ms");
            n += 1;
        }
        assert_eq!(n, 10);
        std::fs::remove_dir_all(&dir).ok();
    }

    #[test]
    fn corrupt_and_missing_videos_name_the_file() {
        let dir = std::env::temp_dir().join(format!("heliar-video-bad-{}", std::process::id()));
        std::fs::create_dir_all(&dir).unwrap();
        let p = dir.join("bad.mp4");
        std::fs::write(&p, b"\x00\x00\x00\x18ftypmp42 this is not a video").unwrap();
        let e = VideoSource::open_file(&p).err().unwrap().to_string();
        assert!(e.contains("bad.mp4"), "{e}");
        assert!(VideoSource::open_file(&dir.join("none.mp4")).err().unwrap().to_string().contains("none.mp4"));
        assert!(VideoSink::create(&dir.join("x.gif"), 10.0, 8, 8).is_err());
        let e = VideoSink::create(Path::new("/proc/heliar/x.mp4"), 10.0, 8, 8).err().unwrap().to_string();
        assert!(e.contains("/proc/heliar"), "{e}");
        std::fs::remove_dir_all(&dir).ok();
    }
}
