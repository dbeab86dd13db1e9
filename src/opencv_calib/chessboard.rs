//! Camera intrinsics and distortion from chessboard views (OpenCV calib3d).
//!
//! # How it works
//! Inner corners are found with `findChessboardCorners` and refined to sub-pixel accuracy with
//! `cornerSubPix`, whose search window is sized from the board as seen: a half-window of
//! [`SUBPIX_WINDOW_FRACTION`] of the smallest square side in pixels, clamped to
//! [`SUBPIX_HALF_WINDOW_MIN`, `SUBPIX_HALF_WINDOW_MAX`] (a window reaching a neighbouring corner
//! pulls the refinement toward it; one much smaller than the square's blur sees too little edge).
//! `calibrateCamera` then fits the pinhole + Brown–Conrady model (OpenCV's
//! `[k1, k2, p1, p2, k3]`, the convention of `calib/camera.toml`) by Levenberg–Marquardt, or
//! `fisheye::calibrate` fits the Kannala–Brandt model. The RMS reprojection error (pixels) says how
//! well the model explains the corners; a good calibration is below 0.5 px.

use super::{OpenCvCalibError, Rgb8};
use crate::camera::{Camera, Intrinsics, Pose};
use glam::{DVec2, DVec3};
use opencv::calib3d;
use opencv::core::{Mat, Point2f, Point3f, Size, TermCriteria, TermCriteria_Type, Vector};
use opencv::imgproc;
use opencv::prelude::*;

/// Fewest usable views for a calibration.
pub const MIN_VIEWS: usize = 3;

/// A chessboard target.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Board {
    /// Inner corners per row.
    pub cols: u32,
    /// Inner corners per column.
    pub rows: u32,
    /// Side of one square, metres.
    pub square_m: f64,
}

impl Board {
    /// Corner positions on the board plane (z = 0), row-major, metres.
    pub fn object_points(&self) -> Vector<Point3f> {
        let mut v = Vector::new();
        for r in 0..self.rows {
            for c in 0..self.cols {
                v.push(Point3f::new((c as f64 * self.square_m) as f32, (r as f64 * self.square_m) as f32, 0.0));
            }
        }
        v
    }
}

/// Half-window of `cornerSubPix` as a fraction of the smallest square side (pixels) in the view.
pub const SUBPIX_WINDOW_FRACTION: f64 = 0.4;
/// Smallest half-window (pixels) of `cornerSubPix`.
pub const SUBPIX_HALF_WINDOW_MIN: i32 = 2;
/// Largest half-window (pixels) of `cornerSubPix`.
pub const SUBPIX_HALF_WINDOW_MAX: i32 = 11;

/// The `cornerSubPix` half-window for corners of `board` found at `corners` (row-major, as
/// `findChessboardCorners` orders them): [`SUBPIX_WINDOW_FRACTION`] of the shortest distance
/// between neighbouring corners, rounded and clamped.
pub fn subpix_half_window(corners: &[(f32, f32)], board: &Board) -> i32 {
    let (cols, rows) = (board.cols as usize, board.rows as usize);
    let mut side = f64::INFINITY;
    let dist = |a: (f32, f32), b: (f32, f32)| (((a.0 - b.0) as f64).powi(2) + ((a.1 - b.1) as f64).powi(2)).sqrt();
    for r in 0..rows {
        for c in 0..cols {
            let i = r * cols + c;
            if c + 1 < cols && i + 1 < corners.len() {
                side = side.min(dist(corners[i], corners[i + 1]));
            }
            if r + 1 < rows && i + cols < corners.len() {
                side = side.min(dist(corners[i], corners[i + cols]));
            }
        }
    }
    if !side.is_finite() {
        return SUBPIX_HALF_WINDOW_MIN;
    }
    ((SUBPIX_WINDOW_FRACTION * side).round() as i32).clamp(SUBPIX_HALF_WINDOW_MIN, SUBPIX_HALF_WINDOW_MAX)
}

/// Finds and refines the inner corners of `board` in `img`; `None` when the board is not found.
pub fn detect_corners(img: &Rgb8, board: &Board) -> Result<Option<Vector<Point2f>>, OpenCvCalibError> {
    Ok(detect_corners_with_window(img, board)?.map(|(c, _)| c))
}

