//! The captured-VEM mode's objects lit through the visibility cuts (`heliar vem --object-light
//! cuts`; issue 15 §2, "the lighting is … the VEM frame in the VEM mode"; cyberworlds §V,
//! `../shared/papers/cyberworlds-captured-lighting-cuts.txt`).
//!
//! # How it works
//! - **Cuts**: the scene's self-visibility cuts, visibility cut fields and proxy field, loaded
//!   from `baked/cuts.bin` or computed for every object, moving or not
//!   ([`CutState::load`], as for the live window's draggable objects).
//! - **Lighting** ([`captured_lighting`]): the VEM frame's polar map is the upper half of an
//!   equirect map (`crate::vem::polar`); below the horizon the ground, a Lambertian plane of the
//!   renderer's ground albedo lit by the map (`ρ/π·E_up`). Both are clustered on the cuts' tree
//!   (`crate::cuts::frame::UnitLighting::from_maps` with `Pa = 1`, `Pd = 0`): the captured sky
//!   is hidden by the proxy field, the ground by the objects only, as the outdoor mode's sky and
//!   surface texels.
//! - **Per frame** ([`VemCuts::evaluate`]): each object vertex's irradiance about its normal and
//!   about the reflected view direction over the product cut SVC × Π VCF_other × proxy field
//!   (`crate::cuts::frame`, the outdoor mode's evaluation, [`CutState::evaluate_with`]); the
//!   shader turns them into radiance with the glTF BRDF's split sum (`fs_cut_object` in
//!   `shaders/vem/shading.wgsl`). Every receiver pixel within [`RECEIVER_REACH_RADII`] bounding
//!   radii of an object gets its share of the captured sky that the objects leave
//!   (`crate::cuts::receivers`, the outdoor mode's contact shadows): the differential ratio of
//!   the composite; the others keep 1.
//! - **Kept between frames** (`crate::cuts::products`): the VEM frame changes the lighting every
//!   frame, so no value can be kept, but an object that did not move keeps its vertices'
//!   visibility products (SVC × Π VCF × proxy field) wherever no moved object reaches, and the
//!   receivers theirs (Π VCF): the frame sums them with its clustered light, bit for bit as
//!   walking them again ([`VemCuts::evaluate_fresh`]).
//!
//! # Limits
//! The ground below the horizon is a uniform plane (no shadow of the objects on the ground in
//! the objects' own lighting); a receiver farther than [`RECEIVER_REACH_RADII`] radii from every
//! object keeps its light (an object of bounding radius `r` hides at most `(r/d)²` of the
//! cosine-weighted sky at distance `d`: 4% at 5 r).

use super::motion_cuts::CutState;
use crate::cuts::CutsError;
use crate::cuts::frame::UnitLighting;
use crate::cuts::products::{ProductUse, ReceiverProductUse};
use crate::cuts::rotate::Pose;
use crate::geometry::Mesh;
use crate::geometry::raycast::RayScene;
use crate::gpu::canvas::Canvas;
use crate::io::image::LinearImage;
use crate::scene::Scene;
use crate::vem::polar::PolarMap;
use glam::{Mat4, Vec3};
use serde::Serialize;
use std::sync::Arc;

/// Receivers within this many bounding radii of an object's centre get their visibility from
/// the cuts (module docs); farther ones keep a ratio of 1.
pub const RECEIVER_REACH_RADII: f32 = 5.0;

/// One vertex's light from the cuts: irradiance about the normal (rgb; `w = 1`: served) and
/// about the reflected view direction. Mirrors `cut_ambient` in `shaders/vem/shading.wgsl`.
pub type VemVertexLight = [[f32; 4]; 2];

/// The cuts of a VEM run's objects and the receivers the camera sees.
pub struct VemCuts {
    state: CutState,
    /// Per canvas pixel that sees a receiver: its index, point and normal (toward the camera).
    receivers: Vec<(u32, Vec3, Vec3)>,
    /// Canvas pixels.
    pixels: usize,
    eye: Vec3,
    ground_albedo: f32,
}

