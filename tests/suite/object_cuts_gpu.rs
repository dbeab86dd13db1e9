//! The visibility cuts' per-vertex sum in a compute pass (`heliar::run::cuts_gpu`, issue 15 §2)
//! against the CPU path (`FrameCuts::object_ambient`) on the courtyard's statue and robot with
//! the frame loop's cuts (`PrecomputeOptions::frame_loop`: `S = 2^10`, 8 spheres × 16², the
//! proxy field over the `[irradiance]` box), the robot driven up to the statue.

use glam::Vec3;
use heliar::cuts::file::{PrecomputedCuts, precompute};
use heliar::cuts::flat::{FlatBanks, FrameOps};
use heliar::cuts::frame::{FrameCuts, UnitLighting};
use heliar::cuts::rotate::Pose;
use heliar::cuts::lighting::ClusteredLighting;
use heliar::cuts::{DirectionTree, no_progress};
use heliar::geometry::raycast::RayScene;
use heliar::gpu::{Gpu, GpuError, GpuOptions};
use heliar::run::cuts_gpu::GpuFrameCuts;
use heliar::run::precompute::{PrecomputeOptions, settings};
use heliar::scene::Scene;
use std::f32::consts::FRAC_1_PI;
use std::path::Path;

/// The courtyard's cuts as the frame loop computes them (in memory), at `levels`.
pub(crate) fn courtyard_cuts(levels: u32) -> FrameCuts {
    let scene = Scene::load(&Path::new(env!("CARGO_MANIFEST_DIR")).join("scenes/courtyard")).unwrap();
    let proxy = RayScene::new(scene.proxy.clone());
    let objects: Vec<(&str, &heliar::geometry::Mesh)> = scene.virtual_objects.iter().map(|o| ("object", &o.mesh)).collect();
    let cuts: PrecomputedCuts = precompute(&objects, Some(&proxy), &settings(&scene, &PrecomputeOptions { levels, ..PrecomputeOptions::frame_loop() }), &no_progress).unwrap();
    FrameCuts::new(cuts).unwrap()
}

/// A lighting with all three parts and structure in every direction: a sky brighter toward
/// the sun side and the zenith, a ground bounce below the horizon per unit `Pa` and `Pd`.
pub(crate) fn lighting(tree: &DirectionTree) -> UnitLighting {
    let sky = |d: Vec3| if d.y > 0.0 { Vec3::new(0.8, 0.9, 1.2) * FRAC_1_PI * (0.6 + 0.4 * d.y + 0.3 * d.x.max(0.0)) } else { Vec3::ZERO };
    let ground = |d: Vec3, s: f32| if d.y <= 0.0 { Vec3::new(0.3, 0.28, 0.25) * s * (1.0 - 0.5 * d.z) } else { Vec3::ZERO };
    UnitLighting {
        sky_pa: ClusteredLighting::from_fn(tree, sky),
        surface_pa: Some(ClusteredLighting::from_fn(tree, |d| ground(d, 0.2))),
        surface_pd: Some(ClusteredLighting::from_fn(tree, |d| ground(d, 0.7))),
        maps: None,
        local: None,
    }
}

/// The device, or `None` (with a message) when the machine has no adapter at all.
pub(crate) fn device() -> Option<Gpu> {
    match Gpu::new(GpuOptions { samples: 1 }) {
        Ok(g) => {
            eprintln!("GPU: {}", g.describe());
            Some(g)
        }
        Err(GpuError::NoAdapter(e)) => {
            eprintln!("SKIPPED: no GPU adapter ({e}); the compute pass of the cuts was not compared");
            None
        }
        Err(e) => panic!("{e}"),
    }
}

#[test]
fn the_compute_pass_equals_the_cpu_walk_on_the_courtyard() {
    let Some(gpu) = device() else { return };
    // The frame loop's S = 2^10, and S = 2^13, where one thread walking a whole product ran past
    // llvmpipe's loop limit and came out up to 95% too dark (cuts::flat, "Segments").
    for levels in [10, 13] {
        compare(&gpu, levels);
    }
}

