//! Self-visibility cuts, visibility cut fields and the proxy field against closed forms and
//! ray casting.

use super::rng;
use crate::cuts::proxy_field::{ProxyField, ProxyGrid};
use crate::cuts::shapes::{icosphere, torus, wall};
use crate::cuts::svc::{SvcSettings, self_visibility_cuts};
use crate::cuts::tree::DirectionTree;
use crate::cuts::vcf::{FieldRegion, VcfSampling, VisibilityCutField};
use crate::cuts::{Cut, CutsError, ValueEncoding, no_progress};
use crate::geometry::Mesh;
use crate::geometry::raycast::RayScene;
use glam::Vec3;
use rand::Rng;
use std::f64::consts::PI;

/// Occluded solid angle `Σ (1 − v_j)·Δω` of a visibility cut, sr.
fn occluded_sr(cut: &Cut) -> f64 {
    let dw = 4.0 * PI / (1u64 << cut.levels()) as f64;
    cut.to_leaves().iter().map(|v| (1.0 - *v as f64) * dw).sum()
}

/// Solid angle of a sphere of radius `r` seen from distance `d`: `2π(1 − √(1 − r²/d²))`.
fn cap_sr(r: f64, d: f64) -> f64 {
    2.0 * PI * (1.0 - (1.0 - (r / d).powi(2)).max(0.0).sqrt())
}

/// Counting error of a region of the sphere with `S` Fibonacci points: the lattice's cap
/// discrepancy decays about as `S^(-3/4)` (Marques et al. 2013), so `4π·S^(-3/4)` sr (0.025 sr
/// at S = 4096; the caps and walls below stay within a third of it).
fn counting_tolerance_sr(levels: u32) -> f64 {
    4.0 * PI * ((1u64 << levels) as f64).powf(-0.75)
}

#[test]
fn svc_of_a_convex_sphere_is_the_cosine_over_the_upper_hemisphere() {
    let tree = DirectionTree::new(10).expect("valid levels");
    let sphere = icosphere(Vec3::new(0.3, 1.0, -0.2), 0.8, 2);
    let settings = SvcSettings { threshold: 0.0, encoding: ValueEncoding::Unorm16 };
    let svc = self_visibility_cuts("sphere", &sphere, &tree, &settings, &no_progress).expect("valid mesh");
    assert_eq!(svc.cuts.len(), sphere.positions.len());
    for v in 0..sphere.positions.len() {
        let n = svc.normals[v];
        let leaves = svc.cuts.get(v).to_leaves();
        for (d, value) in tree.leaf_dirs().iter().zip(leaves) {
            // Unorm16 stores the cosine to within half a step, 7.6e-6.
            assert!((value - n.dot(*d).max(0.0)).abs() < 8e-6, "vertex {v}: {value} vs cos {}", n.dot(*d));
        }
    }
}

#[test]
fn svc_does_not_depend_on_the_thread_count() {
    let tree = DirectionTree::new(8).expect("valid levels");
    let mesh = torus(Vec3::ZERO, 0.5, 0.2, 16, 8);
    let settings = SvcSettings::default();
    let many = self_visibility_cuts("torus", &mesh, &tree, &settings, &no_progress).expect("valid mesh");
    let pool = rayon::ThreadPoolBuilder::new().num_threads(1).build().expect("a thread pool");
    let one = pool.install(|| self_visibility_cuts("torus", &mesh, &tree, &settings, &no_progress)).expect("valid mesh");
    assert_eq!(many, one);
}

