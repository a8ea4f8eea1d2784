//! Thin FFI to Embree 3: one triangle-mesh BVH, closest-hit and occlusion queries.
//!
//! One of the root crate's three FFI modules (with `io::oiio` and `signal`). [`Bvh`] owns the device
//! and the scene and releases them on drop; queries take `&self` and are safe to call from many
//! threads (Embree's committed scenes are read-only).
//!
//! Embree chooses its kernels by the CPU's instruction set at run time, and its kernels differ in the
//! last bits of a hit's distance and barycentrics (they divide by an approximate reciprocal, whose
//! bits also differ between CPU vendors). So Embree only *finds* the triangle a ray meets; the hit's
//! distance and barycentrics are measured again here, in f64 from the triangle's corners, which every
//! IEEE machine computes to the same bits. What stays CPU-dependent is which triangle Embree reports
//! where a ray meets an edge or two surfaces at one distance, and occlusion on such ties
//! (`docs/determinism.md`). [`ISA_VARIABLE`] forces Embree's kernels, to run as another CPU would.
//!
//! A BVH built with a [`Cutout`] has Embree filter functions that reject the hits it cuts away, on
//! closest-hit and occlusion queries alike; one built without has no filter, and costs what it did.

use std::ffi::CString;

use glam::Vec3;

use super::embree_sys::*;

/// The environment variable that forces Embree's instruction set (`sse2`, `sse4.2`, `avx`, `avx2` or
/// `avx512`), as a machine without the newer ones would run; unset, Embree takes the CPU's best.
pub const ISA_VARIABLE: &str = "PMRENDER_EMBREE_ISA";

/// The instruction sets [`ISA_VARIABLE`] may name, as Embree 3's `isa=` configuration spells them.
const ISAS: [&str; 5] = ["sse2", "sse4.2", "avx", "avx2", "avx512"];

/// One ray of a packet: origin, direction, and the range (tnear, tfar) its hit must lie in.
#[derive(Clone, Copy, Debug)]
pub struct PacketRay {
    pub origin: Vec3,
    pub dir: Vec3,
    pub tnear: f32,
    pub tfar: f32,
}

/// A closest hit: distance along the ray, triangle index, barycentrics and the unnormalised geometric
/// normal as Embree reports it (orientation follows the winding).
#[derive(Clone, Copy, Debug)]
pub struct RawHit {
    pub t: f32,
    pub prim: u32,
    pub u: f32,
    pub v: f32,
}

/// What makes parts of triangles invisible: a hit at barycentrics (u, v) of triangle `prim` that
/// [`is_cut`](Self::is_cut) is skipped as if the triangle were not there. Called from Embree's
/// traversal on every thread: it must not panic.
pub trait Cutout: Send + Sync {
    fn is_cut(&self, prim: u32, u: f32, v: f32) -> bool;
}

/// An Embree BVH over one triangle soup, with the corners of its triangles to measure hits by.
pub struct Bvh {
    device: RTCDevice,
    scene: RTCScene,
    /// Boxed: the filter functions find it through the geometry's user pointer.
    tris: Box<Triangles>,
    isa: &'static str,
}

/// The triangles' corners, and what cuts them away (`None`: no filter).
struct Triangles {
    corners: Vec<[Vec3; 3]>,
    cutout: Option<Box<dyn Cutout>>,
}

/// Embree's filter function of a BVH with a cutout: rejects each valid hit that the cutout cuts away
/// at its measured barycentrics (those the hit will be reported with).
///
/// # Safety
/// Embree calls it with `args` valid for the call, `geometry_user_ptr` the geometry's `Triangles`
/// (alive while the scene is), and `ray`/`hit` laid out as `RTCRayN`/`RTCHitN` of `n` rays.
unsafe extern "C" fn cutout_filter(args: *const RTCFilterFunctionNArguments) {
    let args = &*args;
    let tris = &*(args.geometry_user_ptr as *const Triangles);
    let Some(cutout) = &tris.cutout else {
        return;
    };
    let n = args.n as usize;
    let (ray, hit) = (args.ray as *const f32, args.hit as *const f32);
    for i in 0..n {
        let valid = args.valid.add(i);
        if *valid == 0 {
            continue;
        }
        // RTCRayN: org xyz, tnear, dir xyz, time, tfar (the potential hit's distance), …; RTCHitN:
        // Ng xyz, u, v, primID, ….
        let at = |p: *const f32, field: usize| *p.add(field * n + i);
        let origin = Vec3::new(at(ray, 0), at(ray, 1), at(ray, 2));
        let dir = Vec3::new(at(ray, 4), at(ray, 5), at(ray, 6));
        let prim = *(hit as *const u32).add(5 * n + i);
        if prim as usize >= tris.corners.len() {
            continue;
        }
        let h = tris.measured(
            origin,
            dir,
            RawHit {
                t: at(ray, 8),
                prim,
                u: at(hit, 3),
                v: at(hit, 4),
            },
        );
        if cutout.is_cut(prim, h.u, h.v) {
            *valid = 0;
        }
    }
}

