//! Havran's continuous inverse transform from the unit square to the hemisphere (Havran §3.1,
//! after Havran, Dmitriev & Seidel 2003, "Goniometric diagram mapping for hemisphere").
//!
//! # How it works
//! Four stages, each continuous and bijective where the map has light:
//! 1. **Concentric map** (Shirley & Chiu 1997) from the square to the unit disc, in polar form:
//!    `s_c = r²` and `v = ψ_c / 2π`, both uniform on `[0, 1)` for uniform input. It has no seam
//!    inside the square except the ray `ψ_c = 0`, where `v` wraps from 1 to 0 (see 3).
//! 2. **Radial marginal.** The disc is divided into rings, one per polar-map row: row `j`
//!    (`θ ∈ [θ_j, θ_j+1]`) is the annulus `s ∈ [s_j, s_j+1]` with `s = r² = 1 − cos θ`. Inside a
//!    texel the density is uniform in `(s, ψ)`, so the marginal CDF over `s` is piecewise linear
//!    with knots at `s_j`; `s = M⁻¹(s_c)`.
//! 3. **Angular conditional.** `ψ = G⁻¹(v; s)`, with `G(·; s)` the conditional CDF over the
//!    disc angle (the map's `φ` column, `ψ = 2π·x/W`). `G(0) = 0` and `G(2π) = 1` in every
//!    ring, so `v → 1` and `v → 0` give the same direction: continuous across `φ = 0`.
//!    Continuity across rings comes from interpolating linearly between the CDFs of
//!    neighbouring rings. Since all rings share the column knots, the blend of two CDFs is again
//!    piecewise linear with the same knots, and is inverted exactly.
//! 4. **Disc → hemisphere**, area-preserving: `cos θ = 1 − s`, `φ = ψ` (then
//!    [`crate::vem::polar::dir_from_polar`]).
//!
//! # Where the rings are blended ([`RingBlend`])
//! Interpolating between ring *centres*, as the paper describes ([`RingBlend::Centres`]), moves
//! part of a ring's samples to the azimuths of its neighbour's distribution: up to a quarter of
//! the ring's mass times the total-variation distance between the two conditionals. For a sky
//! that is smooth across rings that is nothing; for a ring holding the sun it spreads about a
//! quarter of the sun's power along its almucantar. The default ([`RingBlend::Lighter`])
//! interpolates over a band, on each side of the boundary between rings `j` and `j+1`, of
//! [`BLEND_FRACTION`] times the *lighter* ring's mass (in the `s_c` coordinate). For neighbours of
//! equal mass this is exactly the paper's centre-to-centre interpolation; next to the sun's ring
//! it confines the blending to a sliver of the sun's samples, so the misplaced mass is bounded by
//! the lighter ring's. The map stays continuous (steeper next to heavy rings). The sweep
//! `heliar bench vem` measures both.

use super::{PolarDistribution, SampleRecord, invert_cdf};
use crate::vem::polar::{dir_from_polar, polar_from_dir};
use glam::{Vec2, Vec3};
use std::f32::consts::{FRAC_PI_2, FRAC_PI_4, PI, TAU};

/// The band over which neighbouring rings' conditionals are blended, as a fraction of the lighter
/// ring's mass on each side of their boundary ([`RingBlend::Lighter`]). ½ reproduces the paper's
/// centre-to-centre interpolation between rings of equal mass; it must not exceed ½ (bands would
/// overlap).
pub const BLEND_FRACTION: f64 = 0.5;

/// How the conditional CDFs of neighbouring rings are interpolated (see the module docs).
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum RingBlend {
    /// Over [`BLEND_FRACTION`] of the lighter ring's mass on each side of a boundary (default).
    Lighter,
    /// Linearly in `s` between ring centres (the paper's description).
    Centres,
}

