//! Brown–Conrady lens distortion: OpenCV's five-coefficient radial–tangential model.
//!
//! # Model
//! On normalised image coordinates `(x, y) = (X/Z, Y/Z)`, with `[k1, k2, p1, p2, k3]`:
//!
//! ```text
//! r² = x² + y²,  k = 1 + k1·r² + k2·r⁴ + k3·r⁶
//! x_d = x·k + 2·p1·x·y + p2·(r² + 2x²)
//! y_d = y·k + p1·(r² + 2y²) + 2·p2·x·y
//! u = fx·x_d + cx,  v = fy·y_d + cy
//! ```
//!
//! Undistortion inverts this by Newton's method with the analytic Jacobian; a point whose inverse
//! does not converge (outside the region where the model is invertible) has no ray.
//!
//! # Validity over the image
//! The radial part `r_d(r) = r·(1 + k1·r² + k2·r⁴ + k3·r⁶)` must be increasing from the centre
//! out to the image corner (`r_d′(r) = 1 + 3k1·r² + 5k2·r⁴ + 7k3·r⁶ > 0` until `r_d` reaches the
//! corner's normalised radius); otherwise two directions land on one pixel, undistortion picks
//! one of them, and every ray past the fold is wrong (`k1 = −50` folds at `r ≈ 0.08`).
//! [`BrownConrady::validate`] checks this.

use glam::DVec2;

/// Largest residual (normalised image units) accepted by undistortion.
const UNDISTORT_TOL: f64 = 1e-10;
/// Newton iterations allowed for undistortion.
const UNDISTORT_MAX_ITERS: usize = 30;
/// Steps of the monotonicity walk from the centre to the image corner.
const MONOTONE_STEPS: usize = 4096;
/// How far past the corner's distorted radius (as a multiple of it) the walk looks for the
/// undistorted radius that reaches the corner.
const MONOTONE_REACH: f64 = 8.0;

/// `[k1, k2, p1, p2, k3]` in OpenCV's order; all zero is an undistorted pinhole.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct BrownConrady(pub [f64; 5]);

impl BrownConrady {
    /// Distorts normalised image coordinates `(x, y) = (X/Z, Y/Z)`; also returns the Jacobian.
    pub fn distort(&self, p: DVec2) -> (DVec2, [[f64; 2]; 2]) {
        let [k1, k2, p1, p2, k3] = self.0;
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

    /// Inverts [`BrownConrady::distort`]; `None` when Newton's method does not converge.
    pub fn undistort(&self, pd: DVec2) -> Option<DVec2> {
        if self.0.iter().all(|&k| k == 0.0) {
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

    /// `r_d(r)`: the radial mapping of an undistorted normalised radius.
    pub fn radial(&self, r: f64) -> f64 {
        let [k1, k2, _, _, k3] = self.0;
        let r2 = r * r;
        r * (1.0 + r2 * (k1 + r2 * (k2 + r2 * k3)))
    }

    /// `dr_d/dr`.
    pub fn radial_slope(&self, r: f64) -> f64 {
        let [k1, k2, _, _, k3] = self.0;
        let r2 = r * r;
        1.0 + r2 * (3.0 * k1 + r2 * (5.0 * k2 + r2 * 7.0 * k3))
    }

    /// Checks the coefficients: finite, and the radial mapping increasing from the centre to
    /// `corner_radius`, the distorted normalised radius of the image corner farthest from the
    /// principal point (module docs); `Err((field, message))`.
    pub fn validate(&self, corner_radius: f64) -> Result<(), (&'static str, String)> {
        if self.0.iter().any(|k| !k.is_finite()) {
            return Err(("distortion", "coefficients must be finite".into()));
        }
        if !(corner_radius.is_finite() && corner_radius > 0.0) {
            return Ok(());
        }
        let step = MONOTONE_REACH * corner_radius / MONOTONE_STEPS as f64;
        for i in 0..=MONOTONE_STEPS {
            let r = i as f64 * step;
            if self.radial(r) >= corner_radius {
                return Ok(());
            }
            let slope = self.radial_slope(r);
            if slope.is_nan() || slope <= 0.0 {
                return Err((
                    "distortion",
                    format!(
                        "the radial mapping folds back at normalised radius {r:.4} (r_d = {:.4}), inside the image (corner at {corner_radius:.4}): \
                         the coefficients are not a lens over this image",
                        self.radial(r)
                    ),
                ));
            }
        }
        Err(("distortion", format!("no ray within {MONOTONE_REACH}× the corner radius reaches the image corner ({corner_radius:.4})")))
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::camera::Intrinsics;

    #[test]
    fn distortion_round_trip_over_the_image() {
        // Mild barrel, strong barrel with tangential terms, and pincushion.
        for d in [
            [-0.1, 0.02, 0.0, 0.0, 0.0],
            [-0.3, 0.12, 0.001, -0.002, -0.02],
            [0.15, -0.05, -0.001, 0.0005, 0.01],
        ] {
            let k = Intrinsics::brown_conrady(640, 480, 500.0, 510.0, 321.0, 239.0, d);
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
    fn folding_coefficients_are_refused_and_real_lenses_pass() {
        let corner = 0.77;
        assert!(BrownConrady([-50.0, 0.0, 0.0, 0.0, 0.0]).validate(corner).is_err());
        assert!(BrownConrady([-0.6, 0.0, 0.0, 0.0, 0.0]).validate(corner).is_err());
        for d in [[0.0; 5], [-0.08, 0.012, 0.0005, -0.0003, 0.0], [-0.3, 0.12, 0.001, -0.002, -0.02], [0.15, -0.05, -0.001, 0.0005, 0.01]] {
            assert!(BrownConrady(d).validate(corner).is_ok(), "{d:?}");
        }
        assert!(BrownConrady([f64::NAN, 0.0, 0.0, 0.0, 0.0]).validate(corner).is_err());
    }

    #[test]
    fn jacobian_matches_finite_differences() {
        let k = BrownConrady([-0.3, 0.12, 0.001, -0.002, -0.02]);
        let p = DVec2::new(0.31, -0.22);
        let (_, j) = k.distort(p);
        let h = 1e-6;
        let dx = (k.distort(p + DVec2::X * h).0 - k.distort(p - DVec2::X * h).0) / (2.0 * h);
        let dy = (k.distort(p + DVec2::Y * h).0 - k.distort(p - DVec2::Y * h).0) / (2.0 * h);
        assert!((dx.x - j[0][0]).abs() < 1e-7 && (dx.y - j[1][0]).abs() < 1e-7);
        assert!((dy.x - j[0][1]).abs() < 1e-7 && (dy.y - j[1][1]).abs() < 1e-7);
    }
}
