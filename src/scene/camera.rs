//! The calibrated camera: pinhole intrinsics with Brown–Conrady lens distortion, pose, and the
//! photometric response of LDR footage.
//!
//! Conventions (crate docs): OpenCV camera frame (+X right, +Y down, +Z forward) and pixel
//! coordinates (centre of the top-left pixel at `(0, 0)`). The distortion model is OpenCV's
//! five-coefficient Brown–Conrady model `[k1, k2, p1, p2, k3]`:
//!
//! ```text
//! r² = x² + y²,  k = 1 + k1·r² + k2·r⁴ + k3·r⁶
//! x_d = x·k + 2·p1·x·y + p2·(r² + 2x²)
//! y_d = y·k + p1·(r² + 2y²) + 2·p2·x·y
//! u = fx·x_d + cx,  v = fy·y_d + cy
//! ```
//!
//! Undistortion inverts this by Newton's method with the analytic Jacobian; a pixel whose inverse
//! does not converge (outside the region where the model is invertible) gets no ray.

use glam::{DMat3, DVec2, DVec3};

/// Pinhole intrinsics with Brown–Conrady distortion.
#[derive(Clone, Debug, PartialEq)]
pub struct Intrinsics {
    /// Image width in pixels.
    pub width: u32,
    /// Image height in pixels.
    pub height: u32,
    /// Focal length in pixels, horizontal.
    pub fx: f64,
    /// Focal length in pixels, vertical.
    pub fy: f64,
    /// Principal point, pixels.
    pub cx: f64,
    /// Principal point, pixels.
    pub cy: f64,
    /// `[k1, k2, p1, p2, k3]` (OpenCV order).
    pub distortion: [f64; 5],
}

/// Largest residual (normalised image units) accepted by undistortion.
const UNDISTORT_TOL: f64 = 1e-10;
/// Newton iterations allowed for undistortion.
const UNDISTORT_MAX_ITERS: usize = 30;

impl Intrinsics {
    /// Distorts normalised image coordinates `(x, y) = (X/Z, Y/Z)`; also returns the Jacobian.
    pub fn distort(&self, p: DVec2) -> (DVec2, [[f64; 2]; 2]) {
        let [k1, k2, p1, p2, k3] = self.distortion;
        let (x, y) = (p.x, p.y);
        let r2 = x * x + y * y;
        let radial = 1.0 + r2 * (k1 + r2 * (k2 + r2 * k3));
        let dr = k1 + r2 * (2.0 * k2 + 3.0 * k3 * r2); // d radial / d r²
        let xd = x * radial + 2.0 * p1 * x * y + p2 * (r2 + 2.0 * x * x);
        let yd = y * radial + p1 * (r2 + 2.0 * y * y) + 2.0 * p2 * x * y;
        let j = [
            [radial + 2.0 * x * x * dr + 2.0 * p1 * y + 6.0 * p2 * x, 2.0 * x * y * dr + 2.0 * p1 * x + 2.0 * p2 * y],
            [2.0 * x * y * dr + 2.0 * p1 * x + 2.0 * p2 * y, radial + 2.0 * y * y * dr + 6.0 * p1 * y + 2.0 * p2 * x],
        ];
        (DVec2::new(xd, yd), j)
    }

    /// Inverts [`Intrinsics::distort`]; `None` when Newton's method does not converge.
    pub fn undistort(&self, pd: DVec2) -> Option<DVec2> {
        if self.distortion.iter().all(|&k| k == 0.0) {
            return Some(pd);
        }
        let mut p = pd;
        for _ in 0..UNDISTORT_MAX_ITERS {
            let (f, j) = self.distort(p);
            let r = f - pd;
            if r.length() < UNDISTORT_TOL {
                return Some(p);
            }
            let det = j[0][0] * j[1][1] - j[0][1] * j[1][0];
            if !(det.abs() > 1e-12) {
                return None;
            }
            let dx = (j[1][1] * r.x - j[0][1] * r.y) / det;
            let dy = (-j[1][0] * r.x + j[0][0] * r.y) / det;
            p -= DVec2::new(dx, dy);
            if !p.is_finite() {
                return None;
            }
        }
        let (f, _) = self.distort(p);
        ((f - pd).length() < 1e-7).then_some(p)
    }

    /// Pixel coordinates of a point in the camera frame; `None` behind the camera.
    pub fn project(&self, p_cam: DVec3) -> Option<DVec2> {
        if !(p_cam.z > 1e-9) {
            return None;
        }
        let (d, _) = self.distort(DVec2::new(p_cam.x / p_cam.z, p_cam.y / p_cam.z));
        Some(DVec2::new(self.fx * d.x + self.cx, self.fy * d.y + self.cy))
    }

    /// Unit ray direction in the camera frame through pixel coordinates `(u, v)`.
    pub fn ray(&self, uv: DVec2) -> Option<DVec3> {
        let pd = DVec2::new((uv.x - self.cx) / self.fx, (uv.y - self.cy) / self.fy);
        let p = self.undistort(pd)?;
        Some(DVec3::new(p.x, p.y, 1.0).normalize())
    }
}

