//! The GPU half of the VEM mode (`heliar::render::vem`) against independent CPU references:
//! shading against `vem::glossy`'s reference shading at ray-traced surface points, the
//! shadow-map atlas against ray casting, culling against no culling, tone mapping against
//! `ToneParams::apply`, the `dark` skip, and the report of each kind of frame (recorded).
//! Headless on whatever adapter wgpu opens.

use crate::render::support;

use glam::Vec3;
use heliar::geometry::raycast::RayScene;
use heliar::geometry::{Material, Mesh};
use heliar::io::image::{LinearImage, srgb_u8_from_linear};
use heliar::vem::glossy::{GlossyRegions, high_set, shade_glossy_all, shade_glossy_regions};
use heliar::render::vem::{VemLights, VemRenderConfig, VemRenderer, pass};
use heliar::vem::sampling::pattern::Pattern;
use heliar::vem::polar::PolarMap;
use heliar::vem::regions::{RegionLists, RegionSet};
use heliar::vem::sampling::SamplerKind;
use heliar::vem::{Light, Status, lights_of_map};

/// Mean absolute error allowed, as a fraction of the range of the reference radiance (issue 5,
/// as for the outdoor compositor's shading test).
const MAX_MEAN_ERROR_OF_RANGE: f64 = 0.01;
/// Shadow agreement required away from edges (issue 5).
const MIN_SHADOW_AGREEMENT: f64 = 0.98;
/// Object pixels with `n·l` below this are left out of the shadow comparison: there the light
/// grazes the surface and the lit radiance is too small to tell from shadow.
const MIN_N_DOT_L: f32 = 0.05;

fn material(rgb: [f32; 3], metallic: f32, roughness: f32, name: &str) -> Material {
    Material { name: name.into(), base_color: [rgb[0], rgb[1], rgb[2], 1.0], base_color_texture: None, metallic, roughness }
}

fn ground() -> Mesh {
    let mut m = Mesh::default();
    let mat = m.add_material(Material::diffuse("ground", [0.3; 3]));
    let node = m.add_node("ground", true);
    m.push_quad(Vec3::new(-20.0, 0.0, -20.0), Vec3::Z * 40.0, Vec3::X * 40.0, node, mat);
    m
}

/// A sky with a sun blob: structure in every direction, a strong peak.
fn sky() -> PolarMap {
    let sun = Vec3::new(0.5, 0.7, 0.3).normalize();
    PolarMap::from_fn(360, 90, |d| {
        let s = if d.dot(sun) > 0.995 { 400.0 } else { 0.0 };
        [0.4 + 0.3 * d.y + s, 0.5 + 0.3 * d.y + 0.9 * s, 0.7 + 0.2 * d.x.abs() + 0.8 * s]
    })
}

struct Lists {
    h_set: RegionSet,
    h: RegionLists,
    glossy: GlossyRegions,
    l: RegionLists,
}

fn lists(l_lights: &[Light], h_count: usize) -> Lists {
    let mut h_lights = Vec::new();
    high_set(l_lights, h_count, &mut h_lights);
    let h_set = RegionSet::lambertian(200, 32);
    let glossy = GlossyRegions::new(500, 32);
    let (mut h, mut l) = (RegionLists::default(), RegionLists::default());
    h_set.build_lists(&h_lights, &mut h);
    glossy.regions.build_lists(l_lights, &mut l);
    Lists { h_set, h, glossy, l }
}

/// Per pixel: which mesh (0 none, 1 receiver, 2 + k object k), triangle id, point, normal.
struct Traced {
    kind: Vec<u32>,
    tri: Vec<u32>,
    point: Vec<Vec3>,
    normal: Vec<Vec3>,
}

