//! A small exact 3-d kd-tree for the precomputed irradiance points: the nearest point (optionally
//! the nearest passing a test) and the k nearest, within a radius.
//!
//! The precomputed irradiance is read once per final-gather ray — tens of millions of reads per
//! image. Through FLANN's C API a batched exact 1-NN query cost ≈ 1 µs, and the ~18 % of queries
//! whose nearest point faced another way paid two more k-NN calls, a large part of the cache fill.
//! This tree answers in a fraction of that. The photon maps themselves (k = 100 density estimates
//! with FLANN's radius search) stay in FLANN.
#![forbid(unsafe_code)]

use glam::Vec3;

/// Points per leaf.
const LEAF: usize = 8;

#[derive(Clone, Copy, Debug)]
enum Node {
    /// Points `lo..hi` of the permuted arrays.
    Leaf { lo: u32, hi: u32 },
    /// Points with coordinate `axis` below `split` are under `left` (the next node), the rest under
    /// `right`.
    Split { axis: u8, split: f32, right: u32 },
}

/// An exact kd-tree over a fixed point set; point ids are their indices in the slice given to
/// `build`.
#[derive(Clone, Debug, Default)]
pub(crate) struct PointTree {
    nodes: Vec<Node>,
    /// Points in tree order.
    points: Vec<Vec3>,
    /// `ids[i]` is the caller's index of `points[i]`.
    ids: Vec<u32>,
}

impl PointTree {
    /// Builds the tree (median splits on the widest axis). Non-finite points are left out.
    pub(crate) fn build(points: &[Vec3]) -> PointTree {
        let mut order: Vec<u32> = (0..points.len() as u32)
            .filter(|&i| points[i as usize].is_finite())
            .collect();
        let mut tree = PointTree {
            nodes: Vec::new(),
            points: Vec::with_capacity(order.len()),
            ids: Vec::with_capacity(order.len()),
        };
        if !order.is_empty() {
            tree.build_node(points, &mut order, 0);
        }
        tree
    }

    fn build_node(&mut self, points: &[Vec3], ids: &mut [u32], offset: usize) {
        if ids.len() <= LEAF {
            let lo = offset as u32;
            self.points.extend(ids.iter().map(|&i| points[i as usize]));
            self.ids.extend_from_slice(ids);
            self.nodes.push(Node::Leaf {
                lo,
                hi: lo + ids.len() as u32,
            });
            return;
        }
        let (lo, hi) = ids
            .iter()
            .fold((Vec3::INFINITY, Vec3::NEG_INFINITY), |(lo, hi), &i| {
                (lo.min(points[i as usize]), hi.max(points[i as usize]))
            });
        let extent = hi - lo;
        let axis = if extent.x >= extent.y && extent.x >= extent.z {
            0
        } else if extent.y >= extent.z {
            1
        } else {
            2
        };
        let mid = ids.len() / 2;
        // Ties broken by id, so the tree (and every answer) is a function of the point set alone.
        ids.select_nth_unstable_by(mid, |&a, &b| {
            points[a as usize][axis]
                .total_cmp(&points[b as usize][axis])
                .then(a.cmp(&b))
        });
        let split = points[ids[mid] as usize][axis];
        let at = self.nodes.len();
        self.nodes.push(Node::Leaf { lo: 0, hi: 0 }); // replaced below
        let (left, right) = ids.split_at_mut(mid);
        self.build_node(points, left, offset);
        let right_at = self.nodes.len() as u32;
        self.build_node(points, right, offset + mid);
        self.nodes[at] = Node::Split {
            axis: axis as u8,
            split,
            right: right_at,
        };
    }

    #[cfg(test)]
    fn len(&self) -> usize {
        self.points.len()
    }

    pub(crate) fn memory_bytes(&self) -> usize {
        self.nodes.capacity() * std::mem::size_of::<Node>()
            + self.points.capacity() * 12
            + self.ids.capacity() * 4
    }

    /// The id and squared distance of the nearest point strictly closer than `max_radius` to `q`
    /// for which `accept(id)` holds; among equally distant points the smallest id. `accept` is
    /// called only for points closer than the best accepted so far.
    pub(crate) fn nearest_where(
        &self,
        q: Vec3,
        max_radius: f32,
        mut accept: impl FnMut(u32) -> bool,
    ) -> Option<(u32, f32)> {
        let mut best: Option<(u32, f32)> = None;
        self.search(q, max_radius, |id, d2| {
            let better = match best {
                Some((b, bd)) => d2 < bd || (d2 == bd && id < b),
                None => true,
            };
            if better && accept(id) {
                best = Some((id, d2));
            }
            best.map(|(_, bd)| bd)
        });
        best
    }

    /// The `k` nearest points strictly closer than `max_radius`, as (id, squared distance) sorted
    /// by distance then id, into `out` (cleared first).
    pub(crate) fn knn(&self, q: Vec3, k: usize, max_radius: f32, out: &mut Vec<(u32, f32)>) {
        out.clear();
        if k == 0 {
            return;
        }
        self.search(q, max_radius, |id, d2| {
            let full = out.len() == k;
            if !full || d2 < out[k - 1].1 || (d2 == out[k - 1].1 && id < out[k - 1].0) {
                let at = out.partition_point(|&(b, bd)| bd < d2 || (bd == d2 && b < id));
                out.insert(at, (id, d2));
                out.truncate(k);
            }
            (out.len() == k).then(|| out[k - 1].1)
        });
    }

