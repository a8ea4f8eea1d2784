//! The volume photon map's in-scattered light for final-gather rays: records created lazily at the
//! points of a lattice over the media and interpolated between the eight around a point with gradient
//! extrapolation (so that a record is a function of its lattice point alone and images do not depend
//! on the thread count). A lattice point outside the media, or inside an occluder, has no record: its
//! kernel would hold the light of the medium beyond a wall, read low, and the reads near every wall
//! (where final-gather rays start) would blend it in; the reads weigh the records that are there and
//! on their side of the occluders near them ([`LatticeRecord`]). Camera rays read the adaptive media radiance cache instead (`media_cache`,
//! Jarosz, Donner, Zwicker & Jensen 2008); both use this module's estimate.
//!
//! A record holds, from a smooth-kernel estimate over all volume photons within the k-th neighbour's
//! distance r (biweight kernel K(u) = (1 − u²)², u = distance / r), the in-scattered power per volume
//! and its first moment in direction, Σ K·ΔΦ and Σ K·ΔΦ ωi (normalised): the phase function to first
//! order, p ≈ (1 + 3g cos θ)/(4π). Its gradient is the kernel's derivative at fixed r, exact for the
//! estimate (checked against finite differences in the tests).

use std::sync::OnceLock;

use glam::{IVec3, UVec3, Vec3};
use photon::PhotonMap;

/// Most records in the lattice (the spacing grows to stay under it).
pub const MAX_RECORDS: u64 = 1 << 18;

/// One record: `s[m]` are the moments (0: power, 1–3: power × ωi.x, y, z) per unit volume;
/// `grad[m][axis]` their derivatives.
#[derive(Clone, Copy, Debug, Default, PartialEq)]
pub struct MediaRecord {
    pub s: [Vec3; 4],
    pub grad: [[Vec3; 3]; 4],
}

/// Occluder planes a [`LatticeRecord`] keeps, at most.
pub const LATTICE_WALLS: usize = 4;

/// A lattice record and the planes of the occluders near its point (unit normal facing away from the
/// point, distance; nearest first, the distance infinite past the last): a read from beyond one of
/// them — the other side of a glass wall or a column — leaves the record out.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct LatticeRecord {
    pub rec: MediaRecord,
    pub walls: [(Vec3, f32); LATTICE_WALLS],
}

impl LatticeRecord {
    /// Whether a point `offset` from the record's lies on its side of every occluder it keeps.
    fn reaches(&self, offset: Vec3) -> bool {
        self.walls.iter().all(|&(n, h)| n.dot(offset) <= h)
    }
}

/// The sets of photons an estimate sums.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Photons {
    /// Every volume photon (what a final-gather ray sees: all light the medium scatters).
    All,
    /// Photons that scattered before (multiple scattering, for camera rays).
    NotDirect,
    /// Photons that scattered before at a diffuse surface or in a medium: camera rays' multiple
    /// scattering when the volume caustic map holds the L S+ V ones.
    Indirect,
}

pub struct VolumeGrid {
    lo: Vec3,
    cell: f32,
    dims: UVec3,
    all: Vec<OnceLock<Option<LatticeRecord>>>,
    /// What the centre of each cell of a coarser lattice sees (measured lazily, for
    /// [`VolumeGrid::surroundings`]), and that lattice's cell size and dimensions.
    seen: Vec<OnceLock<Seen>>,
    seen_cell: f32,
    seen_dims: UVec3,
    /// Extrapolate each record by its gradient (`[render.icache] media_gradients`).
    gradients: bool,
}

impl VolumeGrid {
    /// A lattice over `bounds` with records about half the estimate's radius cap apart (about the mean
    /// k-NN radius). A coarser lattice is faster and fine for smooth fog, but a narrow beam and its
    /// volume caustic come out too bright: a lattice cannot be coarse where the light is concentrated.
    pub fn new(bounds: (Vec3, Vec3), max_radius: f32, gradients: bool) -> VolumeGrid {
        let extent = (bounds.1 - bounds.0).max(Vec3::splat(1e-6));
        let mut cell = (0.5 * max_radius).max(extent.max_element() * 1e-3);
        let dims = loop {
            let d = (extent / cell).ceil().as_uvec3().max(UVec3::ONE);
            if (d.x as u64) * (d.y as u64) * (d.z as u64) <= MAX_RECORDS {
                break d;
            }
            cell *= 1.25;
        };
        let n = (dims.x * dims.y * dims.z) as usize;
        let all = (0..n).map(|_| OnceLock::new()).collect();
        let (seen_cell, seen_dims) = seen_lattice(extent, max_radius);
        let seen_n = (seen_dims.x * seen_dims.y * seen_dims.z) as usize;
        VolumeGrid {
            lo: bounds.0,
            cell,
            dims,
            all,
            seen: (0..seen_n).map(|_| OnceLock::new()).collect(),
            seen_cell,
            seen_dims,
            gradients,
        }
    }

    /// The lattice's cell size.
    pub fn cell(&self) -> f32 {
        self.cell
    }

    /// σs·Li toward a ray travelling along `d` at `x` in a medium of asymmetry `g`: all the light the
    /// medium scatters (for final-gather rays). `record(p)` makes the record at lattice point p
    /// (`None` where p is outside the media or sees no photon).
    pub fn radiance(
        &self,
        x: Vec3,
        d: Vec3,
        g: f32,
        record: &dyn Fn(Vec3) -> Option<LatticeRecord>,
    ) -> Vec3 {
        phase_moments(self.interpolate(x, record), d, g)
    }

    /// The moments at `x`: the records among the eight lattice points around it that `x` is not
    /// beyond an occluder from (all of them if it is beyond every one's), trilinearly weighted (the
    /// weights of those used summed to one), each extrapolated to `x` by its gradient.
    fn interpolate(&self, x: Vec3, record: &dyn Fn(Vec3) -> Option<LatticeRecord>) -> [Vec3; 4] {
        let f = (x - self.lo) / self.cell - 0.5;
        let max = self.dims.as_ivec3() - IVec3::ONE;
        let base = f.floor().as_ivec3();
        let t = (f - base.as_vec3()).clamp(Vec3::ZERO, Vec3::ONE);
        // [0]: the records `x` reaches; [1]: all there.
        let mut out = [[Vec3::ZERO; 4]; 2];
        let mut weight = [0.0; 2];
        for corner in 0..8 {
            let o = IVec3::new(corner & 1, (corner >> 1) & 1, (corner >> 2) & 1);
            let c = (base + o).clamp(IVec3::ZERO, max);
            let w = (if o.x == 1 { t.x } else { 1.0 - t.x })
                * (if o.y == 1 { t.y } else { 1.0 - t.y })
                * (if o.z == 1 { t.z } else { 1.0 - t.z });
            if w == 0.0 {
                continue;
            }
            let centre = self.lo + (c.as_vec3() + 0.5) * self.cell;
            let Some(lr) = self.record(c.as_uvec3(), centre, record) else {
                continue;
            };
            let dx = x - centre;
            let reached = lr.reaches(dx);
            for m in 0..4 {
                let mut v = lr.rec.s[m];
                if self.gradients {
                    v += lr.rec.grad[m][0] * dx.x
                        + lr.rec.grad[m][1] * dx.y
                        + lr.rec.grad[m][2] * dx.z;
                }
                out[1][m] += v * w;
                if reached {
                    out[0][m] += v * w;
                }
            }
            weight[1] += w;
            if reached {
                weight[0] += w;
            }
        }
        let pick = if weight[0] > 0.0 { 0 } else { 1 };
        let mut out = out[pick];
        if weight[pick] > 0.0 {
            out.iter_mut().for_each(|v| *v /= weight[pick]);
        }
        out
    }

