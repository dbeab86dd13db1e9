//! The per-vertex product of [`FrameCuts`] laid out in plain arrays for a compute pass
//! (issue 15 §2, "evaluation where it is fastest here": `crate::gpu::cuts` runs
//! `shaders/cuts/eval.wgsl` over these arrays; cyberworlds §V-A.3–4 and §V-B,
//! `../shared/papers/cyberworlds-captured-lighting-cuts.txt`).
//!
//! # Layout
//! - **Banks, uploaded once** ([`FlatBanks`]): every packed bank of the scene (each object's
//!   self-visibility cuts, each object's field, the proxy field) in one `u32` array. Its head is
//!   one record of four words per bank, `[encoding, heights, values, offsets]`: the value
//!   encoding (1, 8 or 16 bits, [`super::ValueEncoding`]) and the word offsets of the bank's
//!   4-bit heights, its values and its cut offsets. Heights and values are the bank's own bytes
//!   ([`PackedCuts`], little-endian, low nibble and low bit first) packed four to a word, so node
//!   `g`'s height is bits `4(g mod 8)..` of word `g / 8`, and its value bit `g mod 32` of word
//!   `g / 32` (1 bit), byte `g mod 4` of word `g / 4` (8 bits) or half `g mod 2` of word `g / 2`
//!   (16 bits). The cut offsets are the bank's first node per cut and the node count.
//!   Then, per cut and per segment (below), the node holding the segment's first leaf and the
//!   leaves of that node before it; the head's fifth word is where these start.
//! - **Directions, uploaded once** ([`node_dirs`]): each heap node's representative direction.
//! - **Lighting, per frame** ([`flat_lighting`]): `l_k` of the sky per unit `Pa`, the surface per
//!   unit `Pa`, the surface per unit `Pd`, one after the other in heap order (zero when absent).
//! - **Operands, per frame** ([`FrameOps::new`]): per vertex a [`VertexRecord`] (its normal and
//!   reflected view direction in the object's frame, where its operands start, how many walk
//!   without and with the proxy field) and its [`OpRecord`]s: the self-visibility cut (group 0,
//!   weight 1), then for each other object that reaches the vertex (culled as
//!   [`FrameCuts`]'s occluders are) the eight neighbouring cuts of its field with their trilinear
//!   weights (one group), then the proxy field's (the last group). The neighbours and weights are
//!   found here, on the CPU (`locate`, the same call the CPU path makes), so the compute pass
//!   walks exactly the cuts and weights the CPU interpolates.
//!
//! # What the pass computes, and how it differs from the CPU walk
//! The shader walks the self-visibility cut and *all the neighbouring cuts* at once (the
//! pointer/counter walk of §V-A.3 over up to 41 operands), forming at each node the product of
//! the groups' weighted sums: `v = Π_g Σ_i w_i v_i`. The CPU instead interpolates each field into
//! one cut first (equal siblings merged, [`super::walk::weighted_sum`]) and then walks the
//! product. Both give the same values on every leaf. `E_n = Σ_k l_k v_k` does not depend on how
//! finely the product is cut (each `l_k` is the sum of its children's), so it agrees to float
//! rounding; `E_r` evaluates the lobe at node directions, so it agrees wherever the two
//! refinements agree: everywhere except where an interpolated field happens to be equal on two
//! siblings whose neighbouring cuts differ (weights that balance exactly).
//! Turned objects (`super::rotate`) are not laid out: [`FrameOps::new`] refuses them.
//!
//! # Segments
//! One thread walks one lighting part of one vertex over one subtree of `2^SEGMENT_HEIGHT` leaves
//! (its pointers start where the segment starts, from the table above), and a second dispatch
//! adds the segments in order. A product node higher than a segment is summed by the segment
//! where it starts, so the nodes and their directions are those of the whole walk. The reason is
//! Mesa's llvmpipe (lavapipe and GL alike): its loop limiter (`LP_MAX_TGSI_LOOP_ITERATIONS`,
//! 65 535) silently ends the loops of an invocation, by what was seen here counting all of its
//! loops' iterations together. A whole walk at `S = 2^13` ran past that (sums too small by up to 95%, docs/measurements.md); a
//! segment runs at most `2^8` steps of at most `2·41 + 1` iterations.

