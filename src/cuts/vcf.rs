//! Visibility cut fields (VCF): an object's occlusion around it (cyberworlds §V, Fig. 4;
//! §V-A.1 and §V-A.4; the sampling study of §VI, Fig. 8).
//!
//! # How it works
//! Sample points lie on `K` concentric spheres around the object's bounding sphere (centre `c`,
//! radius `r`), radii spaced evenly from `inner·r` to `outer·r` (the paper: 32 spheres from
//! 1.2 r to 10 r). On each sphere the points form a `rows × cols` latitude–longitude grid in the
//! crate's equirect convention ([`crate::geometry::equirect::dir_from_texel_centre`]; the paper's 32² points
//! per sphere; its total of 196,608 points per field, §VI, is 32 spheres × 6·32², a cube map's
//! count, which `rows = 64, cols = 96` matches). At each point `x_s` the leaf value is the binary occlusion `V_i(x_s, ω_j)`: 0 when
//! the ray hits the object, 1 otherwise; directions outside the cone of the bounding sphere are
//! 1 without a ray. Leaves are cut at threshold 0 by default (the paper's rule for sharp shadows,
//! §V-A.1) and stored with one bit per value.
//!
//! A lookup at a point `p` takes its spherical coordinates about `c` and interpolates
//! trilinearly the cuts of the eight neighbouring sample points (§V-A.4): linear in the radius
//! between two spheres and bilinear in the grid's two angular coordinates, wrapping in longitude
//! and clamped to the first and last rows in latitude (a point within half a row of a pole is
//! interpolated from the ring of points around it).
//!
//! Outside the sampled shell the radius is clamped and the [`FieldRegion`] says so:
//! - closer than `inner·r`: the cuts of the innermost sphere, which *under-estimate* the
//!   occlusion (it grows toward a hemisphere at the surface); lower `inner` where receivers
//!   come that close (the ground under an object);
//! - beyond `outer·r`: the cuts of the outermost sphere, which *over-estimate* it slightly (at
//!   10 r the object's cap is `2π(1 − √0.99) ≈ 0.031` sr, 0.25 % of the sphere); a caller may
//!   instead leave the object out there ([`VisibilityCutField::beyond_reach`]): the real
//!   receivers do (`super::receivers`) and so do the objects' vertices (`super::frame`'s
//!   occluders, the bounce's sun visibility, and the static reference `super::eval::CutScene`), so that a receiver or a vertex no moved object
//!   reaches keeps its value exactly (`super::reuse`).

use super::cut::{Cut, check_threshold};
use super::packed::{PackedCuts, ValueEncoding};
use super::svc::{bounding_sphere, check_mesh};
use super::tree::DirectionTree;
use super::walk::weighted_sum;
use super::{CutsError, Progress};
use crate::geometry::equirect::{dir_from_texel_centre, texel_from_dir};
use crate::geometry::Mesh;
use crate::geometry::raycast::RayScene;
use glam::Vec3;
use rayon::prelude::*;

/// Relative margin on the bounding sphere in the ray-skipping cone test (covers f32 rounding of
/// the radius, 10⁻⁷ relative, with room to spare).
const CONE_MARGIN: f32 = 1e-4;
/// Relative slack on the shell's radii when a lookup is classified: a point placed on the
/// innermost or outermost sphere is `Within` despite f32 rounding of its distance (10⁻⁷).
const REGION_SLACK: f32 = 1e-5;
/// Largest number of sample points of a field (2^24: 16 M cuts).
pub const MAX_FIELD_POINTS: u64 = 1 << 24;
/// Sample points per parallel chunk.
const CHUNK_POINTS: usize = 512;

/// Where a lookup point lies relative to the sampled region of a field.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum FieldRegion {
    /// Inside the sampled region: a true interpolation.
    Within,
    /// Closer to the object than the innermost sphere (radius clamped).
    InsideInner,
    /// Farther than the outermost sphere (radius clamped).
    BeyondOuter,
    /// Outside a proxy field's box (position clamped to the box).
    OutsideBox,
}

/// The eight neighbouring sample points of a lookup and their trilinear weights (duplicates
/// merged, so fewer when a coordinate is clamped).
#[derive(Clone, Debug, PartialEq)]
pub struct FieldLookup {
    /// `(cut index, weight)`, weights summing to 1.
    pub neighbours: Vec<(usize, f32)>,
    /// Where the point lies.
    pub region: FieldRegion,
}

impl FieldLookup {
    /// Builds the lookup from three axes of `(index0, index1, fraction)` and an index function.
    pub(crate) fn trilinear(axes: [(usize, usize, f32); 3], index: impl Fn(usize, usize, usize) -> usize, region: FieldRegion) -> Self {
        let mut neighbours: Vec<(usize, f32)> = Vec::with_capacity(8);
        for corner in 0..8 {
            let pick = |axis: usize| {
                let (i0, i1, f) = axes[axis];
                if corner >> axis & 1 == 0 { (i0, 1.0 - f) } else { (i1, f) }
            };
            let ((a, wa), (b, wb), (c, wc)) = (pick(0), pick(1), pick(2));
            let (k, w) = (index(a, b, c), wa * wb * wc);
            match neighbours.iter_mut().find(|(j, _)| *j == k) {
                Some((_, total)) => *total += w,
                None => neighbours.push((k, w)),
            }
        }
        neighbours.retain(|(_, w)| *w != 0.0);
        Self { neighbours, region }
    }

