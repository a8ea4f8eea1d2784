//! Per-vertex tangent frames for normal maps, as MikkTSpace (Blender's baker and shader) makes them.
//!
//! A normal map baked against per-vertex tangents shows facets on a smooth mesh when it is read in each
//! triangle's own ∂p/∂u frame. At load, for the meshes whose materials have a normal map, each vertex
//! gets the average of its faces' tangents: corners are welded by the value of their position, normal
//! and texture coordinates (as MikkTSpace welds them, so a seam of the mapping or of the normals splits
//! a vertex and nothing else does), and at each welded vertex the faces whose mapping has the same
//! handedness are averaged apart from those of the other (MikkTSpace's split where the bitangent sign
//! differs). A face's share is its ∂p/∂u made orthogonal to the vertex normal, normalised, and weighted
//! by the corner's angle in the plane of that normal, as MikkTSpace weights it. Every face of such a
//! mesh contributes, whatever its material, as Blender's tangents span a whole mesh.
//!
//! MikkTSpace groups a vertex's faces of one handedness only where they are connected around it; this
//! joins all of them (the same on a manifold fan). Faces whose mapping is degenerate add nothing and
//! keep their normal, as they did with the per-face frame.

use std::collections::HashMap;
use std::ops::Range;

use glam::{Vec3, Vec4};

use crate::bump::uv_tangents;
use crate::geometry::{Geometry, Hit};

/// The tangents of the triangles of normal-mapped materials: per corner a unit tangent orthogonal to
/// the corner's normal, per triangle the bitangent's sign.
#[derive(Default)]
pub struct Tangents {
    /// Per triangle of the scene, its row in `frames`; [`NONE`] for one that has none. Empty when no
    /// triangle has tangents.
    slot: Vec<u32>,
    /// Per triangle with tangents: its corners' tangents (xyz) and the sign (w) that makes the
    /// bitangent `w · n × t` for the hit's shading normal `n` (on the winding's side).
    frames: Vec<[Vec4; 3]>,
}

const NONE: u32 = u32::MAX;

impl Tangents {
    /// The tangents of every mesh in `meshes` (ranges of triangles of `g`) that has a triangle whose
    /// material `wants(material)`, stored for those triangles only.
    pub fn new(g: &Geometry, meshes: &[Range<usize>], wants: impl Fn(u32) -> bool) -> Tangents {
        let mut out = Tangents::default();
        for range in meshes {
            if g.triangles[range.clone()].iter().any(|t| wants(t.material)) {
                out.add_mesh(g, range.clone(), &wants);
            }
        }
        out
    }

    /// The tangent at `hit` (its corners' interpolated by the barycentrics of its point) and the
    /// bitangent's sign; `None` for a triangle without tangents.
    pub fn at(&self, g: &Geometry, hit: &Hit) -> Option<(Vec3, f32)> {
        let k = *self.slot.get(hit.tri as usize)?;
        let f = self.frames.get(k as usize)?;
        let [b0, b1, b2] = barycentrics(g, hit.tri, hit.p);
        let t = f[0].truncate() * b0 + f[1].truncate() * b1 + f[2].truncate() * b2;
        Some((t, f[0].w))
    }

