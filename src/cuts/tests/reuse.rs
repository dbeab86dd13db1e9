//! The objects' ambient kept between frames (`crate::cuts::reuse`) against fresh evaluations,
//! and the fields left out exactly beyond their reach on the vertices' side (`crate::cuts::frame`).

use crate::cuts::bounce::{Bounce, BounceSurface};
use crate::cuts::eval::ObjectCuts;
use crate::cuts::file::PrecomputedCuts;
use crate::cuts::frame::{FrameCuts, UnitLighting};
use crate::cuts::reuse::{AmbientCache, ObjectUse};
use crate::cuts::rotate::Pose;
use crate::cuts::self_bounce::SelfGather;
use crate::cuts::svc::SvcSettings;
use crate::cuts::tree::DirectionTree;
use crate::cuts::vcf::VcfSampling;
use crate::cuts::{no_progress, shapes};
use crate::geometry::Mesh;
use glam::{Mat3, Vec3};
use std::sync::Arc;

const LEVELS: u32 = 9;

/// A sphere of `radius` at the origin and its cuts (fields 4 × 8² from 1.2 r to 10 r: they
/// reach 10 r from the centre).
fn sphere(tree: &DirectionTree, radius: f32) -> (Mesh, ObjectCuts) {
    let mesh = shapes::icosphere(Vec3::ZERO, radius, 1);
    let vcf = VcfSampling { spheres: 4, rows: 8, cols: 8, ..VcfSampling::default() };
    let cuts = ObjectCuts::compute("sphere", &mesh, tree, &SvcSettings::default(), &vcf, &no_progress).unwrap();
    (mesh, cuts)
}

fn frame(objects: Vec<ObjectCuts>) -> FrameCuts {
    FrameCuts::new(PrecomputedCuts { inputs_hash: [0; 32], levels: LEVELS, objects, proxy: None }).unwrap()
}

#[test]
fn a_vertex_beyond_every_other_objects_reach_gets_exactly_its_lone_value() {
    let tree = DirectionTree::new(LEVELS).unwrap();
    let (mesh, a) = sphere(&tree, 0.5);
    let lone = frame(vec![a.clone()]);
    let two = frame(vec![a.clone(), a]);
    let light = Arc::new(UnitLighting::uniform_sky(&lone.tree));
    let eye = Vec3::new(0.0, 1.0, 10.0);
    let alone = lone.object_ambient_posed(&light, &[Pose::translated(Vec3::ZERO)], eye).unwrap();
    // `b` reaches 5 m from its centre; `a`'s vertices lie 5.5 m or more from it (the clamped
    // outermost cut would hide a cap of 0.25% of the sphere there).
    let poses = [Pose::translated(Vec3::ZERO), Pose::translated(Vec3::new(6.0, 0.0, 0.0))];
    let with = two.object_ambient_posed(&light, &poses, eye).unwrap();
    assert_eq!(with.vertices[0], alone.vertices[0]);
    // Nor does `b` send light or shade the sun there: the bounce adds nothing to `a`.
    let surf = BounceSurface::from_mesh(&mesh);
    let bounce = Bounce { surfaces: &[surf.clone(), surf], sun: Some(Vec3::new(0.3, 0.9, 0.1).normalize()), own: &[], proxy: None };
    assert_eq!(two.object_ambient_bounced(&light, &poses, eye, &bounce).unwrap().vertices[0], alone.vertices[0]);
    // Within reach (1.2 m apart) the facing side loses light.
    let near = [Pose::translated(Vec3::ZERO), Pose::translated(Vec3::new(1.2, 0.0, 0.0))];
    assert_ne!(two.object_ambient_posed(&light, &near, eye).unwrap().vertices[0], alone.vertices[0]);
}

/// A large sphere `a` (radius 1 m, reach 10 m) that stands still and a small one `b` (0.25 m,
/// reach 2.5 m) that moves; sun, bounce and self-bounce on.
struct Pair {
    cuts: FrameCuts,
    surfaces: Vec<BounceSurface>,
    own: Vec<SelfGather>,
    light: Arc<UnitLighting>,
}

impl Pair {
    fn new() -> Self {
        let tree = DirectionTree::new(LEVELS).unwrap();
        let ((ma, a), (mb, b)) = (sphere(&tree, 1.0), sphere(&tree, 0.25));
        let own = vec![SelfGather::from_mesh(&ma, &a.svc.normals, 16), SelfGather::from_mesh(&mb, &b.svc.normals, 16)];
        let cuts = frame(vec![a, b]);
        let light = Arc::new(UnitLighting::uniform_sky(&cuts.tree));
        Self { cuts, surfaces: vec![BounceSurface::from_mesh(&ma), BounceSurface::from_mesh(&mb)], own, light }
    }

