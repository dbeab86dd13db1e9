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

use glam::DVec2;

/// Largest residual (normalised image units) accepted by undistortion.
const UNDISTORT_TOL: f64 = 1e-10;
/// Newton iterations allowed for undistortion.
const UNDISTORT_MAX_ITERS: usize = 30;

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

    /// Checks the coefficients; `Err((field, message))`.
    pub fn validate(&self) -> Result<(), (&'static str, String)> {
        if self.0.iter().any(|k| !k.is_finite()) {
            return Err(("distortion", "coefficients must be finite".into()));
        }
        Ok(())
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
