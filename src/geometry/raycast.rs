//! Ray casts against a [`Mesh`] through parry3d's BVH.
//!
//! Surfaces are two-sided: a hit reports the geometric normal turned toward the ray's origin.
//! Degenerate triangles (zero area) are left out of the BVH; [`RayScene::skipped_degenerate`]
//! says how many.

use super::Mesh;
use glam::{Vec2, Vec3};
use parry3d::query::{Ray, RayCast};
use parry3d::shape::TriMesh;

/// Offset (metres) applied along the normal to the origin of secondary rays so that they do not
/// hit the surface they leave. 1 mm is far above f32 precision at the scale of a courtyard
/// (≈ 2 µm at 20 m) and below any proxy detail.
pub const RAY_EPSILON_M: f32 = 1e-3;
/// Angle (radians) by which [`RayScene::intersect_front`] turns a ray that hit a back face: far
/// above the float noise of an edge test, far below a pixel.
pub const CRACK_NUDGE_RAD: f32 = 1e-4;

/// A first hit.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Hit {
    /// Distance along the (unit) ray.
    pub t: f32,
    /// Triangle index in the [`Mesh`].
    pub tri: u32,
    /// Hit point, world frame.
    pub point: Vec3,
    /// Unit geometric normal turned toward the ray origin.
    pub normal: Vec3,
    /// Barycentric weights of corners 1 and 2.
    pub bary: Vec2,
}

/// A mesh with a BVH for ray casts.
pub struct RayScene {
    mesh: Mesh,
    bvh: Option<TriMesh>,
    /// BVH triangle → mesh triangle.
    map: Vec<u32>,
    normals: Vec<Vec3>,
    skipped: usize,
}

impl std::fmt::Debug for RayScene {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.debug_struct("RayScene").field("triangles", &self.map.len()).field("skipped_degenerate", &self.skipped).finish()
    }
}

impl RayScene {
    /// Builds the BVH. Zero-area triangles are skipped (counted), never an error.
    pub fn new(mesh: Mesh) -> Self {
        let normals: Vec<Vec3> = (0..mesh.triangles.len() as u32).map(|t| mesh.face_normal(t)).collect();
        let mut map = Vec::with_capacity(mesh.triangles.len());
        let mut tris = Vec::with_capacity(mesh.triangles.len());
        for (i, t) in mesh.triangles.iter().enumerate() {
            if normals[i] != Vec3::ZERO && mesh.double_area(i as u32) > 1e-10 {
                map.push(i as u32);
                tris.push(*t);
            }
        }
        let skipped = mesh.triangles.len() - map.len();
        let bvh = if tris.is_empty() { None } else { TriMesh::new(mesh.positions.clone(), tris).ok() };
        Self { mesh, bvh, map, normals, skipped }
    }

    /// The mesh.
    pub fn mesh(&self) -> &Mesh {
        &self.mesh
    }

    /// Triangles left out because they have no area.
    pub fn skipped_degenerate(&self) -> usize {
        self.skipped
    }

    /// Unit geometric normal of mesh triangle `tri` (winding order, not turned).
    pub fn face_normal(&self, tri: u32) -> Vec3 {
        self.normals[tri as usize]
    }

    /// The first hit along `origin + t·dir`, `0 < t ≤ t_max`; `dir` must be unit length.
    pub fn intersect(&self, origin: Vec3, dir: Vec3, t_max: f32) -> Option<Hit> {
        let bvh = self.bvh.as_ref()?;
        let ray = Ray::new(origin, dir);
        let hit = bvh.cast_local_ray_and_get_normal(&ray, t_max, false)?;
        let tri = self.map[hit.subshape as usize];
        let point = origin + dir * hit.time_of_impact;
        let n = self.normals[tri as usize];
        let normal = if n.dot(dir) > 0.0 { -n } else { n };
        Some(Hit { t: hit.time_of_impact, tri, point, normal, bary: self.barycentric(tri, point) })
    }

    /// The first hit along `origin + t·dir` (unit `dir`), looked at again along a ray turned by
    /// [`CRACK_NUDGE_RAD`] when it is the back of a triangle: either a ray that slipped through
    /// the shared edge of two triangles (parry's ray–triangle test is not watertight) and hit the
    /// far side from inside, or an open mesh seen from behind, which the turned ray hits again.
    pub fn intersect_front(&self, origin: Vec3, dir: Vec3) -> Option<Hit> {
        let hit = self.intersect(origin, dir, f32::MAX)?;
        if self.face_normal(hit.tri).dot(dir) <= 0.0 {
            return Some(hit);
        }
        let nudge = dir.any_orthonormal_vector() * CRACK_NUDGE_RAD;
        self.intersect(origin, (dir + nudge).normalize(), f32::MAX)
    }

    /// True when anything lies along `origin + t·dir`, `0 < t ≤ t_max`.
    pub fn occluded(&self, origin: Vec3, dir: Vec3, t_max: f32) -> bool {
        match &self.bvh {
            Some(bvh) => bvh.intersects_local_ray(&Ray::new(origin, dir), t_max),
            None => false,
        }
    }

