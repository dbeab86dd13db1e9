//! Light an object reflects onto itself (issue 15 §3, "objects that come close"): an extension
//! of cyberworlds Eq. 3 (`../shared/papers/cyberworlds-captured-lighting-cuts.txt` §V), whose
//! self-visibility cut `V_s` makes the object's own parts *black* occluders of its environment.
//! A statue's sphere above its sunlit pedestal then misses the light the pedestal's top
//! reflects up onto its lower half, which the traced reference (`crate::render::object_transfer`,
//! all bounces) has.
//!
//! # How it works
//! - **Gather, once per object** ([`SelfGather::from_mesh`]): at each vertex, `rays`
//!   cosine-distributed directions about its normal (strata of the unit disc lifted to the
//!   hemisphere, turned by a golden-angle offset per vertex) are cast against the object's own
//!   mesh from the self-visibility cut's ray origin (`super::svc`). A ray that meets the front of
//!   one of the object's triangles keeps its direction (the object's frame) and the hit's three
//!   vertices with their barycentric weights. The object is rigid, so this holds in every pose:
//!   nothing is traced per frame. Rays that escape, or meet a back face (inside the mesh), keep
//!   nothing: there the first pass is right (open) or the direction is dark.
//! - **Per frame** ([`SelfGather::vertex_ambient_lit`], called by
//!   `super::bounce::FrameCuts::self_bounce_rows`): each kept ray brings the radiance of its hit
//!   point. Its ambient part is the barycentric mean of the object's per-vertex outgoing
//!   radiance from the first pass without the direct sun (`super::bounce::ObjectRadiance`:
//!   `ρ/π` times the cuts' ambient), per unit `Pa` and `Pd`. Its direct sun is taken at the hit
//!   itself: `ρ/π` interpolated times `max(n·s, 0)` at the hit, zero where a shadow ray against
//!   the object's own mesh ([`SelfGather::shades`]) or the proxy (traced, or its field) meets
//!   something, times the other objects' fields at the sun's leaf. With cosine-distributed rays
//!   the irradiance about the normal is `E_n = π/M·Σ L`, and about the reflected view direction
//!   (`super::frame`'s split-sum ambient) `E_r = π/M·Σ L·max(r·ω, 0) / max(n·ω, sin 3°)`. One
//!   bounce: the hit point's radiance has no light from the object itself.
//!
//! # Limits
//! The hit's ambient is interpolated from its triangle's vertices, so it goes with every virtual
//! object's long edges split (`crate::geometry::subdivide`). The sun used to be interpolated too:
//! a pedestal top's vertices are sunlit at its corners where the sphere's shadow covers its
//! middle, so the sphere's underside got the bounce of a sunlit top. Tracing it per hit took the
//! unmoved statue from 2.22% to 1.86% against its traced transfer, its sphere's shaded underside
//! from 8.0% to 4.9% (`tests/suite/object_cuts_static.rs`; docs/measurements.md, "The sun at the
//! self-bounce's hits"). The cost is one shadow ray against the object and one against the proxy
//! per kept hit and frame that evaluates the object. `M` rays per vertex give Monte Carlo noise
//! on the bounce (not on the rest). The frame loop casts every object's gather when it loads the
//! cuts (`crate::run::motion_cuts`), and the scene loader splits every virtual object's long
//! edges.

use super::frame::VertexAmbient;
use super::lighting::MIN_BRDF_COS;
use super::svc::{SELF_RAY_OFFSET_FRACTION, bounding_sphere};
use crate::geometry::Mesh;
use crate::geometry::raycast::RayScene;
use glam::Vec3;
use rayon::prelude::*;
use std::f32::consts::PI;
use std::sync::Arc;

/// Rays per vertex of the self-bounce gather, as measured on the courtyard's two statues
/// (docs/measurements.md, "Where the two statues' error was").
pub const SELF_BOUNCE_RAYS: u32 = 64;

/// One ray of a vertex that meets the object itself.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct SelfHit {
    /// The ray's direction, object frame (cut frame).
    pub dir: Vec3,
    /// The hit triangle's vertices.
    pub vertices: [u32; 3],
    /// Their barycentric weights at the hit.
    pub weights: [f32; 3],
}

/// Per vertex, the rays that meet the object itself (module docs).
#[derive(Clone, Default)]
pub struct SelfGather {
    /// Rays cast per vertex (`M`).
    pub rays: u32,
    /// Per vertex, its rays that met the object.
    pub hits: Vec<Vec<SelfHit>>,
    /// The object's mesh in its cut frame, for the sun's shadow rays from the hits
    /// ([`Self::hit_points`]); `None` for an empty mesh.
    pub scene: Option<Arc<RayScene>>,
    /// How far a ray starts off the surface along its normal, m (the self-visibility cut's).
    pub offset_m: f32,
}

impl std::fmt::Debug for SelfGather {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.debug_struct("SelfGather").field("rays", &self.rays).field("vertices", &self.hits.len()).field("offset_m", &self.offset_m).finish()
    }
}

