//! The VEM mode's cut lighting (`super::vem_cuts`) against a brute-force reference: a torus (its
//! inner side shadows itself) under a synthetic VEM frame with a sun-like patch and a sky
//! gradient, the ground below lit by it; each vertex's radiance from the cuts against the same
//! map integrated texel by texel with a ray against the mesh per texel. The lights mode's
//! per-vertex radiance (the frame's directional lights, with exact ray-cast visibility in place
//! of shadow maps: an upper bound on its accuracy) is measured against the same reference.

use super::vem_cuts::{captured_lighting, upward_irradiance};
use crate::cuts::eval::ObjectCuts;
use crate::cuts::file::PrecomputedCuts;
use crate::cuts::frame::FrameCuts;
use crate::cuts::svc::{SELF_RAY_OFFSET_FRACTION, SvcSettings};
use crate::cuts::vcf::VcfSampling;
use crate::cuts::{DirectionTree, no_progress, shapes};
use crate::geometry::equirect::{dir_from_texel_centre, texel_solid_angle};
use crate::geometry::raycast::RayScene;
use crate::vem::polar::PolarMap;
use glam::Vec3;
use std::sync::Arc;

/// Relative RMSE over the vertices allowed for the cuts' radiance (issue 15 §3's 5%). What
/// remains is the tree's resolution at 2^10 directions (leaves ~6° across: the sun patch's light
/// falls on one or two leaves whose visibility is the cut node's mean) and the SVC threshold.
const MAX_CUT_REL_RMSE: f64 = 0.05;
/// Albedo of the ground below the horizon and of the torus (Lambertian).
const ALBEDO: f32 = 0.3;

/// Sun direction and the patch's angular radius (4°: a few texels of the 2° map).
fn sun() -> (Vec3, f32) {
    (Vec3::new(0.45, 0.55, 0.3).normalize(), 4f32.to_radians())
}

/// The synthetic VEM frame: a sky brighter at the zenith and toward +x, and the sun patch.
fn frame_map() -> PolarMap {
    let (s, r) = sun();
    PolarMap::from_fn(180, 45, |d| {
        let patch = if d.dot(s) >= r.cos() { 300.0 } else { 0.0 };
        [0.3 + 0.5 * d.y + 0.1 * d.x + patch, 0.35 + 0.55 * d.y + 0.1 * d.x + 0.95 * patch, 0.5 + 0.7 * d.y + 0.05 * d.x + 0.85 * patch]
    })
}

fn lum(c: Vec3) -> f64 {
    (0.2126 * c.x + 0.7152 * c.y + 0.0722 * c.z) as f64
}

/// Relative RMSE of `got` against `want` (luminance).
fn rel_rmse(got: &[Vec3], want: &[Vec3]) -> f64 {
    let (mut num, mut den) = (0.0, 0.0);
    for (g, w) in got.iter().zip(want) {
        num += (lum(*g) - lum(*w)).powi(2);
        den += lum(*w).powi(2);
    }
    (num / den).sqrt()
}

/// `E(x, n) = Σ_texels L·V·max(n·ω, 0)·Δω` over the equirect `2W × 2H` made of the map above the
/// horizon and the ground radiance below, one ray per texel from just off the surface.
fn reference_irradiance(scene: &RayScene, map: &PolarMap, ground: [f32; 3], x: Vec3, n: Vec3, offset: f32) -> Vec3 {
    let (w, h) = (map.width, 2 * map.height);
    let origin = x + n * offset;
    let mut e = Vec3::ZERO;
    for j in 0..h {
        let dw = texel_solid_angle(j, w, h);
        for i in 0..w {
            let d = dir_from_texel_centre(i, j, w, h);
            let c = n.dot(d);
            if c <= 0.0 || scene.occluded(origin, d, f32::MAX) {
                continue;
            }
            let l = if j < map.height { map.get(i, j) } else { ground };
            e += Vec3::from(l) * c * dw;
        }
    }
    e
}

