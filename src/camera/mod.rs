//! The one camera model of heliar: intrinsics with a lens, a rigid pose, and the views an image's
//! pixel rays can come from.
//!
//! Every camera in the crate is a [`Camera`]: the scene's footage camera (pinhole with
//! Brown–Conrady distortion, `calib/camera.toml`), the VEM capture lens (Kannala–Brandt fisheye,
//! `calib/fisheye.toml`) and the calibration tool's results. The file formats convert into it
//! (`scene::CameraFile`, `vem::capture::lens_file`); the GPU canvas (`gpu::canvas`) is derived
//! from it.
//!
//! # Conventions (crate docs)
//! OpenCV camera frame (`+X` right, `+Y` down, `+Z` forward) and pixel coordinates (the centre of
//! the top-left pixel at `(0, 0)`). [`Intrinsics`] holds the image size, focal lengths and
//! principal point in pixels, and a [`Lens`]:
//!
//! | lens | model | module |
//! |---|---|---|
//! | [`Lens::BrownConrady`] | OpenCV's five-coefficient radial–tangential model on normalised coordinates; all zero is a pinhole | [`brown_conrady`] |
//! | [`Lens::KannalaBrandt`] | the generic fisheye `θ_d = θ(1 + k1θ² + … + k4θ⁸)`, valid past 90° | [`kannala_brandt`] |
//!
//! A new lens is one more variant here with its `project` / `ray` pair in its own file.

pub mod brown_conrady;
pub mod kannala_brandt;

pub use brown_conrady::BrownConrady;
pub use kannala_brandt::KannalaBrandt;

use glam::{DMat3, DVec2, DVec3};

/// The lens of a camera: how directions in the camera frame map to normalised image points.
#[derive(Clone, Debug, PartialEq)]
pub enum Lens {
    /// Pinhole with Brown–Conrady distortion (`[k1, k2, p1, p2, k3]`, OpenCV order).
    BrownConrady(BrownConrady),
    /// Kannala–Brandt fisheye.
    KannalaBrandt(KannalaBrandt),
}

/// Image size, focal lengths and principal point (pixels), and the lens.
#[derive(Clone, Debug, PartialEq)]
pub struct Intrinsics {
    /// Image width in pixels.
    pub width: u32,
    /// Image height in pixels.
    pub height: u32,
    /// Focal length in pixels, horizontal (pixels per radian of `θ_d` for a fisheye).
    pub fx: f64,
    /// Focal length in pixels, vertical.
    pub fy: f64,
    /// Principal point, pixels.
    pub cx: f64,
    /// Principal point, pixels.
    pub cy: f64,
    /// The lens model.
    pub lens: Lens,
}

impl Intrinsics {
    /// A pinhole with Brown–Conrady distortion `[k1, k2, p1, p2, k3]` (all zero: no distortion).
    pub fn brown_conrady(width: u32, height: u32, fx: f64, fy: f64, cx: f64, cy: f64, distortion: [f64; 5]) -> Self {
        Self { width, height, fx, fy, cx, cy, lens: Lens::BrownConrady(BrownConrady(distortion)) }
    }

    /// An undistorted pinhole.
    pub fn pinhole(width: u32, height: u32, fx: f64, fy: f64, cx: f64, cy: f64) -> Self {
        Self::brown_conrady(width, height, fx, fy, cx, cy, [0.0; 5])
    }

    /// A Kannala–Brandt fisheye with `k1 … k4` calibrated up to `max_theta` radians from the
    /// optical axis.
    pub fn kannala_brandt(width: u32, height: u32, fx: f64, fy: f64, cx: f64, cy: f64, k: [f64; 4], max_theta: f64) -> Self {
        Self { width, height, fx, fy, cx, cy, lens: Lens::KannalaBrandt(KannalaBrandt { k, max_theta }) }
    }

    /// The Brown–Conrady coefficients, or `None` for another lens.
    pub fn distortion(&self) -> Option<&[f64; 5]> {
        match &self.lens {
            Lens::BrownConrady(b) => Some(&b.0),
            Lens::KannalaBrandt(_) => None,
        }
    }

    /// Normalised coordinates `((u − cx)/fx, (v − cy)/fy)` of pixel coordinates `uv`, before the
    /// lens is undone.
    pub fn distorted_from_pixel(&self, uv: DVec2) -> DVec2 {
        DVec2::new((uv.x - self.cx) / self.fx, (uv.y - self.cy) / self.fy)
    }