use super::frame::{FrameCuts, ObjectAmbient, VertexAmbient};
use super::frame::UnitLighting;
use super::packed::PackedCuts;
use super::rotate::Pose;
use super::tree::DirectionTree;
use super::vcf::FieldRegion;
use super::CutsError;
use glam::Vec3;
use rayon::prelude::*;

/// Largest number of operand groups per vertex (the self-visibility cut, other objects, the
/// proxy field): matches `MAX_GROUPS` in `shaders/cuts/eval.wgsl`.
pub const MAX_GROUPS: usize = 6;
/// Largest number of operand cuts per vertex: matches `MAX_OPS` in the shader.
pub const MAX_OPS: usize = 1 + 8 * (MAX_GROUPS - 1);

/// One vertex's walk (mirrors `Vertex` in `shaders/cuts/eval.wgsl`).
#[repr(C)]
#[derive(Clone, Copy, Debug, Default, PartialEq, bytemuck::Pod, bytemuck::Zeroable)]
pub struct VertexRecord {
    /// First operand, operands without the proxy field, operands with it, unused.
    pub ops: [u32; 4],
    /// Unit normal, object frame (`w` unused).
    pub normal: [f32; 4],
    /// Reflected view direction, object frame (`w` unused).
    pub reflected: [f32; 4],
}

/// One operand cut (mirrors `Op` in the shader).
#[repr(C)]
#[derive(Clone, Copy, Debug, Default, PartialEq, bytemuck::Pod, bytemuck::Zeroable)]
pub struct OpRecord {
    /// Bank (index into [`FlatBanks`]' head).
    pub bank: u32,
    /// Cut within the bank.
    pub cut: u32,
    /// Group (0: the self-visibility cut; the product multiplies the groups' weighted sums).
    pub group: u32,
    /// Weight within the group.
    pub weight: f32,
}

/// Height of the subtrees one thread walks (module docs, "Segments"): `2^8` leaves.
pub const SEGMENT_HEIGHT: u32 = 8;

/// Words per bank in the head of [`FlatBanks::words`].
const HEAD_WORDS: usize = 8;

/// Segments of a tree of `levels` (`2^(levels − SEGMENT_HEIGHT)`, at least 1).
pub fn segments(levels: u32) -> u32 {
    1 << levels.saturating_sub(SEGMENT_HEIGHT)
}

/// Every bank of a scene's cuts in one `u32` array (module docs).
#[derive(Clone, Debug, PartialEq)]
pub struct FlatBanks {
    /// Head, heights, values, offsets and segment starts.
    pub words: Vec<u32>,
    /// Segments per cut.
    pub segments: u32,
    /// Per object, its self-visibility bank and its field's bank.
    pub objects: Vec<(u32, u32)>,
    /// The proxy field's bank.
    pub proxy: Option<u32>,
}

/// Bytes packed into little-endian words (zero-padded).
fn words_of(bytes: &[u8]) -> impl Iterator<Item = u32> + '_ {
    bytes.chunks(4).map(|c| {
        let mut w = [0u8; 4];
        w[..c.len()].copy_from_slice(c);
        u32::from_le_bytes(w)
    })
}

impl FlatBanks {
    /// Lays out the banks of `frame`'s cuts.
    pub fn new(frame: &FrameCuts) -> Result<Self, CutsError> {
        let mut banks: Vec<&PackedCuts> = Vec::new();
        let mut objects = Vec::new();
        for obj in &frame.cuts.objects {
            objects.push((banks.len() as u32, banks.len() as u32 + 1));
            banks.extend([&obj.svc.cuts, &obj.vcf.cuts]);
        }
        let proxy = frame.cuts.proxy.as_ref().map(|p| {
            banks.push(&p.cuts);
            banks.len() as u32 - 1
        });
        let segments = segments(frame.tree.levels());
        let mut words = vec![0u32; HEAD_WORDS * banks.len()];
        for (b, bank) in banks.iter().enumerate() {
            let (heights, values) = bank.raw();
            let too_big = |_| CutsError::Operands(format!("bank {b}: more than 2^32 words"));
            let at = HEAD_WORDS * b;
            words[at] = bank.encoding().bits() as u32;
            words[at + 1] = u32::try_from(words.len()).map_err(too_big)?;
            words.extend(words_of(heights));
            words[at + 2] = u32::try_from(words.len()).map_err(too_big)?;
            words.extend(words_of(values));
            words[at + 3] = u32::try_from(words.len()).map_err(too_big)?;
            for &o in bank.offsets() {
                words.push(u32::try_from(o).map_err(too_big)?);
            }
            words[at + 4] = u32::try_from(words.len()).map_err(too_big)?;
            segment_starts(bank, frame.tree.levels(), segments, &mut words);
            u32::try_from(words.len()).map_err(too_big)?;
        }
        Ok(Self { words, segments, objects, proxy })
    }
}

