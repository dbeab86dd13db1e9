//! Visibility cuts: all-frequency environment lighting and shadows of rigid objects that move,
//! after the rendering subsystem of the captured-lighting paper
//! (`../shared/papers/cyberworlds-captured-lighting-cuts.txt` §V, "cyberworlds" below). This is
//! the CPU core of the method; the frame loop and the GPU compositor call it ([`frame`]).
//!
//! # How it works
//! - **Directions and tree** ([`tree`]). `S = 2^levels` directions spread evenly over the sphere
//!   (a spherical Fibonacci set; the paper uses point repulsion, §V-A.1, with `S = 2^15`) are the
//!   leaves of a perfect binary tree built by balanced splits along the widest axis, so that
//!   siblings are neighbours on the sphere. Nodes live in one flat heap-ordered array.
//! - **Cuts** ([`cut`]). A function of direction sampled at the leaves is clustered bottom-up
//!   (each inner node holds the mean of its children and a clustering error, §V, Fig. 3) and
//!   cut top-down where the error is within a threshold. The cut's nodes, ordered left to right,
//!   are stored by their *height* instead of a 2-byte index (§V-A.2, Fig. 5): 4 bits per node
//!   for `S ≤ 2^15` ([`packed`]).
//! - **Operations** ([`walk`]). Products and interpolations of several cuts run the paper's
//!   pointer/counter walk (§V-A.3, Steps 1–4, Fig. 6) over their common refinement, never
//!   expanding to leaves.
//! - **Self-visibility cuts** ([`svc`]): at each vertex, `V_s(x, ω)·max(n·ω, 0)`, the object's
//!   own occlusion with the cosine folded in (§V, text after Eq. 4).
//! - **Visibility cut fields** ([`vcf`]): an object's occlusion `V_i(x_s, ω) ∈ {0, 1}` at sample
//!   points on concentric spheres around it (§V-A.1, Fig. 4), looked up by trilinear
//!   interpolation of the eight neighbouring cuts (§V-A.4). [`proxy_field`] records the static
//!   real proxy's occlusion on a regular grid in the same form.
//! - **Shading** ([`lighting`], [`eval`]): the environment clustered on the same tree gives each
//!   node `l_k` (mean radiance × solid angle); a vertex's outgoing radiance is
//!   `B(x, ω_o) ≈ Σ_k l_k v_k f_r(ω_k, ω_o)` over the nodes of the product cut
//!   `V = V_s · Π_i V_i` (Eqs. 3 and 4).
//! - **Interreflection between objects** ([`bounce`]; *not in the paper*: an extension of
//!   Eq. 3, which carries no interreflection and so takes another object as a black occluder).
//!   The directions another object `b` closes at a vertex (the product without `b`'s field
//!   times `1 − V_b`, one walk) get `b`'s outgoing radiance instead of nothing: per vertex of
//!   `b`, `ρ/π` times its own ambient from the cuts plus the direct sun (its SVC at the sun's
//!   leaf times the proxy's and the other fields' values there), seen along each direction as the
//!   projected-area mean of `b`'s vertices facing back, clustered on the tree as `l_k`; split
//!   per unit `Pa` and `Pd` like the rest.
//! - **Light an object reflects onto itself** ([`self_bounce`]; *not in the paper*, the same
//!   extension for the object's own parts, which the self-visibility cut makes black): rays
//!   from each vertex against the object's own mesh, cast once (the object is rigid), bring per
//!   frame the first pass's outgoing radiance at their hits (a statue's sunlit pedestal top onto
//!   its sphere's underside). Passed in `bounce::Bounce::own`; the frame loop casts the gathers
//!   when it loads the cuts (`crate::run::motion_cuts`). It goes with every virtual object's long
//!   edges split at load (`crate::geometry::subdivide`, so that the cuts, shaded per vertex, have
//!   vertices where a two-triangle pedestal top's light changes; static objects too, so that a
//!   motion's still frames equal the static object's bit for bit). Measured on the two statues of
//!   `tests/suite/object_cuts_two.rs` (docs/measurements.md, "Where the two statues' error was"
//!   and "Self-bounce and split edges on by default"): 6.3% → 3.7% over both statues.
//! - **The proxy's light per vertex** ([`local_sun`]; *not in the paper*, whose map is distant
//!   light): in the frame loop's outdoor path each vertex traces the proxy along 2^8 coarse
//!   directions and takes the light of the point it meets (its sun shadow with the objects', the
//!   bake's `c` and the relighter's `b` there) instead of the map's surface texels, which are the
//!   proxy as the capture centre sees it. The unmoved statue against its traced transfer: 7.35%
//!   → 2.22% (docs/measurements.md, "The proxy's light per vertex"); 1.86% with the sun taken at
//!   each hit of the self-bounce gather ([`self_bounce`]; "The sun at the self-bounce's hits").
//! - **Products kept between frames** ([`products`]): a vertex's or a receiver's product cut
//!   depends on the poses only, so an object that did not move keeps it (while no moved object
//!   reaches the point) and a frame whose lighting changed sums it again, bit for bit as a fresh
//!   walk.
//! - **Files and sweeps**: [`mod@file`] stores a scene's cuts with a hash of their inputs;
//!   [`sweep`] measures error against cost.
//! - **Frames** ([`frame`], [`receivers`]): the objects' ambient per vertex and the receivers'
//!   sky visibility for one frame's poses (translated and turned, [`rotate`]), under the relit map split per unit `Pa` and `Pd`; the frame
//!   loop (`crate::run::motion`) hands them to the compositor.
//! - **CPU or compute pass** ([`flat`]; issue 15 §2, "evaluation where it is fastest here … measure
//!   both and say which"). The per-vertex first pass ([`frame::FrameCuts::object_ambient`]) also
//!   runs in a compute pass (`crate::run::cuts_gpu`, `crate::gpu::cuts`,
//!   `shaders/cuts/eval.wgsl`): the same pointer/counter walk over the self-visibility cut and the
//!   eight neighbouring cuts of each other field and of the proxy field, one thread per vertex,
//!   lighting part and `2^8`-leaf segment of the tree; equal to the CPU within 3·10⁻⁶ relative
//!   (`tests/suite/object_cuts_gpu.rs`). **The CPU is faster here, and stays the frame loop's
//!   path**: on the courtyard's statue and robot (5 742 vertices, `benches/bench_cuts.rs`, debug
//!   build) a frame takes 0.15–0.61 s with rayon on the 2 cores against 1.3–2.6 s in the pass at
//!   `S = 2^10`, 0.47 s against 9.8–10.6 s at `S = 2^13`, on lavapipe and on GL/llvmpipe alike
//!   (docs/measurements.md, "Per-frame cuts: CPU or compute pass"). The software adapters run the
//!   shader on the same two cores, eight lanes a vector, and the walk is what vectors do worst:
//!   every lane's pointers, counters and loads differ (divergence, gathers, per-lane arrays in
//!   scratch memory), and llvmpipe's limit of 65 535 loop iterations per invocation forces the
//!   segments, which repeat each operand's set-up per segment and walk the two surface parts
//!   apart. On a real GPU thousands of lanes would hide the gathers, and the uploads per frame
//!   (the lighting, 3 × 2S − 1 `vec4`, and the operands, ~100 k × 16 bytes) are small, so the
//!   pass may win there; without one to measure on, it stays a benchmarked alternative. The paper
//!   too evaluates on the CPU, in parallel over vertices (§V-B, last paragraph).
//!
//! # Frames
//! Every cut is over the directions of its object's *cut frame* (its pose when the cuts were
//! computed); the paper moves objects by translation only (§VI, Fig. 7(c)), where every frame is
//! the world's. A turned object ([`rotate`]) has its product run in its own frame: the lighting
//! clustered again with the texels turned into that frame, its self-visibility cut as stored, the
//! other objects' fields and the proxy field remapped into it by the three nearest leaves; the
//! receivers' weights are pushed into a turned object's frame instead of remapping its field.
//! Measured on the courtyard's statue moved 0.9 m and turned (`tests/suite/object_cuts_turned.rs`):
//! relative RMSE 4.9% over the statue and 6.3% over the contact region at 90° against the statue
//! placed and turned there and traced (translation alone: 4.9% and 6.2%).

