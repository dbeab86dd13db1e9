//! Angular regions and per-region light lists (Havran §4.1), in GPU-ready flat buffers.
//!
//! # How it works
//! - **Regions.** `R` centres spread evenly over the sphere (a spherical Fibonacci lattice; ~200
//!   in the paper). A cube-map LUT ([`CubeLut`], `6 × S × S` texels) gives, for any normal, its
//!   region in one lookup: each texel holds the region whose centre is nearest to the texel's
//!   centre direction (a kd-tree query, `kiddo`). Face order and `(s, t)` addressing follow the
//!   OpenGL/Vulkan/WebGPU cube-map convention, so the LUT uploads as a cube texture unchanged.
//! - **Covering radius.** `α/2` is the largest angle between a region's centre and any direction
//!   the LUT sends to it, measured over every texel's corners: it includes the LUT's
//!   discretisation (the paper's `α/2` is the spacing of neighbouring centres; this is the exact
//!   quantity the culling needs).
//! - **Lists.** A region's list holds every light within `β` of its centre. For Lambertian shading
//!   `β = α/2 + π/2` (Havran's overlap): any light with `n·l > 0` for some normal `n` of the
//!   region is in it, so shading with the region's list equals shading with all lights (tested
//!   with [`shade_lambert_all`] and [`shade_lambert_region`]). For the glossy sets of Havran §4.2
//!   ([`super::glossy`]) the lists are cones. Lists keep the sequence order (Havran's Observation
//!   1: progressive inside any region). They are found by a dot product against every centre;
//!   with `β > π/2` a region holds over half the lights, so a tree would not prune anything.
//! - With `R = 200` and `S = 32`, `α/2 ≈ 10°`, so a list holds about 59% of the lights: culling can
//!   save at most 1.7×, the paper's 1.6–1.8×. The fragment-shader side and its measured speedup
//!   belong to the compositor.
//!
//! # GPU layout (mirrors the compositor's storage buffers; all fields 4-byte scalars, no padding)
//! - `lights: array<GpuLight>`: 32 bytes each, `{ dir: vec3<f32>, shadow: u32, rgb: vec3<f32>,
//!   index: u32 }`. WGSL `vec3<f32>` has 16-byte alignment, and `dir` + `shadow` and `rgb` +
//!   `index` each fill 16 bytes, so the Rust `#[repr(C)]` layout equals the WGSL storage layout.
//!   `shadow` is the shadow-map atlas slot (`u32::MAX`: none; the compositor assigns them).
//! - `ranges: array<vec2<u32>>`: per region, `(offset, count)` into `ids`.
//! - `ids: array<u32>`: light indices (into `lights`), region after region.
//! - The LUT: `6 × S × S` `u32` region numbers, faces `+X, −X, +Y, −Y, +Z, −Z`, row-major with
//!   row 0 at `t = 0`.
//!
//! [`RegionLists::to_bytes`] writes the three buffers little-endian in exactly this layout.

use super::Light;
use glam::Vec3;
use kiddo::{ImmutableKdTree, SquaredEuclidean};
use std::f32::consts::FRAC_PI_2;

/// Default number of angular regions (the paper: about 200).
pub const DEFAULT_REGIONS: usize = 200;
/// Default cube-map LUT size per face.
pub const DEFAULT_LUT_SIZE: u32 = 32;

/// One light as the shaders read it (see the module docs for the layout).
#[repr(C)]
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct GpuLight {
    /// Unit direction toward the light (world).
    pub dir: [f32; 3],
    /// Shadow-map atlas slot, `u32::MAX` for none.
    pub shadow: u32,
    /// RGB power (irradiance at normal incidence).
    pub rgb: [f32; 3],
    /// The light's index (its Halton sample).
    pub index: u32,
}

const _: () = assert!(std::mem::size_of::<GpuLight>() == 32 && std::mem::align_of::<GpuLight>() == 4);

/// `(offset, count)` of a region's list in the `ids` buffer.
#[repr(C)]
#[derive(Clone, Copy, Debug, PartialEq, Eq, Default)]
pub struct GpuRange {
    /// First entry in `ids`.
    pub offset: u32,
    /// Number of entries.
    pub count: u32,
}