    /// Pinhole coordinates `(X/Z, Y/Z)` of the ray through pixel coordinates `uv`; `None` where
    /// the lens has no inverse (or, for a fisheye, at or behind 90°).
    pub fn pinhole_from_pixel(&self, uv: DVec2) -> Option<DVec2> {
        let m = self.distorted_from_pixel(uv);
        match &self.lens {
            Lens::BrownConrady(b) => b.undistort(m),
            Lens::KannalaBrandt(kb) => {
                let d = kb.unproject(m)?;
                (d.z > 1e-9).then(|| DVec2::new(d.x / d.z, d.y / d.z))
            }
        }
    }

    /// Pixel coordinates of a point (or direction, for a fisheye) in the camera frame; `None`
    /// behind a pinhole camera or beyond a fisheye's calibrated field of view.
    pub fn project(&self, p_cam: DVec3) -> Option<DVec2> {
        match &self.lens {
            Lens::BrownConrady(b) => {
                if !(p_cam.z > 1e-9) {
                    return None;
                }
                let (m, _) = b.distort(DVec2::new(p_cam.x / p_cam.z, p_cam.y / p_cam.z));
                Some(DVec2::new(self.fx * m.x + self.cx, self.fy * m.y + self.cy))
            }
            Lens::KannalaBrandt(kb) => kb.pixel_from_dir(self, p_cam),
        }
    }

    /// Unit ray direction in the camera frame through pixel coordinates `uv`.
    pub fn ray(&self, uv: DVec2) -> Option<DVec3> {
        let m = self.distorted_from_pixel(uv);
        match &self.lens {
            Lens::BrownConrady(b) => {
                let p = b.undistort(m)?;
                Some(DVec3::new(p.x, p.y, 1.0).normalize())
            }
            Lens::KannalaBrandt(kb) => kb.unproject(m),
        }
    }

    /// The largest normalised (distorted) radius of the image's corners, from the principal
    /// point: how far out the lens must be valid.
    pub fn corner_radius(&self) -> f64 {
        let (w, h) = (self.width as f64 - 0.5, self.height as f64 - 0.5);
        [(-0.5, -0.5), (w, -0.5), (-0.5, h), (w, h)]
            .into_iter()
            .map(|(u, v)| self.distorted_from_pixel(DVec2::new(u, v)).length())
            .fold(0.0, f64::max)
    }

