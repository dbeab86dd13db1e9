//! The visibility cuts in the frame loop (issue 15 §2; cyberworlds §V-A.4 and §V-B,
//! `../shared/papers/cyberworlds-captured-lighting-cuts.txt`): the objects' ambient per vertex
//! and the real receivers' sky visibility with the objects present, for the objects at this
//! frame's poses (translated and turned about any axis, [`super::rotate`]).
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
//! - **Turned objects** ([`FrameCuts::object_ambient_posed`]): each object's product runs in its
//!   own frame (`super::rotate`): the lighting clustered in it ([`UnitLighting::in_frame`]), the
//!   vertex's self-visibility cut and normal as stored, the view's reflection turned into it, the
//!   other objects' fields (looked up at the vertex taken into *their* frames) and the proxy
//!   field remapped into it. An object that is not turned uses none of this: translated scenes
//!   compute exactly what they did.
//! - **Other objects' reflected light** (`FrameCuts::add_bounce`, [`super::bounce`]): a second
//!   pass adds to each vertex the light the other objects reflect into the directions their
//!   fields close, from their own first-pass ambient and the sun (an extension of Eq. 3; the
//!   frame loop runs it, `crate::run::motion_cuts`). [`FrameCuts::object_ambient_posed`] alone
//!   is Eq. 3 as the paper has it.
//! - **Receivers** ([`ReceiverCuts`], `super::receivers`): a real surface point's share of its
//!   sky light that the objects leave ([`super::lighting::sky_visibility`], weights from the sky
//!   per unit `Pa` and the receiver's cosine); the compositor sets `c_v = c·V` and `b_v = b·V`
//!   from it instead of tracing them again. An object beyond its field's outermost sphere is left
//!   out there (exactly 1), so the compositor evaluates only the receivers a moved object reaches.
//!   The objects' vertices leave it out there too (`FrameCuts::occluders`, the bounce's sun
//!   visibility), so a vertex no moved object reaches keeps its value (`super::reuse`).
//!
//! # Limits
//! `V` at a receiver counts the sky an object hides even where the proxy hides it
//! already (`c` has that part removed), so contact shadows in a wall's sky shadow come out a
//! little too dark; the bounce an object blocks is taken in the same share as the sky.
//!
//! The map's surface texels are the proxy as the map's capture point sees it, multiplied by the
//! objects' visibility only: an object in a wall's sun shadow gets the bounce of the sunlit
//! paving the capture point sees where its own view has the wall's shaded paving and face. That
//! was the dominant error of the unmoved statue against its traced transfer (7.35% where issue 15
//! §3 asks 2%; `tests/suite/object_cuts_static.rs`). The frame loop's outdoor path therefore
//! replaces, per vertex and coarse direction, the texels' light by the proxy's light the vertex
//! itself sees ([`UnitLighting::local`], `super::local_sun`; 2.22% since, docs/measurements.md,
//! "The proxy's light per vertex"); [`Self::object_ambient_posed`] without it is the map's.

pub use super::receivers::ReceiverCuts;
use super::file::PrecomputedCuts;
use super::lighting::{ClusteredLighting, MIN_BRDF_COS};
use super::local_sun::{LocalFrame, LocalSun};
use super::packed::CutView;
use super::rotate::{LeafIndex, LeafRemap, Pose, relative};
use super::tree::{DirectionTree, node_index};
use super::vcf::FieldRegion;
use super::products::{VertexProduct, walk_into};
use super::walk::product_for_each;
use super::{Cut, CutsError};
use crate::io::image::LinearImage;
use glam::{Mat3, Vec3};
use rayon::prelude::*;
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
    /// The maps clustered (`None`: the uniform sky), kept to cluster them again in a turned
    /// object's frame ([`Self::in_frame`]).
    pub maps: Option<Arc<LightingMaps>>,
    /// The proxy's light as each vertex sees it (`super::local_sun`; the frame loop's outdoor
    /// path only): the surface texels' light replaced per vertex and coarse direction.
    pub local: Option<Arc<LocalSun>>,
}

/// The three parts of a relit map (equirect, the crate's convention).
#[derive(Clone, Debug, PartialEq)]
pub struct LightingMaps {
    /// Sky texels per unit `Pa`.
    pub sky_pa: LinearImage,
    /// Surface texels per unit `Pa`.
    pub surface_pa: LinearImage,
    /// Surface texels per unit `Pd`.
    pub surface_pd: Option<LinearImage>,
}