/// One frame's light from the cuts.
#[derive(Clone, Debug, Default, PartialEq)]
pub struct VemCutFrame {
    /// Per object, per mesh vertex.
    pub vertices: Vec<Vec<VemVertexLight>>,
    /// Per canvas pixel, the receivers' ratio (1 where no receiver or none near an object).
    pub ratio: Vec<f32>,
    /// Receiver pixels evaluated.
    pub receivers_evaluated: usize,
    /// Per object, what the frame did with its vertices' visibility products (empty from
    /// [`VemCuts::evaluate_fresh`]).
    pub products: Vec<ProductUse>,
    /// What the frame did with the receivers' visibility products.
    pub receiver_products: ReceiverProductUse,
    /// Bytes of the visibility products kept for the next frame.
    pub kept_bytes: usize,
}

/// The upward irradiance of `map` (rgb): `Σ L·cos θ·Δω` over its texels.
pub fn upward_irradiance(map: &PolarMap) -> [f32; 3] {
    let mut e = [0.0f64; 3];
    for j in 0..map.height {
        let dw = map.row_solid_angle(j) as f64;
        for i in 0..map.width {
            let c = map.texel_dir(i, j).y.max(0.0) as f64;
            for (e, v) in e.iter_mut().zip(map.get(i, j)) {
                *e += v as f64 * c * dw;
            }
        }
    }
    e.map(|v| v as f32)
}

/// A VEM frame's polar `map` over the upper hemisphere and a Lambertian ground of `albedo` lit
/// by it below, clustered on `tree` (module docs). Texels that are not finite or negative are
/// an error naming the texel.
pub fn captured_lighting(tree: &crate::cuts::DirectionTree, map: &PolarMap, albedo: f32) -> Result<UnitLighting, CutsError> {
    let ground = upward_irradiance(map).map(|e| albedo / std::f32::consts::PI * e);
    let (w, h) = (map.width, 2 * map.height);
    let sky = LinearImage::from_fn(w, h, |i, j| if j < map.height { map.get(i, j) } else { [0.0; 3] });
    let below = LinearImage::from_fn(w, h, |_, j| if j >= map.height { ground } else { [0.0; 3] });
    UnitLighting::from_maps(tree, &sky, &below, None)
}

impl VemCuts {
    /// The cuts of `scene` (computed for every object when `baked/cuts.bin` has none) and the
    /// receivers `canvas` sees: the proxy, or `ground` (the renderer's ground plane) without one.
    /// The error is the reason, for the user.
    pub fn load(scene: &Scene, canvas: &Canvas, ground: Option<&Mesh>, ground_albedo: f32) -> Result<Self, String> {
        let proxy = RayScene::new(scene.proxy.clone());
        let state = CutState::load(scene, &proxy, true)?;
        let receiver_mesh = match (scene.proxy.triangles.is_empty(), ground) {
            (false, _) => Some(proxy),
            (true, Some(g)) => Some(RayScene::new(g.clone())),
            (true, None) => None,
        };
        let e = canvas.uniform().eye_world;
        let eye = Vec3::new(e[0], e[1], e[2]);
        let pixels = (canvas.intrinsics.width * canvas.intrinsics.height) as usize;
        let receivers = match &receiver_mesh {
            Some(r) => (0..pixels as u32).filter_map(|i| r.intersect(eye, canvas.pixel_dir(i), f32::MAX).map(|h| (i, h.point, h.normal))).collect(),
            None => Vec::new(),
        };
        Ok(Self { state, receivers, pixels, eye, ground_albedo })
    }

    /// The cuts' direction tree.
    pub fn tree(&self) -> &crate::cuts::DirectionTree {
        self.state.tree()
    }

