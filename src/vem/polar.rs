//! The polar (θ, φ) map of the upper hemisphere that every VEM frame is resampled into
//! (Havran §3.1 and §5.1: 360 × 90 texels in the paper).
//!
//! # Convention
//! The polar map is the **upper half of an equirect map** in the world frame: a `W × H` polar map
//! is rows `0 … H` of a `W × 2H` equirect map, so `θ` runs from `+Y` (zenith, row 0) down to the
//! horizon (row `H`) in steps of `π/2H`, and `φ = atan2(d.x, −d.z)` exactly as in
//! [`crate::envmap`]: column coordinate `x = (φ/2π + ½)·W`, the centre column looking along `−Z`,
//! columns growing toward `+X`. The functions here call [`crate::geometry::equirect::texel_from_dir`] and
//! [`crate::geometry::equirect::dir_from_texel`] with height `2H`; there is no second mapping.
//!
//! Texel values are linear RGB radiance in the units of the input frames ("scaled radiance").
//! Everything below the horizon is outside the map.

use crate::geometry::equirect::{dir_from_texel, texel_from_dir, texel_solid_angle};
use glam::Vec3;

/// Rec. 709 luminance weights (the same as [`crate::estimate::LUMA`], in `f32`).
pub const LUMA_F32: [f32; 3] = [0.2126, 0.7152, 0.0722];

/// Default polar map width (columns over `φ`), as in the paper.
pub const DEFAULT_WIDTH: u32 = 360;
/// Default polar map height (rows over `θ ∈ [0, π/2]`), as in the paper.
pub const DEFAULT_HEIGHT: u32 = 90;

/// Luminance of a linear RGB triple.
#[inline]
pub fn luminance(c: [f32; 3]) -> f32 {
    LUMA_F32[0] * c[0] + LUMA_F32[1] * c[1] + LUMA_F32[2] * c[2]
}

/// Unit world direction through continuous polar-map coordinates `(x, y)` of a `width × height`
/// map (`y ∈ [0, height]`, `y = height` on the horizon).
#[inline]
pub fn dir_from_polar(x: f32, y: f32, width: u32, height: u32) -> Vec3 {
    dir_from_texel(x, y, width, 2 * height)
}

/// Continuous polar-map coordinates of a world direction, `None` below the horizon.
#[inline]
pub fn polar_from_dir(dir: Vec3, width: u32, height: u32) -> Option<(f32, f32)> {
    if !(dir.y >= 0.0) {
        return None;
    }
    let (x, y) = texel_from_dir(dir, width, 2 * height);
    Some((x, y.min(height as f32)))
}

/// A linear RGB map of the upper hemisphere (see the module docs for the mapping).
#[derive(Clone, Debug, PartialEq)]
pub struct PolarMap {
    /// Columns (over `φ`).
    pub width: u32,
    /// Rows (over `θ` from the zenith to the horizon).
    pub height: u32,
    /// `width × height` RGB radiances, row-major, row 0 at the zenith.
    pub data: Vec<[f32; 3]>,
}

impl PolarMap {
    /// A black map.
    pub fn new(width: u32, height: u32) -> Self {
        Self { width, height, data: vec![[0.0; 3]; (width * height) as usize] }
    }

    /// A map whose texel `(i, j)` is `f` of the unit direction through its centre.
    pub fn from_fn(width: u32, height: u32, mut f: impl FnMut(Vec3) -> [f32; 3]) -> Self {
        let mut m = Self::new(width, height);
        for j in 0..height {
            for i in 0..width {
                m.data[(j * width + i) as usize] = f(m.texel_dir(i, j));
            }
        }
        m
    }

    /// The value of texel `(i, j)`.
    #[inline]
    pub fn get(&self, i: u32, j: u32) -> [f32; 3] {
        self.data[(j * self.width + i) as usize]
    }

    /// Unit direction through the centre of texel `(i, j)`.
    #[inline]
    pub fn texel_dir(&self, i: u32, j: u32) -> Vec3 {
        dir_from_polar(i as f32 + 0.5, j as f32 + 0.5, self.width, self.height)
    }

    /// Solid angle (sr) of a texel of row `j`: `Δφ·(cos θ₀ − cos θ₁)`.
    #[inline]
    pub fn row_solid_angle(&self, j: u32) -> f32 {
        texel_solid_angle(j, self.width, 2 * self.height)
    }

    /// Replaces NaN, infinite and negative texels by black and returns how many there were.
    pub fn sanitize(&mut self) -> usize {
        let mut n = 0;
        for p in &mut self.data {
            if p.iter().any(|c| !(c.is_finite() && *c >= 0.0)) {
                *p = [0.0; 3];
                n += 1;
            }
        }
        n
    }

    /// Radiant power of the map, `Σ L·ΔΩ` per channel (the "luminous power emitted by the frame",
    /// Havran §3.3, here per RGB channel). Its luminance is the irradiance a surface would get
    /// if all the light arrived at normal incidence.
    pub fn total_power(&self) -> [f64; 3] {
        let mut t = [0.0f64; 3];
        for j in 0..self.height {
            let dw = self.row_solid_angle(j) as f64;
            let mut row = [0.0f64; 3];
            for p in &self.data[(j * self.width) as usize..((j + 1) * self.width) as usize] {
                for c in 0..3 {
                    row[c] += p[c] as f64;
                }
            }
            for c in 0..3 {
                t[c] += row[c] * dw;
            }
        }
        t
    }
}

