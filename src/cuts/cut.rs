//! Clustering per-leaf values on the tree and cutting it (cyberworlds §V, Fig. 3; §V-A.1–2).
//!
//! # How it works
//! [`ClusterTree::from_leaves`] fills the tree bottom-up: each inner node holds the mean of its
//! two children (so the mean of its leaves) and a clustering error, here the largest deviation
//! of any of its leaves from that mean, `max(max − mean, mean − min)` (computed from the
//! children's minima and maxima). [`ClusterTree::cut`] walks down from the root and keeps a node
//! as soon as its error is within the threshold (§V-A.1: "selects the nodes whose error is
//! smaller than the threshold by traversing the binary tree from the root node").
//!
//! - Threshold 0 merges only constant runs: binary visibility then follows the paper's rule for
//!   sharp shadows, "clusters the two child nodes only if the values of two child nodes are the
//!   same" (§V-A.1), and the cut reproduces the leaves exactly.
//! - Threshold ∞ keeps the root alone (the mean).
//! - In between, every leaf's value is within the threshold of its node's value.
//!
//! A [`Cut`] lists its nodes left to right by height and value only: every root-to-leaf path
//! holds exactly one cut node, so the heights alone say where each node sits (§V-A.2, Fig. 5).
//! [`Cut::node_indices`] and [`Cut::from_node_indices`] convert to and from the 2-byte index
//! form of the earlier methods.

use super::CutsError;
use super::tree::{check_levels, node_first_leaf, node_height, node_index};

/// One node of a cut: its height above the leaves and its value.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct CutNode {
    /// Height (0 for a leaf); the node covers `2^height` leaves.
    pub height: u8,
    /// The cluster value (the mean of the node's leaves, or the result of an operation).
    pub value: f32,
}

/// A cut: nodes covering every leaf exactly once, ordered from the leftmost leaf.
#[derive(Clone, Debug, PartialEq)]
pub struct Cut {
    levels: u32,
    nodes: Vec<CutNode>,
}

/// Means and clustering errors of every node of the tree, in heap order.
#[derive(Clone, Debug)]
pub struct ClusterTree {
    levels: u32,
    mean: Vec<f32>,
    error: Vec<f32>,
}

/// Checks a tree depth and that `leaves` has one finite value per leaf.
fn check_leaves(levels: u32, leaves: &[f32]) -> Result<(), CutsError> {
    check_levels(levels)?;
    let count = 1usize << levels;
    if leaves.len() != count {
        return Err(CutsError::LeafCount { what: "leaf array", expected: count, got: leaves.len() });
    }
    if let Some((index, &value)) = leaves.iter().enumerate().find(|(_, v)| !v.is_finite()) {
        return Err(CutsError::NonFinite { what: "leaf", index, value });
    }
    Ok(())
}

/// Clusters `leaves` (height `height`) and appends their cut to `out`, returning the node's
/// `(mean, min, max)`. Bottom-up, it gives the top-down cut of [`ClusterTree::cut`]: a node
/// within the threshold replaces whatever its subtree appended, so the highest such node on
/// each path wins. The means are formed in the same order as in [`ClusterTree`].
fn cut_subtree(leaves: &[f32], height: u32, threshold: f32, out: &mut Vec<CutNode>) -> (f32, f32, f32) {
    if height == 0 {
        out.push(CutNode { height: 0, value: leaves[0] });
        return (leaves[0], leaves[0], leaves[0]);
    }
    let start = out.len();
    let (left, right) = leaves.split_at(leaves.len() / 2);
    let (ml, lo_l, hi_l) = cut_subtree(left, height - 1, threshold, out);
    let (mr, lo_r, hi_r) = cut_subtree(right, height - 1, threshold, out);
    let (mean, lo, hi) = (0.5 * (ml + mr), lo_l.min(lo_r), hi_l.max(hi_r));
    if (hi - mean).max(mean - lo).max(0.0) <= threshold {
        out.truncate(start);
        out.push(CutNode { height: height as u8, value: mean });
    }
    (mean, lo, hi)
}

/// Checks that `threshold` is a number ≥ 0 (∞ allowed).
pub fn check_threshold(field: &'static str, threshold: f32) -> Result<(), CutsError> {
    if threshold >= 0.0 { Ok(()) } else { Err(CutsError::Threshold { field, value: threshold }) }
}

