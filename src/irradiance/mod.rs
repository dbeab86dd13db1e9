//! Irradiance volume: a grid of probes holding order-2 spherical-harmonic irradiance
//! (Greger et al. 1998, "The Irradiance Volume"; Jensen §3.3).
//!
//! [`ProbeGrid`] is the runtime representation the compositor reads: irradiance SH per probe
//! (already convolved with the clamped cosine, so `E(n) = Σ E_lm·Y_lm(n)`), a validity flag per
//! probe, and trilinear interpolation that leaves invalid probes out.

pub mod probe_transfer;
pub mod sh;
pub mod sources;

use glam::{UVec3, Vec3};
use sh::ShRgb;

/// A regular grid of irradiance probes.
#[derive(Clone, Debug, PartialEq)]
pub struct ProbeGrid {
    /// World position of probe `(0, 0, 0)`.
    pub min: Vec3,
    /// Distance between neighbouring probes, metres (the same on every axis).
    pub spacing: f32,
    /// Probes along x, y, z (each ≥ 1).
    pub dims: UVec3,
    /// Irradiance SH of each probe, index `x + dims.x·(y + dims.y·z)`.
    pub coeffs: Vec<ShRgb>,
    /// Probes inside real geometry are invalid and left out of the interpolation.
    pub valid: Vec<bool>,
}

impl ProbeGrid {
    /// A grid over `[min, max]` with probes `spacing` apart (at least 2 per axis when the extent
    /// is positive), every probe holding `coeffs`.
    pub fn filled(min: Vec3, max: Vec3, spacing: f32, coeffs: ShRgb) -> Self {
        let ext = (max - min).max(Vec3::ZERO);
        let dims = UVec3::new(
            (ext.x / spacing).ceil() as u32 + 1,
            (ext.y / spacing).ceil() as u32 + 1,
            (ext.z / spacing).ceil() as u32 + 1,
        );
        let n = (dims.x * dims.y * dims.z) as usize;
        Self { min, spacing, dims, coeffs: vec![coeffs; n], valid: vec![true; n] }
    }

    /// Index of probe `(x, y, z)`.
    #[inline]
    pub fn index(&self, x: u32, y: u32, z: u32) -> usize {
        (x + self.dims.x * (y + self.dims.y * z)) as usize
    }

    /// World position of probe `(x, y, z)`.
    pub fn position(&self, x: u32, y: u32, z: u32) -> Vec3 {
        self.min + Vec3::new(x as f32, y as f32, z as f32) * self.spacing
    }

    /// Irradiance SH at `p`: trilinear interpolation of the valid probes of the surrounding cell
    /// (weights renormalised); points outside the grid use the nearest cell. `None` when the cell
    /// has no valid probe.
    pub fn coeffs_at(&self, p: Vec3) -> Option<ShRgb> {
        let g = ((p - self.min) / self.spacing).max(Vec3::ZERO);
        let maxc = (self.dims.as_vec3() - Vec3::ONE).max(Vec3::ZERO);
        let g = g.min(maxc);
        let base = g.floor().min((maxc - Vec3::ONE).max(Vec3::ZERO));
        let f = g - base;
        let b = base.as_uvec3();
        let mut acc = [[0.0f32; 3]; sh::N];
        let mut wsum = 0.0;
        for corner in 0..8u32 {
            let o = UVec3::new(corner & 1, (corner >> 1) & 1, (corner >> 2) & 1);
            let q = (b + o).min(self.dims - UVec3::ONE);
            let i = self.index(q.x, q.y, q.z);
            if !self.valid[i] {
                continue;
            }
            let w = (if o.x == 1 { f.x } else { 1.0 - f.x }) * (if o.y == 1 { f.y } else { 1.0 - f.y }) * (if o.z == 1 { f.z } else { 1.0 - f.z });
            if w <= 0.0 {
                continue;
            }
            wsum += w;
            for k in 0..sh::N {
                for c in 0..3 {
                    acc[k][c] += w * self.coeffs[i][k][c];
                }
            }
        }
        if wsum <= 0.0 {
            return None;
        }
        Some(std::array::from_fn(|k| acc[k].map(|v| v / wsum)))
    }

    /// Irradiance at `p` on a surface of unit normal `n`, clamped to be non-negative (SH ringing).
    pub fn irradiance(&self, p: Vec3, n: Vec3) -> Option<Vec3> {
        self.coeffs_at(p).map(|c| sh::eval(&c, n).max(Vec3::ZERO))
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn uniform_grid_returns_the_uniform_sky() {
        let pa = Vec3::new(0.5, 0.6, 0.7);
        let g = ProbeGrid::filled(Vec3::ZERO, Vec3::new(4.0, 2.0, 4.0), 1.0, sh::uniform_upper_sky(pa));
        assert_eq!(g.dims, UVec3::new(5, 3, 5));
        for p in [Vec3::new(0.3, 0.2, 3.9), Vec3::new(-5.0, 9.0, 2.0)] {
            assert!((g.irradiance(p, Vec3::Y).unwrap() - pa).abs().max_element() < 1e-5);
            assert!((g.irradiance(p, Vec3::X).unwrap() - pa * 0.5).abs().max_element() < 1e-5);
        }
    }

    #[test]
    fn interpolation_is_trilinear_and_skips_invalid_probes() {
        let mut g = ProbeGrid::filled(Vec3::ZERO, Vec3::ONE, 1.0, [[0.0; 3]; sh::N]);
        for z in 0..2 {
            for y in 0..2 {
                for x in 0..2 {
                    let i = g.index(x, y, z);
                    g.coeffs[i][0] = [x as f32; 3];
                }
            }
        }
        let c = g.coeffs_at(Vec3::new(0.25, 0.5, 0.5)).unwrap();
        assert!((c[0][0] - 0.25).abs() < 1e-6);
        // Invalidate every x = 1 probe: only x = 0 values remain.
        for z in 0..2 {
            for y in 0..2 {
                let i = g.index(1, y, z);
                g.valid[i] = false;
            }
        }
        assert!(g.coeffs_at(Vec3::new(0.75, 0.5, 0.5)).unwrap()[0][0].abs() < 1e-6);
        g.valid.iter_mut().for_each(|v| *v = false);
        assert!(g.coeffs_at(Vec3::splat(0.5)).is_none());
    }
}
