//! The light other objects reflect onto an object (`crate::cuts::bounce`): closed forms and
//! the same sums on the expanded leaves.

use crate::cuts::bounce::*;
use crate::cuts::frame::FrameCuts;
use crate::cuts::lighting::ClusteredLighting;
use crate::cuts::rotate::Pose;
use crate::cuts::tree::DirectionTree;
use crate::cuts::Cut;
use glam::Vec3;
use crate::cuts::eval::ObjectCuts;
use crate::cuts::file::PrecomputedCuts;
use crate::cuts::frame::UnitLighting;
use crate::cuts::svc::SvcSettings;
use crate::cuts::vcf::{VcfSampling, occlusion_leaves};
use crate::cuts::{no_progress, shapes};
use crate::geometry::raycast::RayScene;
use crate::geometry::{Material, Mesh};
use std::sync::Arc;

/// Lambert's formula: the cosine-weighted solid angle `∫ max(n·ω, 0) dω` of a planar polygon
/// wholly above the tangent plane of `x` (normal `n`), `½ Σ_i γ_i n·(r_i × r_{i+1})/|…|`.
fn polygon_cosine_solid_angle(x: Vec3, n: Vec3, corners: &[Vec3]) -> f64 {
    let mut sum = 0.0f64;
    for i in 0..corners.len() {
        let (a, b) = ((corners[i] - x).normalize(), (corners[(i + 1) % corners.len()] - x).normalize());
        let c = a.cross(b);
        if c.length() > 0.0 {
            sum += a.dot(b).clamp(-1.0, 1.0).acos() as f64 * n.dot(c.normalize()) as f64;
        }
    }
    sum.abs() / 2.0
}

fn sphere_cuts(tree: &DirectionTree, subdiv: u32) -> (Mesh, ObjectCuts) {
    let mesh = shapes::icosphere(Vec3::ZERO, 0.5, subdiv);
    let vcf = VcfSampling { spheres: 4, rows: 8, cols: 8, ..VcfSampling::default() };
    let cuts = ObjectCuts::compute("sphere", &mesh, tree, &SvcSettings::default(), &vcf, &no_progress).unwrap();
    (mesh, cuts)
}

#[test]
fn a_vertex_facing_a_plate_of_uniform_radiance_gains_it_times_the_blocked_cosine_weighted_solid_angle() {
    let levels = 10;
    let tree = DirectionTree::new(levels).unwrap();
    let (_, a) = sphere_cuts(&tree, 1);
    let v = (0..a.positions.len()).max_by(|&i, &j| a.svc.normals[i].z.total_cmp(&a.svc.normals[j].z)).unwrap();
    let (x, n) = (a.positions[v], a.svc.normals[v]);
    // A 3 m square perpendicular to the normal 0.6 m away: wholly above the tangent plane.
    let (t1, t2) = n.any_orthonormal_pair();
    let (h, d) = (1.5f32, 0.6f32);
    let c = x + n * d;
    let corners = [c - t1 * h - t2 * h, c + t1 * h - t2 * h, c + t1 * h + t2 * h, c - t1 * h + t2 * h];
    let mut plate = Mesh::default();
    let (node, material) = (plate.add_node("plate", true), plate.add_material(Material::diffuse("plate", [0.5; 3])));
    plate.push_quad(corners[0], t1 * 2.0 * h, t2 * 2.0 * h, node, material);
    let shut = Cut::from_leaves(levels, &occlusion_leaves(&RayScene::new(plate), &tree, x, c, h * std::f32::consts::SQRT_2), 0.0).unwrap();
    let radiance = Vec3::new(0.8, 0.5, 0.2);
    let light = ClusteredLighting::from_fn(&tree, |_| radiance);
    let sums = blocked_sums(&tree, &[&light], &[a.svc.cuts.view(v)], shut.view(), n, n).unwrap();
    // The same cuts expanded to their leaves: the walk sums exactly what they hold.
    let (svc, vb) = (a.svc.cuts.get(v).to_leaves(), shut.to_leaves());
    let leaf_sum = svc.iter().zip(&vb).map(|(s, b)| (s * (1.0 - b)) as f64).sum::<f64>() * tree.leaf_solid_angle_sr() as f64;
    let rel = |got: Vec3, want: f64| ((got / radiance) - Vec3::splat(want as f32)).abs().max_element() as f64 / want;
    assert!(rel(sums[0].0, leaf_sum) < 1e-4, "cut walk {:?} against the leaves {leaf_sum}", sums[0].0 / radiance);
    // Lambert's closed form: the quadrature over 2^10 leaves and the SVC's threshold (0.1
    // on cos) against the exact blocked solid angle.
    let phi = polygon_cosine_solid_angle(x, n, &corners);
    assert!(phi > 2.0 && phi < std::f64::consts::PI, "{phi}");
    let err = rel(sums[0].0, phi);
    eprintln!("blocked cosine-weighted solid angle: cuts {:.5}, leaves {leaf_sum:.5}, Lambert {phi:.5} (relative error {err:.4})", sums[0].0.x / radiance.x);
    // Measured 0.76%.
    assert!(err < 0.015, "E_n/L = {:?}, closed form {phi:.4}: relative error {err:.4}", sums[0].0 / radiance);
    // About the reflected direction r = n the weight is 1 above sin 3°: E_r ≤ E_n, close.
    assert!(sums[0].1.x <= sums[0].0.x * 1.0001 && sums[0].1.x > 0.98 * sums[0].0.x, "{:?}", sums[0]);
}