    fn bounce(&self) -> Bounce<'_> {
        Bounce { surfaces: &self.surfaces, sun: Some(Vec3::new(0.3, 0.9, 0.1).normalize()), own: &self.own, proxy: None }
    }

    fn poses(b: Vec3) -> Vec<Pose> {
        let turn = Mat3::from_rotation_y(0.4);
        vec![Pose::translated(Vec3::ZERO), Pose::from_parts(turn, b).unwrap()]
    }
}

#[test]
fn the_ambient_kept_between_frames_equals_a_fresh_evaluation_bit_for_bit() {
    let p = Pair::new();
    let eye = Vec3::new(0.0, 1.5, 8.0);
    let mut cache = AmbientCache::default();
    let count = p.cuts.cuts.objects[0].positions.len();
    // `b` 6 m away (beyond its reach of `a`), moved, then 2 m away (it reaches part of `a`),
    // then back (its old pose reached part of `a`), then still.
    let path = [Vec3::new(6.0, 0.0, 0.0), Vec3::new(6.0, 0.0, 1.0), Vec3::new(2.0, 0.0, 0.0), Vec3::new(6.0, 0.0, 1.0), Vec3::new(6.0, 0.0, 1.0)];
    let count_b = p.cuts.cuts.objects[1].positions.len();
    let mut uses_a = Vec::new();
    for (i, b) in path.into_iter().enumerate() {
        let poses = Pair::poses(b);
        let fresh = p.cuts.object_ambient_bounced(&p.light, &poses, eye, &p.bounce()).unwrap();
        let (kept, uses) = p.cuts.object_ambient_reusing(&p.light, &poses, eye, &p.bounce(), &[false, false], &mut cache).unwrap();
        assert_eq!(kept, fresh, "b at {b}");
        // The moving object is evaluated whenever it moved; standing still, it is kept too.
        let want = if i == 4 { ObjectUse::Shown { evaluated: 0, reused: count_b } } else { ObjectUse::Shown { evaluated: count_b, reused: 0 } };
        assert_eq!(uses[1], want);
        uses_a.push(uses[0]);
    }
    assert_eq!(uses_a[0], ObjectUse::Shown { evaluated: count, reused: 0 });
    assert_eq!(uses_a[1], ObjectUse::Shown { evaluated: 0, reused: count });
    for u in &uses_a[2..4] {
        let ObjectUse::Shown { evaluated, reused } = *u else { panic!("{u:?}") };
        assert!(evaluated > 0 && reused > 0 && evaluated + reused == count, "part of a within 2.5 m of b: {u:?}");
    }
    assert_eq!(uses_a[4], ObjectUse::Shown { evaluated: 0, reused: count });
    // Another lighting (another allocation, even with the same values) evaluates everything.
    let light = Arc::new(UnitLighting::uniform_sky(&p.cuts.tree));
    let (_, uses) = p.cuts.object_ambient_reusing(&light, &Pair::poses(path[4]), eye, &p.bounce(), &[false, false], &mut cache).unwrap();
    assert_eq!(uses[0], ObjectUse::Shown { evaluated: count, reused: 0 });
}

#[test]
fn an_unused_object_is_evaluated_only_as_the_source_of_light_onto_a_shown_one() {
    let p = Pair::new();
    let eye = Vec3::new(0.0, 1.5, 8.0);
    let mut cache = AmbientCache::default();
    let count = p.cuts.cuts.objects[0].positions.len();
    // `a` (unused: it keeps its traced transfer) reaches `b` 6 m away: its first pass is the
    // source of the light it reflects onto `b`, whose rows are those of a fresh evaluation.
    for (i, b) in [Vec3::new(6.0, 0.0, 0.0), Vec3::new(6.5, 0.0, 0.5)].into_iter().enumerate() {
        let poses = Pair::poses(b);
        let fresh = p.cuts.object_ambient_bounced(&p.light, &poses, eye, &p.bounce()).unwrap();
        let (kept, uses) = p.cuts.object_ambient_reusing(&p.light, &poses, eye, &p.bounce(), &[true, false], &mut cache).unwrap();
        assert_eq!(kept.vertices[1], fresh.vertices[1]);
        let want = if i == 0 { ObjectUse::SourceOnly { evaluated: count, reused: 0 } } else { ObjectUse::SourceOnly { evaluated: 0, reused: count } };
        assert_eq!(uses[0], want);
    }
    // 30 m away `a` reaches no vertex of `b`: nothing of `a` is evaluated, its rows are zero
    // (not served), and `b`'s rows are still a fresh evaluation's.
    let poses = Pair::poses(Vec3::new(30.0, 0.0, 0.0));
    let fresh = p.cuts.object_ambient_bounced(&p.light, &poses, eye, &p.bounce()).unwrap();
    let (kept, uses) = p.cuts.object_ambient_reusing(&p.light, &poses, eye, &p.bounce(), &[true, false], &mut cache).unwrap();
    assert_eq!(uses[0], ObjectUse::Skipped);
    assert_eq!(kept.vertices[1], fresh.vertices[1]);
    assert!(kept.vertices[0].iter().all(|r| *r == [[0.0; 4]; 4]));
}