/// Polar form `(s_c = r², v = ψ/2π)` of the Shirley–Chiu concentric map of `u ∈ [0,1]²`
/// (the same map as [`crate::geometry::sampling::sample_disk_concentric`]).
#[inline]
pub fn disc_polar_from_square(u: Vec2) -> (f32, f32) {
    let o = 2.0 * u - Vec2::ONE;
    if o.x == 0.0 && o.y == 0.0 {
        return (0.0, 0.0);
    }
    let (r, a) = if o.x.abs() > o.y.abs() {
        (o.x, FRAC_PI_4 * (o.y / o.x))
    } else {
        (o.y, FRAC_PI_2 - FRAC_PI_4 * (o.x / o.y))
    };
    let (r, a) = if r < 0.0 { (-r, a + PI) } else { (r, a) };
    let a = if a < 0.0 { a + TAU } else { a };
    let v = (a / TAU).min(1.0 - f32::EPSILON);
    ((r * r).min(1.0), v)
}

/// The inverse of [`disc_polar_from_square`]: the square point of the disc point with `r² = s_c`
/// and angle `2π·v`.
pub fn square_from_disc_polar(s_c: f32, v: f32) -> Vec2 {
    let r = s_c.max(0.0).sqrt();
    if r == 0.0 {
        return Vec2::splat(0.5);
    }
    // Angle in (-π, π].
    let mut a = v * TAU;
    if a > PI {
        a -= TAU;
    }
    let o = if (-FRAC_PI_4..FRAC_PI_4).contains(&a) {
        Vec2::new(r, r * a / FRAC_PI_4)
    } else if (FRAC_PI_4..3.0 * FRAC_PI_4).contains(&a) {
        Vec2::new(r * (FRAC_PI_2 - a) / FRAC_PI_4, r)
    } else if a >= 3.0 * FRAC_PI_4 || a < -3.0 * FRAC_PI_4 {
        // Left sector: o.x = -r and the forward angle is a - π (or a + π), in [-π/4, π/4].
        let fwd = if a > 0.0 { a - PI } else { a + PI };
        Vec2::new(-r, -r * fwd / FRAC_PI_4)
    } else {
        // Bottom sector: o.y = -r and the forward angle is a + π, in [π/4, 3π/4).
        let fwd = a + PI;
        Vec2::new(-r * (FRAC_PI_2 - fwd) / FRAC_PI_4, -r)
    };
    ((o + Vec2::ONE) * 0.5).clamp(Vec2::ZERO, Vec2::ONE)
}

impl PolarDistribution {
    /// The neighbouring ring blended in at fraction `τ` into ring `j`, and its weight.
    #[inline]
    fn ring_blend(&self, j: u32, tau: f64, blend: RingBlend) -> Option<(u32, f32)> {
        let h = self.height();
        let mass = |k: u32| self.ring_mass(k);
        match blend {
            RingBlend::Lighter => {
                let m = mass(j);
                let mu = tau * m;
                if j + 1 < h && mass(j + 1) > 0.0 {
                    let b = BLEND_FRACTION * m.min(mass(j + 1));
                    if m - mu < b {
                        return Some((j + 1, ((b - (m - mu)) / (2.0 * b)) as f32));
                    }
                }
                if j > 0 && mass(j - 1) > 0.0 {
                    let b = BLEND_FRACTION * m.min(mass(j - 1));
                    if mu < b {
                        return Some((j - 1, ((b - mu) / (2.0 * b)) as f32));
                    }
                }
                None
            }
            RingBlend::Centres => {
                let (s0, ds) = self.ring_s(j);
                let s = s0 + tau * ds;
                let centre = |k: u32| {
                    let (a, d) = self.ring_s(k);
                    a + 0.5 * d
                };
                if tau >= 0.5 && j + 1 < h {
                    Some((j + 1, ((s - centre(j)) / (centre(j + 1) - centre(j))) as f32))
                } else if tau < 0.5 && j > 0 {
                    Some((j - 1, ((centre(j) - s) / (centre(j) - centre(j - 1))) as f32))
                } else {
                    None
                }
            }
        }
    }

    /// Knot `k` of the conditional CDF of ring `j` blended with `blend`.
    #[inline]
    fn blended_knot(&self, j: u32, blend: Option<(u32, f32)>, k: usize) -> f32 {
        match blend {
            None => self.cdf(j)[k],
            Some((n, t)) => (1.0 - t) * self.cdf(j)[k] + t * self.cdf(n)[k],
        }
    }