impl PartialEq for SelfGather {
    /// The same rays and hits (the mesh they were cast against is the object's).
    fn eq(&self, other: &Self) -> bool {
        self.rays == other.rays && self.hits == other.hits && self.offset_m == other.offset_m
    }
}

/// `k` of `m` cosine-distributed directions about `n` (the disc's strata lifted, turned by `turn`).
fn cosine_dir(n: Vec3, k: u32, m: u32, turn: f32) -> Vec3 {
    let side = (m as f32).sqrt().ceil().max(1.0) as u32;
    let (i, j) = (k % side, k / side);
    let u1 = (i as f32 + 0.5) / side as f32;
    let u2 = (j as f32 + 0.5) / (m.div_ceil(side)) as f32;
    let r = u1.sqrt();
    let phi = 2.0 * PI * u2 + turn;
    let (t, b) = n.any_orthonormal_pair();
    (t * (r * phi.cos()) + b * (r * phi.sin()) + n * (1.0 - u1).max(0.0).sqrt()).normalize()
}

impl SelfGather {
    /// The gather of `mesh` (the object at its cut frame) from its vertices with `normals`
    /// (`super::svc::SelfVisibility::normals`), `rays` per vertex. An empty mesh gathers nothing.
    pub fn from_mesh(mesh: &Mesh, normals: &[Vec3], rays: u32) -> Self {
        let Some((_, radius)) = bounding_sphere(mesh) else { return Self { rays, ..Self::default() } };
        let offset_m = (radius * SELF_RAY_OFFSET_FRACTION).max(f32::MIN_POSITIVE);
        let scene = Arc::new(RayScene::new(mesh.clone()));
        let count = mesh.positions.len().min(normals.len());
        let golden = PI * (3.0 - 5f32.sqrt());
        let hits = (0..count)
            .into_par_iter()
            .map(|v| {
                let n = normals[v];
                if rays == 0 || !n.is_finite() || n == Vec3::ZERO {
                    return Vec::new();
                }
                let origin = mesh.positions[v] + n * offset_m;
                (0..rays)
                    .filter_map(|k| {
                        let d = cosine_dir(n, k, rays, golden * v as f32);
                        let hit = scene.intersect(origin, d, f32::MAX)?;
                        let tri = mesh.triangles.get(hit.tri as usize)?;
                        if mesh.face_normal(hit.tri).dot(d) >= 0.0 || tri.iter().any(|&i| i as usize >= mesh.positions.len()) {
                            return None;
                        }
                        let (b1, b2) = (hit.bary.x.clamp(0.0, 1.0), hit.bary.y.clamp(0.0, 1.0));
                        Some(SelfHit { dir: d, vertices: *tri, weights: [(1.0 - b1 - b2).max(0.0), b1, b2] })
                    })
                    .collect()
            })
            .collect();
        Self { rays, hits, scene: Some(scene), offset_m }
    }

