//! Cut construction, the compact representation and the walks, against the same operations on
//! the uncompressed leaves (seeded random cases).

use super::{random_cut, random_leaves, rng};
use crate::cuts::cut::{ClusterTree, Cut, CutNode};
use crate::cuts::packed::{PackedCuts, ValueEncoding};
use crate::cuts::walk::{for_each_common_node, product, weighted_sum};
use crate::cuts::{CutView, CutsError};
use rand::Rng;

/// Random cases per property.
const CASES: u64 = 300;

fn leafwise_product(cuts: &[Cut]) -> Vec<f32> {
    let leaves: Vec<Vec<f32>> = cuts.iter().map(Cut::to_leaves).collect();
    (0..leaves[0].len()).map(|j| leaves.iter().fold(1.0f32, |p, l| p * l[j])).collect()
}

/// Operands of one random case: cuts from random splits and from clustered random leaves.
fn random_operands(seed: u64) -> (u32, Vec<Cut>) {
    let mut r = rng(seed);
    let levels = r.random_range(1..=10);
    let count = r.random_range(1..=5);
    let cuts = (0..count)
        .map(|_| match r.random_range(0..3) {
            0 => {
                let (split, binary) = (r.random_range(0.3..0.9), r.random_bool(0.5));
                random_cut(&mut r, levels, split, binary)
            }
            1 => {
                let binary = r.random_bool(0.5);
                let leaves = random_leaves(&mut r, levels, binary);
                Cut::from_leaves(levels, &leaves, if binary { 0.0 } else { r.random_range(0.0..0.5) }).expect("valid leaves")
            }
            _ => Cut::constant(levels, r.random::<f32>()).expect("valid levels"),
        })
        .collect();
    (levels, cuts)
}

#[test]
fn product_equals_the_leafwise_product() {
    for seed in 0..CASES {
        let (_, cuts) = random_operands(seed);
        let views: Vec<CutView> = cuts.iter().map(Cut::view).collect();
        let p = product(&views).expect("same levels");
        // Both multiply the operands' values in operand order starting from 1, and a zero
        // operand gives 0 either way: the leaves agree bit for bit.
        assert_eq!(p.to_leaves(), leafwise_product(&cuts), "seed {seed}");
        // The output is merged: merging again changes nothing.
        let mut again = p.clone();
        again.merge_equal_siblings();
        assert_eq!(again, p, "seed {seed}");
    }
}

#[test]
fn product_of_packed_cuts_equals_the_leafwise_product_of_their_decoding() {
    for seed in 0..CASES / 3 {
        let (levels, cuts) = random_operands(seed + 1000);
        let mut bank = PackedCuts::new(levels, ValueEncoding::Unorm16).expect("valid levels");
        cuts.iter().for_each(|c| bank.push(c).expect("values in [0, 1]"));
        let views: Vec<CutView> = (0..bank.len()).map(|k| bank.view(k)).collect();
        let decoded: Vec<Cut> = (0..bank.len()).map(|k| bank.get(k)).collect();
        assert_eq!(product(&views).expect("same levels").to_leaves(), leafwise_product(&decoded), "seed {seed}");
    }
}

#[test]
fn interpolation_equals_the_leafwise_weighted_sum() {
    for seed in 0..CASES {
        let (_, cuts) = random_operands(seed + 2000);
        let mut r = rng(seed);
        let weights: Vec<f32> = cuts.iter().map(|_| if r.random_bool(0.2) { 0.0 } else { r.random::<f32>() }).collect();
        let views: Vec<CutView> = cuts.iter().map(Cut::view).collect();
        let sum = weighted_sum(&views, &weights).expect("matching weights").to_leaves();
        let leaves: Vec<Vec<f32>> = cuts.iter().map(Cut::to_leaves).collect();
        for (j, s) in sum.iter().enumerate() {
            let reference: f64 = leaves.iter().zip(&weights).map(|(l, w)| l[j] as f64 * *w as f64).sum();
            // At most 5 f32 products and sums of terms ≤ 1: rounding below 10 · 2⁻²⁴.
            assert!((*s as f64 - reference).abs() < 1e-6, "seed {seed} leaf {j}: {s} vs {reference}");
        }
    }
}

