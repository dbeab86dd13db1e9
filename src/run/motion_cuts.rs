//! The visibility cuts of a scene's moving objects in the frame loop (issue 15 §2; cyberworlds
//! §V, `../shared/papers/cyberworlds-captured-lighting-cuts.txt`): loaded or computed at the
//! start, evaluated for the objects' translations on the frames they move.
//!
//! # How it works
//! - **Loading** ([`CutState::load`]): `baked/cuts.bin` when it holds cuts of this scene's objects
//!   (same count, the same vertex positions at the first key), whatever settings `heliar
//!   precompute` used; otherwise the cuts are computed with [`PrecomputeOptions::frame_loop`]
//!   and cached there as `heliar precompute` does. When neither works, the frame loop re-traces
//!   on every move and each frame reports the cuts pass skipped with the reason.
//! - **Poses** ([`CutState::poses`]): an object's cuts hold in its pose at the first key; its
//!   pose this frame times the inverse of that is a translation, or a rotation and a translation
//!   (a turning sign, a turning statue: the products then run in the turned objects' frames,
//!   `crate::cuts::rotate`). A pose that is not rigid (scaled or mirrored since the first key)
//!   falls back to the re-trace, and the frame says which object.
//! - **Bounce** ([`CutState::evaluate`]): the light the objects reflect onto each other is added
//!   to the cuts' ambient (`crate::cuts::bounce`, an extension of Eq. 3), with each object's
//!   reflectance from its mesh's materials and the relighter's sun, and the light each object
//!   reflects onto itself (`crate::cuts::self_bounce`: its rays are cast once here, at loading,
//!   [`SELF_BOUNCE_RAYS`] per vertex; the scene loader has split the objects' long edges,
//!   `crate::geometry::subdivide`, so that the gather's sources and receivers are resolved).
//! - **Kept between frames** ([`CutState::evaluate`], `crate::cuts::reuse`): an object that keeps
//!   its traced transfer is evaluated only as the source of the light it reflects onto the others
//!   (or not at all), and vertices that no moved object reaches at its old or new pose keep their
//!   last first pass while their object, the lighting and the eye stay the same; the shown
//!   objects' ambient is the same bits as a fresh evaluation ([`CutState::evaluate_with`]).
//! - **Visibility products kept** (`crate::cuts::products`): where the lighting changed (a new
//!   sun or sky, every VEM frame, [`CutState::evaluate_reusing`]) but an object did not move, its
//!   vertices and the receivers no moved object reaches keep their product cuts and sum them
//!   with the new lighting, bit for bit as a fresh walk.
//! - **Lighting** ([`CutState::lighting`]): the relighter's map split per unit `Pa` and `Pd`
//!   (`crate::envmap::relight::Relighter::unit_maps`), clustered again only when its sun planes
//!   change; the uniform sky without a bake. With the relighter's texels as light arriving at
//!   their points (`Relighter::local_light`) and the objects' meshes, each vertex takes the
//!   proxy's light along its own rays (`crate::cuts::local_sun`), and the bounce sources' sun
//!   shadow is traced against the proxy (`crate::cuts::bounce::Bounce::proxy`).

use super::precompute::{self, PrecomputeOptions};
use crate::cuts::bounce::{Bounce, BounceSurface};
use crate::cuts::file::{self, PrecomputedCuts};
use crate::cuts::local_sun::LocalSun;
use crate::cuts::frame::{FrameCuts, ObjectAmbient, ReceiverCuts, UnitLighting};
use crate::cuts::products::{ProductUse, ReceiverProductUse, ReceiverProducts};
use crate::cuts::reuse::{AmbientCache, ObjectUse};
use crate::cuts::rotate::Pose;
use crate::cuts::self_bounce::{SELF_BOUNCE_RAYS, SelfGather};
use crate::cuts::{CutsError, no_progress};
use crate::envmap::relight::Relighter;
use crate::geometry::raycast::RayScene;
use crate::scene::Scene;
use glam::{Mat3, Mat4, Vec3};
use std::sync::{Arc, Mutex};

pub use crate::cuts::rotate::TURN_TOLERANCE;

/// Largest difference between a stored and a scene vertex position for `baked/cuts.bin` to be
/// taken as this scene's cuts, m.
const POSITION_TOLERANCE_M: f32 = 1e-5;

/// What the cuts pass did in one frame, for the report.
#[derive(Clone, Debug, PartialEq)]
pub enum CutOutcome {
    /// It ran, taking this many ms.
    Ran(f64),
    /// It was skipped for this reason.
    Skipped(String),
}

/// Lighting key: whether there is a relighter, and its sun planes' direction.
type LightKey = Option<Option<Vec3>>;