impl UnitLighting {
    /// The uniform upper-hemisphere sky of the crate's radiometry: radiance `1/π` per unit `Pa`.
    pub fn uniform_sky(tree: &DirectionTree) -> Self {
        let sky_pa = ClusteredLighting::from_fn(tree, |d| if d.y > 0.0 { Vec3::splat(FRAC_1_PI) } else { Vec3::ZERO });
        Self { sky_pa, surface_pa: None, surface_pd: None, maps: None, local: None }
    }

    /// The three parts of a relit map, each an equirect map in the crate's convention.
    pub fn from_maps(tree: &DirectionTree, sky_pa: &LinearImage, surface_pa: &LinearImage, surface_pd: Option<&LinearImage>) -> Result<Self, CutsError> {
        Ok(Self {
            sky_pa: ClusteredLighting::from_equirect(tree, sky_pa)?,
            surface_pa: Some(ClusteredLighting::from_equirect(tree, surface_pa)?),
            surface_pd: surface_pd.map(|m| ClusteredLighting::from_equirect(tree, m)).transpose()?,
            maps: Some(Arc::new(LightingMaps { sky_pa: sky_pa.clone(), surface_pa: surface_pa.clone(), surface_pd: surface_pd.cloned() })),
            local: None,
        })
    }

    /// A captured environment (the VEM mode): `radiance(ω)` sampled at the texel centres of an
    /// equirect map `width × width/2` (the crate's convention) and clustered as
    /// [`Self::from_maps`] with `Pa = 1`, `Pd = 0`: the texels above the horizon are the sky
    /// part (the proxy field hides them), those below the surface part (the ground as the
    /// capture point sees it, hidden by the objects only; module docs). A sun-like peak narrower
    /// than a texel is averaged over its texel, so `width` should resolve it.
    pub fn from_radiance(tree: &DirectionTree, width: u32, radiance: impl Fn(Vec3) -> [f32; 3]) -> Result<Self, CutsError> {
        let (w, h) = (width.max(2), (width / 2).max(1));
        let dir = |i: u32, j: u32| crate::geometry::equirect::dir_from_texel_centre(i, j, w, h);
        let sky = LinearImage::from_fn(w, h, |i, j| if dir(i, j).y >= 0.0 { radiance(dir(i, j)) } else { [0.0; 3] });
        let ground = LinearImage::from_fn(w, h, |i, j| if dir(i, j).y < 0.0 { radiance(dir(i, j)) } else { [0.0; 3] });
        Self::from_maps(tree, &sky, &ground, None)
    }

    /// The same lighting in the frame of an object turned by `rotation` (object → world): the
    /// maps clustered again with every texel turned into the object's frame
    /// (`crate::cuts::rotate`); the uniform sky turned analytically.
    pub fn in_frame(&self, tree: &DirectionTree, rotation: Mat3) -> Result<Self, CutsError> {
        let Some(m) = &self.maps else {
            let sky_pa = ClusteredLighting::from_fn(tree, |d| if (rotation * d).y > 0.0 { Vec3::splat(FRAC_1_PI) } else { Vec3::ZERO });
            return Ok(Self { sky_pa, surface_pa: None, surface_pd: None, maps: None, local: None });
        };
        let cluster = |map: &LinearImage| ClusteredLighting::from_equirect_in_frame(tree, map, rotation);
        Ok(Self {
            sky_pa: cluster(&m.sky_pa)?,
            surface_pa: Some(cluster(&m.surface_pa)?),
            surface_pd: m.surface_pd.as_ref().map(cluster).transpose()?,
            maps: self.maps.clone(),
            local: self.local.clone(),
        })
    }
}

/// `(E_n, E_r)` of each of `lights` over a product cut's non-zero nodes `(heap ids, values)` in
/// the walk's order (module docs).
fn product_sums(tree: &DirectionTree, lights: &[&ClusteredLighting], (ids, values): (&[u16], &[f32]), n: Vec3, r: Vec3) -> Vec<(Vec3, Vec3)> {
    let mut out = vec![(Vec3::ZERO, Vec3::ZERO); lights.len()];
    if lights.is_empty() {
        return out;
    }
    for (&k, &value) in ids.iter().zip(values) {
        add_node(&mut out, tree, lights, k as usize, value, n, r);
    }
    out
}

/// Adds node `k`'s light of each of `lights` times `weight` to `out`: about the normal `n`, and
/// with the reflected direction `r`'s lobe (one node's share of Eqs. 3–4's sum).
pub(super) fn add_node(out: &mut [(Vec3, Vec3)], tree: &DirectionTree, lights: &[&ClusteredLighting], k: usize, weight: f32, n: Vec3, r: Vec3) {
    let d = tree.node_dir(k);
    let spec = r.dot(d).max(0.0) / n.dot(d).max(MIN_BRDF_COS);
    for (o, l) in out.iter_mut().zip(lights) {
        let lv = l.node(k) * weight;
        o.0 += lv;
        o.1 += lv * spec;
    }
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
    /// A kd-tree over the leaves (remaps for turned objects, `super::rotate`).
    pub index: Arc<LeafIndex>,
}

