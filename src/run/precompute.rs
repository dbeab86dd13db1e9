//! `heliar precompute`: a scene's visibility cuts for its moving objects, written next to the
//! bake and cached by a hash of their inputs like the bake (issue 15 §2; the cuts themselves are
//! [`crate::cuts`], after cyberworlds §V, `../shared/papers/cyberworlds-captured-lighting-cuts.txt`).
//!
//! # What is written
//! When at least one virtual object moves: every object's self-visibility cuts (one per vertex)
//! and visibility cut field (a moving object is shadowed by the static ones too, so each needs
//! its field), and the real proxy's field on a grid over the irradiance-volume box, in
//! [`crate::cuts::file`]'s format, as `baked/cuts.bin`. Objects are taken where they stand at
//! their motion's first key; the cuts hold for the object translated (`crate::cuts` module docs).
//! A scene where nothing moves needs no cuts: the pass is skipped with its reason and the static
//! per-pixel transfer stays the default.
//!
//! The file carries the blake3 of its inputs (meshes, proxy, settings and the format version);
//! a run whose inputs hash the same loads it instead of computing it again.

use crate::cuts::file::{self, PrecomputeSettings};
use crate::cuts::proxy_field::ProxyGrid;
use crate::cuts::svc::SvcSettings;
use crate::cuts::vcf::VcfSampling;
use crate::cuts::{PAPER_LEVELS, Progress};
use crate::geometry::Mesh;
use crate::geometry::raycast::RayScene;
use crate::scene::{MANIFEST_FILE, Scene};
use anyhow::{Context, Result};
use glam::Vec3;
use serde::Serialize;
use std::path::PathBuf;

/// Name of the cuts file inside the bake folder.
pub const CUTS_FILE: &str = "cuts.bin";
/// Grid spacing of the proxy field when the scene's `[irradiance]` box gives none, m.
pub const DEFAULT_PROXY_SPACING_M: f32 = 1.0;
/// Margin of the default box around the objects when the scene has no `[irradiance]` box, m
/// (the default probe grid's).
const DEFAULT_BOX_MARGIN_M: f32 = 1.0;

/// How to precompute.
#[derive(Clone, Debug, PartialEq)]
pub struct PrecomputeOptions {
    /// Tree depth (`S = 2^levels` directions).
    pub levels: u32,
    /// Self-visibility cuts.
    pub svc: SvcSettings,
    /// Visibility cut fields.
    pub vcf: VcfSampling,
    /// Proxy-field grid spacing (default: the `[irradiance]` spacing).
    pub proxy_spacing_m: Option<f32>,
    /// Compute even when the cache is up to date.
    pub force: bool,
    /// Compute for a scene whose objects have no motion too: they are moved by hand (the live
    /// window's dragging, issue 15 §1).
    pub draggable: bool,
}

impl Default for PrecomputeOptions {
    /// The paper's settings: `S = 2^15`, SVC threshold 0.1, 32 spheres × 32² points.
    fn default() -> Self {
        Self { levels: PAPER_LEVELS, svc: SvcSettings::default(), vcf: VcfSampling::default(), proxy_spacing_m: None, force: false, draggable: false }
    }
}

impl PrecomputeOptions {
    /// What the frame loop computes when a scene with moving objects has no usable
    /// `baked/cuts.bin` (`run::motion_cuts`): `S = 2^10` and 8 spheres × 16² points, which take
    /// seconds where the paper's settings take minutes (docs/measurements.md, "Moving objects");
    /// `heliar precompute` with finer settings beforehand is used instead when present.
    pub fn frame_loop() -> Self {
        Self { levels: 10, vcf: VcfSampling { spheres: 8, rows: 16, cols: 16, ..VcfSampling::default() }, ..Self::default() }
    }

    /// [`Self::frame_loop`] for a scene whose objects are dragged by hand (`heliar live`), moving
    /// or not.
    pub fn draggable() -> Self {
        Self { draggable: true, ..Self::frame_loop() }
    }
}

/// What a precompute did (the JSON summary line).
#[derive(Clone, Debug, Serialize)]
pub struct PrecomputeSummary {
    /// The scene folder.
    pub scene: String,
    /// The cuts file (absent when skipped).
    pub path: Option<String>,
    /// Why nothing was computed, when the pass was skipped.
    pub skipped: Option<String>,
    /// Loaded from the cache.
    pub cached: bool,
    /// Objects with cuts, and how many of them move.
    pub objects: usize,
    /// Moving objects.
    pub moving: usize,
    /// Vertices with a self-visibility cut.
    pub vertices: usize,
    /// Mean SVC size, nodes.
    pub svc_mean_nodes: f64,
    /// Mean VCF cut size, nodes.
    pub vcf_mean_nodes: f64,
    /// Points of the proxy field.
    pub proxy_points: usize,
    /// Bytes of the file.
    pub bytes: u64,
    /// Wall time, s.
    pub seconds: f64,
    /// blake3 of the inputs, hex.
    pub inputs_hash: Option<String>,
}

