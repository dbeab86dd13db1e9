//! Median-cut light extraction (Debevec, *A median cut algorithm for light probe sampling*,
//! SIGGRAPH 2005 poster; cited as the comparison baseline in Havran §2): a built-in baseline,
//! not a per-sample inverse transform.
//!
//! # How it works
//! - **Energy.** Texel `(i, j)` carries `e_ij = Y_ij · ΔΩ_j` (luminance × its exact solid angle
//!   `Δφ·(cos θ_j − cos θ_j+1)`: the cos-latitude weighting of the equirect map). A summed-area
//!   table of `e` gives the energy of any rectangle of texels in O(1).
//! - **Cuts.** Starting from the whole map, every region is split along its longer *angular*
//!   dimension (width `Δx·2π/W·sin θ_centre`, height `Δy·π/2H`) at the energy median: the cut
//!   whose two halves' energies differ least. Whole levels are split while the count can double
//!   within `N` (Debevec's `2^n` regions); the regions still missing are made by splitting the
//!   brightest regions of the last level. Regions of one texel are not split, so a map of fewer
//!   than `N` texels (or with too few lit ones) gives fewer regions.
//! - **Lights.** One light per region, at the region's energy centroid (the normalised
//!   energy-weighted mean of its texel directions; the region's centre if it is black), carrying
//!   the region's power `Σ L·ΔΩ` per channel, so every light's `rgb` is its irradiance on a
//!   surface facing it and the lights' sum is the map's power exactly. Lights are indexed by
//!   region (in split order): an index does not follow a feature from frame to frame.

use crate::vem::Light;
use crate::vem::polar::{PolarMap, dir_from_polar, luminance};
use crate::vem::sampling::is_valid;
use glam::DVec3;

/// A rectangle of texels `[x0, x1) × [y0, y1)` and its luminance energy.
#[derive(Clone, Copy, Debug)]
struct Region {
    x0: u32,
    y0: u32,
    x1: u32,
    y1: u32,
    energy: f64,
}

/// Summed-area table of the luminance energy `Y·ΔΩ` of a polar map (invalid texels count 0).
#[derive(Clone, Debug)]
pub struct EnergyTable {
    width: u32,
    height: u32,
    /// `(width + 1) × (height + 1)` prefix sums, row-major.
    sat: Vec<f64>,
}

impl EnergyTable {
    /// Builds the table of `map`.
    pub fn new(map: &PolarMap) -> Self {
        let (w, h) = (map.width as usize, map.height as usize);
        let mut sat = vec![0.0f64; (w + 1) * (h + 1)];
        for j in 0..h {
            let dw = map.row_solid_angle(j as u32) as f64;
            let mut row = 0.0f64;
            for i in 0..w {
                let p = map.data[j * w + i];
                row += if is_valid(&p) { luminance(p) as f64 * dw } else { 0.0 };
                sat[(j + 1) * (w + 1) + i + 1] = sat[j * (w + 1) + i + 1] + row;
            }
        }
        Self { width: map.width, height: map.height, sat }
    }

    /// Energy of texels `[x0, x1) × [y0, y1)`.
    #[inline]
    pub fn energy(&self, x0: u32, y0: u32, x1: u32, y1: u32) -> f64 {
        let s = |x: u32, y: u32| self.sat[y as usize * (self.width as usize + 1) + x as usize];
        s(x1, y1) - s(x0, y1) - s(x1, y0) + s(x0, y0)
    }

    /// The whole map's energy.
    pub fn total(&self) -> f64 {
        self.energy(0, 0, self.width, self.height)
    }

    fn region(&self, x0: u32, y0: u32, x1: u32, y1: u32) -> Region {
        Region { x0, y0, x1, y1, energy: self.energy(x0, y0, x1, y1) }
    }

    /// Splits `r` at the energy median of its longer angular dimension (the other one if the
    /// longer is one texel); `None` for a single texel.
    fn split(&self, r: &Region) -> Option<(Region, Region)> {
        let (nx, ny) = (r.x1 - r.x0, r.y1 - r.y0);
        let theta = (r.y0 + r.y1) as f64 * 0.5 * std::f64::consts::FRAC_PI_2 / self.height as f64;
        let wide = nx as f64 * std::f64::consts::TAU / self.width as f64 * theta.sin();
        let tall = ny as f64 * std::f64::consts::FRAC_PI_2 / self.height as f64;
        let along_x = (wide >= tall && nx > 1) || ny <= 1;
        if nx <= 1 && ny <= 1 {
            return None;
        }
        let (lo, hi) = if along_x { (r.x0, r.x1) } else { (r.y0, r.y1) };
        let below = |c: u32| if along_x { self.energy(r.x0, r.y0, c, r.y1) } else { self.energy(r.x0, r.y0, r.x1, c) };
        // Smallest cut c in (lo, hi) with 2·E(lo..c) ≥ E, then the better of c and c − 1.
        let (mut a, mut b) = (lo + 1, hi - 1);
        while a < b {
            let m = a + (b - a) / 2;
            if 2.0 * below(m) >= r.energy { b = m } else { a = m + 1 }
        }
        let imbalance = |c: u32| (2.0 * below(c) - r.energy).abs();
        let c = if a > lo + 1 && imbalance(a - 1) <= imbalance(a) { a - 1 } else { a };
        Some(if along_x {
            (self.region(r.x0, r.y0, c, r.y1), self.region(c, r.y0, r.x1, r.y1))
        } else {
            (self.region(r.x0, r.y0, r.x1, c), self.region(r.x0, c, r.x1, r.y1))
        })
    }
}

