//! Multi-view feature fusion (section 3.2.1, figure 3.21): the views'
//! features are combined by pairwise `max` until one set remains, in a
//! balanced tree: when a round has an odd count, one set waits, alternately
//! the last and the first, so the tree never degenerates into a chain.
//!
//! Order does not matter: `max` returns one of its operands, so it is
//! commutative and associative on every value except NaN and the two signed
//! zeros. NaN cannot reach the features (the networks clamp their inputs);
//! the zeros are made one by adding +0.0 to the fused result (-0 + +0 = +0).
//! A permutation of the views therefore gives bit-identical fused features;
//! the tests prove it on the whole networks.
//!
//! The tree is evaluated depth first and its leaves are computed on demand,
//! so at most one pending result per tree level is held: with nine views,
//! five feature maps instead of nine.

use burn::tensor::Tensor;

/// A fusion tree over view indices.
#[derive(Clone, Debug, PartialEq, Eq)]
pub enum FusionTree {
    /// One view's features.
    Leaf(usize),
    /// The element-wise max of two subtrees.
    Pair(Box<FusionTree>, Box<FusionTree>),
}

impl FusionTree {
    /// The thesis's balanced tree over views `0..views`; `None` for no views.
    ///
    /// Each round pairs neighbours in order; with an odd count, round 0, 2,
    /// ... leaves the last set waiting and round 1, 3, ... the first.
    pub fn balanced(views: usize) -> Option<FusionTree> {
        let mut nodes: Vec<FusionTree> = (0..views).map(FusionTree::Leaf).collect();
        let mut round = 0;
        while nodes.len() > 1 {
            let waiting_first = nodes.len() % 2 == 1 && round % 2 == 1;
            let waiting_last = nodes.len() % 2 == 1 && round % 2 == 0;
            let mut rest = nodes.into_iter();
            let mut next = Vec::new();
            if waiting_first {
                next.extend(rest.next());
            }
            let mut rest: Vec<FusionTree> = rest.collect();
            let last = if waiting_last { rest.pop() } else { None };
            let mut pairs = rest.into_iter();
            while let (Some(a), Some(b)) = (pairs.next(), pairs.next()) {
                next.push(FusionTree::Pair(Box::new(a), Box::new(b)));
            }
            next.extend(last);
            nodes = next;
            round += 1;
        }
        nodes.pop()
    }

    /// The view indices, left to right.
    pub fn leaves(&self) -> Vec<usize> {
        match self {
            FusionTree::Leaf(view) => vec![*view],
            FusionTree::Pair(a, b) => {
                let mut leaves = a.leaves();
                leaves.extend(b.leaves());
                leaves
            }
        }
    }

    /// Number of pairings on the longest path from the root to a leaf.
    pub fn depth(&self) -> usize {
        match self {
            FusionTree::Leaf(_) => 0,
            FusionTree::Pair(a, b) => 1 + a.depth().max(b.depth()),
        }
    }

    /// The fused features: the max over the leaves, each leaf computed by
    /// `leaf` when the walk reaches it, signed zeros made +0.
    pub fn fuse<E>(
        &self,
        leaf: &mut impl FnMut(usize) -> Result<Tensor<4>, E>,
    ) -> Result<Tensor<4>, E> {
        Ok(self.max_of(leaf)?.add_scalar(0.0))
    }

    fn max_of<E>(
        &self,
        leaf: &mut impl FnMut(usize) -> Result<Tensor<4>, E>,
    ) -> Result<Tensor<4>, E> {
        match self {
            FusionTree::Leaf(view) => leaf(*view),
            FusionTree::Pair(a, b) => {
                let a = a.max_of(leaf)?;
                let b = b.max_of(leaf)?;
                Ok(a.max_pair(b))
            }
        }
    }
}