    /// The hits of vertex `v` as points and unit normals on the object (its cut frame): the
    /// barycentric means of `positions` and `normals` (the self-visibility cut's vertices).
    pub fn hit_points<'a>(&'a self, v: usize, positions: &'a [Vec3], normals: &'a [Vec3]) -> impl Iterator<Item = (Vec3, Vec3)> + 'a {
        self.hits.get(v).into_iter().flatten().map(move |h| {
            let (mut p, mut n) = (Vec3::ZERO, Vec3::ZERO);
            for (&i, &w) in h.vertices.iter().zip(&h.weights) {
                p += positions.get(i as usize).copied().unwrap_or(Vec3::ZERO) * w;
                n += normals.get(i as usize).copied().unwrap_or(Vec3::ZERO) * w;
            }
            (p, n.normalize_or_zero())
        })
    }

    /// Whether the object itself hides the sun (`sun`, unit, its cut frame) from the point `p`
    /// with normal `n` there; false without a mesh.
    pub fn shades(&self, p: Vec3, n: Vec3, sun: Vec3) -> bool {
        self.scene.as_ref().is_some_and(|s| s.occluded(p + n * self.offset_m, sun, f32::MAX))
    }

    /// What vertex `v` gets from the object itself (module docs): `E_n` and `E_r` per unit `Pa`
    /// (from `pa`, the object's outgoing radiance per vertex) and per unit `Pd` (from `pd`), in
    /// [`VertexAmbient`]'s rows; `n` and `r` in the object's frame.
    pub fn vertex_ambient(&self, v: usize, pa: &[Vec3], pd: &[Vec3], n: Vec3, r: Vec3) -> VertexAmbient {
        self.vertex_ambient_lit(v, pa, pd, None, n, r)
    }

    /// [`Self::vertex_ambient`] with the direct sun at each hit given apart: `lit = (ρ/π per
    /// vertex, the sun's irradiance per unit Pd at each of vertex v's hits)`, added to `pd`
    /// (which then holds the radiance without the direct sun) as `ρ/π` interpolated times the
    /// hit's own value, instead of the vertices' direct sun interpolated across the triangle.
    pub fn vertex_ambient_lit(&self, v: usize, pa: &[Vec3], pd: &[Vec3], lit: Option<(&[Vec3], &[f32])>, n: Vec3, r: Vec3) -> VertexAmbient {
        let mut out: VertexAmbient = [[0.0; 4]; 4];
        let Some(hits) = self.hits.get(v) else { return out };
        if hits.is_empty() || self.rays == 0 {
            return out;
        }
        let (mut en_a, mut er_a, mut en_d, mut er_d) = (Vec3::ZERO, Vec3::ZERO, Vec3::ZERO, Vec3::ZERO);
        for (j, h) in hits.iter().enumerate() {
            let (mut la, mut ld, mut rho) = (Vec3::ZERO, Vec3::ZERO, Vec3::ZERO);
            for (&i, &w) in h.vertices.iter().zip(&h.weights) {
                la += pa.get(i as usize).copied().unwrap_or(Vec3::ZERO) * w;
                ld += pd.get(i as usize).copied().unwrap_or(Vec3::ZERO) * w;
                if let Some((albedo, _)) = lit {
                    rho += albedo.get(i as usize).copied().unwrap_or(Vec3::ZERO) * w;
                }
            }
            if let Some((_, sun)) = lit {
                ld += rho * sun.get(j).copied().unwrap_or(0.0);
            }
            let fr = r.dot(h.dir).max(0.0) / n.dot(h.dir).max(MIN_BRDF_COS);
            en_a += la;
            er_a += la * fr;
            en_d += ld;
            er_d += ld * fr;
        }
        let k = PI / self.rays as f32;
        for (row, e) in out.iter_mut().zip([en_a, er_a, en_d, er_d]) {
            row[0] = e.x * k;
            row[1] = e.y * k;
            row[2] = e.z * k;
        }
        out
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// Triangles of the fan `centre`–`ring`, wound so that their normal points along `up`.
    fn fan(mesh: &mut Mesh, centre: u32, ring: &[u32], up: Vec3) {
        for k in 0..ring.len() {
            let mut t = [centre, ring[k], ring[(k + 1) % ring.len()]];
            let [a, b, c] = t.map(|i| mesh.positions[i as usize]);
            if (b - a).cross(c - a).dot(up) < 0.0 {
                t.swap(1, 2);
            }
            mesh.triangles.push(t);
            mesh.tri_node.push(0);
            mesh.tri_material.push(0);
        }
    }

    #[test]
    fn a_floor_next_to_a_wall_gathers_the_walls_radiance_over_half_its_hemisphere() {
        // A 10 m floor (y = 0, up) and a 10 m wall (x = 0, facing +x); the floor's vertex 1 m
        // from the wall's foot, mid-way along it.
        let mut mesh = Mesh { positions: vec![Vec3::new(1.0, 0.0, 5.0), Vec3::ZERO, Vec3::new(0.0, 0.0, 10.0), Vec3::new(10.0, 0.0, 10.0), Vec3::new(10.0, 0.0, 0.0)], ..Mesh::default() };
        fan(&mut mesh, 0, &[1, 2, 3, 4], Vec3::Y);
        let floor = mesh.clone();
        mesh.positions.extend([Vec3::new(0.0, 5.0, 5.0), Vec3::ZERO, Vec3::new(0.0, 10.0, 0.0), Vec3::new(0.0, 10.0, 10.0), Vec3::new(0.0, 0.0, 10.0)]);
        fan(&mut mesh, 5, &[6, 7, 8, 9], Vec3::X);
        let normals: Vec<Vec3> = (0..10).map(|i| if i < 5 { Vec3::Y } else { Vec3::X }).collect();
        // The floor alone sees nothing of itself.
        let alone = SelfGather::from_mesh(&floor, &normals[..5], 64);
        assert!(alone.hits.iter().all(Vec::is_empty));
        let g = SelfGather::from_mesh(&mesh, &normals, 64);
        // The wall radiates L per unit Pa and 2L per unit Pd, the floor nothing.
        let l = Vec3::new(0.2, 0.3, 0.4);
        let pa: Vec<Vec3> = (0..10).map(|i| if i < 5 { Vec3::ZERO } else { l }).collect();
        let pd: Vec<Vec3> = pa.iter().map(|p| *p * 2.0).collect();
        let e = g.vertex_ambient(0, &pa, &pd, Vec3::Y, Vec3::Y);
        // E = π·L·F; F, the cosine-weighted share of the hemisphere the wall covers, is just under
        // ½ for an infinite wall; the 10 m wall 1 m away leaves a little of it.
        let f = e[0][1] / (PI * l.y);
        assert!(f > 0.40 && f < 0.5, "share {f}");
        assert!((e[0][0] / l.x - e[0][1] / l.y).abs() < 1e-5 && (e[2][1] - 2.0 * e[0][1]).abs() < 1e-6, "{e:?}");
        // About r = n, E_r is E_n (the folded cosine divided out and put back).
        assert!((e[1][1] - e[0][1]).abs() < 1e-5 * e[0][1].max(1.0), "{e:?}");
        // A vertex with no gather gets nothing.
        assert_eq!(g.vertex_ambient(99, &pa, &pd, Vec3::Y, Vec3::Y), [[0.0; 4]; 4]);
    }
}