    /// The objects' light and the receivers' ratio for the objects at `poses` (`None`: as
    /// placed; `crate::run::motion::MovingObjects::poses`) under the VEM frame `map`. The
    /// visibility products of the vertices and receivers that no moved object reaches are kept
    /// from the last call and summed under this frame's light (`crate::cuts::products`): the
    /// same bits as [`Self::evaluate_fresh`].
    pub fn evaluate(&mut self, map: &PolarMap, poses: &[Option<Mat4>]) -> Result<VemCutFrame, String> {
        self.evaluate_inner(map, poses, true)
    }

    /// [`Self::evaluate`] walking every product afresh and keeping nothing.
    pub fn evaluate_fresh(&mut self, map: &PolarMap, poses: &[Option<Mat4>]) -> Result<VemCutFrame, String> {
        self.evaluate_inner(map, poses, false)
    }

    fn evaluate_inner(&mut self, map: &PolarMap, poses: &[Option<Mat4>], reuse: bool) -> Result<VemCutFrame, String> {
        let light = captured_lighting(self.tree(), map, self.ground_albedo).map_err(|e| format!("the VEM frame cannot be clustered: {e}"))?;
        let poses: Vec<Pose> = match poses.is_empty() {
            true => vec![Pose::translated(Vec3::ZERO); self.state.cuts().objects.len()],
            false => self.state.poses(poses).map_err(|(k, why)| format!("object {k} is not moved rigidly ({why}): the cuts hold for rigid motion only"))?,
        };
        let (ambient, receivers) = match reuse {
            true => self.state.evaluate_reusing(&poses, Arc::new(light), self.eye, None),
            false => self.state.evaluate_with(&poses, Arc::new(light), self.eye, None),
        }
        .map_err(|e| e.to_string())?;
        let vertices = ambient.vertices.into_iter().map(|obj| obj.into_iter().map(|a| [a[0], a[1]]).collect()).collect();
        // The objects' bounding spheres where they stand (world frame).
        let spheres: Vec<(Vec3, f32)> = self.state.cuts().objects.iter().zip(&poses).map(|(o, p)| (p.point(o.vcf.centre), o.vcf.radius_m * RECEIVER_REACH_RADII)).collect();
        let near: Vec<(u32, Vec3, Vec3)> = self.receivers.iter().filter(|(_, x, _)| spheres.iter().any(|(c, r)| x.distance_squared(*c) <= r * r)).copied().collect();
        let surfaces: Vec<(Vec3, Vec3)> = near.iter().map(|(_, x, n)| (*x, *n)).collect();
        let mut ratio = vec![1.0f32; self.pixels];
        for ((i, _, _), v) in near.iter().zip(receivers.visibility(&surfaces)) {
            // No proxy light in the captured-VEM mode: the sky's share, the same for `b`.
            ratio[*i as usize] = v.ambient;
        }
        let (products, receiver_products, kept_bytes) = match reuse {
            true => {
                let (r, bytes) = self.state.receiver_product_use();
                (self.state.product_uses().to_vec(), r, bytes)
            }
            false => (Vec::new(), ReceiverProductUse::default(), 0),
        };
        Ok(VemCutFrame { vertices, ratio, receivers_evaluated: near.len(), products, receiver_products, kept_bytes })
    }
}

/// What the visibility cuts did in a frame (`--object-light cuts`).
#[derive(Clone, Debug, Serialize)]
pub struct CutRecord {
    /// The lighting clustered, the objects' vertices and the receivers evaluated, ms (CPU,
    /// before the render; not in `timings.total_ms`).
    pub cuts_ms: f64,
    /// Receiver pixels near an object whose ratio came from the cuts.
    pub receivers: usize,
    /// Of those, the receivers whose visibility product (Π VCF) was kept from the last frame
    /// (no moved object reaches them) and summed under this frame's light
    /// (`crate::cuts::products`).
    pub receivers_reused_product: usize,
    /// Per object (scene order), what its vertices did with their visibility products, and why.
    pub products: Vec<ProductRecord>,
    /// Bytes of the visibility products kept for the next frame.
    pub products_kept_bytes: usize,
}

