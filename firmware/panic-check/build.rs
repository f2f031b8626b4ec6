//! Links with cortex-m-rt's `link.x` and the workspace root's `memory.x` (the board
//! layout: this image is only linked, never run).
use std::env;

fn main() {
    println!("cargo:rerun-if-changed=../../memory.x");
    println!("cargo:rerun-if-changed=build.rs");
    if env::var("TARGET").is_ok_and(|t| t.starts_with("thumb")) {
        println!("cargo:rustc-link-arg-bins=-Tlink.x");
    }
}