#[test]
fn a_half_lit_sphere_shows_two_thirds_of_its_brightest_radiance_from_the_sun_and_none_from_behind() {
    // Radiance max(n·s, 0): seen from the sun's side the projected-area mean is
    // ∫cos²/∫cos = (2π/3)/π = 2/3; from behind no lit vertex faces the viewer.
    let mesh = shapes::icosphere(Vec3::ZERO, 0.5, 3);
    let surf = BounceSurface::from_mesh(&mesh);
    // 1 280 flat triangles inscribed in the sphere: within 2% of its area 4πr² = π.
    assert!((surf.area_m2.iter().sum::<f32>() / std::f32::consts::PI - 1.0).abs() < 0.02, "sphere area {}", surf.area_m2.iter().sum::<f32>());
    assert!(surf.albedo.iter().all(|r| (*r - Vec3::splat(0.5 * 0.96 + 0.04)).abs().max_element() < 1e-6));
    let s = Vec3::new(0.3, 0.8, 0.2).normalize();
    let normals: Vec<Vec3> = mesh.positions.iter().map(|p| p.normalize()).collect();
    let lit: Vec<Vec3> = normals.iter().map(|n| Vec3::splat(n.dot(s).max(0.0))).collect();
    let r = ObjectRadiance { normals, area_m2: surf.area_m2, pa: lit.clone(), pd: lit, ..ObjectRadiance::default() };
    let (front, _) = r.seen_along(-s);
    let (back, _) = r.seen_along(s);
    assert!((front.x - 2.0 / 3.0).abs() < 0.01, "{front}");
    assert_eq!(back, Vec3::ZERO);
}

