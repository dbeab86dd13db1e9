//! Visibility products kept between frames (`crate::cuts::products`) against fresh walks, over
//! frames whose lighting changes every time while an object moves into the other's reach and
//! out again.

use crate::cuts::bounce::{Bounce, BounceSurface};
use crate::cuts::eval::ObjectCuts;
use crate::cuts::file::PrecomputedCuts;
use crate::cuts::frame::{FrameCuts, UnitLighting};
use crate::cuts::products::{ProductBudget, ProductUse, ReceiverProducts};
use crate::cuts::proxy_field::{ProxyField, ProxyGrid};
use crate::cuts::reuse::AmbientCache;
use crate::cuts::rotate::Pose;
use crate::cuts::self_bounce::SelfGather;
use crate::cuts::svc::SvcSettings;
use crate::cuts::tree::DirectionTree;
use crate::cuts::vcf::VcfSampling;
use crate::cuts::{no_progress, shapes};
use crate::geometry::raycast::RayScene;
use glam::{Mat3, Vec3};
use std::sync::Arc;

const LEVELS: u32 = 9;

/// A large sphere `a` (radius 1 m, reach 10 m) that stands still, a small one `b` (0.25 m, reach
/// 2.5 m, turned) that moves, a wall's proxy field behind them (so that the sky product differs
/// from the surface product), the sun, the bounce and the self-bounce on.
struct Scene {
    cuts: FrameCuts,
    surfaces: Vec<BounceSurface>,
    own: Vec<SelfGather>,
}

impl Scene {
    fn new() -> Self {
        let tree = DirectionTree::new(LEVELS).unwrap();
        let vcf = VcfSampling { spheres: 4, rows: 8, cols: 8, ..VcfSampling::default() };
        let object = |r: f32| {
            let mesh = shapes::icosphere(Vec3::ZERO, r, 1);
            let cuts = ObjectCuts::compute("sphere", &mesh, &tree, &SvcSettings::default(), &vcf, &no_progress).unwrap();
            (mesh, cuts)
        };
        let ((ma, a), (mb, b)) = (object(1.0), object(0.25));
        let grid = ProxyGrid { min: [-3.0, -1.5, -3.0], max: [8.0, 1.5, 3.0], counts: [4, 3, 3], threshold: 0.0 };
        let proxy = ProxyField::compute(&RayScene::new(shapes::wall(-4.0, 9.0, 3.0, -4.0)), &tree, &grid, &no_progress).unwrap();
        let own = vec![SelfGather::from_mesh(&ma, &a.svc.normals, 16), SelfGather::from_mesh(&mb, &b.svc.normals, 16)];
        let cuts = FrameCuts::new(PrecomputedCuts { inputs_hash: [0; 32], levels: LEVELS, objects: vec![a, b], proxy: Some(proxy) }).unwrap();
        Self { cuts, surfaces: vec![BounceSurface::from_mesh(&ma), BounceSurface::from_mesh(&mb)], own }
    }

    /// Frame `i`'s lighting: a sky whose bright patch wanders and whose ground brightens, a new
    /// allocation every frame (as a VEM frame's): no value can be kept.
    fn light(&self, i: usize) -> Arc<UnitLighting> {
        let sun = Vec3::new((0.7 * i as f32).cos(), 0.8, (0.7 * i as f32).sin()).normalize();
        let ground = 0.1 + 0.05 * i as f32;
        Arc::new(
            UnitLighting::from_radiance(&self.cuts.tree, 64, |d| match d.y >= 0.0 {
                true => [0.3 + 4.0 * d.dot(sun).max(0.0).powi(8), 0.4, 0.6 + 0.1 * i as f32],
                false => [ground; 3],
            })
            .unwrap(),
        )
    }

    fn bounce(&self) -> Bounce<'_> {
        Bounce { surfaces: &self.surfaces, sun: None, own: &self.own, proxy: None }
    }
}

fn poses(b: Vec3) -> Vec<Pose> {
    vec![Pose::translated(Vec3::ZERO), Pose::from_parts(Mat3::from_rotation_y(0.4), b).unwrap()]
}

/// Ground receivers along x under both objects: some within `b`'s reach on its way, some only
/// within `a`'s, some beyond both.
fn receivers() -> Vec<(Vec3, Vec3)> {
    (0..30).map(|i| (Vec3::new(-12.0 + i as f32 * 0.8, -1.0, 0.4), Vec3::Y)).collect()
}

