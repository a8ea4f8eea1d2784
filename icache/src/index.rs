//! Spatial index over record spheres: an octree that references each record from every node (at one
//! depth matched to the sphere's size) the sphere overlaps, so a point lookup walks a single
//! root-to-leaf path.
//!
//! A sphere is stored at the deepest level whose cells are at least its diameter, so it touches at
//! most 8 cells there. Radii may later shrink (neighbor clamping, adaptive caching); the old cells
//! still cover the smaller sphere, so nothing moves, but the entries take the smaller radius
//! ([`Octree::shrink`]). The caller's exact weight test decides usability. Spheres reaching outside
//! the root cube are also kept in an `outside` list, which is all a lookup outside the cube checks.
#![forbid(unsafe_code)]

use glam::Vec3;

/// Depth cap: 2^-20 of the scene size is far below any pixel footprint we will see.
const MAX_DEPTH: u32 = 20;

#[derive(Clone, Debug, Default)]
struct Node {
    /// Index of the first of 8 consecutive children in `nodes`, 0 when a leaf (the root is node 0).
    first_child: u32,
    spheres: Vec<Sphere>,
}

/// A cell of the octree: its node, lower corner, edge length and depth.
#[derive(Clone, Copy, Debug)]
struct Cell {
    node: usize,
    lo: Vec3,
    size: f32,
    depth: u32,
}

impl Cell {
    /// Child `i` of the cell, whose node's children start at node `first`.
    fn child(self, first: usize, i: usize) -> Cell {
        let half = 0.5 * self.size;
        Cell {
            node: first + i,
            lo: self.lo + child_offset(i) * half,
            size: half,
            depth: self.depth + 1,
        }
    }
}

/// A record's sphere (`center`, `radius`) as placed in the cells of depth `level`.
#[derive(Clone, Copy, Debug)]
struct Placed {
    level: u32,
    center: Vec3,
    radius: f32,
    id: u32,
}

/// A record's sphere as the node holds it: a lookup rejects most candidates here, reading 20 bytes
/// kept together in the node instead of the 132-byte record (the weight test of records whose
/// sphere does not contain the point was a visible part of a render's profile).
#[derive(Clone, Copy, Debug)]
struct Sphere {
    center: Vec3,
    radius: f32,
    id: u32,
}

impl Sphere {
    /// Whether `p` lies in the sphere with its radius scaled by √`scale2`.
    #[inline]
    fn contains_scaled(&self, p: Vec3, scale2: f32) -> bool {
        // Never reject on rounding: the caller's exact test decides at the border.
        (p - self.center).length_squared() <= self.radius * self.radius * scale2 * (1.0 + 1e-5)
    }
}

/// Octree of record spheres over a root cube.
#[derive(Clone, Debug)]
pub(crate) struct Octree {
    origin: Vec3,
    size: f32,
    nodes: Vec<Node>,
    outside: Vec<u32>,
}

/// Squared distance from `c` to the axis-aligned box [lo, lo + size]³.
fn dist2_to_box(c: Vec3, lo: Vec3, size: f32) -> f32 {
    let q = c.clamp(lo, lo + Vec3::splat(size));
    (c - q).length_squared()
}

/// Offset of child `i` (bit 0: x, bit 1: y, bit 2: z) in units of the child size.
fn child_offset(i: usize) -> Vec3 {
    Vec3::new((i & 1) as f32, ((i >> 1) & 1) as f32, ((i >> 2) & 1) as f32)
}

impl Octree {
    /// An empty octree whose root cube encloses [min, max] with a small margin. Non-finite or
    /// inverted bounds, or an extent that overflows, give a unit cube at the origin: records
    /// outside the cube still work, via the outside list.
    pub(crate) fn new(min: Vec3, max: Vec3) -> Self {
        let ok = min.is_finite()
            && max.is_finite()
            && min.cmple(max).all()
            && ((max - min).max_element() * 1.02).is_finite();
        let (min, max) = if ok {
            (min, max)
        } else {
            (Vec3::ZERO, Vec3::ONE)
        };
        let extent = (max - min).max_element().max(1e-6);
        let margin = 0.01 * extent;
        Octree {
            origin: min - Vec3::splat(margin),
            size: extent + 2.0 * margin,
            nodes: vec![Node::default()],
            outside: Vec::new(),
        }
    }