    /// The record at lattice point `c` (centre `centre`), made by `record` the first time it is read.
    fn record(
        &self,
        c: UVec3,
        centre: Vec3,
        record: &dyn Fn(Vec3) -> Option<LatticeRecord>,
    ) -> Option<LatticeRecord> {
        let i = ((c.z * self.dims.y + c.y) * self.dims.x + c.x) as usize;
        *self.all[i].get_or_init(|| record(centre))
    }

    /// What `x` sees around it, for an estimate's fit: `None` where no surface lies within `r` of it.
    /// Taken from what the centre of its cell of a coarse lattice sees (measured once by `measure`,
    /// each plane then moved to `x`) when `clear(centre, x)` says nothing lies between the two; else
    /// measured at `x` itself. A function of the cell and `x` alone, so the answer does not depend on
    /// which thread asked first.
    pub fn surroundings(
        &self,
        x: Vec3,
        r: f32,
        measure: impl Fn(Vec3) -> Surroundings,
        clear: impl FnOnce(Vec3, Vec3) -> bool,
    ) -> Option<Surroundings> {
        let max = self.seen_dims.as_ivec3() - IVec3::ONE;
        let c = ((x - self.lo) / self.seen_cell)
            .floor()
            .as_ivec3()
            .clamp(IVec3::ZERO, max)
            .as_uvec3();
        let centre = self.lo + (c.as_vec3() + 0.5) * self.seen_cell;
        let i = ((c.z * self.seen_dims.y + c.y) * self.seen_dims.x + c.x) as usize;
        let seen = self.seen[i].get_or_init(|| {
            let around = measure(centre);
            Seen {
                nearest: around.nearest(),
                planes: around.planes(),
            }
        });
        let offset = x - centre;
        if seen.nearest - offset.length() >= r {
            return None;
        }
        Some(if clear(centre, x) {
            Surroundings::moved(&seen.planes, offset, r)
        } else {
            measure(x)
        })
    }

    /// Records created so far, of all.
    pub fn filled(&self) -> (usize, usize) {
        (
            self.all.iter().filter(|c| c.get().is_some()).count(),
            self.all.len(),
        )
    }
}

/// What the centre of a cell of [`VolumeGrid`]'s coarse lattice sees: its nearest surface's distance
/// and the distinct planes of the surfaces around it.
struct Seen {
    nearest: f32,
    planes: Vec<(Vec3, f32, bool)>,
}

/// Most cells of the lattice of [`Seen`] (up to [`SEEN_BYTES`] each once measured).
pub const MAX_SEEN_CELLS: u64 = 1 << 14;
/// Bytes of a measured [`Seen`] at most (96 planes of 20 bytes, the list and its lock).
pub const SEEN_BYTES: u64 = 96 * 20 + 48;

/// The coarse lattice over a box of size `extent` whose cells' centres measure what they see: cells
/// about the estimate's radius cap across, fewer than [`MAX_SEEN_CELLS`].
fn seen_lattice(extent: Vec3, max_radius: f32) -> (f32, UVec3) {
    let mut cell = max_radius.max(extent.max_element() * 1e-3);
    loop {
        let d = (extent / cell).ceil().as_uvec3().max(UVec3::ONE);
        if (d.x as u64) * (d.y as u64) * (d.z as u64) <= MAX_SEEN_CELLS {
            return (cell, d);
        }
        cell *= 1.25;
    }
}

/// σs·Li toward direction of travel `d` from the moments, per channel: S0 times Henyey–Greenstein's
/// phase with asymmetry g·|m̄| about the photons' mean direction m̄ = S1/S0. It has the moments' first
/// order, (S0 + 3g S1·d) / 4π, and is exact for light from one direction (|m̄| = 1, a sun shaft) and for
/// light from all directions alike (m̄ = 0). The first order alone goes negative opposite a collimated
/// beam once g > 1/3, and clamping it there at zero overstated the light of a sun shaft in haze.
pub fn phase_moments(s: [Vec3; 4], d: Vec3, g: f32) -> Vec3 {
    let channel = |c: usize| {
        let s0 = s[0][c];
        if !(s0 > 0.0) {
            return 0.0;
        }
        let m = Vec3::new(s[1][c], s[2][c], s[3][c]) / s0;
        let len = m.length();
        if !(len > 1e-6) {
            return s0 / (4.0 * std::f32::consts::PI);
        }
        let mean = len.min(1.0);
        s0 * crate::medium::hg(g * mean, m.dot(d) / len)
    };
    Vec3::new(channel(0), channel(1), channel(2))
}

/// How much wider than the value's kernel the gradient's is: a density estimate's derivative is far
/// noisier than its value (its variance grows as 1/(n r²)); at twice the radius the gradient sums eight
/// times the photons and its noise drops about sixfold, while a smooth field's slope barely changes.
const GRADIENT_WIDTH: f32 = 2.0;

/// The biweight-kernel estimate at `p` over the k nearest photons (radius r: the k-th distance, or the
/// cap when fewer are found) and its gradient, the derivative of the same kernel estimate at radius
/// [`GRADIENT_WIDTH`]·r (at fixed radius; left zero without `gradient`), and r. Normalisation: ∫ K over
/// the ball = 32π r³/105.
pub fn estimate(
    map: &PhotonMap,
    p: Vec3,
    k: usize,
    max_radius: f32,
    which: Photons,
    gradient: bool,
) -> (MediaRecord, f32) {
    let e = estimate_within(map, p, (k, max_radius), which, gradient, None, None);
    (e.rec, e.radius)
}

/// What [`estimate_within`] returns.
#[derive(Clone, Copy, Debug, Default, PartialEq)]
pub struct VolumeEstimate {
    /// The moments at the kernel's radius and their gradient at [`GRADIENT_WIDTH`] times it.
    pub rec: MediaRecord,
    /// The kernel's radius.
    pub radius: f32,
    /// The power (moment 0) over the gradient's wider kernel: about eight times the photons, so far
    /// less noisy than `rec.s[0]` (zero without the gradient).
    pub wide_power: Vec3,
    /// With `toward` = (d, g): per channel, the photons' light scattered toward a ray along d, each by
    /// its own phase, over what [`phase_moments`] gives from the moments (1 without).
    pub phase_ratio: Vec3,
}

/// Faces × cells per face of a [`Surroundings`] cube.
const CUBE_N: usize = 4;
const CUBE_CELLS: usize = 6 * CUBE_N * CUBE_N;

