//! The sample directions and the binary tree over them (cyberworlds §V, Fig. 3; §V-A.1).
//!
//! # How it works
//! `S = 2^levels` directions come from the spherical Fibonacci set
//! ([`crate::geometry::sampling::sphere_fibonacci`]: equal solid angle `4π/S` each, where the
//! paper spreads points by repulsion). They are put in *leaf order* by recursive balanced splits:
//! a set of `2^k` directions is sorted along the widest axis of its bounding box and cut at the
//! median, each half split again, down to single directions. The halves of every split are the
//! two children of a node, so the tree is perfect and siblings cover neighbouring patches of the
//! sphere.
//!
//! Nodes are stored in heap order: the root is 0, the children of `i` are `2i + 1` and `2i + 2`.
//! A node at depth `d` has height `h = levels − d` and covers the `2^h` leaves from
//! `first_leaf = (i + 1 − 2^d)·2^h`; [`node_index`], [`node_height`] and [`node_first_leaf`]
//! convert between the two descriptions with shifts. The height-based cut representation
//! (§V-A.2) rests on this: in a perfect tree, a node is known from its height and where it
//! starts.

use super::CutsError;
use crate::geometry::sampling::sphere_fibonacci;
use glam::Vec3;

/// The deepest tree whose node heights fit 4 bits (the paper's `S = 2^15`, §V-A.2).
pub const MAX_LEVELS: u32 = 15;

/// Heap index of the node of height `height` whose leaves start at `first_leaf` (a multiple of
/// `2^height`).
#[inline]
pub fn node_index(levels: u32, height: u32, first_leaf: u32) -> usize {
    let depth = levels - height;
    ((1usize << depth) - 1) + (first_leaf >> height) as usize
}

/// Height of heap node `index` (0 for a leaf, `levels` for the root).
#[inline]
pub fn node_height(levels: u32, index: usize) -> u32 {
    let depth = usize::BITS - 1 - (index + 1).leading_zeros();
    levels - depth
}

/// First leaf covered by heap node `index`.
#[inline]
pub fn node_first_leaf(levels: u32, index: usize) -> u32 {
    let depth = usize::BITS - 1 - (index + 1).leading_zeros();
    let position = (index + 1 - (1usize << depth)) as u32;
    position << (levels - depth)
}

/// Checks a tree depth.
pub fn check_levels(levels: u32) -> Result<(), CutsError> {
    if (1..=MAX_LEVELS).contains(&levels) { Ok(()) } else { Err(CutsError::Levels { levels, max: MAX_LEVELS }) }
}

/// `S = 2^levels` directions and the perfect binary tree over them.
#[derive(Clone, Debug)]
pub struct DirectionTree {
    levels: u32,
    /// Unit directions in leaf order.
    leaf_dirs: Vec<Vec3>,
    /// Per heap node: the normalised mean of its leaves' directions (the cluster's
    /// representative direction `ω_k` of Eq. 3).
    node_dirs: Vec<Vec3>,
}

impl DirectionTree {
    /// The tree over `2^levels` Fibonacci directions.
    pub fn new(levels: u32) -> Result<Self, CutsError> {
        check_levels(levels)?;
        let count = 1usize << levels;
        let mut points: Vec<(Vec3, u32)> = sphere_fibonacci(count).into_iter().zip(0..).collect();
        split_balanced(&mut points);
        let leaf_dirs: Vec<Vec3> = points.into_iter().map(|(d, _)| d).collect();
        let mut sums = vec![Vec3::ZERO; 2 * count - 1];
        sums[count - 1..].copy_from_slice(&leaf_dirs);
        for i in (0..count - 1).rev() {
            sums[i] = sums[2 * i + 1] + sums[2 * i + 2];
        }
        // A node whose leaves sum to zero (only the root of a symmetric set) gets +Y.
        let node_dirs = sums.into_iter().map(|s| s.try_normalize().unwrap_or(Vec3::Y)).collect();
        Ok(Self { levels, leaf_dirs, node_dirs })
    }

    /// Depth of the tree (the root's height).
    pub fn levels(&self) -> u32 {
        self.levels
    }

