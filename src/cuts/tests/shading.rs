//! Lighting clustering and shading against closed forms and leafwise sums.

use crate::cuts::eval::{CutScene, ObjectCuts};
use crate::cuts::lighting::{ClusteredLighting, ReceiverWeights, Reflectance, shade, sky_visibility};
use crate::cuts::proxy_field::{ProxyField, ProxyGrid};
use crate::cuts::shapes::{icosphere, wall};
use crate::cuts::svc::{SvcSettings, self_visibility_cuts};
use crate::cuts::tree::DirectionTree;
use crate::cuts::vcf::{VcfSampling, VisibilityCutField};
use crate::cuts::{CutsError, no_progress};
use crate::geometry::Material;
use crate::geometry::brdf::GltfSurface;
use crate::geometry::raycast::RayScene;
use crate::io::image::LinearImage;
use glam::Vec3;

fn upper_sky(d: Vec3) -> Vec3 {
    if d.y > 0.0 { Vec3::ONE } else { Vec3::ZERO }
}

#[test]
fn diffuse_sphere_under_skies_matches_closed_forms() {
    // A convex Lambertian sphere of albedo ρ: under a uniform sphere of radiance 1 every vertex
    // reflects B = ρ; under a uniform upper hemisphere (black below) the sky view factor of a
    // tilted plane gives B = ρ·(1 + n_y)/2.
    let levels = 12;
    let tree = DirectionTree::new(levels).expect("valid levels");
    let sphere = icosphere(Vec3::ZERO, 1.0, 2);
    let rho = Vec3::new(0.8, 0.5, 0.2);
    let surface = Reflectance::Lambert(rho);
    let uniform = ClusteredLighting::from_fn(&tree, |_| Vec3::ONE);
    let sky = ClusteredLighting::from_fn(&tree, upper_sky);
    for threshold in [0.0, 0.05] {
        let svc = self_visibility_cuts("sphere", &sphere, &tree, &SvcSettings { threshold, ..SvcSettings::default() }, &no_progress).expect("valid mesh");
        for v in (0..sphere.positions.len()).step_by(7) {
            let n = svc.normals[v];
            let views = [svc.cuts.view(v)];
            // Uniform light: each node's value is its leaves' mean, so Σ l_k v_k is the leaf sum
            // Σ cos⁺ Δω whatever the threshold; the Fibonacci quadrature of ∫cos⁺ = π is within
            // 2·10⁻⁵ at S = 4096 here (plus the Unorm16 steps, 8·10⁻⁶): allow 10⁻⁴.
            let b = shade(&tree, &uniform, &views, &surface, n, n).expect("same tree");
            assert!((b - rho).abs().max_element() < 1e-4, "uniform, vertex {v}, threshold {threshold}: {b}");
            let want = rho * (1.0 + n.y) / 2.0;
            // The horizon cuts cells: the leaf quadrature of the sky view factor is within
            // 4·10⁻⁴ ρ here, allow 2·10⁻³ (threshold 0); a threshold t moves each leaf's cosine by
            // ≤ t, so the sum by ≤ ρ/π · t · 2π = 2ρt (a bound: the uniform sky is far inside it).
            let b = shade(&tree, &sky, &views, &surface, n, n).expect("same tree");
            let tol = 2e-3 + 2.0 * threshold;
            assert!((b - want).abs().max_element() <= tol * rho.max_element(), "sky, vertex {v} (n_y {}), threshold {threshold}: {b} vs {want}", n.y);
        }
    }
}