/// One object's visibility products in a frame (`--object-light cuts`, `crate::cuts::products`).
#[derive(Clone, Debug, Serialize)]
pub struct ProductRecord {
    /// The object (its file name).
    pub object: String,
    /// Vertices whose product SVC × Π VCF × proxy field was kept from the last frame and summed
    /// under this frame's light.
    pub reused: usize,
    /// Vertices whose product was walked again.
    pub walked: usize,
    /// Why.
    pub reason: String,
}

/// Why `u`'s vertices reused their products or not (`moved`: the object moved this frame).
fn product_reason(u: &ProductUse, moved: bool, first: bool) -> String {
    let total = u.reused + u.walked;
    let mut why = if first {
        "first frame: every product walked".to_owned()
    } else if moved {
        "it moved: every product walked".to_owned()
    } else if u.walked == 0 {
        format!("it did not move and no moved object's cut field reaches it: all {total} vertices sum their kept product under the new VEM frame")
    } else if u.reused == 0 {
        "it did not move, but a moved object's cut field reaches every vertex (at its old or new pose), or nothing was kept: every product walked".to_owned()
    } else {
        format!("it did not move: {} of {total} vertices sum their kept product; {} walked again where a moved object's cut field reaches them (at its old or new pose)", u.reused, u.walked)
    };
    if let Some(n) = &u.not_kept {
        why.push_str("; ");
        why.push_str(n);
    }
    why
}

/// Per object of `scene` (scene order), what `frame` did with its vertices' visibility products
/// and why (`moved`: the objects' file names that moved this frame; `first`: the run's first
/// frame).
pub fn product_records(scene: &Scene, frame: &VemCutFrame, moved: &[String], first: bool) -> Vec<ProductRecord> {
    scene
        .virtual_objects
        .iter()
        .zip(&frame.products)
        .map(|(o, u)| {
            let object = o.path.file_name().map(|f| f.to_string_lossy().into_owned()).unwrap_or_else(|| o.path.display().to_string());
            let reason = product_reason(u, moved.contains(&object), first);
            ProductRecord { object, reused: u.reused, walked: u.walked, reason }
        })
        .collect()
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn the_ground_is_lit_by_the_map_and_the_sky_is_its_upper_half() {
        // A uniform sky of radiance 1: E_up = π, so the ground of albedo 0.3 has radiance 0.3;
        // the clustered sky sums to 2π (the hemisphere), the ground to 0.3·2π (quadrature of the
        // equirect texels and leaf cells across the horizon: within 2%).
        let map = PolarMap::from_fn(90, 30, |_| [1.0; 3]);
        let e = upward_irradiance(&map);
        assert!((e[0] - std::f32::consts::PI).abs() < 0.01 * std::f32::consts::PI, "{e:?}");
        let tree = crate::cuts::DirectionTree::new(8).unwrap();
        let l = captured_lighting(&tree, &map, 0.3).unwrap();
        let two_pi = 2.0 * std::f32::consts::PI;
        assert!((l.sky_pa.total().x - two_pi).abs() < 0.02 * two_pi, "{}", l.sky_pa.total());
        let g = l.surface_pa.as_ref().unwrap().total().x;
        assert!((g - 0.3 * two_pi).abs() < 0.02 * 0.3 * two_pi, "{g}");
        assert!(l.surface_pd.is_none());
        // The same from a closure of direction (`UnitLighting::from_radiance`): radiance 1 above
        // and 0.3 below the horizon, split there the same way.
        let f = UnitLighting::from_radiance(&tree, 180, |d| if d.y >= 0.0 { [1.0; 3] } else { [0.3; 3] }).unwrap();
        assert!((f.sky_pa.total().x - two_pi).abs() < 0.02 * two_pi, "{}", f.sky_pa.total());
        let g = f.surface_pa.as_ref().unwrap().total().x;
        assert!((g - 0.3 * two_pi).abs() < 0.02 * 0.3 * two_pi, "{g}");
    }
}
