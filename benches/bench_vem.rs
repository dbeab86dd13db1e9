//! Per-frame cost of the VEM decomposition on one core (issue 5 §7; target: CDFs + 300 lights +
//! FIR + clustering + region lists ≤ 0.5 ms for a 360 × 90 map; the paper: < 5 ms on a 3 GHz
//! Pentium 4), its parts, the sample rate (the paper: 410 samples/ms) and fisheye resampling.

use criterion::{Criterion, Throughput, criterion_group, criterion_main};
use heliar::io::frames::{Frame, FrameData, Linearizer, Response};
use heliar::vem::cluster::{cluster_lights, cluster_radius, DEFAULT_CF};
use heliar::camera::Camera;
use heliar::vem::sampling::pattern::{Pattern, sample};
use heliar::vem::polar::PolarMap;
use heliar::vem::regions::{RegionLists, RegionSet};
use heliar::vem::capture::resample::{Projection, Resampler};
use heliar::vem::sampling::{PolarDistribution, SamplerKind};
use heliar::vem::eval::synth::{RATE_HZ, outdoor, render_fisheye, render_polar};
use heliar::vem::fir::{FirDesign, LightFilter};
use heliar::vem::{Decomposer, Light, VemConfig, lights_of_map};
use std::hint::black_box;

fn maps() -> [PolarMap; 2] {
    [render_polar(&outdoor(0, RATE_HZ), 360, 90, 2), render_polar(&outdoor(1, RATE_HZ), 360, 90, 2)]
}

fn bench_frame(c: &mut Criterion) {
    let maps = maps();
    let mut g = c.benchmark_group("vem_frame");
    // The whole per-frame pipeline: CDFs, 300 lights (Havran, relaxed Halton), FIR, clustering
    // into at most 72 (the paper's |H|), lists for 200 angular regions.
    for kind in [SamplerKind::Havran, SamplerKind::Standard] {
        let mut dec = Decomposer::new(VemConfig { lights: 300, sampler: kind, clusters: Some(72), ..VemConfig::default() }).expect("config");
        let mut t = 0;
        g.bench_function(format!("300_lights_{}", kind.name()), |b| {
            b.iter(|| {
                t += 1;
                black_box(dec.process(&maps[t % 2]))
            })
        });
    }
    g.finish();
}

fn bench_parts(c: &mut Criterion) {
    let maps = maps();
    let mut g = c.benchmark_group("vem_parts");
    let mut dist = PolarDistribution::default();
    g.bench_function("cdfs_360x90", |b| b.iter(|| black_box(dist.rebuild(black_box(&maps[0])))));
    dist.rebuild(&maps[0]);
    for n in [300usize, 1024] {
        g.throughput(Throughput::Elements(n as u64));
        for kind in [SamplerKind::Havran, SamplerKind::Standard] {
            g.bench_function(format!("sample_{n}_{}", kind.name()), |b| {
                b.iter(|| {
                    let mut acc = 0.0f32;
                    for k in 0..n {
                        let r = dist.sample(kind, sample(Pattern::RelaxedHalton, k)).expect("light");
                        acc += dist.light_rgb(&maps[0], &r)[0] + r.dir.x;
                    }
                    black_box(acc)
                })
            });
        }
    }
    g.throughput(Throughput::Elements(1));
    let lights: Vec<Light> = lights_of_map(&maps[0], SamplerKind::Havran, Pattern::RelaxedHalton, 300);
    let raw: Vec<_> = lights.iter().map(|l| (l.dir, [1.0f32; 3])).collect();
    let mut filter = LightFilter::new(&FirDesign::paper());
    let mut out = Vec::new();
    g.bench_function("fir_300", |b| b.iter(|| black_box(filter.step(10.0, &raw, &mut out))));
    let mut clusters = Vec::new();
    g.bench_function("cluster_300_to_72", |b| b.iter(|| cluster_lights(black_box(&lights), 72, cluster_radius(72, DEFAULT_CF), &mut clusters)));
    let regions = RegionSet::lambertian(200, 32);
    let mut lists = RegionLists::default();
    g.bench_function("region_lists_300_x_200", |b| b.iter(|| regions.build_lists(black_box(&lights), &mut lists)));
    g.finish();
}

fn bench_input(c: &mut Criterion) {
    let cam = Camera::equidistant_up(512, 180.0);
    let img = render_fisheye(&outdoor(0, RATE_HZ), &cam, 1);
    let frame = Frame { width: 512, height: 512, data: FrameData::Hdr(img) };
    let lin = Linearizer::new(&Response::Linear, 1.0, 1.0, None);
    let mut rs = Resampler::new(&Projection::Fisheye(cam), 512, 512, 360, 90);
    let mut map = PolarMap::new(360, 90);
    c.bench_function("resample_fisheye_512_to_360x90", |b| b.iter(|| black_box(rs.resample(&frame, &lin, &mut map))));
}

criterion_group!(benches, bench_frame, bench_parts, bench_input);
criterion_main!(benches);
