//! The FPU's square root (`VSQRT.F32`) as a safe function, for kerf's `hw-sqrt`
//! feature: the one place with `unsafe` between the library (which forbids it) and the
//! instruction.
//!
//! Stable Rust has no `f32::sqrt` in `core`, and `asm!` cannot name a single-precision
//! register on thumbv7em-none-eabihf at 1.95: the `sreg` class and explicit `"s0"`
//! operands both require the `vfp2` target feature, which stable rustc does not see on
//! this target, and `-C target-feature=+vfp2` is unstable and also tells LLVM that
//! the FPU has double precision (it then emits `vmul.f64`, which the Cortex-M4's
//! FPv4-SP does not have). So the value crosses in a core register: the asm moves it
//! to `s0`, takes the root there and moves it back, and keeps the compiler's `s0` in a
//! second core register meanwhile. Five instructions, inlined, no call and no stack:
//! about 18 Cortex-M4 cycles, 14 of them the VSQRT itself.
//!
//! The function exists on 32-bit Arm hard-float targets (`target_abi = "eabihf"`:
//! every FPU there has VSQRT); elsewhere the crate is empty and kerf keeps its Newton
//! square root.
#![no_std]
#![deny(unsafe_code)]

/// √x by the FPU's `VSQRT.F32`: correctly rounded (IEEE 754), NaN for negative
/// input and NaN, +∞ for +∞, −0 for −0.
#[cfg(all(target_arch = "arm", target_abi = "eabihf"))]
#[inline(always)]
#[allow(unsafe_code)]
pub fn sqrt_f32(x: f32) -> f32 {
    let mut bits = x.to_bits();
    // SAFETY: the asm reads and writes only its two core-register operands and `s0`,
    // which it restores from `{saved}` before it ends; it touches no memory and no
    // stack. VSQRT.F32 exists on every FPU of a hard-float Arm target, and its only
    // side effect is on FPSCR's cumulative exception bits, as any float operation.
    unsafe {
        core::arch::asm!(
            "vmov {saved}, s0",
            "vmov s0, {x}",
            "vsqrt.f32 s0, s0",
            "vmov {x}, s0",
            "vmov s0, {saved}",
            x = inout(reg) bits,
            saved = out(reg) _,
            options(pure, nomem, nostack),
        );
    }
    f32::from_bits(bits)
}