/// [`detect_corners`], with the `cornerSubPix` half-window used ([`subpix_half_window`]).
pub fn detect_corners_with_window(img: &Rgb8, board: &Board) -> Result<Option<(Vector<Point2f>, i32)>, OpenCvCalibError> {
    let gray = img.to_gray_mat()?;
    let mut corners = Vector::<Point2f>::new();
    let size = Size::new(board.cols as i32, board.rows as i32);
    let flags = calib3d::CALIB_CB_ADAPTIVE_THRESH | calib3d::CALIB_CB_NORMALIZE_IMAGE;
    if !calib3d::find_chessboard_corners(&gray, size, &mut corners, flags)? {
        return Ok(None);
    }
    let crit = TermCriteria::new(TermCriteria_Type::COUNT as i32 + TermCriteria_Type::EPS as i32, 50, 1e-4)?;
    let found: Vec<(f32, f32)> = corners.iter().map(|p| (p.x, p.y)).collect();
    let half = subpix_half_window(&found, board);
    imgproc::corner_sub_pix(&gray, &mut corners, Size::new(half, half), Size::new(-1, -1), crit)?;
    Ok(Some((corners, half)))
}

/// Result of a pinhole calibration.
#[derive(Clone, Debug, PartialEq, serde::Serialize)]
pub struct PinholeCalibration {
    /// Intrinsics with Brown–Conrady distortion.
    pub fx: f64,
    /// Focal length y, pixels.
    pub fy: f64,
    /// Principal point x.
    pub cx: f64,
    /// Principal point y.
    pub cy: f64,
    /// `[k1, k2, p1, p2, k3]`.
    pub distortion: [f64; 5],
    /// RMS reprojection error, pixels.
    pub rms_px: f64,
    /// Views used.
    pub views: usize,
    /// Fraction of the image covered by corners (see [`coverage`]).
    pub coverage: f64,
}

/// Result of a Kannala–Brandt fisheye calibration.
#[derive(Clone, Debug, PartialEq, serde::Serialize)]
pub struct FisheyeCalibration {
    /// Focal length x, pixels.
    pub fx: f64,
    /// Focal length y.
    pub fy: f64,
    /// Principal point x.
    pub cx: f64,
    /// Principal point y.
    pub cy: f64,
    /// `[k1, k2, k3, k4]` of `θ_d = θ(1 + k1θ² + k2θ⁴ + k3θ⁶ + k4θ⁸)`.
    pub k: [f64; 4],
    /// RMS reprojection error, pixels.
    pub rms_px: f64,
    /// Views used.
    pub views: usize,
}

fn check_views(n: usize) -> Result<(), OpenCvCalibError> {
    if n < MIN_VIEWS {
        return Err(OpenCvCalibError::Input(format!("the board was found in {n} views; at least {MIN_VIEWS} are needed (vary the board's tilt and position)")));
    }
    Ok(())
}

fn mat_f64(m: &Mat) -> Result<Vec<f64>, OpenCvCalibError> {
    let mut out = Vec::new();
    for r in 0..m.rows() {
        for c in 0..m.cols() {
            out.push(*m.at_2d::<f64>(r, c)?);
        }
    }
    Ok(out)
}

/// Fraction of the image (a 10 × 10 grid of cells) in which at least one corner was seen. Lens
/// distortion is only determined where there are corners; below about 0.6 the outer image is
/// extrapolated.
pub fn coverage(views: &[Vector<Point2f>], width: u32, height: u32) -> f64 {
    let mut cells = [[false; 10]; 10];
    for v in views {
        for p in v.iter() {
            let (i, j) = ((p.x / width as f32 * 10.0) as usize, (p.y / height as f32 * 10.0) as usize);
            if i < 10 && j < 10 {
                cells[j][i] = true;
            }
        }
    }
    cells.iter().flatten().filter(|&&c| c).count() as f64 / 100.0
}

/// The board's corners and the detected corners of every view, as OpenCV wants them.
fn point_sets(views: &[Vector<Point2f>], board: &Board) -> Result<(Vector<Vector<Point3f>>, Vector<Vector<Point2f>>), OpenCvCalibError> {
    check_views(views.len())?;
    let obj = views.iter().map(|_| board.object_points()).collect();
    let img = views.iter().cloned().collect();
    Ok((obj, img))
}