#[test]
fn interpolation_merges_as_it_walks_into_the_same_nodes_as_merging_afterwards() {
    // `weighted_sum` merges equal siblings as the walk emits them: the same nodes, bit for bit,
    // as the common refinement's weighted values merged by `Cut::merge_equal_siblings`.
    for seed in 0..CASES / 3 {
        let (levels, cuts) = random_operands(seed + 4000);
        let mut r = rng(seed + 7);
        let weights: Vec<f32> = cuts.iter().map(|_| 0.01 + r.random::<f32>()).collect();
        let views: Vec<CutView> = cuts.iter().map(Cut::view).collect();
        let mut nodes = Vec::new();
        for_each_common_node(&views, |h, _, values| nodes.push(CutNode { height: h as u8, value: values.iter().zip(&weights).map(|(v, w)| v * w).sum() }))
            .expect("same levels");
        let mut after = Cut::from_nodes(levels, nodes).expect("a tiling");
        after.merge_equal_siblings();
        assert_eq!(weighted_sum(&views, &weights).expect("matching weights").nodes(), after.nodes(), "seed {seed}");
    }
}

#[test]
fn common_refinement_is_the_finest_of_the_operands() {
    // Each visited node lies inside exactly one node of every operand, with that node's value,
    // and the visited nodes tile the leaves in order.
    for seed in 0..CASES / 3 {
        let (levels, cuts) = random_operands(seed + 3000);
        let views: Vec<CutView> = cuts.iter().map(Cut::view).collect();
        let leaves: Vec<Vec<f32>> = cuts.iter().map(Cut::to_leaves).collect();
        let mut next = 0u32;
        for_each_common_node(&views, |h, first, values| {
            assert_eq!(first, next, "seed {seed}");
            assert_eq!(first % (1 << h), 0);
            for (l, v) in leaves.iter().zip(values) {
                assert!(l[first as usize..(first + (1 << h)) as usize].iter().all(|x| x == v), "seed {seed}");
            }
            next += 1 << h;
        })
        .expect("same levels");
        assert_eq!(next, 1 << levels);
    }
}

#[test]
fn the_papers_two_cut_example() {
    // Fig. 6 in miniature, four leaves: cut 1 = (leaf 1, leaf 2, pair 3), cut 2 = (pair 5,
    // leaf 7, leaf 11). Leafwise: (1·5, 2·5, 3·7, 3·11).
    let a = Cut::from_nodes(2, vec![CutNode { height: 0, value: 1.0 }, CutNode { height: 0, value: 2.0 }, CutNode { height: 1, value: 3.0 }]).expect("a cut");
    let b = Cut::from_nodes(2, vec![CutNode { height: 1, value: 5.0 }, CutNode { height: 0, value: 7.0 }, CutNode { height: 0, value: 11.0 }]).expect("a cut");
    let p = product(&[a.view(), b.view()]).expect("same levels");
    assert_eq!(p.to_leaves(), vec![5.0, 10.0, 21.0, 33.0]);
    assert!(p.nodes().iter().all(|n| n.height == 0));
}

#[test]
fn a_zero_node_is_not_refined() {
    // The left half is 0 in the first operand; the second is fine everywhere. The product keeps
    // the left half as one node.
    let levels = 6;
    let half = Cut::from_nodes(levels, vec![CutNode { height: 5, value: 0.0 }, CutNode { height: 5, value: 1.0 }]).expect("a cut");
    let fine = Cut::from_leaves(levels, &(0..64).map(|j| j as f32 / 64.0).collect::<Vec<_>>(), 0.0).expect("valid leaves");
    let p = product(&[fine.view(), half.view()]).expect("same levels");
    assert_eq!(p.nodes()[0], CutNode { height: 5, value: 0.0 });
    assert_eq!(p.len(), 1 + 32);
}

#[test]
fn threshold_zero_reproduces_the_leaves_and_is_coarsest() {
    for seed in 0..CASES {
        let mut r = rng(seed + 4000);
        let levels = r.random_range(1..=12);
        let binary = r.random_bool(0.5);
        let leaves = random_leaves(&mut r, levels, binary);
        let cut = Cut::from_leaves(levels, &leaves, 0.0).expect("valid leaves");
        assert_eq!(cut.to_leaves(), leaves, "seed {seed}");
        let mut merged = cut.clone();
        merged.merge_equal_siblings();
        assert_eq!(merged, cut, "seed {seed}: threshold 0 left mergeable siblings");
    }
}

