//! Chessboard intrinsics: the board and its views, the calibration's warnings, and the camera
//! file it writes.

use anyhow::{Context, Result, bail};
use heliar::opencv_calib::Rgb8;
use heliar::opencv_calib::chessboard::{Board, FisheyeCalibration, MIN_VIEWS, PinholeCalibration, detect_corners_with_window};
use opencv::core::{Point2f, Vector};
use heliar::io::frames::{Frame, FrameData};
use std::path::{Path, PathBuf};

/// Below this fraction of the image covered by corners, distortion near the edges is extrapolated.
pub const COVERAGE_WARN: f64 = 0.6;
/// Above this RMS reprojection error (pixels) a calibration is suspect.
pub const RMS_WARN_PX: f64 = 1.0;
/// Image files read from a folder of chessboard views.
pub const IMAGE_EXTENSIONS: [&str; 6] = ["png", "jpg", "jpeg", "tif", "tiff", "bmp"];

/// The camera file written when none exists yet: a placeholder pose and an sRGB response.
pub const DEFAULT_CAMERA: &str = "# Camera calibration (heliar-calib). Set the pose with `heliar-calib pose`.\nwidth = 0\nheight = 0\nfx = 0.0\nfy = 0.0\ncx = 0.0\ncy = 0.0\ndistortion = [0.0, 0.0, 0.0, 0.0, 0.0]\n\n[pose]\nposition = [0.0, 1.6, 0.0]\nlook_at = [0.0, 1.6, -1.0]\nup = [0.0, 1.0, 0.0]\n\n[response]\nkind = \"srgb\"\nexposure = 1.0\nsaturation = 0.98\n";

/// A board from `COLSxROWS` inner corners and the square side in millimetres.
pub fn parse_board(board: &str, square_mm: f64) -> Result<Board> {
    let (c, r) = board.split_once(['x', 'X']).with_context(|| format!("board '{board}': expected COLSxROWS inner corners, e.g. 9x6"))?;
    let parse = |s: &str| s.trim().parse::<u32>().with_context(|| format!("board '{board}': '{}' is not a whole number of corners", s.trim()));
    let (cols, rows) = (parse(c)?, parse(r)?);
    if cols < 3 || rows < 3 {
        bail!("board '{board}': at least 3×3 inner corners");
    }
    if !(square_mm.is_finite() && square_mm > 0.0) {
        bail!("square size {square_mm} mm: must be a positive number of millimetres");
    }
    Ok(Board { cols, rows, square_m: square_mm / 1000.0 })
}

/// The image files of a folder, sorted by name.
pub fn list_images(dir: &Path) -> Result<Vec<PathBuf>> {
    let mut files: Vec<PathBuf> = std::fs::read_dir(dir)
        .with_context(|| format!("reading {}", dir.display()))?
        .filter_map(|e| e.ok().map(|e| e.path()))
        .filter(|p| p.extension().and_then(|e| e.to_str()).is_some_and(|e| IMAGE_EXTENSIONS.contains(&e.to_ascii_lowercase().as_str())))
        .collect();
    files.sort();
    if files.is_empty() {
        bail!("{}: no images ({})", dir.display(), IMAGE_EXTENSIONS.join(", "));
    }
    Ok(files)
}

/// Where the chessboard views come from.
#[derive(Clone, Debug, PartialEq)]
pub enum ViewSource {
    /// The images of a folder.
    Images(PathBuf),
    /// Every `every`-th frame of a video.
    Video {
        /// The video file.
        path: PathBuf,
        /// Frame step (≥ 1).
        every: u64,
    },
}

/// Calls `visit(image, label)` for every view of `source` until it returns `false`; an image
/// that cannot be read is passed as its error (`visit` decides whether to go on). A folder that
/// cannot be listed or a video that cannot be opened or decoded is an error, as is an error
/// returned by `visit`.
pub fn for_each_view(source: &ViewSource, mut visit: impl FnMut(Result<Rgb8>, String) -> Result<bool>) -> Result<()> {
    match source {
        ViewSource::Images(dir) => {
            for f in list_images(dir)? {
                if !visit(Rgb8::open(&f).map_err(Into::into), f.display().to_string())? {
                    break;
                }
            }
        }
        ViewSource::Video { path, every } => {
            let every = (*every).max(1);
            let mut src = heliar::io::video::VideoSource::open_file(path)?;
            let mut i = 0u64;
            while let Some((frame, _)) = src.read()? {
                let label = format!("{} frame {i}", path.display());
                let img = rgb8_from_frame(&frame).with_context(|| label.clone());
                if !visit(img, label)? {
                    break;
                }
                src.skip(every - 1)?;
                i += every;
            }
        }
    }
    Ok(())
}