const _: () = assert!(std::mem::size_of::<GpuRange>() == 8);

impl GpuLight {
    /// The GPU record of a light (no shadow slot).
    pub fn from_light(l: &Light) -> Self {
        Self { dir: l.dir.to_array(), shadow: u32::MAX, rgb: l.rgb, index: l.index }
    }
}

/// Spherical Fibonacci lattice of `n` unit vectors (nearly even spacing).
pub fn fibonacci_sphere(n: usize) -> Vec<Vec3> {
    let golden = std::f32::consts::PI * (3.0 - 5.0f32.sqrt());
    (0..n)
        .map(|i| {
            let y = 1.0 - 2.0 * (i as f32 + 0.5) / n as f32;
            let r = (1.0 - y * y).max(0.0).sqrt();
            let (s, c) = (i as f32 * golden).sin_cos();
            Vec3::new(r * c, y, r * s)
        })
        .collect()
}

/// Cube face and `(s, t) ∈ [0,1]²` of a direction, OpenGL convention (faces `+X, −X, +Y, −Y,
/// +Z, −Z`).
#[inline]
pub fn cube_face_st(d: Vec3) -> (usize, f32, f32) {
    let a = d.abs();
    let (face, sc, tc, ma) = if a.x >= a.y && a.x >= a.z {
        if d.x > 0.0 { (0, -d.z, -d.y, a.x) } else { (1, d.z, -d.y, a.x) }
    } else if a.y >= a.z {
        if d.y > 0.0 { (2, d.x, d.z, a.y) } else { (3, d.x, -d.z, a.y) }
    } else if d.z > 0.0 {
        (4, d.x, -d.y, a.z)
    } else {
        (5, -d.x, -d.y, a.z)
    };
    let ma = ma.max(f32::MIN_POSITIVE);
    (face, 0.5 * (sc / ma + 1.0), 0.5 * (tc / ma + 1.0))
}

/// The (unnormalised) direction at `(s, t)` of a cube face; inverse of [`cube_face_st`].
pub fn dir_from_cube_face(face: usize, s: f32, t: f32) -> Vec3 {
    let (sc, tc) = (2.0 * s - 1.0, 2.0 * t - 1.0);
    match face {
        0 => Vec3::new(1.0, -tc, -sc),
        1 => Vec3::new(-1.0, -tc, sc),
        2 => Vec3::new(sc, 1.0, tc),
        3 => Vec3::new(sc, -1.0, -tc),
        4 => Vec3::new(sc, -tc, 1.0),
        _ => Vec3::new(-sc, -tc, -1.0),
    }
}

/// A cube-map lookup table from directions to region numbers.
#[derive(Clone, Debug, PartialEq)]
pub struct CubeLut {
    /// Texels per face side.
    pub size: u32,
    /// `6 × size × size` region numbers (see the module docs for the layout).
    pub texels: Vec<u32>,
}

impl CubeLut {
    /// The LUT texel index of a direction.
    #[inline]
    pub fn texel(&self, d: Vec3) -> usize {
        let (face, s, t) = cube_face_st(d);
        let n = self.size as usize;
        let col = ((s * n as f32) as usize).min(n - 1);
        let row = ((t * n as f32) as usize).min(n - 1);
        (face * n + row) * n + col
    }

    /// The region of a direction.
    #[inline]
    pub fn lookup(&self, d: Vec3) -> u32 {
        self.texels[self.texel(d)]
    }
}

/// A set of angular regions with a LUT and a list radius.
#[derive(Clone, Debug)]
pub struct RegionSet {
    /// Region centres (unit vectors).
    pub centres: Vec<Vec3>,
    /// The normal → region LUT.
    pub lut: CubeLut,
    /// `α/2`: the largest angle between a region's centre and a direction the LUT sends to it.
    pub covering_rad: f32,
    /// `β`: lights within this angle of a centre are in the region's list.
    pub list_radius_rad: f32,
    cos_list: f32,
    /// Centres as structure of arrays (for the per-frame dot products).
    cx: Vec<f32>,
    cy: Vec<f32>,
    cz: Vec<f32>,
}