/// Appends, per cut of `bank` and per segment, the node (index in the bank) holding the
/// segment's first leaf and how many of its leaves lie before it (the walk's pointer and counter
/// there, Step 1 started mid-tree).
fn segment_starts(bank: &PackedCuts, levels: u32, segments: u32, out: &mut Vec<u32>) {
    let span = (1u64 << levels) / segments as u64;
    for k in 0..bank.len() {
        let view = bank.view(k);
        let start = bank.offsets()[k];
        let (mut node, mut first) = (0usize, 0u64);
        for s in 0..segments as u64 {
            let leaf = s * span;
            while first + (1u64 << view.height(node)) <= leaf {
                first += 1u64 << view.height(node);
                node += 1;
            }
            out.extend([(start + node) as u32, (leaf - first) as u32]);
        }
    }
}

/// Each heap node's representative direction (`xyz`, `w = 0`).
pub fn node_dirs(tree: &DirectionTree) -> Vec<[f32; 4]> {
    (0..tree.node_count()).map(|k| tree.node_dir(k).extend(0.0).to_array()).collect()
}

/// The three clustered parts of `lighting`, one after the other in heap order (zero when a part
/// is absent), and which are present (bit 0 sky, 1 surface per `Pa`, 2 surface per `Pd`).
pub fn flat_lighting(tree: &DirectionTree, lighting: &UnitLighting) -> (Vec<[f32; 4]>, u32) {
    let n = tree.node_count();
    let mut out = Vec::with_capacity(3 * n);
    let mut mask = 0;
    for (bit, part) in [Some(&lighting.sky_pa), lighting.surface_pa.as_ref(), lighting.surface_pd.as_ref()].into_iter().enumerate() {
        match part {
            Some(l) => {
                mask |= 1 << bit;
                out.extend((0..n).map(|k| l.node(k).extend(0.0).to_array()));
            }
            None => out.extend(std::iter::repeat_n([0.0; 4], n)),
        }
    }
    (out, mask)
}

/// One frame's operands (module docs).
#[derive(Clone, Debug, Default, PartialEq)]
pub struct FrameOps {
    /// Per vertex of every object, in the scene's order.
    pub vertices: Vec<VertexRecord>,
    /// The operands the vertices point into.
    pub ops: Vec<OpRecord>,
    /// Vertices per object.
    pub counts: Vec<usize>,
    /// Vertices whose proxy lookup was clamped to the box.
    pub outside_proxy_box: usize,
}

impl FrameOps {
    /// The operands of every vertex for the objects at `poses` (translations only), seen from
    /// `eye`: the same cuts, culling and weights as [`FrameCuts::object_ambient_posed`].
    pub fn new(frame: &FrameCuts, banks: &FlatBanks, poses: &[Pose], eye: Vec3) -> Result<Self, CutsError> {
        frame.check_poses(poses)?;
        if poses.iter().any(|p| p.rotation.is_some()) {
            return Err(CutsError::Operands("the compute pass lays out translated objects only (a turned object's product runs in its own frame)".into()));
        }
        let mut out = Self::default();
        for (k, obj) in frame.cuts.objects.iter().enumerate() {
            let count = obj.positions.len().min(obj.svc.cuts.len());
            let rows: Vec<(Vec<OpRecord>, usize, Vec3, Vec3, bool)> = (0..count).into_par_iter().map(|v| vertex_ops(frame, banks, poses, k, v, eye)).collect::<Result<_, _>>()?;
            for (ops, surface, n, r, outside) in rows {
                let start = out.ops.len() as u32;
                out.vertices.push(VertexRecord { ops: [start, surface as u32, ops.len() as u32, 0], normal: n.extend(0.0).to_array(), reflected: r.extend(0.0).to_array() });
                out.ops.extend(ops);
                out.outside_proxy_box += outside as usize;
            }
            out.counts.push(count);
        }
        Ok(out)
    }