    fn in_root(&self, p: Vec3) -> bool {
        p.cmpge(self.origin).all() && p.cmple(self.origin + Vec3::splat(self.size)).all()
    }

    /// Deepest level whose cell size is at least the sphere's diameter.
    fn level_for(&self, radius: f32) -> u32 {
        if !(radius.is_finite() && radius > 0.0) {
            return if radius == 0.0 { MAX_DEPTH } else { 0 };
        }
        let mut level = 0;
        let mut cell = self.size;
        while level < MAX_DEPTH && 0.5 * cell >= 2.0 * radius {
            cell *= 0.5;
            level += 1;
        }
        level
    }

    /// Reference record `id` with sphere (`center`, `radius`) from every overlapping cell at its
    /// level.
    pub(crate) fn insert(&mut self, id: u32, center: Vec3, radius: f32) {
        let r = if radius.is_nan() {
            f32::INFINITY
        } else {
            radius.max(0.0)
        };
        let contained = center.is_finite()
            && r.is_finite()
            && self.in_root(center - Vec3::splat(r))
            && self.in_root(center + Vec3::splat(r));
        if !contained {
            self.outside.push(id);
        }
        if !center.is_finite() {
            return;
        }
        let sphere = Placed {
            level: self.level_for(r),
            center,
            radius: r,
            id,
        };
        self.insert_rec(self.root(), sphere);
    }

    /// The root cell.
    fn root(&self) -> Cell {
        Cell {
            node: 0,
            lo: self.origin,
            size: self.size,
            depth: 0,
        }
    }

    fn insert_rec(&mut self, cell: Cell, s: Placed) {
        if dist2_to_box(s.center, cell.lo, cell.size) > s.radius * s.radius {
            return;
        }
        if cell.depth == s.level {
            self.nodes[cell.node].spheres.push(Sphere {
                center: s.center,
                radius: s.radius,
                id: s.id,
            });
            return;
        }
        if self.nodes[cell.node].first_child == 0 {
            let first = self.nodes.len();
            self.nodes.resize(first + 8, Node::default());
            self.nodes[cell.node].first_child = first as u32;
        }
        let first = self.nodes[cell.node].first_child as usize;
        for i in 0..8 {
            self.insert_rec(cell.child(first, i), s);
        }
    }

    /// Record `id`, indexed with sphere (`center`, `old_radius`), now reaches `new_radius` ≤
    /// `old_radius`. Where the smaller sphere belongs to the same level, its entries stay in their
    /// cells (which still cover it) and test the smaller radius; where it belongs deeper, they move
    /// to that level's cells. Returns the radius the record is now indexed with (the `old_radius`
    /// of its next shrink). In a detailed scene neighbor clamping shrinks most records after
    /// insertion: with the entries left in their first cells a lookup would scan about ten spheres
    /// for each one containing the point.
    pub(crate) fn shrink(
        &mut self,
        id: u32,
        center: Vec3,
        old_radius: f32,
        new_radius: f32,
    ) -> f32 {
        let r = if old_radius.is_nan() {
            f32::INFINITY
        } else {
            old_radius.max(0.0)
        };
        if !(center.is_finite() && new_radius >= 0.0 && new_radius < r) {
            return old_radius;
        }
        let old = Placed {
            level: self.level_for(r),
            center,
            radius: r,
            id,
        };
        let to = self.level_for(new_radius);
        if to == old.level || !r.is_finite() {
            self.shrink_rec(self.root(), old, Some(new_radius));
            return old_radius;
        }
        self.shrink_rec(self.root(), old, None);
        let new = Placed {
            level: to,
            radius: new_radius,
            ..old
        };
        self.insert_rec(self.root(), new);
        new_radius
    }

