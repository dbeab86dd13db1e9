//! The sky models: what a sun move costs (building a basis, whose non-closed-form shapes are
//! normalised by a 96 × 192 quadrature), evaluating them, and one sample's irradiance per shape
//! (the estimator's future per-sample `c`) for two direction counts.

use criterion::{Criterion, criterion_group, criterion_main};
use glam::Vec3;
use heliar::sky::basis::{SkyBasis, SkyBasisSpec};
use heliar::sky::hosek::HosekSky;
use heliar::sky::preetham::PreethamSky;
use heliar::sky::quadrature::{CosineSet, irradiance};
use std::hint::black_box;

fn sun() -> Vec3 {
    Vec3::new(0.5, 0.12, 0.86).normalize()
}

fn bench_setup(c: &mut Criterion) {
    let mut g = c.benchmark_group("sky_setup");
    for (name, spec) in [
        ("uniform+horizon", SkyBasisSpec::recommended(60.0)),
        ("uniform+circumsolar+horizon", SkyBasisSpec::default()),
        ("with_preetham", SkyBasisSpec { preetham_turbidity: Some(3.0), ..SkyBasisSpec::default() }),
    ] {
        g.bench_function(name, |b| b.iter(|| SkyBasis::new(black_box(sun()), &spec).expect("basis")));
    }
    g.bench_function("hosek", |b| b.iter(|| HosekSky::new(black_box(sun()), 3.0, [0.3; 3]).expect("hosek")));
    g.bench_function("preetham", |b| b.iter(|| PreethamSky::new(black_box(sun()), 3.0).expect("preetham")));
    g.finish();
}

fn bench_eval(c: &mut Criterion) {
    let dirs: Vec<Vec3> = heliar::geometry::sampling::sphere_fibonacci(1024).into_iter().filter(|d| d.y > 0.0).collect();
    let hosek = HosekSky::new(sun(), 3.0, [0.3; 3]).expect("hosek");
    let preetham = PreethamSky::new(sun(), 3.0).expect("preetham");
    let basis = SkyBasis::new(sun(), &SkyBasisSpec::default()).expect("basis");
    let mut g = c.benchmark_group("sky_eval_512_dirs");
    g.bench_function("hosek_rgb", |b| b.iter(|| dirs.iter().map(|d| hosek.radiance_rgb(*d)[1]).sum::<f32>()));
    g.bench_function("preetham_rgb", |b| b.iter(|| dirs.iter().map(|d| preetham.radiance_rgb(*d)[1]).sum::<f32>()));
    let mut out = vec![0.0; basis.len()];
    g.bench_function("basis_all_shapes", |b| {
        b.iter(|| {
            dirs.iter()
                .map(|d| {
                    basis.radiances(*d, &mut out);
                    out[1]
                })
                .sum::<f32>()
        })
    });
    g.finish();
    let mut g = c.benchmark_group("sky_irradiance_per_sample");
    for m in [256, 1024] {
        let set = CosineSet::fibonacci(m).expect("set");
        g.bench_function(format!("{m}_dirs"), |b| b.iter(|| irradiance(&basis, black_box(Vec3::X), &set, |d| d.x < 0.9).expect("irradiance")));
    }
    g.finish();
}

criterion_group!(benches, bench_setup, bench_eval);
criterion_main!(benches);
