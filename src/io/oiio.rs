//! Safe wrapper over the OpenImageIO shim (`oiio_shim.cpp`): write float EXR and 8-bit PNG, read images.

use std::ffi::{CStr, CString};
use std::os::raw::{c_char, c_int};
use std::path::Path;

extern "C" {
    fn pm_write_image(
        path: *const c_char,
        width: c_int,
        height: c_int,
        nchannels: c_int,
        names: *const *const c_char,
        data: *const std::ffi::c_void,
        is_u8: c_int,
        err: *mut c_char,
        errlen: usize,
    ) -> c_int;
    fn pm_read_image(
        path: *const c_char,
        width: *mut c_int,
        height: *mut c_int,
        nchannels: *mut c_int,
        data: *mut *mut f32,
        err: *mut c_char,
        errlen: usize,
    ) -> c_int;
    fn pm_image_channels(
        path: *const c_char,
        names: *mut c_char,
        len: usize,
        err: *mut c_char,
        errlen: usize,
    ) -> c_int;
    fn pm_image_size(
        path: *const c_char,
        width: *mut c_int,
        height: *mut c_int,
        nchannels: *mut c_int,
        err: *mut c_char,
        errlen: usize,
    ) -> c_int;
    fn pm_free_image(data: *mut f32);
}

fn c_path(path: &Path) -> Result<CString, String> {
    CString::new(path.to_string_lossy().as_bytes())
        .map_err(|_| "path contains a NUL byte".to_string())
}

fn c_text(buf: &[u8]) -> String {
    CStr::from_bytes_until_nul(buf)
        .map(|c| c.to_string_lossy().into_owned())
        .unwrap_or_default()
}

/// An error from the shim on one line (OpenImageIO joins several with newlines).
fn err_text(buf: &[u8]) -> String {
    c_text(buf)
        .lines()
        .map(str::trim)
        .filter(|l| !l.is_empty())
        .collect::<Vec<_>>()
        .join("; ")
}

/// Pixel data handed to the writer: float (EXR) or 8-bit (PNG), interleaved by channel.
pub enum Pixels<'a> {
    F32(&'a [f32]),
    U8(&'a [u8]),
}

/// Writes an image with the given channel names; the format follows the extension.
pub fn write(
    path: &Path,
    width: u32,
    height: u32,
    names: &[&str],
    pixels: Pixels,
) -> Result<(), String> {
    let n = width as usize * height as usize * names.len();
    let (ptr, len, is_u8) = match pixels {
        Pixels::F32(d) => (d.as_ptr() as *const std::ffi::c_void, d.len(), 0),
        Pixels::U8(d) => (d.as_ptr() as *const std::ffi::c_void, d.len(), 1),
    };
    if len != n {
        return Err(format!("internal: {len} values for {n} channels×pixels"));
    }
    let cpath = c_path(path)?;
    let cnames: Vec<CString> = names
        .iter()
        .map(|s| CString::new(*s).unwrap_or_default())
        .collect();
    let name_ptrs: Vec<*const c_char> = cnames.iter().map(|c| c.as_ptr()).collect();
    let mut err = vec![0u8; 1024];
    // SAFETY: all pointers are valid for the call; `ptr` covers width×height×nchannels values of the
    // declared type (checked above).
    let rc = unsafe {
        pm_write_image(
            cpath.as_ptr(),
            width as c_int,
            height as c_int,
            names.len() as c_int,
            name_ptrs.as_ptr(),
            ptr,
            is_u8,
            err.as_mut_ptr() as *mut c_char,
            err.len(),
        )
    };
    if rc == 0 {
        Ok(())
    } else {
        Err(err_text(&err))
    }
}

/// A float image as read from disk.
pub struct ImageData {
    pub width: u32,
    pub height: u32,
    pub channels: u32,
    pub data: Vec<f32>,
}

pub fn read(path: &Path) -> Result<ImageData, String> {
    let cpath = c_path(path)?;
    let (mut w, mut h, mut c) = (0, 0, 0);
    let mut data: *mut f32 = std::ptr::null_mut();
    let mut err = vec![0u8; 1024];
    // SAFETY: out-pointers are valid; on success the shim allocated w*h*c floats that we copy and free.
    unsafe {
        let rc = pm_read_image(
            cpath.as_ptr(),
            &mut w,
            &mut h,
            &mut c,
            &mut data,
            err.as_mut_ptr() as *mut c_char,
            err.len(),
        );
        if rc != 0 || data.is_null() {
            return Err(err_text(&err));
        }
        let n = w as usize * h as usize * c as usize;
        let v = std::slice::from_raw_parts(data, n).to_vec();
        pm_free_image(data);
        Ok(ImageData {
            width: w as u32,
            height: h as u32,
            channels: c as u32,
            data: v,
        })
    }
}

/// Width, height and channel count from an image file's header, without decoding its pixels.
pub fn image_size(path: &Path) -> Result<(u32, u32, u32), String> {
    let cpath = c_path(path)?;
    let (mut w, mut h, mut c) = (0, 0, 0);
    let mut err = vec![0u8; 1024];
    // SAFETY: out-pointers and the error buffer are valid for the call; its length is passed.
    let rc = unsafe {
        pm_image_size(
            cpath.as_ptr(),
            &mut w,
            &mut h,
            &mut c,
            err.as_mut_ptr() as *mut c_char,
            err.len(),
        )
    };
    if rc != 0 {
        return Err(err_text(&err));
    }
    let dim = |v: c_int| {
        u32::try_from(v).map_err(|_| format!("image header gives a negative size ({w}×{h}×{c})"))
    };
    Ok((dim(w)?, dim(h)?, dim(c)?))
}

/// The channel names stored in an image file.
pub fn channel_names(path: &Path) -> Result<Vec<String>, String> {
    let cpath = c_path(path)?;
    let mut names = vec![0u8; 8192];
    let mut err = vec![0u8; 1024];
    // SAFETY: buffers are valid and their lengths are passed.
    let rc = unsafe {
        pm_image_channels(
            cpath.as_ptr(),
            names.as_mut_ptr() as *mut c_char,
            names.len(),
            err.as_mut_ptr() as *mut c_char,
            err.len(),
        )
    };
    if rc != 0 {
        return Err(err_text(&err));
    }
    Ok(c_text(&names).lines().map(str::to_string).collect())
}
