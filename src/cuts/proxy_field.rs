//! The static real proxy's visibility on a regular grid, in cut form, so that a virtual object
//! moving under a wall loses that part of the sky (issue 15, §2; the field is the VCF idea of
//! cyberworlds §V-A.1 on a box instead of spheres).
//!
//! # How it works
//! Grid points fill a box `min..max` with `nx × ny × nz` points (corners included; a count of 1
//! puts the points on the box's lower face along that axis). At each point the leaf value is
//! the proxy's binary occlusion (0 when a ray from the point hits the proxy); the ray starts
//! [`RAY_EPSILON_M`] along its own direction so that a grid point lying on a proxy surface (a
//! box resting on the ground) does not hit that surface at `t = 0` but still sees everything
//! beyond it. A lookup interpolates the eight neighbouring cuts trilinearly (§V-A.4). A point
//! outside the box is clamped onto it and reported as [`FieldRegion::OutsideBox`] so the caller
//! can warn; a lookup never gives NaN.
//!
//! Grid points that fall inside the proxy's solids (at the `[irradiance]` spacing of 1 m the
//! courtyard's points at x = −3 m lie inside its 0.4 m wall) see nothing in any direction. A
//! lookup leaves them out and shares their weight among the other neighbours
//! ([`ProxyField::locate`]), as probe grids do with probes stuck in geometry: a point beside
//! the wall then takes the sky of the grid points on its own side instead of a blend toward
//! black (the statue at the wall's foot, 0.1–0.5 m from it, took up to 0.7 of its weight from
//! inside the wall: its wall side came out 6–15% too dark; docs/measurements.md, "Grid points
//! inside the wall"). A cut that is zero everywhere marks such a point: a point in the open
//! always sees some sky. When all the neighbours are inside (a point in the wall itself) the
//! lookup keeps them.

use super::cut::{Cut, check_threshold};
use super::packed::{PackedCuts, ValueEncoding};
use super::tree::DirectionTree;
use super::vcf::{FieldLookup, FieldRegion, MAX_FIELD_POINTS, clamped_axis};
use super::{CutsError, Progress};
use crate::geometry::raycast::{RAY_EPSILON_M, RayScene};
use glam::Vec3;
use rayon::prelude::*;

/// Grid points per parallel chunk.
const CHUNK_POINTS: usize = 512;

/// The box and grid of a proxy field.
#[derive(Clone, Copy, Debug, PartialEq, serde::Serialize, serde::Deserialize)]
pub struct ProxyGrid {
    /// Lower corner, world frame, metres.
    pub min: [f32; 3],
    /// Upper corner, world frame, metres.
    pub max: [f32; 3],
    /// Points along x, y, z (each ≥ 1).
    pub counts: [u32; 3],
    /// Cut threshold; 0 keeps the visibility binary (1 bit per value).
    pub threshold: f32,
}

impl ProxyGrid {
    /// Checks the box and the counts.
    pub fn check(&self) -> Result<(), CutsError> {
        let bad = |field, value: String, reason| Err(CutsError::Sampling { field, value, reason });
        if !self.min.iter().chain(&self.max).all(|v| v.is_finite()) {
            return bad("proxy box", format!("{:?}..{:?}", self.min, self.max), "corners must be finite");
        }
        for a in 0..3 {
            if self.counts[a] == 0 {
                return bad("proxy counts", format!("{:?}", self.counts), "each count must be at least 1");
            }
            if self.counts[a] > 1 && self.max[a] <= self.min[a] {
                return bad("proxy box", format!("{:?}..{:?}", self.min, self.max), "max must exceed min along every axis with more than one point");
            }
        }
        let points: u64 = self.counts.iter().map(|&c| c as u64).product();
        if points > MAX_FIELD_POINTS {
            return bad("proxy counts", format!("{:?}", self.counts), "at most 2^24 points");
        }
        check_threshold("proxy threshold", self.threshold)
    }

    /// Grid points in all.
    pub fn points(&self) -> usize {
        self.counts.iter().map(|&c| c as usize).product()
    }

    /// Position of grid point `(i, j, k)`.
    pub fn point(&self, ijk: [u32; 3]) -> Vec3 {
        let axis = |a: usize| {
            let n = self.counts[a];
            let f = if n > 1 { ijk[a] as f32 / (n - 1) as f32 } else { 0.0 };
            self.min[a] + (self.max[a] - self.min[a]) * f
        };
        Vec3::new(axis(0), axis(1), axis(2))
    }

    fn index(&self, i: usize, j: usize, k: usize) -> usize {
        (k * self.counts[1] as usize + j) * self.counts[0] as usize + i
    }
}