#[test]
fn cut_radiance_of_a_torus_under_a_vem_frame_matches_ray_traced_quadrature() {
    let torus = shapes::torus(Vec3::ZERO, 0.5, 0.2, 16, 10);
    let tree = DirectionTree::new(10).unwrap();
    let vcf = VcfSampling { spheres: 4, rows: 8, cols: 8, ..VcfSampling::default() };
    let obj = ObjectCuts::compute("torus", &torus, &tree, &SvcSettings::default(), &vcf, &no_progress).unwrap();
    let frame = FrameCuts::new(PrecomputedCuts { inputs_hash: [0; 32], levels: 10, objects: vec![obj], proxy: None }).unwrap();
    let map = frame_map();
    let light = captured_lighting(&frame.tree, &map, ALBEDO).unwrap();
    let amb = frame.object_ambient_posed(&Arc::new(light), &[crate::cuts::rotate::Pose::translated(Vec3::ZERO)], Vec3::new(0.0, 2.0, 6.0)).unwrap();
    let o = &frame.cuts.objects[0];
    let scene = RayScene::new(torus.clone());
    let ground = upward_irradiance(&map).map(|e| ALBEDO / std::f32::consts::PI * e);
    let offset = o.vcf.radius_m * SELF_RAY_OFFSET_FRACTION;
    let lights = crate::vem::lights_of_map(&map, crate::vem::sampling::SamplerKind::CoherentCut, crate::vem::sampling::pattern::Pattern::RelaxedHalton, 300);
    let rho = ALBEDO / std::f32::consts::PI;
    let (mut cut, mut reference, mut lit, mut sky_only) = (Vec::new(), Vec::new(), Vec::new(), Vec::new());
    // Every other vertex (80 of 160): the reference casts ~16 000 rays per vertex.
    for v in (0..o.positions.len()).step_by(2) {
        let (x, n) = (o.positions[v], o.svc.normals[v]);
        let a = amb.vertices[0][v][0];
        cut.push(rho * Vec3::new(a[0], a[1], a[2]));
        reference.push(rho * reference_irradiance(&scene, &map, ground, x, n, offset));
        sky_only.push(rho * reference_irradiance(&scene, &map, [0.0; 3], x, n, offset));
        let mut e = Vec3::ZERO;
        for l in &lights {
            let c = n.dot(l.dir);
            if c > 0.0 && !scene.occluded(x + n * offset, l.dir, f32::MAX) {
                e += Vec3::from(l.rgb) * c;
            }
        }
        lit.push(rho * e);
    }
    let (e_cut, e_lights, e_lights_sky) = (rel_rmse(&cut, &reference), rel_rmse(&lit, &reference), rel_rmse(&lit, &sky_only));
    // The lights stand for the map above the horizon only: against the reference without the
    // ground's light too (what the lights mode leaves out by design).
    eprintln!(
        "torus, {} vertices: relative RMSE of the radiance against the reference: cuts {e_cut:.4}, 300 lights with exact visibility {e_lights:.4} (against the sky's part alone {e_lights_sky:.4})",
        cut.len()
    );
    assert!(e_cut <= MAX_CUT_REL_RMSE, "cuts: relative RMSE {e_cut}");
    // The reference is not trivial: the sun patch dominates the lit side, and the inner ring is
    // partly in its shadow (at least a quarter of the vertices lose half their light or more).
    let dim = reference.iter().filter(|r| lum(**r) < 0.5 * reference.iter().map(|x| lum(*x)).fold(0.0, f64::max)).count();
    assert!(dim * 4 >= reference.len(), "{dim} of {}", reference.len());
}

#[test]
fn a_sphere_shadows_the_ground_away_from_the_vem_sun() {
    // A sphere of radius 0.5 m centred 1 m above the ground under a sun patch from +x at 45°
    // (and a dim sky): the ground point at x = −1 m lies in its shadow, the one at x = +1 m not.
    let ball = shapes::icosphere(Vec3::ZERO, 0.5, 2);
    let tree = DirectionTree::new(10).unwrap();
    let vcf = VcfSampling { spheres: 8, rows: 16, cols: 16, ..VcfSampling::default() };
    let obj = ObjectCuts::compute("ball", &ball, &tree, &SvcSettings::default(), &vcf, &no_progress).unwrap();
    let frame = FrameCuts::new(PrecomputedCuts { inputs_hash: [0; 32], levels: 10, objects: vec![obj], proxy: None }).unwrap();
    let s = Vec3::new(1.0, 1.0, 0.0).normalize();
    let map = PolarMap::from_fn(180, 45, |d| if d.dot(s) >= 4f32.to_radians().cos() { [300.0; 3] } else { [0.05; 3] });
    let light = Arc::new(captured_lighting(&frame.tree, &map, ALBEDO).unwrap());
    let rc = frame.receivers_posed(light, vec![crate::cuts::rotate::Pose::translated(Vec3::new(0.0, 1.0, 0.0))]);
    let v = rc.visibility(&[(Vec3::new(-1.0, 0.0, 0.0), Vec3::Y), (Vec3::new(1.0, 0.0, 0.0), Vec3::Y)]);
    eprintln!("visibility in the shadow {:.3}, on the sunny side {:.3}", v[0].ambient, v[1].ambient);
    assert!(v[0].ambient < 0.3 && v[1].ambient > 0.9, "{v:?}");
}