/// An 8-bit RGB copy of an LDR frame (16-bit codes keep their high byte).
pub fn rgb8_from_frame(frame: &Frame) -> Result<Rgb8> {
    let data = match &frame.data {
        FrameData::Ldr { bits: 8, codes } => codes.iter().map(|&c| c.min(255) as u8).collect(),
        FrameData::Ldr { codes, .. } => codes.iter().map(|&c| (c >> 8) as u8).collect(),
        FrameData::Hdr(_) => bail!("an HDR frame; chessboard detection needs 8-bit images"),
    };
    Ok(Rgb8 { width: frame.width, height: frame.height, data })
}

/// The size every view must share: the first view's. An error names the view that differs.
pub fn check_view_size(size: &mut Option<(u32, u32)>, img: &Rgb8, label: &str) -> Result<()> {
    match *size {
        Some(s) if s != (img.width, img.height) => bail!("{label}: {}×{} but earlier views are {}×{}", img.width, img.height, s.0, s.1),
        Some(_) => {}
        None => *size = Some((img.width, img.height)),
    }
    Ok(())
}

/// The usable views of a source: those with the board found, all of one size.
pub struct Views {
    /// The corners of each usable view.
    pub corners: Vec<Vector<Point2f>>,
    /// Their size.
    pub size: (u32, u32),
    /// The `cornerSubPix` half-window of each usable view (pixels).
    pub half_windows: Vec<i32>,
    /// The views left out, each as `label: why`.
    pub skipped: Vec<String>,
    /// Views looked at.
    pub seen: usize,
}

type Found = (String, (u32, u32), Vector<Point2f>, i32);

/// Reads every view of `source` and finds `board` in it. A view that cannot be read, in which
/// the board is not found, or whose size differs from that of most views with the board (ties:
/// the first seen) is skipped, and named in [`Views::skipped`]; an error only when fewer than
/// [`MIN_VIEWS`] usable views remain (or the source itself cannot be read).
pub fn collect_views(source: &ViewSource, board: &Board) -> Result<Views> {
    // Label, size, corners and sub-pixel half-window of each view with the board.
    let mut found: Vec<Found> = Vec::new();
    let mut skipped = Vec::new();
    let mut seen = 0usize;
    for_each_view(source, |img, label| {
        seen += 1;
        match img.and_then(|img| Ok((img.width, img.height, detect_corners_with_window(&img, board)?))) {
            Err(e) => skipped.push(format!("{label}: unreadable ({e:#})")),
            Ok((_, _, None)) => skipped.push(format!("{label}: board not found")),
            Ok((w, h, Some((c, half)))) => found.push((label, (w, h), c, half)),
        }
        Ok(true)
    })?;
    let mut counts: Vec<((u32, u32), usize)> = Vec::new();
    for (_, size, _, _) in &found {
        match counts.iter_mut().find(|(s, _)| s == size) {
            Some((_, n)) => *n += 1,
            None => counts.push((*size, 1)),
        }
    }
    let size = counts.iter().fold(None::<((u32, u32), usize)>, |best, &(s, n)| if best.is_some_and(|(_, m)| m >= n) { best } else { Some((s, n)) }).map(|(s, _)| s);
    let (mut corners, mut half_windows) = (Vec::new(), Vec::new());
    for (label, s, c, half) in found {
        match size {
            Some(size) if s != size => skipped.push(format!("{label}: {}×{} but the other views are {}×{}", s.0, s.1, size.0, size.1)),
            _ => {
                corners.push(c);
                half_windows.push(half);
            }
        }
    }
    let Some(size) = size.filter(|_| corners.len() >= MIN_VIEWS) else {
        bail!(
            "{} usable views of {seen}; at least {MIN_VIEWS} are needed (vary the board's tilt and position){}",
            corners.len(),
            skipped.iter().map(|s| format!("\n  skipped {s}")).collect::<String>()
        );
    };
    Ok(Views { corners, size, half_windows, skipped, seen })
}