#[test]
fn svc_of_a_torus_sees_its_hemisphere_outside_and_itself_inside() {
    // Outer-equator vertices lie on a supporting plane of the torus: the whole hemisphere is
    // visible. Inner-equator vertices face the hole, where the far side of the tube blocks the
    // direction along the normal.
    let tree = DirectionTree::new(10).expect("valid levels");
    let (major, minor, rings, segments) = (0.5, 0.2, 24, 12);
    let mesh = torus(Vec3::ZERO, major, minor, rings, segments);
    let svc = self_visibility_cuts("torus", &mesh, &tree, &SvcSettings { threshold: 0.0, ..SvcSettings::default() }, &no_progress).expect("valid mesh");
    let cos_sum = |n: Vec3| tree.leaf_dirs().iter().map(|d| n.dot(*d).max(0.0) as f64).sum::<f64>();
    for ring in 0..rings as usize {
        let (outer, inner) = (ring * segments as usize, ring * segments as usize + segments as usize / 2);
        let seen = svc.cuts.get(outer).leaf_sum();
        assert!((seen - cos_sum(svc.normals[outer])).abs() < 1e-3 * seen, "outer vertex {outer}: {seen}");
        let inside = svc.cuts.get(inner);
        let n = svc.normals[inner];
        let along = tree.leaf_dirs().iter().enumerate().max_by(|a, b| a.1.dot(n).total_cmp(&b.1.dot(n))).map_or(0, |(j, _)| j);
        assert_eq!(inside.to_leaves()[along], 0.0, "inner vertex {inner} sees through the hole");
        assert!(inside.leaf_sum() < 0.9 * cos_sum(n));
    }
}

fn sphere_field(levels: u32, sampling: VcfSampling) -> (Mesh, DirectionTree, VisibilityCutField) {
    let tree = DirectionTree::new(levels).expect("valid levels");
    let mesh = icosphere(Vec3::new(0.5, 2.0, -1.0), 1.0, 3);
    let field = VisibilityCutField::compute("sphere", &mesh, &tree, &sampling, &no_progress).expect("valid mesh");
    (mesh, tree, field)
}

/// Radius of the icosphere's inscribed sphere (its nearest face plane to the centre).
fn inscribed_radius(mesh: &Mesh, centre: Vec3) -> f64 {
    (0..mesh.triangles.len() as u32).map(|t| mesh.face_normal(t).dot(mesh.corners(t)[0] - centre).abs() as f64).fold(f64::MAX, f64::min)
}

#[test]
fn vcf_of_a_sphere_matches_the_cap_solid_angle() {
    let levels = 12;
    let sampling = VcfSampling { spheres: 8, rows: 16, cols: 16, ..VcfSampling::default() };
    let (mesh, _, field) = sphere_field(levels, sampling);
    assert!((field.radius_m - 1.0).abs() < 1e-5);
    let (r_out, r_in) = (1.0, inscribed_radius(&mesh, field.centre));
    let tol = counting_tolerance_sr(levels);
    let mut r = rng(7);
    for k in 0..8 {
        let d = field.sphere_radius_m(k) as f64;
        for _ in 0..6 {
            // Any direction at a sample radius: angular neighbours all see the same cap.
            let dir = Vec3::new(r.random_range(-1.0..1.0), r.random_range(-1.0..1.0), r.random_range(-1.0..1.0)).normalize();
            let (cut, region) = field.lookup(field.centre + dir * d as f32).expect("finite point");
            assert_eq!(region, FieldRegion::Within);
            // The polyhedron lies between its inscribed and circumscribed spheres.
            let got = occluded_sr(&cut);
            assert!(got >= cap_sr(r_in, d) - tol && got <= cap_sr(r_out, d) + tol, "d = {d}: {got} sr, cap {}..{} ± {tol}", cap_sr(r_in, d), cap_sr(r_out, d));
        }
    }
}

#[test]
fn vcf_cuts_record_the_traced_occlusion_exactly() {
    // Every stored cut, expanded, equals a first-hit trace from its sample point in every leaf
    // direction: the ray-skipping cone around the bounding sphere loses nothing and the binary
    // cut at threshold 0 is lossless.
    let (mesh, tree, field) = sphere_field(10, VcfSampling { spheres: 3, rows: 4, cols: 8, ..VcfSampling::default() });
    let scene = RayScene::new(mesh);
    for k in 0..field.cuts.len() {
        let (sphere, row, col) = (k / 32, k / 8 % 4, k % 8);
        let p = field.sample_point(sphere as u32, row as u32, col as u32);
        let traced: Vec<f32> = tree.leaf_dirs().iter().map(|d| if scene.intersect(p, *d, f32::MAX).is_some() { 0.0 } else { 1.0 }).collect();
        assert_eq!(field.cuts.get(k).to_leaves(), traced, "sample point {k}");
    }
}

