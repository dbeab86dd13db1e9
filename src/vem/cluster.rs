//! Clustering of the high-intensity lights (Havran §4.3): at most `Q` lights, with temporally
//! stable centres.
//!
//! # How it works
//! - If `Q` clusters covered the hemisphere evenly, each would cover `2π/Q` sr, a cap of angular
//!   radius `asin √(2/Q)`; with a correction `c_f ≈ 1.8–1.9` for covering by discs, the clustering
//!   radius is `ε = c_f · asin √(2/Q)` ([`cluster_radius`]).
//! - Lights are visited **in sequence order** (light index). An unassigned light seeds a cluster
//!   and takes every unassigned light within `ε` of it (a radius query in a kd-tree over the unit
//!   direction vectors, `kiddo`, with the chord `2 sin(ε/2)`). Since the order is the Halton
//!   order, the seeds (and so the centres) change little from frame to frame.
//! - The paper bounds the count by `Q` only on average. Here it is a hard bound: once `Q`
//!   clusters exist, every light still unassigned joins the cluster whose seed is nearest (a
//!   nearest-neighbour query over the seeds), so no power is lost.
//! - A cluster's direction is the normalised mean of its members' directions (equal luminance
//!   power each); its power is the sum of theirs. The output is ordered by seed index.

use super::Light;
use glam::Vec3;
use kiddo::{ImmutableKdTree, SquaredEuclidean};

/// The paper's correction factor for covering the hemisphere by discs (it quotes 1.8–1.9).
pub const DEFAULT_CF: f32 = 1.85;

/// A clustered light.
#[derive(Clone, Copy, Debug, PartialEq, serde::Serialize)]
pub struct Cluster {
    /// Index of the light that seeded the cluster.
    pub seed: u32,
    /// Unit direction (world).
    pub dir: Vec3,
    /// Summed RGB power of the members.
    pub rgb: [f32; 3],
    /// Number of member lights.
    pub members: u32,
}

/// `ε = c_f · asin √(2/Q)` in radians (Havran §4.3); `Q ≤ 2` gives `c_f · π/2`.
pub fn cluster_radius(q: usize, c_f: f32) -> f32 {
    c_f * (2.0 / q.max(1) as f32).sqrt().min(1.0).asin()
}

/// Clusters `lights` (in sequence order) into at most `q` lights with radius `eps` (radians).
/// Reuses `out`.
pub fn cluster_lights(lights: &[Light], q: usize, eps: f32, out: &mut Vec<Cluster>) {
    out.clear();
    if lights.is_empty() || q == 0 {
        return;
    }
    let pts: Vec<[f32; 3]> = lights.iter().map(|l| l.dir.to_array()).collect();
    let Ok(tree) = ImmutableKdTree::<f32, 3>::new_from_slice(&pts) else {
        return;
    };
    let chord = 2.0 * (0.5 * eps.clamp(0.0, std::f32::consts::PI)).sin();
    let r2 = chord * chord;
    let mut owner = vec![u32::MAX; lights.len()];
    let mut sums: Vec<(Vec3, [f32; 3], u32)> = Vec::new();
    let mut seeds: Vec<usize> = Vec::new();
    for i in 0..lights.len() {
        if owner[i] != u32::MAX {
            continue;
        }
        if seeds.len() == q {
            break;
        }
        let c = seeds.len() as u32;
        seeds.push(i);
        sums.push((Vec3::ZERO, [0.0; 3], 0));
        for hit in tree.query(&pts[i]).within::<SquaredEuclidean<f32>>(r2).unsorted().execute() {
            let j = hit.item as usize;
            if owner[j] == u32::MAX {
                owner[j] = c;
            }
        }
        owner[i] = c;
    }
    // Lights left over once Q clusters exist join the cluster with the nearest seed.
    if owner.contains(&u32::MAX) {
        let seed_pts: Vec<[f32; 3]> = seeds.iter().map(|&i| pts[i]).collect();
        if let Ok(seed_tree) = ImmutableKdTree::<f32, 3>::new_from_slice(&seed_pts) {
            for (j, o) in owner.iter_mut().enumerate() {
                if *o == u32::MAX {
                    *o = seed_tree.query(&pts[j]).nearest_one::<SquaredEuclidean<f32>>().execute().item;
                }
            }
        }
    }
    for (l, &o) in lights.iter().zip(&owner) {
        if let Some(s) = sums.get_mut(o as usize) {
            s.0 += l.dir;
            for c in 0..3 {
                s.1[c] += l.rgb[c];
            }
            s.2 += 1;
        }
    }
    out.extend(seeds.iter().zip(&sums).map(|(&i, &(v, rgb, members))| {
        let dir = v.try_normalize().unwrap_or(lights[i].dir);
        Cluster { seed: lights[i].index, dir, rgb, members }
    }));
}

#[cfg(test)]
mod tests {
    use super::*;
    use rand::{Rng, SeedableRng, rngs::SmallRng};

    fn light(index: u32, dir: Vec3) -> Light {
        Light { index, dir: dir.normalize(), rgb: [1.0, 0.5, 0.25], radius: 0.0 }
    }

    #[test]
    fn radius_closed_form() {
        // Q = 8: asin(0.5) = 30°.
        assert!((cluster_radius(8, 1.0) - std::f32::consts::FRAC_PI_6).abs() < 1e-6);
        assert!((cluster_radius(1, 1.0) - std::f32::consts::FRAC_PI_2).abs() < 1e-6);
    }

    #[test]
    fn at_most_q_clusters_and_no_power_lost() {
        let mut rng = SmallRng::seed_from_u64(9);
        let lights: Vec<Light> = (0..300)
            .map(|i| {
                let d = Vec3::new(rng.random_range(-1.0..1.0), rng.random_range(0.0..1.0), rng.random_range(-1.0..1.0));
                light(i, d)
            })
            .collect();
        for q in [4usize, 16, 72] {
            for cf in [0.5f32, DEFAULT_CF] {
                let mut out = Vec::new();
                cluster_lights(&lights, q, cluster_radius(q, cf), &mut out);
                assert!(out.len() <= q && !out.is_empty());
                let m: u32 = out.iter().map(|c| c.members).sum();
                assert_eq!(m, 300);
                let r: f32 = out.iter().map(|c| c.rgb[0]).sum();
                assert!((r - 300.0).abs() < 1e-2);
                assert!(out.windows(2).all(|w| w[0].seed < w[1].seed));
                assert!(out.iter().all(|c| (c.dir.length() - 1.0).abs() < 1e-5));
            }
        }
    }

    #[test]
    fn a_tight_bundle_becomes_one_cluster_at_its_mean() {
        let sun = Vec3::new(0.3, 0.9, 0.1).normalize();
        let mut lights: Vec<Light> = (0..20).map(|i| light(i, sun + Vec3::new(0.01 * (i % 3) as f32, 0.0, 0.01 * (i % 5) as f32))).collect();
        lights.push(light(20, Vec3::new(-0.9, 0.2, 0.0)));
        let mut out = Vec::new();
        cluster_lights(&lights, 16, cluster_radius(16, DEFAULT_CF), &mut out);
        assert_eq!(out.len(), 2);
        assert_eq!((out[0].seed, out[0].members, out[1].seed, out[1].members), (0, 20, 20, 1));
        let mean = lights[..20].iter().map(|l| l.dir).sum::<Vec3>().normalize();
        assert!((out[0].dir - mean).length() < 1e-5);
    }
}