    /// In every cell of `s`'s level that its sphere overlaps: its record's entry takes radius
    /// `new_radius`, or leaves the cell when that is `None`.
    fn shrink_rec(&mut self, cell: Cell, s: Placed, new_radius: Option<f32>) {
        if dist2_to_box(s.center, cell.lo, cell.size) > s.radius * s.radius {
            return;
        }
        if cell.depth == s.level {
            let id = s.id;
            let spheres = &mut self.nodes[cell.node].spheres;
            match new_radius {
                Some(nr) => {
                    if let Some(s) = spheres.iter_mut().find(|s| s.id == id) {
                        s.radius = s.radius.min(nr);
                    }
                }
                None => spheres.retain(|s| s.id != id),
            }
            return;
        }
        let first = self.nodes[cell.node].first_child as usize;
        if first == 0 {
            return;
        }
        for i in 0..8 {
            self.shrink_rec(cell.child(first, i), s, new_radius);
        }
    }

    /// Call `f` with every record whose sphere contains `p` (with its radius as last shrunk: a
    /// superset of the records usable there; each id at most once).
    pub(crate) fn for_each_candidate(&self, p: Vec3, f: impl FnMut(u32)) {
        self.for_each_candidate_within(p, 1.0, f)
    }

    /// [`for_each_candidate`](Self::for_each_candidate) with every sphere's radius scaled by
    /// `scale` ≤ 1: a lookup whose records reach less far than the index holds them (pass A: a·R'
    /// where the index holds pass B's reach) rejects the others here, without reading their
    /// records.
    pub(crate) fn for_each_candidate_within(&self, p: Vec3, scale: f32, mut f: impl FnMut(u32)) {
        if !self.in_root(p) {
            self.outside.iter().for_each(|&id| f(id));
            return;
        }
        let scale2 = scale * scale;
        let (mut node, mut lo, mut size) = (0usize, self.origin, self.size);
        loop {
            self.nodes[node]
                .spheres
                .iter()
                .filter(|s| s.contains_scaled(p, scale2))
                .for_each(|s| f(s.id));
            let first = self.nodes[node].first_child as usize;
            if first == 0 {
                return;
            }
            size *= 0.5;
            let mid = lo + Vec3::splat(size);
            let i = (p.x >= mid.x) as usize
                | ((p.y >= mid.y) as usize) << 1
                | ((p.z >= mid.z) as usize) << 2;
            lo += child_offset(i) * size;
            node = first + i;
        }
    }

    /// Ids of every record whose sphere may overlap the sphere (`c`, `r`), in the index's order, an
    /// id once per cell that holds it (neighbor clamping takes minima, which repeats do not change;
    /// sorting them away was a fifth of the serial insertion).
    pub(crate) fn query_sphere(&self, c: Vec3, r: f32, out: &mut Vec<u32>) {
        out.clear();
        out.extend_from_slice(&self.outside);
        if c.is_finite() && !r.is_nan() {
            self.query_rec(0, self.origin, self.size, c, r.max(0.0), out);
        }
    }

    fn query_rec(&self, node: usize, lo: Vec3, size: f32, c: Vec3, r: f32, out: &mut Vec<u32>) {
        if dist2_to_box(c, lo, size) > r * r {
            return;
        }
        out.extend(
            self.nodes[node]
                .spheres
                .iter()
                .filter(|s| (c - s.center).length() <= (s.radius + r) * (1.0 + 1e-5))
                .map(|s| s.id),
        );
        let first = self.nodes[node].first_child as usize;
        if first != 0 {
            let half = 0.5 * size;
            for i in 0..8 {
                self.query_rec(first + i, lo + child_offset(i) * half, half, c, r, out);
            }
        }
    }