impl RegionSet {
    /// `count` regions on a `lut_size²`-per-face LUT with lists of radius `α/2 + extra_rad`.
    pub fn new(count: usize, lut_size: u32, extra_rad: f32) -> Self {
        let count = count.max(1);
        let lut_size = lut_size.max(1);
        let centres = fibonacci_sphere(count);
        let pts: Vec<[f32; 3]> = centres.iter().map(|c| c.to_array()).collect();
        let n = lut_size as usize;
        let mut texels = vec![0u32; 6 * n * n];
        let mut covering = 0.0f32;
        if let Ok(tree) = ImmutableKdTree::<f32, 3>::new_from_slice(&pts) {
            for face in 0..6 {
                for row in 0..n {
                    for col in 0..n {
                        let st = |a: usize| a as f32 / n as f32;
                        let centre = dir_from_cube_face(face, st(2 * col + 1) / 2.0, st(2 * row + 1) / 2.0).normalize();
                        let r = tree.query(&centre.to_array()).nearest_one::<SquaredEuclidean<f32>>().execute().item;
                        texels[(face * n + row) * n + col] = r;
                        let c = centres[r as usize];
                        for (a, b) in [(col, row), (col + 1, row), (col, row + 1), (col + 1, row + 1)] {
                            let corner = dir_from_cube_face(face, st(a), st(b)).normalize();
                            covering = covering.max(corner.dot(c).clamp(-1.0, 1.0).acos());
                        }
                    }
                }
            }
        }
        let list_radius_rad = (covering + extra_rad).min(std::f32::consts::PI);
        Self {
            cx: centres.iter().map(|c| c.x).collect(),
            cy: centres.iter().map(|c| c.y).collect(),
            cz: centres.iter().map(|c| c.z).collect(),
            centres,
            lut: CubeLut { size: lut_size, texels },
            covering_rad: covering,
            list_radius_rad,
            cos_list: list_radius_rad.cos(),
        }
    }

    /// Regions for Lambertian culling: `β = α/2 + π/2` (Havran §4.1).
    pub fn lambertian(count: usize, lut_size: u32) -> Self {
        Self::new(count, lut_size, FRAC_PI_2)
    }

    /// The smallest angle between two centres (the paper's `γ` for the glossy sets).
    pub fn min_spacing_rad(&self) -> f32 {
        let pts: Vec<[f32; 3]> = self.centres.iter().map(|c| c.to_array()).collect();
        let Ok(tree) = ImmutableKdTree::<f32, 3>::new_from_slice(&pts) else { return 0.0 };
        let two = std::num::NonZero::new(2).unwrap_or(std::num::NonZero::<usize>::MIN);
        pts.iter()
            .filter_map(|p| tree.query(p).nearest_n::<SquaredEuclidean<f32>>(two).execute().get(1).map(|h| h.distance))
            .map(|chord2| 2.0 * (0.5 * chord2.sqrt()).min(1.0).asin())
            .fold(f32::MAX, f32::min)
    }

    /// Number of regions.
    pub fn len(&self) -> usize {
        self.centres.len()
    }

    /// Whether there are no regions (never: at least one is made).
    pub fn is_empty(&self) -> bool {
        self.centres.is_empty()
    }

    /// Builds this frame's lists for `lights` into `out` (buffers reused).
    pub fn build_lists(&self, lights: &[Light], out: &mut RegionLists) {
        out.lights.clear();
        out.lights.extend(lights.iter().map(GpuLight::from_light));
        out.ranges.clear();
        out.ids.clear();
        out.lx.clear();
        out.ly.clear();
        out.lz.clear();
        out.lx.extend(lights.iter().map(|l| l.dir.x));
        out.ly.extend(lights.iter().map(|l| l.dir.y));
        out.lz.extend(lights.iter().map(|l| l.dir.z));
        // Branch-free compaction: write every index, advance only past those inside (a branch
        // per light and region would mispredict about half the time).
        let n = lights.len();
        out.scratch.clear();
        out.scratch.resize(n + 1, 0);
        out.flags.clear();
        out.flags.resize(n, 0);
        for r in 0..self.centres.len() {
            let (x, y, z) = (self.cx[r], self.cy[r], self.cz[r]);
            let offset = out.ids.len() as u32;
            // Membership first (a vectorised loop), then the compaction.
            for (((f, lx), ly), lz) in out.flags.iter_mut().zip(&out.lx).zip(&out.ly).zip(&out.lz) {
                *f = u32::from(x * lx + y * ly + z * lz >= self.cos_list);
            }
            let mut count = 0usize;
            for (k, &f) in out.flags.iter().enumerate() {
                out.scratch[count] = k as u32;
                count += f as usize;
            }
            out.ids.extend_from_slice(&out.scratch[..count]);
            out.ranges.push(GpuRange { offset, count: count as u32 });
        }
    }

