//! Tells the person running the tests, at build time, when the shared pbrt-v3
//! scenes are missing and the tests that compare against them will skip.

use std::path::PathBuf;

fn main() {
    println!("cargo:rerun-if-env-changed=FARM_SHARED");
    let shared = std::env::var_os("FARM_SHARED").map(PathBuf::from).unwrap_or_else(|| {
        PathBuf::from(std::env::var_os("CARGO_MANIFEST_DIR").unwrap_or_default())
            .join("../../shared")
    });
    let readme = shared.join("reference/README.md");
    println!("cargo:rerun-if-changed={}", readme.display());
    if !readme.is_file() {
        println!(
            "cargo:warning=no pbrt-v3 scenes at {}: the tests against pbrt-v3's images will be skipped (set FARM_SHARED)",
            shared.display()
        );
    }
}