#[test]
fn a_lone_object_is_unchanged_and_a_neighbour_adds_light_linearly_on_its_facing_side() {
    let tree = DirectionTree::new(9).unwrap();
    let (mesh, one) = sphere_cuts(&tree, 1);
    let surf = BounceSurface::from_mesh(&mesh);
    let frame = |count: usize| FrameCuts::new(PrecomputedCuts { inputs_hash: [0; 32], levels: 9, objects: vec![one.clone(); count], proxy: None }).unwrap();
    let eye = Vec3::new(0.0, 0.0, 10.0);
    let sun = Some(Vec3::new(0.0, 1.0, 0.0));
    let lone = frame(1);
    let light = Arc::new(UnitLighting::uniform_sky(&lone.tree));
    let first = lone.object_ambient_posed(&light, &[Pose::translated(Vec3::ZERO)], eye).unwrap();
    let mut with = first.clone();
    lone.add_bounce(&mut with, &[Pose::translated(Vec3::ZERO)], eye, &Bounce { surfaces: std::slice::from_ref(&surf), sun, own: &[], proxy: None }).unwrap();
    assert_eq!(with, first);

    let two = frame(2);
    let poses = [Pose::translated(Vec3::ZERO), Pose::translated(Vec3::new(1.2, 0.0, 0.0))];
    let base = two.object_ambient_posed(&light, &poses, eye).unwrap();
    let bounced = |albedo: f32| {
        let mut b = surf.clone();
        b.albedo.iter_mut().for_each(|r| *r = Vec3::splat(albedo));
        let mut amb = base.clone();
        two.add_bounce(&mut amb, &poses, eye, &Bounce { surfaces: &[surf.clone(), b], sun, own: &[], proxy: None }).unwrap();
        amb
    };
    let (once, twice) = (bounced(0.4), bounced(0.8));
    // Both passes at once (the fields looked up once) give the same bits.
    let mut b = surf.clone();
    b.albedo.iter_mut().for_each(|r| *r = Vec3::splat(0.4));
    assert_eq!(two.object_ambient_bounced(&light, &poses, eye, &Bounce { surfaces: &[surf.clone(), b], sun, own: &[], proxy: None }).unwrap(), once);
    let normals = &one.svc.normals;
    let facing = (0..normals.len()).max_by(|&i, &j| normals[i].x.total_cmp(&normals[j].x)).unwrap();
    let away = (0..normals.len()).min_by(|&i, &j| normals[i].x.total_cmp(&normals[j].x)).unwrap();
    for row in [0, 2] {
        let gain = once.vertices[0][facing][row][1] - base.vertices[0][facing][row][1];
        let gain2 = twice.vertices[0][facing][row][1] - base.vertices[0][facing][row][1];
        assert!(gain > 0.0, "row {row}: the lit neighbour adds light ({gain})");
        assert!((gain2 / gain - 2.0).abs() < 1e-3, "row {row}: linear in the neighbour's albedo ({gain} → {gain2})");
    }
    // The vertex facing away from the neighbour (culled, §V-B) gets nothing.
    assert_eq!(once.vertices[0][away], base.vertices[0][away]);
    // The neighbour itself gains from the first sphere too, the same (mirror image).
    let b_facing = (0..normals.len()).min_by(|&i, &j| normals[i].x.total_cmp(&normals[j].x)).unwrap();
    assert!(once.vertices[1][b_facing][0][1] > base.vertices[1][b_facing][0][1]);
}