/// What a point in a medium sees around it: the distance to the first surface (any: medium boundaries,
/// occluders) in each cell of a small cube map of directions (6 × 4 × 4), with each cell's share of the
/// sphere. The kernel's part that is visible (inside the medium, in front of occluders) is its integral
/// over the cells up to each cell's distance. A photon is hidden when it lies beyond an occluder in its
/// direction (beyond a medium's boundary there are none to hide: a cell's constant distance is too
/// coarse a test there, it hid photons inside the medium at grazing angles).
pub struct Surroundings {
    dist: [f32; CUBE_CELLS],
    /// The cell's distance is to an occluder (not to a medium's invisible boundary).
    solid: [bool; CUBE_CELLS],
    /// The plane through the cell's hit: its unit normal facing away from the point, and its distance.
    plane: [(Vec3, f32); CUBE_CELLS],
}

/// Directions per cell side over which [`Surroundings::share`] integrates each cell's plane: with one
/// distance per cell (its centre's), a point 0.05 r from a wall saw 0.51 of the kernel instead of 0.55
/// (8 % too bright once divided by it), at 0.2 r 0.73 instead of 0.71.
const SUB_N: usize = 4;

/// ∫₀ᵘ (1 − s²)² s² ds over its value at u = 1 (8/105): the biweight kernel's share of a cone within u·r.
fn kernel_share(u: f32) -> f32 {
    let u = u.clamp(0.0, 1.0);
    let (u2, u3) = (u * u, u * u * u);
    (u3 / 3.0 - 2.0 * u3 * u2 / 5.0 + u3 * u2 * u2 / 7.0) * (105.0 / 8.0)
}

/// Its derivative in u.
fn kernel_share_slope(u: f32) -> f32 {
    if !(0.0..1.0).contains(&u) {
        return 0.0;
    }
    u * u * (1.0 - u * u) * (1.0 - u * u) * (105.0 / 8.0)
}

/// ∫₀ᵘ (1 − s²)² s³ ds over ∫₀¹ (1 − s²)² s² ds: the kernel's first radial moment along a cone within
/// u·r, in units of r (105/192 for the whole radius).
fn kernel_first_moment(u: f32) -> f32 {
    let u2 = u.clamp(0.0, 1.0).powi(2);
    (u2 * u2 / 4.0 - u2 * u2 * u2 / 3.0 + u2 * u2 * u2 * u2 / 8.0) * (105.0 / 8.0)
}

/// ∫₀ᵘ (1 − s²)² s⁴ ds over ∫₀¹ (1 − s²)² s² ds: the second radial moment, in units of r² (1/3 for
/// the whole radius).
fn kernel_second_moment(u: f32) -> f32 {
    let u = u.clamp(0.0, 1.0);
    let (u2, u5) = (u * u, u.powi(5));
    (u5 / 5.0 - 2.0 * u5 * u2 / 7.0 + u5 * u2 * u2 / 9.0) * (105.0 / 8.0)
}

/// d·dᵀ.
fn outer(d: Vec3) -> glam::Mat3 {
    glam::Mat3::from_cols(d * d.x, d * d.y, d * d.z)
}

impl Surroundings {
    /// Measures the distances with `dist(direction)`: the first surface's (infinite where nothing is
    /// hit), whether it is an occluder, and its normal.
    pub fn measure(mut dist: impl FnMut(Vec3) -> (f32, bool, Vec3)) -> Surroundings {
        let mut s = Surroundings {
            dist: [0.0; CUBE_CELLS],
            solid: [false; CUBE_CELLS],
            plane: [(Vec3::ZERO, f32::INFINITY); CUBE_CELLS],
        };
        for c in 0..CUBE_CELLS {
            let d = cell_centres()[c];
            let n;
            (s.dist[c], s.solid[c], n) = dist(d);
            let cos = d.dot(n);
            if s.dist[c].is_finite() && cos != 0.0 {
                let away = if cos > 0.0 { n } else { -n };
                s.plane[c] = (away, s.dist[c] * cos.abs());
            }
        }
        s
    }

    /// The cell of direction `d` (not normalised).
    fn cell(d: Vec3) -> usize {
        let a = d.abs();
        let (face, u, v, m) = if a.x >= a.y && a.x >= a.z {
            (if d.x > 0.0 { 0 } else { 1 }, d.y, d.z, a.x)
        } else if a.y >= a.z {
            (if d.y > 0.0 { 2 } else { 3 }, d.z, d.x, a.y)
        } else {
            (if d.z > 0.0 { 4 } else { 5 }, d.x, d.y, a.z)
        };
        let m = m.max(f32::MIN_POSITIVE);
        let idx = |t: f32| (((t / m + 1.0) * 0.5 * CUBE_N as f32) as usize).min(CUBE_N - 1);
        face * CUBE_N * CUBE_N + idx(u) * CUBE_N + idx(v)
    }

    /// Whether a photon at offset `d` from the point is in view: not beyond its cell's occluder plane.
    fn sees(&self, d: Vec3) -> bool {
        let c = Self::cell(d);
        !self.solid[c] || d.dot(self.plane[c].0) < self.plane[c].1
    }

    /// The kernel's visible share within radius `r`, and its gradient as the point moves: each cell's
    /// plane integrated over SUB_N² directions in the cell (the plane at distance h along its normal n
    /// is t = h / (ω·n) away along ω, and ∂t/∂x = −n / (ω·n)). Within about 0.1 r of a plane the
    /// gradient is up to 2× off (grazing directions, few of them sampled, carry it).
    fn share(&self, r: f32) -> (f32, Vec3) {
        let (mut f, mut g) = (0.0, Vec3::ZERO);
        for c in 0..CUBE_CELLS {
            let (n, h) = self.plane[c];
            if !(h < r) {
                f += cell_weights()[c];
                continue;
            }
            let (mut fc, mut gc, mut wsum) = (0.0, Vec3::ZERO, 0.0);
            for (d, w) in sub_directions(c) {
                let cos = d.dot(n);
                wsum += w;
                if cos <= 0.0 {
                    fc += w;
                    continue;
                }
                let u = h / cos / r;
                fc += w * kernel_share(u);
                gc -= n * (w * kernel_share_slope(u) / (r * cos.max(0.05)));
            }
            f += cell_weights()[c] * fc / wsum;
            g += gc * (cell_weights()[c] / wsum);
        }
        (f, g)
    }

    /// The visible kernel's moments at radius `r`, each over the whole kernel's integral: its share
    /// f0 = ∫_V K / ∫K, first moment f1 = ∫_V K·(y − x) / ∫K and second f2 = ∫_V K·(y − x)(y − x)ᵀ / ∫K
    /// (for the whole ball: 1, 0 and r²/9·I).
    pub(crate) fn moments(&self, r: f32) -> (f32, Vec3, glam::Mat3) {
        let (mut f0, mut f1, mut f2) = (0.0, Vec3::ZERO, glam::Mat3::ZERO);
        for c in 0..CUBE_CELLS {
            let (n, h) = self.plane[c];
            if !(h < r) {
                // The whole cell within reach: its directions' mean and second moment (tabled) times
                // the kernel's radial moments over the whole radius.
                let (mean, second) = cell_direction_moments()[c];
                f0 += cell_weights()[c];
                f1 += mean * (cell_weights()[c] * r * kernel_first_moment(1.0));
                f2 += second * (cell_weights()[c] * r * r * kernel_second_moment(1.0));
                continue;
            }
            let mut wsum = 0.0;
            let (mut c0, mut c1, mut c2) = (0.0, Vec3::ZERO, glam::Mat3::ZERO);
            for (d, w) in sub_directions(c) {
                wsum += w;
                let cos = d.dot(n);
                let u = if cos > 0.0 { h / cos / r } else { 1.0 };
                c0 += w * kernel_share(u);
                c1 += d * (w * kernel_first_moment(u) * r);
                c2 += outer(d) * (w * kernel_second_moment(u) * r * r);
            }
            let cw = cell_weights()[c] / wsum;
            f0 += c0 * cw;
            f1 += c1 * cw;
            f2 += c2 * cw;
        }
        (f0, f1, f2)
    }