/// The cuts of a scene's objects and what the frame loop keeps of them.
pub struct CutState {
    frame: FrameCuts,
    /// Per object, the pose its cuts were computed at (`None`: a static object).
    origin: Vec<Option<Mat4>>,
    lighting: Option<(LightKey, Arc<UnitLighting>)>,
    /// Per object, what it reflects onto the others (`crate::cuts::bounce`).
    surfaces: Vec<BounceSurface>,
    /// Per object, its mesh in its cuts' frame (its shadow on the proxy, `crate::cuts::local_sun`).
    meshes: Vec<Arc<crate::geometry::Mesh>>,
    /// The same meshes to trace receivers against (`crate::cuts::receivers::near_cut`): the
    /// self-bounce gathers' own (`SelfGather::scene`), built once for both.
    near: Vec<Option<Arc<RayScene>>>,
    /// Per object, the rays from its vertices that meet itself (`crate::cuts::self_bounce`).
    own: Vec<SelfGather>,
    /// The objects' per-vertex ambient and visibility products kept between frames
    /// (`crate::cuts::reuse`, `crate::cuts::products`).
    cache: AmbientCache,
    /// The receivers' visibility products kept between frames (`crate::cuts::products`).
    receiver_products: Arc<Mutex<ReceiverProducts>>,
    /// This frame's outcome.
    pub outcome: CutOutcome,
    /// Per object, what this frame did with its per-vertex ambient (empty when the cuts did not
    /// run through [`Self::evaluate`]).
    pub uses: Vec<ObjectUse>,
}

fn same_objects(cuts: &PrecomputedCuts, scene: &Scene) -> bool {
    cuts.objects.len() == scene.virtual_objects.len()
        && cuts.objects.iter().zip(&scene.virtual_objects).all(|(c, o)| {
            c.positions.len() == o.mesh.positions.len() && c.positions.iter().zip(&o.mesh.positions).all(|(a, b)| (*a - *b).abs().max_element() <= POSITION_TOLERANCE_M)
        })
}

impl CutState {
    /// The cuts of `scene` (module docs); `proxy` is the proxy's BVH; `draggable`: computed
    /// for objects without a motion too (the live window moves them by hand). The error is the
    /// reason the frame loop reports.
    pub fn load(scene: &Scene, proxy: &RayScene, draggable: bool) -> Result<Self, String> {
        let path = precompute::cuts_path(scene);
        let opts = if draggable { PrecomputeOptions::draggable() } else { PrecomputeOptions::frame_loop() };
        let cuts = match file::read(&path) {
            Ok(c) if same_objects(&c, scene) => c,
            _ => {
                precompute::precompute(scene, proxy, &opts, &no_progress)
                    .map_err(|e| format!("no usable visibility cuts for {}: {e:#}: every move is re-traced", scene.root.display()))?;
                file::read(&path).map_err(|e| format!("{e}: every move is re-traced"))?
            }
        };
        let frame = FrameCuts::new(cuts).map_err(|e| format!("{}: {e}: every move is re-traced", path.display()))?;
        let origin = scene.virtual_objects.iter().map(|o| o.motion.as_ref().map(|m| m.motion.world_from_rest(m.motion.start_seconds()))).collect();
        let surfaces = scene.virtual_objects.iter().map(|o| BounceSurface::from_mesh(&o.mesh)).collect();
        // The cuts' vertices are the meshes' at the first key (`same_objects`, or computed from
        // them), in the cuts' frame: the gathers hold in every rigid pose.
        let own: Vec<SelfGather> = scene.virtual_objects.iter().zip(&frame.cuts.objects).map(|(o, c)| SelfGather::from_mesh(&o.mesh, &c.svc.normals, SELF_BOUNCE_RAYS)).collect();
        // The receivers' near field traces the same meshes the gathers were cast against.
        let near = own.iter().map(|g| g.scene.clone()).collect();
        let meshes: Vec<Arc<crate::geometry::Mesh>> = scene.virtual_objects.iter().map(|o| Arc::new(o.mesh.clone())).collect();
        Ok(Self { frame, origin, lighting: None, surfaces, own, meshes, near, cache: AmbientCache::default(), receiver_products: Arc::default(), uses: Vec::new(), outcome: CutOutcome::Skipped("no object has moved yet: the traced per-pixel transfer serves".into()) })
    }

    /// Each object's pose since its cuts were computed (`crate::cuts::rotate::Pose`), from its
    /// pose this frame: world from its rest frame for an object with a motion, world from its
    /// placement for one without (moved by hand in the live window), `None` where it stands as
    /// placed (the identity). `Err((k, why))` when object `k` is not moved rigidly (scaled or
    /// mirrored since its first key).
    pub fn poses(&self, poses: &[Option<Mat4>]) -> Result<Vec<Pose>, (usize, String)> {
        self.origin
            .iter()
            .enumerate()
            .map(|(k, origin)| {
                let d = match (origin, poses.get(k).copied().flatten()) {
                    (Some(o), Some(p)) => p * o.inverse(),
                    (None, Some(p)) => p,
                    (_, None) => return Ok(Pose::translated(Vec3::ZERO)),
                };
                Pose::from_parts(Mat3::from_mat4(d), d.w_axis.truncate()).map_err(|e| (k, e))
            })
            .collect()
    }