fn trace(camera: &heliar::camera::Camera, receiver: &RayScene, objects: &[RayScene]) -> Traced {
    let (w, h) = (camera.intrinsics.width, camera.intrinsics.height);
    let mut t = Traced { kind: vec![0; (w * h) as usize], tri: vec![u32::MAX; (w * h) as usize], point: vec![Vec3::ZERO; (w * h) as usize], normal: vec![Vec3::ZERO; (w * h) as usize] };
    for i in 0..(w * h) as usize {
        let Some((o, d)) = camera.pixel_ray(i as u32 % w, i as u32 / w) else { continue };
        let (o, d) = (o.as_vec3(), d.as_vec3());
        let mut best = receiver.intersect(o, d, f32::MAX).map(|hit| (hit, 1u32));
        for (k, s) in objects.iter().enumerate() {
            if let Some(hit) = s.intersect(o, d, f32::MAX)
                && best.as_ref().is_none_or(|b| hit.t < b.0.t)
            {
                best = Some((hit, 2 + k as u32));
            }
        }
        if let Some((hit, kind)) = best {
            t.kind[i] = kind;
            t.tri[i] = kind * 1_000_000 + hit.tri;
            t.point[i] = hit.point;
            t.normal[i] = hit.normal;
        }
    }
    t
}

/// The glTF metallic–roughness lobes `(diffuse, specular)·max(n·l, 0)` (specification,
/// Appendix B), written again: their sum is `support::brdf_cos`.
fn lobes(base: Vec3, metallic: f32, roughness: f32, n: Vec3, v: Vec3, l: Vec3) -> (Vec3, Vec3) {
    let nl = n.dot(l);
    if nl <= 0.0 {
        return (Vec3::ZERO, Vec3::ZERO);
    }
    let nv = n.dot(v).max(1e-4);
    let h = (l + v).normalize();
    let (nh, vh) = (n.dot(h).max(0.0), v.dot(h).max(0.0));
    let alpha = (roughness * roughness).max(0.002);
    let a2 = alpha * alpha;
    let f0 = Vec3::splat(0.04).lerp(base, metallic);
    let fresnel = f0 + (Vec3::ONE - f0) * (1.0 - vh).powi(5);
    let c_diff = base.lerp(Vec3::ZERO, metallic);
    let t = nh * nh * (a2 - 1.0) + 1.0;
    let d = a2 / (std::f32::consts::PI * t * t);
    let vis = 0.5 / (nl * (nv * nv * (1.0 - a2) + a2).sqrt() + nv * (nl * nl * (1.0 - a2) + a2).sqrt());
    ((Vec3::ONE - fresnel) * c_diff / std::f32::consts::PI * nl, fresnel * d * vis * nl)
}

fn renderer(camera: &heliar::camera::Camera, proxy: Option<&Mesh>, objects: &[&Mesh], cfg: VemRenderConfig) -> VemRenderer {
    VemRenderer::new(support::gpu(), camera, proxy, objects, cfg).expect("VEM renderer")
}

