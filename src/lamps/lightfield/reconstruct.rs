//! Irradiance from a light field at any point in front of the lamp, three ways: the exact
//! reconstruction (Eq. 5), the shift-invariant one (Eq. 11), both integrated over the sampling
//! plane, and the textured spot lights of Eq. 14.
//!
//! # How it works
//! A receiver at `x` (depth `z' = −x_z > 0` below the sampling plane) with unit normal `n` gets
//! `E(x) = ∫_S L̃(u, v, s, t) cos θ_S cos θ_x / δ² du dv` (Eq. 12 with `ρ = V = 1`): `δ` is the
//! distance from `p = (u, v, 0)` to `x`, `cos θ_S = z'/δ`, `cos θ_x = n · (p − x)/δ`, and the ray
//! from `p` through `x` meets the measurement plane at `(s, t) = p + (x − p) d/z'` (extended past
//! `x` when `x` is nearer than `d`), at distance `R = δ d/z'` from `p`.
//!
//! - **Exact** (Eq. 5): `L̃ = Σ Φ_mn E'_mn(s, t) (R/R_c)⁴ / h²`, `R_c` the distance from the filter
//!   centre to `(s, t)`.
//! - **Shift-invariant** (Eq. 11): the same without `(R/R_c)⁴`.
//!
//! Both are integrated by Gauss–Legendre on the cells of width `h/2` between the basis
//! breakpoints (the basis is one quadratic per cell), [`Quadrature::points_per_half_cell`] points
//! per cell and axis.
//!
//! - **Textured spot lights** (Eq. 13–14): each filter position is a spot at its centre `c_mn`,
//!   `E(x) ≈ Σ f_mn(x) Ē'_mn(x)` with `f = cos θ_S cos θ_x / δ_c²` from the centre and `Ē'` the
//!   `Φ_mn`-weighted mean of `E'_mn(s(x, u), t(x, v))` over the support (so that `A Ē'` is the
//!   integral of Eq. 13, `A = h²`); [`Footprint::Centre`] takes the single lookup along the central
//!   ray instead, which is what one projective-texture fetch gives. Visibility `V_mn` is 1 here
//!   (the shadow maps come with the GPU pass).
//!
//! Points at or behind the sampling plane (`z' ≤ 0`) get no light.

use super::bellq::gauss_legendre;
use super::LightField;
use glam::{DVec2, DVec3};

/// Gauss points per `h/2` cell and axis for the integrals over the sampling plane.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct Quadrature {
    /// Points per cell and axis (at least 1).
    pub points_per_half_cell: usize,
}

impl Default for Quadrature {
    /// Four points: exact for the basis times a cubic, and enough for the footprints of receivers
    /// down to a fifth of `d` (one cell spans a few texels there).
    fn default() -> Self {
        Self { points_per_half_cell: 4 }
    }
}

/// How a textured spot light averages its image (Eq. 14).
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Footprint {
    /// One lookup along the ray from the filter centre through the point.
    Centre,
    /// The `Φ_mn`-weighted mean over the support, with this many Gauss points per `h/2` cell.
    Support(usize),
}

/// Which reconstruction [`LightField::irradiance`] evaluates.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Method {
    /// Eq. 5 integrated over the sampling plane.
    Exact(Quadrature),
    /// Eq. 11 integrated over the sampling plane.
    ShiftInvariant(Quadrature),
    /// Eq. 14: one textured spot light per filter position.
    Spots(Footprint),
}

/// Gauss nodes `(x, weight)` over `[lo, hi]` split into `cells` equal cells.
fn nodes(lo: f64, hi: f64, cells: usize, rule: &[(f64, f64)]) -> Vec<(f64, f64)> {
    let w = (hi - lo) / cells as f64;
    (0..cells).flat_map(|i| rule.iter().map(move |&(x, wt)| (lo + w * (i as f64 + 0.5 + 0.5 * x), 0.5 * w * wt))).collect()
}

impl LightField {
    /// Irradiance at `x_in_lamp` on a surface of unit normal `normal_in_lamp` (both in the
    /// luminaire frame), per channel.
    pub fn irradiance(&self, method: Method, x_in_lamp: DVec3, normal_in_lamp: DVec3) -> [f64; 3] {
        match method {
            Method::Exact(q) => self.integrate_plane(x_in_lamp, normal_in_lamp, q, true),
            Method::ShiftInvariant(q) => self.integrate_plane(x_in_lamp, normal_in_lamp, q, false),
            Method::Spots(f) => self.spots(x_in_lamp, normal_in_lamp, f),
        }
    }

    /// Where the ray from `p` (on `S`) through `x` meets `M`.
    fn st_through(&self, p: DVec2, x: DVec3) -> DVec2 {
        p + (x.truncate() - p) * (self.distance_m() / -x.z)
    }

    fn integrate_plane(&self, x: DVec3, n: DVec3, q: Quadrature, exact: bool) -> [f64; 3] {
        let z = -x.z;
        if z.is_nan() || z <= 0.0 {
            return [0.0; 3];
        }
        let g = *self.grid();
        let d = self.distance_m();
        let h = g.spacing_m;
        let rule = gauss_legendre(q.points_per_half_cell.max(1));
        let (lo, hi) = g.support_bounds();
        let nu = nodes(lo.x, hi.x, 2 * g.counts[0] + 2, &rule);
        let nv = nodes(lo.y, hi.y, 2 * g.counts[1] + 2, &rule);
        let mut acc = [0.0; 3];
        for &(v, wv) in &nv {
            for &(u, wu) in &nu {
                let p = DVec2::new(u, v);
                let r = x - p.extend(0.0);
                let delta2 = r.length_squared();
                let delta = delta2.sqrt();
                let cos_x = -n.dot(r) / delta;
                if cos_x <= 0.0 {
                    continue;
                }
                let geo = wu * wv * (z / delta) * cos_x / delta2 / (h * h);
                let st = self.st_through(p, x);
                let r2 = delta2 * (d / z) * (d / z);
                let (ru, rv) = g.active(p);
                for jn in rv {
                    for jm in ru.clone() {
                        let phi = g.basis(jm, jn, p);
                        if phi == 0.0 {
                            continue;
                        }
                        let mut w = geo * phi;
                        if exact {
                            let rc2 = (st - g.centre(jm, jn)).length_squared() + d * d;
                            w *= (r2 / rc2) * (r2 / rc2);
                        }
                        let e = self.sample(g.index(jm, jn), st);
                        for c in 0..3 {
                            acc[c] += w * e[c];
                        }
                    }
                }
            }
        }
        acc
    }