/// Brute-force irradiance of a polar map at any normal: the reference the light decomposition is
/// measured against.
///
/// Each texel is split into `sub × sub` cells of equal solid angle (uniform in `cos θ` and `φ`),
/// and `E(n) = Σ L_texel · ΔΩ_cell · max(n·ω_cell, 0)`. This integrates the piecewise-constant map
/// exactly up to the variation of the cosine inside a cell.
#[derive(Clone, Debug)]
pub struct IrradianceReference {
    dirs: Vec<Vec3>,
    /// Radiance × cell solid angle, per cell.
    weights: Vec<[f32; 3]>,
}

impl IrradianceReference {
    /// Precomputes the cells of `map` (`sub ≥ 1` cells per texel side).
    pub fn new(map: &PolarMap, sub: u32) -> Self {
        let sub = sub.max(1);
        let (w, h) = (map.width, map.height);
        let mut dirs = Vec::new();
        let mut weights = Vec::new();
        let dtheta = std::f32::consts::FRAC_PI_2 / h as f32;
        for j in 0..h {
            let (c0, c1) = ((j as f32 * dtheta).cos(), ((j + 1) as f32 * dtheta).cos());
            let dw = map.row_solid_angle(j) / (sub * sub) as f32;
            for i in 0..w {
                let l = map.get(i, j);
                if l == [0.0; 3] {
                    continue;
                }
                let lw = [l[0] * dw, l[1] * dw, l[2] * dw];
                for b in 0..sub {
                    let ct = c0 + (c1 - c0) * (b as f32 + 0.5) / sub as f32;
                    let y = ct.clamp(-1.0, 1.0).acos() / std::f32::consts::PI * (2 * h) as f32;
                    for a in 0..sub {
                        let x = i as f32 + (a as f32 + 0.5) / sub as f32;
                        dirs.push(dir_from_polar(x, y, w, h));
                        weights.push(lw);
                    }
                }
            }
        }
        Self { dirs, weights }
    }

    /// Irradiance (RGB) on a surface with unit normal `n`.
    pub fn irradiance(&self, n: Vec3) -> [f64; 3] {
        let mut e = [0.0f64; 3];
        for (d, w) in self.dirs.iter().zip(&self.weights) {
            let c = n.dot(*d);
            if c > 0.0 {
                for k in 0..3 {
                    e[k] += (w[k] * c) as f64;
                }
            }
        }
        e
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use std::f32::consts::PI;

    #[test]
    fn polar_map_is_the_upper_half_of_the_equirect_map() {
        let (w, h) = (360, 90);
        // Zenith on row 0, horizon on row h, -Z at the centre column, +X a quarter to the right.
        assert!(polar_from_dir(Vec3::Y, w, h).unwrap().1.abs() < 1e-4);
        let (x, y) = polar_from_dir(Vec3::NEG_Z, w, h).unwrap();
        assert!((x - 180.0).abs() < 1e-3 && (y - 90.0).abs() < 1e-3);
        assert!((polar_from_dir(Vec3::X, w, h).unwrap().0 - 270.0).abs() < 1e-3);
        assert!(polar_from_dir(Vec3::new(0.0, -0.1, 1.0), w, h).is_none());
        // Round trip through texel centres.
        let m = PolarMap::new(w, h);
        for j in (0..h).step_by(7) {
            for i in (0..w).step_by(11) {
                let (x, y) = polar_from_dir(m.texel_dir(i, j), w, h).unwrap();
                assert!((x - i as f32 - 0.5).abs() < 2e-3 && (y - j as f32 - 0.5).abs() < 2e-3);
            }
        }
    }

    #[test]
    fn solid_angles_sum_to_the_hemisphere_and_power_of_a_uniform_sky() {
        let m = PolarMap::from_fn(90, 30, |_| [1.0, 2.0, 0.5]);
        let total: f32 = (0..m.height).map(|j| m.row_solid_angle(j) * m.width as f32).sum();
        assert!((total - 2.0 * PI).abs() < 1e-4);
        let p = m.total_power();
        assert!((p[1] - 4.0 * std::f64::consts::PI).abs() < 1e-4);
    }

    #[test]
    fn reference_irradiance_of_a_uniform_sky_is_pi_up_and_half_pi_sideways() {
        // Closed forms for a uniform upper hemisphere of radiance 1: E = π facing up,
        // π/2 facing the horizon, 0 facing down.
        let m = PolarMap::from_fn(180, 45, |_| [1.0; 3]);
        let r = IrradianceReference::new(&m, 2);
        let pi = std::f64::consts::PI;
        assert!((r.irradiance(Vec3::Y)[0] - pi).abs() < 2e-3 * pi);
        assert!((r.irradiance(Vec3::X)[0] - pi / 2.0).abs() < 2e-3 * pi);
        assert!(r.irradiance(Vec3::NEG_Y)[0].abs() < 1e-9);
    }

    #[test]
    fn sanitize_counts_bad_texels() {
        let mut m = PolarMap::new(4, 2);
        m.data[1] = [f32::NAN, 0.0, 0.0];
        m.data[2] = [0.0, f32::INFINITY, 0.0];
        m.data[3] = [-1.0, 0.0, 0.0];
        m.data[4] = [1.0, 1.0, 1.0];
        assert_eq!(m.sanitize(), 3);
        assert!(m.data.iter().all(|p| p.iter().all(|c| c.is_finite() && *c >= 0.0)));
        assert_eq!(m.data[4], [1.0; 3]);
    }
}