/// A rigid transform `world_from_camera`: `p_world = rotation · p_cam + translation`.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Pose {
    /// Rotation, columns are the camera's right, down and forward axes in world coordinates.
    pub rotation: DMat3,
    /// Camera centre in world coordinates.
    pub translation: DVec3,
}

impl Pose {
    /// A camera at `position` looking at `target`, with `up` (world) pointing up in the image.
    /// `None` when the view direction is parallel to `up` or zero.
    pub fn look_at(position: DVec3, target: DVec3, up: DVec3) -> Option<Self> {
        let forward = (target - position).try_normalize()?;
        let right = forward.cross(up).try_normalize()?;
        let down = forward.cross(right);
        Some(Self { rotation: DMat3::from_cols(right, down, forward), translation: position })
    }

    /// From OpenCV's `solvePnP` output (`camera_from_world` as a Rodrigues vector and a
    /// translation).
    pub fn from_rvec_tvec(rvec: DVec3, tvec: DVec3) -> Self {
        let angle = rvec.length();
        let camera_from_world = if angle < 1e-15 {
            DMat3::IDENTITY
        } else {
            DMat3::from_axis_angle(rvec / angle, angle)
        };
        let rotation = camera_from_world.transpose();
        Self { rotation, translation: -(rotation * tvec) }
    }

    /// Camera-frame coordinates of a world point.
    pub fn camera_from_world(&self, p: DVec3) -> DVec3 {
        self.rotation.transpose() * (p - self.translation)
    }

    /// World coordinates of a camera-frame point.
    pub fn world_from_camera(&self, p: DVec3) -> DVec3 {
        self.rotation * p + self.translation
    }
}

/// A calibrated camera.
#[derive(Clone, Debug, PartialEq)]
pub struct Camera {
    /// Intrinsics and distortion.
    pub intrinsics: Intrinsics,
    /// `world_from_camera`.
    pub pose: Pose,
}

impl Camera {
    /// The same camera for frames of `width × height`: focal lengths and principal point scaled
    /// by `width / current width` (the same horizontal field of view), then cropped or padded
    /// vertically about the centre. Distortion coefficients are unchanged (they act on
    /// normalised coordinates).
    pub fn resized(&self, width: u32, height: u32) -> Camera {
        let mut c = self.clone();
        let k = &mut c.intrinsics;
        let s = width as f64 / k.width as f64;
        k.fx *= s;
        k.fy *= s;
        k.cx = (k.cx + 0.5) * s - 0.5;
        k.cy = (k.cy + 0.5) * s - 0.5 - (k.height as f64 * s - height as f64) / 2.0;
        k.width = width;
        k.height = height;
        c
    }

    /// World-space ray (origin, unit direction) through the centre of pixel `(col, row)`.
    pub fn pixel_ray(&self, col: u32, row: u32) -> Option<(DVec3, DVec3)> {
        self.ray_at(DVec2::new(col as f64, row as f64))
    }

    /// World-space ray through pixel coordinates `uv`.
    pub fn ray_at(&self, uv: DVec2) -> Option<(DVec3, DVec3)> {
        let d = self.intrinsics.ray(uv)?;
        Some((self.pose.translation, self.pose.rotation * d))
    }

    /// Pixel coordinates of a world point; `None` behind the camera.
    pub fn project_world(&self, p: DVec3) -> Option<DVec2> {
        self.intrinsics.project(self.pose.camera_from_world(p))
    }
}

/// Where an image's pixel rays come from: a calibrated camera, or an equirect map seen from a
/// point (an environment map at its capture centre).
#[derive(Clone, Copy, Debug)]
pub enum View<'a> {
    /// A calibrated pinhole camera with distortion.
    Camera(&'a Camera),
    /// An equirect map of `width × height` texels (crate conventions) around `centre`.
    Equirect {
        /// World position of the map's centre of projection.
        centre: DVec3,
        /// Width in texels.
        width: u32,
        /// Height in texels.
        height: u32,
    },
}