// SAFETY: a committed Embree scene is immutable and Embree documents concurrent rtcIntersect1 /
// rtcOccluded1 calls on it as thread-safe; the handles are released only in Drop (&mut self).
unsafe impl Send for Bvh {}
unsafe impl Sync for Bvh {}

#[derive(Debug, thiserror::Error)]
pub enum BvhError {
    #[error("Embree could not create a device (error code {0})")]
    Device(u32),
    #[error("Embree failed to build the scene (error code {0})")]
    Build(u32),
    #[error(
        "PMRENDER_EMBREE_ISA={0:?} is not an instruction set Embree knows: set it to sse2, sse4.2, \
         avx, avx2 or avx512, or unset it"
    )]
    Isa(String),
    #[error("PMRENDER_EMBREE_ISA={0:?}: this CPU cannot run Embree's kernels for it (unset it)")]
    IsaUnsupported(String),
}

impl From<BvhError> for crate::error::Error {
    /// A forced instruction set is the user's setting (exit status 2); the rest are Embree's failures.
    fn from(e: BvhError) -> Self {
        match e {
            BvhError::Isa(_) | BvhError::IsaUnsupported(_) => Self::Input(e.to_string()),
            _ => crate::error::runtime(e),
        }
    }
}

/// The instruction sets Embree's kernels are pinned to when none is forced, the first this CPU runs:
/// AVX2 (every x86-64 CPU since 2013–2015, Intel and AMD alike), else SSE4.2. Left to itself Embree
/// would take AVX-512 where a CPU has it, and its AVX-512 and AVX2 kernels find different triangles
/// on edges, which changes every pixel of a large scene through the photons and the caches. AVX2 costs
/// nothing against AVX-512 on Sibenik, SSE4.2 about 20 % (`docs/determinism.md`).
const PINNED: [&str; 2] = ["avx2", "sse4.2"];

/// A device running the `forced` instruction set, else the first of [`PINNED`] this CPU runs, else
/// Embree's own choice (a CPU that is not x86-64); with the name of what it runs.
///
/// # Safety
/// Calls into Embree; the device returned is the caller's to release.
unsafe fn new_device(forced: Option<&'static str>) -> Result<(RTCDevice, &'static str), BvhError> {
    let config = |isa: &str| CString::new(format!("isa={isa}")).expect("no NUL in a listed name");
    if let Some(isa) = forced {
        let device = rtcNewDevice(config(isa).as_ptr());
        return match device.is_null() {
            true => Err(BvhError::IsaUnsupported(isa.to_string())),
            false => Ok((device, isa)),
        };
    }
    for isa in PINNED {
        let device = rtcNewDevice(config(isa).as_ptr());
        if !device.is_null() {
            return Ok((device, isa));
        }
    }
    let device = rtcNewDevice(std::ptr::null());
    match device.is_null() {
        true => Err(BvhError::Device(rtcGetDeviceError(std::ptr::null_mut()))),
        false => Ok((device, "Embree's choice")),
    }
}

/// The instruction set [`ISA_VARIABLE`] forces, if it is set.
fn forced_isa() -> Result<Option<&'static str>, BvhError> {
    let Some(isa) = std::env::var_os(ISA_VARIABLE) else {
        return Ok(None);
    };
    match ISAS.iter().copied().find(|known| isa == *known) {
        Some(known) => Ok(Some(known)),
        None => Err(BvhError::Isa(isa.to_string_lossy().into_owned())),
    }
}