/// The cuts file of a scene (`baked/cuts.bin`, beside the bake's maps).
pub fn cuts_path(scene: &Scene) -> PathBuf {
    scene.root.join("baked").join(CUTS_FILE)
}

/// The settings of `scene`'s precompute: `opts` and the proxy grid over the `[irradiance]` box
/// (or the objects' bounds with a 1 m margin).
pub fn settings(scene: &Scene, opts: &PrecomputeOptions) -> PrecomputeSettings {
    let (lo, hi, spacing) = match &scene.manifest.irradiance {
        Some(g) => (Vec3::from(g.min.map(|v| v as f32)), Vec3::from(g.max.map(|v| v as f32)), g.spacing_m as f32),
        None => {
            let b = scene.virtual_objects.iter().filter_map(|o| o.mesh.bounds()).reduce(|(a, b), (c, d)| (a.min(c), b.max(d)));
            let (lo, hi) = b.unwrap_or((Vec3::ZERO, Vec3::ZERO));
            (lo - Vec3::splat(DEFAULT_BOX_MARGIN_M), hi + Vec3::splat(DEFAULT_BOX_MARGIN_M), DEFAULT_PROXY_SPACING_M)
        }
    };
    let spacing = opts.proxy_spacing_m.unwrap_or(spacing);
    let counts = ((hi - lo) / spacing).to_array().map(|n| (n.max(0.0).floor() as u32 + 1).max(2));
    let proxy = ProxyGrid { min: lo.to_array(), max: hi.to_array(), counts, threshold: 0.0 };
    PrecomputeSettings { levels: opts.levels, svc: opts.svc, vcf: opts.vcf, proxy: Some(proxy) }
}

/// The objects the cuts are for, named `i:file` (where each stands at its first key).
fn objects(scene: &Scene) -> Vec<(String, &Mesh)> {
    scene
        .virtual_objects
        .iter()
        .enumerate()
        .map(|(i, o)| (format!("{i}:{}", o.path.file_name().map(|f| f.to_string_lossy().into_owned()).unwrap_or_default()), &o.mesh))
        .collect()
}

/// Precomputes (or loads) `scene`'s cuts (module docs); `proxy` is the proxy's BVH.
/// `progress` gets `(done, total)` over vertices and sample points.
pub fn precompute(scene: &Scene, proxy: &RayScene, opts: &PrecomputeOptions, progress: Progress) -> Result<PrecomputeSummary> {
    let t = std::time::Instant::now();
    let moving = scene.virtual_objects.iter().filter(|o| o.moves()).count();
    let mut summary = PrecomputeSummary {
        scene: scene.root.display().to_string(),
        path: None,
        skipped: None,
        cached: false,
        objects: scene.virtual_objects.len(),
        moving,
        vertices: 0,
        svc_mean_nodes: 0.0,
        vcf_mean_nodes: 0.0,
        proxy_points: 0,
        bytes: 0,
        seconds: 0.0,
        inputs_hash: None,
    };
    if moving == 0 && !opts.draggable {
        let m = scene.root.join(MANIFEST_FILE);
        summary.skipped = Some(format!("no virtual object in {} has a motion: the static per-pixel transfer serves every frame (`--draggable` computes them for the live window's dragging)", m.display()));
        return Ok(summary);
    }
    let settings = settings(scene, opts);
    let named = objects(scene);
    let list: Vec<(&str, &Mesh)> = named.iter().map(|(n, m)| (n.as_str(), *m)).collect();
    let hash = file::inputs_hash(&list, Some(&scene.proxy), &settings);
    let path = cuts_path(scene);
    let cached = if opts.force { None } else { file::read_cached(&path, &hash).with_context(|| format!("reading the cached cuts {}", path.display()))? };
    let (cuts, cached) = match cached {
        Some(c) => (c, true),
        None => {
            let c = file::precompute(&list, Some(proxy), &settings, progress).with_context(|| format!("precomputing the cuts of {}", scene.root.display()))?;
            file::write(&path, &c)?;
            (c, false)
        }
    };
    let mean = |sizes: Vec<(usize, usize)>| {
        let (cuts, nodes) = sizes.iter().fold((0, 0), |(a, b), (c, n)| (a + c, b + n));
        if cuts == 0 { 0.0 } else { nodes as f64 / cuts as f64 }
    };
    summary.vertices = cuts.objects.iter().map(|o| o.positions.len()).sum();
    summary.svc_mean_nodes = mean(cuts.objects.iter().map(|o| (o.svc.cuts.len(), o.svc.cuts.node_count())).collect());
    summary.vcf_mean_nodes = mean(cuts.objects.iter().map(|o| (o.vcf.cuts.len(), o.vcf.cuts.node_count())).collect());
    summary.proxy_points = cuts.proxy.as_ref().map_or(0, |p| p.cuts.len());
    summary.bytes = std::fs::metadata(&path).map(|m| m.len()).unwrap_or(0);
    summary.cached = cached;
    summary.path = Some(path.display().to_string());
    summary.inputs_hash = Some(hash.iter().map(|b| format!("{b:02x}")).collect());
    summary.seconds = t.elapsed().as_secs_f64();
    Ok(summary)
}
