//! The visibility cuts in the frame loop (issue 15 §2; cyberworlds §V-A.4 and §V-B,
//! `../shared/papers/cyberworlds-captured-lighting-cuts.txt`): the objects' ambient per vertex
//! and the real receivers' sky visibility with the objects present, for the objects at this
//! frame's translation.
//!
//! # How it works
//! - **Lighting per unit intensity** ([`UnitLighting`]). The outdoor mode's relit environment
//!   map without the sun (`crate::envmap::relight`) is linear in the frame's `Pa` and `Pd`: its
//!   sky texels are `S·Pa`, its surface texels `A·Pa + D·Pd`. Each part is clustered on the
//!   direction tree ([`super::lighting::ClusteredLighting`], Eq. 3's `l_k`) when the relighter's
//!   sun planes change; a frame scales the sums by its own `Pa` and `Pd` in the shader, as the
//!   per-pixel transfer does (`crate::render::object_transfer`). Without a bake, the uniform sky
//!   of the crate's radiometry (radiance `1/π` per unit `Pa` above the horizon).
//! - **Per vertex** ([`FrameCuts::object_ambient`]). The visibility is the product (Eq. 4) of the
//!   vertex's self-visibility cut (cosine folded in), the other objects' fields at the vertex
//!   (trilinear, §V-A.4; culled when wholly below the tangent plane, §V-B) and, for the sky part
//!   only, the proxy field. The map's surface texels *are* the proxy as the map's centre sees it:
//!   multiplying them by the proxy field would take the ground's bounce away at the very
//!   directions that show the ground, so they get the objects' visibility only (the distant-light
//!   assumption of the probe grid). The cut sum gives the irradiance about the normal
//!   `E_n = Σ_k l_k v_k` and, for the specular half of the shader's split-sum ambient
//!   (`ambient_radiance` in `shaders/common/brdf.wgsl`, which the probe path feeds with the
//!   irradiance about the normal and about the reflected view direction `r`),
//!   `E_r = Σ_k l_k v_k max(r·ω_k, 0) / max(n·ω_k, sin 3°)`: the folded cosine divided out at the
//!   node's direction, as [`super::lighting::Reflectance::brdf`] does for the glTF BRDF.
//! - **Receivers** ([`ReceiverCuts`]): a real surface point's share of its sky light that the
//!   objects leave ([`super::lighting::sky_visibility`], weights from the sky per unit `Pa` and
//!   the receiver's cosine); the compositor sets `c_v = c·V` and `b_v = b·V` from it instead of
//!   tracing them again.
//!
//! # Limits
//! Translation only (`crate::cuts` module docs): the caller falls back to the re-trace when an
//! object turns. `V` at a receiver counts the sky an object hides even where the proxy hides it
//! already (`c` has that part removed), so contact shadows in a wall's sky shadow come out a
//! little too dark; the bounce an object blocks is taken in the same share as the sky.

use super::eval::CutScene;
use super::file::PrecomputedCuts;
use super::lighting::{ClusteredLighting, MIN_BRDF_COS, ReceiverWeights};
use super::packed::CutView;
use super::tree::{DirectionTree, node_index};
use super::vcf::FieldRegion;
use super::walk::product_for_each;
use super::{Cut, CutsError};
use crate::io::image::LinearImage;
use glam::Vec3;
use rayon::prelude::*;
use std::collections::HashMap;
use std::f32::consts::FRAC_1_PI;
use std::sync::Arc;

/// One vertex's ambient: irradiance per unit `Pa` about the normal (rgb; `w = 1`, the vertex is
/// served by the cuts) and about the reflected view direction, then the same two per unit `Pd`.
/// Mirrors `cut_ambient` in `shaders/virtual_shading.wgsl`.
pub type VertexAmbient = [[f32; 4]; 4];

/// The environment per unit intensity, clustered on the tree (module docs).
#[derive(Clone, Debug, PartialEq)]
pub struct UnitLighting {
    /// Sky texels per unit `Pa`.
    pub sky_pa: ClusteredLighting,
    /// Surface texels per unit `Pa` (none without a bake).
    pub surface_pa: Option<ClusteredLighting>,
    /// Surface texels per unit `Pd` (the sun's bounce; none without a sun or a bake).
    pub surface_pd: Option<ClusteredLighting>,
}