/// Pinhole + Brown–Conrady calibration from the corner sets of several views. `fit_k3` frees the
/// sixth-order radial term; keep it fixed at 0 (OpenCV's advice) unless the lens is very wide and
/// the views cover the image corners, or the polynomial overfits and diverges at the edges.
pub fn calibrate_pinhole(views: &[Vector<Point2f>], board: &Board, width: u32, height: u32, fit_k3: bool) -> Result<PinholeCalibration, OpenCvCalibError> {
    let (obj, img) = point_sets(views, board)?;
    let mut k = Mat::default();
    let mut d = Mat::default();
    let (mut rv, mut tv) = (Vector::<Mat>::new(), Vector::<Mat>::new());
    let crit = TermCriteria::new(TermCriteria_Type::COUNT as i32 + TermCriteria_Type::EPS as i32, 100, 1e-10)?;
    let flags = if fit_k3 { 0 } else { calib3d::CALIB_FIX_K3 };
    let rms = calib3d::calibrate_camera(&obj, &img, Size::new(width as i32, height as i32), &mut k, &mut d, &mut rv, &mut tv, flags, crit)?;
    let k = mat_f64(&k)?;
    let d = mat_f64(&d)?;
    let dist = std::array::from_fn(|i| d.get(i).copied().unwrap_or(0.0));
    Ok(PinholeCalibration { fx: k[0], fy: k[4], cx: k[2], cy: k[5], distortion: dist, rms_px: rms, views: views.len(), coverage: coverage(views, width, height) })
}

/// Kannala–Brandt fisheye calibration (OpenCV's `fisheye::calibrate`).
pub fn calibrate_fisheye(views: &[Vector<Point2f>], board: &Board, width: u32, height: u32) -> Result<FisheyeCalibration, OpenCvCalibError> {
    let (obj, img) = point_sets(views, board)?;
    let mut k = Mat::default();
    let mut d = Mat::default();
    let (mut rv, mut tv) = (Vector::<Mat>::new(), Vector::<Mat>::new());
    let crit = TermCriteria::new(TermCriteria_Type::COUNT as i32 + TermCriteria_Type::EPS as i32, 100, 1e-10)?;
    let flags = calib3d::Fisheye_CALIB_RECOMPUTE_EXTRINSIC | calib3d::Fisheye_CALIB_FIX_SKEW;
    let rms = calib3d::calibrate(&obj, &img, Size::new(width as i32, height as i32), &mut k, &mut d, &mut rv, &mut tv, flags, crit)?;
    let k = mat_f64(&k)?;
    let d = mat_f64(&d)?;
    Ok(FisheyeCalibration { fx: k[0], fy: k[4], cx: k[2], cy: k[5], k: std::array::from_fn(|i| d.get(i).copied().unwrap_or(0.0)), rms_px: rms, views: views.len() })
}

/// Renders a synthetic view of `board` (white margin of one square) through `camera`, with
/// `supersample²` samples per pixel: the test target for calibration, with known intrinsics.
/// The board lies in its own plane z = 0 placed by `world_from_board` (the camera's world).
pub fn render_board(camera: &Camera, board: &Board, world_from_board: &Pose, supersample: u32) -> Rgb8 {
    let (w, h) = (camera.intrinsics.width, camera.intrinsics.height);
    let s = supersample.max(1);
    let n = DVec3::from(world_from_board.rotation.z_axis);
    let o = world_from_board.translation;
    let mut data = Vec::with_capacity((w * h * 3) as usize);
    for y in 0..h {
        for x in 0..w {
            let mut acc = 0.0;
            for sy in 0..s {
                for sx in 0..s {
                    let uv = DVec2::new(x as f64 - 0.5 + (sx as f64 + 0.5) / s as f64, y as f64 - 0.5 + (sy as f64 + 0.5) / s as f64);
                    let Some((ro, rd)) = camera.ray_at(uv) else { continue };
                    let denom = rd.dot(n);
                    let mut v = 0.55; // background grey
                    if denom.abs() > 1e-9 {
                        let t = (o - ro).dot(n) / denom;
                        if t > 0.0 {
                            let p = world_from_board.rotation.transpose() * (ro + rd * t - o);
                            let (bx, by) = (p.x / board.square_m + 1.0, p.y / board.square_m + 1.0);
                            // Squares span [-1, cols] × [-1, rows] corners; a white margin of one square.
                            let inside = bx >= 0.0 && by >= 0.0 && bx < (board.cols + 1) as f64 && by < (board.rows + 1) as f64;
                            let margin = bx >= -1.0 && by >= -1.0 && bx < (board.cols + 2) as f64 && by < (board.rows + 2) as f64;
                            v = if inside {
                                if (bx.floor() as i64 + by.floor() as i64) % 2 == 0 { 0.05 } else { 0.95 }
                            } else if margin {
                                0.95
                            } else {
                                0.55
                            };
                        }
                    }
                    acc += v;
                }
            }
            let g = (acc / (s * s) as f64 * 255.0).round() as u8;
            data.extend([g, g, g]);
        }
    }
    Rgb8 { width: w, height: h, data }
}

