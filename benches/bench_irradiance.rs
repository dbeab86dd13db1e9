//! Relighting, probe updates (linear and full paths) and the bake.
//! Targets: relight 512×256 ≤ 2 ms on 2 cores; linear probe update ≤ 0.1 ms for 16×4×16 probes;
//! bake of the bundled scene ≤ 30 s.

use criterion::{Criterion, criterion_group, criterion_main};
use glam::Vec3;
use heliar::envmap::bake::{BakeInfo, Baked, SKY, bake};
use heliar::lighting::Lighting;
use heliar::envmap::relight::{RelightConfig, RelitMap, Relighter};
use heliar::geometry::raycast::RayScene;
use heliar::irradiance::probe_transfer::{LinearBasis, ProbeTransfer};
use heliar::scene::Scene;
use std::hint::black_box;
use std::path::Path;
use std::sync::Arc;

fn scene() -> Scene {
    Scene::load(&Path::new(env!("CARGO_MANIFEST_DIR")).join("scenes/courtyard")).expect("bundled scene")
}

/// A synthetic bake of the given size: the lower half surface, the upper half sky.
fn synthetic(w: u32, h: u32) -> Baked {
    let n = (w * h) as usize;
    let surface = |i: usize| (i as u32 / w) >= h / 2;
    Baked {
        width: w,
        height: h,
        centre: Vec3::ZERO,
        node: (0..n).map(|i| if surface(i) { 0 } else { SKY }).collect(),
        position: (0..n).map(|i| Vec3::new(i as f32 * 1e-3, -1.0, 0.0)).collect(),
        normal: vec![Vec3::Y; n],
        ambient: vec![Vec3::splat(0.9); n],
        albedo: (0..n).map(|i| Vec3::splat(0.2 + 0.3 * ((i % 7) as f32 / 7.0))).collect(),
        info: BakeInfo::default(),
    }
}

fn bench_relight(c: &mut Criterion) {
    let lighting = Lighting { sun_dir: Vec3::new(0.3, 0.8, 0.2).normalize(), above_horizon: true, pd: Vec3::new(3.0, 2.9, 2.6), pa: Vec3::new(0.6, 0.7, 0.9), sky: heliar::lighting::FrameSky::Declared, lamps: heliar::lighting::LampScales::NONE };
    let ray = Arc::new(RayScene::new(heliar::geometry::Mesh::default()));
    let mut g = c.benchmark_group("relight");
    for (w, h) in [(256, 128), (512, 256), (1024, 512)] {
        let b = synthetic(w, h);
        let mut r = Relighter::new(&b, ray.clone(), RelightConfig { sun_bounce: false, ..Default::default() });
        r.update_sun(lighting.sun_dir);
        let mut out = RelitMap::new(w, h);
        g.bench_function(format!("{w}x{h}"), |bch| bch.iter(|| r.relight_into(black_box(&lighting), &mut out)));
    }
    g.finish();
}

fn bench_probes(c: &mut Criterion) {
    let scene = scene();
    let ray = Arc::new(RayScene::new(scene.proxy.clone()));
    let b = bake(&scene, ray.clone(), &|_, _, _| {}).expect("bake");
    // 16×4×16 probes: x, z over 12 m at 0.8 m, y over 2.4 m.
    let t = ProbeTransfer::build(Vec3::new(-6.0, 0.1, -6.0), Vec3::new(6.0, 2.5, 6.0), 0.8, &b, &ray, scene.bake.probe_directions);
    assert_eq!(t.probes(), 16 * 4 * 16);
    let l = Lighting { sun_dir: Vec3::from(b.info.capture_sun_dir), above_horizon: true, pd: Vec3::new(3.0, 2.9, 2.6), pa: Vec3::new(0.6, 0.7, 0.9), sky: heliar::lighting::FrameSky::Declared, lamps: heliar::lighting::LampScales::NONE };
    let mut r = Relighter::new(&b, ray.clone(), scene.bake.relight.clone());
    r.update_sun(l.sun_dir);
    let relit = r.relight(&l);
    let basis = LinearBasis { ambient: t.ambient_response(&r), direct: t.direct_response(&r) };
    let mut grid = t.grid();
    let mut g = c.benchmark_group("probe_update_16x4x16");
    g.bench_function("linear", |bch| bch.iter(|| t.linear_into(&basis, black_box(l.pd), black_box(l.pa), &mut grid)));
    g.bench_function("full", |bch| bch.iter(|| t.full_into(black_box(&relit), l.pa, &mut grid)));
    g.bench_function("direct_response_rebuild", |bch| bch.iter(|| black_box(t.direct_response(&r))));
    g.finish();
}

fn bench_bake(c: &mut Criterion) {
    let scene = scene();
    let ray = Arc::new(RayScene::new(scene.proxy.clone()));
    let mut g = c.benchmark_group("bake");
    g.sample_size(10);
    g.bench_function("courtyard_256x128", |bch| bch.iter(|| black_box(bake(&scene, ray.clone(), &|_, _, _| {}).expect("bake"))));
    g.finish();
}

criterion_group!(benches, bench_relight, bench_probes, bench_bake);
criterion_main!(benches);