    /// The list of the region that the LUT gives for `d`.
    #[inline]
    pub fn list<'a>(&self, lists: &'a RegionLists, d: Vec3) -> &'a [u32] {
        let r = lists.ranges[self.lut.lookup(d) as usize];
        &lists.ids[r.offset as usize..(r.offset + r.count) as usize]
    }
}

/// One frame's lights and per-region lists, as uploaded to the GPU (see the module docs).
#[derive(Clone, Debug, Default)]
pub struct RegionLists {
    /// The frame's lights, each once.
    pub lights: Vec<GpuLight>,
    /// Per region, its slice of `ids`.
    pub ranges: Vec<GpuRange>,
    /// Light indices into `lights`, region after region, each region's in sequence order.
    pub ids: Vec<u32>,
    lx: Vec<f32>,
    ly: Vec<f32>,
    lz: Vec<f32>,
    scratch: Vec<u32>,
    flags: Vec<u32>,
}

impl RegionLists {
    /// The three buffers, little-endian, in the documented layout: `(lights, ranges, ids)`.
    pub fn to_bytes(&self) -> (Vec<u8>, Vec<u8>, Vec<u8>) {
        let mut lights = Vec::with_capacity(32 * self.lights.len());
        for l in &self.lights {
            for v in l.dir {
                lights.extend_from_slice(&v.to_le_bytes());
            }
            lights.extend_from_slice(&l.shadow.to_le_bytes());
            for v in l.rgb {
                lights.extend_from_slice(&v.to_le_bytes());
            }
            lights.extend_from_slice(&l.index.to_le_bytes());
        }
        let ranges = self.ranges.iter().flat_map(|r| [r.offset.to_le_bytes(), r.count.to_le_bytes()]).flatten().collect();
        let ids = self.ids.iter().flat_map(|i| i.to_le_bytes()).collect();
        (lights, ranges, ids)
    }

    /// Mean list length over regions, as a fraction of the light count (the shading work left
    /// after culling).
    pub fn mean_fraction(&self) -> f64 {
        if self.lights.is_empty() || self.ranges.is_empty() {
            return 0.0;
        }
        self.ids.len() as f64 / (self.ranges.len() * self.lights.len()) as f64
    }
}

/// Lambertian irradiance at normal `n` from all lights: `Σ rgb · max(n·l, 0)` (the CPU reference
/// without culling).
pub fn shade_lambert_all(lights: &[GpuLight], n: Vec3) -> [f32; 3] {
    let mut e = [0.0f32; 3];
    for l in lights {
        let c = n.dot(Vec3::from_array(l.dir));
        if c > 0.0 {
            for k in 0..3 {
                e[k] += l.rgb[k] * c;
            }
        }
    }
    e
}

/// The same from the list of `n`'s region only (what the fragment shader does).
pub fn shade_lambert_region(set: &RegionSet, lists: &RegionLists, n: Vec3) -> [f32; 3] {
    let mut e = [0.0f32; 3];
    for &i in set.list(lists, n) {
        let l = &lists.lights[i as usize];
        let c = n.dot(Vec3::from_array(l.dir));
        if c > 0.0 {
            for k in 0..3 {
                e[k] += l.rgb[k] * c;
            }
        }
    }
    e
}

#[cfg(test)]
mod tests {
    use super::*;
    use rand::{Rng, SeedableRng, rngs::SmallRng};

