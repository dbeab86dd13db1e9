//! Triangle meshes in the world frame, ray casts against the real proxy, and the light-transport
//! integrals the estimator and the bake share.
//!
//! - [`Mesh`]: indexed triangles with per-triangle node and material, as loaded from glTF.
//! - [`raycast::RayScene`]: a BVH over a mesh (parry3d) for first-hit and shadow rays.
//! - [`ambient`]: weighted-ambient factor `c` and sun bounce `b` by path tracing.
//! - [`sampling`]: hemisphere sampling used by the integrals.
//! - [`brdf`]: the glTF metallic–roughness BRDF with importance sampling (the virtual objects'
//!   path-traced ambient transfer).

pub mod ambient;
pub mod brdf;
pub mod equirect;
pub mod proxy_light;
pub mod raycast;
pub mod sampling;
pub mod subdivide;

use glam::{Vec2, Vec3};

/// A material: the glTF metallic–roughness parameters heliar uses.
#[derive(Clone, Debug, PartialEq)]
pub struct Material {
    /// Name in the glTF file (may be empty).
    pub name: String,
    /// Linear base colour factor (RGBA). For the real proxy this is the diffuse albedo.
    pub base_color: [f32; 4],
    /// Index into [`Mesh::textures`] of the base-colour texture, if any.
    pub base_color_texture: Option<u32>,
    /// Metallic factor.
    pub metallic: f32,
    /// Perceptual roughness factor.
    pub roughness: f32,
}

impl Material {
    /// A rough dielectric of linear albedo `rgb` (the kind of material a real proxy has).
    pub fn diffuse(name: &str, rgb: [f32; 3]) -> Self {
        Self { name: name.to_owned(), base_color: [rgb[0], rgb[1], rgb[2], 1.0], base_color_texture: None, metallic: 0.0, roughness: 1.0 }
    }
}

impl Default for Material {
    fn default() -> Self {
        // The glTF default material.
        Self { name: String::new(), base_color: [1.0; 4], base_color_texture: None, metallic: 1.0, roughness: 1.0 }
    }
}

/// A texture decoded to linear RGB.
#[derive(Clone, Debug, PartialEq)]
pub struct Texture {
    /// Width in texels.
    pub width: u32,
    /// Height in texels.
    pub height: u32,
    /// Linear RGB texels, row-major.
    pub data: Vec<[f32; 3]>,
}

impl Texture {
    /// Bilinear lookup with repeat wrapping; `uv` in glTF convention (v down).
    pub fn sample(&self, uv: Vec2) -> Vec3 {
        let x = uv.x * self.width as f32 - 0.5;
        let y = uv.y * self.height as f32 - 0.5;
        let (x0, y0) = (x.floor(), y.floor());
        let (fx, fy) = (x - x0, y - y0);
        let at = |i: f32, j: f32| {
            let i = (i as i64).rem_euclid(self.width as i64) as usize;
            let j = (j as i64).rem_euclid(self.height as i64) as usize;
            Vec3::from(self.data[j * self.width as usize + i])
        };
        let top = at(x0, y0) * (1.0 - fx) + at(x0 + 1.0, y0) * fx;
        let bottom = at(x0, y0 + 1.0) * (1.0 - fx) + at(x0 + 1.0, y0 + 1.0) * fx;
        top * (1.0 - fy) + bottom * fy
    }
}

/// A glTF node that owns triangles.
#[derive(Clone, Debug, PartialEq)]
pub struct NodeInfo {
    /// Node name (or `node<index>` when unnamed).
    pub name: String,
    /// Marked as a diffuse estimation surface.
    pub diffuse: bool,
}

/// Indexed triangles in world coordinates with per-triangle node and material.
#[derive(Clone, Debug, Default, PartialEq)]
pub struct Mesh {
    /// Vertex positions, world frame, metres.
    pub positions: Vec<Vec3>,
    /// Vertex normals (world frame) when the file has them; empty otherwise.
    pub normals: Vec<Vec3>,
    /// Texture coordinates (set 0), one per vertex; zeros when the file has none.
    pub uvs: Vec<Vec2>,
    /// Triangles as vertex indices, counter-clockwise seen from the front.
    pub triangles: Vec<[u32; 3]>,
    /// Node index (into `nodes`) of each triangle.
    pub tri_node: Vec<u32>,
    /// Material index (into `materials`) of each triangle.
    pub tri_material: Vec<u32>,
    /// Nodes that own triangles.
    pub nodes: Vec<NodeInfo>,
    /// Materials.
    pub materials: Vec<Material>,
    /// Textures.
    pub textures: Vec<Texture>,
}

impl Mesh {
    /// The three corners of triangle `t`.
    #[inline]
    pub fn corners(&self, t: u32) -> [Vec3; 3] {
        let [a, b, c] = self.triangles[t as usize];
        [self.positions[a as usize], self.positions[b as usize], self.positions[c as usize]]
    }

    /// Unit geometric normal of triangle `t` (from its winding); zero for a degenerate triangle.
    pub fn face_normal(&self, t: u32) -> Vec3 {
        let [a, b, c] = self.corners(t);
        (b - a).cross(c - a).normalize_or_zero()
    }

    /// Twice the area of triangle `t`.
    pub fn double_area(&self, t: u32) -> f32 {
        let [a, b, c] = self.corners(t);
        (b - a).cross(c - a).length()
    }

