//! Links the system FLANN library (C API). pkg-config's `flann.pc` drags in HDF5 and MPI, which the
//! C API does not need, so the library is named directly.
fn main() {
    println!("cargo:rerun-if-changed=build.rs");
    println!("cargo:rustc-link-lib=flann");
}