/// The other objects' fields at one vertex, culled (§V-B): `(object, cut)` in the vertex's
/// object's frame.
pub(super) type Occluders = Vec<(usize, Cut)>;

/// The per-vertex ambient of every object, and how many vertices fell outside the proxy box.
#[derive(Clone, Debug, Default, PartialEq)]
pub struct ObjectAmbient {
    /// Per object, per mesh vertex.
    pub vertices: Vec<Vec<VertexAmbient>>,
    /// Vertices whose proxy-field lookup was clamped to the box (a warning, never NaN).
    pub outside_proxy_box: usize,
}

/// What one object's product needs in its own frame: the lighting, and the remaps of the proxy
/// field (world frame) and of the other objects' fields into the object's frame (`None`: the
/// same frame, used as stored).
pub(super) struct ObjectFrame {
    lighting: Arc<UnitLighting>,
    proxy: Option<LeafRemap>,
    others: Vec<Option<LeafRemap>>,
    /// The proxy's light per vertex (`super::local_sun`), when the lighting has it.
    local: Option<LocalFrame>,
}

impl FrameCuts {
    /// Builds the tree of `cuts`.
    pub fn new(cuts: PrecomputedCuts) -> Result<Self, CutsError> {
        let tree = Arc::new(DirectionTree::new(cuts.levels)?);
        let index = Arc::new(LeafIndex::new(&tree)?);
        Ok(Self { cuts: Arc::new(cuts), tree, index })
    }

    /// The ambient of every vertex of every object translated by `translations` (object frame
    /// + translation = world), seen from the eye at `eye`; in parallel over vertices.
    pub fn object_ambient(&self, lighting: &UnitLighting, translations: &[Vec3], eye: Vec3) -> Result<ObjectAmbient, CutsError> {
        let poses: Vec<Pose> = translations.iter().map(|&t| Pose::translated(t)).collect();
        self.object_ambient_posed(&Arc::new(lighting.clone()), &poses, eye)
    }

    pub(super) fn check_poses(&self, poses: &[Pose]) -> Result<(), CutsError> {
        if poses.len() != self.cuts.objects.len() {
            return Err(CutsError::Operands(format!("{} objects but {} poses", self.cuts.objects.len(), poses.len())));
        }
        if let Some(p) = poses.iter().find(|p| !p.translation.is_finite() || p.rotation.is_some_and(|r| !r.is_finite())) {
            return Err(CutsError::NonFinitePoint(p.translation.to_array()));
        }
        Ok(())
    }

    /// Object `k`'s frame this frame (see [`ObjectFrame`]).
    pub(super) fn object_frame(&self, lighting: &Arc<UnitLighting>, poses: &[Pose], k: usize) -> Result<ObjectFrame, CutsError> {
        let remap = |q: Option<Mat3>| q.map(|q| LeafRemap::new(&self.tree, &self.index, q));
        let own = poses[k].rotation;
        let lighting = match own {
            Some(r) => Arc::new(lighting.in_frame(&self.tree, r)?),
            None => lighting.clone(),
        };
        let others = poses.iter().map(|p| remap(relative(p.rotation, own))).collect();
        let local = lighting.local.clone().map(|l| LocalFrame::new(l, poses));
        Ok(ObjectFrame { lighting, proxy: remap(relative(None, own)), others, local })
    }

    /// The ambient of every vertex of every object at `poses` (cut frame → world, `super::rotate`),
    /// seen from the eye at `eye`; in parallel over vertices. Each object's product runs in its
    /// own frame: its self-visibility cut as stored, the lighting clustered in its frame, the
    /// other fields and the proxy field remapped into it (module docs of `super::rotate`).
    pub fn object_ambient_posed(&self, lighting: &Arc<UnitLighting>, poses: &[Pose], eye: Vec3) -> Result<ObjectAmbient, CutsError> {
        Ok(self.object_ambient_kept(lighting, poses, eye, false)?.0)
    }

