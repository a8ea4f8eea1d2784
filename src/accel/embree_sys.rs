//! Embree 3's C API as far as [`super::embree`] calls it: handles, the ray and hit layouts of
//! `rtcore_ray.h`, and the functions (the root crate's FFI, with `io::oiio` and `signal`).
#![allow(non_camel_case_types)]

use std::os::raw::{c_char, c_uint, c_void};

pub(super) type RTCDevice = *mut c_void;
pub(super) type RTCScene = *mut c_void;
pub(super) type RTCGeometry = *mut c_void;

pub(super) const RTC_GEOMETRY_TYPE_TRIANGLE: c_uint = 0;
pub(super) const RTC_BUFFER_TYPE_INDEX: c_uint = 0;
pub(super) const RTC_BUFFER_TYPE_VERTEX: c_uint = 1;
pub(super) const RTC_FORMAT_UINT3: c_uint = 0x5003;
pub(super) const RTC_FORMAT_FLOAT3: c_uint = 0x9003;
pub(super) const RTC_SCENE_FLAG_ROBUST: c_uint = 1 << 2;
pub(super) const RTC_BUILD_QUALITY_HIGH: c_uint = 2;
pub(super) const RTC_INVALID_GEOMETRY_ID: c_uint = u32::MAX;

#[repr(C)]
pub(super) struct RTCIntersectContext {
    pub(super) flags: c_uint,
    pub(super) filter: *const c_void,
    pub(super) inst_id: [c_uint; 1],
}

#[repr(C, align(16))]
#[derive(Clone, Copy)]
pub(super) struct RTCRay {
    pub(super) org: [f32; 3],
    pub(super) tnear: f32,
    pub(super) dir: [f32; 3],
    pub(super) time: f32,
    pub(super) tfar: f32,
    pub(super) mask: c_uint,
    pub(super) id: c_uint,
    pub(super) flags: c_uint,
}

#[repr(C, align(16))]
#[derive(Clone, Copy)]
pub(super) struct RTCHit {
    pub(super) ng: [f32; 3],
    pub(super) u: f32,
    pub(super) v: f32,
    pub(super) prim_id: c_uint,
    pub(super) geom_id: c_uint,
    pub(super) inst_id: [c_uint; 1],
}

#[repr(C, align(16))]
pub(super) struct RTCRayHit {
    pub(super) ray: RTCRay,
    pub(super) hit: RTCHit,
}

/// Rays and hits of a packet of 8 (Embree's `RTCRayHit8`, structure of arrays).
#[repr(C, align(32))]
pub(super) struct RTCRayHit8 {
    pub(super) org: [[f32; 8]; 3],
    pub(super) tnear: [f32; 8],
    pub(super) dir: [[f32; 8]; 3],
    pub(super) time: [f32; 8],
    pub(super) tfar: [f32; 8],
    pub(super) mask: [c_uint; 8],
    pub(super) id: [c_uint; 8],
    pub(super) flags: [c_uint; 8],
    pub(super) ng: [[f32; 8]; 3],
    pub(super) u: [f32; 8],
    pub(super) v: [f32; 8],
    pub(super) prim_id: [c_uint; 8],
    pub(super) geom_id: [c_uint; 8],
    pub(super) inst_id: [[c_uint; 8]; 1],
}

#[repr(C, align(32))]
pub(super) struct Valid8(pub(super) [i32; 8]);

/// What Embree hands a geometry's filter function: one potential hit of each of `n` rays (structure
/// of arrays: `ray` as `RTCRayN`, `hit` as `RTCHitN`); clearing `valid[i]` rejects ray i's hit.
#[repr(C)]
pub(super) struct RTCFilterFunctionNArguments {
    pub(super) valid: *mut i32,
    pub(super) geometry_user_ptr: *mut c_void,
    pub(super) context: *mut RTCIntersectContext,
    pub(super) ray: *mut c_void,
    pub(super) hit: *mut c_void,
    pub(super) n: c_uint,
}

pub(super) type RTCFilterFunctionN = unsafe extern "C" fn(args: *const RTCFilterFunctionNArguments);

/// Context flag: the rays of a packet start close together and run alike.
pub(super) const RTC_INTERSECT_CONTEXT_FLAG_COHERENT: c_uint = 1;

#[link(name = "embree3")]
extern "C" {
    pub(super) fn rtcNewDevice(config: *const c_char) -> RTCDevice;
    pub(super) fn rtcReleaseDevice(device: RTCDevice);
    pub(super) fn rtcGetDeviceError(device: RTCDevice) -> c_uint;
    pub(super) fn rtcNewScene(device: RTCDevice) -> RTCScene;
    pub(super) fn rtcReleaseScene(scene: RTCScene);
    pub(super) fn rtcSetSceneFlags(scene: RTCScene, flags: c_uint);
    pub(super) fn rtcSetSceneBuildQuality(scene: RTCScene, quality: c_uint);
    pub(super) fn rtcNewGeometry(device: RTCDevice, ty: c_uint) -> RTCGeometry;
    pub(super) fn rtcSetNewGeometryBuffer(
        geometry: RTCGeometry,
        ty: c_uint,
        slot: c_uint,
        format: c_uint,
        byte_stride: usize,
        item_count: usize,
    ) -> *mut c_void;
    pub(super) fn rtcCommitGeometry(geometry: RTCGeometry);
    pub(super) fn rtcSetGeometryUserData(geometry: RTCGeometry, ptr: *mut c_void);
    pub(super) fn rtcSetGeometryIntersectFilterFunction(
        geometry: RTCGeometry,
        filter: Option<RTCFilterFunctionN>,
    );
    pub(super) fn rtcSetGeometryOccludedFilterFunction(
        geometry: RTCGeometry,
        filter: Option<RTCFilterFunctionN>,
    );
    pub(super) fn rtcAttachGeometry(scene: RTCScene, geometry: RTCGeometry) -> c_uint;
    pub(super) fn rtcReleaseGeometry(geometry: RTCGeometry);
    pub(super) fn rtcCommitScene(scene: RTCScene);
    pub(super) fn rtcIntersect1(
        scene: RTCScene,
        context: *mut RTCIntersectContext,
        rayhit: *mut RTCRayHit,
    );
    pub(super) fn rtcIntersect8(
        valid: *const i32,
        scene: RTCScene,
        context: *mut RTCIntersectContext,
        rayhit: *mut RTCRayHit8,
    );
    pub(super) fn rtcOccluded1(
        scene: RTCScene,
        context: *mut RTCIntersectContext,
        ray: *mut RTCRay,
    );
}
