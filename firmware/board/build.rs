//! Links with cortex-m-rt's `link.x`, which includes the workspace root's `memory.x`
//! (the STM32G474RE: 512 KiB flash, 128 KiB SRAM), and with defmt's `defmt.x`.
use std::env;

fn main() {
    println!("cargo:rerun-if-changed=../../memory.x");
    println!("cargo:rerun-if-changed=build.rs");
    if env::var("TARGET").is_ok_and(|t| t.starts_with("thumb")) {
        println!("cargo:rustc-link-arg-bins=-Tlink.x");
        println!("cargo:rustc-link-arg-bins=-Tdefmt.x");
    }
}