#[test]
fn shading_matches_the_cpu_reference_of_vem_glossy() {
    let camera = support::camera([0.0, 1.4, 4.0], [0.0, 0.8, 0.0], 160, 120, [0.0; 5]);
    let mats = [(Vec3::new(0.7, 0.5, 0.3), 0.0, 0.6), (Vec3::new(0.9, 0.85, 0.8), 1.0, 0.3)];
    let objects = [
        support::icosphere(Vec3::new(-0.7, 0.8, 0.0), 0.6, 3, material(mats[0].0.to_array(), mats[0].1, mats[0].2, "rough"), "rough"),
        support::icosphere(Vec3::new(0.7, 0.8, 0.0), 0.6, 3, material(mats[1].0.to_array(), mats[1].1, mats[1].2, "metal"), "metal"),
    ];
    let proxy = ground();
    let refs: Vec<&Mesh> = objects.iter().collect();
    let cfg = VemRenderConfig { shadows: false, ..Default::default() };
    let mut r = renderer(&camera, Some(&proxy), &refs, cfg);
    let l_lights = lights_of_map(&sky(), SamplerKind::Havran, Pattern::RelaxedHalton, 1200);
    let li = lists(&l_lights, 300);
    let lights = VemLights { status: Status::Ok, h: (&li.h_set, &li.h), glossy: Some((&li.glossy, &li.l)), clusters: vec![] };
    let bg = LinearImage::new(160, 120);
    let out = r.render(&lights, &bg, 1.0 / 21.0).unwrap();
    assert!(out.report.ran.contains(&pass::SHADING));
    assert_eq!(out.report.skip_reason(pass::SHADOW_ATLAS), Some("shadows are off"));

    let traced = trace(&camera, &RayScene::new(proxy.clone()), &objects.iter().map(|m| RayScene::new(m.clone())).collect::<Vec<_>>());
    // Silhouettes only: the faceted spheres' triangles are a few pixels each, and a pixel centre
    // lies on the same facet for the rasteriser and the ray caster except within rounding.
    let edges = support::edges(160, 120, &traced.kind);
    let eye = camera.pose.translation.as_vec3();
    let (mut err, mut n, mut lo, mut hi, mut sum) = (0.0f64, 0usize, f64::MAX, f64::MIN, 0.0f64);
    for i in 0..traced.kind.len() {
        if traced.kind[i] < 2 || edges[i] {
            continue;
        }
        let (base, metallic, roughness) = mats[(traced.kind[i] - 2) as usize];
        let (p, nrm) = (traced.point[i], traced.normal[i]);
        let v = (eye - p).normalize();
        let refl = (2.0 * nrm.dot(v) * nrm - v).normalize();
        let mut want = [0.0f32; 3];
        for c in 0..3 {
            // Diffuse lobe over all of H (an empty L and a cone that holds nothing), specular lobe
            // with the L/H split walking the region lists, as vem::glossy defines them.
            let d = shade_glossy_all(&[], &li.h.lights, refl, 2.0, None, |l| lobes(base, metallic, roughness, nrm, v, l).0[c]);
            let s = shade_glossy_regions(&li.glossy, &li.l, &li.h_set, &li.h, nrm, refl, None, |l| lobes(base, metallic, roughness, nrm, v, l).1[c]);
            want[c] = d[c] + s[c];
            let sum = lobes(base, metallic, roughness, nrm, v, Vec3::Y);
            let whole = support::brdf_cos(base, metallic, roughness, nrm, v, Vec3::Y);
            assert!(((sum.0 + sum.1)[c] - whole[c]).abs() <= 1e-5 * whole[c].abs().max(1.0));
        }
        let got = out.hdr.data[i];
        for c in 0..3 {
            err += (got[c] - want[c]).abs() as f64;
            sum += want[c] as f64;
            lo = lo.min(want[c] as f64);
            hi = hi.max(want[c] as f64);
            n += 1;
        }
    }
    assert!(n > 3 * 2000, "only {} object samples", n / 3);
    let rel = err / n as f64 / (hi - lo);
    // The range holds the sun's highlight on the metal ball; the error against the mean value is
    // the stricter measure, bounded the same way.
    let rel_mean = err / sum;
    eprintln!("VEM shading: mean error {:.4}% of the range [{lo:.3}, {hi:.3}], {:.3}% of the mean, over {} pixels", 100.0 * rel, 100.0 * rel_mean, n / 3);
    assert!(rel < MAX_MEAN_ERROR_OF_RANGE, "mean error {rel} of range");
    assert!(rel_mean < MAX_MEAN_ERROR_OF_RANGE, "mean error {rel_mean} of the mean");
}

#[test]
fn culling_changes_nothing_but_the_work() {
    let camera = support::camera([0.0, 1.6, 4.0], [0.0, 0.6, 0.0], 120, 90, [0.0; 5]);
    let obj = support::icosphere(Vec3::new(0.0, 0.7, 0.0), 0.7, 3, material([0.6, 0.6, 0.6], 0.0, 0.4, "ball"), "ball");
    let l_lights = lights_of_map(&sky(), SamplerKind::Havran, Pattern::RelaxedHalton, 1200);
    let li = lists(&l_lights, 300);
    let lights = VemLights { status: Status::Ok, h: (&li.h_set, &li.h), glossy: Some((&li.glossy, &li.l)), clusters: vec![] };
    let bg = LinearImage::from_fn(120, 90, |_, _| [1.0; 3]);
    let mut r = renderer(&camera, None, &[&obj], VemRenderConfig::default());
    assert_eq!(r.receivers_kind(), "ground plane");
    let a = r.render(&lights, &bg, 0.05).unwrap();
    r.set_culling(false);
    let b = r.render(&lights, &bg, 0.05).unwrap();
    assert!(a.report.culling && !b.report.culling);
    assert_eq!(a.report.shadow_maps, b.report.shadow_maps);
    assert!(a.report.shadow_maps > 1 && a.report.shadow_maps <= 72);
    let max = a.hdr.data.iter().flat_map(|p| p.iter()).fold(0.0f32, |m, &x| m.max(x));
    // Same sums in a different order: float rounding, stored as half floats (2⁻¹⁰ relative).
    for (p, q) in a.hdr.data.iter().zip(&b.hdr.data) {
        for c in 0..3 {
            assert!((p[c] - q[c]).abs() <= 2e-3 * max, "{p:?} vs {q:?}");
        }
    }
    // The ball shadows the ground plane under it: the background is darkened somewhere.
    assert!(a.hdr.data.iter().any(|p| p[1] < 0.5));
}

