//! The objects' per-vertex ambient from the visibility cuts in a compute pass: the GPU
//! alternative to [`FrameCuts::object_ambient`] (issue 15 §2, "evaluation where it is fastest
//! here … measure both and say which"; `crate::cuts::flat` lays the cuts out,
//! `crate::gpu::cuts` runs `shaders/cuts/eval.wgsl`).
//!
//! It computes the first pass (Eq. 3 as the paper has it: self-visibility × the other objects'
//! fields × the proxy field, times the clustered lighting) for translated objects; the bounce
//! passes and turned objects stay on the CPU. Measured against the CPU path in
//! `benches/bench_cuts.rs` (docs/measurements.md, "Per-frame cuts (issue 15 §2)"): on this
//! machine's software adapters the CPU (rayon) is faster, so the frame loop keeps the CPU and
//! this stays a benchmarked alternative.

use crate::cuts::flat::{FlatBanks, FrameOps, flat_lighting, node_dirs};
use crate::cuts::frame::{FrameCuts, ObjectAmbient, UnitLighting};
use crate::cuts::rotate::Pose;
use crate::cuts::CutsError;
use crate::gpu::cuts::CutsPass;
use crate::gpu::{Gpu, GpuError};
use glam::Vec3;

/// What can go wrong.
#[derive(Debug, thiserror::Error)]
pub enum CutsGpuError {
    /// The cuts could not be laid out.
    #[error(transparent)]
    Cuts(#[from] CutsError),
    /// The device failed.
    #[error(transparent)]
    Gpu(#[from] GpuError),
}

/// A scene's cuts on the GPU.
pub struct GpuFrameCuts {
    banks: FlatBanks,
    pass: CutsPass,
}

impl GpuFrameCuts {
    /// Uploads the banks and the tree's node directions of `frame` (once).
    pub fn new(gpu: &Gpu, frame: &FrameCuts) -> Result<Self, CutsGpuError> {
        let banks = FlatBanks::new(frame)?;
        let pass = CutsPass::new(gpu, frame.tree.levels(), banks.segments, &banks.words, &node_dirs(&frame.tree))?;
        Ok(Self { banks, pass })
    }

    /// [`FrameCuts::object_ambient`] in the compute pass: the objects at `translations`, seen
    /// from `eye`, under `lighting`. Per frame: the operands (found on the CPU), the lighting up,
    /// the rows back.
    pub fn object_ambient(&mut self, gpu: &Gpu, frame: &FrameCuts, lighting: &UnitLighting, translations: &[Vec3], eye: Vec3) -> Result<ObjectAmbient, CutsGpuError> {
        let poses: Vec<Pose> = translations.iter().map(|&t| Pose::translated(t)).collect();
        let ops = FrameOps::new(frame, &self.banks, &poses, eye)?;
        let (lights, mask) = flat_lighting(&frame.tree, lighting);
        let rows = self.pass.run(gpu, &lights, mask, bytemuck::cast_slice(&ops.vertices), ops.vertices.len() as u32, bytemuck::cast_slice(&ops.ops))?;
        Ok(ops.ambient(&rows)?)
    }
}
