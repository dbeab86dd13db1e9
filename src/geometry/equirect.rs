//! The one equirectangular direction ↔ texel mapping (crate docs, "Equirectangular maps"):
//! `φ = atan2(d.x, −d.z)`, `θ = acos(d.y)`, column `x = (φ/2π + ½)·W`, row `y = θ/π·H`, texel
//! centres at `+½`. Every other piece of code calls [`texel_from_dir`] and [`dir_from_texel`].

use glam::Vec3;
use std::f32::consts::PI;

/// Continuous texel coordinates `(x, y)` of a world direction in a `width × height` equirect map.
///
/// `x ∈ [0, width)`, `y ∈ [0, height]`; texel `(i, j)` has its centre at `(i + ½, j + ½)`.
/// `dir` need not be normalised but must be non-zero.
pub fn texel_from_dir(dir: Vec3, width: u32, height: u32) -> (f32, f32) {
    let d = dir.normalize();
    let phi = d.x.atan2(-d.z); // (-π, π], 0 along -Z, +π/2 along +X
    let theta = d.y.clamp(-1.0, 1.0).acos(); // 0 at zenith
    let mut x = (phi / (2.0 * PI) + 0.5) * width as f32;
    if x >= width as f32 {
        x -= width as f32;
    }
    let y = theta / PI * height as f32;
    (x.max(0.0), y)
}

/// Unit world direction through continuous texel coordinates `(x, y)`; the inverse of
/// [`texel_from_dir`].
pub fn dir_from_texel(x: f32, y: f32, width: u32, height: u32) -> Vec3 {
    let phi = (x / width as f32 - 0.5) * 2.0 * PI;
    let theta = y / height as f32 * PI;
    let (st, ct) = theta.sin_cos();
    let (sp, cp) = phi.sin_cos();
    Vec3::new(st * sp, ct, -st * cp)
}

/// Unit direction through the centre of texel `(i, j)`.
pub fn dir_from_texel_centre(i: u32, j: u32, width: u32, height: u32) -> Vec3 {
    dir_from_texel(i as f32 + 0.5, j as f32 + 0.5, width, height)
}

/// Row-major index of the texel containing direction `dir`.
pub fn texel_index(dir: Vec3, width: u32, height: u32) -> usize {
    let (x, y) = texel_from_dir(dir, width, height);
    let (i, j) = ((x as u32).min(width - 1), (y as u32).min(height - 1));
    (j * width + i) as usize
}

/// Solid angle (sr) of texel row `j` in a `width × height` equirect map (all texels of a row are
/// equal): `Δφ · (cos θ₀ − cos θ₁)`.
pub fn texel_solid_angle(j: u32, width: u32, height: u32) -> f32 {
    let t0 = j as f32 / height as f32 * PI;
    let t1 = (j + 1) as f32 / height as f32 * PI;
    2.0 * PI / width as f32 * (t0.cos() - t1.cos())
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn axes_land_where_documented() {
        let (w, h) = (360, 180);
        // -Z is the centre column, on the horizon row.
        let (x, y) = texel_from_dir(Vec3::NEG_Z, w, h);
        assert!((x - 180.0).abs() < 1e-3 && (y - 90.0).abs() < 1e-3);
        // +X is a quarter to the right of the centre.
        let (x, _) = texel_from_dir(Vec3::X, w, h);
        assert!((x - 270.0).abs() < 1e-3);
        // -X a quarter to the left, +Z at the seam.
        let (x, _) = texel_from_dir(Vec3::NEG_X, w, h);
        assert!((x - 90.0).abs() < 1e-3);
        let (x, _) = texel_from_dir(Vec3::new(1e-7, 0.0, 1.0), w, h);
        assert!(x < 1e-2 || x > 359.99, "x = {x}");
        // Zenith is row 0, nadir the last row.
        assert!(texel_from_dir(Vec3::Y, w, h).1.abs() < 1e-4);
        assert!((texel_from_dir(Vec3::NEG_Y, w, h).1 - 180.0).abs() < 1e-3);
    }

    #[test]
    fn round_trip_over_the_sphere() {
        let (w, h) = (512, 256);
        for j in 0..h {
            for i in (0..w).step_by(7) {
                let d = dir_from_texel_centre(i, j, w, h);
                assert!((d.length() - 1.0).abs() < 1e-5);
                let (x, y) = texel_from_dir(d, w, h);
                assert!((x - (i as f32 + 0.5)).abs() < 2e-3, "{i} {j} -> {x}");
                assert!((y - (j as f32 + 0.5)).abs() < 2e-3, "{i} {j} -> {y}");
            }
        }
    }

    #[test]
    fn solid_angles_sum_to_the_sphere() {
        let (w, h) = (64, 32);
        let total: f32 = (0..h).map(|j| texel_solid_angle(j, w, h) * w as f32).sum();
        assert!((total - 4.0 * PI).abs() < 1e-4, "{total}");
    }
}
