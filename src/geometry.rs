//! The scene's triangles, surface hits built from Embree's raw hits, and scale-independent ray offsets.

use glam::{Vec2, Vec3};

use crate::accel::embree::RawHit;

#[derive(Clone, Debug)]
pub struct Triangle {
    pub v: [u32; 3],
    pub material: u32,
    /// Unit geometric normal from counter-clockwise winding.
    pub ng: Vec3,
    pub area: f32,
    pub has_normals: bool,
    pub has_uv: bool,
}

/// All triangles of the scene, vertices shared per mesh.
#[derive(Default)]
pub struct Geometry {
    pub positions: Vec<Vec3>,
    /// Per-vertex shading normals (zero where the mesh has none).
    pub normals: Vec<Vec3>,
    pub uvs: Vec<Vec2>,
    pub triangles: Vec<Triangle>,
    /// Triangles dropped at load because their area was zero (or not finite).
    pub n_degenerate: usize,
}

/// A surface point hit by a ray.
#[derive(Clone, Copy, Debug)]
pub struct Hit {
    pub p: Vec3,
    pub t: f32,
    /// Unit geometric normal (winding).
    pub ng: Vec3,
    /// Unit shading normal, oriented to the same side as `ng`.
    pub ns: Vec3,
    pub uv: Vec2,
    pub tri: u32,
    pub material: u32,
}

impl Geometry {
    pub fn hit(&self, origin: Vec3, dir: Vec3, raw: RawHit) -> Hit {
        let tri = &self.triangles[raw.prim as usize];
        let [a, b, c] = tri.v.map(|i| i as usize);
        let (u, v) = (raw.u, raw.v);
        let w = 1.0 - u - v;
        let p_bary = self.positions[a] * w + self.positions[b] * u + self.positions[c] * v;
        // The barycentric point is more accurate than origin + t·dir for long rays.
        let p = if p_bary.is_finite() {
            p_bary
        } else {
            origin + dir * raw.t
        };
        let mut ns = tri.ng;
        if tri.has_normals {
            let n = self.normals[a] * w + self.normals[b] * u + self.normals[c] * v;
            if n.length_squared() > 1e-12 {
                ns = n.normalize();
                if ns.dot(tri.ng) < 0.0 {
                    ns = -ns;
                }
            }
        }
        let uv = if tri.has_uv {
            self.uvs[a] * w + self.uvs[b] * u + self.uvs[c] * v
        } else {
            Vec2::new(u, v)
        };
        Hit {
            p,
            t: raw.t,
            ng: tri.ng,
            ns,
            uv,
            tri: raw.prim,
            material: tri.material,
        }
    }

    /// [`hit`](Self::hit) without the shading normal (`ns` = `ng`) and without texture coordinates (`uv`
    /// holds the barycentrics), at `origin + t·dir`: what a final-gather ray that ends on a diffuse
    /// surface needs (its side, triangle and texel; the texel holds the albedo). Fetches no vertex at
    /// all — the random memory reads that were most of a gather ray's cost besides the ray.
    pub fn hit_flat(&self, origin: Vec3, dir: Vec3, raw: RawHit) -> Hit {
        let tri = &self.triangles[raw.prim as usize];
        let uv = Vec2::new(raw.u, raw.v);
        Hit {
            p: origin + dir * raw.t,
            t: raw.t,
            ng: tri.ng,
            ns: tri.ng,
            uv,
            tri: raw.prim,
            material: tri.material,
        }
    }

    /// Point on triangle `i` at barycentrics (b1, b2).
    pub fn point_on(&self, i: u32, b1: f32, b2: f32) -> Vec3 {
        let t = &self.triangles[i as usize];
        let [a, b, c] = t.v.map(|k| self.positions[k as usize]);
        a * (1.0 - b1 - b2) + b * b1 + c * b2
    }

    /// The side an emissive triangle emits toward: the given vertex normals' side, else the winding.
    pub fn emit_normal(&self, i: u32) -> Vec3 {
        let t = &self.triangles[i as usize];
        if t.has_normals {
            let s: Vec3 = t.v.iter().map(|&k| self.normals[k as usize]).sum();
            if s.dot(t.ng) < 0.0 {
                return -t.ng;
            }
        }
        t.ng
    }