    /// Number of leaves `S`.
    pub fn leaf_count(&self) -> usize {
        self.leaf_dirs.len()
    }

    /// Number of nodes, `2S − 1`.
    pub fn node_count(&self) -> usize {
        self.node_dirs.len()
    }

    /// Leaf directions, in leaf order.
    pub fn leaf_dirs(&self) -> &[Vec3] {
        &self.leaf_dirs
    }

    /// Representative direction of heap node `index`.
    #[inline]
    pub fn node_dir(&self, index: usize) -> Vec3 {
        self.node_dirs[index]
    }

    /// Solid angle of one leaf, `4π/S` sr.
    pub fn leaf_solid_angle_sr(&self) -> f32 {
        4.0 * std::f32::consts::PI / self.leaf_count() as f32
    }
}

/// Orders `points` (a power-of-two count) so that every aligned half, quarter, … is a compact
/// patch: sort along the widest bounding-box axis, split at the median, recurse. Ties are broken
/// by the original index, so the order is deterministic.
fn split_balanced(points: &mut [(Vec3, u32)]) {
    if points.len() <= 1 {
        return;
    }
    let (lo, hi) = points.iter().fold((Vec3::splat(f32::MAX), Vec3::splat(f32::MIN)), |(lo, hi), (p, _)| (lo.min(*p), hi.max(*p)));
    let extent = hi - lo;
    let axis = if extent.x >= extent.y && extent.x >= extent.z {
        0
    } else if extent.y >= extent.z {
        1
    } else {
        2
    };
    points.sort_unstable_by(|a, b| a.0[axis].total_cmp(&b.0[axis]).then(a.1.cmp(&b.1)));
    let (left, right) = points.split_at_mut(points.len() / 2);
    split_balanced(left);
    split_balanced(right);
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn index_arithmetic_round_trips() {
        let levels = 6;
        for index in 0..(1usize << (levels + 1)) - 1 {
            let (h, first) = (node_height(levels, index), node_first_leaf(levels, index));
            assert_eq!(first % (1 << h), 0);
            assert_eq!(node_index(levels, h, first), index);
            if h > 0 {
                // Children start at the parent's first leaf and at its middle.
                assert_eq!(node_first_leaf(levels, 2 * index + 1), first);
                assert_eq!(node_first_leaf(levels, 2 * index + 2), first + (1 << (h - 1)));
                assert_eq!(node_height(levels, 2 * index + 1), h - 1);
            }
        }
        assert_eq!(node_height(levels, 0), levels);
        assert_eq!(node_index(levels, 0, 63), 126);
    }

    #[test]
    fn levels_are_checked() {
        assert!(DirectionTree::new(0).is_err());
        assert!(DirectionTree::new(16).is_err());
        assert!(DirectionTree::new(1).is_ok());
    }

    #[test]
    fn siblings_are_neighbours() {
        // Every leaf is a permutation of the Fibonacci set, and the leaves of a node lie within a
        // cone that shrinks with the height: for equal-area patches the cone's half-angle is
        // about 2·asin(√(2^h/S)) (a spherical cap of 2^h leaf areas); allow 2× that for the
        // patches' elongation.
        let tree = DirectionTree::new(10).expect("valid levels");
        let mut sorted: Vec<[u32; 3]> = tree.leaf_dirs().iter().map(|d| d.to_array().map(f32::to_bits)).collect();
        sorted.sort_unstable();
        sorted.dedup();
        assert_eq!(sorted.len(), 1024);
        for index in 0..tree.node_count() {
            let h = node_height(10, index);
            if h > 6 {
                continue;
            }
            let first = node_first_leaf(10, index) as usize;
            let centre = tree.node_dir(index);
            let widest = tree.leaf_dirs()[first..first + (1 << h)].iter().map(|d| d.dot(centre).clamp(-1.0, 1.0).acos()).fold(0.0f32, f32::max);
            let cap = 2.0 * ((1u32 << h) as f32 / 1024.0).sqrt().asin();
            assert!(widest <= 2.0 * cap + 1e-3, "node {index} (height {h}): {widest} rad > 2·{cap}");
        }
    }
}