    /// [`Self::object_ambient_posed`], and with `keep` the other objects' fields at every vertex
    /// as the product used them (object `b`, its cut in the vertex's object's frame), per
    /// object and vertex, for the bounce (`super::bounce`).
    pub(super) fn object_ambient_kept(&self, lighting: &Arc<UnitLighting>, poses: &[Pose], eye: Vec3, keep: bool) -> Result<(ObjectAmbient, Vec<Vec<Occluders>>), CutsError> {
        self.check_poses(poses)?;
        let mut out = ObjectAmbient::default();
        let mut kept = Vec::new();
        for (k, obj) in self.cuts.objects.iter().enumerate() {
            let frame = self.object_frame(lighting, poses, k)?;
            let rows: Vec<(VertexAmbient, bool, Occluders)> =
                (0..obj.positions.len().min(obj.svc.cuts.len())).into_par_iter().map(|v| self.vertex_ambient(&frame, poses, k, v, eye)).collect::<Result<_, _>>()?;
            out.outside_proxy_box += rows.iter().filter(|r| r.1).count();
            let (amb, others): (Vec<VertexAmbient>, Vec<Occluders>) = rows.into_iter().map(|r| (r.0, r.2)).unzip();
            out.vertices.push(amb);
            if keep {
                kept.push(others);
            }
        }
        Ok((out, kept))
    }

    /// The other objects' fields at `x` (world) with normal `n` (world), culled as
    /// `CutScene::occluder_cuts` does (§V-B), left out beyond their outermost sphere
    /// ([`super::vcf::VisibilityCutField::beyond_reach`]: exactly 1 there) and remapped by `others[b]` into the frame of
    /// object `skip` (`ObjectFrame::others`; the bounce's own remaps in `super::bounce`).
    pub(super) fn occluders(&self, others: &[Option<LeafRemap>], poses: &[Pose], x: Vec3, n: Vec3, skip: usize) -> Result<Occluders, CutsError> {
        let mut cuts = Vec::new();
        for (b, obj) in self.cuts.objects.iter().enumerate() {
            if b == skip {
                continue;
            }
            let centre = poses[b].point(obj.vcf.centre);
            if n != Vec3::ZERO && n.dot(centre - x) < -obj.vcf.radius_m {
                continue;
            }
            // Beyond the outermost sphere the object is left out (its field exactly 1), as on
            // the receivers' side: a vertex no other object reaches keeps its value exactly.
            let local = poses[b].local_point(x);
            if obj.vcf.beyond_reach(local) {
                continue;
            }
            let (cut, _region) = obj.vcf.lookup(local)?;
            cuts.push((b, match &others[b] {
                Some(remap) => remap.cut(cut.view())?,
                None => cut,
            }));
        }
        Ok(cuts)
    }

    /// Vertex `v` of `object` placed by its pose: the world point, the normal in the object's
    /// frame and in the world, and the view direction's mirror about the normal (world) for `eye`.
    pub(super) fn vertex_geometry(&self, poses: &[Pose], object: usize, v: usize, eye: Vec3) -> Result<(Vec3, Vec3, Vec3, Vec3), CutsError> {
        let obj = &self.cuts.objects[object];
        let pose = poses[object];
        let x = pose.point(obj.positions[v]);
        if !x.is_finite() {
            return Err(CutsError::NonFinitePoint(x.to_array()));
        }
        let n_local = obj.svc.normals[v];
        let n = pose.dir(n_local);
        let view = (eye - x).normalize_or(Vec3::Y);
        Ok((x, n_local, n, (2.0 * n.dot(view) * n - view).normalize_or(n)))
    }

    /// One vertex of [`Self::object_ambient_posed`], and whether its proxy lookup was clamped:
    /// its product cuts ([`Self::vertex_product`]) summed against the lighting
    /// ([`Self::ambient_from_product`]).
    pub(super) fn vertex_ambient(&self, frame: &ObjectFrame, poses: &[Pose], object: usize, v: usize, eye: Vec3) -> Result<(VertexAmbient, bool, Occluders), CutsError> {
        let (product, others) = self.vertex_product(frame, poses, object, v)?;
        let amb = self.ambient_from_product(frame, poses, object, v, eye, &product)?;
        Ok((amb, product.outside, others))
    }

