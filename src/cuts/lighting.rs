//! The environment clustered on the direction tree, and shading by the cut sum
//! (cyberworlds §V, Eqs. 1–3; §V-A.4).
//!
//! # How it works
//! - **Clustering** ([`ClusteredLighting`]). Each leaf `j` gets `L_j·Δω`, the mean radiance of
//!   the map over the leaf's cell times the leaf's solid angle `Δω = 4π/S`: every texel of the
//!   equirect map goes to its nearest leaf direction (a kd-tree) with its solid angle
//!   ([`crate::geometry::equirect::texel_solid_angle`]) as weight, and a leaf no texel reached (a map coarser
//!   than the tree) takes the texel under its direction. Inner nodes sum their children, so node
//!   `k` holds `l_k = Σ_{j∈C_k} L_j·Δω` (the paper's `l_k = ∫_{C_k} L(ω) dω`, Eq. 3).
//! - **Shading** ([`shade`]). With the product cut `v` of the vertex's cosine-folded SVC and the
//!   occluders' cuts (Eq. 4; its node values are means of `V·cos` over the node), Eq. 3 reads
//!   `B(x, ω_o) ≈ Σ_k l_k v_k f_r(ω_k, ω_o)` with `ω_k` the node's representative direction
//!   ([`super::tree::DirectionTree::node_dir`]). The sum runs over the product walk
//!   ([`super::walk::product_for_each`]) without storing the product. For a Lambertian surface
//!   `f_r = ρ/π`; for the glTF BRDF ([`crate::geometry::brdf`]) `f_r = f·cos / cos` at `ω_k`,
//!   with `ω_k` raised to at least [`MIN_BRDF_COS`] above the tangent plane (a coarse node
//!   whose mean direction dips below the horizon still carries light from its upper part).
//! - **Receiver sky visibility** ([`ReceiverWeights`], [`sky_visibility`]): a real surface
//!   point's share of its sky light that the virtual objects leave, `Σ_j w_j V_j / Σ_j w_j`
//!   with `w_j = L_j·max(n·ω_j, 0)·Δω` summed into every node; on a cut the sum over its nodes
//!   is exact for the piecewise-constant `V`.

use super::CutsError;
use super::packed::CutView;
use super::tree::{DirectionTree, node_index};
use super::walk::product_for_each;
use crate::geometry::equirect::{texel_index, texel_solid_angle};
use crate::geometry::brdf::GltfSurface;
use crate::io::image::LinearImage;
use glam::Vec3;
use kiddo::{ImmutableKdTree, SquaredEuclidean};

/// Smallest cosine at which the glTF BRDF is evaluated for a cut node (see module docs):
/// `sin 3°`, below the angular size of a cut node that straddles the horizon.
pub const MIN_BRDF_COS: f32 = 0.052;

/// Per-node light `l_k = Σ L_j·Δω` (RGB, radiance × sr) in heap order.
#[derive(Clone, Debug, PartialEq)]
pub struct ClusteredLighting {
    levels: u32,
    nodes: Vec<Vec3>,
}

fn sum_up(levels: u32, leaves: Vec<Vec3>) -> Vec<Vec3> {
    let count = 1usize << levels;
    let mut nodes = vec![Vec3::ZERO; 2 * count - 1];
    nodes[count - 1..].copy_from_slice(&leaves);
    for i in (0..count - 1).rev() {
        nodes[i] = nodes[2 * i + 1] + nodes[2 * i + 2];
    }
    nodes
}

impl ClusteredLighting {
    /// Clusters an equirect map (the crate's convention). Non-finite or negative texels are an
    /// error naming the texel.
    pub fn from_equirect(tree: &DirectionTree, map: &LinearImage) -> Result<Self, CutsError> {
        Self::cluster(tree, map, |d| d, |d| d)
    }

    /// Clusters an equirect map in the frame of an object turned by `rotation` (object → world):
    /// the texel of world direction `ω` goes to the leaf nearest `rotationᵀ·ω`
    /// (`crate::cuts::rotate`), and a leaf no texel reached takes the texel under
    /// `rotation·d_leaf`.
    pub fn from_equirect_in_frame(tree: &DirectionTree, map: &LinearImage, rotation: glam::Mat3) -> Result<Self, CutsError> {
        let back = rotation.transpose();
        Self::cluster(tree, map, |d| back * d, |d| rotation * d)
    }