    fn spots(&self, x: DVec3, n: DVec3, footprint: Footprint) -> [f64; 3] {
        let z = -x.z;
        if z.is_nan() || z <= 0.0 {
            return [0.0; 3];
        }
        let g = *self.grid();
        let h = g.spacing_m;
        let rule = match footprint {
            Footprint::Centre => Vec::new(),
            Footprint::Support(k) => gauss_legendre(k.max(1)),
        };
        let mut acc = [0.0; 3];
        for jn in 0..g.counts[1] {
            for jm in 0..g.counts[0] {
                let c = g.centre(jm, jn);
                let r = x - c.extend(0.0);
                let delta2 = r.length_squared();
                let delta = delta2.sqrt();
                let cos_x = -n.dot(r) / delta;
                if cos_x <= 0.0 {
                    continue;
                }
                let f = (z / delta) * cos_x / delta2;
                let k = g.index(jm, jn);
                let mean = match footprint {
                    Footprint::Centre => self.sample(k, self.st_through(c, x)),
                    Footprint::Support(_) => {
                        let nu = nodes(c.x - h, c.x + h, 4, &rule);
                        let nv = nodes(c.y - h, c.y + h, 4, &rule);
                        let (mut sum, mut wsum) = ([0.0; 3], 0.0);
                        for &(v, wv) in &nv {
                            for &(u, wu) in &nu {
                                let p = DVec2::new(u, v);
                                let w = wu * wv * g.basis(jm, jn, p);
                                let e = self.sample(k, self.st_through(p, x));
                                wsum += w;
                                for ch in 0..3 {
                                    sum[ch] += w * e[ch];
                                }
                            }
                        }
                        sum.map(|s| s / wsum)
                    }
                };
                for ch in 0..3 {
                    acc[ch] += f * mean[ch];
                }
            }
        }
        acc
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::io::image::LinearImage;
    use crate::lamps::lightfield::FilterGrid;
    use std::path::Path;

    /// A 1×1 grid whose one image is constant: every method is then a closed form we can check.
    fn constant_field(value: f32) -> LightField {
        let grid = FilterGrid { counts: [1, 1], spacing_m: 0.01 };
        LightField::new(grid, 0.5, [4.0, 4.0], vec![LinearImage::from_fn(16, 16, |_, _| [value; 3])], Path::new("<test>")).unwrap()
    }

    #[test]
    fn far_away_all_methods_agree_with_a_point_source() {
        // Constant E' = 1 over a plane far larger than the footprint: the spot of Eq. 14 is a
        // point source of intensity cos θ_S · E' (module docs), so on the axis at depth D,
        // E = 1/D². The integrals of Eq. 5 and 11 see the same source spread over 2h: they agree
        // to O((h/D)²) = 1e-4 at D = 1 m.
        let lf = constant_field(1.0);
        let x = DVec3::new(0.0, 0.0, -1.0);
        let spot = lf.irradiance(Method::Spots(Footprint::Centre), x, DVec3::Z)[0];
        assert!((spot - 1.0).abs() < 1e-12);
        let support = lf.irradiance(Method::Spots(Footprint::Support(3)), x, DVec3::Z)[0];
        assert!((support - 1.0).abs() < 1e-12);
        for m in [Method::Exact(Quadrature::default()), Method::ShiftInvariant(Quadrature::default())] {
            let e = lf.irradiance(m, x, DVec3::Z)[0];
            assert!((e - 1.0).abs() < 1e-3, "{m:?}: {e}");
        }
        // behind the lamp, or facing away: nothing
        assert_eq!(lf.irradiance(Method::Spots(Footprint::Centre), DVec3::new(0.0, 0.0, 0.5), DVec3::Z), [0.0; 3]);
        assert_eq!(lf.irradiance(Method::Exact(Quadrature::default()), x, -DVec3::Z), [0.0; 3]);
    }

    #[test]
    fn on_the_measurement_plane_the_exact_reconstruction_returns_the_measurement() {
        // At x on M with the normal toward the lamp, Eq. 12 with Eq. 5 gives Σ E_mn(x) ∫Φ_mn/h²
        // = E_mn(x): the measured irradiance, E' · cos²θ_c/R_c² (Eq. 8), whatever the angle.
        let lf = constant_field(2.0);
        for &sx in &[0.0, 0.3, 0.8] {
            let x = DVec3::new(sx, 0.1, -0.5);
            let rc2 = sx * sx + 0.01 + 0.25;
            let want = 2.0 * 0.25 / (rc2 * rc2);
            let got = lf.irradiance(Method::Exact(Quadrature::default()), x, DVec3::Z)[0];
            // Gauss with 4 points per cell integrates Φ exactly; what is left is f64 rounding
            assert!((got / want - 1.0).abs() < 1e-10, "{sx}: {got} vs {want}");
        }
    }
}