impl Bvh {
    /// Builds the BVH. `positions` are the vertices, `triangles` index into them (already validated).
    pub fn build(positions: &[Vec3], triangles: &[[u32; 3]]) -> Result<Bvh, BvhError> {
        Self::build_on(positions, triangles, None, forced_isa()?)
    }

    /// [`build`](Self::build), the hits `cutout` cuts away skipped by every query.
    pub fn build_with_cutout(
        positions: &[Vec3],
        triangles: &[[u32; 3]],
        cutout: Box<dyn Cutout>,
    ) -> Result<Bvh, BvhError> {
        Self::build_on(positions, triangles, Some(cutout), forced_isa()?)
    }

    /// [`build`](Self::build) on Embree's kernels for `isa` (`None`: the pinned ones).
    fn build_on(
        positions: &[Vec3],
        triangles: &[[u32; 3]],
        cutout: Option<Box<dyn Cutout>>,
        isa: Option<&'static str>,
    ) -> Result<Bvh, BvhError> {
        // SAFETY: every pointer passed to Embree is either one it returned or a buffer it allocated for
        // us with exactly the size we write; errors are checked after each phase.
        unsafe {
            let (device, isa) = new_device(isa)?;
            let scene = rtcNewScene(device);
            let corners = triangles
                .iter()
                .map(|t| t.map(|i| positions[i as usize]))
                .collect();
            let bvh = Bvh {
                device,
                scene,
                tris: Box::new(Triangles { corners, cutout }),
                isa,
            };
            rtcSetSceneFlags(scene, RTC_SCENE_FLAG_ROBUST);
            rtcSetSceneBuildQuality(scene, RTC_BUILD_QUALITY_HIGH);
            if !triangles.is_empty() {
                let geom = rtcNewGeometry(device, RTC_GEOMETRY_TYPE_TRIANGLE);
                let vb = rtcSetNewGeometryBuffer(
                    geom,
                    RTC_BUFFER_TYPE_VERTEX,
                    0,
                    RTC_FORMAT_FLOAT3,
                    12,
                    positions.len(),
                ) as *mut f32;
                let ib = rtcSetNewGeometryBuffer(
                    geom,
                    RTC_BUFFER_TYPE_INDEX,
                    0,
                    RTC_FORMAT_UINT3,
                    12,
                    triangles.len(),
                ) as *mut u32;
                if vb.is_null() || ib.is_null() {
                    rtcReleaseGeometry(geom);
                    return Err(BvhError::Build(rtcGetDeviceError(device)));
                }
                let vs = std::slice::from_raw_parts_mut(vb, positions.len() * 3);
                for (i, p) in positions.iter().enumerate() {
                    vs[3 * i..3 * i + 3].copy_from_slice(&p.to_array());
                }
                let is = std::slice::from_raw_parts_mut(ib, triangles.len() * 3);
                for (i, t) in triangles.iter().enumerate() {
                    is[3 * i..3 * i + 3].copy_from_slice(t);
                }
                if bvh.tris.cutout.is_some() {
                    // The box's address stays fixed while the Bvh (and so the scene) lives.
                    let user = &*bvh.tris as *const Triangles as *mut std::os::raw::c_void;
                    rtcSetGeometryUserData(geom, user);
                    rtcSetGeometryIntersectFilterFunction(geom, Some(cutout_filter));
                    rtcSetGeometryOccludedFilterFunction(geom, Some(cutout_filter));
                }
                rtcCommitGeometry(geom);
                rtcAttachGeometry(scene, geom);
                rtcReleaseGeometry(geom);
            }
            rtcCommitScene(scene);
            let err = rtcGetDeviceError(device);
            if err != 0 {
                return Err(BvhError::Build(err));
            }
            Ok(bvh)
        }
    }