    /// The interpolated cut `Σ w_k cut_k` over `bank` (§V-A.4).
    pub fn interpolate(&self, bank: &PackedCuts) -> Result<Cut, CutsError> {
        let views: Vec<_> = self.neighbours.iter().map(|(k, _)| bank.view(*k)).collect();
        let weights: Vec<f32> = self.neighbours.iter().map(|(_, w)| *w).collect();
        weighted_sum(&views, &weights)
    }
}

/// `(index0, index1, fraction)` of continuous coordinate `x` on `n` samples at `0..n`, clamped.
pub(crate) fn clamped_axis(x: f32, n: usize) -> (usize, usize, f32) {
    if n <= 1 {
        return (0, 0, 0.0);
    }
    let x = x.clamp(0.0, (n - 1) as f32);
    let i0 = (x.floor() as usize).min(n - 2);
    (i0, i0 + 1, x - i0 as f32)
}

/// How an object's field is sampled.
#[derive(Clone, Copy, Debug, PartialEq, serde::Serialize, serde::Deserialize)]
pub struct VcfSampling {
    /// Number of concentric spheres `K`.
    pub spheres: u32,
    /// Latitude rows per sphere.
    pub rows: u32,
    /// Longitude columns per sphere.
    pub cols: u32,
    /// Innermost radius over the bounding radius (the paper: 1.2).
    pub inner_factor: f32,
    /// Outermost radius over the bounding radius (the paper: 10).
    pub outer_factor: f32,
    /// Cut threshold; 0 (the paper) keeps the visibility binary and stores 1 bit per value,
    /// above 0 values are stored in 8 bits.
    pub threshold: f32,
}

impl Default for VcfSampling {
    /// The paper's sampling: 32 spheres × 32² points from 1.2 r to 10 r (§VI).
    fn default() -> Self {
        Self { spheres: 32, rows: 32, cols: 32, inner_factor: 1.2, outer_factor: 10.0, threshold: 0.0 }
    }
}

impl VcfSampling {
    /// Checks the counts and radii.
    pub fn check(&self) -> Result<(), CutsError> {
        let bad = |field, value: String, reason| Err(CutsError::Sampling { field, value, reason });
        for (field, n) in [("vcf spheres", self.spheres), ("vcf rows", self.rows), ("vcf cols", self.cols)] {
            if n == 0 {
                return bad(field, n.to_string(), "must be at least 1");
            }
        }
        let points = self.spheres as u64 * self.rows as u64 * self.cols as u64;
        if points > MAX_FIELD_POINTS {
            return bad("vcf spheres × rows × cols", points.to_string(), "must be at most 2^24");
        }
        if !(self.inner_factor > 0.0 && self.inner_factor.is_finite()) {
            return bad("vcf inner_factor", self.inner_factor.to_string(), "must be a finite number > 0");
        }
        if !(self.outer_factor.is_finite() && (self.outer_factor > self.inner_factor || (self.spheres == 1 && self.outer_factor == self.inner_factor))) {
            return bad("vcf outer_factor", self.outer_factor.to_string(), "must be finite and above inner_factor");
        }
        check_threshold("vcf threshold", self.threshold)
    }

    /// Sample points in all.
    pub fn points(&self) -> usize {
        (self.spheres * self.rows * self.cols) as usize
    }
}

/// An object's visibility cut field, in the object's frame.
#[derive(Clone, Debug, PartialEq)]
pub struct VisibilityCutField {
    /// Centre of the bounding sphere, object frame.
    pub centre: Vec3,
    /// Bounding radius `r`, metres.
    pub radius_m: f32,
    /// The sampling.
    pub sampling: VcfSampling,
    /// One cut per sample point, index `(sphere·rows + row)·cols + col`.
    pub cuts: PackedCuts,
}

impl VisibilityCutField {
    /// Radius of sphere `k`, metres.
    pub fn sphere_radius_m(&self, k: u32) -> f32 {
        let s = &self.sampling;
        let f = if s.spheres > 1 { k as f32 / (s.spheres - 1) as f32 } else { 0.0 };
        self.radius_m * (s.inner_factor + (s.outer_factor - s.inner_factor) * f)
    }

    /// Position of sample point `(sphere, row, col)`, object frame.
    pub fn sample_point(&self, sphere: u32, row: u32, col: u32) -> Vec3 {
        self.centre + self.sphere_radius_m(sphere) * dir_from_texel_centre(col, row, self.sampling.cols, self.sampling.rows)
    }

