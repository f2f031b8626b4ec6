//! Links with cortex-m-rt's `link.x` and the workspace root's `memory.x` (the board
//! layout with 1 MiB of flash: this image is only linked, never run).
use std::env;

fn main() {
    println!("cargo:rerun-if-changed=../../memory.x");
    println!("cargo:rerun-if-changed=build.rs");
    if env::var("TARGET").is_ok_and(|t| t.starts_with("thumb")) {
        println!("cargo:rustc-link-arg-bins=-Tlink.x");
        // Every machine's periods side by side (the joints, the delta slave, ARROW, the
        // remote master and slave, the grinding cell), which no board image holds:
        // they pass the board's 512 KiB of flash. The images are only linked, so they
        // get 1 MiB; the proof is about the code's panic paths, not its size.
        println!("cargo:rustc-link-arg-bins=--defsym=_kerf_flash_length=0x100000");
    }
}