    /// Checks sizes, focal lengths, principal point and the lens; `Err((field, message))` with the
    /// field named as in the camera files.
    pub fn validate(&self) -> Result<(), (&'static str, String)> {
        if self.width == 0 || self.height == 0 {
            return Err(("width/height", "must be positive".into()));
        }
        let unit = match self.lens {
            Lens::BrownConrady(_) => "pixels",
            Lens::KannalaBrandt(_) => "pixels per radian",
        };
        for (f, v) in [("fx", self.fx), ("fy", self.fy)] {
            if !(v.is_finite() && v > 0.0) {
                return Err((f, format!("focal length {v} must be a positive number of {unit}")));
            }
        }
        for (f, v) in [("cx", self.cx), ("cy", self.cy)] {
            if !v.is_finite() {
                return Err((f, "must be finite".into()));
            }
        }
        match &self.lens {
            Lens::BrownConrady(b) => b.validate(self.corner_radius()),
            Lens::KannalaBrandt(kb) => kb.validate(),
        }
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

    /// A rotation only (a camera whose position does not matter: distant light).
    pub fn rotation_only(world_from_camera: DMat3) -> Self {
        Self { rotation: world_from_camera, translation: DVec3::ZERO }
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

/// A calibrated camera: intrinsics with their lens, and the pose.
#[derive(Clone, Debug, PartialEq)]
pub struct Camera {
    /// Intrinsics and lens.
    pub intrinsics: Intrinsics,
    /// `world_from_camera`.
    pub pose: Pose,
}

impl Camera {
    /// The same camera for frames of `width × height`: focal lengths and principal point scaled
    /// by `width / current width` (the same horizontal field of view), then cropped or padded
    /// vertically about the centre. Lens coefficients are unchanged (they act on normalised
    /// coordinates).
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

    /// Pixel coordinates of a world direction (a camera at infinity: only the rotation counts);
    /// `None` outside the field of view.
    pub fn pixel_from_world_dir(&self, d: DVec3) -> Option<DVec2> {
        self.intrinsics.project(self.pose.rotation.transpose() * d)
    }

    /// Unit world direction through pixel coordinates `uv`.
    pub fn world_dir_from_pixel(&self, uv: DVec2) -> Option<DVec3> {
        Some(self.pose.rotation * self.intrinsics.ray(uv)?)
    }

    /// An equidistant fisheye of `size × size` pixels and `fov_deg` field of view looking
    /// straight up, with north (`−Z` by default) at the top of the image: the lens of the
    /// generated VEM sequences.
    pub fn equidistant_up(size: u32, fov_deg: f64) -> Self {
        let max_theta = (0.5 * fov_deg).to_radians();
        let c = (size as f64 - 1.0) / 2.0;
        let f = size as f64 / 2.0 / max_theta;
        // Optical axis +Y, image up (−v, camera −Y) toward −Z: camera +Y (down) is +Z,
        // camera +X (right) = forward × up = Y × (−Z) = −X.
        let world_from_camera = DMat3::from_cols(DVec3::NEG_X, DVec3::Z, DVec3::Y);
        Self { intrinsics: Intrinsics::kannala_brandt(size, size, f, f, c, c, [0.0; 4], max_theta), pose: Pose::rotation_only(world_from_camera) }
    }
}

/// Where an image's pixel rays come from: a calibrated camera, or an equirect map seen from a
/// point (an environment map at its capture centre).
#[derive(Clone, Copy, Debug)]
pub enum View<'a> {
    /// A calibrated camera.
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
                Some((*centre, crate::geometry::equirect::dir_from_texel_centre(x, y, *width, *height).as_dvec3()))
            }
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn intr(distortion: [f64; 5]) -> Intrinsics {
        Intrinsics::brown_conrady(640, 480, 500.0, 510.0, 321.0, 239.0, distortion)
    }

    #[test]
    fn resized_camera_sees_the_same_points_at_scaled_pixels() {
        let cam = Camera { intrinsics: intr([-0.1, 0.02, 0.0, 0.0, 0.0]), pose: Pose { rotation: DMat3::IDENTITY, translation: DVec3::ZERO } };
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

    #[test]
    fn equidistant_closed_form_and_orientation() {
        let cam = Camera::equidistant_up(512, 180.0);
        let k = &cam.intrinsics;
        // Zenith at the centre, the horizon on the image circle.
        let c = cam.pixel_from_world_dir(DVec3::Y).unwrap();
        assert!((c - DVec2::new(k.cx, k.cy)).length() < 1e-9);
        let n = cam.pixel_from_world_dir(DVec3::NEG_Z).unwrap();
        assert!((n.x - k.cx).abs() < 1e-9 && (k.cy - n.y - 256.0).abs() < 1e-9, "north at the top: {n}");
        let e = cam.pixel_from_world_dir(DVec3::X).unwrap();
        // Looking up with north at the top, east is on the left.
        assert!(e.x < k.cx - 255.0, "{e}");
        // 45° elevation: half way to the rim (equidistant).
        let d = DVec3::new(0.0, 1.0, -1.0).normalize();
        assert!((k.cy - cam.pixel_from_world_dir(d).unwrap().y - 128.0).abs() < 1e-9);
        // Directions round-trip through pixels.
        let back = cam.world_dir_from_pixel(cam.pixel_from_world_dir(d).unwrap()).unwrap();
        assert!((back - d).length() < 1e-9);
    }

    #[test]
    fn pinhole_coordinates_agree_between_lenses() {
        // An equidistant fisheye and the pinhole point of its rays: the same ray in both forms.
        let fe = Intrinsics::kannala_brandt(400, 400, 120.0, 120.0, 199.5, 199.5, [0.01, 0.0, 0.0, 0.0], 95f64.to_radians());
        for uv in [DVec2::new(150.0, 220.0), DVec2::new(199.5, 199.5), DVec2::new(330.0, 60.0)] {
            let d = fe.ray(uv).unwrap();
            let p = fe.pinhole_from_pixel(uv).unwrap();
            assert!((DVec3::new(p.x, p.y, 1.0).normalize() - d).length() < 1e-12);
        }
        let bc = intr([-0.2, 0.05, 0.001, 0.0, 0.0]);
        let uv = DVec2::new(100.0, 400.0);
        let p = bc.pinhole_from_pixel(uv).unwrap();
        assert!((DVec3::new(p.x, p.y, 1.0).normalize() - bc.ray(uv).unwrap()).length() < 1e-12);
    }
}