#[test]
fn vcf_between_spheres_interpolates_the_caps_linearly() {
    // Between two sample spheres the occluded solid angle is linear in the cut values, so the
    // lookup gives (1 − t)·Ω(r_k) + t·Ω(r_k+1) of the analytic caps; the analytic cap at the
    // point itself differs by the radial sampling error. 8× more spheres cut it by far less
    // than the 64× of a smooth function's h²: Ω(d) bends sharply near the inner sphere
    // (dΩ/dd ∝ 1/√(d² − r²)), so the error near 1.2 r falls about as h; require 7×.
    let levels = 11;
    let tol = counting_tolerance_sr(levels);
    let mut errors = Vec::new();
    for spheres in [4, 32] {
        let (mesh, _, field) = sphere_field(levels, VcfSampling { spheres, rows: 8, cols: 16, ..VcfSampling::default() });
        let r_in = inscribed_radius(&mesh, field.centre);
        let mut worst = 0.0f64;
        for (k, t) in [(0u32, 0.3f64), (0, 0.5), (1, 0.7)] {
            let (a, b) = (field.sphere_radius_m(k) as f64, field.sphere_radius_m(k + 1) as f64);
            let d = a + t * (b - a);
            let (cut, _) = field.lookup(field.centre + Vec3::new(0.6, -0.48, 0.64) * d as f32).expect("finite point");
            let got = occluded_sr(&cut);
            let lerp = |r: f64| (1.0 - t) * cap_sr(r, a) + t * cap_sr(r, b);
            assert!(got >= lerp(r_in) - tol && got <= lerp(1.0) + tol, "{spheres} spheres, d = {d}: {got} vs {}", lerp(1.0));
            worst = worst.max((got - cap_sr(1.0, d)).abs());
        }
        errors.push(worst);
    }
    assert!(errors[1] < errors[0] / 7.0, "radial error with 4 vs 32 spheres: {errors:?}");
}

#[test]
fn vcf_occlusion_points_at_the_object() {
    let (_, tree, field) = sphere_field(11, VcfSampling { spheres: 4, rows: 8, cols: 16, ..VcfSampling::default() });
    let p = field.centre + Vec3::new(-2.0, 1.0, 2.0);
    let (cut, _) = field.lookup(p).expect("finite point");
    let centroid: Vec3 = cut.to_leaves().iter().zip(tree.leaf_dirs()).map(|(v, d)| *d * (1.0 - v)).sum();
    let toward = (field.centre - p).normalize();
    assert!(centroid.normalize().dot(toward) > 0.99, "occlusion centroid {centroid} vs {toward}");
}

#[test]
fn vcf_lookups_outside_the_shell_are_clamped_and_flagged() {
    let (_, _, field) = sphere_field(8, VcfSampling { spheres: 3, rows: 4, cols: 8, ..VcfSampling::default() });
    let c = field.centre;
    let (near, region) = field.lookup(c + Vec3::X * 1.05).expect("finite point");
    assert_eq!(region, FieldRegion::InsideInner);
    let (inner, _) = field.lookup(c + Vec3::X * 1.2).expect("finite point");
    assert_eq!(near.to_leaves(), inner.to_leaves());
    let (far, region) = field.lookup(c + Vec3::X * 50.0).expect("finite point");
    assert_eq!(region, FieldRegion::BeyondOuter);
    assert!(far.to_leaves().iter().all(|v| v.is_finite()));
    // The exact centre has no direction: +Y is used, no NaN.
    let (centre, _) = field.lookup(c).expect("finite point");
    assert!(centre.to_leaves().iter().all(|v| v.is_finite()));
    assert!(matches!(field.lookup(Vec3::new(f32::NAN, 0.0, 0.0)), Err(CutsError::NonFinitePoint(_))));
}