    /// The planes of the occluders seen within `reach` (unit normal facing away from the point,
    /// distance), nearest first, at most [`LATTICE_WALLS`]; the distance infinite past the last.
    pub(crate) fn occluders(&self, reach: f32) -> [(Vec3, f32); LATTICE_WALLS] {
        let mut near: Vec<(Vec3, f32)> = self
            .planes()
            .into_iter()
            .filter(|&(_, h, solid)| solid && h < reach)
            .map(|(n, h, _)| (n, h))
            .collect();
        near.sort_by(|a, b| a.1.total_cmp(&b.1));
        let mut out = [(Vec3::ZERO, f32::INFINITY); LATTICE_WALLS];
        for (o, p) in out.iter_mut().zip(near) {
            *o = p;
        }
        out
    }

    /// The distinct planes of the surfaces seen, each as its unit normal facing away from the point,
    /// its distance and whether it is an occluder's (for [`Surroundings::moved`]).
    fn planes(&self) -> Vec<(Vec3, f32, bool)> {
        let mut planes: Vec<(Vec3, f32, bool)> = Vec::new();
        for (&(n, h), &solid) in self.plane.iter().zip(&self.solid) {
            let same = |p: &(Vec3, f32, bool)| {
                (p.0 - n).length_squared() < 1e-6 && (p.1 - h).abs() <= 1e-4 * h.max(1e-3)
            };
            if h.is_finite() && !planes.iter().any(same) {
                planes.push((n, h, solid));
            }
        }
        planes
    }

    /// What a point `offset` away from the one that saw `planes` ([`Surroundings::planes`]) sees within
    /// `reach`, approximately: the planes moved by the offset, and along each cell's direction the
    /// first of them — exact inside a convex space (a room, a fog box: the first wall along a ray is
    /// the nearest crossing of all the walls' planes), approximate among occluders. A plane the point
    /// lies beyond, or farther than `reach`, is left out.
    fn moved(planes: &[(Vec3, f32, bool)], offset: Vec3, reach: f32) -> Surroundings {
        let near: Vec<(Vec3, f32, bool)> = planes
            .iter()
            .map(|&(n, h, solid)| (n, h - n.dot(offset), solid))
            .filter(|p| p.1 > 0.0 && p.1 < reach)
            .collect();
        let mut s = Surroundings {
            dist: [f32::INFINITY; CUBE_CELLS],
            solid: [false; CUBE_CELLS],
            plane: [(Vec3::ZERO, f32::INFINITY); CUBE_CELLS],
        };
        if near.is_empty() {
            return s;
        }
        for c in 0..CUBE_CELLS {
            let d = cell_centres()[c];
            for &(n, h, solid) in &near {
                let cos = d.dot(n);
                if cos > 0.0 && h < s.dist[c] * cos {
                    s.dist[c] = h / cos;
                    s.plane[c] = (n, h);
                    s.solid[c] = solid;
                }
            }
        }
        s
    }

    /// The distance to the nearest plane of the surfaces seen (infinite when none is).
    fn nearest(&self) -> f32 {
        self.plane
            .iter()
            .zip(&self.dist)
            .map(|(p, d)| p.1.min(*d))
            .fold(f32::INFINITY, f32::min)
    }

    /// Harmonic mean of the distances, each cut at `cap`.
    pub fn harmonic_mean(&self, cap: f32) -> f32 {
        let inv: f32 = self
            .dist
            .iter()
            .zip(cell_weights())
            .map(|(d, w)| w / d.min(cap).max(1e-9))
            .sum();
        1.0 / inv
    }
}

/// Each cube cell's central direction (tabled).
fn cell_centres() -> &'static [Vec3; CUBE_CELLS] {
    static TABLE: OnceLock<[Vec3; CUBE_CELLS]> = OnceLock::new();
    TABLE.get_or_init(|| std::array::from_fn(|c| cell_direction(c, 0.5, 0.5).0))
}

/// Each cube cell's share of the sphere, as [`Surroundings::measure`] weights it (tabled).
fn cell_weights() -> &'static [f32; CUBE_CELLS] {
    static TABLE: OnceLock<[f32; CUBE_CELLS]> = OnceLock::new();
    TABLE.get_or_init(|| {
        let w: [f32; CUBE_CELLS] = std::array::from_fn(|c| cell_direction(c, 0.5, 0.5).1);
        let total: f32 = w.iter().sum();
        w.map(|x| x / total)
    })
}

/// The unit direction at (fi, fj) ∈ [0, 1]² within cube cell `c`, and its solid angle's weight
/// (∝ 1 / (1 + a² + b²)^(3/2) on the unit cube's face).
fn cell_direction(c: usize, fi: f32, fj: f32) -> (Vec3, f32) {
    let (face, i, j) = (c / (CUBE_N * CUBE_N), (c / CUBE_N) % CUBE_N, c % CUBE_N);
    let a = 2.0 * (i as f32 + fi) / CUBE_N as f32 - 1.0;
    let b = 2.0 * (j as f32 + fj) / CUBE_N as f32 - 1.0;
    (
        face_vector(face, a, b).normalize(),
        (1.0 + a * a + b * b).powf(-1.5),
    )
}

/// The [`SUB_N`]² directions over cube cell `c` (their cell's centres), each with its solid angle's
/// weight (tabled: every estimate near a surface integrates over them).
fn sub_directions(c: usize) -> impl Iterator<Item = (Vec3, f32)> {
    type Table = [[(Vec3, f32); SUB_N * SUB_N]; CUBE_CELLS];
    static TABLE: std::sync::OnceLock<Box<Table>> = std::sync::OnceLock::new();
    let table = TABLE.get_or_init(|| {
        Box::new(std::array::from_fn(|c| {
            std::array::from_fn(|k| {
                cell_direction(
                    c,
                    ((k / SUB_N) as f32 + 0.5) / SUB_N as f32,
                    ((k % SUB_N) as f32 + 0.5) / SUB_N as f32,
                )
            })
        }))
    });
    table[c].iter().copied()
}

/// Per cube cell, the mean of its [`SUB_N`]² directions and of their outer products, weighted by solid
/// angle (what [`Surroundings::moments`] integrates over a cell with nothing within reach).
fn cell_direction_moments() -> &'static [(Vec3, glam::Mat3); CUBE_CELLS] {
    static TABLE: std::sync::OnceLock<[(Vec3, glam::Mat3); CUBE_CELLS]> =
        std::sync::OnceLock::new();
    TABLE.get_or_init(|| {
        std::array::from_fn(|c| {
            let (mut wsum, mut mean, mut second) = (0.0, Vec3::ZERO, glam::Mat3::ZERO);
            for (d, w) in sub_directions(c) {
                wsum += w;
                mean += d * w;
                second += outer(d) * w;
            }
            (mean / wsum, second * (1.0 / wsum))
        })
    })
}