#[test]
fn threshold_bounds_every_leaf_and_infinity_keeps_the_root() {
    for seed in 0..CASES {
        let mut r = rng(seed + 5000);
        let levels = r.random_range(1..=11);
        let leaves: Vec<f32> = (0..1 << levels).map(|_| r.random::<f32>()).collect();
        let threshold = r.random_range(0.0..0.6);
        let cut = Cut::from_leaves(levels, &leaves, threshold).expect("valid leaves");
        // Every leaf within the threshold of its node's mean (plus f32 rounding of the mean).
        for (j, (a, b)) in cut.to_leaves().iter().zip(&leaves).enumerate() {
            assert!((a - b).abs() <= threshold + 1e-6, "seed {seed} leaf {j}: {a} vs {b} (threshold {threshold})");
        }
        // The leaf sum is kept: each node is its leaves' mean.
        let exact: f64 = leaves.iter().map(|&v| v as f64).sum();
        assert!((cut.leaf_sum() - exact).abs() < 1e-5 * exact.max(1.0), "seed {seed}");
        let root = Cut::from_leaves(levels, &leaves, f32::INFINITY).expect("valid leaves");
        assert_eq!(root.len(), 1);
        assert!((root.nodes()[0].value as f64 - exact / leaves.len() as f64).abs() < 1e-5);
    }
}

#[test]
fn one_pass_cut_equals_the_top_down_walk_of_the_cluster_tree() {
    for seed in 0..CASES {
        let mut r = rng(seed + 7000);
        let levels = r.random_range(1..=11);
        let leaves = if r.random_bool(0.5) { random_leaves(&mut r, levels, false) } else { (0..1 << levels).map(|_| r.random::<f32>()).collect() };
        let threshold = if r.random_bool(0.1) { f32::INFINITY } else { r.random_range(0.0..0.7) };
        let walked = ClusterTree::from_leaves(levels, &leaves).expect("valid leaves").cut(threshold).expect("valid threshold");
        assert_eq!(Cut::from_leaves(levels, &leaves, threshold).expect("valid leaves"), walked, "seed {seed}");
    }
}

#[test]
fn clustering_error_is_the_largest_deviation() {
    let tree = ClusterTree::from_leaves(2, &[0.0, 1.0, 0.5, 0.5]).expect("valid leaves");
    // Root: mean 0.5, leaves 0..1 deviate by 0.5; left child: mean 0.5, error 0.5; right: 0.
    assert_eq!((tree.mean(0), tree.error(0)), (0.5, 0.5));
    assert_eq!((tree.mean(1), tree.error(1)), (0.5, 0.5));
    assert_eq!((tree.mean(2), tree.error(2)), (0.5, 0.0));
    assert_eq!(tree.cut(0.0).expect("valid").len(), 3);
}

#[test]
fn bad_inputs_are_errors() {
    assert!(matches!(Cut::from_leaves(3, &[0.0; 8], -1.0), Err(CutsError::Threshold { .. })));
    assert!(matches!(Cut::from_leaves(3, &[0.0; 8], f32::NAN), Err(CutsError::Threshold { .. })));
    assert!(matches!(Cut::from_leaves(3, &[0.0; 7], 0.0), Err(CutsError::LeafCount { .. })));
    let mut leaves = [0.0; 8];
    leaves[5] = f32::INFINITY;
    assert!(matches!(Cut::from_leaves(3, &leaves, 0.0), Err(CutsError::NonFinite { index: 5, .. })));
    assert!(matches!(Cut::from_leaves(16, &[], 0.0), Err(CutsError::Levels { .. })));
    // Not cuts: a misaligned node, too few leaves, too many.
    let n = |h| CutNode { height: h, value: 0.0 };
    assert!(Cut::from_nodes(2, vec![n(0), n(1), n(0)]).is_err());
    assert!(Cut::from_nodes(2, vec![n(1)]).is_err());
    assert!(Cut::from_nodes(2, vec![n(2), n(0)]).is_err());
    // Operations on nothing or on different trees.
    assert!(product(&[]).is_err());
    let (a, b) = (Cut::constant(3, 1.0).expect("valid"), Cut::constant(4, 1.0).expect("valid"));
    assert!(matches!(product(&[a.view(), b.view()]), Err(CutsError::LevelMismatch { index: 1, .. })));
    assert!(weighted_sum(&[a.view()], &[]).is_err());
    assert!(weighted_sum(&[a.view()], &[f32::NAN]).is_err());
}