impl View<'_> {
    /// Image size.
    pub fn size(&self) -> (u32, u32) {
        match self {
            View::Camera(c) => (c.intrinsics.width, c.intrinsics.height),
            View::Equirect { width, height, .. } => (*width, *height),
        }
    }

    /// The centre of projection.
    pub fn eye(&self) -> DVec3 {
        match self {
            View::Camera(c) => c.pose.translation,
            View::Equirect { centre, .. } => *centre,
        }
    }

    /// World ray (origin, unit direction) through the centre of pixel `(x, y)`.
    pub fn ray(&self, x: u32, y: u32) -> Option<(DVec3, DVec3)> {
        match self {
            View::Camera(c) => c.pixel_ray(x, y),
            View::Equirect { centre, width, height } => {
                Some((*centre, crate::envmap::dir_from_texel_centre(x, y, *width, *height).as_dvec3()))
            }
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn intr(distortion: [f64; 5]) -> Intrinsics {
        Intrinsics { width: 640, height: 480, fx: 500.0, fy: 510.0, cx: 321.0, cy: 239.0, distortion }
    }

    #[test]
    fn distortion_round_trip_over_the_image() {
        // Mild barrel, strong barrel with tangential terms, and pincushion.
        for d in [
            [-0.1, 0.02, 0.0, 0.0, 0.0],
            [-0.3, 0.12, 0.001, -0.002, -0.02],
            [0.15, -0.05, -0.001, 0.0005, 0.01],
        ] {
            let k = intr(d);
            for v in (0..480).step_by(31) {
                for u in (0..640).step_by(37) {
                    let uv = DVec2::new(u as f64, v as f64);
                    let ray = k.ray(uv).expect("inside the invertible region");
                    let back = k.project(ray).unwrap();
                    assert!((back - uv).length() < 1e-6, "{d:?} {uv} -> {back}");
                }
            }
        }
    }

    #[test]
    fn resized_camera_sees_the_same_points_at_scaled_pixels() {
        let cam = Camera { intrinsics: intr([-0.1, 0.02, 0.0, 0.0, 0.0]), pose: Pose { rotation: glam::DMat3::IDENTITY, translation: DVec3::ZERO } };
        // Twice the width and height: pixel edges scale by 2 (centres by 2·(u + ½) − ½).
        let big = cam.resized(1280, 960);
        // Same width, 80 rows fewer: cropped by 40 rows at the top.
        let crop = cam.resized(640, 400);
        for p in [DVec3::new(0.3, -0.2, 2.0), DVec3::new(-0.5, 0.4, 3.0), DVec3::new(0.0, 0.0, 1.0)] {
            let a = cam.intrinsics.project(p).unwrap();
            let b = big.intrinsics.project(p).unwrap();
            assert!((b - (2.0 * (a + DVec2::splat(0.5)) - DVec2::splat(0.5))).length() < 1e-9, "{a} {b}");
            let c = crop.intrinsics.project(p).unwrap();
            assert!((c - (a - DVec2::new(0.0, 40.0))).length() < 1e-9, "{a} {c}");
        }
        assert_eq!(cam.resized(640, 480), cam);
    }

    #[test]
    fn jacobian_matches_finite_differences() {
        let k = intr([-0.3, 0.12, 0.001, -0.002, -0.02]);
        let p = DVec2::new(0.31, -0.22);
        let (_, j) = k.distort(p);
        let h = 1e-6;
        let dx = (k.distort(p + DVec2::X * h).0 - k.distort(p - DVec2::X * h).0) / (2.0 * h);
        let dy = (k.distort(p + DVec2::Y * h).0 - k.distort(p - DVec2::Y * h).0) / (2.0 * h);
        assert!((dx.x - j[0][0]).abs() < 1e-7 && (dx.y - j[1][0]).abs() < 1e-7);
        assert!((dy.x - j[0][1]).abs() < 1e-7 && (dy.y - j[1][1]).abs() < 1e-7);
    }

    #[test]
    fn look_at_follows_opencv_axes() {
        let pose = Pose::look_at(DVec3::new(0.0, 1.0, 5.0), DVec3::new(0.0, 1.0, 0.0), DVec3::Y).unwrap();
        // Looking along -Z with +Y up: right is +X, down is -Y.
        assert!((pose.rotation.x_axis - DVec3::X).length() < 1e-12);
        assert!((pose.rotation.y_axis - DVec3::NEG_Y).length() < 1e-12);
        let cam = Camera { intrinsics: intr([0.0; 5]), pose };
        let uv = cam.project_world(DVec3::new(0.0, 1.0, 0.0)).unwrap();
        assert!((uv - DVec2::new(321.0, 239.0)).length() < 1e-9);
        // A point up and to the right lands up (smaller v) and right (larger u).
        let uv = cam.project_world(DVec3::new(1.0, 2.0, 0.0)).unwrap();
        assert!(uv.x > 321.0 && uv.y < 239.0);
        assert!(Pose::look_at(DVec3::ZERO, DVec3::Y, DVec3::Y).is_none());
    }

    #[test]
    fn rvec_tvec_matches_look_at() {
        let pose = Pose::look_at(DVec3::new(2.0, 1.5, 6.0), DVec3::new(-1.0, 0.5, 0.0), DVec3::Y).unwrap();
        let cfw = pose.rotation.transpose();
        let q = glam::DQuat::from_mat3(&cfw);
        let (axis, angle) = q.to_axis_angle();
        let tvec = -(cfw * pose.translation);
        let back = Pose::from_rvec_tvec(axis * angle, tvec);
        assert!((back.translation - pose.translation).length() < 1e-9);
        assert!(back.rotation.abs_diff_eq(pose.rotation, 1e-9));
    }
}
