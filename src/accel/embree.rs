//! Thin FFI to Embree 3: one triangle-mesh BVH, closest-hit and occlusion queries.
//!
//! One of the root crate's three FFI modules (with `io::oiio` and `signal`). [`Bvh`] owns the device
//! and the scene and releases them on drop; queries take `&self` and are safe to call from many
//! threads (Embree's committed scenes are read-only).
#![allow(non_camel_case_types)]

use std::os::raw::{c_char, c_uint, c_void};

use glam::Vec3;

type RTCDevice = *mut c_void;
type RTCScene = *mut c_void;
type RTCGeometry = *mut c_void;

const RTC_GEOMETRY_TYPE_TRIANGLE: c_uint = 0;
const RTC_BUFFER_TYPE_INDEX: c_uint = 0;
const RTC_BUFFER_TYPE_VERTEX: c_uint = 1;
const RTC_FORMAT_UINT3: c_uint = 0x5003;
const RTC_FORMAT_FLOAT3: c_uint = 0x9003;
const RTC_SCENE_FLAG_ROBUST: c_uint = 1 << 2;
const RTC_BUILD_QUALITY_HIGH: c_uint = 2;
const RTC_INVALID_GEOMETRY_ID: c_uint = u32::MAX;

#[repr(C)]
struct RTCIntersectContext {
    flags: c_uint,
    filter: *const c_void,
    inst_id: [c_uint; 1],
}

#[repr(C, align(16))]
#[derive(Clone, Copy)]
struct RTCRay {
    org: [f32; 3],
    tnear: f32,
    dir: [f32; 3],
    time: f32,
    tfar: f32,
    mask: c_uint,
    id: c_uint,
    flags: c_uint,
}

#[repr(C, align(16))]
#[derive(Clone, Copy)]
struct RTCHit {
    ng: [f32; 3],
    u: f32,
    v: f32,
    prim_id: c_uint,
    geom_id: c_uint,
    inst_id: [c_uint; 1],
}

#[repr(C, align(16))]
struct RTCRayHit {
    ray: RTCRay,
    hit: RTCHit,
}

/// Rays and hits of a packet of 8 (Embree's `RTCRayHit8`, structure of arrays).
#[repr(C, align(32))]
struct RTCRayHit8 {
    org: [[f32; 8]; 3],
    tnear: [f32; 8],
    dir: [[f32; 8]; 3],
    time: [f32; 8],
    tfar: [f32; 8],
    mask: [c_uint; 8],
    id: [c_uint; 8],
    flags: [c_uint; 8],
    ng: [[f32; 8]; 3],
    u: [f32; 8],
    v: [f32; 8],
    prim_id: [c_uint; 8],
    geom_id: [c_uint; 8],
    inst_id: [[c_uint; 8]; 1],
}

#[repr(C, align(32))]
struct Valid8([i32; 8]);

/// Context flag: the rays of a packet start close together and run alike.
const RTC_INTERSECT_CONTEXT_FLAG_COHERENT: c_uint = 1;

/// One ray of a packet: origin, direction, and the range (tnear, tfar) its hit must lie in.
#[derive(Clone, Copy, Debug)]
pub struct PacketRay {
    pub origin: Vec3,
    pub dir: Vec3,
    pub tnear: f32,
    pub tfar: f32,
}

#[link(name = "embree3")]
extern "C" {
    fn rtcNewDevice(config: *const c_char) -> RTCDevice;
    fn rtcReleaseDevice(device: RTCDevice);
    fn rtcGetDeviceError(device: RTCDevice) -> c_uint;
    fn rtcNewScene(device: RTCDevice) -> RTCScene;
    fn rtcReleaseScene(scene: RTCScene);
    fn rtcSetSceneFlags(scene: RTCScene, flags: c_uint);
    fn rtcSetSceneBuildQuality(scene: RTCScene, quality: c_uint);
    fn rtcNewGeometry(device: RTCDevice, ty: c_uint) -> RTCGeometry;
    fn rtcSetNewGeometryBuffer(
        geometry: RTCGeometry,
        ty: c_uint,
        slot: c_uint,
        format: c_uint,
        byte_stride: usize,
        item_count: usize,
    ) -> *mut c_void;
    fn rtcCommitGeometry(geometry: RTCGeometry);
    fn rtcAttachGeometry(scene: RTCScene, geometry: RTCGeometry) -> c_uint;
    fn rtcReleaseGeometry(geometry: RTCGeometry);
    fn rtcCommitScene(scene: RTCScene);
    fn rtcIntersect1(scene: RTCScene, context: *mut RTCIntersectContext, rayhit: *mut RTCRayHit);
    fn rtcIntersect8(
        valid: *const i32,
        scene: RTCScene,
        context: *mut RTCIntersectContext,
        rayhit: *mut RTCRayHit8,
    );
    fn rtcOccluded1(scene: RTCScene, context: *mut RTCIntersectContext, ray: *mut RTCRay);
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

/// An Embree BVH over one triangle soup.
pub struct Bvh {
    device: RTCDevice,
    scene: RTCScene,
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
}

impl Bvh {
    /// Builds the BVH. `positions` are the vertices, `triangles` index into them (already validated).
    pub fn build(positions: &[Vec3], triangles: &[[u32; 3]]) -> Result<Bvh, BvhError> {
        // SAFETY: every pointer passed to Embree is either one it returned or a buffer it allocated for
        // us with exactly the size we write; errors are checked after each phase.
        unsafe {
            let device = rtcNewDevice(std::ptr::null());
            if device.is_null() {
                return Err(BvhError::Device(rtcGetDeviceError(std::ptr::null_mut())));
            }
            let scene = rtcNewScene(device);
            let bvh = Bvh { device, scene };
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
        (rh.hit.geom_id != RTC_INVALID_GEOMETRY_ID).then_some(RawHit {
            t: rh.ray.tfar,
            prim: rh.hit.prim_id,
            u: rh.hit.u,
            v: rh.hit.v,
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
        for i in 0..rays.len() {
            out[i] = (rh.geom_id[i] != RTC_INVALID_GEOMETRY_ID).then_some(RawHit {
                t: rh.tfar[i],
                prim: rh.prim_id[i],
                u: rh.u[i],
                v: rh.v[i],
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

impl Drop for Bvh {
    fn drop(&mut self) {
        // SAFETY: handles were created in `build` and are released exactly once.
        unsafe {
            rtcReleaseScene(self.scene);
            rtcReleaseDevice(self.device);
        }
    }
}