    fn cluster(tree: &DirectionTree, map: &LinearImage, to_frame: impl Fn(Vec3) -> Vec3, from_frame: impl Fn(Vec3) -> Vec3) -> Result<Self, CutsError> {
        let (w, h) = (map.width, map.height);
        if w == 0 || h == 0 || map.data.len() != (w * h) as usize {
            return Err(CutsError::EnvMap(format!("{w}×{h} map with {} texels", map.data.len())));
        }
        if let Some(i) = map.data.iter().position(|t| !t.iter().all(|c| c.is_finite() && *c >= 0.0)) {
            return Err(CutsError::EnvMap(format!("texel ({}, {}) is {:?}, not a finite radiance ≥ 0", i as u32 % w, i as u32 / w, map.data[i])));
        }
        let points: Vec<[f32; 3]> = tree.leaf_dirs().iter().map(|d| d.to_array()).collect();
        let kd = ImmutableKdTree::<f32, 3>::new_from_slice(&points).map_err(|e| CutsError::EnvMap(format!("kd-tree of the leaf directions: {e}")))?;
        let count = tree.leaf_count();
        let (mut sum, mut weight) = (vec![Vec3::ZERO; count], vec![0.0f64; count]);
        for j in 0..h {
            let omega = texel_solid_angle(j, w, h);
            for i in 0..w {
                let d = crate::geometry::equirect::dir_from_texel_centre(i, j, w, h);
                let leaf = kd.query(&to_frame(d).to_array()).nearest_one::<SquaredEuclidean<f32>>().execute().item as usize;
                sum[leaf] += Vec3::from(map.get(i, j)) * omega;
                weight[leaf] += omega as f64;
            }
        }
        let dw = tree.leaf_solid_angle_sr();
        let leaves = (0..count)
            .map(|k| match weight[k] > 0.0 {
                true => sum[k] / weight[k] as f32 * dw,
                false => Vec3::from(map.data[texel_index(from_frame(tree.leaf_dirs()[k]), w, h)]) * dw,
            })
            .collect();
        Ok(Self { levels: tree.levels(), nodes: sum_up(tree.levels(), leaves) })
    }

    /// Clusters an analytic radiance `radiance(ω)` sampled at the leaf directions.
    pub fn from_fn(tree: &DirectionTree, radiance: impl Fn(Vec3) -> Vec3) -> Self {
        let dw = tree.leaf_solid_angle_sr();
        let leaves = tree.leaf_dirs().iter().map(|&d| radiance(d) * dw).collect();
        Self { levels: tree.levels(), nodes: sum_up(tree.levels(), leaves) }
    }

    /// Clusters per-leaf radiances `L_j` (leaf order; a missing leaf is black).
    pub fn from_leaf_radiance(tree: &DirectionTree, leaves: Vec<Vec3>) -> Self {
        let dw = tree.leaf_solid_angle_sr();
        let leaves = (0..tree.leaf_count()).map(|j| leaves.get(j).copied().unwrap_or(Vec3::ZERO) * dw).collect();
        Self { levels: tree.levels(), nodes: sum_up(tree.levels(), leaves) }
    }

    /// Depth of the tree.
    pub fn levels(&self) -> u32 {
        self.levels
    }

    /// `l_k` of heap node `index`.
    #[inline]
    pub fn node(&self, index: usize) -> Vec3 {
        self.nodes[index]
    }

    /// `l_k` of the node of `height` starting at `first_leaf`.
    #[inline]
    pub fn at(&self, height: u32, first_leaf: u32) -> Vec3 {
        self.nodes[node_index(self.levels, height, first_leaf)]
    }

    /// `∫ L dω` over the sphere (the root).
    pub fn total(&self) -> Vec3 {
        self.nodes[0]
    }
}

/// How a surface reflects.
#[derive(Clone, Copy, Debug, PartialEq)]
pub enum Reflectance {
    /// Lambertian of linear albedo `ρ`: `f_r = ρ/π`.
    Lambert(Vec3),
    /// The glTF metallic–roughness BRDF.
    Gltf(GltfSurface),
}

impl Reflectance {
    /// `f_r(ω, ω_o)` (no cosine) for unit normal `n`, view direction `v` (toward the viewer).
    pub fn brdf(&self, n: Vec3, v: Vec3, omega: Vec3) -> Vec3 {
        match self {
            Reflectance::Lambert(rho) => *rho * std::f32::consts::FRAC_1_PI,
            Reflectance::Gltf(s) => {
                let c = n.dot(omega);
                let l = if c >= MIN_BRDF_COS {
                    omega
                } else {
                    let t = (omega - n * c).try_normalize().unwrap_or_else(|| n.any_orthonormal_vector());
                    (t * (1.0 - MIN_BRDF_COS * MIN_BRDF_COS).sqrt() + n * MIN_BRDF_COS).normalize()
                };
                s.eval_cos(n, v, l) / n.dot(l)
            }
        }
    }
}