impl UnitLighting {
    /// The uniform upper-hemisphere sky of the crate's radiometry: radiance `1/π` per unit `Pa`.
    pub fn uniform_sky(tree: &DirectionTree) -> Self {
        let sky_pa = ClusteredLighting::from_fn(tree, |d| if d.y > 0.0 { Vec3::splat(FRAC_1_PI) } else { Vec3::ZERO });
        Self { sky_pa, surface_pa: None, surface_pd: None }
    }

    /// The three parts of a relit map, each an equirect map in the crate's convention.
    pub fn from_maps(tree: &DirectionTree, sky_pa: &LinearImage, surface_pa: &LinearImage, surface_pd: Option<&LinearImage>) -> Result<Self, CutsError> {
        Ok(Self {
            sky_pa: ClusteredLighting::from_equirect(tree, sky_pa)?,
            surface_pa: Some(ClusteredLighting::from_equirect(tree, surface_pa)?),
            surface_pd: surface_pd.map(|m| ClusteredLighting::from_equirect(tree, m)).transpose()?,
        })
    }
}

/// `(E_n, E_r)` of each of `lights` over the product of `views` (module docs).
fn irradiance_sums(tree: &DirectionTree, lights: &[&ClusteredLighting], views: &[CutView], n: Vec3, r: Vec3) -> Result<Vec<(Vec3, Vec3)>, CutsError> {
    let mut out = vec![(Vec3::ZERO, Vec3::ZERO); lights.len()];
    if lights.is_empty() {
        return Ok(out);
    }
    let levels = tree.levels();
    product_for_each(views, |h, first, value| {
        if value == 0.0 {
            return;
        }
        let k = node_index(levels, h, first);
        let d = tree.node_dir(k);
        let spec = r.dot(d).max(0.0) / n.dot(d).max(MIN_BRDF_COS);
        for (o, l) in out.iter_mut().zip(lights) {
            let lv = l.node(k) * value;
            o.0 += lv;
            o.1 += lv * spec;
        }
    })?;
    Ok(out)
}

fn rgbw(v: Vec3, w: f32) -> [f32; 4] {
    [v.x, v.y, v.z, w]
}

/// A scene's precomputed cuts ready for the frame loop.
#[derive(Clone, Debug)]
pub struct FrameCuts {
    /// The cuts (objects in the scene's order, in the frame they were computed in).
    pub cuts: Arc<PrecomputedCuts>,
    /// Their direction tree.
    pub tree: Arc<DirectionTree>,
}

/// The per-vertex ambient of every object, and how many vertices fell outside the proxy box.
#[derive(Clone, Debug, Default, PartialEq)]
pub struct ObjectAmbient {
    /// Per object, per mesh vertex.
    pub vertices: Vec<Vec<VertexAmbient>>,
    /// Vertices whose proxy-field lookup was clamped to the box (a warning, never NaN).
    pub outside_proxy_box: usize,
}

impl FrameCuts {
    /// Builds the tree of `cuts`.
    pub fn new(cuts: PrecomputedCuts) -> Result<Self, CutsError> {
        let tree = Arc::new(DirectionTree::new(cuts.levels)?);
        Ok(Self { cuts: Arc::new(cuts), tree })
    }