#[test]
fn shadow_atlas_agrees_with_ray_casting() {
    let camera = support::camera([2.0, 2.4, 3.2], [0.0, 0.5, 0.0], 160, 120, [0.0; 5]);
    let grey = material([0.6, 0.6, 0.6], 0.0, 0.7, "grey");
    let objects = [
        support::cube(Vec3::new(-0.6, 0.0, -0.6), Vec3::new(0.6, 0.8, 0.6), grey.clone(), "box"),
        support::icosphere(Vec3::new(0.2, 1.5, 0.1), 0.4, 3, grey, "ball"),
    ];
    let refs: Vec<&Mesh> = objects.iter().collect();
    let proxy = ground();
    let mut r = renderer(&camera, Some(&proxy), &refs, VemRenderConfig::default());
    let rays_objects: Vec<RayScene> = objects.iter().map(|m| RayScene::new(m.clone())).collect();
    let traced = trace(&camera, &RayScene::new(proxy.clone()), &rays_objects);
    let bg = LinearImage::from_fn(160, 120, |_, _| [1.0; 3]);
    let set = RegionSet::lambertian(200, 32);
    for l in [Vec3::new(0.3, 0.9, 0.2), Vec3::new(-0.6, 0.5, 0.4), Vec3::new(0.1, 0.35, -0.9)] {
        let l = l.normalize();
        let mut lists = RegionLists::default();
        set.build_lists(&[Light { index: 0, dir: l, rgb: [1.0; 3], radius: 0.0 }], &mut lists);
        let lights = VemLights { status: Status::Ok, h: (&set, &lists), glossy: None, clusters: vec![] };
        let out = r.render(&lights, &bg, 0.05).unwrap();
        assert_eq!(out.report.shadow_maps, 1);
        // Reference: a shadow ray toward the light against the objects.
        let lit: Vec<u8> = (0..traced.kind.len())
            .map(|i| {
                if traced.kind[i] == 0 {
                    return 2;
                }
                let (p, n) = (traced.point[i], traced.normal[i]);
                u8::from(!rays_objects.iter().any(|s| !s.sees_direction(p, n, l)))
            })
            .collect();
        let key: Vec<(u32, u8)> = traced.tri.iter().zip(&lit).map(|(&t, &v)| (t, v)).collect();
        let edges = support::edges(160, 120, &key);
        let (mut agree, mut total) = (0usize, 0usize);
        for i in 0..traced.kind.len() {
            if traced.kind[i] == 0 || edges[i] {
                continue;
            }
            let got = out.hdr.data[i][1];
            let gpu_lit = if traced.kind[i] == 1 {
                // Receiver: background 1 times the ratio, 0 or 1 for one light.
                got > 0.5
            } else {
                if traced.normal[i].dot(l) < MIN_N_DOT_L {
                    continue;
                }
                got > 1e-4
            };
            total += 1;
            agree += usize::from(gpu_lit == (lit[i] == 1));
        }
        let frac = agree as f64 / total as f64;
        let shadowed = lit.iter().filter(|&&v| v == 0).count();
        eprintln!("atlas vs ray casting, light {l}: {:.2}% of {total} pixels agree ({shadowed} pixels in shadow)", 100.0 * frac);
        assert!(total > 5000 && frac >= MIN_SHADOW_AGREEMENT, "{frac} of {total}");
        assert!(shadowed > 100, "the case has shadow: {shadowed} pixels");
    }
}

