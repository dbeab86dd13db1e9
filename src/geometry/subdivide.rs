//! Splitting a mesh's long edges, for attributes carried per vertex (issue 15 §3): the
//! visibility cuts (`crate::cuts`) shade a moving object from per-vertex values interpolated over
//! each triangle (Gouraud), so a large flat triangle — a box pedestal's top, two triangles under
//! a sphere — takes the sky its corners see across its middle, where the sphere hides most of
//! it, and the light it reflects onto the sphere comes from its corners too
//! (`crate::cuts::self_bounce`). Splitting its long edges gives the cuts vertices there. The
//! surface is unchanged: new vertices are edge midpoints, their normal, texture coordinates and
//! position the mean of the edge's ends.
//!
//! # How it works
//! Rounds of red–green refinement: every edge longer than the limit is marked (its length
//! depends on its two ends only, so both triangles that share it mark it, whichever indices they
//! use: no T-junctions, no cracks), and each triangle is split by its marked edges' midpoints:
//! three marked into four, two into three (the quad cut from the unmarked edge's far end), one into
//! two, keeping the winding. Rounds repeat until no edge is longer than the limit. The split is
//! planned once ([`plan`]) and applied to any mesh with the same triangles ([`apply`]: a moving
//! object's rest mesh and its mesh at the first key).
//!
//! The scene loader (`crate::scene`'s `load::virtual_objects`) splits every virtual object,
//! static or moving, with one plan made on the object in its glTF frame (edges longer than
//! [`CUTS_EDGE_FRACTION`] of its bounding radius): a static object and a moving one at the same
//! placement get the same triangles, so a motion's still frames equal the static object's bit
//! for bit (`object_motion`'s `augment_follows_the_motion_and_keeps_static_frames`). Splitting
//! only the movers broke that (docs/measurements.md, "Where the two statues' error was").

use super::Mesh;
use glam::Vec3;
use std::collections::HashMap;

/// Edges longer than this fraction of an object's bounding radius (half its box's diagonal)
/// are split for the visibility cuts: a quarter, 0.25 m for the courtyard's statue, whose
/// pedestal top (0.7 m, two triangles) becomes a 4 × 4 grid; its sphere's edges (0.06 m) are
/// left alone (1 292 → 1 536 triangles). A fraction of the object's size, so a scaled copy is
/// split alike; the value measured on the two statues (docs/measurements.md, "Self-bounce and
/// split edges on by default"). The courtyard's robot, flat boxes, goes from 396 to 1 240
/// triangles (1 188 → 2 000 vertices): little for the rasteriser, the cost is the cuts'
/// per-vertex work.
pub const CUTS_EDGE_FRACTION: f32 = 0.25;

/// Largest number of refinement rounds (each halves the longest edges).
const MAX_ROUNDS: usize = 12;

/// A planned split: new vertices as midpoints of two earlier ones, and the triangles.
#[derive(Clone, Debug, Default, PartialEq)]
pub struct Subdivision {
    /// Per new vertex (indices after the mesh's own), the two vertices it is the midpoint of.
    pub midpoints: Vec<(u32, u32)>,
    /// The triangles.
    pub triangles: Vec<[u32; 3]>,
    /// Per triangle, the mesh's triangle it lies in.
    pub source: Vec<u32>,
}

/// Half the diagonal of `mesh`'s bounding box (0 without vertices).
pub fn bounding_radius(mesh: &Mesh) -> f32 {
    let (lo, hi) = mesh.positions.iter().fold((Vec3::splat(f32::INFINITY), Vec3::splat(f32::NEG_INFINITY)), |(lo, hi), p| (lo.min(*p), hi.max(*p)));
    if mesh.positions.is_empty() { 0.0 } else { 0.5 * (hi - lo).length() }
}

/// The split of `mesh`'s edges longer than `max_edge_m` (module docs); `None` when none is,
/// or the limit is not a positive number.
pub fn plan(mesh: &Mesh, max_edge_m: f32) -> Option<Subdivision> {
    if !(max_edge_m.is_finite() && max_edge_m > 0.0) || mesh.triangles.iter().flatten().any(|&v| v as usize >= mesh.positions.len()) {
        return None;
    }
    let mut positions = mesh.positions.clone();
    let mut out = Subdivision { midpoints: Vec::new(), triangles: mesh.triangles.clone(), source: (0..mesh.triangles.len() as u32).collect() };
    let long = |p: &[Vec3], a: u32, b: u32| (p[a as usize] - p[b as usize]).length() > max_edge_m;
    for _ in 0..MAX_ROUNDS {
        if !out.triangles.iter().any(|t| (0..3).any(|e| long(&positions, t[e], t[(e + 1) % 3]))) {
            break;
        }
        let mut mids: HashMap<(u32, u32), u32> = HashMap::new();
        let (mut triangles, mut source) = (Vec::with_capacity(out.triangles.len() * 2), Vec::with_capacity(out.triangles.len() * 2));
        for (t, &src) in out.triangles.iter().zip(&out.source) {
            let marked: Vec<bool> = (0..3).map(|e| long(&positions, t[e], t[(e + 1) % 3])).collect();
            let mut mid = |a: u32, b: u32| {
                *mids.entry((a.min(b), a.max(b))).or_insert_with(|| {
                    positions.push((positions[a as usize] + positions[b as usize]) * 0.5);
                    out.midpoints.push((a, b));
                    positions.len() as u32 - 1
                })
            };
            let count = marked.iter().filter(|m| **m).count();
            let mut push = |tri: [u32; 3]| {
                triangles.push(tri);
                source.push(src);
            };
            match count {
                0 => push(*t),
                3 => {
                    let (m0, m1, m2) = (mid(t[0], t[1]), mid(t[1], t[2]), mid(t[2], t[0]));
                    push([t[0], m0, m2]);
                    push([m0, t[1], m1]);
                    push([m2, m1, t[2]]);
                    push([m0, m1, m2]);
                }
                1 => {
                    // Turned so that the marked edge is (v0, v1).
                    let e = marked.iter().position(|m| *m).unwrap_or(0);
                    let (v0, v1, v2) = (t[e], t[(e + 1) % 3], t[(e + 2) % 3]);
                    let m = mid(v0, v1);
                    push([v0, m, v2]);
                    push([m, v1, v2]);
                }
                _ => {
                    // Turned so that the unmarked edge is (v2, v0).
                    let e = (marked.iter().position(|m| !*m).unwrap_or(2) + 1) % 3;
                    let (v0, v1, v2) = (t[e], t[(e + 1) % 3], t[(e + 2) % 3]);
                    let (m0, m1) = (mid(v0, v1), mid(v1, v2));
                    push([m0, v1, m1]);
                    push([v0, m0, m1]);
                    push([v0, m1, v2]);
                }
            }
        }
        out.triangles = triangles;
        out.source = source;
    }
    (!out.midpoints.is_empty()).then_some(out)
}