impl ClusterTree {
    /// Clusters `leaves` (one finite value per leaf, in leaf order) bottom-up.
    pub fn from_leaves(levels: u32, leaves: &[f32]) -> Result<Self, CutsError> {
        check_leaves(levels, leaves)?;
        let count = 1usize << levels;
        let nodes = 2 * count - 1;
        let (mut mean, mut lo, mut hi) = (vec![0.0f32; nodes], vec![0.0f32; nodes], vec![0.0f32; nodes]);
        mean[count - 1..].copy_from_slice(leaves);
        lo[count - 1..].copy_from_slice(leaves);
        hi[count - 1..].copy_from_slice(leaves);
        for i in (0..count - 1).rev() {
            let (l, r) = (2 * i + 1, 2 * i + 2);
            mean[i] = 0.5 * (mean[l] + mean[r]);
            lo[i] = lo[l].min(lo[r]);
            hi[i] = hi[l].max(hi[r]);
        }
        let error = (0..nodes).map(|i| (hi[i] - mean[i]).max(mean[i] - lo[i]).max(0.0)).collect();
        Ok(Self { levels, mean, error })
    }

    /// Depth of the tree.
    pub fn levels(&self) -> u32 {
        self.levels
    }

    /// Mean of heap node `index`'s leaves.
    pub fn mean(&self, index: usize) -> f32 {
        self.mean[index]
    }

    /// Clustering error of heap node `index`: the largest deviation of one of its leaves from
    /// its mean.
    pub fn error(&self, index: usize) -> f32 {
        self.error[index]
    }

    /// The cut of the highest nodes whose error is within `threshold` (≥ 0; ∞ gives the root).
    pub fn cut(&self, threshold: f32) -> Result<Cut, CutsError> {
        check_threshold("threshold", threshold)?;
        let mut nodes = Vec::new();
        let mut stack = vec![0usize];
        while let Some(i) = stack.pop() {
            let height = node_height(self.levels, i);
            if height == 0 || self.error[i] <= threshold {
                nodes.push(CutNode { height: height as u8, value: self.mean[i] });
            } else {
                // Right first, so that the left child is taken next: nodes come out left to right.
                stack.push(2 * i + 2);
                stack.push(2 * i + 1);
            }
        }
        Ok(Cut { levels: self.levels, nodes })
    }
}

impl Cut {
    /// Clusters `leaves` and cuts at `threshold`: the cut of [`ClusterTree::cut`], computed in
    /// one bottom-up pass without storing the tree.
    pub fn from_leaves(levels: u32, leaves: &[f32], threshold: f32) -> Result<Self, CutsError> {
        check_leaves(levels, leaves)?;
        check_threshold("threshold", threshold)?;
        let mut nodes = Vec::new();
        cut_subtree(leaves, levels, threshold, &mut nodes);
        Ok(Self { levels, nodes })
    }

    /// The one-node cut of a constant function.
    pub fn constant(levels: u32, value: f32) -> Result<Self, CutsError> {
        check_levels(levels)?;
        Ok(Self { levels, nodes: vec![CutNode { height: levels as u8, value }] })
    }

    /// A cut from its nodes in left-to-right order; checks that they tile the leaves.
    pub fn from_nodes(levels: u32, nodes: Vec<CutNode>) -> Result<Self, CutsError> {
        check_levels(levels)?;
        check_tiling(levels, nodes.iter().map(|n| n.height as u32))?;
        Ok(Self { levels, nodes })
    }

    /// A cut from nodes already known to tile the leaves (the walks' outputs).
    pub(crate) fn from_nodes_unchecked(levels: u32, nodes: Vec<CutNode>) -> Self {
        Self { levels, nodes }
    }

    /// Depth of the tree the cut is over.
    pub fn levels(&self) -> u32 {
        self.levels
    }

    /// The nodes, left to right.
    pub fn nodes(&self) -> &[CutNode] {
        &self.nodes
    }

    /// Number of nodes.
    pub fn len(&self) -> usize {
        self.nodes.len()
    }

    /// Never true: a cut covers every leaf, so it has a node.
    pub fn is_empty(&self) -> bool {
        self.nodes.is_empty()
    }