#[test]
fn gltf_shading_matches_the_leafwise_sum() {
    // With threshold 0 the cut has one node per lit leaf, so Eq. 3 becomes Eq. 2: the cut sum
    // equals Σ_j L_j f(ω_j) cos θ_j Δω evaluated leaf by leaf, except on leaves within 3° of
    // the horizon where the BRDF is read at 3° elevation (weighted by cos < 0.052), and for the
    // Unorm16 steps of the stored cosines: within 10⁻⁴ here, allow 10⁻³.
    let tree = DirectionTree::new(11).expect("valid levels");
    let sphere = icosphere(Vec3::ZERO, 1.0, 1);
    let svc = self_visibility_cuts("sphere", &sphere, &tree, &SvcSettings { threshold: 0.0, ..SvcSettings::default() }, &no_progress).expect("valid mesh");
    let radiance = |d: Vec3| Vec3::new(1.0 + d.x.max(0.0) * 4.0, 1.0, 0.5 + d.y.max(0.0));
    let lighting = ClusteredLighting::from_fn(&tree, radiance);
    let material = Material { metallic: 0.7, roughness: 0.4, ..Material::default() };
    let surface = GltfSurface::new(&material, Vec3::new(0.9, 0.6, 0.3));
    for v in 0..sphere.positions.len() {
        let n = svc.normals[v];
        let view = (n + Vec3::new(0.3, 0.5, -0.2)).normalize();
        let b = shade(&tree, &lighting, &[svc.cuts.view(v)], &Reflectance::Gltf(surface), n, view).expect("same tree");
        let dw = tree.leaf_solid_angle_sr();
        let reference: Vec3 = tree.leaf_dirs().iter().map(|&d| radiance(d) * surface.eval_cos(n, view, d) * dw).sum();
        assert!((b - reference).abs().max_element() < 1e-3 * reference.max_element(), "vertex {v}: {b} vs {reference}");
    }
}

#[test]
fn equirect_lighting_keeps_the_map_power() {
    let tree = DirectionTree::new(10).expect("valid levels");
    // A constant map, finer and coarser than the tree: exactly 4π·L.
    for (w, h) in [(256, 128), (8, 4)] {
        let map = LinearImage::from_fn(w, h, |_, _| [2.0, 1.0, 0.5]);
        let l = ClusteredLighting::from_equirect(&tree, &map).expect("valid map");
        let want = Vec3::new(2.0, 1.0, 0.5) * 4.0 * std::f32::consts::PI;
        assert!((l.total() - want).abs().max_element() < 1e-4 * want.max_element(), "{w}×{h}: {}", l.total());
    }
    // Sky above, black below: 2π within the leaves' cell-area spread along the horizon (1 %).
    let map = LinearImage::from_fn(256, 128, |_, y| if y < 64 { [1.0; 3] } else { [0.0; 3] });
    let l = ClusteredLighting::from_equirect(&tree, &map).expect("valid map");
    assert!((l.total().x - 2.0 * std::f32::consts::PI).abs() < 0.01 * 2.0 * std::f32::consts::PI, "{}", l.total());
    // Bad maps.
    let mut bad = LinearImage::new(4, 2);
    bad.data[3] = [f32::NAN, 0.0, 0.0];
    assert!(matches!(ClusteredLighting::from_equirect(&tree, &bad), Err(CutsError::EnvMap(_))));
    assert!(ClusteredLighting::from_equirect(&tree, &LinearImage::new(0, 0)).is_err());
}

#[test]
fn receiver_under_a_sphere_loses_the_cap_share() {
    // A horizontal receiver straight below a sphere of radius R at distance d, under a uniform
    // sky, loses the cosine-weighted share of the cap: sin² α = (R/d)².
    let tree = DirectionTree::new(12).expect("valid levels");
    let sphere = icosphere(Vec3::ZERO, 1.0, 3);
    let sampling = VcfSampling { spheres: 8, rows: 32, cols: 32, ..VcfSampling::default() };
    let field = VisibilityCutField::compute("sphere", &sphere, &tree, &sampling, &no_progress).expect("valid mesh");
    let weights = ReceiverWeights::new(&tree, &ClusteredLighting::from_fn(&tree, upper_sky), Vec3::Y).expect("same tree");
    for k in [0, 1, 3] {
        let d = field.sphere_radius_m(k);
        let (cut, _) = field.lookup(field.centre - Vec3::Y * d).expect("finite point");
        let lost = 1.0 - sky_visibility(&weights, &[cut.view()]).expect("same tree");
        let want = (1.0 / d).powi(2);
        // Inscribed radius of the icosphere (0.994) and the pole row's 2.8° tilt bound the
        // deviation by 2 %; the leaf count adds about 0.5 % at S = 4096.
        assert!((lost - want).abs() < 0.03 * want, "d = {d}: lost {lost} vs {want}");
    }
}