    /// The instruction set Embree's kernels run (one of [`ISAS`], or "Embree's choice").
    pub fn isa(&self) -> &'static str {
        self.isa
    }

    fn context() -> RTCIntersectContext {
        RTCIntersectContext {
            flags: 0,
            filter: std::ptr::null(),
            inst_id: [RTC_INVALID_GEOMETRY_ID],
        }
    }

    fn ray(origin: Vec3, dir: Vec3, tmax: f32) -> RTCRay {
        RTCRay {
            org: origin.to_array(),
            tnear: 0.0,
            dir: dir.to_array(),
            time: 0.0,
            tfar: tmax,
            mask: u32::MAX,
            id: 0,
            flags: 0,
        }
    }

    /// Closest hit in (0, tmax).
    pub fn intersect(&self, origin: Vec3, dir: Vec3, tmax: f32) -> Option<RawHit> {
        self.intersect_range(origin, dir, 0.0, tmax)
    }

    /// Closest hit in (tnear, tmax), `t` measured from `origin`: the same ray continued past a surface it
    /// crossed (an invisible medium boundary) without moving its origin off its line.
    pub fn intersect_range(
        &self,
        origin: Vec3,
        dir: Vec3,
        tnear: f32,
        tmax: f32,
    ) -> Option<RawHit> {
        let mut ctx = Self::context();
        let mut ray = Self::ray(origin, dir, tmax);
        ray.tnear = tnear;
        let mut rh = RTCRayHit {
            ray,
            hit: RTCHit {
                ng: [0.0; 3],
                u: 0.0,
                v: 0.0,
                prim_id: 0,
                geom_id: RTC_INVALID_GEOMETRY_ID,
                inst_id: [RTC_INVALID_GEOMETRY_ID],
            },
        };
        // SAFETY: scene is committed; ctx and rh are valid, aligned and live for the call.
        unsafe { rtcIntersect1(self.scene, &mut ctx, &mut rh) };
        (rh.hit.geom_id != RTC_INVALID_GEOMETRY_ID).then(|| {
            self.tris.measured(
                origin,
                dir,
                RawHit {
                    t: rh.ray.tfar,
                    prim: rh.hit.prim_id,
                    u: rh.hit.u,
                    v: rh.hit.v,
                },
            )
        })
    }

    /// The closest hit of each of up to 8 rays that start close together and run alike (the probes of a
    /// photon disc's coverage), traced as one coherent packet: `out[i]` is `rays[i]`'s, as
    /// [`intersect_range`](Self::intersect_range) would find it.
    pub fn intersect8(&self, rays: &[PacketRay], out: &mut [Option<RawHit>]) {
        assert!(rays.len() <= 8 && out.len() >= rays.len());
        let mut ctx = Self::context();
        ctx.flags = RTC_INTERSECT_CONTEXT_FLAG_COHERENT;
        let mut valid = Valid8([0; 8]);
        let mut rh = RTCRayHit8 {
            org: [[0.0; 8]; 3],
            tnear: [0.0; 8],
            // Invalid lanes are never traced; a unit direction keeps them well-formed all the same.
            dir: [[0.0; 8], [0.0; 8], [1.0; 8]],
            time: [0.0; 8],
            tfar: [0.0; 8],
            mask: [u32::MAX; 8],
            id: [0; 8],
            flags: [0; 8],
            ng: [[0.0; 8]; 3],
            u: [0.0; 8],
            v: [0.0; 8],
            prim_id: [0; 8],
            geom_id: [RTC_INVALID_GEOMETRY_ID; 8],
            inst_id: [[RTC_INVALID_GEOMETRY_ID; 8]; 1],
        };
        for (i, r) in rays.iter().enumerate() {
            valid.0[i] = -1;
            for a in 0..3 {
                rh.org[a][i] = r.origin[a];
                rh.dir[a][i] = r.dir[a];
            }
            rh.tnear[i] = r.tnear;
            rh.tfar[i] = r.tfar;
        }
        // SAFETY: scene is committed; `valid` and `rh` are 32-byte aligned, laid out as Embree's int[8]
        // and RTCRayHit8, and live for the call; lanes past `rays.len()` are marked invalid.
        unsafe { rtcIntersect8(valid.0.as_ptr(), self.scene, &mut ctx, &mut rh) };
        for (i, r) in rays.iter().enumerate() {
            out[i] = (rh.geom_id[i] != RTC_INVALID_GEOMETRY_ID).then(|| {
                self.tris.measured(
                    r.origin,
                    r.dir,
                    RawHit {
                        t: rh.tfar[i],
                        prim: rh.prim_id[i],
                        u: rh.u[i],
                        v: rh.v[i],
                    },
                )
            });
        }
    }

    /// Whether anything blocks the segment (0, tmax).
    pub fn occluded(&self, origin: Vec3, dir: Vec3, tmax: f32) -> bool {
        let mut ctx = Self::context();
        let mut ray = Self::ray(origin, dir, tmax);
        // SAFETY: as in `intersect`; Embree sets tfar to -inf when the ray is occluded.
        unsafe { rtcOccluded1(self.scene, &mut ctx, &mut ray) };
        ray.tfar < 0.0
    }
}