    /// Linear diffuse albedo (base colour) of triangle `t` at barycentric coordinates `bary`
    /// (weights of corners 1 and 2).
    pub fn albedo(&self, t: u32, bary: Vec2) -> Vec3 {
        let m = &self.materials[self.tri_material[t as usize] as usize];
        let factor = Vec3::new(m.base_color[0], m.base_color[1], m.base_color[2]);
        match m.base_color_texture {
            Some(tex) => {
                let [a, b, c] = self.triangles[t as usize];
                let uv = self.uvs[a as usize] * (1.0 - bary.x - bary.y)
                    + self.uvs[b as usize] * bary.x
                    + self.uvs[c as usize] * bary.y;
                factor * self.textures[tex as usize].sample(uv)
            }
            None => factor,
        }
    }

    /// Axis-aligned bounds `(min, max)`; `None` for an empty mesh.
    pub fn bounds(&self) -> Option<(Vec3, Vec3)> {
        let mut it = self.positions.iter();
        let first = *it.next()?;
        Some(it.fold((first, first), |(lo, hi), p| (lo.min(*p), hi.max(*p))))
    }

    /// Adds a node and returns its index.
    pub fn add_node(&mut self, name: &str, diffuse: bool) -> u32 {
        self.nodes.push(NodeInfo { name: name.to_owned(), diffuse });
        self.nodes.len() as u32 - 1
    }

    /// Adds a material and returns its index.
    pub fn add_material(&mut self, material: Material) -> u32 {
        self.materials.push(material);
        self.materials.len() as u32 - 1
    }

    /// Appends the parallelogram `o, o+u, o+u+v, o+v` as two triangles facing `u × v`.
    pub fn push_quad(&mut self, o: Vec3, u: Vec3, v: Vec3, node: u32, material: u32) {
        let v0 = self.positions.len() as u32;
        self.positions.extend([o, o + u, o + u + v, o + v]);
        if !self.normals.is_empty() {
            self.normals.extend([u.cross(v).normalize_or_zero(); 4]);
        }
        self.uvs.extend([Vec2::ZERO, Vec2::X, Vec2::ONE, Vec2::Y]);
        self.triangles.extend([[v0, v0 + 1, v0 + 2], [v0, v0 + 2, v0 + 3]]);
        self.tri_node.extend([node, node]);
        self.tri_material.extend([material, material]);
    }

    /// Appends an axis-aligned box `lo..hi` with outward-facing triangles; the bottom face is left
    /// out when `open_bottom` (a building standing on the ground).
    pub fn push_box(&mut self, lo: Vec3, hi: Vec3, node: u32, material: u32, open_bottom: bool) {
        let d = hi - lo;
        let (x, y, z) = (Vec3::X * d.x, Vec3::Y * d.y, Vec3::Z * d.z);
        self.push_quad(Vec3::new(hi.x, lo.y, lo.z), y, z, node, material); // +X
        self.push_quad(lo, z, y, node, material); // -X
        self.push_quad(Vec3::new(lo.x, hi.y, lo.z), z, x, node, material); // +Y
        if !open_bottom {
            self.push_quad(lo, x, z, node, material); // -Y
        }
        self.push_quad(Vec3::new(lo.x, lo.y, hi.z), x, y, node, material); // +Z
        self.push_quad(lo, y, x, node, material); // -Z
    }

    /// Appends a closed torus of `2·rings·segments` outward-facing triangles around +Y at
    /// `centre` (tube radius `minor` at distance `major` from the axis): a smooth, closed test
    /// object whose triangle count is set by `rings` and `segments`.
    pub fn push_torus(&mut self, centre: Vec3, major: f32, minor: f32, rings: u32, segments: u32, node: u32, material: u32) {
        let base = self.positions.len() as u32;
        for i in 0..rings {
            let u = i as f32 / rings as f32 * std::f32::consts::TAU;
            for j in 0..segments {
                let v = j as f32 / segments as f32 * std::f32::consts::TAU;
                let r = major + minor * v.cos();
                self.positions.push(centre + Vec3::new(r * u.cos(), minor * v.sin(), r * u.sin()));
                self.uvs.push(Vec2::ZERO);
            }
        }
        let idx = |i: u32, j: u32| base + (i % rings) * segments + (j % segments);
        for i in 0..rings {
            for j in 0..segments {
                let (a, b, c, d) = (idx(i, j), idx(i + 1, j), idx(i + 1, j + 1), idx(i, j + 1));
                self.triangles.extend([[a, c, b], [a, d, c]]);
                self.tri_node.extend([node, node]);
                self.tri_material.extend([material, material]);
            }
        }
    }

    /// Appends another mesh (its node, material and texture indices are shifted).
    pub fn append(&mut self, other: &Mesh) {
        let (v0, n0, m0, t0) = (
            self.positions.len() as u32,
            self.nodes.len() as u32,
            self.materials.len() as u32,
            self.textures.len() as u32,
        );
        let had_normals = !self.normals.is_empty() || self.positions.is_empty();
        self.positions.extend_from_slice(&other.positions);
        if had_normals && !other.normals.is_empty() {
            self.normals.extend_from_slice(&other.normals);
        } else {
            self.normals.clear();
        }
        self.uvs.extend_from_slice(&other.uvs);
        self.triangles.extend(other.triangles.iter().map(|t| t.map(|i| i + v0)));
        self.tri_node.extend(other.tri_node.iter().map(|i| i + n0));
        self.tri_material.extend(other.tri_material.iter().map(|i| i + m0));
        self.nodes.extend_from_slice(&other.nodes);
        self.materials.extend(other.materials.iter().map(|m| Material {
            base_color_texture: m.base_color_texture.map(|t| t + t0),
            ..m.clone()
        }));
        self.textures.extend_from_slice(&other.textures);
    }
}