/// Solid angle of the wall `x ∈ [x0, x1]`, `y ∈ [0, h]` in the plane `z = 0` seen from `p`
/// (`p.z ≠ 0`): inclusion–exclusion of the four rectangles with a corner at the foot of `p`,
/// each `atan(a·b / (d·√(d² + a² + b²)))`.
fn wall_sr(p: Vec3, x0: f64, x1: f64, h: f64) -> f64 {
    let d = (p.z as f64).abs();
    let f = |a: f64, b: f64| (a * b / (d * (d * d + a * a + b * b).sqrt())).atan();
    let (ax0, ax1, by0, by1) = (x0 - p.x as f64, x1 - p.x as f64, -(p.y as f64), h - p.y as f64);
    f(ax1, by1) - f(ax0, by1) - f(ax1, by0) + f(ax0, by0)
}

#[test]
fn proxy_field_of_a_wall_matches_its_solid_angle() {
    let levels = 12;
    let tree = DirectionTree::new(levels).expect("valid levels");
    let (x0, x1, h) = (-2.0, 2.0, 2.0);
    let proxy = RayScene::new(wall(x0, x1, h, 0.0));
    let grid = ProxyGrid { min: [-1.0, 0.2, 0.5], max: [1.0, 1.8, 2.5], counts: [5, 5, 5], threshold: 0.0 };
    let field = ProxyField::compute(&proxy, &tree, &grid, &no_progress).expect("valid grid");
    let tol = counting_tolerance_sr(levels);
    let (x0, x1, h) = (x0 as f64, x1 as f64, h as f64);
    // At grid points: the stored cut is the first-hit trace leaf by leaf, and its occluded
    // solid angle is the analytic one.
    for ijk in [[0, 0, 0], [2, 2, 2], [4, 1, 3], [1, 4, 4]] {
        let p = grid.point(ijk);
        let index = ((ijk[2] * 5 + ijk[1]) * 5 + ijk[0]) as usize;
        let traced: Vec<f32> = tree.leaf_dirs().iter().map(|d| if proxy.intersect(p, *d, f32::MAX).is_some() { 0.0 } else { 1.0 }).collect();
        assert_eq!(field.cuts.get(index).to_leaves(), traced, "grid point {ijk:?}");
        let (cut, region) = field.lookup(p).expect("finite point");
        assert_eq!(region, FieldRegion::Within);
        let (got, want) = (occluded_sr(&cut), wall_sr(p, x0, x1, h));
        assert!((got - want).abs() < tol, "grid point {ijk:?}: {got} vs {want}");
    }
    // Between grid points: the trilinear blend of the analytic values at the eight corners.
    let mut r = rng(11);
    for _ in 0..20 {
        let p = Vec3::new(r.random_range(-1.0..1.0), r.random_range(0.2..1.8), r.random_range(0.5..2.5));
        let found = field.locate(p).expect("finite point");
        let corners: f64 = found.neighbours.iter().map(|(k, w)| {
            let (nx, ny) = (grid.counts[0] as usize, grid.counts[1] as usize);
            let ijk = [(k % nx) as u32, (k / nx % ny) as u32, (k / (nx * ny)) as u32];
            *w as f64 * wall_sr(grid.point(ijk), x0, x1, h)
        }).sum();
        let got = occluded_sr(&found.interpolate(&field.cuts).expect("same levels"));
        assert!((got - corners).abs() < tol, "{p}: {got} vs {corners}");
        // And the grid is fine enough that the blend is near the truth at the point: the
        // analytic blend of this grid is within 0.07 sr of the analytic value at these points.
        assert!((got - wall_sr(p, x0, x1, h)).abs() < 0.07 + tol, "{p}");
    }
}