    fn random_dir(rng: &mut SmallRng) -> Vec3 {
        loop {
            let v = Vec3::new(rng.random_range(-1.0..1.0), rng.random_range(-1.0..1.0), rng.random_range(-1.0..1.0));
            if v.length_squared() > 1e-3 && v.length_squared() <= 1.0 {
                return v.normalize();
            }
        }
    }

    #[test]
    fn cube_faces_follow_the_gl_convention_and_invert() {
        assert_eq!(cube_face_st(Vec3::X).0, 0);
        assert_eq!(cube_face_st(Vec3::NEG_Z).0, 5);
        // +X face: s grows toward -Z, t toward -Y.
        let (_, s, t) = cube_face_st(Vec3::new(1.0, -0.5, -0.5));
        assert!((s - 0.75).abs() < 1e-6 && (t - 0.75).abs() < 1e-6);
        let mut rng = SmallRng::seed_from_u64(2);
        for _ in 0..1000 {
            let d = random_dir(&mut rng);
            let (f, s, t) = cube_face_st(d);
            assert!((dir_from_cube_face(f, s, t).normalize() - d).length() < 1e-5);
        }
    }

    #[test]
    fn lut_regions_are_covered_and_lists_cull_without_changing_the_shading() {
        let set = RegionSet::lambertian(DEFAULT_REGIONS, DEFAULT_LUT_SIZE);
        // Every LUT direction is within α/2 of its region's centre.
        let mut rng = SmallRng::seed_from_u64(4);
        for _ in 0..20000 {
            let d = random_dir(&mut rng);
            let c = set.centres[set.lut.lookup(d) as usize];
            assert!(d.dot(c).clamp(-1.0, 1.0).acos() <= set.covering_rad + 1e-5);
        }
        assert!(set.covering_rad > 0.1 && set.covering_rad < 0.25, "α/2 = {}", set.covering_rad);
        let lights: Vec<Light> = (0..300)
            .map(|i| {
                let mut d = random_dir(&mut rng);
                d.y = d.y.abs();
                Light { index: i, dir: d, rgb: [rng.random_range(0.1..2.0), 1.0, 0.5], radius: 0.0 }
            })
            .collect();
        let mut lists = RegionLists::default();
        set.build_lists(&lights, &mut lists);
        assert_eq!(lists.ranges.len(), DEFAULT_REGIONS);
        assert!(lists.mean_fraction() < 0.7 && lists.mean_fraction() > 0.45, "{}", lists.mean_fraction());
        for r in &lists.ranges {
            let ids = &lists.ids[r.offset as usize..(r.offset + r.count) as usize];
            assert!(ids.windows(2).all(|w| w[0] < w[1]), "lists keep sequence order");
        }
        for _ in 0..5000 {
            let n = random_dir(&mut rng);
            let (a, b) = (shade_lambert_all(&lists.lights, n), shade_lambert_region(&set, &lists, n));
            for k in 0..3 {
                assert!((a[k] - b[k]).abs() <= 1e-5 * a[k].abs().max(1.0), "{n}: {a:?} vs {b:?}");
            }
            // Every light facing n is in n's list.
            let list = set.list(&lists, n);
            for (i, l) in lists.lights.iter().enumerate() {
                if n.dot(Vec3::from_array(l.dir)) > 0.0 {
                    assert!(list.binary_search(&(i as u32)).is_ok());
                }
            }
        }
    }

    #[test]
    fn byte_layout() {
        let set = RegionSet::lambertian(8, 4);
        let mut lists = RegionLists::default();
        set.build_lists(&[Light { index: 7, dir: Vec3::Y, rgb: [1.0, 2.0, 3.0], radius: 0.0 }], &mut lists);
        let (l, r, i) = lists.to_bytes();
        assert_eq!(l.len(), 32);
        assert_eq!(&l[0..4], &0.0f32.to_le_bytes());
        assert_eq!(&l[4..8], &1.0f32.to_le_bytes());
        assert_eq!(&l[12..16], &u32::MAX.to_le_bytes());
        assert_eq!(&l[20..24], &2.0f32.to_le_bytes());
        assert_eq!(&l[28..32], &7u32.to_le_bytes());
        assert_eq!(r.len(), 8 * 8);
        assert_eq!(i.len(), 4 * lists.ids.len());
    }
}