/// The light an object reflects onto itself takes the sun where it falls at each hit
/// (`FrameCuts::self_bounce_rows`), not its triangle's corners' sun interpolated: a 2 m floor
/// (two triangles, its corners all sunlit) under a 0.4 m roof 0.3 m up, the sun overhead. The
/// roof's corner, facing down, sees the floor lit but for the roof's shadow square, the
/// 0.4 m square right under the roof: `E = ρ·(F_floor − F_shadow)` per unit `Pd`, the view
/// factors `F` by Lambert's formula. The corners' sun interpolated lights the whole floor.
#[test]
fn the_light_an_object_reflects_onto_itself_has_its_own_shadow_where_it_falls() {
    let tree = DirectionTree::new(9).unwrap();
    let (f, h, r) = (1.0f32, 0.3f32, 0.2f32);
    let mut mesh = Mesh {
        positions: vec![
            Vec3::new(-f, 0.0, -f),
            Vec3::new(f, 0.0, -f),
            Vec3::new(f, 0.0, f),
            Vec3::new(-f, 0.0, f),
            Vec3::new(-r, h, -r),
            Vec3::new(r, h, -r),
            Vec3::new(r, h, r),
            Vec3::new(-r, h, r),
        ],
        // The floor wound to face +y, the roof −y.
        triangles: vec![[0, 2, 1], [0, 3, 2], [4, 5, 6], [4, 6, 7]],
        ..Mesh::default()
    };
    mesh.tri_node = vec![0; 4];
    mesh.tri_material = vec![0; 4];
    let vcf = VcfSampling { spheres: 4, rows: 8, cols: 8, ..VcfSampling::default() };
    let cuts = ObjectCuts::compute("floor and roof", &mesh, &tree, &SvcSettings::default(), &vcf, &no_progress).unwrap();
    assert!(cuts.svc.normals[6].y < -0.99 && cuts.svc.normals[0].y > 0.99, "{:?}", cuts.svc.normals);
    let gather = crate::cuts::self_bounce::SelfGather::from_mesh(&mesh, &cuts.svc.normals, 1024);
    let frame = FrameCuts::new(PrecomputedCuts { inputs_hash: [0; 32], levels: 9, objects: vec![cuts], proxy: None }).unwrap();
    let rho = Vec3::new(0.6, 0.5, 0.4);
    let n = mesh.positions.len();
    // No ambient: the light per unit Pd is the floor's direct sun only (the roof faces away).
    let lit_corner = |v: usize| if v < 4 { rho / std::f32::consts::PI } else { Vec3::ZERO };
    let rad = ObjectRadiance {
        normals: frame.cuts.objects[0].svc.normals.clone(),
        area_m2: vec![0.1; n],
        pa: vec![Vec3::ZERO; n],
        pd: (0..n).map(lit_corner).collect(),
        pd_indirect: vec![Vec3::ZERO; n],
        albedo_pi: vec![rho / std::f32::consts::PI; n],
    };
    let surfaces = [BounceSurface { albedo: vec![rho; n], area_m2: vec![0.1; n] }];
    let own = [gather];
    let bounce = Bounce { surfaces: &surfaces, sun: Some(Vec3::Y), own: &own, proxy: None };
    let poses = [Pose::translated(Vec3::ZERO)];
    let eye = Vec3::new(0.0, 5.0, 0.1);
    let traced = frame.self_bounce_rows(&poses, 0, eye, &bounce, &rad).unwrap();
    let interpolated = frame.self_bounce_rows(&poses, 0, eye, &bounce, &ObjectRadiance { albedo_pi: Vec::new(), ..rad.clone() }).unwrap();
    let x = mesh.positions[6];
    let down = Vec3::NEG_Y;
    let floor = polygon_cosine_solid_angle(x, down, &mesh.positions[..4]) / std::f64::consts::PI;
    let square = [Vec3::new(-r, 0.0, -r), Vec3::new(r, 0.0, -r), Vec3::new(r, 0.0, r), Vec3::new(-r, 0.0, r)];
    let shadow = polygon_cosine_solid_angle(x, down, &square) / std::f64::consts::PI;
    let (e_traced, e_interpolated) = (traced[6][2][1] as f64, interpolated[6][2][1] as f64);
    let expected = rho.y as f64 * (floor - shadow);
    // 1 024 stratified cosine rays: the view factors within 0.005 (the shadow's edge crosses
    // strata).
    assert!((e_traced - expected).abs() < 0.005 * rho.y as f64, "traced {e_traced:.4}, expected {expected:.4} (floor {floor:.4}, shadow {shadow:.4})");
    assert!((e_interpolated - rho.y as f64 * floor).abs() < 0.005 * rho.y as f64, "interpolated {e_interpolated:.4}, floor {floor:.4}");
    assert!(shadow > 0.15, "the shadow's view factor {shadow:.4}");
    // Per unit Pa nothing (no ambient anywhere): the sun goes to the Pd rows only.
    assert_eq!(traced[6][0], [0.0; 4]);
}