    /// Vertex `v`'s product cuts (Eq. 4) in its object's frame, as the walk emits them (its
    /// non-zero nodes, `super::products`): `SVC × Π VCF` for the surface lighting and, with a
    /// proxy field, `× proxy` for the sky; with the other objects' fields it used. They depend on
    /// the poses only (the vertex's object's and those of the objects that reach it), not on the
    /// lighting nor the eye.
    pub(super) fn vertex_product(&self, frame: &ObjectFrame, poses: &[Pose], object: usize, v: usize) -> Result<(VertexProduct, Occluders), CutsError> {
        let obj = &self.cuts.objects[object];
        let (x, _, n, _) = self.vertex_geometry(poses, object, v, Vec3::ZERO)?;
        let others = self.occluders(&frame.others, poses, x, n, object)?;
        let (proxy, outside) = match &self.cuts.proxy {
            Some(field) => {
                let (cut, region) = field.lookup(x)?;
                let cut = match &frame.proxy {
                    Some(remap) => remap.cut(cut.view())?,
                    None => cut,
                };
                (Some(cut), region == FieldRegion::OutsideBox)
            }
            None => (None, false),
        };
        let mut views: Vec<CutView> = Vec::with_capacity(others.len() + 2);
        views.push(obj.svc.cuts.view(v));
        views.extend(others.iter().map(|(_, c)| c.view()));
        let levels = self.tree.levels();
        let record = |ids: &mut Vec<u16>, values: &mut Vec<f32>, h: u32, first: u32, value: f32| {
            if value != 0.0 {
                ids.push(node_index(levels, h, first) as u16);
                values.push(value);
            }
        };
        let (ids, values, sky_at) = walk_into(|ids, values| {
            product_for_each(&views, |h, first, value| record(ids, values, h, first, value))?;
            let sky_at = ids.len();
            if let Some(p) = &proxy {
                views.push(p.view());
                product_for_each(&views, |h, first, value| record(ids, values, h, first, value))?;
            }
            Ok::<_, CutsError>(sky_at)
        })?;
        Ok((VertexProduct::new(ids, values, proxy.is_some().then_some(sky_at), outside), others))
    }

    /// Vertex `v`'s ambient from its product cuts under `frame`'s lighting, seen from `eye`:
    /// the sums of Eqs. 3–4 over the product's nodes in the walk's order, the same floating-point
    /// operations in the same order as summing during the walk (`super::products`).
    pub(super) fn ambient_from_product(&self, frame: &ObjectFrame, poses: &[Pose], object: usize, v: usize, eye: Vec3, product: &VertexProduct) -> Result<VertexAmbient, CutsError> {
        let (_, n_local, _, r) = self.vertex_geometry(poses, object, v, eye)?;
        // The object's frame: its normal as stored, `r` turned into it.
        let (n, r) = (n_local, poses[object].local_dir(r));
        let lighting = &*frame.lighting;
        let surface: Vec<&ClusteredLighting> = [lighting.surface_pa.as_ref(), lighting.surface_pd.as_ref()].into_iter().flatten().collect();
        let surf = product_sums(&self.tree, &surface, product.surface(), n, r);
        let zero = (Vec3::ZERO, Vec3::ZERO);
        let surf_pa = if lighting.surface_pa.is_some() { surf[0] } else { zero };
        let surf_pd = if lighting.surface_pd.is_some() { surf[surf.len() - 1] } else { zero };
        let sky = product_sums(&self.tree, &[&lighting.sky_pa], product.sky(), n, r)[0];
        let (surf_pa, surf_pd) = match &frame.local {
            Some(local) => {
                let x = poses[object].point(self.cuts.objects[object].positions[v]);
                let [a, d] = local.deltas(&self.tree, lighting, &poses[object], x, n).sums(&self.tree, product.surface(), n, r);
                ((surf_pa.0 + a.0, surf_pa.1 + a.1), (surf_pd.0 + d.0, surf_pd.1 + d.1))
            }
            None => (surf_pa, surf_pd),
        };
        Ok([rgbw(sky.0 + surf_pa.0, 1.0), rgbw(sky.1 + surf_pa.1, 0.0), rgbw(surf_pd.0, 0.0), rgbw(surf_pd.1, 0.0)])
    }

    /// The receivers' visibility for the objects at `translations` under `lighting`'s sky.
    pub fn receivers(&self, lighting: Arc<UnitLighting>, translations: Vec<Vec3>) -> ReceiverCuts {
        self.receivers_posed(lighting, translations.into_iter().map(Pose::translated).collect())
    }

    /// The receivers' visibility for the objects at `poses` under `lighting`'s sky.
    pub fn receivers_posed(&self, lighting: Arc<UnitLighting>, poses: Vec<Pose>) -> ReceiverCuts {
        ReceiverCuts::new(self.clone(), lighting, poses)
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
        // Far away, beyond the field's outermost sphere (10 r), the receivers leave the object
        // out: exactly 1 (the clamped outermost cut would hide a cone of 5.7°).
        assert!(v[0].ambient < 0.7 && v[1] == crate::cuts::receivers::LightLeft::ALL, "{v:?}");
    }
}