#[test]
fn a_moving_occluder_darkens_a_vertex_and_the_scene_is_deterministic() {
    let tree = DirectionTree::new(9).expect("valid levels");
    let lighting = ClusteredLighting::from_fn(&tree, upper_sky);
    let settings = SvcSettings::default();
    let sampling = VcfSampling { spheres: 6, rows: 12, cols: 12, ..VcfSampling::default() };
    let mesh = icosphere(Vec3::ZERO, 0.5, 1);
    let objects = [
        ObjectCuts::compute("a", &mesh, &tree, &settings, &sampling, &no_progress).expect("valid mesh"),
        ObjectCuts::compute("b", &mesh, &tree, &settings, &sampling, &no_progress).expect("valid mesh"),
    ];
    let top = (0..mesh.positions.len()).max_by(|&a, &b| mesh.positions[a].y.total_cmp(&mesh.positions[b].y)).unwrap_or(0);
    let lambert = Reflectance::Lambert(Vec3::ONE);
    let radiance = |b_at: Vec3| {
        let t = [Vec3::ZERO, b_at];
        let scene = CutScene { tree: &tree, lighting: &lighting, objects: &objects, translations: &t, proxy: None };
        scene.vertex_radiance(0, top, &lambert, Vec3::Y).expect("valid scene")
    };
    let (far, above, below) = (radiance(Vec3::new(40.0, 0.0, 0.0)), radiance(Vec3::new(0.0, 1.3, 0.0)), radiance(Vec3::new(0.0, -3.0, 0.0)));
    // B overhead at 1.6 r leaves 1 − (0.5/0.8)² = 61 % of the cosine-weighted sky. The field's
    // radial interpolation (spheres at 1.2 r and 2.96 r) is linear in a convex Ω(d), so it can
    // only over-darken: below 61 % plus the leaf count (2 % at S = 512).
    assert!(above.radiance.x < 0.63 * far.radiance.x, "an object overhead: {} vs {}", above.radiance.x, far.radiance.x);
    // Below the vertex's horizon the other object is culled (§V-B) and changes nothing.
    assert_eq!(below.occluders, 0);
    assert_eq!(below.radiance, radiance(Vec3::new(0.0, -30.0, 0.0)).radiance);
    // One thread or many: the same bits.
    let t = [Vec3::ZERO, Vec3::new(0.7, 0.6, 0.1)];
    let scene = CutScene { tree: &tree, lighting: &lighting, objects: &objects, translations: &t, proxy: None };
    let all = scene.object_radiance(0, &|_| lambert, Vec3::new(0.0, 5.0, 5.0)).expect("valid scene");
    let pool = rayon::ThreadPoolBuilder::new().num_threads(1).build().expect("a thread pool");
    let one = pool.install(|| scene.object_radiance(0, &|_| lambert, Vec3::new(0.0, 5.0, 5.0))).expect("valid scene");
    assert_eq!(all, one);
    // Bad frames: a NaN translation, a translation list of the wrong length.
    let nan = [Vec3::ZERO, Vec3::NAN];
    assert!(CutScene { translations: &nan, ..scene }.vertex_radiance(0, 0, &lambert, Vec3::Y).is_err());
    assert!(CutScene { translations: &t[..1], ..scene }.vertex_radiance(0, 0, &lambert, Vec3::Y).is_err());
    assert!(scene.vertex_radiance(0, 10_000, &lambert, Vec3::Y).is_err());
}