/// The direction of cube face `face` at face coordinates (a, b) in [−1, 1]².
fn face_vector(face: usize, a: f32, b: f32) -> Vec3 {
    match face {
        0 => Vec3::new(1.0, a, b),
        1 => Vec3::new(-1.0, a, b),
        2 => Vec3::new(b, 1.0, a),
        3 => Vec3::new(b, -1.0, a),
        4 => Vec3::new(a, b, 1.0),
        _ => Vec3::new(a, b, -1.0),
    }
}

/// The kernel's visible share below which an estimate is not corrected further (a point in a tight
/// corner: the correction's noise would grow as 1/share).
const MIN_SHARE: f32 = 0.25;

/// The power at the kernel's centre from a local-linear fit over its visible part (`around`, radius
/// r): the sums S0 = Σ K·ΔΦ and S1 = Σ K·ΔΦ·(y − x) estimate a·f0 + f1·∇ and a·f1 + f2·∇ for a density
/// a + ∇·(y − x), with f the visible kernel's moments; solved for a. Dividing S0 by the share f0 alone
/// assumes the density flat, and near an absorbing wall, where the light grows away from it, came out
/// 7 % high. `None` where the fit is ill-conditioned (the point in a tight corner): the caller divides
/// by the share.
fn fit_power(around: &Surroundings, r: f32, s0: Vec3, first: [Vec3; 3]) -> Option<Vec3> {
    let (f0, f1, f2) = around.moments(r);
    let inv = f2.inverse();
    let schur = f0 - f1.dot(inv * f1);
    if !(inv.is_finite() && f0 > FIT_MIN_SHARE && schur > FIT_MIN_SCHUR * f0) {
        return None;
    }
    let t = inv * f1;
    let channel = |c: usize| {
        let s1 = Vec3::new(first[0][c], first[1][c], first[2][c]);
        ((s0[c] - t.dot(s1)) / schur).max(0.0)
    };
    Some(Vec3::new(channel(0), channel(1), channel(2)))
}

/// The fit needs this much of the kernel visible,
const FIT_MIN_SHARE: f32 = 0.05;
/// and its power's weight in the solved system at least this share of f0 (near 0 the fitted slope
/// swamps the value with noise).
const FIT_MIN_SCHUR: f32 = 0.2;