    /// True when `relighter`'s sun planes changed since the lighting was last clustered.
    pub fn lighting_changed(&self, relighter: Option<&Relighter>) -> bool {
        self.lighting.as_ref().is_none_or(|(k, _)| *k != relighter.map(Relighter::sun_dir))
    }

    /// The lighting per unit `Pa`, `Pd` on the cuts' tree (module docs).
    pub fn lighting(&mut self, relighter: Option<&Relighter>) -> Arc<UnitLighting> {
        let key = relighter.map(Relighter::sun_dir);
        if let Some((k, l)) = &self.lighting
            && *k == key
        {
            return l.clone();
        }
        let tree = &self.frame.tree;
        let l = match relighter {
            Some(r) => {
                let m = r.unit_maps();
                // A map the tree cannot take (a negative texel of a shaped sky) falls back to the
                // uniform sky rather than failing the frame.
                match UnitLighting::from_maps(tree, &m.sky_pa, &m.surface_pa, m.surface_pd.as_ref()) {
                    // The proxy's light as each vertex sees it (`crate::cuts::local_sun`).
                    Ok(l) => {
                        let texels = r.local_light();
                        UnitLighting { local: texels.map(|texels| Arc::new(LocalSun { texels, objects: self.meshes.clone() })), ..l }
                    }
                    Err(_) => UnitLighting::uniform_sky(tree),
                }
            }
            None => UnitLighting::uniform_sky(tree),
        };
        let l = Arc::new(l);
        self.lighting = Some((key, l.clone()));
        l
    }

    /// The objects' ambient per vertex and the receivers' visibility for `poses`, seen from
    /// `eye`. Vertices outside the proxy field's box (the `[irradiance]` box, whose floor lies a
    /// little above the ground) take the box's edge: finite, and an object that leaves the box
    /// is warned of by `super::motion`. `hidden[k]`: object `k`'s ambient will not be shown (it
    /// keeps its traced transfer); its rows are then left out or only its first pass
    /// (`crate::cuts::reuse`, which also keeps what did not change since the last call; the
    /// shown objects' rows are those of [`Self::evaluate_with`] bit for bit). [`Self::uses`]
    /// says what was done per object.
    pub fn evaluate(&mut self, poses: &[Pose], relighter: Option<&Relighter>, eye: Vec3, hidden: &[bool]) -> Result<(ObjectAmbient, ReceiverCuts), CutsError> {
        let light = self.lighting(relighter);
        let sun = relighter.and_then(Relighter::sun_dir);
        let proxy = light.local.as_ref().map(|l| &*l.texels.ray);
        let bounce = Bounce { surfaces: &self.surfaces, sun, own: &self.own, proxy };
        let result = self.frame.object_ambient_reusing(&light, poses, eye, &bounce, hidden, &mut self.cache);
        let (ambient, uses) = match result {
            Ok(r) => r,
            Err(e) => {
                self.cache.clear();
                self.uses.clear();
                return Err(e);
            }
        };
        self.uses = uses;
        let mut receivers = self.frame.receivers_posed(light.clone(), poses.to_vec()).with_products(self.receiver_products.clone());
        if light.local.is_some() {
            receivers = receivers.with_near(self.near.clone());
            // What the objects reflect onto the receivers they hide light from
            // (`crate::cuts::receiver_light`); an object whose first pass was skipped (not
            // shown, reaching no shown object) has no ambient rows to reflect and shows nothing.
            let uses = &self.uses;
            let radiance = self.frame.objects_radiance(&ambient, poses, &bounce, |b| !matches!(uses.get(b), Some(ObjectUse::Skipped)))?;
            let objects = &self.frame.cuts.objects;
            let points: Vec<Vec<Vec3>> = objects.iter().zip(poses).map(|(o, p)| o.positions.iter().map(|&x| p.point(x)).collect()).collect();
            let seen: Vec<(Vec3, f32, &[Vec3], &crate::cuts::bounce::ObjectRadiance)> =
                objects.iter().zip(poses).zip(&points).zip(&radiance).map(|(((o, p), x), r)| (p.point(o.vcf.centre), o.vcf.radius_m, &x[..], r)).collect();
            receivers = receivers.with_seen(Arc::new(crate::cuts::receiver_light::ObjectsSeen::new(&seen)));
        }
        Ok((ambient, receivers))
    }

