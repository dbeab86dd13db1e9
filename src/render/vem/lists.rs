//! The light and list buffers of a frame as the shading pass reads them
//! (`shaders/common/vem_lights.wgsl`), grouped by shadow slot.

use crate::vem::regions::{GpuLight, RegionLists, RegionSet};

/// The list buffer of `set` (see `shaders/common/vem_lights.wgsl`): LUT, ranges, ids.
pub fn list_words(set: &RegionSet, lists: &RegionLists) -> Vec<u32> {
    let mut w = Vec::with_capacity(set.lut.texels.len() + 2 * lists.ranges.len() + lists.ids.len());
    w.extend_from_slice(&set.lut.texels);
    for r in &lists.ranges {
        w.extend([r.offset, r.count]);
    }
    w.extend_from_slice(&lists.ids);
    w
}

/// Reorders `lights` by shadow slot (sequence order within a slot) and rewrites the ids of the
/// list buffer `words` (`regions` regions after a LUT of `lut_len` texels) to the new order, each
/// region's ids ascending: a region's list then visits the lights of one shadow map one after the
/// other, and the shader reads each map once per run instead of once per light.
pub fn group_by_slot(lights: &mut Vec<GpuLight>, words: &mut [u32], lut_len: usize, regions: usize) {
    let mut perm: Vec<u32> = (0..lights.len() as u32).collect();
    perm.sort_by_key(|&i| (lights[i as usize].shadow, i));
    let mut new_of_old = vec![0u32; lights.len()];
    for (new, &old) in perm.iter().enumerate() {
        new_of_old[old as usize] = new as u32;
    }
    *lights = perm.iter().map(|&i| lights[i as usize]).collect();
    let ids_at = lut_len + 2 * regions;
    for r in 0..regions {
        let (off, cnt) = (words[lut_len + 2 * r] as usize, words[lut_len + 2 * r + 1] as usize);
        let ids = &mut words[ids_at + off..ids_at + off + cnt];
        for id in ids.iter_mut() {
            *id = new_of_old[*id as usize];
        }
        ids.sort_unstable();
    }
}

pub(super) fn light_bytes(lights: &[GpuLight]) -> Vec<u8> {
    let mut out = Vec::with_capacity(32 * lights.len().max(1));
    for l in lights {
        out.extend(bytemuck::cast_slice::<f32, u8>(&l.dir));
        out.extend(l.shadow.to_le_bytes());
        out.extend(bytemuck::cast_slice::<f32, u8>(&l.rgb));
        out.extend(l.index.to_le_bytes());
    }
    if out.is_empty() {
        out.resize(32, 0);
    }
    out
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::render::vem::shadow_atlas;
    use glam::Vec3;
    use crate::vem::Light;
    use crate::vem::regions::{shade_lambert_all, shade_lambert_region};
    use rand::{Rng, SeedableRng, rngs::SmallRng};

    /// `shade_lambert_region` read from a list buffer (what the shader does).
    fn shade_from_words(set: &RegionSet, words: &[u32], lights: &[GpuLight], n: Vec3) -> [f32; 3] {
        let lut_len = set.lut.texels.len();
        let r = lut_len + 2 * words[set.lut.texel(n)] as usize;
        let ids_at = lut_len + 2 * set.len();
        let mut e = [0.0f32; 3];
        for &i in &words[ids_at + words[r] as usize..ids_at + (words[r] + words[r + 1]) as usize] {
            let l = &lights[i as usize];
            let c = n.dot(Vec3::from_array(l.dir)).max(0.0);
            for k in 0..3 {
                e[k] += l.rgb[k] * c;
            }
        }
        e
    }

    #[test]
    fn grouping_by_slot_keeps_every_list_and_groups_its_maps() {
        let mut rng = SmallRng::seed_from_u64(3);
        let lights: Vec<Light> = (0..300)
            .map(|i| {
                let d = Vec3::new(rng.random_range(-1.0..1.0), rng.random_range(0.05..1.0), rng.random_range(-1.0..1.0)).normalize();
                Light { index: i, dir: d, rgb: [rng.random_range(0.1..1.0), 0.5, 0.2], radius: 0.0 }
            })
            .collect();
        let set = RegionSet::lambertian(200, 16);
        let mut lists = RegionLists::default();
        set.build_lists(&lights, &mut lists);
        let mut words = list_words(&set, &lists);
        let mut gpu = lists.lights.clone();
        let dirs = shadow_atlas::shadow_directions(&gpu, &[], 12);
        shadow_atlas::assign_slots(&mut gpu, &dirs);
        group_by_slot(&mut gpu, &mut words, set.lut.texels.len(), set.len());
        assert!(gpu.windows(2).all(|w| w[0].shadow <= w[1].shadow), "lights ordered by slot");
        for _ in 0..500 {
            let n = Vec3::new(rng.random_range(-1.0..1.0), rng.random_range(-1.0..1.0), rng.random_range(-1.0..1.0)).normalize_or(Vec3::Y);
            let (a, b) = (shade_lambert_region(&set, &lists, n), shade_from_words(&set, &words, &gpu, n));
            let all = shade_lambert_all(&lists.lights, n);
            for k in 0..3 {
                assert!((a[k] - b[k]).abs() <= 1e-4 * a[k].max(1.0) && (all[k] - b[k]).abs() <= 1e-4 * all[k].max(1.0));
            }
        }
    }
}