/// [`estimate`] aware of what the point sees (`around`): photons hidden from it (behind an occluder)
/// are left out, and the power is fitted over the kernel's visible part ([`fit_power`]) — near a
/// medium's boundary a plain kernel estimate counts the empty space beyond it and comes out low (half
/// at the boundary). The gradient is that of the estimate over the visible share, the share's own
/// derivative included (the occlusion-aware gradient of Jarosz, Zwicker & Jensen 2008 in the form a
/// density estimate takes). `(k, max_radius)` as for [`estimate`].
pub fn estimate_within(
    map: &PhotonMap,
    p: Vec3,
    (k, max_radius): (usize, f32),
    which: Photons,
    gradient: bool,
    around: Option<&Surroundings>,
    toward: Option<(Vec3, f32)>,
) -> VolumeEstimate {
    let mut nb = Vec::new();
    map.tree().knn(p, k, max_radius, &mut nb);
    let r2 = if nb.len() >= k {
        nb.last().map_or(0.0, |n| n.dist2)
    } else {
        max_radius * max_radius
    };
    let mut rec = MediaRecord::default();
    if nb.is_empty() || r2.is_nan() || r2 <= 0.0 {
        return VolumeEstimate {
            rec,
            radius: max_radius,
            wide_power: Vec3::ZERO,
            phase_ratio: Vec3::ONE,
        };
    }
    let photons = map.photons();
    let moments = |i: u32| {
        let ph = &photons[i as usize];
        [
            ph.power,
            ph.power * ph.wi.x,
            ph.power * ph.wi.y,
            ph.power * ph.wi.z,
        ]
    };
    let kept = |i: u32| {
        let ph = &photons[i as usize];
        let wanted = match which {
            Photons::All => true,
            Photons::NotDirect => !ph.direct,
            Photons::Indirect => ph.indirect,
        };
        wanted && around.is_none_or(|a| a.sees(ph.pos - p))
    };
    let norm = |r2: f32| 105.0 / (32.0 * std::f32::consts::PI * r2 * r2.sqrt());
    let (n0, rg2) = (norm(r2), r2 * GRADIENT_WIDTH * GRADIENT_WIDTH);
    // The power's first moment about p, per axis (for the fit at a boundary).
    let mut first = [Vec3::ZERO; 3];
    let mut exact = Vec3::ZERO;
    for n in nb.iter().filter(|n| kept(n.index)) {
        let u2 = n.dist2 / r2;
        if u2 < 1.0 {
            let w = (1.0 - u2) * (1.0 - u2) * n0;
            let ph = &photons[n.index as usize];
            if let Some((d, g)) = toward {
                exact += ph.power * (w * crate::medium::hg(g, ph.wi.dot(d)));
            }
            for (s, m) in rec.s.iter_mut().zip(moments(n.index)) {
                *s += m * w;
            }
            if around.is_some() {
                let off = ph.pos - p;
                for a in 0..3 {
                    first[a] += ph.power * (w * off[a]);
                }
            }
        }
    }
    let share = |r: f32| {
        around
            .map_or((1.0, Vec3::ZERO), |a| a.share(r))
            .0
            .max(MIN_SHARE)
    };
    let phase_ratio = match toward {
        Some((d, g)) => {
            let model = phase_moments(rec.s, d, g);
            Vec3::select(model.cmpgt(Vec3::ZERO), exact / model, Vec3::ONE)
        }
        None => Vec3::ONE,
    };
    let f0 = share(r2.sqrt());
    let fitted = around.and_then(|a| fit_power(a, r2.sqrt(), rec.s[0], first));
    let scale = match fitted {
        // The fit corrects the power; the direction moments keep their ratio to it (a fit of their
        // own is noisier and would skew the photons' mean direction).
        Some(power) => Vec3::select(
            rec.s[0].cmpgt(Vec3::ZERO),
            power / rec.s[0],
            Vec3::splat(1.0 / f0),
        ),
        None => Vec3::splat(1.0 / f0),
    };
    rec.s.iter_mut().for_each(|s| *s *= scale);
    if !gradient {
        return VolumeEstimate {
            rec,
            radius: r2.sqrt(),
            wide_power: Vec3::ZERO,
            phase_ratio,
        };
    }
    let (ng, cap) = (norm(rg2), GRADIENT_WIDTH * r2.sqrt());
    // Eight times the volume holds about eight times the k photons: 12 k leaves a margin.
    map.tree().knn(p, (k * 12).min(map.len()), cap, &mut nb);
    let mut wide_power = Vec3::ZERO;
    for n in nb.iter().filter(|n| kept(n.index)) {
        let u2 = n.dist2 / rg2;
        if u2 < 1.0 {
            wide_power += photons[n.index as usize].power * ((1.0 - u2) * (1.0 - u2) * ng);
            // ∂K/∂x = −4 (1 − u²) (x − x_k) / r².
            let dk = (p - photons[n.index as usize].pos) * (-4.0 * (1.0 - u2) / rg2 * ng);
            for (g, m) in rec.grad.iter_mut().zip(moments(n.index)) {
                for a in 0..3 {
                    g[a] += m * dk[a];
                }
            }
        }
    }
    if let Some(a) = around {
        // ∇(S/F) = (∇S − (S/F)·∇F) / F at the gradient's radius; S/F there is taken as the value's
        // (both estimate the same light). Below MIN_SHARE the share is held constant.
        let (f, df) = a.share(GRADIENT_WIDTH * r2.sqrt());
        let (f, df) = if f < MIN_SHARE {
            (MIN_SHARE, Vec3::ZERO)
        } else {
            (f, df)
        };
        wide_power /= f;
        for (g, v) in rec.grad.iter_mut().zip(rec.s) {
            for ax in 0..3 {
                g[ax] = (g[ax] - v * df[ax]) / f;
            }
        }
    }
    VolumeEstimate {
        rec,
        radius: r2.sqrt(),
        wide_power,
        phase_ratio,
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use photon::sampling::Rng;
    use photon::Photon;

    /// Photons whose density grows along x, arriving from varied directions.
    fn slanted_map() -> PhotonMap {
        let mut rng = Rng::new(11);
        let mut photons = Vec::new();
        while photons.len() < 200_000 {
            let p = Vec3::new(rng.uniform(), rng.uniform(), rng.uniform());
            if rng.uniform() > 0.2 + 0.8 * p.x {
                continue;
            }
            let wi = Vec3::new(rng.uniform() - 0.5, rng.uniform() - 0.5, 1.0).normalize();
            photons.push(Photon {
                pos: p,
                wi,
                power: Vec3::new(1.0, 0.5, 0.25),
                normal: Vec3::ZERO,
                indirect: true,
                direct: false,
            });
        }
        PhotonMap::new(photons).unwrap()
    }

    /// Near a wall with the light growing away from it, the fit reads the density where the share
    /// alone reads high; far from the wall both are the plain estimate.
    #[test]
    fn the_fit_at_a_wall_follows_a_sloped_density() {
        let mut rng = Rng::new(5);
        let mut photons = Vec::new();
        while photons.len() < 400_000 {
            let pos = Vec3::new(rng.uniform(), rng.uniform(), rng.uniform());
            if rng.uniform() * 6.0 <= 1.0 + 5.0 * pos.x {
                photons.push(Photon {
                    pos,
                    wi: Vec3::Z,
                    power: Vec3::ONE,
                    normal: Vec3::ZERO,
                    indirect: true,
                    direct: false,
                });
            }
        }
        let map = PhotonMap::new(photons).unwrap();
        // Density 400 000 / 3.5 · (1 + 5x) over the cube.
        for x in [0.005f32, 0.02] {
            let truth = 400_000.0 / 3.5 * (1.0 + 5.0 * x);
            let (mut fit, mut share) = (0.0, 0.0);
            for _ in 0..200 {
                let p = Vec3::new(x, 0.3 + 0.4 * rng.uniform(), 0.3 + 0.4 * rng.uniform());
                let around = Surroundings::measure(|d| box_distance(p, d, 1.0));
                let e = estimate_within(
                    &map,
                    p,
                    (100, 0.3),
                    Photons::All,
                    false,
                    Some(&around),
                    None,
                );
                fit += e.rec.s[0].x / 200.0 / truth;
                let plain = estimate(&map, p, 100, 0.3, Photons::All, false).0.s[0].x;
                share += plain / around.share(e.radius).0.max(MIN_SHARE) / 200.0 / truth;
            }
            assert!((fit - 1.0).abs() < 0.03, "x {x}: fit {fit}, share {share}");
            if x < 0.01 {
                assert!(share > 1.04, "x {x}: share {share}");
            }
        }
    }

    /// The phase ratio turns the moments' phase into each photon's own: photons from two opposite
    /// directions have no mean direction, and the moments scatter their light evenly.
    #[test]
    fn the_phase_ratio_gives_each_photons_own_phase() {
        let photons: Vec<Photon> = (0..2000)
            .map(|i| Photon {
                pos: Vec3::new((i % 10) as f32, ((i / 10) % 10) as f32, (i / 100) as f32) * 0.01,
                wi: if i % 2 == 0 { Vec3::X } else { -Vec3::X },
                power: Vec3::ONE,
                normal: Vec3::ZERO,
                indirect: true,
                direct: false,
            })
            .collect();
        let map = PhotonMap::new(photons).unwrap();
        let (p, g) = (Vec3::new(0.045, 0.045, 0.1), 0.8);
        let e = estimate_within(
            &map,
            p,
            (400, 1.0),
            Photons::All,
            false,
            None,
            Some((Vec3::X, g)),
        );
        let model = phase_moments(e.rec.s, Vec3::X, g).x;
        let exact = 0.5 * (crate::medium::hg(g, 1.0) + crate::medium::hg(g, -1.0)) * e.rec.s[0].x;
        assert!((model - e.rec.s[0].x / (4.0 * std::f32::consts::PI)).abs() < 1e-3 * model);
        assert!(
            (model * e.phase_ratio.x / exact - 1.0).abs() < 0.05,
            "model {model} × ratio {} vs exact {exact}",
            e.phase_ratio.x
        );
    }

    /// The wider kernel's power estimates the same density as the value, with a fraction of its noise.
    #[test]
    fn the_wide_power_is_the_density_with_less_noise() {
        let mut rng = Rng::new(5);
        let photons: Vec<Photon> = (0..200_000)
            .map(|_| Photon {
                pos: Vec3::new(rng.uniform(), rng.uniform(), rng.uniform()),
                wi: Vec3::Z,
                power: Vec3::ONE,
                normal: Vec3::ZERO,
                indirect: true,
                direct: false,
            })
            .collect();
        let map = PhotonMap::new(photons).unwrap();
        let (mut value, mut wide) = (Vec::new(), Vec::new());
        for _ in 0..200 {
            let p = Vec3::new(rng.uniform(), rng.uniform(), rng.uniform()) * 0.4 + 0.3;
            let e = estimate_within(&map, p, (100, 0.3), Photons::All, true, None, None);
            value.push(e.rec.s[0].x / 200_000.0);
            wide.push(e.wide_power.x / 200_000.0);
        }
        let stats = |v: &[f32]| {
            let m = v.iter().sum::<f32>() / v.len() as f32;
            let var = v.iter().map(|x| (x - m) * (x - m)).sum::<f32>() / v.len() as f32;
            (m, var.sqrt() / m)
        };
        let ((mv, sv), (mw, sw)) = (stats(&value), stats(&wide));
        assert!(
            (mv - 1.0).abs() < 0.03 && (mw - 1.0).abs() < 0.02,
            "{mv} {mw}"
        );
        assert!(sw < 0.5 * sv, "relative spread: wide {sw}, value {sv}");
    }

    #[test]
    fn record_gradients_match_finite_differences_of_the_estimate() {
        let map = slanted_map();
        let p = Vec3::new(0.5, 0.45, 0.55);
        // At fixed r: the estimate with the k-th distance found at p, differentiated numerically.
        let mut nb = Vec::new();
        map.tree().knn(p, 1000, 1.0, &mut nb);
        let r = nb.last().unwrap().dist2.sqrt() * GRADIENT_WIDTH;
        // The gradient's own kernel estimate (radius GRADIENT_WIDTH·r, fixed), differentiated numerically.
        let fixed = |q: Vec3| estimate_at_radius(&map, q, r);
        let rec = estimate(&map, p, 1000, 1.0, Photons::All, true).0;
        let h = 1e-3;
        for a in 0..3 {
            let mut e = Vec3::ZERO;
            e[a] = h;
            let fd = (fixed(p + e)[0] - fixed(p - e)[0]) / (2.0 * h);
            let g = rec.grad[0][a];
            assert!(
                (fd - g).abs().max_element()
                    <= 0.02 * g.abs().max_element().max(fd.abs().max_element()) + 1e-3,
                "axis {a}: gradient {g} vs finite difference {fd}"
            );
        }
        // The density grows along x: the gradient says so.
        assert!(rec.grad[0][0].x > 0.0 && rec.grad[0][0].x.abs() > 3.0 * rec.grad[0][1].x.abs());
    }

    /// Distance from `p` inside the box [0, 1]³ (or the half-box left of `wall`) to its faces along `d`.
    /// An occluder when it is the wall; the face's normal.
    fn box_distance(p: Vec3, d: Vec3, wall: f32) -> (f32, bool, Vec3) {
        let hi = Vec3::new(wall, 1.0, 1.0);
        let t = |a: usize| {
            if d[a] > 0.0 {
                (hi[a] - p[a]) / d[a]
            } else if d[a] < 0.0 {
                -p[a] / d[a]
            } else {
                f32::INFINITY
            }
        };
        let a = (0..3).min_by(|&i, &j| t(i).total_cmp(&t(j))).unwrap();
        let mut n = Vec3::ZERO;
        n[a] = -d[a].signum();
        (t(a), wall < 1.0 && a == 0 && d.x > 0.0, n)
    }

    /// What a box's centre sees, moved to a point near two of its walls, is what that point sees:
    /// the kernel's visible share and moments agree with a measurement made there.
    #[test]
    fn moved_surroundings_match_a_measurement_at_the_point() {
        let centre = Vec3::splat(0.5);
        let x = Vec3::new(0.12, 0.8, 0.55);
        let here = Surroundings::measure(|d| box_distance(x, d, 1.0));
        let planes = Surroundings::measure(|d| box_distance(centre, d, 1.0)).planes();
        let moved = Surroundings::moved(&planes, x - centre, 1.0);
        for r in [0.1, 0.25, 0.4] {
            let (a, b) = (here.share(r).0, moved.share(r).0);
            assert!((a - b).abs() < 0.02, "r {r}: share {a} measured, {b} moved");
            let (ma, mb) = (here.moments(r).1, moved.moments(r).1);
            assert!(
                (ma - mb).length() < 0.02 * r,
                "r {r}: first moment {ma} vs {mb}"
            );
        }
        assert!((moved.nearest() - 0.12).abs() < 1e-4, "{}", moved.nearest());
    }

    /// Uniform photons (power 1 each) in the unit cube, twice as dense left of x = 0.5.
    fn two_densities() -> (PhotonMap, f32) {
        let mut rng = Rng::new(7);
        let mut photons = Vec::new();
        while photons.len() < 300_000 {
            let p = Vec3::new(rng.uniform(), rng.uniform(), rng.uniform());
            if p.x > 0.5 && rng.uniform() < 0.5 {
                continue;
            }
            photons.push(Photon {
                pos: p,
                wi: Vec3::Z,
                power: Vec3::ONE,
                normal: Vec3::ZERO,
                indirect: true,
                direct: false,
            });
        }
        // Photons per unit volume on the left: n = d·(0.5 + 0.5·0.5) ⇒ d = n / 0.75.
        (PhotonMap::new(photons).unwrap(), 300_000.0 / 0.75)
    }

    #[test]
    fn estimates_near_a_boundary_count_only_the_medium_and_what_is_in_view() {
        let (map, left) = two_densities();
        // Near the cube's face x = 0: a plain kernel counts the empty space beyond it. The fit's
        // noise is a few times the plain estimate's there, so the mean over points along the face.
        let (mut plain, mut seen) = (0.0, 0.0);
        for i in 0..16 {
            let p = Vec3::new(
                0.01,
                0.35 + 0.1 * (i % 4) as f32,
                0.35 + 0.1 * (i / 4) as f32,
            );
            plain += estimate(&map, p, 3000, 0.3, Photons::All, true).0.s[0].x / 16.0;
            let around = Surroundings::measure(|d| box_distance(p, d, 1.0));
            seen += estimate_within(
                &map,
                p,
                (3000, 0.3),
                Photons::All,
                true,
                Some(&around),
                None,
            )
            .rec
            .s[0]
                .x
                / 16.0;
        }
        assert!(plain < 0.8 * left, "plain {plain} vs {left}");
        assert!(
            (seen / left - 1.0).abs() < 0.03,
            "boundary-aware {seen} vs {left}"
        );
        // Along the face the density is flat; across it, the plain gradient points into the medium.
        // (A sixth of the gradient's radius from the face: nearer, the share's slope from 16
        // directions per cell is up to 2× off — grazing directions dominate it.)
        let p = Vec3::new(0.05, 0.5, 0.5);
        let plain = estimate(&map, p, 3000, 0.3, Photons::All, true).0;
        let around = Surroundings::measure(|d| box_distance(p, d, 1.0));
        let seen = estimate_within(
            &map,
            p,
            (3000, 0.3),
            Photons::All,
            true,
            Some(&around),
            None,
        )
        .rec;
        assert!(plain.grad[0][0].x > 0.0);
        assert!(
            seen.grad[0][0].x.abs() < 0.3 * plain.grad[0][0].x,
            "gradient across the face: {} vs plain {}",
            seen.grad[0][0].x,
            plain.grad[0][0].x
        );
        // Just left of a wall at x = 0.5 (the sparser photons behind it are hidden): the density of
        // this side, where a plain kernel mixes both.
        let q = Vec3::new(0.49, 0.5, 0.5);
        let around = Surroundings::measure(|d| box_distance(q, d, 0.5));
        let seen = estimate_within(
            &map,
            q,
            (3000, 0.3),
            Photons::All,
            false,
            Some(&around),
            None,
        )
        .rec
        .s[0]
            .x;
        let plain = estimate(&map, q, 3000, 0.3, Photons::All, false).0.s[0].x;
        assert!(
            (seen / left - 1.0).abs() < 0.05 && plain < 0.85 * left,
            "behind a wall: aware {seen}, plain {plain}, density {left}"
        );
        // Far from any surface the two agree.
        let c = Vec3::splat(0.25);
        let around = Surroundings::measure(|d| box_distance(c, d, 0.5));
        let (a, b) = (
            estimate(&map, c, 400, 0.3, Photons::All, true).0,
            estimate_within(&map, c, (400, 0.3), Photons::All, true, Some(&around), None).rec,
        );
        assert!((a.s[0].x - b.s[0].x).abs() < 1e-3 * a.s[0].x);
    }

    #[test]
    fn the_kernel_share_is_the_biweight_integral() {
        assert!(
            (kernel_share(1.0) - 1.0).abs() < 1e-5
                && kernel_share(0.0) == 0.0
                && (kernel_share(2.0) - 1.0).abs() < 1e-5
        );
        let h = 1e-3;
        for u in [0.2f32, 0.5, 0.8] {
            let fd = (kernel_share(u + h) - kernel_share(u - h)) / (2.0 * h);
            assert!(
                (fd - kernel_share_slope(u)).abs() < 1e-2,
                "slope at {u}: {fd} vs {}",
                kernel_share_slope(u)
            );
        }
        // A point on a plane sees half the sphere: half the kernel.
        let around = Surroundings::measure(|d| {
            (if d.z < 0.0 { 0.0 } else { f32::INFINITY }, false, Vec3::Z)
        });
        assert!(
            (around.share(1.0).0 - 0.5).abs() < 1e-3,
            "{}",
            around.share(1.0).0
        );
    }

    /// The kernel estimate's power moment at `q` with radius `r` fixed.
    fn estimate_at_radius(map: &PhotonMap, q: Vec3, r: f32) -> [Vec3; 4] {
        let r2 = r * r;
        let norm = 105.0 / (32.0 * std::f32::consts::PI * r2 * r);
        let mut s = [Vec3::ZERO; 4];
        for ph in map.photons() {
            let u2 = (q - ph.pos).length_squared() / r2;
            if u2 < 1.0 {
                s[0] += ph.power * (1.0 - u2) * (1.0 - u2) * norm;
            }
        }
        s
    }

    #[test]
    fn interpolated_records_follow_a_linear_density_and_gradients_help() {
        let map = slanted_map();
        let with = VolumeGrid::new((Vec3::ZERO, Vec3::ONE), 0.4, true);
        let without = VolumeGrid::new((Vec3::ZERO, Vec3::ONE), 0.4, false);
        let record = |c: Vec3| {
            Some(LatticeRecord {
                rec: estimate(&map, c, 1000, 0.4, Photons::All, true).0,
                walls: [(Vec3::ZERO, f32::INFINITY); LATTICE_WALLS],
            })
        };
        // Against the full estimate at points between lattice records, inside (away from the faces).
        let (mut err_with, mut err_without) = (0.0f32, 0.0f32);
        let mut rng = Rng::new(5);
        for _ in 0..200 {
            let x = Vec3::new(
                0.3 + 0.4 * rng.uniform(),
                0.3 + 0.4 * rng.uniform(),
                0.3 + 0.4 * rng.uniform(),
            );
            let truth = estimate(&map, x, 1000, 0.4, Photons::All, true).0.s[0].x;
            err_with += (with.interpolate(x, &record)[0].x - truth).abs() / truth;
            err_without += (without.interpolate(x, &record)[0].x - truth).abs() / truth;
        }
        assert!(
            err_with / 200.0 < 0.05,
            "mean relative error with gradients {}",
            err_with / 200.0
        );
        assert!(
            err_with <= err_without * 1.05,
            "gradients: {err_with} vs none: {err_without}"
        );
    }

    /// A wall at x = 0.5 (an occluder) with light 1 on its left and 9 on its right: a read leaves out
    /// the records on the wall's other side, and the lattice points without a record, so that a read
    /// beside the wall gets its own side's light; with every record on the other side it takes them all.
    #[test]
    fn reads_leave_out_records_beyond_an_occluder_and_points_without_one() {
        let grid = VolumeGrid::new((Vec3::ZERO, Vec3::ONE), 0.2, false);
        let side = |v: f32, n: Vec3, h: f32| LatticeRecord {
            rec: MediaRecord {
                s: [Vec3::splat(v), Vec3::ZERO, Vec3::ZERO, Vec3::ZERO],
                grad: [[Vec3::ZERO; 3]; 4],
            },
            walls: [
                (n, h),
                (Vec3::ZERO, f32::INFINITY),
                (Vec3::ZERO, f32::INFINITY),
                (Vec3::ZERO, f32::INFINITY),
            ],
        };
        let record = |c: Vec3| {
            if c.y > 0.9 {
                return None; // a point outside the medium
            }
            Some(if c.x < 0.5 {
                side(1.0, Vec3::X, 0.5 - c.x)
            } else {
                side(9.0, -Vec3::X, c.x - 0.5)
            })
        };
        let left = grid.interpolate(Vec3::new(0.47, 0.5, 0.5), &record)[0].x;
        let right = grid.interpolate(Vec3::new(0.53, 0.5, 0.5), &record)[0].x;
        assert_eq!((left, right), (1.0, 9.0));
        // Beside the points without a record, the others' weights still sum to one.
        assert_eq!(
            grid.interpolate(Vec3::new(0.2, 0.92, 0.5), &record)[0].x,
            1.0
        );
        // Without the walls the two sides blend.
        let blind = |c: Vec3| {
            record(c).map(|mut r| {
                r.walls[0] = (Vec3::ZERO, f32::INFINITY);
                r
            })
        };
        let blended = VolumeGrid::new((Vec3::ZERO, Vec3::ONE), 0.2, false)
            .interpolate(Vec3::new(0.47, 0.5, 0.5), &blind)[0]
            .x;
        assert!(blended > 1.5 && blended < 8.5, "{blended}");
    }

    /// The phase of the moments: Henyey–Greenstein's exactly for light from one direction, isotropic
    /// for light from all directions alike, never negative, and over all directions of travel the
    /// in-scattered power S0 (checked by a Fibonacci-sphere quadrature).
    #[test]
    fn the_moments_phase_is_exact_for_a_beam_and_conserves_power() {
        let g = 0.7;
        let wi = Vec3::new(1.0, -0.55, -0.15).normalize();
        let power = Vec3::new(2.0, 1.0, 0.5);
        let beam = [power, power * wi.x, power * wi.y, power * wi.z];
        let n = 20_000;
        let mut total = Vec3::ZERO;
        for i in 0..n {
            let z = 1.0 - (2.0 * i as f32 + 1.0) / n as f32;
            let phi = i as f32 * 2.399_963;
            let r = (1.0 - z * z).sqrt();
            let d = Vec3::new(r * phi.cos(), r * phi.sin(), z);
            let l = phase_moments(beam, d, g);
            let exact = power * crate::medium::hg(g, wi.dot(d));
            assert!(
                (l - exact).abs().max_element() <= 1e-4 * exact.max_element().max(1.0),
                "{l} {exact}"
            );
            assert!(l.min_element() >= 0.0);
            total += l * (4.0 * std::f32::consts::PI / n as f32);
        }
        assert!(
            (total / power - Vec3::ONE).abs().max_element() < 2e-3,
            "{total}"
        );
        let even = [power, Vec3::ZERO, Vec3::ZERO, Vec3::ZERO];
        let iso = phase_moments(even, Vec3::X, g);
        assert!(
            (iso - power / (4.0 * std::f32::consts::PI))
                .abs()
                .max_element()
                < 1e-6
        );
    }
}