    /// The piecewise-constant function on the leaves: every leaf gets its node's value.
    pub fn to_leaves(&self) -> Vec<f32> {
        let mut leaves = Vec::with_capacity(1 << self.levels);
        for n in &self.nodes {
            leaves.extend(std::iter::repeat_n(n.value, 1 << n.height));
        }
        leaves
    }

    /// Sum of the values over the leaves, `Σ value · 2^height` (in f64).
    pub fn leaf_sum(&self) -> f64 {
        self.nodes.iter().map(|n| n.value as f64 * (1u64 << n.height) as f64).sum()
    }

    /// Heap index of each node: the index representation of the earlier methods (§V-A.2).
    pub fn node_indices(&self) -> Vec<u32> {
        let mut first = 0u32;
        self.nodes
            .iter()
            .map(|n| {
                let index = node_index(self.levels, n.height as u32, first) as u32;
                first += 1 << n.height;
                index
            })
            .collect()
    }

    /// The cut of heap nodes `indices` (any order) with their `values`; checks that they tile
    /// the leaves.
    pub fn from_node_indices(levels: u32, indices: &[u32], values: &[f32]) -> Result<Self, CutsError> {
        check_levels(levels)?;
        if indices.len() != values.len() {
            return Err(CutsError::Operands(format!("{} node indices but {} values", indices.len(), values.len())));
        }
        let node_count = (2usize << levels) - 1;
        if let Some(&bad) = indices.iter().find(|&&i| i as usize >= node_count) {
            return Err(CutsError::InvalidCut { levels, reason: format!("node index {bad} ≥ {node_count}") });
        }
        let mut order: Vec<usize> = (0..indices.len()).collect();
        order.sort_by_key(|&k| node_first_leaf(levels, indices[k] as usize));
        let nodes: Vec<CutNode> = order.iter().map(|&k| CutNode { height: node_height(levels, indices[k] as usize) as u8, value: values[k] }).collect();
        Self::from_nodes(levels, nodes)
    }

    /// Merges sibling pairs of equal value into their parent, repeatedly: the coarsest cut of the
    /// same piecewise-constant function (the walks' common refinements can be finer than needed).
    pub fn merge_equal_siblings(&mut self) {
        let mut out: Vec<(CutNode, u32)> = Vec::with_capacity(self.nodes.len());
        let mut first = 0u32;
        for &n in &self.nodes {
            push_merging(&mut out, self.levels, n, first);
            first += 1 << n.height;
        }
        self.nodes = out.into_iter().map(|(n, _)| n).collect();
    }
}

/// Appends node `n` (first leaf `first`) to `out`, a left-to-right run of nodes with their first
/// leaves, merging sibling pairs of equal value into their parent as long as there are any
/// ([`Cut::merge_equal_siblings`] one node at a time: the walks merge as they emit).
pub(crate) fn push_merging(out: &mut Vec<(CutNode, u32)>, levels: u32, n: CutNode, first: u32) {
    out.push((n, first));
    while let [.., (a, fa), (b, _)] = out.as_slice() {
        let h = a.height as u32;
        let siblings = a.height == b.height && h < levels && fa % (2 << h) == 0;
        if !(siblings && a.value == b.value) {
            break;
        }
        let merged = (CutNode { height: a.height + 1, value: a.value }, *fa);
        out.truncate(out.len() - 2);
        out.push(merged);
    }
}

/// Checks that nodes of these heights, laid left to right, are aligned tree nodes covering the
/// `2^levels` leaves exactly once.
pub fn check_tiling(levels: u32, heights: impl Iterator<Item = u32>) -> Result<(), CutsError> {
    let total = 1u64 << levels;
    let mut first = 0u64;
    for (k, h) in heights.enumerate() {
        if h > levels {
            return Err(CutsError::InvalidCut { levels, reason: format!("node {k} has height {h}") });
        }
        if first >= total {
            return Err(CutsError::InvalidCut { levels, reason: format!("node {k} lies past the last leaf") });
        }
        if !first.is_multiple_of(1u64 << h) {
            return Err(CutsError::InvalidCut { levels, reason: format!("node {k} of height {h} would start at leaf {first}, not a multiple of 2^{h}") });
        }
        first += 1u64 << h;
    }
    if first != total {
        return Err(CutsError::InvalidCut { levels, reason: format!("the nodes cover {first} of {total} leaves") });
    }
    Ok(())
}