/// The default intrinsics a [`PinholeCalibration`] describes, for a `width × height` camera.
impl PinholeCalibration {
    /// As heliar intrinsics.
    pub fn intrinsics(&self, width: u32, height: u32) -> Intrinsics {
        Intrinsics::brown_conrady(width, height, self.fx, self.fy, self.cx, self.cy, self.distortion)
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use glam::DMat3;

    #[test]
    fn synthetic_views_give_the_known_intrinsics() {
        // Ground truth: a 640×480 camera with mild barrel distortion.
        let truth = Intrinsics::brown_conrady(640, 480, 520.0, 518.0, 318.5, 243.0, [-0.12, 0.04, 0.0, 0.0, 0.0]);
        let cam = Camera { intrinsics: truth.clone(), pose: Pose { rotation: DMat3::IDENTITY, translation: DVec3::ZERO } };
        let board = Board { cols: 9, rows: 6, square_m: 0.03 };
        let centre = DVec3::new(-0.15, -0.1, 0.0);
        let mut views = Vec::new();
        for (i, (ax, ay, dist, ox, oy)) in [
            (0.0, 0.0, 0.55, 0.0, 0.0),
            (0.35, 0.0, 0.6, 0.0, 0.0),
            (-0.35, 0.1, 0.6, 0.0, 0.0),
            (0.0, 0.4, 0.5, 0.0, 0.0),
            (0.1, -0.4, 0.65, 0.0, 0.0),
            (0.3, 0.3, 0.7, 0.0, 0.0),
            (-0.25, -0.3, 0.5, 0.0, 0.0),
            // Boards near the four image corners, so that the distortion is measured there.
            (0.2, 0.2, 0.6, 0.22, 0.16),
            (-0.2, 0.2, 0.6, -0.22, 0.16),
            (0.2, -0.2, 0.6, 0.22, -0.16),
            (-0.2, -0.2, 0.6, -0.22, -0.16),
        ]
        .iter()
        .enumerate()
        {
            let (ax, ay, dist, ox, oy) = (*ax, *ay, *dist, *ox, *oy);
            let rot = DMat3::from_rotation_x(ax) * DMat3::from_rotation_y(ay) * DMat3::from_rotation_z(0.1 * i as f64);
            let pose = Pose { rotation: rot, translation: DVec3::new(ox, oy, dist) + rot * centre };
            let img = render_board(&cam, &board, &pose, 4);
            if let Some(c) = detect_corners(&img, &board).unwrap() {
                views.push(c);
            }
        }
        assert!(views.len() >= 6, "found the board in {} views", views.len());
        let c = calibrate_pinhole(&views, &board, 640, 480, false).unwrap();
        // The acceptance: focal within 0.5%, principal point within 2 px.
        assert!((c.fx / truth.fx - 1.0).abs() < 0.005 && (c.fy / truth.fy - 1.0).abs() < 0.005, "{c:?}");
        assert!((c.cx - truth.cx).abs() < 2.0 && (c.cy - truth.cy).abs() < 2.0, "{c:?}");
        assert!(c.rms_px < 0.3, "{c:?}");
        // The distortion is right where it matters: at the image corner the calibrated model maps
        // the pixel's ray back to the same pixel under the true model within half a pixel.
        let calibrated = c.intrinsics(640, 480);
        for uv in [DVec2::new(5.0, 5.0), DVec2::new(634.0, 474.0), DVec2::new(320.0, 5.0)] {
            let ray = calibrated.ray(uv).unwrap();
            let back = truth.project(ray).unwrap();
            assert!((back - uv).length() < 0.5, "{uv} -> {back}");
        }
        // Too few views is a clear error.
        assert!(calibrate_pinhole(&views[..2], &board, 640, 480, false).unwrap_err().to_string().contains("at least 3"));
    }

    #[test]
    fn the_subpixel_window_follows_the_square_size() {
        let board = Board { cols: 3, rows: 3, square_m: 0.03 };
        let grid = |side: f32| (0..9).map(|i| ((i % 3) as f32 * side, (i / 3) as f32 * side)).collect::<Vec<_>>();
        assert_eq!(subpix_half_window(&grid(12.5), &board), 5);
        assert_eq!(subpix_half_window(&grid(20.0), &board), 8);
        // Clamped: tiny squares keep 2 px, huge ones 11 px.
        assert_eq!(subpix_half_window(&grid(3.0), &board), SUBPIX_HALF_WINDOW_MIN);
        assert_eq!(subpix_half_window(&grid(200.0), &board), SUBPIX_HALF_WINDOW_MAX);
        // The smallest square decides (a foreshortened board).
        let mut g = grid(20.0);
        g[1].0 = 10.0;
        assert_eq!(subpix_half_window(&g, &board), 4);
    }
}
