//! Glossy surfaces with a low- and a high-intensity light set (Havran §4.2).
//!
//! # How it works
//! - **Sets.** `L` is the first `|L|` lights of the sequence (power `P/|L|` each) and `H` the
//!   first `|H|` of the same sequence with power rescaled to `P/|H|` ([`high_set`]): `H` is a
//!   subsequence of `L`, so `H`'s directions are also `L`'s.
//! - **Regions.** `S_H` is the Lambertian region set of [`super::regions`] (looked up by the
//!   normal). `S_L` ([`GlossyRegions`]) has finer regions whose centres are at least `γ` apart; the
//!   cone `C` around the reflected direction `R` has angular radius `γ/2`. A region's `L` list
//!   holds every light within `α_L/2 + γ/2` of its centre (`α_L/2` its LUT covering radius), so
//!   it always contains the whole cone of any `R` the LUT sends to it. (The paper sizes the
//!   regions at `γ`; with a lattice whose covering radius exceeds `γ/2` that can miss the rim of
//!   the cone, so the radius here is the exact one.)
//! - **Shading.** Lights of `L` inside `C` (`l·R ≥ cos(γ/2)`) plus lights of `H` outside `C`, with
//!   the same test on both sides: the cone's energy comes from `L` only and the rest from `H`
//!   only, never twice. With a cap of `k` cone lights, the first `k` in sequence order are used
//!   and scaled by `count/k` (the paper's rule, progressive by Observation 1).
//! - [`shade_glossy_all`] does this over all lights (the CPU reference), [`shade_glossy_regions`]
//!   walks only the two region lists (what the fragment shader does); they agree (tested).

use super::Light;
use super::regions::{GpuLight, RegionLists, RegionSet};
use glam::Vec3;

/// Default number of `S_L` regions.
pub const DEFAULT_GLOSSY_REGIONS: usize = 500;

/// The fine regions `S_L` and the cone radius.
#[derive(Clone, Debug)]
pub struct GlossyRegions {
    /// The `S_L` regions (lists are cones of radius `α_L/2 + γ/2`).
    pub regions: RegionSet,
    /// `γ`: the smallest angle between two `S_L` centres.
    pub gamma_rad: f32,
    /// `cos(γ/2)`: a light is in the cone around `R` when `l·R ≥` this.
    pub cos_cone: f32,
}

impl GlossyRegions {
    /// `count` regions on a `lut_size²`-per-face LUT.
    pub fn new(count: usize, lut_size: u32) -> Self {
        let probe = RegionSet::new(count, lut_size, 0.0);
        let gamma = probe.min_spacing_rad();
        let regions = RegionSet::new(count, lut_size, 0.5 * gamma);
        Self { regions, gamma_rad: gamma, cos_cone: (0.5 * gamma).cos() }
    }
}

/// The high-intensity set `H`: the first `h` lights of `L`, each with power scaled by `|L|/h`.
pub fn high_set(l: &[Light], h: usize, out: &mut Vec<Light>) {
    out.clear();
    let h = h.min(l.len());
    if h == 0 {
        return;
    }
    let scale = l.len() as f32 / h as f32;
    out.extend(l[..h].iter().map(|x| Light { rgb: x.rgb.map(|c| c * scale), ..*x }));
}

fn add(e: &mut [f32; 3], rgb: [f32; 3], w: f32) {
    for k in 0..3 {
        e[k] += rgb[k] * w;
    }
}

/// Glossy shading over all lights (reference): `Σ_{L∩C} + Σ_{H∖C}` of `rgb · f(l)`, where `f`
/// is the whole per-light factor (BRDF × cosine) and `C` is the cone `l·r ≥ cos_cone`; at most
/// `max_cone` lights of `L∩C` (the first ones, scaled up).
pub fn shade_glossy_all(l: &[GpuLight], h: &[GpuLight], r: Vec3, cos_cone: f32, max_cone: Option<usize>, f: impl Fn(Vec3) -> f32) -> [f32; 3] {
    let mut e = [0.0f32; 3];
    let in_cone = |d: Vec3| d.dot(r) >= cos_cone;
    cone_part(&mut e, l.iter(), in_cone, max_cone, &f);
    for x in h {
        let d = Vec3::from_array(x.dir);
        if !in_cone(d) {
            add(&mut e, x.rgb, f(d));
        }
    }
    e
}

fn cone_part<'a>(e: &mut [f32; 3], lights: impl Iterator<Item = &'a GpuLight> + Clone, in_cone: impl Fn(Vec3) -> bool, max_cone: Option<usize>, f: &impl Fn(Vec3) -> f32) {
    let count = lights.clone().filter(|x| in_cone(Vec3::from_array(x.dir))).count();
    let k = max_cone.map_or(count, |k| k.min(count));
    if k == 0 {
        return;
    }
    let scale = count as f32 / k as f32;
    for x in lights.filter(|x| in_cone(Vec3::from_array(x.dir))).take(k) {
        let d = Vec3::from_array(x.dir);
        add(e, x.rgb, f(d) * scale);
    }
}

