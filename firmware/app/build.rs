//! Links with cortex-m-rt's `link.x` and the workspace root's `memory.x` (STM32G474RE).
//! With the `qemu` feature the flash region moves to 0x0 for QEMU's mps2-an386; see the
//! comment in `memory.x` for why this is a symbol rather than a second layout file.
use std::env;

fn main() {
    println!("cargo:rerun-if-changed=../../memory.x");
    println!("cargo:rerun-if-changed=build.rs");
    println!("cargo:rerun-if-changed=../../data/remote_commands.krfr");
    if env::var("TARGET").is_ok_and(|t| t.starts_with("thumb")) {
        if env::var_os("CARGO_FEATURE_QEMU").is_some() {
            println!("cargo:rustc-link-arg-bins=--defsym=_kerf_flash_origin=0");
            // The contour image's simulated plant, operator and queues need more than
            // the board's 128 KiB (memory.x); 1 MiB of the model's 4 MiB SRAM.
            println!("cargo:rustc-link-arg-bin=contour=--defsym=_kerf_ram_length=0x100000");
            // The remote image's slave calibrates in place (the fit's working set on
            // the stack) and carries the recorded frames (88 KB) beside its code.
            println!("cargo:rustc-link-arg-bin=remote=--defsym=_kerf_ram_length=0x100000");
            println!("cargo:rustc-link-arg-bin=remote=--defsym=_kerf_flash_length=0x100000");
            // The link image carries the simulated delta like the contour image.
            println!("cargo:rustc-link-arg-bin=link=--defsym=_kerf_ram_length=0x100000");
            // The ARROW image holds the pyramid job twice (the supervisor's copy and
            // the command slot's) beside the parse buffer: 1 MiB of SRAM.
            println!("cargo:rustc-link-arg-bin=arrow=--defsym=_kerf_ram_length=0x100000");
            // ARROW behind the link: the job in the supervisor, in the command slot and
            // being built at the commit, the parse buffer and the upload (12 KB).
            println!("cargo:rustc-link-arg-bin=arrow-link=--defsym=_kerf_ram_length=0x100000");
            // The grinding cell behind the link: the simulated workpiece (3000 samples,
            // 24 KB) and the sensor's inverse calibration beside the cell and its queues.
            println!("cargo:rustc-link-arg-bin=grinding-link=--defsym=_kerf_ram_length=0x100000");
            // The remote master behind the link: the master delta's plant, the fixture's
            // contour twice (the supervisor's job and the command slot's) and both ends
            // of the remote link with their frames in flight.
            println!(
                "cargo:rustc-link-arg-bin=remote-master-link=--defsym=_kerf_ram_length=0x100000"
            );
            // The remote slave behind the link: the session in the upload buffer, the
            // supervisor's copy and the command slots (12 KB each), the playout and the
            // simulated delta; its code with the plant and the calibration fit (530 KB)
            // passes the board's 512 KiB of flash.
            println!(
                "cargo:rustc-link-arg-bin=remote-slave-link=--defsym=_kerf_ram_length=0x100000"
            );
            println!(
                "cargo:rustc-link-arg-bin=remote-slave-link=--defsym=_kerf_flash_length=0x100000"
            );
            // The benchmark image links every kernel beside its peers: 1 MiB of the
            // model's 4 MiB code memory.
            println!("cargo:rustc-link-arg-bin=bench=--defsym=_kerf_flash_length=0x100000");
            // The Cortex-M0 image on QEMU's microbit (nRF51822): the part's 256 KiB of
            // flash at 0x0 and its 16 KiB of SRAM.
            println!("cargo:rustc-link-arg-bin=axis-m0=--defsym=_kerf_flash_length=0x40000");
            println!("cargo:rustc-link-arg-bin=axis-m0=--defsym=_kerf_ram_length=0x4000");
            // The Cortex-M3 images run the host's lockstep scenario driver, whose
            // queues and plant sit on the stack: 1 MiB of the an385's 4 MiB SRAM.
            println!("cargo:rustc-link-arg-bin=axis-m3=--defsym=_kerf_ram_length=0x100000");
            println!("cargo:rustc-link-arg-bin=bench-m3=--defsym=_kerf_ram_length=0x100000");
        }
        println!("cargo:rustc-link-arg-bins=-Tlink.x");
    }
}