/// What is doubtful about a pinhole calibration, in words (empty when it looks good).
pub fn warnings(c: &PinholeCalibration) -> Vec<String> {
    let mut w = Vec::new();
    if c.coverage < COVERAGE_WARN {
        w.push(format!(
            "the corners cover {:.0}% of the image; distortion near the edges is extrapolated (add views with the board near the corners)",
            100.0 * c.coverage
        ));
    }
    if c.rms_px > RMS_WARN_PX {
        w.push(format!("RMS reprojection error {:.2} px is high (good calibrations are below 0.5 px)", c.rms_px));
    }
    w
}

/// The report of a pinhole calibration (what the command prints).
pub fn pinhole_json(width: u32, height: u32, c: &PinholeCalibration) -> serde_json::Value {
    serde_json::json!({"model": "brown_conrady", "width": width, "height": height, "result": c})
}

/// The report of a fisheye calibration.
pub fn fisheye_json(width: u32, height: u32, c: &FisheyeCalibration) -> serde_json::Value {
    serde_json::json!({"model": "kannala_brandt", "width": width, "height": height, "result": c})
}

/// The camera file `existing` (or [`DEFAULT_CAMERA`]) with new size, intrinsics and distortion;
/// its pose, response and comments are kept. `path` is only for the error message.
pub fn camera_toml_with_intrinsics(existing: Option<&str>, path: &Path, width: u32, height: u32, c: &PinholeCalibration) -> Result<String> {
    let mut doc: toml_edit::DocumentMut = existing.unwrap_or(DEFAULT_CAMERA).parse().with_context(|| format!("{}: not valid TOML", path.display()))?;
    doc["width"] = toml_edit::value(width as i64);
    doc["height"] = toml_edit::value(height as i64);
    for (k, v) in [("fx", c.fx), ("fy", c.fy), ("cx", c.cx), ("cy", c.cy)] {
        doc[k] = toml_edit::value(v);
    }
    doc["distortion"] = super::toml_array(c.distortion);
    Ok(doc.to_string())
}

/// The current text of a camera file, `None` when it does not exist yet.
pub fn read_camera_file(path: &Path) -> Result<Option<String>> {
    match std::fs::read_to_string(path) {
        Ok(t) => Ok(Some(t)),
        Err(e) if e.kind() == std::io::ErrorKind::NotFound => Ok(None),
        Err(e) => Err(e).with_context(|| format!("reading {}", path.display())),
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn boards_parse_or_say_what_is_wrong() {
        let b = parse_board("9x6", 25.0).unwrap();
        assert_eq!((b.cols, b.rows), (9, 6));
        assert!((b.square_m - 0.025).abs() < 1e-12);
        for (s, mm, msg) in [("9", 25.0, "COLSxROWS"), ("9xa", 25.0, "whole number"), ("2x6", 25.0, "3×3"), ("9x6", 0.0, "positive")] {
            let e = parse_board(s, mm).unwrap_err().to_string();
            assert!(e.contains(msg), "{s}: {e}");
        }
    }

    #[test]
    fn intrinsics_keep_the_rest_of_the_camera_file() {
        let c = PinholeCalibration { fx: 500.0, fy: 501.0, cx: 320.0, cy: 240.0, distortion: [-0.1, 0.01, 0.0, 0.0, 0.0], rms_px: 0.2, views: 10, coverage: 0.8 };
        let old = "# my camera\nwidth = 1\nheight = 1\nfx = 1.0\nfy = 1.0\ncx = 0.0\ncy = 0.0\ndistortion = [0.0, 0.0, 0.0, 0.0, 0.0]\n\n[pose]  # surveyed\nposition = [1.0, 2.0, 3.0]\nlook_at = [0.0, 0.0, 0.0]\nup = [0.0, 1.0, 0.0]\n\n[response]\nkind = \"linear\"\nexposure = 2.0\nsaturation = 0.9\n";
        let new = camera_toml_with_intrinsics(Some(old), Path::new("c.toml"), 640, 480, &c).unwrap();
        assert!(new.contains("# my camera") && new.contains("# surveyed") && new.contains("kind = \"linear\""), "{new}");
        let cf: heliar::scene::CameraFile = toml::from_str(&new).unwrap();
        assert_eq!((cf.width, cf.height, cf.fx, cf.cy), (640, 480, 500.0, 240.0));
        assert!(warnings(&c).is_empty());
        let bad = PinholeCalibration { rms_px: 1.5, coverage: 0.3, ..c };
        assert_eq!(warnings(&bad).len(), 2);
    }
}