    /// Accumulates the corner tangents of the triangles `range` of `g` and stores those of the ones
    /// whose material `wants` them.
    fn add_mesh(&mut self, g: &Geometry, range: Range<usize>, wants: &impl Fn(u32) -> bool) {
        // Welded vertex of each corner, and each triangle's ∂p/∂u and handedness (+1, −1).
        let mut weld: HashMap<[u32; 8], u32> = HashMap::new();
        let mut corners: Vec<[u32; 3]> = Vec::with_capacity(range.len());
        let mut faces: Vec<Option<(Vec3, bool)>> = Vec::with_capacity(range.len());
        for i in range.clone() {
            let tri = &g.triangles[i];
            corners.push(tri.v.map(|k| {
                let n = corner_normal(g, i, k);
                let key = vertex_key(g.positions[k as usize], n, g.uvs[k as usize]);
                let next = weld.len() as u32;
                *weld.entry(key).or_insert(next)
            }));
            faces.push(uv_tangents(g, i as u32).map(|(dpdu, dpdv)| {
                let right_handed = dpdu.cross(dpdv).dot(tri.ng) >= 0.0;
                (dpdu, right_handed)
            }));
        }
        // Per welded vertex, the angle-weighted sums of its left- and right-handed faces' tangents.
        let mut sums = vec![[Vec3::ZERO; 2]; weld.len()];
        for (j, i) in range.clone().enumerate() {
            let Some((dpdu, right)) = faces[j] else {
                continue;
            };
            for c in 0..3 {
                let v = g.triangles[i].v;
                let n = corner_normal(g, i, v[c]);
                let share = on_plane(dpdu, n) * corner_angle(g, v, c, n);
                sums[corners[j][c] as usize][right as usize] += share;
            }
        }
        if self.slot.is_empty() {
            self.slot = vec![NONE; g.triangles.len()];
        }
        for (j, i) in range.enumerate() {
            let tri = &g.triangles[i];
            let Some((dpdu, right)) = faces[j].filter(|_| wants(tri.material)) else {
                continue;
            };
            // The sign for the hit's normal, which is turned to the winding's side: flipped where the
            // vertex normals point the other way, so that the bitangent is MikkTSpace's.
            let n_sum: Vec3 = (0..3).map(|c| corner_normal(g, i, tri.v[c])).sum();
            let flipped = n_sum.dot(tri.ng) < 0.0;
            let sign = if right != flipped { 1.0 } else { -1.0 };
            let frame = std::array::from_fn(|c| {
                let n = corner_normal(g, i, tri.v[c]);
                let sum = sums[corners[j][c] as usize][right as usize];
                let t = sum.normalize_or_zero();
                // A vertex whose faces' tangents cancel keeps this face's own.
                let t = if t == Vec3::ZERO {
                    on_plane(dpdu, n)
                } else {
                    t
                };
                t.extend(sign)
            });
            self.slot[i] = self.frames.len() as u32;
            self.frames.push(frame);
        }
    }
}

/// The normal at corner `k` of triangle `i`: the vertex normal where the triangle has them (and it is
/// not zero), else the face's.
fn corner_normal(g: &Geometry, i: usize, k: u32) -> Vec3 {
    let t = &g.triangles[i];
    let n = g.normals[k as usize];
    if t.has_normals && n != Vec3::ZERO {
        n
    } else {
        t.ng
    }
}

/// The bits of a vertex's position, normal and texture coordinates: equal keys are one vertex.
fn vertex_key(p: Vec3, n: Vec3, uv: glam::Vec2) -> [u32; 8] {
    // +0 and −0 are one value.
    let b = |x: f32| (x + 0.0).to_bits();
    [
        b(p.x),
        b(p.y),
        b(p.z),
        b(n.x),
        b(n.y),
        b(n.z),
        b(uv.x),
        b(uv.y),
    ]
}

/// `v` made orthogonal to the unit vector `n` and normalised (zero where it is parallel to `n`).
fn on_plane(v: Vec3, n: Vec3) -> Vec3 {
    (v - n * n.dot(v)).normalize_or_zero()
}

/// The angle at corner `c` of the triangle with vertices `v`, between its two edges projected onto
/// the plane orthogonal to `n`.
fn corner_angle(g: &Geometry, v: [u32; 3], c: usize, n: Vec3) -> f32 {
    let p = |k: usize| g.positions[v[k % 3] as usize];
    let (e1, e2) = (on_plane(p(c + 1) - p(c), n), on_plane(p(c + 2) - p(c), n));
    e1.dot(e2).clamp(-1.0, 1.0).acos()
}