    /// Depth-first traversal nearest side first: `visit(id, d2)` sees every point strictly inside
    /// `max_radius` and not farther than the bound it last returned (`None`: still the radius);
    /// subtrees farther than the bound are skipped.
    fn search(&self, q: Vec3, max_radius: f32, mut visit: impl FnMut(u32, f32) -> Option<f32>) {
        if self.nodes.is_empty() || !q.is_finite() || max_radius.is_nan() || max_radius <= 0.0 {
            return;
        }
        let limit = max_radius * max_radius;
        let mut bound = limit;
        let mut stack: [(u32, f32); 64] = [(0, 0.0); 64];
        let mut top = 1usize;
        while top > 0 {
            top -= 1;
            let (mut node, d2min) = stack[top];
            if d2min > bound {
                continue;
            }
            loop {
                match self.nodes[node as usize] {
                    Node::Leaf { lo, hi } => {
                        for i in lo as usize..hi as usize {
                            let d2 = self.points[i].distance_squared(q);
                            if d2 < limit && d2 <= bound {
                                bound = visit(self.ids[i], d2).unwrap_or(limit);
                            }
                        }
                        break;
                    }
                    Node::Split { axis, split, right } => {
                        let diff = q[axis as usize] - split;
                        let (near, far) = if diff < 0.0 {
                            (node + 1, right)
                        } else {
                            (right, node + 1)
                        };
                        // Depth ≤ log2(n / LEAF) + 1 < 64 for any point count that fits in u32.
                        if diff * diff <= bound && top < stack.len() {
                            stack[top] = (far, diff * diff);
                            top += 1;
                        }
                        node = near;
                    }
                }
            }
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::sampling::Rng;

    fn brute(points: &[Vec3], q: Vec3, r: f32, accept: impl Fn(u32) -> bool) -> Option<(u32, f32)> {
        let mut best: Option<(u32, f32)> = None;
        for (i, p) in points.iter().enumerate() {
            let d2 = p.distance_squared(q);
            if d2 < r * r
                && accept(i as u32)
                && best.is_none_or(|(b, bd)| d2 < bd || (d2 == bd && (i as u32) < b))
            {
                best = Some((i as u32, d2));
            }
        }
        best
    }

    #[test]
    fn matches_brute_force_with_and_without_a_test() {
        let mut rng = Rng::new(5);
        // Points on three planes plus duplicates and a non-finite one: clustered like photons.
        let mut points: Vec<Vec3> = (0..3000)
            .map(|i| {
                let (u, v) = (rng.uniform() * 4.0 - 2.0, rng.uniform() * 4.0 - 2.0);
                match i % 3 {
                    0 => Vec3::new(u, v, 0.0),
                    1 => Vec3::new(u, 0.0, v),
                    _ => Vec3::new(1.0, u, v),
                }
            })
            .collect();
        points.extend_from_within(..50);
        points.push(Vec3::NAN);
        let tree = PointTree::build(&points);
        assert_eq!(tree.len(), points.len() - 1);
        for k in 0..2000 {
            let q = Vec3::new(
                rng.uniform() * 5.0 - 2.5,
                rng.uniform() * 5.0 - 2.5,
                rng.uniform() * 5.0 - 2.5,
            );
            let r = if k % 2 == 0 { 0.3 } else { 10.0 };
            assert_eq!(
                tree.nearest_where(q, r, |_| true),
                brute(&points, q, r, |_| true),
                "query {q}"
            );
            let odd = |id: u32| id % 7 == 3;
            assert_eq!(
                tree.nearest_where(q, r, odd),
                brute(&points, q, r, odd),
                "query {q} with a test"
            );
        }
        assert_eq!(tree.nearest_where(Vec3::NAN, 1.0, |_| true), None);
        assert_eq!(tree.nearest_where(Vec3::ZERO, 0.0, |_| true), None);
        assert_eq!(
            PointTree::build(&[]).nearest_where(Vec3::ZERO, 1.0, |_| true),
            None
        );
    }

    #[test]
    fn knn_matches_brute_force() {
        let mut rng = Rng::new(11);
        let points: Vec<Vec3> = (0..2000)
            .map(|_| {
                Vec3::new(
                    rng.uniform(),
                    rng.uniform(),
                    (rng.uniform() * 4.0).floor() * 0.1,
                )
            })
            .collect();
        let tree = PointTree::build(&points);
        let mut out = Vec::new();
        for _ in 0..500 {
            let q = Vec3::new(rng.uniform(), rng.uniform(), rng.uniform() * 0.4);
            for (k, r) in [(1, 0.05), (8, 0.05), (8, 2.0), (30, 0.1)] {
                tree.knn(q, k, r, &mut out);
                let mut all: Vec<(u32, f32)> = points
                    .iter()
                    .enumerate()
                    .map(|(i, p)| (i as u32, p.distance_squared(q)))
                    .filter(|&(_, d)| d < r * r)
                    .collect();
                all.sort_by(|a, b| a.1.total_cmp(&b.1).then(a.0.cmp(&b.0)));
                all.truncate(k);
                assert_eq!(out, all, "q {q} k {k} r {r}");
            }
        }
    }

    #[test]
    fn duplicates_resolve_to_the_smallest_id() {
        let points = vec![Vec3::ONE; 40];
        let tree = PointTree::build(&points);
        assert_eq!(
            tree.nearest_where(Vec3::ZERO, 5.0, |_| true).map(|b| b.0),
            Some(0)
        );
        assert_eq!(
            tree.nearest_where(Vec3::ZERO, 5.0, |id| id >= 17)
                .map(|b| b.0),
            Some(17)
        );
    }
}
