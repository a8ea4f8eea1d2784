//! Builds the OpenImageIO shim and links Embree 3.
fn main() {
    println!("cargo:rerun-if-changed=src/io/oiio_shim.cpp");
    let oiio = pkg_config::Config::new()
        .cargo_metadata(true)
        .probe("OpenImageIO");
    let mut build = cc::Build::new();
    build
        .cpp(true)
        .file("src/io/oiio_shim.cpp")
        .flag_if_supported("-std=c++17")
        .warnings(false);
    if let Ok(lib) = &oiio {
        for p in &lib.include_paths {
            build.include(p);
        }
    } else {
        println!("cargo:rustc-link-lib=OpenImageIO");
        println!("cargo:rustc-link-lib=OpenImageIO_Util");
    }
    build.compile("pm_oiio_shim");
    println!("cargo:rustc-link-lib=embree3");
}