    fn scene<'a>(&'a self, sky: &'a ClusteredLighting, translations: &'a [Vec3]) -> CutScene<'a> {
        CutScene { tree: &self.tree, lighting: sky, objects: &self.cuts.objects, translations, proxy: self.cuts.proxy.as_ref() }
    }

    /// The ambient of every vertex of every object translated by `translations` (object frame
    /// + translation = world), seen from the eye at `eye`; in parallel over vertices.
    pub fn object_ambient(&self, lighting: &UnitLighting, translations: &[Vec3], eye: Vec3) -> Result<ObjectAmbient, CutsError> {
        let scene = self.scene(&lighting.sky_pa, translations);
        if translations.len() != self.cuts.objects.len() {
            return Err(CutsError::Operands(format!("{} objects but {} translations", self.cuts.objects.len(), translations.len())));
        }
        let mut out = ObjectAmbient::default();
        for (k, obj) in self.cuts.objects.iter().enumerate() {
            let rows: Vec<(VertexAmbient, bool)> =
                (0..obj.positions.len().min(obj.svc.cuts.len())).into_par_iter().map(|v| self.vertex_ambient(&scene, lighting, k, v, eye)).collect::<Result<_, _>>()?;
            out.outside_proxy_box += rows.iter().filter(|r| r.1).count();
            out.vertices.push(rows.into_iter().map(|r| r.0).collect());
        }
        Ok(out)
    }

    /// One vertex of [`Self::object_ambient`], and whether its proxy lookup was clamped.
    fn vertex_ambient(&self, scene: &CutScene<'_>, lighting: &UnitLighting, object: usize, v: usize, eye: Vec3) -> Result<(VertexAmbient, bool), CutsError> {
        let obj = &scene.objects[object];
        let x = obj.positions[v] + scene.translations[object];
        if !x.is_finite() {
            return Err(CutsError::NonFinitePoint(x.to_array()));
        }
        let n = obj.svc.normals[v];
        let view = (eye - x).normalize_or(Vec3::Y);
        let r = (2.0 * n.dot(view) * n - view).normalize_or(n);
        let others = scene.occluder_cuts(x, n, Some(object))?;
        let (proxy, outside) = match scene.proxy {
            Some(field) => {
                let (cut, region) = field.lookup(x)?;
                (Some(cut), region == FieldRegion::OutsideBox)
            }
            None => (None, false),
        };
        let mut views: Vec<CutView> = Vec::with_capacity(others.len() + 2);
        views.push(obj.svc.cuts.view(v));
        views.extend(others.iter().map(Cut::view));
        let surface: Vec<&ClusteredLighting> = [lighting.surface_pa.as_ref(), lighting.surface_pd.as_ref()].into_iter().flatten().collect();
        let surf = irradiance_sums(&self.tree, &surface, &views, n, r)?;
        let zero = (Vec3::ZERO, Vec3::ZERO);
        let surf_pa = if lighting.surface_pa.is_some() { surf[0] } else { zero };
        let surf_pd = if lighting.surface_pd.is_some() { surf[surf.len() - 1] } else { zero };
        views.extend(proxy.iter().map(Cut::view));
        let sky = irradiance_sums(&self.tree, &[&lighting.sky_pa], &views, n, r)?[0];
        let amb = [rgbw(sky.0 + surf_pa.0, 1.0), rgbw(sky.1 + surf_pa.1, 0.0), rgbw(surf_pd.0, 0.0), rgbw(surf_pd.1, 0.0)];
        Ok((amb, outside))
    }

    /// The receivers' visibility for the objects at `translations` under `lighting`'s sky.
    pub fn receivers(&self, lighting: Arc<UnitLighting>, translations: Vec<Vec3>) -> ReceiverCuts {
        ReceiverCuts { cuts: self.clone(), lighting, translations }
    }
}

/// The real receivers' sky visibility with the objects at one frame's translations.
#[derive(Clone, Debug)]
pub struct ReceiverCuts {
    cuts: FrameCuts,
    lighting: Arc<UnitLighting>,
    translations: Vec<Vec3>,
}

/// A receiver normal's key in the weights cache (a proxy has few distinct normals).
fn normal_key(n: Vec3) -> [i32; 3] {
    (n * 1000.0).round().as_ivec3().to_array()
}