    /// The pass's output split per object: per vertex six `vec4`, `E_n` and `E_r` of the sky
    /// per unit `Pa`, of the surface per unit `Pa` and of the surface per unit `Pd`, added into a
    /// [`VertexAmbient`] as `FrameCuts::vertex_ambient` adds them.
    pub fn ambient(&self, rows: &[[f32; 4]]) -> Result<ObjectAmbient, CutsError> {
        if rows.len() != 6 * self.vertices.len() {
            return Err(CutsError::Operands(format!("{} output rows for {} vertices", rows.len(), self.vertices.len())));
        }
        let mut vertices = Vec::with_capacity(self.counts.len());
        let mut at = 0;
        for &n in &self.counts {
            vertices.push(rows[6 * at..6 * (at + n)].chunks_exact(6).map(vertex_ambient).collect());
            at += n;
        }
        Ok(ObjectAmbient { vertices, outside_proxy_box: self.outside_proxy_box })
    }
}

/// One vertex's six rows added up (`FrameCuts::vertex_ambient`'s `amb`).
fn vertex_ambient(c: &[[f32; 4]]) -> VertexAmbient {
    let add = |a: [f32; 4], b: [f32; 4]| [a[0] + b[0], a[1] + b[1], a[2] + b[2]];
    let [n, r] = [add(c[0], c[2]), add(c[1], c[3])];
    [[n[0], n[1], n[2], 1.0], [r[0], r[1], r[2], 0.0], [c[4][0], c[4][1], c[4][2], 0.0], [c[5][0], c[5][1], c[5][2], 0.0]]
}

/// Vertex `v` of object `k`: its operands, how many walk without the proxy field, its normal
/// and reflected view direction (object frame; translations only, so the world's), and whether
/// its proxy lookup was clamped.
fn vertex_ops(frame: &FrameCuts, banks: &FlatBanks, poses: &[Pose], k: usize, v: usize, eye: Vec3) -> Result<(Vec<OpRecord>, usize, Vec3, Vec3, bool), CutsError> {
    let (x, n_local, n, r) = frame.vertex_geometry(poses, k, v, eye)?;
    let mut ops = vec![OpRecord { bank: banks.objects[k].0, cut: v as u32, group: 0, weight: 1.0 }];
    let mut group = 1;
    for (b, obj) in frame.cuts.objects.iter().enumerate() {
        // The culling and reach of `FrameCuts::occluders`, in the same order.
        let centre = poses[b].point(obj.vcf.centre);
        let local = poses[b].local_point(x);
        if b == k || (n != Vec3::ZERO && n.dot(centre - x) < -obj.vcf.radius_m) || obj.vcf.beyond_reach(local) {
            continue;
        }
        let found = obj.vcf.locate(local)?;
        ops.extend(found.neighbours.iter().filter(|(_, w)| *w != 0.0).map(|&(c, w)| OpRecord { bank: banks.objects[b].1, cut: c as u32, group, weight: w }));
        group += 1;
    }
    let surface = ops.len();
    let mut outside = false;
    if let (Some(field), Some(bank)) = (&frame.cuts.proxy, banks.proxy) {
        let found = field.locate(x)?;
        outside = found.region == FieldRegion::OutsideBox;
        ops.extend(found.neighbours.iter().filter(|(_, w)| *w != 0.0).map(|&(c, w)| OpRecord { bank, cut: c as u32, group, weight: w }));
        group += 1;
    }
    if group as usize > MAX_GROUPS || ops.len() > MAX_OPS {
        return Err(CutsError::Operands(format!("vertex {v} of object {k}: {group} operand groups, the compute pass takes {MAX_GROUPS}")));
    }
    // The walk runs in the object's frame (`FrameCuts::vertex_ambient`): its normal as stored.
    Ok((ops, surface, n_local, poses[k].local_dir(r), outside))
}
