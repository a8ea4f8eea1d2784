//! Whether a pixel's light can have changed for a moved mesh: the ends of its shadow rays, a sphere
//! against a cone of rays, and spheres binned in a lattice to find those near a point.

use glam::Vec3;

use crate::scene::Scene;

/// Where a light's shadow rays from a point end.
#[derive(Clone, Copy)]
pub(super) enum ShadowEnd {
    /// A ball every shadow ray ends in (centre, radius): all emissive triangles as one, a point or
    /// spot light.
    Ball(Vec3, f32),
    /// Far along a directional light's reverse direction from the point itself: its shadow rays are
    /// parallel (this offset).
    Along(Vec3),
}

impl ShadowEnd {
    /// The ball the shadow rays from `p` end in.
    pub(super) fn seen_from(self, p: Vec3) -> (Vec3, f32) {
        match self {
            ShadowEnd::Ball(c, r) => (c, r),
            ShadowEnd::Along(offset) => (p + offset, 0.0),
        }
    }
}

/// Where the lights' shadow rays end.
pub(super) fn shadow_ends(scene: &Scene) -> Vec<ShadowEnd> {
    let mut out = Vec::new();
    let (lo, hi) = scene.bounds;
    let far = (hi - lo).length() * 4.0 + 1.0;
    let mut area: Option<(Vec3, Vec3)> = None;
    for l in &scene.lights.lights {
        match *l {
            crate::light::Light::Area { tri, .. } => {
                for k in scene.geometry.triangles[tri as usize].v {
                    let p = scene.geometry.positions[k as usize];
                    area = Some(area.map_or((p, p), |(a, b)| (a.min(p), b.max(p))));
                }
            }
            crate::light::Light::Point { pos, .. } | crate::light::Light::Spot { pos, .. } => {
                out.push(ShadowEnd::Ball(pos, 0.0))
            }
            crate::light::Light::Directional { dir, .. } => out.push(ShadowEnd::Along(-dir * far)),
        }
    }
    if let Some((a, b)) = area {
        out.push(ShadowEnd::Ball((a + b) * 0.5, (b - a).length() * 0.5));
    }
    out
}

/// Whether the sphere (c, r) meets the cone from apex `p` to the ball (c_l, r_l): the rays from a
/// point to a light's ball (shadow rays), or a pixel's camera rays. The cone's cross-section at
/// t ∈ [0, 1] is the ball (p + t (c_l − p), t r_l): narrow at `p`, as wide as the ball at its end (a
/// mover near the floor and a light at the ceiling shade only the floor points whose narrow end of the
/// cone it crosses). The sphere meets it when g(t) = |c − p − t d| − t r_l falls below r for some t; g
/// is convex, its minimum found in closed form.
pub(super) fn sphere_meets_cone(c: Vec3, r: f32, p: Vec3, c_l: Vec3, r_l: f32) -> bool {
    let d = c_l - p;
    let len = d.length();
    if !(len > 0.0) {
        return c.distance(p) < r + r_l;
    }
    let w = c - p;
    let along = w.dot(d) / len;
    let across = (w.length_squared() - along * along).max(0.0).sqrt();
    let k = r_l / len;
    // g'(t) = 0 where (along − t len) = −k across / √(1 − k²); past k ≥ 1 g only falls.
    let t = if k >= 1.0 {
        1.0
    } else {
        ((along + k * across / (1.0 - k * k).sqrt()) / len).clamp(0.0, 1.0)
    };
    w.distance(d * t) - t * r_l < r
}

/// Spheres binned in a uniform lattice over their bounds, each in every cell its bounding box meets:
/// the spheres that may hold a point are those of its cell.
pub(super) struct SphereBins {
    pub(super) lo: Vec3,
    pub(super) cell: f32,
    pub(super) dims: [usize; 3],
    /// Per cell, its spheres' slice of `ids` (`start[c]..start[c + 1]`).
    pub(super) start: Vec<u32>,
    pub(super) ids: Vec<u32>,
}

/// Cells of a [`SphereBins`] lattice, at most.
pub(super) const MAX_BIN_CELLS: f32 = 32_768.0;

impl SphereBins {
    pub(super) fn new(spheres: impl Iterator<Item = (Vec3, f32)>) -> SphereBins {
        let spheres: Vec<(Vec3, f32)> = spheres
            .filter(|(c, r)| c.is_finite() && r.is_finite())
            .collect();
        let (mut lo, mut hi) = (Vec3::splat(f32::INFINITY), Vec3::splat(f32::NEG_INFINITY));
        for &(c, r) in &spheres {
            lo = lo.min(c - r);
            hi = hi.max(c + r);
        }
        let extent = (hi - lo).max(Vec3::splat(1e-6));
        // Cells about the mean sphere's diameter, fewer than MAX_BIN_CELLS.
        let mean = spheres.iter().map(|s| 2.0 * s.1).sum::<f32>() / spheres.len().max(1) as f32;
        let cell = mean
            .max((extent.x * extent.y * extent.z / MAX_BIN_CELLS).cbrt())
            .max(1e-6);
        let dims = (extent / cell).ceil().max(Vec3::ONE).as_uvec3();
        let dims = [dims.x as usize, dims.y as usize, dims.z as usize];
        let cell_of = |p: Vec3| {
            let c = ((p - lo) / cell).floor().max(Vec3::ZERO).as_uvec3();
            [
                (c.x as usize).min(dims[0] - 1),
                (c.y as usize).min(dims[1] - 1),
                (c.z as usize).min(dims[2] - 1),
            ]
        };
        let index = |c: [usize; 3]| (c[2] * dims[1] + c[1]) * dims[0] + c[0];
        let mut per_cell: Vec<Vec<u32>> = vec![Vec::new(); dims[0] * dims[1] * dims[2]];
        for (id, &(c, r)) in spheres.iter().enumerate() {
            let (a, b) = (cell_of(c - r), cell_of(c + r));
            for z in a[2]..=b[2] {
                for y in a[1]..=b[1] {
                    for x in a[0]..=b[0] {
                        per_cell[index([x, y, z])].push(id as u32);
                    }
                }
            }
        }
        let mut start = Vec::with_capacity(per_cell.len() + 1);
        let mut ids = Vec::new();
        for c in per_cell {
            start.push(ids.len() as u32);
            ids.extend(c);
        }
        start.push(ids.len() as u32);
        SphereBins {
            lo,
            cell,
            dims,
            start,
            ids,
        }
    }

    /// Whether `test` holds for one of the spheres whose bounding box may hold `p`.
    pub(super) fn any_near(&self, p: Vec3, mut test: impl FnMut(u32) -> bool) -> bool {
        let f = (p - self.lo) / self.cell;
        let top = Vec3::new(
            self.dims[0] as f32,
            self.dims[1] as f32,
            self.dims[2] as f32,
        );
        if !(f.cmpge(Vec3::ZERO).all() && f.cmple(top).all()) {
            return false;
        }
        let c = f.min(top - 1.0).as_uvec3();
        let i = (c.z as usize * self.dims[1] + c.y as usize) * self.dims[0] + c.x as usize;
        self.ids[self.start[i] as usize..self.start[i + 1] as usize]
            .iter()
            .any(|&id| test(id))
    }
}
