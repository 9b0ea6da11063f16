//! Puts the repository's `memory.x` where the linker (cortex-m-rt's `link.x`) finds it.
use std::path::PathBuf;
use std::{env, fs};

fn main() {
    let out = PathBuf::from(env::var_os("OUT_DIR").unwrap());
    let memory = PathBuf::from(env::var_os("CARGO_MANIFEST_DIR").unwrap()).join("../memory.x");
    fs::copy(&memory, out.join("memory.x")).unwrap();
    println!("cargo:rustc-link-search={}", out.display());
    println!("cargo:rerun-if-changed={}", memory.display());
}