/// Fuses already computed feature sets in the balanced tree; `None` if empty.
pub fn fuse_max(sets: Vec<Tensor<4>>) -> Option<Tensor<4>> {
    let tree = FusionTree::balanced(sets.len())?;
    let mut sets: Vec<Option<Tensor<4>>> = sets.into_iter().map(Some).collect();
    let fused = tree.fuse(&mut |view| sets[view].take().ok_or(()));
    fused.ok()
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::device::backend::cpu_device;
    use burn::tensor::TensorData;
    use rand::seq::SliceRandom;
    use rand::{Rng, SeedableRng};
    use rand_pcg::Pcg64;

    fn leaf(view: usize) -> Box<FusionTree> {
        Box::new(FusionTree::Leaf(view))
    }

    fn pair(a: Box<FusionTree>, b: Box<FusionTree>) -> Box<FusionTree> {
        Box::new(FusionTree::Pair(a, b))
    }

    #[test]
    fn odd_rounds_alternate_which_set_waits() {
        assert_eq!(FusionTree::balanced(0), None);
        assert_eq!(FusionTree::balanced(1), Some(FusionTree::Leaf(0)));
        // 3: the last waits in round 0.
        assert_eq!(
            FusionTree::balanced(3).map(Box::new),
            Some(pair(pair(leaf(0), leaf(1)), leaf(2)))
        );
        // 5: the last waits in round 0, then the first of three in round 1.
        assert_eq!(
            FusionTree::balanced(5).map(Box::new),
            Some(pair(
                pair(leaf(0), leaf(1)),
                pair(pair(leaf(2), leaf(3)), leaf(4))
            ))
        );
        // 9: last, first, last.
        assert_eq!(
            FusionTree::balanced(9).map(Box::new),
            Some(pair(
                pair(
                    pair(leaf(0), leaf(1)),
                    pair(pair(leaf(2), leaf(3)), pair(leaf(4), leaf(5)))
                ),
                pair(pair(leaf(6), leaf(7)), leaf(8))
            ))
        );
    }

    #[test]
    fn trees_hold_every_view_once_and_stay_balanced() {
        for views in 1..=64usize {
            let tree = FusionTree::balanced(views).expect("non-empty");
            assert_eq!(tree.leaves(), (0..views).collect::<Vec<_>>());
            let optimal = views.next_power_of_two().trailing_zeros() as usize;
            assert!(
                tree.depth() <= optimal + 1,
                "{views} views: depth {}",
                tree.depth()
            );
        }
    }

    #[test]
    fn fusion_is_the_elementwise_max_and_order_free_to_the_bit() {
        let device = cpu_device();
        let mut rng = Pcg64::seed_from_u64(7);
        // Ties, and +0 against -0, are where an order could show.
        let palette = [0.0f32, -0.0, 1.0, -1.0, 0.5, 1.0e-30, -2.0];
        for views in 1..=7 {
            let sets: Vec<Vec<f32>> = (0..views)
                .map(|_| {
                    (0..48)
                        .map(|_| palette[rng.gen_range(0..palette.len())])
                        .collect()
                })
                .collect();
            let expected: Vec<u32> = (0..48)
                .map(|i| {
                    let max = sets.iter().map(|s| s[i]).fold(f32::NEG_INFINITY, f32::max);
                    (max + 0.0).to_bits()
                })
                .collect();
            let mut order: Vec<usize> = (0..views).collect();
            for _ in 0..10 {
                order.shuffle(&mut rng);
                let tensors = order
                    .iter()
                    .map(|&v| {
                        Tensor::<4>::from_data(
                            TensorData::new(sets[v].clone(), [1, 3, 4, 4]),
                            &device,
                        )
                    })
                    .collect();
                let fused = fuse_max(tensors).expect("non-empty");
                let bits: Vec<u32> = fused
                    .into_data()
                    .try_to_vec::<f32>()
                    .expect("f32")
                    .iter()
                    .map(|v| v.to_bits())
                    .collect();
                assert_eq!(bits, expected, "{views} views in order {order:?}");
            }
        }
    }

    #[test]
    fn leaves_are_computed_once_each_in_tree_order() {
        let device = cpu_device();
        let tree = FusionTree::balanced(5).expect("non-empty");
        let mut visited = Vec::new();
        let fused = tree
            .fuse::<()>(&mut |view| {
                visited.push(view);
                Ok(Tensor::<4>::full([1, 1, 1, 1], view as f32, &device))
            })
            .expect("no error");
        assert_eq!(visited, vec![0, 1, 2, 3, 4]);
        assert_eq!(
            fused.into_data().try_to_vec::<f32>().expect("f32"),
            vec![4.0]
        );
    }

    #[test]
    fn an_empty_set_does_not_fuse() {
        assert!(fuse_max(Vec::new()).is_none());
    }
}
