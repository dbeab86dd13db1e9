//! Measures of the decomposition, shared by the sweeps (`heliar bench vem`) and the tests.
//!
//! - **Irradiance error**: lights against brute-force integration of the polar map
//!   ([`crate::vem::polar::IrradianceReference`]) at a fixed set of random unit normals (uniform on
//!   the sphere, so a third face away from the sky). `rel_rms = √(mean ΔE²) / √(mean E²)` on
//!   luminance; the 95th percentile of `|ΔE| / max E` says how large the worst normals' errors
//!   are relative to the brightest.
//! - **Coherence**: the angle each light (matched by index) moves between the lights of two maps,
//!   with the same input samples: mean, 95th percentile, maximum, and the fraction of lights that
//!   jump by more than [`JUMP_RAD`].

use crate::vem::Light;
use crate::vem::polar::{IrradianceReference, luminance};
use glam::Vec3;
use rand::{Rng, SeedableRng, rngs::SmallRng};

/// A light moving more than this between two frames counts as a jump (2°).
pub const JUMP_RAD: f32 = 2.0 * std::f32::consts::PI / 180.0;

/// `n` unit vectors uniform on the sphere (seeded).
pub fn random_normals(n: usize, seed: u64) -> Vec<Vec3> {
    let mut rng = SmallRng::seed_from_u64(seed);
    (0..n)
        .map(|_| {
            let z: f32 = rng.random_range(-1.0..1.0);
            let phi: f32 = rng.random_range(0.0..std::f32::consts::TAU);
            let r = (1.0 - z * z).max(0.0).sqrt();
            Vec3::new(r * phi.cos(), z, r * phi.sin())
        })
        .collect()
}

/// Reference irradiance (luminance) at each normal.
pub fn reference_irradiance(reference: &IrradianceReference, normals: &[Vec3]) -> Vec<f64> {
    normals.iter().map(|&n| lum64(reference.irradiance(n))).collect()
}

fn lum64(e: [f64; 3]) -> f64 {
    0.2126 * e[0] + 0.7152 * e[1] + 0.0722 * e[2]
}

/// Irradiance error of lights against reference values at the same normals.
#[derive(Clone, Copy, Debug, PartialEq, serde::Serialize)]
pub struct IrradianceError {
    /// `√(mean ΔE²) / √(mean E²)`.
    pub rel_rms: f64,
    /// 95th percentile of `|ΔE| / max E`.
    pub p95_of_max: f64,
}

/// Compares the lights' irradiance with `reference` (from [`reference_irradiance`]).
pub fn irradiance_error(lights: &[Light], normals: &[Vec3], reference: &[f64]) -> IrradianceError {
    let est: Vec<f64> = normals.iter().map(|&n| lum64(crate::vem::irradiance(lights, n))).collect();
    let (mut se, mut s2, mut emax) = (0.0f64, 0.0f64, 0.0f64);
    for (a, b) in est.iter().zip(reference) {
        se += (a - b) * (a - b);
        s2 += b * b;
        emax = emax.max(*b);
    }
    let rel: Vec<f64> = est.iter().zip(reference).map(|(a, b)| (a - b).abs() / emax.max(1e-300)).collect();
    IrradianceError { rel_rms: (se / s2.max(1e-300)).sqrt(), p95_of_max: crate::report::percentile(&rel, 0.95) }
}

/// How far index-matched lights moved between two frames.
#[derive(Clone, Copy, Debug, PartialEq, serde::Serialize)]
pub struct Motion {
    /// Mean angle, radians.
    pub mean_rad: f64,
    /// 95th percentile, radians.
    pub p95_rad: f64,
    /// Largest, radians.
    pub max_rad: f64,
    /// Fraction of lights moving more than [`JUMP_RAD`].
    pub jump_fraction: f64,
}

/// Angular motion between `a` and `b`, matched by light index.
pub fn motion(a: &[Light], b: &[Light]) -> Motion {
    let mut angles: Vec<f64> = Vec::with_capacity(a.len());
    for (i, la) in a.iter().enumerate() {
        let same_slot = b.get(i).filter(|l| l.index == la.index);
        if let Some(lb) = same_slot.or_else(|| b.iter().find(|l| l.index == la.index)) {
            angles.push(la.dir.dot(lb.dir).clamp(-1.0, 1.0).acos() as f64);
        }
    }
    if angles.is_empty() {
        return Motion { mean_rad: 0.0, p95_rad: 0.0, max_rad: 0.0, jump_fraction: 0.0 };
    }
    let n = angles.len() as f64;
    Motion {
        mean_rad: angles.iter().sum::<f64>() / n,
        p95_rad: crate::report::percentile(&angles, 0.95),
        max_rad: angles.iter().cloned().fold(0.0, f64::max),
        jump_fraction: angles.iter().filter(|&&x| x > JUMP_RAD as f64).count() as f64 / n,
    }
}

/// Luminance power of a set of lights.
pub fn lights_power(lights: &[Light]) -> f64 {
    lights.iter().map(|l| luminance(l.rgb) as f64).sum()
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::vem::sampling::pattern::Pattern;
    use crate::vem::polar::PolarMap;
    use crate::vem::sampling::SamplerKind;

    #[test]
    fn uniform_sky_irradiance_converges_for_both_samplers() {
        let map = PolarMap::from_fn(360, 90, |_| [1.0; 3]);
        let reference = IrradianceReference::new(&map, 2);
        let normals = random_normals(200, 1);
        let r = reference_irradiance(&reference, &normals);
        for kind in [SamplerKind::Havran, SamplerKind::Standard] {
            let e64 = irradiance_error(&crate::vem::lights_of_map(&map, kind, Pattern::RelaxedHalton, 64), &normals, &r).rel_rms;
            let e1k = irradiance_error(&crate::vem::lights_of_map(&map, kind, Pattern::RelaxedHalton, 1024), &normals, &r).rel_rms;
            assert!(e1k < 0.02 && e1k < 0.5 * e64, "{kind:?}: {e64} {e1k}");
        }
    }

    #[test]
    fn motion_of_identical_sets_is_zero() {
        let map = PolarMap::from_fn(36, 9, |d| [1.0 + d.x.abs(); 3]);
        let l = crate::vem::lights_of_map(&map, SamplerKind::Havran, Pattern::Halton, 50);
        let m = motion(&l, &l);
        assert!(m.max_rad < 1e-3 && m.jump_fraction == 0.0);
    }
}
