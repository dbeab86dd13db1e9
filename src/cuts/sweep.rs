//! Error against cost of the cuts (issue 15, §4): sweeps of the cut threshold, the number of
//! directions `S` and the field sampling (spheres × points per sphere) on a test scene, each
//! point against a brute-force ray-traced reference.
//!
//! # The test scene and the measures
//! A torus (object A, shadows itself) stands beside a sphere (object B) above a ground of real
//! receivers, under an analytic sky with a bright patch ([`sweep_sky`]). For every sweep point:
//! - **vertex error**: the irradiance `Σ_k l_k v_k` of every vertex of A through
//!   `SVC_A × VCF_B` (Eqs. 3–4 with `f_r = 1`) against `Σ_j L_j V_j cos θ_j Δω` over
//!   `reference_dirs` Fibonacci directions traced against A and B together; relative RMSE
//!   `√(mean (E − E_ref)²) / √(mean E_ref²)`;
//! - **receiver error**: the occlusion `1 − visibility` that B casts on each ground receiver
//!   (from `VCF_B`) against the traced one; RMSE over the receivers relative to the RMS of the
//!   traced occlusion;
//! - **precompute time** of `SVC_A` and `VCF_B`, **stored bytes** of both banks and their mean
//!   cut sizes, and the **time per evaluation** of a vertex and of a receiver and of one frame's
//!   evaluations of all of them (one thread, the fastest of three runs).
//!
//! `heliar bench cuts` runs it from the command line (table, CSV, plot).

use super::eval::{CutScene, ObjectCuts};
use super::lighting::{ClusteredLighting, ReceiverWeights, Reflectance};
use super::shapes::{icosphere, torus};
use super::svc::{SelfVisibility, SvcSettings, bounding_sphere, self_visibility_cuts, vertex_normals};
use super::tree::DirectionTree;
use super::vcf::{VcfSampling, VisibilityCutField};
use super::{Cut, CutsError, PackedCuts, ValueEncoding, no_progress};
use crate::geometry::Mesh;
use crate::geometry::raycast::RayScene;
use crate::geometry::sampling::sphere_fibonacci;
use crate::report::{Table, sig3};
use glam::Vec3;
use rayon::prelude::*;
use std::time::Instant;

/// The sweep's test scene: objects in their own frames and their translations.
#[derive(Clone, Debug)]
pub struct SweepScene {
    /// Object A (shaded).
    pub a: Mesh,
    /// A's translation.
    pub a_at: Vec3,
    /// Object B (occluder of A and of the receivers).
    pub b: Mesh,
    /// B's translation.
    pub b_at: Vec3,
    /// Ground receivers (normal +Y), world frame.
    pub receivers: Vec<Vec3>,
}

/// One setting of the sweep.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct SweepPoint {
    /// Tree depth.
    pub levels: u32,
    /// SVC threshold.
    pub svc_threshold: f32,
    /// Field sampling of B.
    pub vcf: VcfSampling,
}

/// The measures at one sweep point.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct SweepRow {
    /// The setting.
    pub point: SweepPoint,
    /// Relative RMSE of A's vertex irradiance.
    pub vertex_rel_rmse: f64,
    /// RMSE of B's occlusion on the receivers over the RMS occlusion.
    pub receiver_rel_rmse: f64,
    /// Wall time of `SVC_A` and `VCF_B`, ms.
    pub precompute_ms: f64,
    /// Stored bytes of `SVC_A`.
    pub svc_bytes: usize,
    /// Stored bytes of `VCF_B`.
    pub vcf_bytes: usize,
    /// Mean SVC cut size (nodes).
    pub mean_svc_cut: f64,
    /// Mean VCF cut size (nodes).
    pub mean_vcf_cut: f64,
    /// Time per vertex evaluation (one thread), µs.
    pub us_per_vertex: f64,
    /// Time per receiver evaluation (one thread), µs.
    pub us_per_receiver: f64,
    /// One frame's evaluations (every vertex of A and every receiver, one thread), ms.
    pub frame_ms: f64,
}

/// The sky of the sweep: a zenith-bright gradient, a bright patch (σ = 8°) at 35° elevation
/// toward +X, and a dim ground (radiance 0.1) below the horizon.
pub fn sweep_sky(d: Vec3) -> Vec3 {
    if d.y < 0.0 {
        return Vec3::splat(0.1);
    }
    let patch_dir = Vec3::new(35f32.to_radians().cos(), 35f32.to_radians().sin(), 0.0);
    let angle = d.dot(patch_dir).clamp(-1.0, 1.0).acos();
    let sigma = 8f32.to_radians();
    Vec3::splat(0.4 + 0.6 * d.y + 6.0 * (-(angle * angle) / (2.0 * sigma * sigma)).exp())
}