    pub fn bounds(&self) -> (Vec3, Vec3) {
        let mut lo = Vec3::splat(f32::INFINITY);
        let mut hi = Vec3::splat(f32::NEG_INFINITY);
        for t in &self.triangles {
            for &k in &t.v {
                lo = lo.min(self.positions[k as usize]);
                hi = hi.max(self.positions[k as usize]);
            }
        }
        if lo.x > hi.x {
            (Vec3::ZERO, Vec3::ZERO)
        } else {
            (lo, hi)
        }
    }
}

/// Moves a ray origin off the surface along `n` by a few ULPs of its coordinates (Wächter & Binder,
/// "A Fast and Robust Method for Avoiding Self-Intersection", Ray Tracing Gems ch. 6): robust at any
/// scene scale, unlike a fixed epsilon.
pub fn offset_origin(p: Vec3, n: Vec3) -> Vec3 {
    const ORIGIN: f32 = 1.0 / 32.0;
    const FLOAT_SCALE: f32 = 1.0 / 65536.0;
    const INT_SCALE: f32 = 256.0;
    let of_i = (n * INT_SCALE).to_array().map(|x| x as i32);
    let pa = p.to_array();
    // Near the origin the paper moves by a fixed FLOAT_SCALE; in a scene much smaller than 1/32 that is
    // far too much (shadow rays start beyond a light 10 µm under a ceiling), so the fixed step shrinks
    // with the point's own magnitude.
    let float_scale = FLOAT_SCALE * (p.abs().max_element() / ORIGIN).clamp(1e-4, 1.0);
    let mut out = [0.0f32; 3];
    for k in 0..3 {
        let bits = pa[k].to_bits() as i32;
        let moved = f32::from_bits((bits + if pa[k] < 0.0 { -of_i[k] } else { of_i[k] }) as u32);
        out[k] = if pa[k].abs() < ORIGIN {
            pa[k] + float_scale * n.to_array()[k]
        } else {
            moved
        };
    }
    Vec3::from_array(out)
}

/// Origin for a ray leaving `hit` in direction `dir` (offset to the side `dir` goes to).
pub fn spawn(hit: &Hit, dir: Vec3) -> Vec3 {
    let n = if dir.dot(hit.ng) >= 0.0 {
        hit.ng
    } else {
        -hit.ng
    };
    offset_origin(hit.p, n)
}

/// [`spawn`], then a step along `dir` of 10⁻⁵ of the point's magnitude: an origin off the planes of
/// the triangles that meet the hit's triangle at an edge. A point on an edge (the pixel-corner rays
/// of a centred camera meet a box's edges exactly) lies on its neighbour's plane, and a ray leaving
/// it into the room met that neighbour at t = 0 from behind, reading the light of its other side.
pub fn spawn_clear(hit: &Hit, dir: Vec3) -> Vec3 {
    let o = spawn(hit, dir);
    o + dir * (1e-5 * o.abs().max_element())
}

/// Shading frame at a hit seen from direction `wo`: the shading normal turned toward `wo`, and
/// whether `wo` is on the side the geometric normal points to.
#[derive(Clone, Copy, Debug)]
pub struct Frame {
    /// The shading normal: a bump or normal map's where the material has one ([`Frame::bumped`]).
    pub n: Vec3,
    /// The shading normal without the bump (`n` itself on a surface without one): what the
    /// irradiance cache places, spaces and weighs its records by, so that bumps do not multiply
    /// records (each record's rotational gradient turns its irradiance to `n` at lookup).
    pub smooth: Vec3,
    /// Geometric normal turned toward `wo`.
    pub ng: Vec3,
    pub front: bool,
}

impl Frame {
    pub fn new(hit: &Hit, wo: Vec3) -> Frame {
        let front = wo.dot(hit.ng) >= 0.0;
        let s = if front { 1.0 } else { -1.0 };
        Frame {
            n: hit.ns * s,
            smooth: hit.ns * s,
            ng: hit.ng * s,
            front,
        }
    }

    /// The frame with shading normal `n_bumped` (a unit vector on the side of the hit's `ns`), turned
    /// toward `wo` as the smooth one is.
    pub fn bumped(self, n_bumped: Vec3) -> Frame {
        let s = if self.front { 1.0 } else { -1.0 };
        Frame {
            n: n_bumped * s,
            ..self
        }
    }

    /// Whether a bump turned the shading normal.
    pub fn is_bumped(&self) -> bool {
        self.n != self.smooth
    }

    /// Reflection must stay on `wo`'s geometric side, or light leaks through shading normals.
    pub fn same_side(&self, wi: Vec3) -> bool {
        wi.dot(self.ng) > 0.0
    }
}
