//! Self-visibility cuts (SVC) of an object's vertices (cyberworlds §V, Eq. 4; §V-A.1).
//!
//! # How it works
//! At each vertex `x` with normal `n`, a ray leaves `x + ε·n` in each of the `S` tree
//! directions `ω_j` with `n·ω_j > 0` and is tested against the object itself; the leaf value is
//! `V_s(x, ω_j)·max(n·ω_j, 0)`, the self-visibility with the cosine folded in ("the product of
//! the self-visibility V_s and the cosine term is represented with V(x; ω)", §V after Eq. 4).
//! The leaves are clustered and cut at the threshold ([`super::cut`]) and stored in the
//! height-based form ([`super::packed`]), values as `[0, 1]` fixed point.
//!
//! Vertices are independent and run in parallel (rayon) in fixed chunks; each cut depends only
//! on its vertex, so the result is the same on any number of threads. The normal is the mesh's
//! when it has one per vertex, otherwise the area-weighted mean of the adjacent faces' normals;
//! a vertex on no triangle has no normal and gets the zero cut (it receives no light).

use super::cut::{Cut, check_threshold};
use super::packed::{PackedCuts, ValueEncoding};
use super::tree::DirectionTree;
use super::{CutsError, Progress};
use crate::geometry::Mesh;
use crate::geometry::raycast::RayScene;
use glam::Vec3;
use rayon::prelude::*;

/// Offset of a vertex's rays along its normal, as a fraction of the object's bounding radius:
/// 10⁻³ r is four orders above f32 rounding at that scale and below any modelled detail.
pub const SELF_RAY_OFFSET_FRACTION: f32 = 1e-3;
/// Vertices per parallel chunk (bounds the memory of unpacked cuts in flight).
const CHUNK_VERTICES: usize = 256;

/// Settings of an object's self-visibility cuts.
#[derive(Clone, Copy, Debug, PartialEq, serde::Serialize, serde::Deserialize)]
pub struct SvcSettings {
    /// Cut threshold on the cosine-folded visibility (largest deviation of a leaf from its
    /// node, in `[0, 1]` units); 0 keeps every distinct value.
    pub threshold: f32,
    /// Value encoding (values lie in `[0, 1]`).
    pub encoding: ValueEncoding,
}

impl Default for SvcSettings {
    /// Threshold 0.1: at `S = 2^15` the sweep's torus has mean cuts of 379 nodes (the paper
    /// reports 428, §VI) and its irradiance stays within 0.3 % RMS of the traced reference
    /// (0.18 % at 0.05 with 2.4× the nodes; [`super::sweep`]).
    fn default() -> Self {
        Self { threshold: 0.1, encoding: ValueEncoding::Unorm16 }
    }
}

/// The self-visibility cuts of one object, one per vertex, in the object's frame.
#[derive(Clone, Debug, PartialEq)]
pub struct SelfVisibility {
    /// Unit vertex normals used (zero for a vertex on no triangle).
    pub normals: Vec<Vec3>,
    /// One cut per vertex, in vertex order.
    pub cuts: PackedCuts,
}

/// Checks that `mesh` can carry cuts: vertices, triangles, finite positions, indices in range.
pub fn check_mesh(what: &str, mesh: &Mesh) -> Result<(), CutsError> {
    let fail = |reason: String| Err(CutsError::Mesh { what: what.to_owned(), reason });
    if mesh.positions.is_empty() {
        return fail("no vertices".into());
    }
    if mesh.triangles.is_empty() {
        return fail("no triangles".into());
    }
    if let Some(i) = mesh.positions.iter().position(|p| !p.is_finite()) {
        return fail(format!("vertex {i} is not finite ({:?})", mesh.positions[i]));
    }
    let n = mesh.positions.len() as u32;
    if let Some(t) = mesh.triangles.iter().position(|t| t.iter().any(|&i| i >= n)) {
        return fail(format!("triangle {t} refers to a vertex past the {n} vertices"));
    }
    Ok(())
}

/// Bounding sphere `(centre, radius)` of the vertices: the centre of their bounding box and the
/// largest distance from it (`None` for an empty mesh).
pub fn bounding_sphere(mesh: &Mesh) -> Option<(Vec3, f32)> {
    let (lo, hi) = mesh.bounds()?;
    let centre = 0.5 * (lo + hi);
    let radius = mesh.positions.iter().map(|p| p.distance(centre)).fold(0.0f32, f32::max);
    Some((centre, radius))
}

/// Unit vertex normals: the mesh's own when it has one per vertex, else area-weighted face
/// normals (zero for a vertex on no triangle).
pub fn vertex_normals(mesh: &Mesh) -> Vec<Vec3> {
    if mesh.normals.len() == mesh.positions.len() {
        return mesh.normals.iter().map(|n| n.normalize_or_zero()).collect();
    }
    let mut sums = vec![Vec3::ZERO; mesh.positions.len()];
    for (t, tri) in mesh.triangles.iter().enumerate() {
        let [a, b, c] = mesh.corners(t as u32);
        let weighted = (b - a).cross(c - a); // twice the area times the unit normal
        for &i in tri {
            sums[i as usize] += weighted;
        }
    }
    sums.into_iter().map(Vec3::normalize_or_zero).collect()
}

/// The cosine-folded self-visibility of one point: leaf values `V_s(x, ω_j)·max(n·ω_j, 0)`.
pub fn self_visibility_leaves(scene: &RayScene, tree: &DirectionTree, point: Vec3, normal: Vec3, offset_m: f32) -> Vec<f32> {
    let origin = point + normal * offset_m;
    tree.leaf_dirs()
        .iter()
        .map(|&d| {
            let cos = normal.dot(d);
            if cos <= 0.0 || scene.occluded(origin, d, f32::MAX) { 0.0 } else { cos }
        })
        .collect()
}

/// Self-visibility cuts of every vertex of `mesh` (§V-A.1). `progress` gets `(vertices done,
/// vertices)` after each chunk, from worker threads.
pub fn self_visibility_cuts(what: &str, mesh: &Mesh, tree: &DirectionTree, settings: &SvcSettings, progress: Progress) -> Result<SelfVisibility, CutsError> {
    check_mesh(what, mesh)?;
    check_threshold("svc threshold", settings.threshold)?;
    let (_, radius) = bounding_sphere(mesh).ok_or_else(|| CutsError::Mesh { what: what.to_owned(), reason: "no vertices".into() })?;
    let offset_m = (radius * SELF_RAY_OFFSET_FRACTION).max(f32::MIN_POSITIVE);
    let normals = vertex_normals(mesh);
    let scene = RayScene::new(mesh.clone());
    let levels = tree.levels();
    let mut cuts = PackedCuts::new(levels, settings.encoding)?;
    let total = mesh.positions.len();
    let done = std::sync::atomic::AtomicU64::new(0);
    for chunk in (0..total).collect::<Vec<_>>().chunks(CHUNK_VERTICES) {
        let batch: Vec<Result<Cut, CutsError>> = chunk
            .par_iter()
            .map(|&v| {
                let leaves = self_visibility_leaves(&scene, tree, mesh.positions[v], normals[v], offset_m);
                Cut::from_leaves(levels, &leaves, settings.threshold)
            })
            .collect();
        for cut in batch {
            cuts.push(&cut?)?;
        }
        let d = done.fetch_add(chunk.len() as u64, std::sync::atomic::Ordering::Relaxed) + chunk.len() as u64;
        progress(d, total as u64);
    }
    Ok(SelfVisibility { normals, cuts })
}