/// The proxy's visibility field, world frame.
#[derive(Clone, Debug, PartialEq)]
pub struct ProxyField {
    /// The grid.
    pub grid: ProxyGrid,
    /// One cut per grid point, index `(k·ny + j)·nx + i`.
    pub cuts: PackedCuts,
    /// Per grid point, whether it lies inside the proxy's solids ([`Self::solid`]), found once.
    solid: Vec<bool>,
}

/// Binary visibility leaves of `proxy` seen from `p` (rays start [`RAY_EPSILON_M`] along their
/// own direction).
pub fn proxy_visibility_leaves(proxy: &RayScene, tree: &DirectionTree, p: Vec3) -> Vec<f32> {
    tree.leaf_dirs().iter().map(|&w| if proxy.occluded(p + w * RAY_EPSILON_M, w, f32::MAX) { 0.0 } else { 1.0 }).collect()
}

impl ProxyField {
    /// Records the proxy's visibility on `grid`. `progress` gets `(points done, points)`.
    pub fn compute(proxy: &RayScene, tree: &DirectionTree, grid: &ProxyGrid, progress: Progress) -> Result<Self, CutsError> {
        grid.check()?;
        let encoding = if grid.threshold == 0.0 { ValueEncoding::Bits } else { ValueEncoding::Unorm8 };
        let mut cuts = PackedCuts::new(tree.levels(), encoding)?;
        let [nx, ny, _] = grid.counts.map(|c| c as usize);
        let total = grid.points();
        for start in (0..total).step_by(CHUNK_POINTS) {
            let end = (start + CHUNK_POINTS).min(total);
            let batch: Vec<Result<Cut, CutsError>> = (start..end)
                .into_par_iter()
                .map(|g| {
                    let ijk = [(g % nx) as u32, (g / nx % ny) as u32, (g / (nx * ny)) as u32];
                    let leaves = proxy_visibility_leaves(proxy, tree, grid.point(ijk));
                    Cut::from_leaves(tree.levels(), &leaves, grid.threshold)
                })
                .collect();
            for cut in batch {
                cuts.push(&cut?)?;
            }
            progress(end as u64, total as u64);
        }
        Ok(Self::new(*grid, cuts))
    }

    /// The field of `cuts` (one per point of `grid`), with its points inside the proxy found.
    pub fn new(grid: ProxyGrid, cuts: PackedCuts) -> Self {
        let solid = (0..cuts.len())
            .map(|k| {
                let v = cuts.view(k);
                (0..v.len()).all(|i| v.value(i) == 0.0)
            })
            .collect();
        Self { grid, cuts, solid }
    }

    /// The neighbouring grid points of `p` (world frame) and their weights; a point outside the
    /// box is clamped onto it ([`FieldRegion::OutsideBox`]).
    pub fn locate(&self, p: Vec3) -> Result<FieldLookup, CutsError> {
        if !p.is_finite() {
            return Err(CutsError::NonFinitePoint(p.to_array()));
        }
        let g = &self.grid;
        let (lo, hi) = (Vec3::from(g.min), Vec3::from(g.max));
        let outside = (0..3).any(|a| p[a] < lo[a] || p[a] > hi[a]);
        let axis = |a: usize| {
            let n = g.counts[a] as usize;
            let x = if n > 1 { (p[a] - lo[a]) / (hi[a] - lo[a]) * (n - 1) as f32 } else { 0.0 };
            clamped_axis(x, n)
        };
        let region = if outside { FieldRegion::OutsideBox } else { FieldRegion::Within };
        let mut found = FieldLookup::trilinear([axis(0), axis(1), axis(2)], |i, j, k| g.index(i, j, k), region);
        // Neighbours inside the proxy's solids left out, their weight shared (module docs).
        let open: f32 = found.neighbours.iter().filter(|(k, _)| !self.solid(*k)).map(|(_, w)| w).sum();
        if open > 0.0 && open < 1.0 {
            found.neighbours.retain(|(k, _)| !self.solid(*k));
            for (_, w) in &mut found.neighbours {
                *w /= open;
            }
        }
        Ok(found)
    }

    /// Whether grid point `k` lies inside the proxy: its cut is zero in every direction.
    pub fn solid(&self, k: usize) -> bool {
        self.solid.get(k).copied().unwrap_or(false)
    }

    /// The interpolated visibility cut at `p` and where `p` lies.
    pub fn lookup(&self, p: Vec3) -> Result<(Cut, FieldRegion), CutsError> {
        let found = self.locate(p)?;
        Ok((found.interpolate(&self.cuts)?, found.region))
    }
}