#[test]
fn height_representation_round_trips() {
    for seed in 0..CASES {
        let mut r = rng(seed + 6000);
        let levels = r.random_range(1..=15);
        let binary = r.random_bool(0.5);
        let count = r.random_range(1..6);
        let cuts: Vec<Cut> = (0..count)
            .map(|_| {
                let split = r.random_range(0.2..0.8);
                random_cut(&mut r, levels, split, binary)
            })
            .collect();
        // Heights ↔ heap indices (in any order).
        for c in &cuts {
            let mut pairs: Vec<(u32, f32)> = c.node_indices().into_iter().zip(c.nodes().iter().map(|n| n.value)).collect();
            pairs.reverse();
            let (idx, val): (Vec<u32>, Vec<f32>) = pairs.into_iter().unzip();
            assert_eq!(&Cut::from_node_indices(levels, &idx, &val).expect("a cut"), c, "seed {seed}");
        }
        // Packed banks: bits are exact, fixed point within half a step.
        for (encoding, step) in [(ValueEncoding::Bits, 0.0), (ValueEncoding::Unorm8, 1.0 / 255.0), (ValueEncoding::Unorm16, 1.0 / 65535.0)] {
            if encoding == ValueEncoding::Bits && !binary {
                continue;
            }
            let mut bank = PackedCuts::new(levels, encoding).expect("valid levels");
            cuts.iter().for_each(|c| bank.push(c).expect("encodable"));
            for (k, c) in cuts.iter().enumerate() {
                let back = bank.get(k);
                assert_eq!(back.len(), c.len());
                for (a, b) in back.nodes().iter().zip(c.nodes()) {
                    assert_eq!(a.height, b.height);
                    assert!((a.value - b.value).abs() <= 0.5 * step + 1e-7, "seed {seed} {encoding:?}");
                }
            }
            // Sizes: 4 bits of height per node plus the values.
            let nodes = bank.node_count();
            assert_eq!(bank.stored_bytes(), nodes.div_ceil(2) + (nodes * encoding.bits()).div_ceil(8));
            // The raw parts rebuild the same bank (offsets recovered from the heights).
            let (h, v) = bank.raw();
            let again = PackedCuts::from_parts(levels, encoding, bank.len(), nodes, h.to_vec(), v.to_vec()).expect("valid parts");
            assert_eq!(again, bank, "seed {seed}");
        }
    }
}

#[test]
fn packed_banks_reject_what_they_cannot_hold() {
    let mut bits = PackedCuts::new(3, ValueEncoding::Bits).expect("valid");
    assert!(matches!(bits.push(&Cut::constant(3, 0.5).expect("valid")), Err(CutsError::Encoding { .. })));
    let mut unorm = PackedCuts::new(3, ValueEncoding::Unorm16).expect("valid");
    assert!(unorm.push(&Cut::constant(3, 1.5).expect("valid")).is_err());
    assert!(unorm.push(&Cut::constant(3, f32::NAN).expect("valid")).is_err());
    assert!(unorm.push(&Cut::constant(4, 0.5).expect("valid")).is_err());
    // Heights that do not tile: (0, 1) puts a pair at leaf 1.
    assert!(PackedCuts::from_parts(2, ValueEncoding::Bits, 1, 2, vec![0x10], vec![0]).is_err());
    // Heights that tile but a header that counts differently.
    assert!(PackedCuts::from_parts(2, ValueEncoding::Bits, 2, 1, vec![0x02], vec![0]).is_err());
    // Part lengths that do not match the node count.
    assert!(PackedCuts::from_parts(2, ValueEncoding::Unorm16, 1, 1, vec![0x02], vec![0]).is_err());
}