fn compare(gpu: &Gpu, levels: u32) {
    let frame = courtyard_cuts(levels);
    let light = lighting(&frame.tree);
    let mut pass = GpuFrameCuts::new(gpu, &frame).unwrap();
    let eye = Vec3::new(0.5, 1.6, 9.0);
    // The robot (object 1, cut at its first key [5, 0, −3]) where it starts, halfway, beside
    // the statue (at [−1.9, 0, 0], 0.9 m between their bounds) and under the wall's sky shadow.
    let frames = [[0.0, 0.0, 0.0], [-3.0, 0.0, 1.5], [-5.8, 0.0, 4.2], [-4.6, 0.0, 2.2]];
    let (mut worst_n, mut worst_r, mut near, mut reached) = (0.0f32, 0.0f32, 0usize, 0usize);
    let banks = FlatBanks::new(&frame).unwrap();
    for t in frames {
        let poses = [Vec3::ZERO, Vec3::from(t)];
        // What the pass walks: every vertex has the proxy field; beside the statue, some have
        // the other object's field too (a group of up to 8 cuts).
        let ops = FrameOps::new(&frame, &banks, &poses.map(Pose::translated), eye).unwrap();
        let groups: Vec<u32> = ops.vertices.iter().map(|v| ops.ops[(v.ops[0] + v.ops[2] - 1) as usize].group + 1).collect();
        assert!(groups.iter().all(|&g| g >= 2));
        reached += groups.iter().filter(|&&g| g == 3).count();
        let cpu = frame.object_ambient(&light, &poses, eye).unwrap();
        let gpu_rows = pass.object_ambient(gpu, &frame, &light, &poses, eye).unwrap();
        assert_eq!(cpu.outside_proxy_box, gpu_rows.outside_proxy_box);
        assert_eq!(cpu.vertices.iter().map(Vec::len).collect::<Vec<_>>(), gpu_rows.vertices.iter().map(Vec::len).collect::<Vec<_>>());
        for (a, b) in cpu.vertices.iter().flatten().zip(gpu_rows.vertices.iter().flatten()) {
            // Per row, relative to the row's largest channel plus a floor of 1e-6 (a row of the
            // Pd part is 0 on vertices that see no ground).
            for row in 0..4 {
                let scale = a[row][..3].iter().fold(1e-6f32, |m, v| m.max(v.abs()));
                let err = (0..3).map(|c| (a[row][c] - b[row][c]).abs()).fold(0.0, f32::max) / scale;
                let worst = if row % 2 == 0 { &mut worst_n } else { &mut worst_r };
                *worst = worst.max(err);
            }
            assert_eq!(a[0][3], b[0][3]);
            near += (a[0][1] > 0.0) as usize;
        }
    }
    eprintln!("S = 2^{levels}: worst relative difference: E_n {worst_n:.2e}, E_r {worst_r:.2e} over {near} vertex rows ({reached} with the other object's field)");
    assert!(near > 1000, "only {near} vertices lit");
    assert!(reached > 1000, "only {reached} vertex rows had the other object's field");
    // Both walks add the same terms, the pass in 2^8-leaf segments added afterwards (measured
    // 8e-7 at 2^10, 3e-6 at 2^13 on lavapipe and GL: f32 rounding of the other summation order).
    assert!(worst_n < 1e-5, "E_n differs by {worst_n:.2e} (relative)");
    // E_r divides by n·ω_k, which GL/llvmpipe rounds differently (measured 8e-6); and it would
    // differ where an interpolated field's equal siblings are merged on the CPU only
    // (cuts::flat module docs), which none of these frames has.
    assert!(worst_r < 5e-5, "E_r differs by {worst_r:.2e} (relative)");
}