    /// [`Self::evaluate_with`] keeping between calls what did not change
    /// (`crate::cuts::reuse`, `crate::cuts::products`): under a new lighting every call (the
    /// captured-VEM mode), the vertices and receivers that no moved object reaches sum their
    /// kept visibility products with it. Every object is shown; the rows and the receivers'
    /// values equal [`Self::evaluate_with`]'s bit for bit. [`Self::uses`] and
    /// [`Self::product_uses`] say what was done per object, [`Self::receiver_product_use`] for
    /// the receivers.
    pub fn evaluate_reusing(&mut self, poses: &[Pose], light: Arc<UnitLighting>, eye: Vec3, sun: Option<Vec3>) -> Result<(ObjectAmbient, ReceiverCuts), CutsError> {
        let bounce = Bounce { surfaces: &self.surfaces, sun, own: &self.own, proxy: None };
        match self.frame.object_ambient_reusing(&light, poses, eye, &bounce, &[], &mut self.cache) {
            Ok((ambient, uses)) => {
                self.uses = uses;
                let receivers = self.frame.receivers_posed(light, poses.to_vec()).with_products(self.receiver_products.clone());
                Ok((ambient, receivers))
            }
            Err(e) => {
                self.cache.clear();
                self.uses.clear();
                Err(e)
            }
        }
    }

    /// Per object, what the last evaluation did with its visibility products
    /// (`crate::cuts::products`).
    pub fn product_uses(&self) -> &[ProductUse] {
        self.cache.product_uses()
    }

    /// What the receivers' last evaluation did with their visibility products, and the bytes the
    /// vertices' and the receivers' products take now.
    pub fn receiver_product_use(&self) -> (ReceiverProductUse, usize) {
        let store = self.receiver_products.lock().unwrap_or_else(std::sync::PoisonError::into_inner);
        (store.last.clone(), self.cache.product_bytes() + store.bytes())
    }

    /// [`Self::evaluate`] under a lighting given on the cuts' tree ([`Self::tree`]) instead of
    /// the relighter's: the captured-VEM mode's frame (`super::vem_cuts`). `sun`: the sun's
    /// direction when the lighting leaves it out (the outdoor mode's sun planes), for the light
    /// the objects reflect onto each other (`crate::cuts::bounce`); `None` when the lighting holds
    /// all of it (a VEM frame).
    pub fn evaluate_with(&self, poses: &[Pose], light: Arc<UnitLighting>, eye: Vec3, sun: Option<Vec3>) -> Result<(ObjectAmbient, ReceiverCuts), CutsError> {
        let ambient = self.frame.object_ambient_bounced(&light, poses, eye, &Bounce { surfaces: &self.surfaces, sun, own: &self.own, proxy: None })?;
        let receivers = self.frame.receivers_posed(light, poses.to_vec());
        Ok((ambient, receivers))
    }

    /// Per object, how far its visibility cut field reaches beyond its bounding sphere's centre:
    /// the outermost sphere's radius, m (`crate::cuts::vcf`; the compositor measures it from the
    /// object's box, `render::compositor`'s `kept`, which reaches a little farther).
    pub fn reach_m(&self) -> Vec<f32> {
        self.frame.cuts.objects.iter().map(|o| o.vcf.radius_m * o.vcf.sampling.outer_factor).collect()
    }

    /// The cuts' direction tree.
    pub fn tree(&self) -> &crate::cuts::DirectionTree {
        &self.frame.tree
    }

    /// The cuts themselves (per object: vertices, fields' centres and radii).
    pub fn cuts(&self) -> &PrecomputedCuts {
        &self.frame.cuts
    }
}

/// The receivers' visibility as the compositor keeps it between frames
/// (`render::compositor`'s `cut_cache`): evaluated only where a moved object's field reaches.
impl crate::render::compositor::ReceiverField for ReceiverCuts {
    fn visibility(&self, surfaces: &[(Vec3, Vec3)], which: &[usize]) -> Vec<crate::cuts::receivers::LightLeft> {
        self.visibility_of(surfaces, which)
    }

    fn pose_keys(&self) -> Option<Vec<[u32; 12]>> {
        let key = |p: &Pose| {
            // Not turned: marked apart from any rotation (a rotation's entries are finite).
            let r = p.rotation.map_or([u32::MAX; 9], |r| r.to_cols_array().map(f32::to_bits));
            let t = p.translation.to_array().map(f32::to_bits);
            std::array::from_fn(|i| if i < 9 { r[i] } else { t[i - 9] })
        };
        Some(self.poses().iter().map(key).collect())
    }

    fn lighting_key(&self) -> usize {
        Arc::as_ptr(self.lighting()) as usize
    }

    fn reaches(&self, b: usize, x: Vec3) -> bool {
        ReceiverCuts::reaches(self, b, x)
    }
}