impl ReceiverCuts {
    /// The share of sky light the objects leave at each `(point, normal)` (world frame), in
    /// `[0, 1]`; 1 where the lookup fails (a non-finite point: nothing to darken). In parallel.
    pub fn visibility(&self, surfaces: &[(Vec3, Vec3)]) -> Vec<f32> {
        let mut normals: HashMap<[i32; 3], Vec3> = HashMap::new();
        for (_, n) in surfaces {
            normals.entry(normal_key(*n)).or_insert(*n);
        }
        let (tree, sky) = (&*self.cuts.tree, &self.lighting.sky_pa);
        let list: Vec<([i32; 3], Vec3)> = normals.into_iter().collect();
        let weights: HashMap<[i32; 3], ReceiverWeights> = list.into_par_iter().filter_map(|(k, n)| ReceiverWeights::new(tree, sky, n).ok().map(|w| (k, w))).collect();
        let scene = CutScene { tree, lighting: sky, objects: &self.cuts.cuts.objects, translations: &self.translations, proxy: None };
        surfaces
            .par_iter()
            .map(|(x, n)| match weights.get(&normal_key(*n)) {
                Some(w) => scene.receiver_visibility(w, *x, *n).map_or(1.0, |r| r.visibility.clamp(0.0, 1.0)),
                None => 1.0,
            })
            .collect()
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::cuts::eval::ObjectCuts;
    use crate::cuts::svc::SvcSettings;
    use crate::cuts::vcf::VcfSampling;
    use crate::cuts::{no_progress, shapes};

    /// `count` spheres of radius 0.5 m at the origin (object frame).
    fn spheres(levels: u32, count: usize) -> FrameCuts {
        let tree = DirectionTree::new(levels).unwrap();
        let vcf = VcfSampling { spheres: 4, rows: 8, cols: 8, ..VcfSampling::default() };
        let a = shapes::icosphere(Vec3::ZERO, 0.5, 1);
        let one = ObjectCuts::compute("sphere", &a, &tree, &SvcSettings::default(), &vcf, &no_progress).unwrap();
        FrameCuts::new(PrecomputedCuts { inputs_hash: [0; 32], levels, objects: vec![one; count], proxy: None }).unwrap()
    }

    #[test]
    fn a_lone_convex_object_sees_the_closed_form_sky() {
        // A sphere's vertex sees no part of itself: E_n per unit Pa of the uniform upper sky is
        // (1 + n_y)/2 exactly; the cut sum at S = 2^10 is within 2% of it (leaf quadrature and
        // the SVC threshold 0.1 on cos; sweep.rs measures 0.3% RMS at 2^15).
        let f = spheres(10, 1);
        let light = UnitLighting::uniform_sky(&f.tree);
        let amb = f.object_ambient(&light, &[Vec3::ZERO], Vec3::new(0.0, 0.0, 10.0)).unwrap();
        let obj = &f.cuts.objects[0];
        let mut worst = 0.0f32;
        for (v, a) in amb.vertices[0].iter().enumerate() {
            let n = obj.svc.normals[v];
            let want = (1.0 + n.y) / 2.0;
            worst = worst.max((a[0][1] - want).abs());
            assert_eq!(a[0][3], 1.0);
        }
        assert!(worst < 0.02, "worst |E_n − (1 + n_y)/2| = {worst}");
    }

    #[test]
    fn a_neighbour_darkens_the_facing_side_and_receivers() {
        let f = spheres(9, 2);
        let light = UnitLighting::uniform_sky(&f.tree);
        let eye = Vec3::new(0.0, 0.0, 10.0);
        let far = f.object_ambient(&light, &[Vec3::ZERO, Vec3::new(1000.0, 0.0, 0.0)], eye).unwrap();
        let near = f.object_ambient(&light, &[Vec3::ZERO, Vec3::new(1.2, 0.0, 0.0)], eye).unwrap();
        // The vertex of `a` facing +x (towards `b`) loses light; the one facing −x keeps it.
        let obj = &f.cuts.objects[0];
        let facing = (0..obj.positions.len()).max_by(|&i, &j| obj.svc.normals[i].x.total_cmp(&obj.svc.normals[j].x)).unwrap();
        let away = (0..obj.positions.len()).min_by(|&i, &j| obj.svc.normals[i].x.total_cmp(&obj.svc.normals[j].x)).unwrap();
        assert!(near.vertices[0][facing][0][1] < 0.8 * far.vertices[0][facing][0][1]);
        assert!((near.vertices[0][away][0][1] - far.vertices[0][away][0][1]).abs() < 1e-6);
        // A receiver under `b` loses sky; one far away keeps all of it.
        let rc = f.receivers(Arc::new(light), vec![Vec3::ZERO, Vec3::new(3.0, 0.0, 0.0)]);
        let v = rc.visibility(&[(Vec3::new(3.0, -0.6, 0.0), Vec3::Y), (Vec3::new(-30.0, -0.6, 0.0), Vec3::Y)]);
        // Far away the field is clamped to its outermost sphere (10 r), where the sphere hides
        // a cone of 5.7°: under 1% of the receiver's light.
        assert!(v[0] < 0.7 && v[1] > 0.99, "{v:?}");
    }
}