#[test]
fn tone_mapping_matches_the_cpu_and_dark_frames_skip_shadows() {
    let camera = support::camera([0.0, 1.4, 4.0], [0.0, 0.8, 0.0], 96, 72, [0.0; 5]);
    let obj = support::icosphere(Vec3::new(0.0, 0.8, 0.0), 0.6, 2, material([0.8, 0.4, 0.2], 0.0, 0.5, "ball"), "ball");
    let mut r = renderer(&camera, None, &[&obj], VemRenderConfig::default());
    let l_lights = lights_of_map(&sky(), SamplerKind::Havran, Pattern::RelaxedHalton, 300);
    let set = RegionSet::lambertian(200, 32);
    let mut lists = RegionLists::default();
    set.build_lists(&l_lights, &mut lists);
    let bg = LinearImage::from_fn(96, 72, |x, y| [0.05 * x as f32, 0.1 + 0.02 * y as f32, 3.0]);
    let out = r.render(&VemLights { status: Status::Ok, h: (&set, &lists), glossy: None, clusters: vec![] }, &bg, 0.05).unwrap();
    let tone = out.report.tone.unwrap();
    let mut worst = 0i32;
    for (i, p) in out.hdr.data.iter().enumerate() {
        let want = tone.apply(*p).map(srgb_u8_from_linear);
        for c in 0..3 {
            worst = worst.max((out.srgb[4 * i + c] as i32 - want[c] as i32).abs());
        }
    }
    // One code: the GPU's sRGB encoder rounds differently from the CPU's at some values.
    assert!(worst <= 1, "largest difference {worst} codes");

    // Dark: no power, no shadow pass, and no NaN anywhere.
    let dark: Vec<Light> = l_lights.iter().map(|l| Light { rgb: [0.0; 3], ..*l }).collect();
    set.build_lists(&dark, &mut lists);
    let out = r.render(&VemLights { status: Status::Dark, h: (&set, &lists), glossy: None, clusters: vec![] }, &bg, 0.05).unwrap();
    let why = out.report.skip_reason(pass::SHADOW_ATLAS).expect("shadow pass skipped");
    assert!(why.contains("no power") && why.contains("dark"), "{why}");
    assert!(out.hdr.data.iter().all(|p| p.iter().all(|c| c.is_finite())));
}

#[test]
fn tone_parameters_are_smoothed_over_frames() {
    // The background flickers ±30% every frame at 21 Hz: the log-average luminance the GPU pass
    // uses moves far less than the frames' own (vem::tonemap, time constant 0.5 s).
    let camera = support::camera([0.0, 1.4, 4.0], [0.0, 0.8, 0.0], 64, 48, [0.0; 5]);
    let obj = support::icosphere(Vec3::new(0.0, 0.8, 0.0), 0.6, 1, material([0.5; 3], 0.0, 0.5, "ball"), "ball");
    let mut r = renderer(&camera, None, &[&obj], VemRenderConfig { shadows: false, ..Default::default() });
    let set = RegionSet::lambertian(200, 32);
    let mut lists = RegionLists::default();
    set.build_lists(&lights_of_map(&sky(), SamplerKind::Havran, Pattern::RelaxedHalton, 64), &mut lists);
    let lights = VemLights { status: Status::Ok, h: (&set, &lists), glossy: None, clusters: vec![] };
    let mut used = Vec::new();
    for t in 0..60 {
        let s = if t % 2 == 0 { 1.3f32 } else { 0.7 };
        let bg = LinearImage::from_fn(64, 48, |x, _| [s * (0.5 + 0.01 * x as f32); 3]);
        used.push(r.render(&lights, &bg, 1.0 / 21.0).unwrap().report.tone.unwrap().log_average);
    }
    let tail = &used[40..];
    let (lo, hi) = tail.iter().fold((f64::MAX, f64::MIN), |a, &x| (a.0.min(x), a.1.max(x)));
    // The frames' own log averages differ by 1.3/0.7 = 1.86×; the smoothed ones by < 6% (the
    // bound of vem::tonemap's own test for the same flicker).
    assert!(hi / lo - 1.0 < 0.06, "smoothed swing {}", hi / lo - 1.0);
}