#[test]
fn proxy_field_clamps_outside_its_box_and_flags_it() {
    let tree = DirectionTree::new(8).expect("valid levels");
    let proxy = RayScene::new(wall(-2.0, 2.0, 2.0, 0.0));
    let grid = ProxyGrid { min: [-1.0, 0.0, 0.5], max: [1.0, 1.0, 1.5], counts: [2, 2, 2], threshold: 0.0 };
    let field = ProxyField::compute(&proxy, &tree, &grid, &no_progress).expect("valid grid");
    let (outside, region) = field.lookup(Vec3::new(5.0, 3.0, -9.0)).expect("finite point");
    assert_eq!(region, FieldRegion::OutsideBox);
    let (corner, _) = field.lookup(Vec3::new(1.0, 1.0, 0.5)).expect("finite point");
    assert_eq!(outside.to_leaves(), corner.to_leaves());
    assert!(outside.to_leaves().iter().all(|v| v.is_finite()));
    assert!(field.lookup(Vec3::splat(f32::INFINITY)).is_err());
    // Bad grids.
    for bad in [ProxyGrid { counts: [0, 1, 1], ..grid }, ProxyGrid { max: [-1.0, 1.0, 1.5], ..grid }, ProxyGrid { threshold: -1.0, ..grid }, ProxyGrid { min: [f32::NAN, 0.0, 0.0], ..grid }] {
        assert!(ProxyField::compute(&proxy, &tree, &bad, &no_progress).is_err(), "{bad:?}");
    }
}

#[test]
fn meshes_and_samplings_that_cannot_carry_cuts_are_errors() {
    let tree = DirectionTree::new(6).expect("valid levels");
    let empty = Mesh::default();
    let svc = SvcSettings::default();
    let err = self_visibility_cuts("empty", &empty, &tree, &svc, &no_progress).expect_err("no vertices");
    assert!(err.to_string().contains("'empty'") && err.to_string().contains("no vertices"), "{err}");
    assert!(VisibilityCutField::compute("empty", &empty, &tree, &VcfSampling::default(), &no_progress).is_err());
    let mut bad = icosphere(Vec3::ZERO, 1.0, 0);
    bad.positions[3].y = f32::NAN;
    assert!(self_visibility_cuts("nan", &bad, &tree, &svc, &no_progress).is_err());
    let mut bad = icosphere(Vec3::ZERO, 1.0, 0);
    bad.triangles[0][1] = 99;
    assert!(self_visibility_cuts("index", &bad, &tree, &svc, &no_progress).is_err());
    // All vertices at one point: no bounding radius to place spheres at.
    let point = icosphere(Vec3::ONE, 0.0, 0);
    let err = VisibilityCutField::compute("point", &point, &tree, &VcfSampling::default(), &no_progress).expect_err("radius 0");
    assert!(err.to_string().contains("bounding radius 0"), "{err}");
    let sphere = icosphere(Vec3::ZERO, 1.0, 0);
    assert!(self_visibility_cuts("t", &sphere, &tree, &SvcSettings { threshold: -0.1, ..svc }, &no_progress).is_err());
    let base = VcfSampling::default();
    for s in [VcfSampling { spheres: 0, ..base }, VcfSampling { inner_factor: 0.0, ..base }, VcfSampling { outer_factor: 1.0, ..base }, VcfSampling { rows: 4096, cols: 4096, ..base }] {
        assert!(VisibilityCutField::compute("sphere", &sphere, &tree, &s, &no_progress).is_err(), "{s:?}");
    }
    // Threshold ∞: one node per sample point, the mean visibility.
    let coarse = VisibilityCutField::compute("sphere", &sphere, &tree, &VcfSampling { spheres: 2, rows: 2, cols: 2, threshold: f32::INFINITY, ..base }, &no_progress).expect("valid");
    assert_eq!(coarse.cuts.mean_cut_size(), 1.0);
}

