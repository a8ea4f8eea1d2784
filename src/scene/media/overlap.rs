//! Refuses two boundary meshes of different media that overlap in part (neither inside the other, yet
//! not only touching). The medium on each side of a face is found face by face, so the space inside
//! both would be filled by one medium or the other depending on which face a ray entered it through.
//!
//! Surfaces are not intersected: where the meshes share faces, edges or planes (two boxes flush with
//! each other, the usual way media touch) a crossing test cannot tell touching from crossing. Instead,
//! points are classified as inside or outside each mesh: a point inside both, one inside the first only
//! and one inside the second only prove the overlap. The points lie just inside each mesh's surface (a
//! partial overlap always takes in some of each surface) and over each bounding box. A point is
//! classified only when two opposite parity rays agree and neither starts at a surface, so a
//! misclassified point — the only way to a false refusal — needs two rays wrong at once. What this
//! can miss is an overlap too small for the points to land in, and one thinner than 10⁻⁴ of the
//! meshes' size, which counts as touching (exported meshes meant to share a face are seldom exact).

use glam::Vec3;
use rayon::prelude::*;

use super::{Boundary, PARITY_DIR};
use crate::accel::embree::Bvh;
use crate::error::Result;
use crate::geometry::Geometry;
use crate::scene::context::Ctx;
use crate::scene::file::SceneFile;

/// Points per boundary mesh: half just inside its surface, half over its bounding box.
const SAMPLES: u64 = 512;
/// Crossings a parity ray may count before the point is left unclassified.
const MAX_CROSSINGS: usize = 1024;
/// Points over all pairs of meshes whose bounding boxes overlap: beyond 2048 such pairs each gets
/// fewer, keeping the check's time bounded.
const POINT_BUDGET: u64 = 1 << 20;

/// One boundary mesh on its own: a BVH of its triangles alone (a BVH of every boundary reports only
/// one of two coincident faces, which breaks the parity of the other mesh), its bounding box and what
/// places points just inside its surface.
struct Solid {
    bvh: Bvh,
    lo: Vec3,
    hi: Vec3,
    /// Points closer to a surface than this along a parity ray are not classified.
    eps: f32,
    /// Per triangle: its corners and its unit normal pointing into the mesh.
    tris: Vec<([Vec3; 3], Vec3)>,
    /// The triangles' cumulative areas, for choosing one in proportion to its area.
    cdf: Vec<f64>,
}

impl Solid {
    fn new(geo: &Geometry, b: &Boundary) -> Result<Solid> {
        let mut positions = Vec::new();
        let mut index = std::collections::HashMap::new();
        let tris = &geo.triangles[b.tris.clone()];
        let indices: Vec<[u32; 3]> = tris
            .iter()
            .map(|t| {
                t.v.map(|k| {
                    *index.entry(k).or_insert_with(|| {
                        positions.push(geo.positions[k as usize]);
                        (positions.len() - 1) as u32
                    })
                })
            })
            .collect();
        let (lo, hi) = positions
            .iter()
            .fold((Vec3::INFINITY, Vec3::NEG_INFINITY), |(lo, hi), &p| {
                (lo.min(p), hi.max(p))
            });
        let scale = (hi - lo)
            .length()
            .max(lo.abs().max(hi.abs()).max_element() * 1e-2);
        let inward = if b.outward { -1.0 } else { 1.0 };
        let cdf = tris
            .iter()
            .scan(0.0f64, |sum, t| {
                *sum += t.area as f64;
                Some(*sum)
            })
            .collect();
        Ok(Solid {
            bvh: Bvh::build(&positions, &indices)?,
            lo,
            hi,
            eps: 1e-4 * scale,
            tris: tris
                .iter()
                .map(|t| (t.v.map(|k| geo.positions[k as usize]), t.ng * inward))
                .collect(),
            cdf,
        })
    }

    /// Whether `p` is inside; `None` when that cannot be told for sure.
    fn contains(&self, p: Vec3) -> Option<bool> {
        if p.cmplt(self.lo).any() || p.cmpgt(self.hi).any() {
            return Some(false);
        }
        let d = PARITY_DIR.normalize();
        let (a, t_a) = self.parity(p, d)?;
        let (b, t_b) = self.parity(p, -d)?;
        (a == b && t_a.min(t_b) > self.eps).then_some(a)
    }