    /// True when the point `p` with facing normal `n` sees the direction `l` unobstructed (a
    /// directional light: the ray goes to infinity).
    pub fn sees_direction(&self, p: Vec3, n: Vec3, l: Vec3) -> bool {
        !self.occluded(p + n * RAY_EPSILON_M, l, f32::MAX)
    }

    /// Of the rays from `p` along `dirs` that hit something, the fraction whose first hit is the
    /// back of a triangle (its winding normal points along the ray). Near 1 inside a closed mesh,
    /// 0 outside; `None` when no ray hits anything.
    pub fn back_face_fraction(&self, p: Vec3, dirs: &[Vec3]) -> Option<f32> {
        let (mut hits, mut back) = (0u32, 0u32);
        for &d in dirs {
            if let Some(h) = self.intersect(p, d, f32::MAX) {
                hits += 1;
                back += (self.normals[h.tri as usize].dot(d) > 0.0) as u32;
            }
        }
        (hits > 0).then(|| back as f32 / hits as f32)
    }

    /// Barycentric weights (corners 1 and 2) of point `p` on triangle `tri`.
    pub fn barycentric(&self, tri: u32, p: Vec3) -> Vec2 {
        let [a, b, c] = self.mesh.corners(tri);
        let (e1, e2, ep) = (b - a, c - a, p - a);
        let (d11, d12, d22) = (e1.dot(e1), e1.dot(e2), e2.dot(e2));
        let (dp1, dp2) = (ep.dot(e1), ep.dot(e2));
        let det = d11 * d22 - d12 * d12;
        if det.abs() < 1e-20 {
            return Vec2::ZERO;
        }
        Vec2::new((d22 * dp1 - d12 * dp2) / det, (d11 * dp2 - d12 * dp1) / det)
    }

    /// Albedo at a hit.
    pub fn albedo(&self, hit: &Hit) -> Vec3 {
        self.mesh.albedo(hit.tri, hit.bary)
    }

    /// Whether the triangle's node is a marked diffuse estimation surface.
    pub fn is_diffuse(&self, tri: u32) -> bool {
        self.mesh.nodes[self.mesh.tri_node[tri as usize] as usize].diffuse
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::geometry::{Material, NodeInfo};

    pub(crate) fn quad(y: f32, half: f32) -> Mesh {
        Mesh {
            positions: vec![
                Vec3::new(-half, y, -half),
                Vec3::new(-half, y, half),
                Vec3::new(half, y, half),
                Vec3::new(half, y, -half),
            ],
            normals: vec![],
            uvs: vec![Vec2::ZERO; 4],
            triangles: vec![[0, 1, 2], [0, 2, 3], [1, 1, 2]],
            tri_node: vec![0; 3],
            tri_material: vec![0; 3],
            nodes: vec![NodeInfo { name: "ground".into(), diffuse: true }],
            materials: vec![Material { base_color: [0.5, 0.25, 0.125, 1.0], ..Default::default() }],
            textures: vec![],
        }
    }

    #[test]
    fn hits_from_both_sides_with_facing_normal() {
        let scene = RayScene::new(quad(0.0, 1.0));
        assert_eq!(scene.skipped_degenerate(), 1);
        let h = scene.intersect(Vec3::new(0.2, 2.0, 0.1), Vec3::NEG_Y, 10.0).unwrap();
        assert!((h.t - 2.0).abs() < 1e-5 && (h.normal - Vec3::Y).length() < 1e-6);
        let h = scene.intersect(Vec3::new(0.2, -3.0, 0.1), Vec3::Y, 10.0).unwrap();
        assert!((h.t - 3.0).abs() < 1e-5 && (h.normal - Vec3::NEG_Y).length() < 1e-6);
        assert!(scene.intersect(Vec3::new(5.0, 2.0, 0.0), Vec3::NEG_Y, 10.0).is_none());
        assert!(scene.intersect(Vec3::new(0.0, 2.0, 0.0), Vec3::NEG_Y, 1.5).is_none());
        assert_eq!(scene.albedo(&h), Vec3::new(0.5, 0.25, 0.125));
        let p = scene.mesh().corners(h.tri);
        let b = h.bary;
        let back = p[0] * (1.0 - b.x - b.y) + p[1] * b.x + p[2] * b.y;
        assert!((back - h.point).length() < 1e-5);
    }

    #[test]
    fn shadow_rays() {
        let mut m = quad(0.0, 10.0);
        m.append(&quad(1.0, 0.5));
        let scene = RayScene::new(m);
        assert!(!scene.sees_direction(Vec3::ZERO, Vec3::Y, Vec3::Y));
        assert!(scene.sees_direction(Vec3::new(3.0, 0.0, 0.0), Vec3::Y, Vec3::Y));
        // Grazing: a direction in the plane of the surface does not hit it.
        assert!(scene.sees_direction(Vec3::new(3.0, 0.0, 0.0), Vec3::Y, Vec3::X));
    }
}