impl Triangles {
    /// `hit` with its distance and barycentrics measured again from its triangle's corners in f64
    /// (Möller–Trumbore; the same bits on every IEEE machine, unlike Embree's kernels), the
    /// barycentrics kept inside the triangle; Embree's own where the ray runs in the triangle's plane.
    fn measured(&self, origin: Vec3, dir: Vec3, hit: RawHit) -> RawHit {
        let [a, b, c] = self.corners[hit.prim as usize].map(|p| p.as_dvec3());
        let (o, d) = (origin.as_dvec3(), dir.as_dvec3());
        let (e1, e2) = (b - a, c - a);
        let p = d.cross(e2);
        let det = e1.dot(p);
        let s = o - a;
        let q = s.cross(e1);
        let (t, u, v) = (e2.dot(q) / det, s.dot(p) / det, d.dot(q) / det);
        if !(t.is_finite() && u.is_finite() && v.is_finite()) {
            return hit;
        }
        let (u, v) = (u.clamp(0.0, 1.0), v.clamp(0.0, 1.0));
        let (u, v) = if u + v > 1.0 {
            (u / (u + v), v / (u + v))
        } else {
            (u, v)
        };
        RawHit {
            t: t as f32,
            u: u as f32,
            v: v as f32,
            ..hit
        }
    }
}

