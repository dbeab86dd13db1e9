//! Shadow volumes of a directional sun, built on the CPU (rayon).
//!
//! # How it works
//! (Jensen §3.2 steps 1–2; Crow 1977; Everitt & Kilgard 2002.) For a closed component, a face is
//! *lit* when `n·l > 0` and *dark* otherwise (a face exactly parallel to the sun, or of zero area,
//! is dark, so every face has one class and the volume stays closed). A silhouette edge joins a
//! lit and a dark face. The volume is the region swept from the dark side away from the sun:
//!
//! - the dark faces, with their winding reversed (so the volume's faces point outward), as the
//!   cap;
//! - one side triangle `(a, b, L∞)` per silhouette edge, with `a → b` as the edge runs in its
//!   dark face and `L∞ = (−l, 0)` the point at infinity away from the sun. For a directional
//!   light every edge's far end is that one point, so each side is a triangle and the far cap
//!   degenerates to the point itself: nothing to draw.
//!
//! Capping with the dark faces (not the lit ones) puts the only coplanar volume faces on surfaces
//! that face away from the sun, where a tie in the depth test changes nothing (their sun term is
//! zero anyway).
//!
//! Open or non-manifold components get a closed prism per triangle: the triangle, moved by
//! `cap_offset_m` along its normal to the side away from the sun and wound toward the sun, plus
//! its three sides. The offset keeps the triangle's own lit side out of its prism despite depth
//! precision; a triangle parallel to the sun casts nothing.
//!
//! Vertices are homogeneous (`w = 0` at infinity); triangles come out as a flat list.

use super::occluder::Occluder;
use glam::Vec3;

/// A homogeneous vertex `[x, y, z, w]` (mirrors the `vec4<f32>` vertex of `shaders/shadow_volume.wgsl`).
pub type HVertex = [f32; 4];
use rayon::prelude::*;

/// Default cap offset of per-triangle volumes, metres: far above the depth resolution of either
/// depth format at courtyard distances (24-bit reversed depth resolves ≈ 1.2 mm at 20 m) and
/// below any proxy detail.
pub const OPEN_CAP_OFFSET_M: f32 = 5e-3;
/// Work items per rayon task.
const CHUNK: usize = 4096;

/// The point at infinity away from the sun.
#[inline]
fn at_infinity(sun: Vec3) -> HVertex {
    [-sun.x, -sun.y, -sun.z, 0.0]
}

/// Which faces are lit (`n·l > 0`).
pub fn lit_faces(occ: &Occluder, sun: Vec3) -> Vec<bool> {
    occ.normals.par_iter().map(|n| n.dot(sun) > 0.0).collect()
}

/// Which parts to build: all, or a subset of components.
#[derive(Clone, Copy, Debug)]
pub enum Parts<'a> {
    /// Every component.
    All,
    /// Only these component indices.
    Only(&'a [usize]),
}

/// Appends the volume triangles of `occ` for the sun direction `sun` (unit, toward the sun) to
/// `out`. Returns the number of triangles appended.
pub fn build(occ: &Occluder, sun: Vec3, cap_offset_m: f32, parts: Parts, out: &mut Vec<HVertex>) -> usize {
    let before = out.len();
    let lit = lit_faces(occ, sun);
    let inf = at_infinity(sun);
    let p = |i: u32| occ.positions[i as usize].extend(1.0).to_array();
    let comps: Vec<usize> = match parts {
        Parts::All => (0..occ.components.len()).collect(),
        Parts::Only(c) => c.iter().copied().filter(|&c| c < occ.components.len()).collect(),
    };
    for c in comps {
        let comp = &occ.components[c];
        if comp.closed {
            let sides: Vec<HVertex> = occ.edges[comp.edges.clone()]
                .par_chunks(CHUNK)
                .flat_map_iter(|chunk| {
                    chunk.iter().filter_map(|e| {
                        let (l0, l1) = (lit[e.f0 as usize], lit[e.f1 as usize]);
                        (l0 != l1).then(|| if l0 { [p(e.b), p(e.a), inf] } else { [p(e.a), p(e.b), inf] })
                    })
                    .flatten()
                })
                .collect();
            out.extend(sides);
            let faces = comp.faces.clone();
            let caps: Vec<HVertex> = faces
                .into_par_iter()
                .with_min_len(CHUNK)
                .filter(|&f| !lit[f])
                .flat_map_iter(|f| {
                    let [a, b, c] = occ.faces[f];
                    [p(c), p(b), p(a)]
                })
                .collect();
            out.extend(caps);
        } else {
            let prisms: Vec<HVertex> = comp
                .faces
                .clone()
                .into_par_iter()
                .with_min_len(CHUNK)
                .flat_map_iter(|f| prism(occ, f, sun, cap_offset_m, inf).into_iter().flatten())
                .collect();
            out.extend(prisms);
        }
    }
    (out.len() - before) / 3
}