    /// The blended conditional CDF as a function of the knot (slices fetched once).
    #[inline]
    fn blended_cdf(&self, j: u32, blend: Option<(u32, f32)>) -> impl Fn(usize) -> f32 + '_ {
        let a = self.cdf(j);
        let (b, t) = match blend {
            Some((n, t)) => (self.cdf(n), t),
            None => (a, 0.0),
        };
        move |k| a[k] + t * (b[k] - a[k])
    }

    /// Havran's transform of `u ∈ [0,1]²`; `None` for a black map.
    pub fn sample_havran(&self, u: Vec2, blend: RingBlend) -> Option<SampleRecord> {
        let (s_c, v) = disc_polar_from_square(u);
        let (j, tau) = self.invert_marginal(s_c as f64)?;
        let b = self.ring_blend(j, tau, blend);
        let (col, frac) = invert_cdf(self.blended_cdf(j, b), self.width() as usize, v);
        let (s0, ds) = self.ring_s(j);
        let cos_theta = (1.0 - (s0 + tau * ds)).clamp(0.0, 1.0) as f32;
        let x = col as f32 + frac;
        let y = (cos_theta.acos() / FRAC_PI_2 * self.height() as f32).clamp(j as f32, (j + 1) as f32);
        Some(SampleRecord { dir: dir_from_polar(x, y, self.width(), self.height()), x, y, ring: j, col, blend: b })
    }

    /// Ring, fraction into it and column coordinate of a direction, `None` below the horizon.
    fn locate(&self, dir: Vec3) -> Option<(u32, f64, f32)> {
        let d = dir.try_normalize()?;
        let (x, y) = polar_from_dir(d, self.width(), self.height())?;
        let j = (y as u32).min(self.height() - 1);
        let (s0, ds) = self.ring_s(j);
        let tau = (((1.0 - d.y as f64) - s0) / ds).clamp(0.0, 1.0);
        Some((j, tau, x.min(self.width() as f32 - 1e-4)))
    }

    /// Density per steradian with which [`PolarDistribution::sample_havran`] produces `dir`.
    pub fn havran_pdf(&self, dir: Vec3, blend: RingBlend) -> f32 {
        let Some((j, tau, x)) = self.locate(dir) else { return 0.0 };
        if self.is_empty() || self.ring_mass(j) <= 0.0 {
            return 0.0;
        }
        let b = self.ring_blend(j, tau, blend);
        let col = x as usize;
        let g = (self.blended_knot(j, b, col + 1) - self.blended_knot(j, b, col)) * self.width() as f32 / TAU;
        let (_, ds) = self.ring_s(j);
        (self.ring_mass(j) / ds) as f32 * g
    }

    /// The inverse of [`PolarDistribution::sample_havran`]; `None` below the horizon or where the
    /// density is zero.
    pub fn invert_havran(&self, dir: Vec3, blend: RingBlend) -> Option<Vec2> {
        let (j, tau, x) = self.locate(dir)?;
        if self.is_empty() || self.ring_mass(j) <= 0.0 {
            return None;
        }
        let b = self.ring_blend(j, tau, blend);
        let col = x as usize;
        let (k0, k1) = (self.blended_knot(j, b, col), self.blended_knot(j, b, col + 1));
        if !(k1 > k0) {
            return None;
        }
        let v = k0 + (x - col as f32) * (k1 - k0);
        let s_c = self.marginal_at(j, tau) as f32;
        Some(square_from_disc_polar(s_c, if v >= 1.0 { 0.0 } else { v }))
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::geometry::sampling::sample_disk_concentric;
    use crate::vem::polar::PolarMap;
    use crate::vem::sampling::SamplerKind;
    use rand::{Rng, SeedableRng, rngs::SmallRng};

    /// A positive, structured sky: gradient, a bright blob straddling φ = 0 and a sun.
    fn sky() -> PolarMap {
        let sun = Vec3::new(0.5, 0.6, 0.3).normalize();
        let blob = Vec3::new(0.05, 0.4, 0.9).normalize();
        PolarMap::from_fn(360, 90, |d| {
            let g = 0.2 + 0.8 * d.y;
            let b = 3.0 * (-(1.0 - d.dot(blob)) * 40.0).exp();
            let s = if d.dot(sun) > 0.9995 { 2000.0 } else { 0.0 };
            [g + b + s, 0.8 * g + b + s, 1.2 * g + s]
        })
    }

    #[test]
    fn concentric_polar_form_matches_the_shared_map_and_inverts() {
        let mut rng = SmallRng::seed_from_u64(3);
        for _ in 0..2000 {
            let u = Vec2::new(rng.random(), rng.random());
            let (s_c, v) = disc_polar_from_square(u);
            let p = sample_disk_concentric(u);
            assert!((p.length_squared() - s_c).abs() < 1e-5);
            if s_c > 1e-6 {
                let a = (p.y.atan2(p.x) + TAU) % TAU;
                let da = (a - v * TAU).abs();
                assert!(da < 1e-4 || (da - TAU).abs() < 1e-4, "{u} {a} {v}");
            }
            let back = square_from_disc_polar(s_c, v);
            assert!((back - u).length() < 2e-4, "{u} -> {back}");
        }
    }

    #[test]
    fn inverse_round_trips() {
        let map = sky();
        let dist = PolarDistribution::new(&map);
        let mut rng = SmallRng::seed_from_u64(7);
        for kind in [SamplerKind::Havran, SamplerKind::HavranCentres, SamplerKind::Standard] {
            let mut worst = 0.0f32;
            for _ in 0..5000 {
                let u = Vec2::new(rng.random_range(0.001..0.999), rng.random_range(0.001..0.999));
                let rec = dist.sample(kind, u).unwrap();
                assert!((rec.dir.length() - 1.0).abs() < 1e-5 && rec.dir.y >= -1e-6);
                let back = dist.invert(kind, rec.dir).unwrap();
                worst = worst.max((back - u).length());
            }
            // f32 directions: a 1e-7 rad error in a ring of width 1e-4 in s is 1e-3 in u.
            assert!(worst < 2e-3, "{kind:?}: worst round-trip error {worst}");
        }
    }

    /// Largest and mean angle between the images of random pairs `step` apart, and the largest
    /// across the seam line (`u.y = ½`, `u.x > ½`, the ray `ψ_c = 0` that maps to `φ = 0`).
    fn motion(dist: &PolarDistribution, kind: SamplerKind, step: f32) -> (f32, f32) {
        let ang = |a: Vec3, b: Vec3| a.dot(b).clamp(-1.0, 1.0).acos();
        let mut rng = SmallRng::seed_from_u64(11);
        let mut worst = 0.0f32;
        for _ in 0..20000 {
            let u = Vec2::new(rng.random_range(0.01..0.99), rng.random_range(0.01..0.99));
            let dv = Vec2::new(rng.random_range(-step..step), rng.random_range(-step..step));
            worst = worst.max(ang(dist.sample(kind, u).unwrap().dir, dist.sample(kind, u + dv).unwrap().dir));
        }
        let mut seam = 0.0f32;
        for k in 1..50 {
            let x = 0.5 + 0.5 * k as f32 / 50.0;
            let (a, b) = (dist.sample(kind, Vec2::new(x, 0.5 + step)).unwrap(), dist.sample(kind, Vec2::new(x, 0.5 - step)).unwrap());
            if kind != SamplerKind::Standard && k >= 10 {
                assert!(a.x < 3.0 || a.x > 357.0, "the seam line maps to φ = 0: {a:?}");
            }
            seam = seam.max(ang(a.dir, b.dir));
        }
        (worst, seam)
    }

    #[test]
    fn continuous_across_phi_zero_and_everywhere_else() {
        // A positive map with a bright blob straddling φ = 0.
        let blob = Vec3::new(0.05, 0.4, 0.9).normalize();
        let smooth = PolarMap::from_fn(360, 90, |d| {
            let g = 0.2 + 0.8 * d.y;
            let b = 3.0 * (-(1.0 - d.dot(blob)) * 40.0).exp();
            [g + b, 0.8 * g + b, 1.2 * g]
        });
        let dist = PolarDistribution::new(&smooth);
        for kind in [SamplerKind::Havran, SamplerKind::HavranCentres] {
            // Continuous: the largest move shrinks with the step (measured: 0.029, 0.0029, 0.0006
            // rad for steps of 1e-3, 1e-4, 1e-5; the last is f32 resolution).
            let (w3, s3) = motion(&dist, kind, 1e-3);
            let (w4, s4) = motion(&dist, kind, 1e-4);
            assert!(w3 < 0.05 && w4 < 0.2 * w3, "{kind:?}: {w3} {w4}");
            assert!(s3 < 0.01 && s4 < 0.2 * s3, "{kind:?} seam: {s3} {s4}");
        }
        // The standard inversion jumps at row boundaries: its largest move does not shrink
        // (measured: 0.070, 0.053, 0.045 rad).
        let (w3, _) = motion(&dist, SamplerKind::Standard, 1e-3);
        let (w5, _) = motion(&dist, SamplerKind::Standard, 1e-5);
        assert!(w5 > 0.5 * w3 && w5 > 0.02, "standard: {w3} {w5}");
        // With a sun 1e4 times brighter than the sky the map is steep next to it, but still
        // continuous (measured for `Havran`: 0.98 and 0.16 rad for steps of 1e-4 and 1e-5).
        let dist = PolarDistribution::new(&sky());
        for kind in [SamplerKind::Havran, SamplerKind::HavranCentres] {
            let ((w4, s4), (w5, s5)) = (motion(&dist, kind, 1e-4), motion(&dist, kind, 1e-5));
            assert!(w5 < 0.3 * w4 && s5 < 0.3 * s4, "{kind:?}: {w4} {w5}, seam {s4} {s5}");
        }
    }

    #[test]
    fn pdf_integrates_to_one_and_matches_a_histogram() {
        let map = sky();
        let dist = PolarDistribution::new(&map);
        for kind in [SamplerKind::Havran, SamplerKind::HavranCentres, SamplerKind::Standard] {
            // ∫ pdf dΩ over a fine equal-area grid.
            let (nx, ny) = (720usize, 360usize);
            let mut integral = 0.0f64;
            for b in 0..ny {
                let ct = 1.0 - (b as f64 + 0.5) / ny as f64;
                let st = (1.0 - ct * ct).sqrt();
                for a in 0..nx {
                    let phi = (a as f64 + 0.5) / nx as f64 * std::f64::consts::TAU;
                    let dir = Vec3::new((st * phi.sin()) as f32, ct as f32, (-st * phi.cos()) as f32);
                    integral += dist.pdf(kind, dir) as f64 * std::f64::consts::TAU / (nx * ny) as f64;
                }
            }
            assert!((integral - 1.0).abs() < 0.02, "{kind:?}: ∫pdf = {integral}");
            // Histogram of 20000 samples over 12 × 6 cells against ∫pdf over each cell.
            let mut rng = SmallRng::seed_from_u64(5);
            let n = 20000;
            let mut hist = [[0.0f64; 12]; 6];
            for _ in 0..n {
                let r = dist.sample(kind, Vec2::new(rng.random(), rng.random())).unwrap();
                hist[((r.y / 15.0) as usize).min(5)][((r.x / 30.0) as usize).min(11)] += 1.0 / n as f64;
            }
            let mut want = [[0.0f64; 12]; 6];
            for j in 0..90u32 {
                for i in 0..360u32 {
                    let d = map.texel_dir(i, j);
                    want[(j / 15) as usize][(i / 30) as usize] += dist.pdf(kind, d) as f64 * map.row_solid_angle(j) as f64;
                }
            }
            for r in 0..6 {
                for c in 0..12 {
                    let (h, w) = (hist[r][c], want[r][c]);
                    assert!((h - w).abs() < 0.01 + 0.1 * w, "{kind:?} cell {r},{c}: {h} vs {w}");
                }
            }
        }
    }

    #[test]
    fn delta_map_puts_every_sample_on_the_sun_texel() {
        let mut map = PolarMap::new(360, 90);
        map.data[(40 * 360 + 123) as usize] = [5e5, 4e5, 3e5];
        let dist = PolarDistribution::new(&map);
        for kind in [SamplerKind::Havran, SamplerKind::HavranCentres, SamplerKind::Standard] {
            for k in 0..500 {
                let r = dist.sample(kind, crate::vem::sampling::pattern::sample(crate::vem::sampling::pattern::Pattern::Halton, k)).unwrap();
                assert_eq!((r.col, r.ring), (123, 40), "{kind:?}");
                let c = dist.light_rgb(&map, &r);
                assert!((crate::vem::polar::luminance(c) - 1.0).abs() < 1e-5 && (c[0] / c[2] - 5.0 / 3.0).abs() < 1e-4);
            }
        }
    }
}