#[test]
fn kept_products_summed_under_new_lighting_equal_fresh_walks_bit_for_bit() {
    let s = Scene::new();
    let eye = Vec3::new(0.0, 1.5, 8.0);
    let (count_a, count_b) = (s.cuts.cuts.objects[0].positions.len(), s.cuts.cuts.objects[1].positions.len());
    let mut cache = AmbientCache::default();
    let mut store = ReceiverProducts::default();
    let surfaces = receivers();
    let all: Vec<usize> = (0..surfaces.len()).collect();
    // `b` beyond its reach of `a` (2.5 m), still, then into reach (1.8 m), still there, then
    // out again, and still: the lighting changes on every frame.
    let path = [6.0, 6.0, 1.8, 1.8, 6.0, 6.0].map(|x| Vec3::new(x, 0.0, 0.5));
    let mut uses: Vec<Vec<ProductUse>> = Vec::new();
    let mut receiver_reused = Vec::new();
    for (i, b) in path.into_iter().enumerate() {
        let (light, poses) = (s.light(i), poses(b));
        let fresh = s.cuts.object_ambient_bounced(&light, &poses, eye, &s.bounce()).unwrap();
        let (kept, _) = s.cuts.object_ambient_reusing(&light, &poses, eye, &s.bounce(), &[], &mut cache).unwrap();
        // Bit for bit: `VertexAmbient` compares f32 with `==`, so compare the bits.
        let bits = |a: &crate::cuts::frame::ObjectAmbient| a.vertices.iter().flatten().flatten().flatten().map(|v| v.to_bits()).collect::<Vec<u32>>();
        assert_eq!(bits(&kept), bits(&fresh), "frame {i}, b at {b}");
        assert_eq!(kept.outside_proxy_box, fresh.outside_proxy_box);
        uses.push(cache.product_uses().to_vec());
        // The receivers: kept products against the fresh walk, bit for bit.
        let rc = s.cuts.receivers_posed(light.clone(), poses.clone());
        let want = rc.visibility(&surfaces);
        let got = rc.visibility_reusing(&surfaces, &all, &mut store);
        assert_eq!(got.iter().map(|v| [v.ambient.to_bits(), v.bounce.to_bits()]).collect::<Vec<_>>(), want.iter().map(|v| [v.ambient.to_bits(), v.bounce.to_bits()]).collect::<Vec<_>>(), "frame {i}");
        receiver_reused.push((store.last.reused, store.last.walked));
    }
    assert!(cache.product_bytes() > 0);
    // Frame 0 walks everything; the moving object walks whenever it moved.
    assert_eq!(uses[0], vec![ProductUse { reused: 0, walked: count_a, not_kept: None }, ProductUse { reused: 0, walked: count_b, not_kept: None }]);
    for i in [2, 4] {
        assert_eq!(uses[i][1], ProductUse { reused: 0, walked: count_b, not_kept: None }, "frame {i}");
    }
    // Standing still beyond reach (frames 1 and 5), everything is summed from the kept products.
    for i in [1, 5] {
        assert_eq!(uses[i], vec![ProductUse { reused: count_a, walked: 0, not_kept: None }, ProductUse { reused: count_b, walked: 0, not_kept: None }], "frame {i}");
    }
    // Moving into reach (frame 2, new pose) and out (frame 4, old pose) walks the vertices of
    // `a` that `b` reaches, and only those; standing still within reach (frame 3), `b` moved
    // nothing and every vertex keeps its product.
    for i in [2, 4] {
        let u = &uses[i][0];
        assert!(u.walked > 0 && u.reused > 0 && u.walked + u.reused == count_a, "frame {i}: {u:?}");
    }
    assert_eq!(uses[3][0], ProductUse { reused: count_a, walked: 0, not_kept: None });
    // The receivers likewise: all walked at first, all kept while nothing moves, those `b`
    // reaches walked again when it moves.
    assert_eq!(receiver_reused[0], (0, surfaces.len()));
    for i in [1, 3, 5] {
        assert_eq!(receiver_reused[i], (surfaces.len(), 0), "frame {i}");
    }
    for i in [2, 4] {
        let (r, w) = receiver_reused[i];
        assert!(r > 0 && w > 0 && r + w == surfaces.len(), "frame {i}: {r} kept, {w} walked");
    }
}

#[test]
fn past_the_budget_nothing_is_kept_and_the_values_are_the_same() {
    let s = Scene::new();
    let eye = Vec3::new(0.0, 1.5, 8.0);
    let count_a = s.cuts.cuts.objects[0].positions.len();
    let mut cache = AmbientCache::with_budget(ProductBudget(0));
    let mut store = ReceiverProducts::with_budget(ProductBudget(0));
    let surfaces = receivers();
    let all: Vec<usize> = (0..surfaces.len()).collect();
    for i in 0..2 {
        let (light, poses) = (s.light(i), poses(Vec3::new(6.0, 0.0, 0.5)));
        let fresh = s.cuts.object_ambient_bounced(&light, &poses, eye, &s.bounce()).unwrap();
        let (kept, _) = s.cuts.object_ambient_reusing(&light, &poses, eye, &s.bounce(), &[], &mut cache).unwrap();
        assert_eq!(kept, fresh);
        let u = &cache.product_uses()[0];
        assert_eq!((u.reused, u.walked), (0, count_a), "frame {i}");
        assert!(u.not_kept.as_deref().is_some_and(|r| r.contains("budget of 0 bytes")), "{u:?}");
        let rc = s.cuts.receivers_posed(light, poses);
        assert_eq!(rc.visibility_reusing(&surfaces, &all, &mut store), rc.visibility(&surfaces));
        assert_eq!((store.last.reused, store.last.over_budget), (0, surfaces.len()));
    }
    assert_eq!(cache.product_bytes(), 0);
}