/// The median-cut regions of `table`, at most `n`.
fn regions(table: &EnergyTable, n: usize) -> Vec<Region> {
    let mut level = vec![table.region(0, 0, table.width, table.height)];
    if n == 0 {
        return Vec::new();
    }
    // Whole levels while the count can double.
    while level.len() * 2 <= n {
        let mut next = Vec::with_capacity(level.len() * 2);
        let mut split_any = false;
        for r in &level {
            match table.split(r) {
                Some((a, b)) => {
                    next.extend([a, b]);
                    split_any = true;
                }
                None => next.push(*r),
            }
        }
        level = next;
        if !split_any {
            return level;
        }
    }
    // The rest: split the brightest splittable regions of the last level, once each.
    let mut order: Vec<usize> = (0..level.len()).collect();
    order.sort_by(|&a, &b| level[b].energy.total_cmp(&level[a].energy).then(a.cmp(&b)));
    let mut out = level.clone();
    let mut missing = n - level.len();
    for k in order {
        if missing == 0 {
            break;
        }
        if let Some((a, b)) = table.split(&level[k]) {
            out[k] = a;
            out.push(b);
            missing -= 1;
        }
    }
    out
}

/// One light per median-cut region of `map` (at most `n`; see the module docs). Empty for a
/// black map or `n = 0`.
pub fn median_cut_lights(map: &PolarMap, n: usize) -> Vec<Light> {
    let table = EnergyTable::new(map);
    if !(table.total() > 0.0) || n == 0 {
        return Vec::new();
    }
    let (w, h) = (map.width, map.height);
    regions(&table, n)
        .iter()
        .enumerate()
        .map(|(k, r)| {
            let (mut c, mut rgb) = (DVec3::ZERO, [0.0f64; 3]);
            for j in r.y0..r.y1 {
                let dw = map.row_solid_angle(j) as f64;
                for i in r.x0..r.x1 {
                    let p = map.get(i, j);
                    if !is_valid(&p) {
                        continue;
                    }
                    c += map.texel_dir(i, j).as_dvec3() * (luminance(p) as f64 * dw);
                    for ch in 0..3 {
                        rgb[ch] += p[ch] as f64 * dw;
                    }
                }
            }
            let centre = || dir_from_polar((r.x0 + r.x1) as f32 * 0.5, (r.y0 + r.y1) as f32 * 0.5, w, h);
            let dir = c.try_normalize().map_or_else(centre, |d| d.as_vec3());
            Light { index: k as u32, dir, rgb: rgb.map(|v| v as f32), radius: 0.0 }
        })
        .collect()
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::vem::sampling::lights_power as power;

    #[test]
    fn total_power_is_conserved_and_n_lights_are_returned() {
        let map = PolarMap::from_fn(360, 90, |d| [1.0 + 3.0 * d.x.max(0.0), 0.5 + d.y, 2.0 * (1.0 - d.y)]);
        let want = map.total_power();
        for n in [1usize, 2, 3, 64, 100, 128, 300] {
            let l = median_cut_lights(&map, n);
            assert_eq!(l.len(), n);
            let got = power(&l);
            for c in 0..3 {
                assert!((got[c] - want[c]).abs() < 1e-4 * want[c], "n={n} channel {c}: {} vs {}", got[c], want[c]);
            }
            assert!(l.iter().all(|x| x.dir.y >= 0.0 && (x.dir.length() - 1.0).abs() < 1e-4));
            let mut idx: Vec<u32> = l.iter().map(|x| x.index).collect();
            idx.dedup();
            assert_eq!(idx.len(), n);
        }
    }

    #[test]
    fn a_single_bright_texel_gets_one_light_at_its_direction() {
        let mut map = PolarMap::new(360, 90);
        let (i, j) = (123u32, 40u32);
        map.data[(j * 360 + i) as usize] = [50.0, 40.0, 30.0];
        for n in [1usize, 16, 64] {
            let l = median_cut_lights(&map, n);
            let lit: Vec<&Light> = l.iter().filter(|x| x.rgb.iter().any(|&c| c > 0.0)).collect();
            assert_eq!(lit.len(), 1, "n={n}");
            assert!(lit[0].dir.dot(map.texel_dir(i, j)) > 1.0 - 1e-6);
            let dw = map.row_solid_angle(j);
            assert!((lit[0].rgb[0] - 50.0 * dw).abs() < 1e-4 * 50.0 * dw);
        }
    }

    #[test]
    fn lights_follow_the_energy() {
        // Half the map ten times brighter: most regions land there.
        let map = PolarMap::from_fn(120, 30, |d| if d.x > 0.0 { [10.0; 3] } else { [1.0; 3] });
        let l = median_cut_lights(&map, 64);
        let bright = l.iter().filter(|x| x.dir.x > 0.0).count();
        assert!(bright >= 48, "{bright}");
        assert!(median_cut_lights(&PolarMap::new(36, 9), 8).is_empty());
    }
}
