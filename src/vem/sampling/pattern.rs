//! The fixed input samples on the unit square (Havran §3.2): the 2D Halton sequence with bases 2
//! and 3, relaxed toward blue noise by Lloyd iterations once, then reused for every frame.
//!
//! # How it works
//! - Sample `k` (0-based) is Halton point `k + 1` (the origin, Halton point 0, is skipped: it is
//!   a corner of the square and would land on the horizon). A light keeps its index `k` for the
//!   whole sequence, which is what lets the temporal filter follow it (Havran §3.3).
//! - **Progressive relaxation.** Lloyd's relaxation (as in Hiller, Deussen & Keller 2001, which
//!   Havran cites) moves every point to the centroid of its Voronoi cell. Done on the whole set,
//!   it would make sample `k` depend on how many samples there are. Here it runs level by level:
//!   the samples `[2^(l−1), 2^l)` are relaxed among all samples `[0, 2^l)` while the earlier ones
//!   stay fixed. So every prefix of length `2^l` is a relaxed set, and a sample's position never
//!   depends on the light count: adding lights never moves existing ones.
//! - Voronoi cells are discretised on a grid of about [`LLOYD_GRID_PER_POINT`] cells per sample,
//!   whose nearest sample comes from a kd-tree (`kiddo`, with periodic boundaries). The domain is
//!   the unit **torus**, as for tiled blue noise (Hiller et al.): relaxing in the bounded square
//!   leaves a boundary layer whose density differs from the interior, and since the square's edge
//!   is the horizon of Havran's transform, that showed up as a few percent too many samples in
//!   mid-elevation rings (measured: 62 instead of 54 of 64 lights on a sun holding 85% of the
//!   power; 50 with the torus, 55 for plain Halton).
//! - The first [`RELAXED_COUNT`] samples are relaxed, computed once per process on first use
//!   (about 0.2 s) and cached; samples beyond are plain Halton points, which keeps the
//!   progressive property at any count.

use glam::Vec2;
use kiddo::{ImmutableKdTree, SquaredEuclidean};
use std::sync::OnceLock;

/// How many samples are relaxed (and cached); later ones are plain Halton points.
pub const RELAXED_COUNT: usize = 4096;
/// Lloyd iterations per level.
pub const LLOYD_ITERATIONS: usize = 8;
/// Grid cells per sample used to discretise the Voronoi cells.
pub const LLOYD_GRID_PER_POINT: usize = 64;

/// Which input samples to use.
#[derive(Clone, Copy, Debug, PartialEq, Eq, serde::Serialize, serde::Deserialize, Default)]
#[serde(rename_all = "snake_case")]
pub enum Pattern {
    /// Halton (2, 3) relaxed toward blue noise (the paper's choice).
    #[default]
    RelaxedHalton,
    /// Plain Halton (2, 3).
    Halton,
}

/// Radical inverse of `i` in base `b` (van der Corput).
pub fn radical_inverse(mut i: u64, b: u64) -> f64 {
    let inv = 1.0 / b as f64;
    let (mut f, mut r) = (inv, 0.0);
    while i > 0 {
        r += (i % b) as f64 * f;
        i /= b;
        f *= inv;
    }
    r
}

/// The 2D Halton point of index `i` with bases 2 and 3.
pub fn halton_2d(i: u64) -> Vec2 {
    Vec2::new(radical_inverse(i, 2) as f32, radical_inverse(i, 3) as f32)
}

/// Sample `k` of a pattern (Halton index `k + 1`).
pub fn sample(pattern: Pattern, k: usize) -> Vec2 {
    match pattern {
        Pattern::RelaxedHalton if k < RELAXED_COUNT => relaxed()[k],
        _ => halton_2d(k as u64 + 1),
    }
}

/// The first `n` samples of a pattern.
pub fn samples(pattern: Pattern, n: usize) -> Vec<Vec2> {
    (0..n).map(|k| sample(pattern, k)).collect()
}

/// The cached relaxed samples (computed on first call).
pub fn relaxed() -> &'static [Vec2] {
    static CACHE: OnceLock<Vec<Vec2>> = OnceLock::new();
    CACHE.get_or_init(|| relax_progressively(&(1..=RELAXED_COUNT as u64).map(halton_2d).collect::<Vec<_>>()))
}

/// Progressive Lloyd relaxation of `points` (see the module docs): level `l` moves the points
/// `[2^(l−1), 2^l)` and keeps the earlier ones fixed.
pub fn relax_progressively(points: &[Vec2]) -> Vec<Vec2> {
    let mut pts = points.to_vec();
    let mut lo = 0;
    while lo < pts.len() {
        let hi = (lo.max(1) * 2).min(pts.len());
        relax_level(&mut pts[..hi], lo);
        lo = hi;
    }
    pts
}