impl Drop for Bvh {
    fn drop(&mut self) {
        // SAFETY: handles were created in `build` and are released exactly once.
        unsafe {
            rtcReleaseScene(self.scene);
            rtcReleaseDevice(self.device);
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// Vertices, triangles over them, and rays (origin, unit direction).
    type Soup = (Vec<Vec3>, Vec<[u32; 3]>, Vec<(Vec3, Vec3)>);

    /// A few thousand small triangles in a unit box, from a fixed LCG, and rays through it.
    fn soup() -> Soup {
        let mut state = 0x2545_f491_4f6c_dd1du64;
        let mut next = move || {
            state = state
                .wrapping_mul(6_364_136_223_846_793_005)
                .wrapping_add(1_442_695_040_888_963_407);
            (state >> 40) as f32 / (1u64 << 24) as f32
        };
        let mut positions = Vec::new();
        let mut triangles = Vec::new();
        for i in 0..3000u32 {
            let c = Vec3::new(next(), next(), next());
            for _ in 0..3 {
                positions.push(c + 0.1 * Vec3::new(next() - 0.5, next() - 0.5, next() - 0.5));
            }
            triangles.push([3 * i, 3 * i + 1, 3 * i + 2]);
        }
        let rays = (0..20_000)
            .map(|_| {
                let o = Vec3::new(next(), next(), -1.0);
                let to = Vec3::new(next(), next(), 2.0);
                (o, (to - o).normalize())
            })
            .collect();
        (positions, triangles, rays)
    }

    /// Embree's kernels for different instruction sets find the same triangles (but on ties), and a
    /// hit on the same triangle has the same bits of distance and barycentrics whichever found it.
    #[test]
    fn a_hit_has_the_same_bits_whatever_instruction_set_found_it() {
        let (positions, triangles, rays) = soup();
        let pinned = Bvh::build_on(&positions, &triangles, None, None).unwrap();
        let mut compared = 0;
        for isa in ["sse4.2", "avx2", "avx512"] {
            // An instruction set this CPU lacks is not compared.
            let Ok(other) = Bvh::build_on(&positions, &triangles, None, Some(isa)) else {
                continue;
            };
            compared += 1;
            let (mut same_prim, mut hits) = (0, 0);
            for &(o, d) in &rays {
                let (a, b) = (pinned.intersect(o, d, 10.0), other.intersect(o, d, 10.0));
                let Some(a) = a else { continue };
                hits += 1;
                let Some(b) = b.filter(|b| b.prim == a.prim) else {
                    continue;
                };
                same_prim += 1;
                assert_eq!(
                    (a.t.to_bits(), a.u.to_bits(), a.v.to_bits()),
                    (b.t.to_bits(), b.u.to_bits(), b.v.to_bits()),
                    "{isa}: {a:?} against {b:?}"
                );
            }
            assert!(hits > 10_000, "{hits}");
            assert!(
                same_prim * 1000 >= hits * 999,
                "{isa}: {same_prim} of {hits}"
            );
        }
        // Every x86-64 CPU runs SSE4.2's kernels (and AVX2's but the oldest): at least one compared.
        #[cfg(target_arch = "x86_64")]
        assert!(compared >= 1, "no other instruction set ran here");
    }

    /// A measured hit lies on its triangle's plane and within it: the barycentric point is the ray's
    /// point at `t` to a few ulps of the scene.
    #[test]
    fn a_measured_hit_is_where_the_ray_meets_the_triangle() {
        let (positions, triangles, rays) = soup();
        let bvh = Bvh::build_on(&positions, &triangles, None, None).unwrap();
        for &(o, d) in &rays {
            let Some(h) = bvh.intersect(o, d, 10.0) else {
                continue;
            };
            let [a, b, c] = triangles[h.prim as usize].map(|i| positions[i as usize]);
            let bary = a * (1.0 - h.u - h.v) + b * h.u + c * h.v;
            assert!(h.u >= 0.0 && h.v >= 0.0 && h.u + h.v <= 1.0, "{h:?}");
            assert!((bary - (o + d * h.t)).length() < 1e-5, "{h:?}");
        }
    }

    /// Cuts away the even triangles, and the half u > v of the odd ones.
    struct EvenAndHalf;

    impl Cutout for EvenAndHalf {
        fn is_cut(&self, prim: u32, u: f32, v: f32) -> bool {
            prim.is_multiple_of(2) || u > v
        }
    }

    /// A cut hit is never reported and never occludes, for single rays and packets alike; each ray's hit
    /// is the closest uncut one of the soup without the filter, found by re-tracing past cut hits.
    #[test]
    fn cut_hits_are_skipped_by_every_query() {
        let (positions, triangles, rays) = soup();
        let plain = Bvh::build_on(&positions, &triangles, None, None).unwrap();
        let cut = Bvh::build_on(&positions, &triangles, Some(Box::new(EvenAndHalf)), None).unwrap();
        let (mut n_hits, mut n_skipped) = (0, 0);
        for chunk in rays.chunks(8) {
            let packet: Vec<PacketRay> = chunk
                .iter()
                .map(|&(origin, dir)| PacketRay {
                    origin,
                    dir,
                    tnear: 0.0,
                    tfar: 10.0,
                })
                .collect();
            let mut hits8 = [None; 8];
            cut.intersect8(&packet, &mut hits8);
            for (k, &(o, d)) in chunk.iter().enumerate() {
                // The closest uncut hit, by stepping past cut ones on the unfiltered BVH.
                let mut t0 = 0.0;
                let expected = loop {
                    match plain.intersect_range(o, d, t0, 10.0) {
                        Some(h) if EvenAndHalf.is_cut(h.prim, h.u, h.v) => {
                            n_skipped += 1;
                            t0 = h.t + 1e-5;
                        }
                        h => break h,
                    }
                };
                let got = cut.intersect(o, d, 10.0);
                assert_eq!(got.map(|h| h.prim), expected.map(|h| h.prim), "{o} {d}");
                assert_eq!(hits8[k].map(|h| h.prim), got.map(|h| h.prim));
                if let Some(h) = got {
                    n_hits += 1;
                    assert!(!EvenAndHalf.is_cut(h.prim, h.u, h.v), "{h:?}");
                }
                assert_eq!(cut.occluded(o, d, 10.0), got.is_some());
            }
        }
        assert!(n_hits > 1000 && n_skipped > 1000, "{n_hits} {n_skipped}");
    }
}
