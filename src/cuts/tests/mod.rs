//! Tests of the cuts against references: leaf-level operations, closed forms, ray casting.

mod bounce;
mod fields;
mod files;
mod ops;
mod products;
mod reuse;
mod shading;

use super::cut::{Cut, CutNode};
use rand::rngs::SmallRng;
use rand::{Rng, SeedableRng};

/// A seeded generator.
pub(super) fn rng(seed: u64) -> SmallRng {
    SmallRng::seed_from_u64(seed)
}

/// A random cut of a `levels`-deep tree: each node splits with probability `split` (always
/// below the root when `split ≥ 1`), values binary or uniform in `[0, 1]`.
pub(super) fn random_cut(rng: &mut SmallRng, levels: u32, split: f64, binary: bool) -> Cut {
    let mut nodes = Vec::new();
    let mut stack = vec![levels];
    while let Some(h) = stack.pop() {
        if h > 0 && rng.random_bool(split) {
            stack.push(h - 1);
            stack.push(h - 1);
        } else {
            let value = if binary { rng.random_bool(0.5) as u8 as f32 } else { rng.random::<f32>() };
            nodes.push(CutNode { height: h as u8, value });
        }
    }
    Cut::from_nodes(levels, nodes).expect("a top-down split is a cut")
}

/// Random leaves with runs: piecewise-constant stretches of random length and value, binary or
/// in `[0, 1]`.
pub(super) fn random_leaves(rng: &mut SmallRng, levels: u32, binary: bool) -> Vec<f32> {
    let n = 1usize << levels;
    let mut leaves = Vec::with_capacity(n);
    while leaves.len() < n {
        let run = rng.random_range(1..=(n / 4).max(1));
        let value = if binary { rng.random_bool(0.5) as u8 as f32 } else { rng.random::<f32>() };
        leaves.extend(std::iter::repeat_n(value, run.min(n - leaves.len())));
    }
    leaves
}
