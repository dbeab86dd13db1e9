//! Operations on several cuts by the pointer/counter walk (cyberworlds §V-A.3, Fig. 6).
//!
//! # How it works
//! Each operand cut `j` has a pointer `p_j` to its current node `n_j` (height `h_j`) and a
//! counter `c_j` of the leaves of `n_j` already consumed. All pointers start at the leftmost
//! node with `c_j = 0` (Step 1). At each step the current nodes all start at the same leaf, so
//! the lowest of them, height `h_min`, lies inside every other: the operation on the current
//! values is stored on a node of height `h_min` (Step 2). Then every pointer whose node has
//! height `h_min` advances and its counter resets (Step 3(a)); every other counter grows by
//! `2^h_min` and its pointer advances once the counter reaches `2^h_j` (Step 3(b)). The walk
//! ends after the last leaf (Step 4). The output is the common refinement of the operands, one
//! node per step, and its cost is the number of output nodes times the number of operands: no
//! operand is ever expanded to its leaves.
//!
//! [`product_for_each`] adds one shortcut the paper leaves out: when a current node has value 0
//! the product is 0 on all its leaves, so the walk emits that node whole and moves every other
//! pointer past it (the vertex's cosine-folded SVC is 0 on the lower hemisphere; the other
//! operands need not be refined there).

use super::CutsError;
use super::cut::{Cut, CutNode, push_merging};
use super::packed::CutView;

/// Walk state over `cuts` (checked to share a tree depth and be non-empty): per operand the
/// pointer `p_j`, the counter `c_j` and the current node's height `h_j`.
struct Walker<'c, 'a> {
    cuts: &'c [CutView<'a>],
    pointer: Vec<usize>,
    counter: Vec<u32>,
    height: Vec<u32>,
}

fn check_operands(cuts: &[CutView]) -> Result<u32, CutsError> {
    let first = cuts.first().ok_or_else(|| CutsError::Operands("an operation on cuts needs at least one cut".into()))?;
    for (index, c) in cuts.iter().enumerate() {
        if c.levels() != first.levels() {
            return Err(CutsError::LevelMismatch { index, expected: first.levels(), got: c.levels() });
        }
    }
    Ok(first.levels())
}

impl<'c, 'a> Walker<'c, 'a> {
    fn new(cuts: &'c [CutView<'a>]) -> Self {
        // Step 1: every pointer at its first node, every counter at zero.
        let height = cuts.iter().map(|c| c.height(0)).collect();
        Self { cuts, pointer: vec![0; cuts.len()], counter: vec![0; cuts.len()], height }
    }

    /// Advances operand `j` by `leaves` leaves that lie either inside its current node or over
    /// whole nodes from its current one (Step 3, generalised to a skip of several nodes).
    #[inline]
    fn advance(&mut self, j: usize, mut leaves: u32) {
        while leaves > 0 {
            let left = (1u32 << self.height[j]) - self.counter[j];
            if leaves >= left {
                leaves -= left;
                self.pointer[j] += 1;
                self.counter[j] = 0;
                if self.pointer[j] < self.cuts[j].len() {
                    self.height[j] = self.cuts[j].height(self.pointer[j]);
                }
            } else {
                self.counter[j] += leaves;
                leaves = 0;
            }
        }
    }
}

/// Visits the common refinement of `cuts` from the left: `visit(height, first_leaf, values)`
/// with the operands' values on that node (Steps 1–4).
pub fn for_each_common_node(cuts: &[CutView], mut visit: impl FnMut(u32, u32, &[f32])) -> Result<(), CutsError> {
    let levels = check_operands(cuts)?;
    let mut walk = Walker::new(cuts);
    // The current nodes' values, read again only when a pointer moves (a packed cut decodes
    // them bit by bit).
    let mut values: Vec<f32> = cuts.iter().map(|c| c.value(0)).collect();
    let (total, mut first) = (1u64 << levels, 0u32);
    while (first as u64) < total {
        // Step 2: the operation on the current nodes, stored at the lowest height.
        let h_min = walk.height.iter().copied().min().unwrap_or(0);
        visit(h_min, first, &values);
        // Step 3 with `2^h_min` leaves: every current node is at least that high and starts on
        // a multiple of it, so each pointer moves at most once (`Walker::advance` in one step).
        for (j, c) in cuts.iter().enumerate() {
            walk.counter[j] += 1 << h_min;
            if walk.counter[j] >= 1 << walk.height[j] {
                walk.pointer[j] += 1;
                walk.counter[j] = 0;
                if walk.pointer[j] < c.len() {
                    walk.height[j] = c.height(walk.pointer[j]);
                    values[j] = c.value(walk.pointer[j]);
                }
            }
        }
        first += 1 << h_min;
    }
    Ok(())
}