/// The report of each kind of frame, entry by entry and in order (part of `vem --scene`'s JSON
/// lines), as recorded from the renderer before its passes became units (commit e556da0, one
/// `render` function holding every decision).
#[test]
fn every_kind_of_frame_gives_the_recorded_report() {
    let camera = support::camera([0.0, 1.4, 4.0], [0.0, 0.8, 0.0], 64, 48, [0.0; 5]);
    let obj = support::icosphere(Vec3::new(0.0, 0.8, 0.0), 0.6, 1, material([0.5; 3], 0.0, 0.5, "ball"), "ball");
    let l_lights = lights_of_map(&sky(), SamplerKind::Havran, Pattern::RelaxedHalton, 200);
    let li = lists(&l_lights, 60);
    let dark: Vec<Light> = l_lights.iter().map(|l| Light { rgb: [0.0; 3], ..*l }).collect();
    let mut dark_lists = RegionLists::default();
    li.h_set.build_lists(&dark, &mut dark_lists);
    let bg = LinearImage::new(64, 48);
    let proxy = ground();
    let line = |r: &heliar::render::vem::VemReport| {
        let skipped: Vec<String> = r.skipped.iter().map(|s| format!("{}: {}", s.pass, s.reason)).collect();
        format!("maps={} lights={} glossy={} ran=[{}] skipped=[{}]", r.shadow_maps, r.lights, r.glossy_lights, r.ran.join(", "), skipped.join("; "))
    };
    let ok = VemLights { status: Status::Ok, h: (&li.h_set, &li.h), glossy: None, clusters: vec![] };
    let glossy = VemLights { glossy: Some((&li.glossy, &li.l)), ..ok.clone() };
    let dim = VemLights { status: Status::Dark, h: (&li.h_set, &dark_lists), glossy: None, clusters: vec![] };
    let mut got = Vec::new();
    for (proxy, objects, shadows) in [(Some(&proxy), vec![&obj], true), (None, vec![&obj], true), (None, vec![&obj], false), (Some(&proxy), vec![], true)] {
        let mut r = renderer(&camera, proxy, &objects, VemRenderConfig { shadows, ..Default::default() });
        for lights in [&ok, &glossy, &dim] {
            got.push(line(&r.render(lights, &bg, 0.05).unwrap().report));
        }
    }
    let want: Vec<&str> = vec![
        "maps=14 lights=60 glossy=0 ran=[shadow_atlas, depth_prepass, receivers, shading, composite, tonemap] skipped=[]",
        "maps=14 lights=60 glossy=200 ran=[shadow_atlas, depth_prepass, receivers, shading, composite, tonemap] skipped=[]",
        "maps=0 lights=200 glossy=0 ran=[depth_prepass, shading, composite, tonemap] skipped=[shadow_atlas: the lights carry no power (status dark); receivers: no shadow maps this frame: the ratio is 1 everywhere]",
        "maps=14 lights=60 glossy=0 ran=[shadow_atlas, depth_prepass, receivers, shading, composite, tonemap] skipped=[]",
        "maps=14 lights=60 glossy=200 ran=[shadow_atlas, depth_prepass, receivers, shading, composite, tonemap] skipped=[]",
        "maps=0 lights=200 glossy=0 ran=[depth_prepass, shading, composite, tonemap] skipped=[shadow_atlas: the lights carry no power (status dark); receivers: no shadow maps this frame: the ratio is 1 everywhere]",
        "maps=0 lights=60 glossy=0 ran=[depth_prepass, shading, composite, tonemap] skipped=[shadow_atlas: shadows are off; receivers: no shadow maps this frame: the ratio is 1 everywhere]",
        "maps=0 lights=60 glossy=200 ran=[depth_prepass, shading, composite, tonemap] skipped=[shadow_atlas: shadows are off; receivers: no shadow maps this frame: the ratio is 1 everywhere]",
        "maps=0 lights=200 glossy=0 ran=[depth_prepass, shading, composite, tonemap] skipped=[shadow_atlas: shadows are off; receivers: no shadow maps this frame: the ratio is 1 everywhere]",
        "maps=0 lights=60 glossy=0 ran=[depth_prepass, composite, tonemap] skipped=[shadow_atlas: the scene has no virtual objects; receivers: no shadow maps this frame: the ratio is 1 everywhere; shading: the scene has no virtual objects]",
        "maps=0 lights=60 glossy=200 ran=[depth_prepass, composite, tonemap] skipped=[shadow_atlas: the scene has no virtual objects; receivers: no shadow maps this frame: the ratio is 1 everywhere; shading: the scene has no virtual objects]",
        "maps=0 lights=200 glossy=0 ran=[depth_prepass, composite, tonemap] skipped=[shadow_atlas: the scene has no virtual objects; receivers: no shadow maps this frame: the ratio is 1 everywhere; shading: the scene has no virtual objects]",
    ];
    assert_eq!(got.len(), want.len(), "{}", got.join("\n"));
    for (g, w) in got.iter().zip(want) {
        assert_eq!(g, &w);
    }
}