/// `mesh` with the split `plan` (made on a mesh with the same triangles) applied: midpoints'
/// positions, normals (normalised) and texture coordinates the mean of their ends', each new
/// triangle its source triangle's node and material.
pub fn apply(mesh: &Mesh, plan: &Subdivision) -> Mesh {
    let mut out = mesh.clone();
    let normals = out.normals.len() == out.positions.len();
    let uvs = out.uvs.len() == out.positions.len();
    for &(a, b) in &plan.midpoints {
        let (a, b) = (a as usize, b as usize);
        out.positions.push((out.positions[a] + out.positions[b]) * 0.5);
        if normals {
            let n = out.normals[a] + out.normals[b];
            out.normals.push(n.try_normalize().unwrap_or(out.normals[a]));
        }
        if uvs {
            out.uvs.push((out.uvs[a] + out.uvs[b]) * 0.5);
        }
    }
    out.triangles = plan.triangles.clone();
    let pick = |v: &[u32]| plan.source.iter().map(|&s| v.get(s as usize).copied().unwrap_or(0)).collect::<Vec<u32>>();
    out.tri_node = pick(&mesh.tri_node);
    out.tri_material = pick(&mesh.tri_material);
    out
}

#[cfg(test)]
mod tests {
    use super::*;
    use glam::Vec2;

    fn square() -> Mesh {
        Mesh {
            positions: vec![Vec3::ZERO, Vec3::X, Vec3::new(1.0, 0.0, 1.0), Vec3::Z, Vec3::X, Vec3::new(1.0, -1.0, 0.0)],
            normals: vec![Vec3::Y; 6],
            uvs: vec![Vec2::ZERO, Vec2::X, Vec2::ONE, Vec2::Y, Vec2::X, Vec2::ONE],
            // Two triangles of the top and one of a side that shares the edge (0,0,0)-(1,0,0)
            // through other indices (a non-indexed mesh).
            triangles: vec![[0, 2, 1], [0, 3, 2], [4, 5, 0]],
            tri_node: vec![0, 0, 1],
            tri_material: vec![0, 0, 1],
            ..Mesh::default()
        }
    }

    #[test]
    fn long_edges_split_everywhere_they_are_shared_and_the_surface_is_kept() {
        let m = square();
        let p = plan(&m, 0.3).unwrap();
        let s = apply(&m, &p);
        // Every edge is within the limit, and the area and winding are those of the source.
        for t in 0..s.triangles.len() as u32 {
            let [a, b, c] = s.corners(t);
            assert!((b - a).length() <= 0.3 && (c - b).length() <= 0.3 && (a - c).length() <= 0.3);
            let src = p.source[t as usize];
            assert!(s.face_normal(t).dot(m.face_normal(src)) > 0.999, "winding of {t}");
        }
        for src in 0..3u32 {
            let area: f32 = (0..s.triangles.len()).filter(|&t| p.source[t] == src).map(|t| s.double_area(t as u32)).sum();
            assert!((area - m.double_area(src)).abs() < 1e-5, "area of {src}: {area}");
        }
        // No T-junction: every vertex lying on an edge of another triangle is one of its ends
        // (the shared edge is split at the same points from both sides).
        for t in 0..s.triangles.len() as u32 {
            let [a, b, c] = s.corners(t);
            for (u, v) in [(a, b), (b, c), (c, a)] {
                for q in &s.positions {
                    let (d, l) = (*q - u, v - u);
                    let k = d.dot(l) / l.length_squared();
                    let inside = k > 1e-4 && k < 1.0 - 1e-4 && (d - l * k).length() < 1e-6;
                    assert!(!inside, "T-junction: edge {u}-{v} of triangle {t} passes through vertex {q}");
                }
            }
        }
        // Attributes are the mean of the ends; materials follow the source triangle.
        assert!(s.uvs.iter().zip(&s.positions).all(|(uv, q)| q.y < -1e-6 || (uv.x - q.x).abs() < 1e-6));
        assert!(s.normals.iter().all(|n| (n.length() - 1.0).abs() < 1e-6));
        assert!(s.tri_material.iter().zip(&p.source).all(|(m, src)| *m == m_of(*src)));
        assert!(plan(&m, 2.0).is_none() && plan(&m, f32::NAN).is_none());
    }

    fn m_of(src: u32) -> u32 {
        [0, 0, 1][src as usize]
    }
}
