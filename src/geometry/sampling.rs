//! Hemisphere sampling for the light-transport integrals (pbrt-v4 `util/sampling.h`, §A.5).

use glam::{Vec2, Vec3};
use std::f32::consts::{FRAC_PI_2, FRAC_PI_4};

/// Shirley–Chiu concentric map from `[0,1)²` to the unit disc (pbrt-v4 `SampleUniformDiskConcentric`).
pub fn sample_disk_concentric(u: Vec2) -> Vec2 {
    let o = 2.0 * u - Vec2::ONE;
    if o.x == 0.0 && o.y == 0.0 {
        return Vec2::ZERO;
    }
    let (r, theta) = if o.x.abs() > o.y.abs() {
        (o.x, FRAC_PI_4 * (o.y / o.x))
    } else {
        (o.y, FRAC_PI_2 - FRAC_PI_4 * (o.x / o.y))
    };
    r * Vec2::new(theta.cos(), theta.sin())
}

/// Cosine-weighted direction on the hemisphere around +Z (Malley's method); pdf `cos θ / π`.
pub fn sample_cosine_hemisphere(u: Vec2) -> Vec3 {
    let d = sample_disk_concentric(u);
    let z = (1.0 - d.length_squared()).max(0.0).sqrt();
    Vec3::new(d.x, d.y, z)
}

/// An orthonormal basis `(t, b)` completing unit `n` (Duff et al. 2017, "Building an Orthonormal
/// Basis, Revisited").
pub fn basis_from_normal(n: Vec3) -> (Vec3, Vec3) {
    let sign = 1.0f32.copysign(n.z);
    let a = -1.0 / (sign + n.z);
    let b = n.x * n.y * a;
    (Vec3::new(1.0 + sign * n.x * n.x * a, sign * b, -sign * n.x), Vec3::new(b, sign + n.y * n.y * a, -n.y))
}

/// Cosine-weighted direction around unit normal `n`.
pub fn sample_cosine_around(n: Vec3, u: Vec2) -> Vec3 {
    let l = sample_cosine_hemisphere(u);
    let (t, b) = basis_from_normal(n);
    (t * l.x + b * l.y + n * l.z).normalize()
}

/// Sample `i` of `count` stratified points in `[0,1)²`: the first `m²` (`m = ⌊√count⌋`) are
/// jittered in the cells of an `m × m` grid (row-major), the rest uniform. Each point on its own
/// is uniform over its cell or the square, so the mean of any prefix that completes the grid, or
/// of all `count`, estimates an integral without bias (a grid of `⌈√count⌉²` cells filled only
/// `count` times would leave its last cells empty). Draws two numbers from `rng` per call.
pub fn sample_stratified_2d(i: u32, count: u32, rng: &mut impl rand::Rng) -> Vec2 {
    let m = ((count.max(1) as f64).sqrt().floor() as u32).max(1);
    let j = Vec2::new(rng.random::<f32>(), rng.random::<f32>());
    let u = if i < m * m { (Vec2::new((i % m) as f32, (i / m) as f32) + j) / m as f32 } else { j };
    u.min(Vec2::splat(0.999_999))
}

/// `n` directions spread evenly over the unit sphere (spherical Fibonacci lattice; Marques et al.
/// 2013, "Spherical Fibonacci Point Sets for Illumination Integrals"). Each stands for `4π/n` sr.
pub fn sphere_fibonacci(n: usize) -> Vec<Vec3> {
    let golden = (1.0 + 5f64.sqrt()) / 2.0;
    (0..n)
        .map(|i| {
            let z = 1.0 - (2.0 * i as f64 + 1.0) / n as f64;
            let phi = 2.0 * std::f64::consts::PI * (i as f64 / golden).fract();
            let r = (1.0 - z * z).max(0.0).sqrt();
            // y is up in the world frame: put the lattice's pole on +Y.
            Vec3::new((r * phi.cos()) as f32, z as f32, (r * phi.sin()) as f32)
        })
        .collect()
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn stratified_points_are_unbiased_for_any_count() {
        // The mean of f(u) = u.y (integral ½) over `count` points: with ⌈√count⌉² cells filled
        // row by row the top rows would stay empty and the mean fall short (0.45 for 128).
        use rand::SeedableRng;
        for count in [1u32, 2, 7, 64, 128, 200, 512] {
            let mut rng = rand::rngs::SmallRng::seed_from_u64(count as u64);
            let runs = 2000;
            let mut mean = 0.0f64;
            for _ in 0..runs {
                mean += (0..count).map(|i| sample_stratified_2d(i, count, &mut rng).y as f64).sum::<f64>() / count as f64;
            }
            mean /= runs as f64;
            // Standard error of the mean of means: below 0.29/√(runs·count) ≤ 0.0065.
            assert!((mean - 0.5).abs() < 0.01, "{count}: {mean}");
        }
        // A square count is a full jittered grid: one point per cell.
        let mut rng = rand::rngs::SmallRng::seed_from_u64(1);
        let mut cells: Vec<(u32, u32)> = (0..16).map(|i| sample_stratified_2d(i, 16, &mut rng)).map(|u| ((u.x * 4.0) as u32, (u.y * 4.0) as u32)).collect();
        cells.sort_unstable();
        cells.dedup();
        assert_eq!(cells.len(), 16);
    }

    #[test]
    fn fibonacci_directions_are_uniform() {
        let d = sphere_fibonacci(4096);
        assert!(d.iter().all(|v| (v.length() - 1.0).abs() < 1e-5));
        // Mean of a uniform sphere is 0; mean of y² is 1/3; upper-hemisphere fraction ½.
        let mean = d.iter().copied().sum::<Vec3>() / d.len() as f32;
        assert!(mean.length() < 1e-3, "{mean}");
        let y2 = d.iter().map(|v| v.y * v.y).sum::<f32>() / d.len() as f32;
        assert!((y2 - 1.0 / 3.0).abs() < 1e-3);
        assert_eq!(d.iter().filter(|v| v.y > 0.0).count(), 2048);
    }

    #[test]
    fn basis_is_orthonormal() {
        for n in [Vec3::Z, Vec3::NEG_Z, Vec3::X, Vec3::new(0.3, -0.5, 0.8).normalize(), Vec3::new(1e-8, 0.0, -1.0).normalize()] {
            let (t, b) = basis_from_normal(n);
            assert!((t.length() - 1.0).abs() < 1e-5 && (b.length() - 1.0).abs() < 1e-5);
            assert!(t.dot(b).abs() < 1e-5 && t.dot(n).abs() < 1e-5 && b.dot(n).abs() < 1e-5);
        }
    }

    #[test]
    fn cosine_sampling_integrates_cos_to_pi() {
        // With pdf = cos θ/π, the estimate of ∫cos² θ dω = 2π/3 is the mean of π·cos θ. A 256² grid
        // of stratum midpoints has a quadrature error of order 1/256.
        let n = 256;
        let mut sum = 0.0f64;
        for i in 0..n {
            for j in 0..n {
                let u = Vec2::new((i as f32 + 0.5) / n as f32, (j as f32 + 0.5) / n as f32);
                let d = sample_cosine_hemisphere(u);
                assert!(d.z >= 0.0 && (d.length() - 1.0).abs() < 1e-5);
                sum += (d.z as f64 * d.z as f64) * std::f64::consts::PI / d.z.max(1e-9) as f64;
            }
        }
        let est = sum / (n * n) as f64;
        assert!((est - 2.0 * std::f64::consts::PI / 3.0).abs() < 2e-3, "{est}");
    }
}
