//! The camera pose against the proxy from 2D–3D point pairs (OpenCV `solvePnP`).
//!
//! The user clicks image points and the matching proxy points; `solvePnP` (iterative
//! Levenberg–Marquardt from an SQPnP start) gives `camera_from_world` as a Rodrigues vector and a
//! translation (the form `calib/camera.toml` accepts), and the RMS reprojection error tells
//! whether the pairs agree.

use super::OpenCvCalibError;
use crate::camera::{Camera, Intrinsics, Pose};
use glam::{DVec2, DVec3};
use opencv::calib3d;
use opencv::core::{Mat, Point2f, Point3f, Vector};
use opencv::prelude::*;

/// Fewest pairs for a pose.
pub const MIN_PAIRS: usize = 4;

/// A solved pose.
#[derive(Clone, Debug, PartialEq, serde::Serialize)]
pub struct PoseFit {
    /// Rodrigues vector of `camera_from_world`.
    pub rvec_camera_from_world: [f64; 3],
    /// Translation of `camera_from_world`.
    pub tvec_camera_from_world: [f64; 3],
    /// RMS reprojection error of the pairs, pixels.
    pub rms_px: f64,
    /// Largest reprojection error, pixels.
    pub max_px: f64,
}

impl PoseFit {
    /// As a heliar pose (`world_from_camera`).
    pub fn pose(&self) -> Pose {
        Pose::from_rvec_tvec(DVec3::from(self.rvec_camera_from_world), DVec3::from(self.tvec_camera_from_world))
    }
}

/// Solves the pose of a camera with `intrinsics` from pixel points and their world points.
pub fn solve_pose(intrinsics: &Intrinsics, pixels: &[DVec2], world: &[DVec3]) -> Result<PoseFit, OpenCvCalibError> {
    if pixels.len() != world.len() {
        return Err(OpenCvCalibError::Input(format!("{} image points but {} world points", pixels.len(), world.len())));
    }
    if pixels.len() < MIN_PAIRS {
        return Err(OpenCvCalibError::Input(format!("{} point pairs; at least {MIN_PAIRS} are needed", pixels.len())));
    }
    if pixels.iter().any(|p| !p.is_finite()) || world.iter().any(|p| !p.is_finite()) {
        return Err(OpenCvCalibError::Input("point pairs must be finite".into()));
    }
    let img: Vector<Point2f> = pixels.iter().map(|p| Point2f::new(p.x as f32, p.y as f32)).collect();
    let obj: Vector<Point3f> = world.iter().map(|p| Point3f::new(p.x as f32, p.y as f32, p.z as f32)).collect();
    let k = Mat::from_slice_2d(&[[intrinsics.fx, 0.0, intrinsics.cx], [0.0, intrinsics.fy, intrinsics.cy], [0.0, 0.0, 1.0]])?;
    let d = Mat::from_slice(intrinsics.distortion().unwrap_or(&[0.0; 5]))?.try_clone()?;
    let (mut rvec, mut tvec) = (Mat::default(), Mat::default());
    // SQPnP finds the global optimum without a start; the iterative method then polishes it.
    if !calib3d::solve_pnp(&obj, &img, &k, &d, &mut rvec, &mut tvec, false, calib3d::SOLVEPNP_SQPNP)? {
        return Err(OpenCvCalibError::Input("solvePnP found no pose for these pairs".into()));
    }
    calib3d::solve_pnp(&obj, &img, &k, &d, &mut rvec, &mut tvec, true, calib3d::SOLVEPNP_ITERATIVE)?;
    let get = |m: &Mat| -> Result<[f64; 3], OpenCvCalibError> { Ok([*m.at::<f64>(0)?, *m.at::<f64>(1)?, *m.at::<f64>(2)?]) };
    let mut fit = PoseFit { rvec_camera_from_world: get(&rvec)?, tvec_camera_from_world: get(&tvec)?, rms_px: 0.0, max_px: 0.0 };
    let cam = Camera { intrinsics: intrinsics.clone(), pose: fit.pose() };
    let mut sq = 0.0;
    for (p, w) in pixels.iter().zip(world) {
        let e = cam.project_world(*w).map_or(f64::INFINITY, |q| (q - *p).length());
        sq += e * e;
        fit.max_px = fit.max_px.max(e);
    }
    fit.rms_px = (sq / pixels.len() as f64).sqrt();
    Ok(fit)
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn recovers_a_known_pose() {
        let intr = Intrinsics::brown_conrady(640, 480, 500.0, 500.0, 320.0, 240.0, [-0.08, 0.01, 0.0, 0.0, 0.0]);
        let truth = Pose::look_at(DVec3::new(4.5, 1.7, 9.0), DVec3::new(-2.5, 0.6, -4.0), DVec3::Y).unwrap();
        let cam = Camera { intrinsics: intr.clone(), pose: truth };
        // Corners of the courtyard proxy: buildings and the wall.
        let world = [
            DVec3::new(-8.0, 0.0, -8.0),
            DVec3::new(-8.0, 6.0, -8.0),
            DVec3::new(12.0, 9.0, -8.0),
            DVec3::new(-3.2, 2.4, 1.5),
            DVec3::new(-2.8, 0.0, 1.5),
            DVec3::new(5.0, 0.0, -8.0),
            DVec3::new(-8.0, 6.0, 4.0),
        ];
        let pixels: Vec<DVec2> = world.iter().map(|w| cam.project_world(*w).unwrap()).collect();
        let fit = solve_pose(&intr, &pixels, &world).unwrap();
        let p = fit.pose();
        assert!((p.translation - truth.translation).length() < 1e-3, "{:?}", p.translation);
        assert!(fit.rms_px < 1e-3, "{fit:?}");
        // Too few pairs, mismatched lists.
        assert!(solve_pose(&intr, &pixels[..3], &world[..3]).unwrap_err().to_string().contains("at least 4"));
        assert!(solve_pose(&intr, &pixels[..5], &world).is_err());
    }
}