/// Glossy shading from the region lists only: the `L` list of `r`'s `S_L` region and the `H` list
/// of `n`'s `S_H` region. `f` must vanish for lights below the surface (`n·l ≤ 0`), as a BRDF times
/// the cosine does; then this equals [`shade_glossy_all`].
#[allow(clippy::too_many_arguments)]
pub fn shade_glossy_regions(
    glossy: &GlossyRegions,
    l_lists: &RegionLists,
    h_set: &RegionSet,
    h_lists: &RegionLists,
    n: Vec3,
    r: Vec3,
    max_cone: Option<usize>,
    f: impl Fn(Vec3) -> f32,
) -> [f32; 3] {
    let mut e = [0.0f32; 3];
    let in_cone = |d: Vec3| d.dot(r) >= glossy.cos_cone;
    let l_ids = glossy.regions.list(l_lists, r);
    cone_part(&mut e, l_ids.iter().map(|&i| &l_lists.lights[i as usize]), in_cone, max_cone, &f);
    for &i in h_set.list(h_lists, n) {
        let x = &h_lists.lights[i as usize];
        let d = Vec3::from_array(x.dir);
        if !in_cone(d) {
            add(&mut e, x.rgb, f(d));
        }
    }
    e
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::vem::sampling::pattern::{Pattern, sample};
    use crate::vem::polar::{PolarMap, luminance};
    use crate::vem::regions::DEFAULT_REGIONS;
    use crate::vem::sampling::{PolarDistribution, SamplerKind};
    use rand::{Rng, SeedableRng, rngs::SmallRng};

    fn lights_from(map: &PolarMap, n: usize) -> Vec<Light> {
        let dist = PolarDistribution::new(map);
        let p = dist.integral() as f32 / n as f32;
        (0..n)
            .map(|k| {
                let r = dist.sample(SamplerKind::Havran, sample(Pattern::RelaxedHalton, k)).unwrap();
                Light { index: k as u32, dir: r.dir, rgb: dist.light_rgb(map, &r).map(|c| c * p), radius: 0.0 }
            })
            .collect()
    }

    #[test]
    fn region_lists_give_the_reference_glossy_shading() {
        let map = PolarMap::from_fn(360, 90, |d| [1.0 + d.x.max(0.0) * 3.0, 1.0, 1.0 + d.z.abs()]);
        let l = lights_from(&map, 1024);
        let mut h = Vec::new();
        high_set(&l, 64, &mut h);
        let glossy = GlossyRegions::new(DEFAULT_GLOSSY_REGIONS, 32);
        let h_set = RegionSet::lambertian(DEFAULT_REGIONS, 32);
        let (mut l_lists, mut h_lists) = (RegionLists::default(), RegionLists::default());
        glossy.regions.build_lists(&l, &mut l_lists);
        h_set.build_lists(&h, &mut h_lists);
        assert!(glossy.gamma_rad > 0.05 && glossy.gamma_rad < 0.2, "γ = {}", glossy.gamma_rad);
        let mut rng = SmallRng::seed_from_u64(8);
        for _ in 0..3000 {
            let n = Vec3::new(rng.random_range(-1.0..1.0), rng.random_range(-0.3..1.0), rng.random_range(-1.0..1.0)).normalize();
            let v = Vec3::new(rng.random_range(-1.0..1.0), rng.random_range(0.0..1.0), rng.random_range(-1.0..1.0)).normalize();
            let r = (2.0 * n.dot(v) * n - v).normalize();
            let f = |d: Vec3| d.dot(r).max(0.0).powi(30) * d.dot(n).max(0.0);
            for cap in [None, Some(8)] {
                let a = shade_glossy_all(&l_lists.lights, &h_lists.lights, r, glossy.cos_cone, cap, f);
                let b = shade_glossy_regions(&glossy, &l_lists, &h_set, &h_lists, n, r, cap, f);
                for k in 0..3 {
                    assert!((a[k] - b[k]).abs() <= 1e-4 * a[k].abs().max(1e-3), "{a:?} vs {b:?}");
                }
            }
        }
    }

    #[test]
    fn cone_energy_comes_from_one_set_only() {
        // With f ≡ 1 the two strata estimate the total power once: L inside the cone plus H
        // outside. Counting H inside the cone as well would add the cone's share again.
        let map = PolarMap::from_fn(360, 90, |_| [1.0; 3]);
        let l = lights_from(&map, 4096);
        let mut h = Vec::new();
        high_set(&l, 256, &mut h);
        let gl: Vec<GpuLight> = l.iter().map(GpuLight::from_light).collect();
        let gh: Vec<GpuLight> = h.iter().map(GpuLight::from_light).collect();
        let total = 2.0 * std::f32::consts::PI;
        let cos_cone = 0.3f32.cos(); // a wide cone (0.28 sr) makes double counting visible
        for r in [Vec3::Y, Vec3::new(0.6, 0.5, 0.2).normalize()] {
            let e = luminance(shade_glossy_all(&gl, &gh, r, cos_cone, None, |_| 1.0));
            assert!((e - total).abs() < 0.02 * total, "{e} vs {total}");
            let twice = luminance(shade_glossy_all(&gl, &gh, r, cos_cone, None, |_| 1.0))
                + gh.iter().filter(|x| Vec3::from_array(x.dir).dot(r) >= cos_cone).map(|x| luminance(x.rgb)).sum::<f32>();
            assert!(twice > 1.03 * total);
        }
    }
}