    /// Records the field of `mesh` (§V-A.1). `progress` gets `(points done, points)`.
    pub fn compute(what: &str, mesh: &Mesh, tree: &DirectionTree, sampling: &VcfSampling, progress: Progress) -> Result<Self, CutsError> {
        check_mesh(what, mesh)?;
        sampling.check()?;
        let (centre, radius_m) = bounding_sphere(mesh).ok_or_else(|| CutsError::Mesh { what: what.to_owned(), reason: "no vertices".into() })?;
        if radius_m <= 0.0 || !radius_m.is_finite() {
            return Err(CutsError::Mesh { what: what.to_owned(), reason: "all vertices coincide (bounding radius 0)".into() });
        }
        let encoding = if sampling.threshold == 0.0 { ValueEncoding::Bits } else { ValueEncoding::Unorm8 };
        let mut field = Self { centre, radius_m, sampling: *sampling, cuts: PackedCuts::new(tree.levels(), encoding)? };
        let scene = RayScene::new(mesh.clone());
        let (rows, cols) = (sampling.rows as usize, sampling.cols as usize);
        let total = sampling.points();
        for start in (0..total).step_by(CHUNK_POINTS) {
            let end = (start + CHUNK_POINTS).min(total);
            let batch: Vec<Result<Cut, CutsError>> = (start..end)
                .into_par_iter()
                .map(|k| {
                    let (sphere, row, col) = (k / (rows * cols), k / cols % rows, k % cols);
                    let p = field.sample_point(sphere as u32, row as u32, col as u32);
                    let leaves = occlusion_leaves(&scene, tree, p, centre, radius_m);
                    Cut::from_leaves(tree.levels(), &leaves, sampling.threshold)
                })
                .collect();
            for cut in batch {
                field.cuts.push(&cut?)?;
            }
            progress(end as u64, total as u64);
        }
        Ok(field)
    }

    /// True when `p` (object frame) lies beyond the outermost sphere, as [`Self::locate`]
    /// classifies it ([`FieldRegion::BeyondOuter`]): the real receivers and the other objects'
    /// vertices leave the object out there (`super::receivers`, `super::frame`), so its field is
    /// exactly 1 beyond this reach.
    pub fn beyond_reach(&self, p: Vec3) -> bool {
        (p - self.centre).length() > self.sphere_radius_m(self.sampling.spheres - 1) * (1.0 + REGION_SLACK)
    }

    /// The neighbouring sample points of `p` (object frame) and their weights.
    pub fn locate(&self, p: Vec3) -> Result<FieldLookup, CutsError> {
        if !p.is_finite() {
            return Err(CutsError::NonFinitePoint(p.to_array()));
        }
        let s = &self.sampling;
        let q = p - self.centre;
        let rho = q.length();
        let dir = if rho > 0.0 { q / rho } else { Vec3::Y };
        let (r_in, r_out) = (self.sphere_radius_m(0), self.sphere_radius_m(s.spheres - 1));
        let region = if rho < r_in * (1.0 - REGION_SLACK) {
            FieldRegion::InsideInner
        } else if rho > r_out * (1.0 + REGION_SLACK) {
            FieldRegion::BeyondOuter
        } else {
            FieldRegion::Within
        };
        let radial = if r_out > r_in { (rho - r_in) / (r_out - r_in) * (s.spheres - 1) as f32 } else { 0.0 };
        let (x, y) = texel_from_dir(dir, s.cols, s.rows);
        let u = x - 0.5;
        let j0 = u.floor();
        let cols = s.cols as i64;
        let col = ((j0 as i64).rem_euclid(cols) as usize, (j0 as i64 + 1).rem_euclid(cols) as usize, u - j0);
        let axes = [clamped_axis(radial, s.spheres as usize), clamped_axis(y - 0.5, s.rows as usize), col];
        let (rows, cols) = (s.rows as usize, s.cols as usize);
        Ok(FieldLookup::trilinear(axes, |k, i, j| (k * rows + i) * cols + j, region))
    }

    /// The interpolated occlusion cut at `p` (object frame) and where `p` lies.
    pub fn lookup(&self, p: Vec3) -> Result<(Cut, FieldRegion), CutsError> {
        let found = self.locate(p)?;
        Ok((found.interpolate(&self.cuts)?, found.region))
    }
}

/// Binary occlusion leaves at `p` against `scene`: 0 where a ray hits, 1 elsewhere; directions
/// outside the cone of the bounding sphere `(centre, radius)` are 1 without a ray.
pub fn occlusion_leaves(scene: &RayScene, tree: &DirectionTree, p: Vec3, centre: Vec3, radius: f32) -> Vec<f32> {
    let to_centre = centre - p;
    let d = to_centre.length();
    let r = radius * (1.0 + CONE_MARGIN);
    // cos of the cone's half-angle; -1 (every direction) from inside the bounding sphere.
    let (axis, cos_cone) = if d > r { (to_centre / d, (1.0 - (r / d) * (r / d)).max(0.0).sqrt()) } else { (Vec3::Y, -1.0) };
    tree.leaf_dirs()
        .iter()
        .map(|&w| if w.dot(axis) < cos_cone || !scene.occluded(p, w, f32::MAX) { 1.0 } else { 0.0 })
        .collect()
}
