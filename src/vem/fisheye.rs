//! The fisheye lens: Kannala–Brandt generic model (Kannala & Brandt 2004/2006, the paper's
//! [KB04], cited in Havran §5.1) and the lens orientation in the world frame.
//!
//! # Model
//! In the camera frame (OpenCV: `+X` right, `+Y` down, `+Z` along the optical axis) a direction
//! `(x, y, z)` at angle `θ = atan2(√(x²+y²), z)` from the axis and azimuth `ψ = atan2(y, x)`
//! lands at
//!
//! ```text
//! θ_d = θ · (1 + k1·θ² + k2·θ⁴ + k3·θ⁶ + k4·θ⁸)
//! u = fx · θ_d · cos ψ + cx,   v = fy · θ_d · sin ψ + cy
//! ```
//!
//! the same polynomial as OpenCV's `cv::fisheye` (which writes it with `θ = atan(r)` and so stops
//! at 90°); here `θ` comes from the 3D direction, so lenses wider than 180° work. `k = 0` is the
//! equidistant fisheye. Pixels follow the crate's convention (centre of the top-left pixel at
//! `(0, 0)`). Directions beyond `max_theta` are outside the calibrated field of view.
//! [`KannalaBrandt::unproject`] inverts `θ_d(θ)` by Newton's method; [`KannalaBrandt::validate`]
//! checks that `θ_d` is strictly increasing up to `max_theta`, so the inverse is unique.

use glam::{DMat3, DVec2, DVec3};

/// Newton tolerance on `θ_d`, radians.
const NEWTON_TOL: f64 = 1e-12;
/// Newton iterations allowed.
const NEWTON_MAX_ITERS: usize = 30;

/// Kannala–Brandt intrinsics.
#[derive(Clone, Debug, PartialEq)]
pub struct KannalaBrandt {
    /// Image width, pixels.
    pub width: u32,
    /// Image height, pixels.
    pub height: u32,
    /// Focal length (pixels per radian of `θ_d`), horizontal.
    pub fx: f64,
    /// Focal length, vertical.
    pub fy: f64,
    /// Principal point, pixels.
    pub cx: f64,
    /// Principal point, pixels.
    pub cy: f64,
    /// `k1 … k4`.
    pub k: [f64; 4],
    /// Largest angle from the optical axis the calibration covers, radians.
    pub max_theta: f64,
}

impl KannalaBrandt {
    /// `θ_d(θ)` and its derivative.
    #[inline]
    pub fn distort_theta(&self, theta: f64) -> (f64, f64) {
        let [k1, k2, k3, k4] = self.k;
        let t2 = theta * theta;
        let poly = 1.0 + t2 * (k1 + t2 * (k2 + t2 * (k3 + t2 * k4)));
        let dpoly = 1.0 + t2 * (3.0 * k1 + t2 * (5.0 * k2 + t2 * (7.0 * k3 + t2 * 9.0 * k4)));
        (theta * poly, dpoly)
    }

    /// The `θ` with `θ_d(θ) = theta_d` in `[0, max_theta]`, or `None`.
    pub fn undistort_theta(&self, theta_d: f64) -> Option<f64> {
        if !(theta_d >= 0.0) {
            return None;
        }
        let mut t = theta_d.min(self.max_theta);
        for _ in 0..NEWTON_MAX_ITERS {
            let (f, df) = self.distort_theta(t);
            let r = f - theta_d;
            if r.abs() < NEWTON_TOL {
                break;
            }
            if !(df > 0.0) {
                return None;
            }
            t = (t - r / df).clamp(0.0, self.max_theta * 1.05);
        }
        let (f, _) = self.distort_theta(t);
        ((f - theta_d).abs() < 1e-9 && t <= self.max_theta + 1e-9).then_some(t)
    }

    /// Pixel coordinates of a camera-frame direction; `None` beyond `max_theta`.
    pub fn project(&self, d: DVec3) -> Option<DVec2> {
        let rxy = (d.x * d.x + d.y * d.y).sqrt();
        let theta = rxy.atan2(d.z);
        if !(theta <= self.max_theta) {
            return None;
        }
        if rxy < 1e-15 {
            return Some(DVec2::new(self.cx, self.cy));
        }
        let (td, _) = self.distort_theta(theta);
        Some(DVec2::new(self.fx * td * d.x / rxy + self.cx, self.fy * td * d.y / rxy + self.cy))
    }

    /// Unit camera-frame direction through pixel coordinates `uv`; `None` outside the calibrated
    /// field of view.
    pub fn unproject(&self, uv: DVec2) -> Option<DVec3> {
        let m = DVec2::new((uv.x - self.cx) / self.fx, (uv.y - self.cy) / self.fy);
        let td = m.length();
        if td < 1e-15 {
            return Some(DVec3::Z);
        }
        let t = self.undistort_theta(td)?;
        let (s, c) = t.sin_cos();
        Some(DVec3::new(s * m.x / td, s * m.y / td, c))
    }