/// Visits the nodes of the product of `cuts` (`Π_j v_j`, Eq. 4) from the left, skipping the
/// refinement wherever one operand is 0: `visit(height, first_leaf, product)`.
pub fn product_for_each(cuts: &[CutView], mut visit: impl FnMut(u32, u32, f32)) -> Result<(), CutsError> {
    let levels = check_operands(cuts)?;
    let mut walk = Walker::new(cuts);
    let (total, mut first) = (1u64 << levels, 0u32);
    while (first as u64) < total {
        let (mut h_min, mut h_zero, mut product) = (u32::MAX, None::<u32>, 1.0f32);
        for (j, c) in cuts.iter().enumerate() {
            let (h, v) = (walk.height[j], c.value(walk.pointer[j]));
            h_min = h_min.min(h);
            product *= v;
            // A zero node entered at its first leaf is skipped whole (the highest such node).
            if v == 0.0 && walk.counter[j] == 0 {
                h_zero = Some(h_zero.map_or(h, |z| z.max(h)));
            }
        }
        let (h, value) = match h_zero {
            Some(h) => (h, 0.0),
            None => (h_min, product),
        };
        visit(h, first, value);
        for j in 0..cuts.len() {
            walk.advance(j, 1 << h);
        }
        first += 1 << h;
    }
    Ok(())
}

/// The product `Π_j cuts_j` as a cut (equal siblings merged).
pub fn product(cuts: &[CutView]) -> Result<Cut, CutsError> {
    let mut nodes = Vec::new();
    product_for_each(cuts, |h, _, v| nodes.push(CutNode { height: h as u8, value: v }))?;
    let mut cut = Cut::from_nodes_unchecked(check_operands(cuts)?, nodes);
    cut.merge_equal_siblings();
    Ok(cut)
}

/// The interpolation `Σ_j w_j cuts_j` (§V-A.4) as a cut (equal siblings merged). Operands of
/// weight 0 are left out of the walk; all weights must be finite.
pub fn weighted_sum(cuts: &[CutView], weights: &[f32]) -> Result<Cut, CutsError> {
    if cuts.len() != weights.len() {
        return Err(CutsError::Operands(format!("{} cuts but {} weights", cuts.len(), weights.len())));
    }
    if let Some((index, &value)) = weights.iter().enumerate().find(|(_, w)| !w.is_finite()) {
        return Err(CutsError::NonFinite { what: "interpolation weight", index, value });
    }
    let levels = check_operands(cuts)?;
    let (kept, w): (Vec<CutView>, Vec<f32>) = cuts.iter().zip(weights).filter(|(_, w)| **w != 0.0).map(|(c, w)| (*c, *w)).unzip();
    if kept.is_empty() {
        return Cut::constant(levels, 0.0);
    }
    // Equal siblings merged as the walk emits them (`Cut::merge_equal_siblings`, the same nodes).
    let mut nodes: Vec<(CutNode, u32)> = Vec::with_capacity(kept.iter().map(CutView::len).max().unwrap_or(1));
    for_each_common_node(&kept, |h, first, values| {
        let value = values.iter().zip(&w).map(|(v, w)| v * w).sum();
        push_merging(&mut nodes, levels, CutNode { height: h as u8, value }, first);
    })?;
    Ok(Cut::from_nodes_unchecked(levels, nodes.into_iter().map(|(n, _)| n).collect()))
}