/// The closed prism of face `f` (4 triangles), or nothing when the face is parallel to the sun.
fn prism(occ: &Occluder, f: usize, sun: Vec3, offset: f32, inf: HVertex) -> Option<[HVertex; 12]> {
    let n = occ.normals[f];
    let d = n.dot(sun);
    if d == 0.0 {
        return None;
    }
    let shift = -d.signum() * offset * n;
    let [a, b, c] = occ.faces[f].map(|i| (occ.positions[i as usize] + shift).extend(1.0).to_array());
    // Cap wound toward the sun.
    let (p0, p1, p2) = if d > 0.0 { (a, b, c) } else { (a, c, b) };
    Some([p0, p1, p2, p1, p0, inf, p2, p1, inf, p0, p2, inf])
}

/// Upper bound of the triangles [`build`] can produce for `occ` (for GPU buffer sizes).
pub fn max_triangles(occ: &Occluder) -> usize {
    occ.edges.len() + occ.closed_faces + 4 * (occ.faces.len() - occ.closed_faces)
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::render::occluder::tests::closed_box;

    /// Replaces points at infinity by far points so ordinary geometry can test the volume.
    fn finite(v: HVertex) -> Vec3 {
        let p = Vec3::new(v[0], v[1], v[2]);
        if v[3] == 0.0 { p * 1e4 } else { p }
    }

    /// Signed crossings of the ray `o + t·d` with the volume: +1 leaving through a face (the ray
    /// along its outward normal), −1 entering. Inside a closed volume the sum is 1, outside 0.
    fn winding(tris: &[HVertex], o: Vec3, d: Vec3) -> i32 {
        let mut w = 0;
        for t in tris.chunks(3) {
            let (a, b, c) = (finite(t[0]), finite(t[1]), finite(t[2]));
            let (e1, e2) = (b - a, c - a);
            let pv = d.cross(e2);
            let det = e1.dot(pv);
            if det.abs() < 1e-12 {
                continue;
            }
            let s = o - a;
            let u = s.dot(pv) / det;
            let q = s.cross(e1);
            let v = d.dot(q) / det;
            let tt = e2.dot(q) / det;
            if u < 0.0 || v < 0.0 || u + v > 1.0 || tt <= 0.0 {
                continue;
            }
            w += if e1.cross(e2).dot(d) > 0.0 { 1 } else { -1 };
        }
        w
    }

    fn sun() -> Vec3 {
        Vec3::new(-0.486, 0.756, 0.437).normalize()
    }

    #[test]
    fn closed_box_volume_is_closed_outward_and_covers_the_shadow() {
        let occ = Occluder::new(&closed_box(Vec3::new(0.0, 1.0, 0.0), Vec3::new(1.0, 2.0, 1.0)), "box");
        let mut tris = Vec::new();
        let n = build(&occ, sun(), OPEN_CAP_OFFSET_M, Parts::All, &mut tris);
        assert_eq!(n * 3, tris.len());
        // A box against a generic sun: 3 dark faces (6 triangles) and a silhouette of 6 edges.
        assert_eq!(n, 6 + 6);
        // Directed edges cancel (the surface is closed and consistently wound).
        let mut edges: Vec<([u32; 4], [u32; 4])> = Vec::new();
        for t in tris.chunks(3) {
            for k in 0..3 {
                edges.push((t[k].map(f32::to_bits), t[(k + 1) % 3].map(f32::to_bits)));
            }
        }
        for (a, b) in &edges {
            assert!(edges.contains(&(*b, *a)), "unmatched edge");
        }
        let dir = Vec3::new(0.31, 0.22, -0.93).normalize(); // generic ray direction
        // Behind the box (away from the sun): inside. Beside it, and in front of it: outside.
        let behind = Vec3::new(0.5, 1.5, 0.5) - sun() * 2.0;
        assert_eq!(winding(&tris, behind, dir), 1);
        assert_eq!(winding(&tris, Vec3::new(3.0, 0.5, 0.5), dir), 0);
        assert_eq!(winding(&tris, Vec3::new(0.5, 1.5, 0.5) + sun() * 2.0, dir), 0);
        // The box's interior is not part of the volume (capped with the dark side).
        assert_eq!(winding(&tris, Vec3::new(0.5, 1.5, 0.5), dir), 0);
    }

    #[test]
    fn per_triangle_prisms_and_a_face_parallel_to_the_sun() {
        // An open quad (two triangles) facing up: two prisms below it.
        let mut m = crate::geometry::Mesh::default();
        let mat = m.add_material(crate::geometry::Material::diffuse("g", [0.5; 3]));
        let node = m.add_node("sheet", false);
        m.push_quad(Vec3::new(0.0, 1.0, 0.0), Vec3::Z, Vec3::X, node, mat);
        let occ = Occluder::new(&m, "sheet");
        assert!(!occ.components[0].closed);
        let mut tris = Vec::new();
        assert_eq!(build(&occ, sun(), OPEN_CAP_OFFSET_M, Parts::All, &mut tris), 8);
        let dir = Vec3::new(0.31, 0.22, -0.93).normalize();
        assert_eq!(winding(&tris, Vec3::new(0.3, 1.0, 0.6) - sun(), dir), 1);
        // The sheet itself is outside its prisms (the cap is moved below it).
        assert_eq!(winding(&tris, Vec3::new(0.3, 1.0, 0.6), dir), 0);
        // Sun exactly in the sheet's plane: no volume at all.
        let mut none = Vec::new();
        assert_eq!(build(&occ, Vec3::X, OPEN_CAP_OFFSET_M, Parts::All, &mut none), 0);
    }
}