/// The barycentric weights of the corners of triangle `tri` at `p` (on its plane or near it).
fn barycentrics(g: &Geometry, tri: u32, p: Vec3) -> [f32; 3] {
    let [a, b, c] = g.triangles[tri as usize].v.map(|k| g.positions[k as usize]);
    let (e1, e2, d) = (b - a, c - a, p - a);
    let (d00, d01, d11) = (e1.dot(e1), e1.dot(e2), e2.dot(e2));
    let (d20, d21) = (d.dot(e1), d.dot(e2));
    let det = d00 * d11 - d01 * d01;
    if !(det > 0.0) {
        return [1.0 / 3.0; 3];
    }
    let w1 = (d11 * d20 - d01 * d21) / det;
    let w2 = (d00 * d21 - d01 * d20) / det;
    [1.0 - w1 - w2, w1, w2]
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::geometry::Triangle;
    use glam::Vec2;

    /// A strip of `n` quads bent around the z axis (a quarter of a cylinder of radius 1, u around it,
    /// v along z), smooth normals; `mirror` maps the second half with u running backwards.
    fn bent_strip(n: usize, mirror: bool) -> Geometry {
        let mut g = Geometry::default();
        for i in 0..=n {
            let a = std::f32::consts::FRAC_PI_2 * i as f32 / n as f32;
            let u = i as f32 / n as f32;
            for z in [0.0, 1.0] {
                g.positions.push(Vec3::new(a.cos(), a.sin(), z));
                g.normals.push(Vec3::new(a.cos(), a.sin(), 0.0));
                g.uvs
                    .push(Vec2::new(if mirror && i > n / 2 { 1.0 - u } else { u }, z));
            }
        }
        for i in 0..n as u32 {
            let [a, b, c, d] = [2 * i, 2 * i + 2, 2 * i + 3, 2 * i + 1];
            for v in [[a, b, c], [a, c, d]] {
                let [p0, p1, p2] = v.map(|k| g.positions[k as usize]);
                let cross = (p1 - p0).cross(p2 - p0);
                g.triangles.push(Triangle {
                    v,
                    material: 0,
                    ng: cross.normalize(),
                    area: 0.5 * cross.length(),
                    has_normals: true,
                    has_uv: true,
                });
            }
        }
        g
    }

    /// The strip as one mesh.
    fn whole(g: &Geometry) -> Vec<Range<usize>> {
        std::iter::once(0..g.triangles.len()).collect()
    }

    fn hit_at(g: &Geometry, tri: u32, w: [f32; 3]) -> Hit {
        let [a, b, c] = g.triangles[tri as usize].v.map(|k| g.positions[k as usize]);
        let t = &g.triangles[tri as usize];
        Hit {
            p: a * w[0] + b * w[1] + c * w[2],
            t: 1.0,
            ng: t.ng,
            ns: t.ng,
            uv: Vec2::ZERO,
            tri,
            material: 0,
        }
    }

    /// At each vertex the tangent is the circle's direction there (orthogonal to the normal), the
    /// same from both quads that share it.
    #[test]
    fn vertex_tangents_follow_the_smooth_surface() {
        let n = 6;
        let g = bent_strip(n, false);
        let t = Tangents::new(&g, &whole(&g), |_| true);
        for i in 1..n as u32 {
            // Vertex 2i (angle a_i) is corner 1 of triangle 2(i−1) and corner 0 of triangle 2i.
            let a = std::f32::consts::FRAC_PI_2 * i as f32 / n as f32;
            let want = Vec3::new(-a.sin(), a.cos(), 0.0);
            let (left, s1) = t.at(&g, &hit_at(&g, 2 * (i - 1), [0.0, 1.0, 0.0])).unwrap();
            let (right, s2) = t.at(&g, &hit_at(&g, 2 * i, [1.0, 0.0, 0.0])).unwrap();
            assert!((left - want).length() < 1e-5, "{left} {want}");
            assert!((right - want).length() < 1e-5, "{right} {want}");
            assert_eq!((s1, s2), (1.0, 1.0));
        }
    }

    /// Where the mapping mirrors, the vertex splits: each side keeps its own tangent and sign.
    #[test]
    fn a_mirrored_mapping_splits_the_vertex_by_its_sign() {
        let n = 6;
        let g = bent_strip(n, true);
        let t = Tangents::new(&g, &whole(&g), |_| true);
        // Vertex i = n/2, where u turns back, is one vertex of a right- and a left-handed quad.
        let i = n as u32 / 2;
        let (left, s1) = t.at(&g, &hit_at(&g, 2 * (i - 1), [0.0, 1.0, 0.0])).unwrap();
        let (right, s2) = t.at(&g, &hit_at(&g, 2 * i, [1.0, 0.0, 0.0])).unwrap();
        assert_eq!((s1, s2), (1.0, -1.0));
        assert!((left + right).length() < 1e-5, "{left} {right}");
        assert!((left.length() - 1.0).abs() < 1e-5);
    }

    /// Only meshes with a wanted material get tangents, and only their wanted triangles are stored.
    #[test]
    fn tangents_only_where_wanted() {
        let g = bent_strip(2, false);
        assert!(Tangents::new(&g, &whole(&g), |_| false).frames.is_empty());
        let t = Tangents::new(&g, &[0..2, 2..4], |_| true);
        assert_eq!(t.frames.len(), 4);
        let h = hit_at(&g, 1, [0.2, 0.3, 0.5]);
        assert!(t.at(&g, &h).is_some());
    }
}