    /// The parity of the crossings along the ray from `p` in `d`, and the distance to the first;
    /// `None` past [`MAX_CROSSINGS`].
    fn parity(&self, p: Vec3, d: Vec3) -> Option<(bool, f32)> {
        let (mut inside, mut first, mut tnear) = (false, f32::INFINITY, 0.0f32);
        for _ in 0..=MAX_CROSSINGS {
            let Some(hit) = self.bvh.intersect_range(p, d, tnear, f32::INFINITY) else {
                return Some((inside, first));
            };
            inside = !inside;
            first = first.min(hit.t);
            tnear = crate::scene::past(hit.t, p);
        }
        None
    }

    /// The `i`-th point: for even `i` just inside the surface (twice the distance below which a point
    /// is not classified), for odd `i` in the bounding box. Shifted Halton points: not on a grid that
    /// axis-aligned faces could fall on.
    fn point(&self, i: u64) -> Vec3 {
        let h = |dim| photon::sampling::halton(i / 2 + 1, dim, 0x006f_7665_726c_6170);
        let (u, v, w) = (h(0), h(1), h(2));
        if i % 2 == 1 {
            return self.lo + (self.hi - self.lo) * Vec3::new(u, v, w);
        }
        let total = self.cdf.last().copied().unwrap_or(0.0);
        let k = self
            .cdf
            .partition_point(|&c| c < u as f64 * total)
            .min(self.tris.len() - 1);
        let ([a, b, c], inward) = self.tris[k];
        let (s, t) = (v.sqrt(), w);
        a * (1.0 - s) + b * (s * (1.0 - t)) + c * (s * t) + inward * (2.0 * self.eps)
    }
}

/// Refuses, at the later mesh's `interior` line, two boundaries of different media that overlap in
/// part.
pub(super) fn check_overlaps(
    cx: &Ctx,
    desc: &SceneFile,
    geo: &Geometry,
    boundaries: &[Boundary],
) -> Result<()> {
    let boxes: Vec<(Vec3, Vec3)> = boundaries
        .iter()
        .map(|b| {
            geo.triangles[b.tris.clone()]
                .iter()
                .flat_map(|t| t.v.map(|k| geo.positions[k as usize]))
                .fold((Vec3::INFINITY, Vec3::NEG_INFINITY), |(lo, hi), p| {
                    (lo.min(p), hi.max(p))
                })
        })
        .collect();
    let pairs: Vec<(usize, usize)> = (0..boundaries.len())
        .flat_map(|j| (0..j).map(move |i| (i, j)))
        .filter(|&(i, j)| {
            let ((a_lo, a_hi), (b_lo, b_hi)) = (boxes[i], boxes[j]);
            boundaries[i].medium != boundaries[j].medium
                && a_lo.cmplt(b_hi).all()
                && b_lo.cmplt(a_hi).all()
        })
        .collect();
    if pairs.is_empty() {
        return Ok(());
    }
    // Only the meshes in some pair get a BVH of their own.
    let mut solids: Vec<Option<Solid>> = (0..boundaries.len()).map(|_| None).collect();
    for &(i, j) in &pairs {
        for b in [i, j] {
            if solids[b].is_none() {
                solids[b] = Some(Solid::new(geo, &boundaries[b])?);
            }
        }
    }
    let solid = |b: usize| solids[b].as_ref().expect("built for every pair");
    let n = (POINT_BUDGET / pairs.len() as u64).clamp(4, SAMPLES);
    let overlapping = pairs
        .par_iter()
        .find_first(|&&(i, j)| overlap_in_part(solid(i), solid(j), n));
    let Some(&(i, j)) = overlapping else {
        return Ok(());
    };
    let name = |b: usize| &desc.mesh[boundaries[b].mesh].obj;
    Err(cx.err(
        "mesh",
        boundaries[j].mesh,
        "interior",
        format!(
            "'{}' and the boundary '{}' before it overlap in part: the space inside both would be \
             filled by either medium, depending on where a ray enters it (one must lie inside the \
             other, or they may only touch)",
            name(j),
            name(i)
        ),
    ))
}

/// Whether, of `n` points of each mesh, some lie inside both, some inside `a` only and some inside `b`
/// only.
fn overlap_in_part(a: &Solid, b: &Solid, n: u64) -> bool {
    let (mut both, mut a_only, mut b_only) = (false, false, false);
    for k in 0..2 * n {
        let p = if k < n { a.point(k) } else { b.point(k - n) };
        match (a.contains(p), b.contains(p)) {
            (Some(true), Some(true)) => both = true,
            (Some(true), Some(false)) => a_only = true,
            (Some(false), Some(true)) => b_only = true,
            _ => {}
        }
        if both && a_only && b_only {
            return true;
        }
    }
    false
}