pub mod bounce;
pub mod cut;
pub mod eval;
pub mod file;
pub mod flat;
pub mod frame;
pub mod lighting;
pub mod local_sun;
pub mod packed;
pub mod products;
pub mod proxy_field;
pub mod receiver_light;
pub mod receivers;
pub mod reuse;
pub mod rotate;
pub mod self_bounce;
pub mod shapes;
pub mod svc;
pub mod sweep;
pub mod tree;
pub mod vcf;
pub mod walk;

#[cfg(test)]
mod tests;

pub use cut::{ClusterTree, Cut, CutNode};
pub use packed::{CutView, PackedCuts, ValueEncoding};
pub use tree::DirectionTree;

use std::path::PathBuf;

/// The paper's number of directions, `2^15` (§V-A.1).
pub const PAPER_LEVELS: u32 = 15;

/// Progress reports from worker threads: `(done, total)`.
pub type Progress<'a> = &'a (dyn Fn(u64, u64) + Sync);

/// A progress report that goes nowhere.
pub fn no_progress(_done: u64, _total: u64) {}

/// What went wrong in the cuts module.
#[derive(Debug, thiserror::Error)]
pub enum CutsError {
    /// The tree depth is outside `1..=15` (4-bit heights).
    #[error("cuts: tree levels {levels} is outside 1..={max} (S = 2^levels directions, heights in 4 bits)")]
    Levels {
        /// The requested depth.
        levels: u32,
        /// The largest supported depth.
        max: u32,
    },
    /// A clustering threshold is negative or NaN.
    #[error("cuts: {field} = {value} must be a number ≥ 0 (∞ keeps the root only)")]
    Threshold {
        /// The setting.
        field: &'static str,
        /// Its value.
        value: f32,
    },
    /// A per-leaf array has the wrong length.
    #[error("cuts: {what} has {got} leaf values, the tree has {expected}")]
    LeafCount {
        /// What was given.
        what: &'static str,
        /// Leaves in the tree.
        expected: usize,
        /// Values given.
        got: usize,
    },
    /// A value is NaN or infinite.
    #[error("cuts: {what} {index} is not finite ({value})")]
    NonFinite {
        /// What the value is.
        what: &'static str,
        /// Its index.
        index: usize,
        /// The value.
        value: f32,
    },
    /// A list of nodes is not a cut of the tree.
    #[error("cuts: not a cut of a {levels}-level tree: {reason}")]
    InvalidCut {
        /// Depth of the tree.
        levels: u32,
        /// What is wrong.
        reason: String,
    },
    /// Cuts of different trees were combined.
    #[error("cuts: operand {index} has {got} levels, the first has {expected}")]
    LevelMismatch {
        /// Operand index.
        index: usize,
        /// Depth of the first operand.
        expected: u32,
        /// Depth of this one.
        got: u32,
    },
    /// An operation was given no cuts, or weights of the wrong count.
    #[error("cuts: {0}")]
    Operands(String),
    /// A value cannot be stored in the chosen encoding.
    #[error("cuts: value {value} of node {node} cannot be stored as {encoding:?} (needs {needs})")]
    Encoding {
        /// The encoding.
        encoding: ValueEncoding,
        /// Node index within the cut.
        node: usize,
        /// The value.
        value: f32,
        /// The allowed values.
        needs: &'static str,
    },
    /// A mesh cannot be used.
    #[error("cuts: mesh '{what}': {reason}")]
    Mesh {
        /// Which mesh.
        what: String,
        /// What is wrong.
        reason: String,
    },
    /// A sampling setting is out of range.
    #[error("cuts: {field} = {value}: {reason}")]
    Sampling {
        /// The setting.
        field: &'static str,
        /// Its value, printed.
        value: String,
        /// The allowed range.
        reason: &'static str,
    },
    /// A lookup point is NaN or infinite.
    #[error("cuts: lookup point {0:?} is not finite")]
    NonFinitePoint([f32; 3]),
    /// The environment map cannot be clustered.
    #[error("cuts: environment map: {0}")]
    EnvMap(String),
    /// A precompute file could not be read or written.
    #[error("{path}: {source}")]
    File {
        /// The file.
        path: PathBuf,
        /// The OS error.
        source: std::io::Error,
    },
    /// A precompute file is corrupt, truncated or of another format.
    #[error("{path}: corrupt cuts file: {reason}")]
    Corrupt {
        /// The file.
        path: PathBuf,
        /// What is wrong, naming the field.
        reason: String,
    },
}