#[test]
fn an_object_moving_out_of_the_proxy_box_is_flagged_and_stays_finite() {
    let tree = DirectionTree::new(8).expect("valid levels");
    let lighting = ClusteredLighting::from_fn(&tree, upper_sky);
    let mesh = icosphere(Vec3::ZERO, 0.3, 1);
    let sampling = VcfSampling { spheres: 2, rows: 4, cols: 4, ..VcfSampling::default() };
    let objects = [ObjectCuts::compute("a", &mesh, &tree, &SvcSettings::default(), &sampling, &no_progress).expect("valid mesh")];
    let proxy = RayScene::new(wall(-3.0, 3.0, 3.0, 0.0));
    let grid = ProxyGrid { min: [-2.0, 0.0, 0.3], max: [2.0, 2.0, 3.0], counts: [3, 3, 3], threshold: 0.0 };
    let field = ProxyField::compute(&proxy, &tree, &grid, &no_progress).expect("valid grid");
    let top = (0..mesh.positions.len()).max_by(|&a, &b| mesh.positions[a].z.total_cmp(&mesh.positions[b].z)).unwrap_or(0);
    for (at, outside) in [(Vec3::new(0.0, 1.0, 1.0), false), (Vec3::new(0.0, 1.0, 40.0), true)] {
        let t = [at];
        let scene = CutScene { tree: &tree, lighting: &lighting, objects: &objects, translations: &t, proxy: Some(&field) };
        let s = scene.vertex_radiance(0, top, &Reflectance::Lambert(Vec3::ONE), Vec3::Z).expect("valid scene");
        assert_eq!(s.outside_proxy_box, outside);
        assert!(s.radiance.is_finite());
    }
}

#[test]
fn an_object_beyond_its_outermost_sphere_is_left_out_exactly() {
    // `CutScene` leaves an object out beyond its field's outermost sphere (10 r here, 5 m), as
    // `FrameCuts` does: a vertex or a receiver there sees exactly what it sees without the object
    // (clamping to the outermost sphere's cuts would hide a cap of ~0.031 sr).
    let tree = DirectionTree::new(9).expect("valid levels");
    let lighting = ClusteredLighting::from_fn(&tree, upper_sky);
    let sampling = VcfSampling { spheres: 4, rows: 8, cols: 8, ..VcfSampling::default() };
    let mesh = icosphere(Vec3::ZERO, 0.5, 1);
    let one = ObjectCuts::compute("a", &mesh, &tree, &SvcSettings::default(), &sampling, &no_progress).expect("valid mesh");
    let objects = [one.clone(), one];
    let reach = objects[1].vcf.sphere_radius_m(sampling.spheres - 1);
    let lambert = Reflectance::Lambert(Vec3::ONE);
    let alone_t = [Vec3::ZERO];
    let alone = CutScene { tree: &tree, lighting: &lighting, objects: &objects[..1], translations: &alone_t, proxy: None };
    let weights = ReceiverWeights::new(&tree, &lighting, Vec3::Y).expect("same tree");
    let receiver = Vec3::new(0.0, -0.6, 0.0);
    for (dx, inside) in [(0.9 * reach, true), (1.2 * reach, false), (40.0, false)] {
        let t = [Vec3::ZERO, Vec3::new(dx, 0.4, 0.0)];
        let scene = CutScene { tree: &tree, lighting: &lighting, objects: &objects, translations: &t, proxy: None };
        let top_side = (0..mesh.positions.len()).max_by(|&a, &b| mesh.positions[a].x.total_cmp(&mesh.positions[b].x)).unwrap_or(0);
        let with = scene.vertex_radiance(0, top_side, &lambert, Vec3::X).expect("valid scene");
        let without = alone.vertex_radiance(0, top_side, &lambert, Vec3::X).expect("valid scene");
        // The receiver under object a sees a's field either way.
        let rv = scene.receiver_visibility(&weights, receiver, Vec3::Y).expect("valid scene");
        let rv_alone = alone.receiver_visibility(&weights, receiver, Vec3::Y).expect("valid scene");
        if inside {
            // Within reach b's field enters and hides part of the sky.
            assert_eq!((with.occluders, rv.occluders), (1, 2));
            assert!(with.radiance.x < without.radiance.x && rv.visibility < rv_alone.visibility, "{with:?} {rv:?} {rv_alone:?}");
        } else {
            assert_eq!((with.occluders, rv.occluders), (0, 1), "object at {dx} m, reach {reach} m");
            assert_eq!(with.radiance, without.radiance);
            assert_eq!(rv.visibility, rv_alone.visibility);
        }
    }
}