/// Lloyd iterations on `pts[movable_from..]` inside the Voronoi diagram of all of `pts`, on the
/// unit torus.
fn relax_level(pts: &mut [Vec2], movable_from: usize) {
    let n = pts.len();
    let g = ((n * LLOYD_GRID_PER_POINT) as f64).sqrt().ceil().max(16.0) as usize;
    let cell = 1.0 / g as f32;
    let wrap = |d: f32| d - d.round(); // into [-½, ½]
    let mut sums = vec![(Vec2::ZERO, 0u32); n];
    for _ in 0..LLOYD_ITERATIONS {
        let coords: Vec<[f32; 2]> = pts.iter().map(|p| [p.x, p.y]).collect();
        let Ok(tree) = ImmutableKdTree::<f32, 2>::new_from_slice(&coords) else {
            return; // cannot happen for a few thousand points; leave the level unrelaxed
        };
        sums.iter_mut().for_each(|s| *s = (Vec2::ZERO, 0));
        for b in 0..g {
            for a in 0..g {
                let q = Vec2::new((a as f32 + 0.5) * cell, (b as f32 + 0.5) * cell);
                let k = tree.query(&[q.x, q.y]).periodic_boundary_condition(&[1.0, 1.0]).nearest_one::<SquaredEuclidean<f32>>().execute().item as usize;
                if k >= movable_from {
                    let d = q - pts[k];
                    sums[k].0 += Vec2::new(wrap(d.x), wrap(d.y));
                    sums[k].1 += 1;
                }
            }
        }
        for (p, (s, c)) in pts.iter_mut().zip(&sums).skip(movable_from) {
            if *c > 0 {
                let m = *p + *s / *c as f32;
                *p = Vec2::new(m.x.rem_euclid(1.0), m.y.rem_euclid(1.0));
            }
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// Minimum and mean nearest-neighbour distance.
    fn nn_distances(p: &[Vec2]) -> (f32, f32) {
        let (mut min, mut sum) = (f32::MAX, 0.0);
        for i in 0..p.len() {
            let m = (0..p.len()).filter(|&j| j != i).map(|j| p[i].distance(p[j])).fold(f32::MAX, f32::min);
            min = min.min(m);
            sum += m;
        }
        (min, sum / p.len() as f32)
    }

    #[test]
    fn halton_closed_forms() {
        assert_eq!(halton_2d(1), Vec2::new(0.5, 1.0 / 3.0));
        assert_eq!(halton_2d(2), Vec2::new(0.25, 2.0 / 3.0));
        assert!((halton_2d(5) - Vec2::new(0.625, 7.0 / 9.0)).length() < 1e-7);
        assert_eq!(sample(Pattern::Halton, 0), halton_2d(1));
    }

    #[test]
    fn relaxed_samples_are_blue_noise_and_stay_stratified() {
        let r = relaxed();
        assert_eq!(r.len(), RELAXED_COUNT);
        assert!(r.iter().all(|p| p.x >= 0.0 && p.x < 1.0 && p.y >= 0.0 && p.y < 1.0));
        for n in [64usize, 256, 1024] {
            let raw: Vec<Vec2> = (1..=n as u64).map(halton_2d).collect();
            let ((min_raw, mean_raw), (min_rel, mean_rel)) = (nn_distances(&raw), nn_distances(&r[..n]));
            // Blue noise: no two samples close together. Measured: minimum distance 1.5–1.9× the
            // raw Halton prefix's, mean nearest-neighbour distance 1.18× (n = 64), 1.23× (256),
            // 1.34× (1024). Progressive relaxation keeps earlier samples fixed, so it cannot reach
            // the 1.7× of a fully relaxed (hexagonal) set.
            assert!(min_rel > 1.4 * min_raw, "n={n}: relaxed {min_rel} raw {min_raw}");
            assert!(mean_rel > 1.1 * mean_raw, "n={n}: relaxed {mean_rel} raw {mean_raw}");
            // Stratification survives: every cell of a 4×4 grid holds n/16 samples within
            // ±2√(n/16); measured: ±2 of 4, ±3 of 16, ±4 of 64 (a random set scatters by about
            // √(n/16) per cell, so its largest deviation would typically exceed 2√(n/16)).
            let mut counts = [0usize; 16];
            for p in &r[..n] {
                counts[((p.x * 4.0) as usize).min(3) + 4 * ((p.y * 4.0) as usize).min(3)] += 1;
            }
            let want = n as f32 / 16.0;
            println!("n={n}: {counts:?}");
            assert!(counts.iter().all(|&c| (c as f32 - want).abs() <= 2.0 * want.sqrt()), "n={n}: {counts:?}");
        }
    }

    #[test]
    fn a_sample_does_not_depend_on_the_count() {
        // The relaxation of a prefix is the prefix of the relaxation.
        let pts: Vec<Vec2> = (1..=200u64).map(halton_2d).collect();
        let all = relax_progressively(&pts);
        let part = relax_progressively(&pts[..128]);
        assert_eq!(&all[..128], &part[..]);
        assert_eq!(&relaxed()[..128], &relax_progressively(&(1..=128u64).map(halton_2d).collect::<Vec<_>>())[..]);
    }
}