    /// Heap bytes held by the index.
    pub(crate) fn memory_bytes(&self) -> usize {
        let spheres: usize = self.nodes.iter().map(|n| n.spheres.capacity()).sum();
        self.nodes.capacity() * std::mem::size_of::<Node>()
            + spheres * std::mem::size_of::<Sphere>()
            + self.outside.capacity() * 4
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use photon::sampling::Rng;

    fn rand_vec(rng: &mut Rng, lo: f32, hi: f32) -> Vec3 {
        Vec3::new(rng.uniform(), rng.uniform(), rng.uniform()) * (hi - lo) + Vec3::splat(lo)
    }

    /// Every sphere containing a point is among the point's candidates, including spheres centred
    /// outside the root cube and points outside it; sphere queries find every overlapping sphere.
    #[test]
    fn candidates_superset_of_truth() {
        let mut rng = Rng::new(7);
        let mut tree = Octree::new(Vec3::ZERO, Vec3::splat(10.0));
        let spheres: Vec<(Vec3, f32)> = (0..2000)
            .map(|_| {
                (
                    rand_vec(&mut rng, -1.0, 11.0),
                    0.01 + 2.0 * rng.uniform().powi(3),
                )
            })
            .collect();
        for (i, &(c, r)) in spheres.iter().enumerate() {
            tree.insert(i as u32, c, r);
        }
        let mut out = Vec::new();
        for _ in 0..2000 {
            let p = rand_vec(&mut rng, -1.5, 11.5);
            let mut cand = Vec::new();
            tree.for_each_candidate(p, |id| cand.push(id));
            let n_before = cand.len();
            cand.sort_unstable();
            cand.dedup();
            assert_eq!(cand.len(), n_before, "duplicate candidate");
            for (i, &(c, r)) in spheres.iter().enumerate() {
                if (p - c).length() <= r {
                    assert!(cand.binary_search(&(i as u32)).is_ok(), "missed sphere {i}");
                }
            }
            let qr = 0.5 * rng.uniform();
            tree.query_sphere(p, qr, &mut out);
            out.sort_unstable();
            out.dedup();
            for (i, &(c, r)) in spheres.iter().enumerate() {
                if (p - c).length() < r + qr {
                    assert!(
                        out.binary_search(&(i as u32)).is_ok(),
                        "query missed sphere {i}"
                    );
                }
            }
        }
    }

    /// A shrunk sphere is met only within its new radius, however often it shrinks, and the others
    /// in its cells are untouched.
    #[test]
    fn shrunk_spheres_are_met_within_their_new_radius() {
        let mut tree = Octree::new(Vec3::ZERO, Vec3::splat(10.0));
        let c = Vec3::new(5.0, 5.0, 5.0);
        tree.insert(0, c, 1.0);
        tree.insert(1, c + Vec3::new(0.1, 0.0, 0.0), 1.0);
        let ids = |tree: &Octree, p: Vec3| {
            let mut v = Vec::new();
            tree.for_each_candidate(p, |id| v.push(id));
            v.sort_unstable();
            v
        };
        let at = |d: f32| c + Vec3::new(0.0, d, 0.0);
        assert_eq!(ids(&tree, at(0.8)), [0, 1]);
        let r = tree.shrink(0, c, 1.0, 0.5);
        assert_eq!(ids(&tree, at(0.8)), [1]);
        assert_eq!(ids(&tree, at(0.45)), [0, 1]);
        // A second shrink names the radius the first one returned (its cells); this one moves the
        // sphere two levels down (cells of 0.625 for a diameter of 0.4).
        let r = tree.shrink(0, c, r, 0.2);
        assert_eq!(r, 0.2);
        assert_eq!(ids(&tree, at(0.45)), [1]);
        assert_eq!(ids(&tree, at(0.15)), [0, 1]);
        for d in [-0.19f32, 0.0, 0.19] {
            for axis in [Vec3::X, Vec3::Y, Vec3::Z] {
                assert!(ids(&tree, c + d * axis).contains(&0), "{d} {axis}");
            }
        }
        // Growing is not shrinking, and odd values change nothing.
        assert_eq!(tree.shrink(0, c, r, 0.9), r);
        assert_eq!(tree.shrink(0, c, r, f32::NAN), r);
        assert_eq!(ids(&tree, at(0.45)), [1]);
        assert_eq!(ids(&tree, at(0.15)), [0, 1]);
    }

    #[test]
    fn degenerate_bounds_and_values_do_not_panic() {
        let mut tree = Octree::new(Vec3::splat(f32::NAN), Vec3::ZERO);
        tree.insert(0, Vec3::splat(f32::NAN), 1.0);
        tree.insert(1, Vec3::ZERO, f32::NAN);
        tree.insert(2, Vec3::ZERO, 0.0);
        tree.insert(3, Vec3::ZERO, f32::INFINITY);
        let mut n = 0;
        tree.for_each_candidate(Vec3::splat(0.5), |_| n += 1);
        assert!(n >= 2); // ids 1 and 3 reach everywhere
    }
}