/// A closed box, `lo..hi`, as 12 triangles.
fn solid_box(lo: Vec3, hi: Vec3) -> Mesh {
    let c = |i: u32| Vec3::new(if i & 1 == 0 { lo.x } else { hi.x }, if i & 2 == 0 { lo.y } else { hi.y }, if i & 4 == 0 { lo.z } else { hi.z });
    let faces: [[u32; 4]; 6] = [[0, 1, 3, 2], [4, 6, 7, 5], [0, 4, 5, 1], [2, 3, 7, 6], [0, 2, 6, 4], [1, 5, 7, 3]];
    let mut mesh = Mesh { positions: (0..8).map(c).collect(), ..Mesh::default() };
    for f in faces {
        mesh.triangles.push([f[0], f[1], f[2]]);
        mesh.triangles.push([f[0], f[2], f[3]]);
    }
    mesh.tri_node = vec![0; 12];
    mesh.tri_material = vec![0; 12];
    mesh
}

/// A grid point inside a solid wall sees nothing in any direction; a lookup beside the wall
/// leaves it out and takes the sky of the grid points on its own side, not a blend toward
/// black (`ProxyField::locate`). A point whose neighbours are all inside keeps them.
#[test]
fn proxy_field_lookups_leave_out_grid_points_inside_the_proxy() {
    let levels = 10;
    let tree = DirectionTree::new(levels).expect("valid levels");
    // A 0.4 m thick, 3 m high, 10 m long wall at x = 0; grid points at x = −1, 0, 1 (the middle
    // ones inside it), z = −1, 0, 1, all at 1 m height.
    let proxy = RayScene::new(solid_box(Vec3::new(-0.2, 0.0, -5.0), Vec3::new(0.2, 3.0, 5.0)));
    let grid = ProxyGrid { min: [-1.0, 1.0, -1.0], max: [1.0, 1.0, 1.0], counts: [3, 1, 3], threshold: 0.0 };
    let field = ProxyField::compute(&proxy, &tree, &grid, &no_progress).expect("valid grid");
    let index = |i: usize, k: usize| k * 3 + i;
    for k in 0..3 {
        assert!(field.solid(index(1, k)), "the grid point in the wall at z index {k}");
        assert!(!field.solid(index(0, k)) && !field.solid(index(2, k)));
    }
    // 0.5 m east of the wall's axis (0.3 m off its face): half the weight was the point inside.
    let found = field.locate(Vec3::new(0.5, 1.0, 0.0)).expect("finite point");
    assert_eq!(found.neighbours, vec![(index(2, 1), 1.0)]);
    let cut = found.interpolate(&field.cuts).expect("same levels");
    assert_eq!(cut.to_leaves(), field.cuts.get(index(2, 1)).to_leaves());
    // What it sees: the wall's east face, 0.8 m away, 2 m above and 1 m below, 5 m to each
    // side: four rectangles with a corner at the foot of the perpendicular, each
    // `atan(a·b / (d·√(a² + b² + d²)))` (0.325 of the sphere), where the blend with the black
    // point inside gave 0.66.
    let corner = |a: f64, b: f64, d: f64| (a * b / (d * (a * a + b * b + d * d).sqrt())).atan();
    let want = 2.0 * (corner(2.0, 5.0, 0.8) + corner(1.0, 5.0, 0.8));
    let got = occluded_sr(&cut);
    assert!((got - want).abs() < counting_tolerance_sr(levels), "hidden {got} sr, the face subtends {want} sr");
    // Off the grid's lines: the two points on the east side share the weight by their distance.
    let found = field.locate(Vec3::new(0.5, 1.0, 0.25)).expect("finite point");
    let mut got = found.neighbours.clone();
    got.sort_by_key(|(k, _)| *k);
    assert_eq!(got, vec![(index(2, 1), 0.75), (index(2, 2), 0.25)]);
    // A point in the wall itself, between two points inside it: no open neighbour, kept.
    let found = field.locate(Vec3::new(0.0, 1.0, 0.5)).expect("finite point");
    assert!(found.neighbours.iter().all(|(k, _)| field.solid(*k)) && found.neighbours.len() == 2, "{:?}", found.neighbours);
}