/// The default scene: a torus (major 0.5 m, tube 0.2 m, 24 × 12) at height 0.4 m and a sphere
/// (0.3 m, 162 vertices) 1.15 m away at height 0.45 m, over 11 × 11 receivers around the sphere.
pub fn sweep_scene() -> SweepScene {
    let b_at = Vec3::new(1.15, 0.45, 0.0);
    let receivers = (0..11).flat_map(|i| (0..11).map(move |k| Vec3::new(b_at.x - 1.0 + 0.2 * i as f32, 0.0, -1.0 + 0.2 * k as f32))).collect();
    SweepScene { a: torus(Vec3::ZERO, 0.5, 0.2, 24, 12), a_at: Vec3::new(0.0, 0.4, 0.0), b: icosphere(Vec3::ZERO, 0.3, 2), b_at, receivers }
}

/// The sweep points: the SVC threshold, `S`, and the field sampling from 8 × 8² to the paper's
/// 32 × 32², each varied around a middle setting; then the paper's `S` and sampling at three
/// thresholds.
pub fn default_sweep_points() -> Vec<SweepPoint> {
    let vcf = |n: u32| VcfSampling { spheres: n, rows: n, cols: n, ..VcfSampling::default() };
    let mut points = Vec::new();
    for t in [0.0, 0.02, 0.05, 0.1, 0.2] {
        points.push(SweepPoint { levels: 13, svc_threshold: t, vcf: vcf(16) });
    }
    for levels in [11, 12, 14, 15] {
        points.push(SweepPoint { levels, svc_threshold: 0.05, vcf: vcf(16) });
    }
    for n in [8, 24, 32] {
        points.push(SweepPoint { levels: 13, svc_threshold: 0.05, vcf: vcf(n) });
    }
    for t in [0.05, 0.1, 0.2] {
        points.push(SweepPoint { levels: 15, svc_threshold: t, vcf: vcf(32) });
    }
    points
}

/// Repeats of each timed loop; the fastest is reported (the least disturbed by other load).
const TIMING_REPEATS: usize = 3;

/// Runs `f` `repeats` times; its (last) result and the fastest wall time in seconds.
fn fastest_of<T>(repeats: usize, mut f: impl FnMut() -> Result<T, CutsError>) -> Result<(T, f64), CutsError> {
    let mut best = f64::MAX;
    let mut out = None;
    for _ in 0..repeats.max(1) {
        let timer = Instant::now();
        let value = f()?;
        best = best.min(timer.elapsed().as_secs_f64());
        out = Some(value);
    }
    out.map(|v| (v, best)).ok_or_else(|| CutsError::Operands("no timing run".into()))
}

/// Traced references: per-vertex irradiance of A, per-receiver occlusion by B.
#[derive(Clone, Debug)]
pub struct SweepReference {
    /// Irradiance of each vertex of A with A and B present.
    pub vertex_irradiance: Vec<f64>,
    /// Share of each receiver's sky light that B blocks.
    pub receiver_occlusion: Vec<f64>,
}

fn translated(mesh: &Mesh, t: Vec3) -> Mesh {
    let mut m = mesh.clone();
    m.positions.iter_mut().for_each(|p| *p += t);
    m
}

/// Traces the reference with `reference_dirs` Fibonacci directions (in parallel).
pub fn trace_reference(scene: &SweepScene, reference_dirs: usize) -> SweepReference {
    let dirs = sphere_fibonacci(reference_dirs);
    let dw = 4.0 * std::f64::consts::PI / reference_dirs as f64;
    let mut both = translated(&scene.a, scene.a_at);
    both.append(&translated(&scene.b, scene.b_at));
    let (both, only_b) = (RayScene::new(both), RayScene::new(translated(&scene.b, scene.b_at)));
    let normals = vertex_normals(&scene.a);
    let offset = bounding_sphere(&scene.a).map_or(0.0, |(_, r)| r) * super::svc::SELF_RAY_OFFSET_FRACTION;
    let vertex_irradiance = (0..scene.a.positions.len())
        .into_par_iter()
        .map(|v| {
            let (n, x) = (normals[v], scene.a.positions[v] + scene.a_at);
            let origin = x + n * offset;
            dirs.iter().filter(|d| n.dot(**d) > 0.0 && !both.occluded(origin, **d, f32::MAX)).map(|d| sweep_sky(*d).x as f64 * n.dot(*d) as f64 * dw).sum()
        })
        .collect();
    let receiver_occlusion = scene
        .receivers
        .par_iter()
        .map(|&x| {
            let (mut all, mut lost) = (0.0f64, 0.0f64);
            for d in dirs.iter().filter(|d| d.y > 0.0) {
                let w = sweep_sky(*d).x as f64 * d.y as f64;
                all += w;
                if only_b.occluded(x, *d, f32::MAX) {
                    lost += w;
                }
            }
            lost / all
        })
        .collect();
    SweepReference { vertex_irradiance, receiver_occlusion }
}

fn rel_rmse(estimate: &[f64], reference: &[f64]) -> f64 {
    let err: f64 = estimate.iter().zip(reference).map(|(e, r)| (e - r) * (e - r)).sum();
    let norm: f64 = reference.iter().map(|r| r * r).sum();
    if norm > 0.0 { (err / norm).sqrt() } else { err.sqrt() }
}

/// Runs the sweep (`reference_dirs` directions for the traced reference).
pub fn sweep(scene: &SweepScene, points: &[SweepPoint], reference_dirs: usize) -> Result<Vec<SweepRow>, CutsError> {
    let reference = trace_reference(scene, reference_dirs);
    points.iter().map(|p| sweep_point(scene, p, &reference)).collect()
}