/// Outgoing radiance `B(x, ω_o) ≈ Σ_k l_k v_k f_r(ω_k, ω_o)` (Eq. 3) over the product of
/// `visibility` (the vertex's cosine-folded SVC first, then occluders' cuts; Eq. 4).
pub fn shade(tree: &DirectionTree, lighting: &ClusteredLighting, visibility: &[CutView], surface: &Reflectance, n: Vec3, v: Vec3) -> Result<Vec3, CutsError> {
    check_tree(tree, lighting)?;
    if let Some(c) = visibility.first().filter(|c| c.levels() != tree.levels()) {
        return Err(CutsError::LevelMismatch { index: 0, expected: tree.levels(), got: c.levels() });
    }
    let mut sum = Vec3::ZERO;
    product_for_each(visibility, |h, first, value| {
        if value != 0.0 {
            let k = node_index(tree.levels(), h, first);
            sum += lighting.node(k) * value * surface.brdf(n, v, tree.node_dir(k));
        }
    })?;
    Ok(sum)
}

fn check_tree(tree: &DirectionTree, lighting: &ClusteredLighting) -> Result<(), CutsError> {
    if tree.levels() != lighting.levels() {
        return Err(CutsError::LevelMismatch { index: 0, expected: tree.levels(), got: lighting.levels() });
    }
    Ok(())
}

/// Per-node weights `Σ_{j∈k} lum(L_j)·max(n·ω_j, 0)·Δω` of a receiver of normal `n`.
#[derive(Clone, Debug, PartialEq)]
pub struct ReceiverWeights {
    levels: u32,
    nodes: Vec<f32>,
}

impl ReceiverWeights {
    /// The weights of unit normal `n` under `lighting` (luminance, Rec. 709 weights).
    pub fn new(tree: &DirectionTree, lighting: &ClusteredLighting, n: Vec3) -> Result<Self, CutsError> {
        check_tree(tree, lighting)?;
        let count = tree.leaf_count();
        let mut nodes = vec![0.0f32; 2 * count - 1];
        for (j, d) in tree.leaf_dirs().iter().enumerate() {
            let l = lighting.node(count - 1 + j);
            nodes[count - 1 + j] = (0.2126 * l.x + 0.7152 * l.y + 0.0722 * l.z) * n.dot(*d).max(0.0);
        }
        for i in (0..count - 1).rev() {
            nodes[i] = nodes[2 * i + 1] + nodes[2 * i + 2];
        }
        Ok(Self { levels: tree.levels(), nodes })
    }

    /// The receiver's unoccluded weight (its irradiance's luminance).
    pub fn total(&self) -> f32 {
        self.nodes[0]
    }

    /// The weight of heap node `index`.
    #[inline]
    pub fn node(&self, index: usize) -> f32 {
        self.nodes[index]
    }

    /// The per-leaf weights.
    pub fn leaves(&self) -> &[f32] {
        &self.nodes[(1usize << self.levels) - 1..]
    }

    /// Weights from per-leaf values (another frame's, `crate::cuts::rotate::LeafRemap::push_forward`).
    pub fn from_leaf_weights(levels: u32, leaves: &[f32]) -> Result<Self, CutsError> {
        let count = 1usize << levels;
        if leaves.len() != count {
            return Err(CutsError::LeafCount { what: "receiver weights", expected: count, got: leaves.len() });
        }
        let mut nodes = vec![0.0f32; 2 * count - 1];
        nodes[count - 1..].copy_from_slice(leaves);
        for i in (0..count - 1).rev() {
            nodes[i] = nodes[2 * i + 1] + nodes[2 * i + 2];
        }
        Ok(Self { levels, nodes })
    }
}

/// The share `Σ w_k v_k / Σ w` of the receiver's light left by the product of `occluders`
/// (virtual objects' field cuts at the point). 1 when nothing weighs (a receiver facing only
/// black sky): no light to lose.
pub fn sky_visibility(weights: &ReceiverWeights, occluders: &[CutView]) -> Result<f32, CutsError> {
    if occluders.is_empty() || weights.total() <= 0.0 {
        return Ok(1.0);
    }
    if occluders[0].levels() != weights.levels {
        return Err(CutsError::LevelMismatch { index: 0, expected: weights.levels, got: occluders[0].levels() });
    }
    let mut seen = 0.0f64;
    product_for_each(occluders, |h, first, value| {
        seen += (weights.nodes[node_index(weights.levels, h, first)] * value) as f64;
    })?;
    Ok((seen / weights.total() as f64) as f32)
}
