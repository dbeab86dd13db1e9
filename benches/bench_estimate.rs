//! Per-frame cost of the estimator on the bundled scene (target: ≤ 0.2 ms at N = 500 on one
//! core, excluding frame decode), the robust solver alone, and the amortised set-up steps.

use criterion::{Criterion, criterion_group, criterion_main};
use heliar::estimate::Estimator;
use heliar::estimate::solve::{ChannelRows, robust_fit};
use heliar::geometry::raycast::RayScene;
use heliar::io::frames::Frame;
use heliar::scene::Scene;
use rand::{Rng, SeedableRng, rngs::SmallRng};
use std::hint::black_box;
use std::path::Path;
use std::sync::Arc;

fn scene() -> Scene {
    Scene::load(&Path::new(env!("CARGO_MANIFEST_DIR")).join("scenes/courtyard")).expect("bundled scene")
}

fn bench_frame(c: &mut Criterion) {
    // One core, as the target says: the per-frame path never uses rayon, and set-up runs first.
    let scene = scene();
    let ray = Arc::new(RayScene::new(scene.proxy.clone()));
    let seq = &scene.sequences[0];
    let frame = Frame::load(&seq.files[0]).expect("frame");
    let lin = seq.photometry.linearizer();
    let mut est = Estimator::new(&scene, ray).expect("estimator");
    est.estimate(0, &seq.times[0], &frame, &lin).expect("first frame builds the sun state");
    let mut g = c.benchmark_group("estimate_frame");
    for n in [50, 500, 5000] {
        est.set_samples(n);
        let mut i = 1;
        g.bench_function(format!("N={n}"), |b| {
            b.iter(|| {
                i += 1;
                black_box(est.estimate(i, &seq.times[0], &frame, &lin).expect("estimate"))
            })
        });
    }
    g.finish();
    c.bench_function("decode_frame_exr_320x240", |b| b.iter(|| black_box(Frame::load(&seq.files[0]).expect("frame"))));
}

fn bench_solver(c: &mut Criterion) {
    let mut rng = SmallRng::seed_from_u64(1);
    let mut rows = ChannelRows::default();
    let mut lit = Vec::new();
    for i in 0..500 {
        let (a, b) = (rng.random_range(0.02..0.2), if i % 2 == 0 { rng.random_range(0.02..0.2) } else { 0.0 });
        let mut y = a * 0.6 + b * 3.0;
        if i % 10 == 0 {
            y *= 0.3; // 10% outliers
        }
        rows.push(a, b, y * (1.0 + 0.01 * rng.random_range(-1.0..1.0)));
        lit.push(i % 2 == 0);
    }
    c.bench_function("robust_fit_500_rows_one_channel", |b| b.iter(|| black_box(robust_fit(&rows, &lit, true, heliar::estimate::solve::HDR_NOISE_FLOOR_REL, &mut rng))));
}

fn bench_setup(c: &mut Criterion) {
    let scene = scene();
    let ray = Arc::new(RayScene::new(scene.proxy.clone()));
    let mut g = c.benchmark_group("setup");
    g.sample_size(10);
    g.bench_function("estimator_new_pool_4096", |b| b.iter(|| black_box(Estimator::new(&scene, ray.clone()).expect("estimator"))));
    g.finish();
}

criterion_group!(benches, bench_frame, bench_solver, bench_setup);
criterion_main!(benches);