/// Measures one sweep point against `reference`.
pub fn sweep_point(scene: &SweepScene, point: &SweepPoint, reference: &SweepReference) -> Result<SweepRow, CutsError> {
    let tree = DirectionTree::new(point.levels)?;
    let lighting = ClusteredLighting::from_fn(&tree, sweep_sky);
    let started = Instant::now();
    let svc = SvcSettings { threshold: point.svc_threshold, ..SvcSettings::default() };
    let svc_a = self_visibility_cuts("sweep torus", &scene.a, &tree, &svc, &no_progress)?;
    let vcf_b = VisibilityCutField::compute("sweep sphere", &scene.b, &tree, &point.vcf, &no_progress)?;
    let precompute_ms = started.elapsed().as_secs_f64() * 1e3;
    // A's field and B's self-visibility do not enter the measures: a one-point field and zero
    // cuts stand in for them.
    let vcf_a = VisibilityCutField::compute("sweep torus", &scene.a, &tree, &VcfSampling { spheres: 1, rows: 1, cols: 1, ..point.vcf }, &no_progress)?;
    let mut zero = PackedCuts::new(point.levels, ValueEncoding::Bits)?;
    let none = Cut::constant(point.levels, 0.0)?;
    for _ in &scene.b.positions {
        zero.push(&none)?;
    }
    let svc_b = SelfVisibility { normals: vec![Vec3::ZERO; scene.b.positions.len()], cuts: zero };
    let a = ObjectCuts { positions: scene.a.positions.clone(), svc: svc_a, vcf: vcf_a };
    let b = ObjectCuts { positions: scene.b.positions.clone(), svc: svc_b, vcf: vcf_b };
    let objects = [a, b];
    let translations = [scene.a_at, scene.b_at];
    let cuts = CutScene { tree: &tree, lighting: &lighting, objects: &objects, translations: &translations, proxy: None };
    let flat = Reflectance::Lambert(Vec3::splat(std::f32::consts::PI)); // f_r = 1: irradiance
    let vertices = || (0..scene.a.positions.len()).map(|v| cuts.vertex_radiance(0, v, &flat, Vec3::Y).map(|s| s.radiance.x as f64)).collect::<Result<Vec<f64>, _>>();
    let (vertex, vertex_s) = fastest_of(TIMING_REPEATS, vertices)?;
    let us_per_vertex = vertex_s * 1e6 / vertex.len().max(1) as f64;
    let weights = ReceiverWeights::new(&tree, &lighting, Vec3::Y)?;
    let b_only = CutScene { objects: &objects[1..], translations: &translations[1..], ..cuts };
    let receivers = || scene.receivers.iter().map(|&x| b_only.receiver_visibility(&weights, x, Vec3::Y).map(|r| 1.0 - r.visibility as f64)).collect::<Result<Vec<f64>, _>>();
    let (occlusion, receiver_s) = fastest_of(TIMING_REPEATS, receivers)?;
    let us_per_receiver = receiver_s * 1e6 / occlusion.len().max(1) as f64;
    Ok(SweepRow {
        point: *point,
        vertex_rel_rmse: rel_rmse(&vertex, &reference.vertex_irradiance),
        receiver_rel_rmse: rel_rmse(&occlusion, &reference.receiver_occlusion),
        precompute_ms,
        svc_bytes: objects[0].svc.cuts.stored_bytes(),
        vcf_bytes: objects[1].vcf.cuts.stored_bytes(),
        mean_svc_cut: objects[0].svc.cuts.mean_cut_size(),
        mean_vcf_cut: objects[1].vcf.cuts.mean_cut_size(),
        us_per_vertex,
        us_per_receiver,
        frame_ms: (vertex_s + receiver_s) * 1e3,
    })
}

/// The sweep as a table (for the terminal or CSV).
pub fn sweep_table(rows: &[SweepRow]) -> Table {
    let mut t = Table::new(&["S", "svc_threshold", "vcf", "vertex_rel_rmse", "receiver_rel_rmse", "precompute_ms", "svc_bytes", "vcf_bytes", "mean_svc_cut", "mean_vcf_cut", "us_per_vertex", "us_per_receiver", "frame_ms"]);
    for r in rows {
        let v = &r.point.vcf;
        t.push(vec![
            (1u32 << r.point.levels).to_string(),
            sig3(r.point.svc_threshold as f64),
            format!("{}x{}x{}", v.spheres, v.rows, v.cols),
            format!("{:.4}", r.vertex_rel_rmse),
            format!("{:.4}", r.receiver_rel_rmse),
            format!("{:.0}", r.precompute_ms),
            r.svc_bytes.to_string(),
            r.vcf_bytes.to_string(),
            format!("{:.1}", r.mean_svc_cut),
            format!("{:.1}", r.mean_vcf_cut),
            format!("{:.1}", r.us_per_vertex),
            format!("{:.1}", r.us_per_receiver),
            format!("{:.3}", r.frame_ms),
        ]);
    }
    t
}
