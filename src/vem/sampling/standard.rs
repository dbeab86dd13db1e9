//! The standard marginal/conditional inversion (Havran §3.1's baseline; pbrt's
//! `Distribution2D` and infinite-light sampling, the paper's [PH04]).
//!
//! # How it works
//! `u.y` picks a row (`θ`) from the marginal CDF of the ring masses and a point inside it,
//! linear in `θ`; `u.x` picks a column (`φ`) from that row's own conditional CDF, linear in `φ`.
//! The density is piecewise constant over the `(φ, θ)` parameter square, so per steradian it is
//! `p(x, y) / (π² sin θ)`. Neighbouring rows are not interpolated: where two rows' conditionals
//! differ, a sample crossing the row boundary jumps in `φ`. That is the behaviour Havran's
//! transform is measured against.

use super::{PolarDistribution, SampleRecord, invert_cdf};
use crate::vem::polar::{dir_from_polar, polar_from_dir};
use glam::{Vec2, Vec3};
use std::f32::consts::PI;

impl PolarDistribution {
    /// The standard inversion of `u ∈ [0,1]²`; `None` for a black map.
    pub fn sample_standard(&self, u: Vec2) -> Option<SampleRecord> {
        let (j, tau) = self.invert_marginal(u.y as f64)?;
        let cdf = self.cdf(j);
        let (col, frac) = invert_cdf(|k| cdf[k], self.width() as usize, u.x);
        let (x, y) = (col as f32 + frac, j as f32 + tau as f32);
        Some(SampleRecord { dir: dir_from_polar(x, y, self.width(), self.height()), x, y, ring: j, col, blend: None })
    }

    /// Density per steradian with which [`PolarDistribution::sample_standard`] produces `dir`.
    pub fn standard_pdf(&self, dir: Vec3) -> f32 {
        let Some(d) = dir.try_normalize() else { return 0.0 };
        let Some((x, y)) = polar_from_dir(d, self.width(), self.height()) else { return 0.0 };
        if self.is_empty() {
            return 0.0;
        }
        let (w, h) = (self.width(), self.height());
        let (col, j) = ((x as u32).min(w - 1), (y as u32).min(h - 1));
        let cdf = self.cdf(j);
        let p_uv = self.ring_mass(j) as f32 * h as f32 * (cdf[col as usize + 1] - cdf[col as usize]) * w as f32;
        let sin_theta = (1.0 - d.y * d.y).max(0.0).sqrt();
        if sin_theta <= 0.0 { 0.0 } else { p_uv / (PI * PI * sin_theta) }
    }

    /// The inverse of [`PolarDistribution::sample_standard`]; `None` below the horizon or where
    /// the density is zero.
    pub fn invert_standard(&self, dir: Vec3) -> Option<Vec2> {
        let (x, y) = polar_from_dir(dir.try_normalize()?, self.width(), self.height())?;
        if self.is_empty() {
            return None;
        }
        let (w, h) = (self.width(), self.height());
        let (col, j) = ((x as u32).min(w - 1), (y as u32).min(h - 1));
        let cdf = self.cdf(j);
        let (k0, k1) = (cdf[col as usize], cdf[col as usize + 1]);
        if self.ring_mass(j) <= 0.0 || !(k1 > k0) {
            return None;
        }
        let ux = k0 + (x - col as f32).clamp(0.0, 1.0) * (k1 - k0);
        let uy = self.marginal_at(j, (y - j as f32).clamp(0.0, 1.0) as f64) as f32;
        Some(Vec2::new(ux, uy))
    }
}