    /// Checks the intrinsics; `Err((field, message))`.
    pub fn validate(&self) -> Result<(), (&'static str, String)> {
        if self.width == 0 || self.height == 0 {
            return Err(("width/height", "must be positive".into()));
        }
        for (f, v) in [("fx", self.fx), ("fy", self.fy)] {
            if !(v.is_finite() && v > 0.0) {
                return Err((f, format!("{v} must be a positive number of pixels per radian")));
            }
        }
        for (f, v) in [("cx", self.cx), ("cy", self.cy)] {
            if !v.is_finite() {
                return Err((f, "must be finite".into()));
            }
        }
        if self.k.iter().any(|k| !k.is_finite()) {
            return Err(("k", "coefficients must be finite".into()));
        }
        if !(self.max_theta > 0.0 && self.max_theta <= std::f64::consts::PI) {
            return Err(("max_theta_deg", "must be in (0, 180]".into()));
        }
        const STEPS: usize = 2000;
        let mut last = 0.0;
        for i in 1..=STEPS {
            let t = self.max_theta * i as f64 / STEPS as f64;
            let (td, d) = self.distort_theta(t);
            if !(d > 0.0 && td > last) {
                return Err((
                    "k",
                    format!("θ_d(θ) stops increasing at θ = {:.1}° (below max_theta_deg): the model cannot be inverted there", t.to_degrees()),
                ));
            }
            last = td;
        }
        Ok(())
    }
}

/// A calibrated fisheye camera: intrinsics and orientation.
#[derive(Clone, Debug, PartialEq)]
pub struct FisheyeCamera {
    /// The lens model.
    pub lens: KannalaBrandt,
    /// Rotation `world_from_camera` (columns: the camera's right, down and optical axis in world
    /// coordinates). The camera's position does not matter: the lights are distant.
    pub world_from_camera: DMat3,
}

impl FisheyeCamera {
    /// Pixel coordinates of a world direction; `None` outside the field of view.
    pub fn pixel_from_world_dir(&self, d: DVec3) -> Option<DVec2> {
        self.lens.project(self.world_from_camera.transpose() * d)
    }

    /// Unit world direction through pixel coordinates `uv`.
    pub fn world_dir_from_pixel(&self, uv: DVec2) -> Option<DVec3> {
        Some(self.world_from_camera * self.lens.unproject(uv)?)
    }

    /// An equidistant 180° fisheye of `size × size` pixels looking straight up, with north
    /// (`−Z` by default) at the top of the image: the lens of the generated sequences.
    pub fn equidistant_up(size: u32, fov_deg: f64) -> Self {
        let max_theta = (0.5 * fov_deg).to_radians();
        let c = (size as f64 - 1.0) / 2.0;
        let f = size as f64 / 2.0 / max_theta;
        let lens = KannalaBrandt { width: size, height: size, fx: f, fy: f, cx: c, cy: c, k: [0.0; 4], max_theta };
        // Optical axis +Y, image up (−v, camera −Y) toward −Z: camera +Y (down) is +Z,
        // camera +X (right) = forward × up = Y × (−Z) = −X.
        let world_from_camera = DMat3::from_cols(DVec3::NEG_X, DVec3::Z, DVec3::Y);
        Self { lens, world_from_camera }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn lenses() -> Vec<KannalaBrandt> {
        let base = KannalaBrandt { width: 640, height: 600, fx: 190.0, fy: 188.0, cx: 321.3, cy: 298.7, k: [0.0; 4], max_theta: 100f64.to_radians() };
        vec![
            base.clone(),
            KannalaBrandt { k: [0.02, -0.004, 0.0008, -0.0001], ..base.clone() },
            KannalaBrandt { k: [-0.05, 0.01, -0.002, 0.0001], max_theta: 95f64.to_radians(), ..base },
        ]
    }

    #[test]
    fn projection_round_trips() {
        for lens in lenses() {
            lens.validate().unwrap();
            // Directions → pixels → directions.
            for a in 0..60 {
                for b in 0..36 {
                    let theta = lens.max_theta * a as f64 / 60.0;
                    let psi = b as f64 * 10f64.to_radians();
                    let d = DVec3::new(theta.sin() * psi.cos(), theta.sin() * psi.sin(), theta.cos());
                    let uv = lens.project(d).unwrap();
                    let back = lens.unproject(uv).unwrap();
                    assert!((back - d).length() < 1e-9, "{d} -> {uv} -> {back}");
                }
            }
            // Pixels → directions → pixels, inside the field of view.
            for v in (0..600).step_by(23) {
                for u in (0..640).step_by(29) {
                    let uv = DVec2::new(u as f64, v as f64);
                    if let Some(d) = lens.unproject(uv) {
                        assert!((lens.project(d).unwrap() - uv).length() < 1e-7);
                    }
                }
            }
            assert!(lens.project(DVec3::new(0.0, 0.0, -1.0)).is_none());
        }
    }

    #[test]
    fn equidistant_closed_form_and_orientation() {
        let cam = FisheyeCamera::equidistant_up(512, 180.0);
        let k = &cam.lens;
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
    }

    #[test]
    fn validation_rejects_a_fold_back() {
        let mut lens = lenses()[0].clone();
        lens.k = [-0.5, 0.0, 0.0, 0.0];
        let (field, msg) = lens.validate().unwrap_err();
        assert_eq!(field, "k");
        assert!(msg.contains("stops increasing"), "{msg}");
    }
}
