//! Hand-written instruction sequences with cycle counts worked out by hand from the
//! Cortex-M4 TRM (zero wait states, P = 2), for `scripts/cycles` to check its model
//! against: each is timed like a kernel (net of an empty routine called the same way),
//! so its estimate must equal the count in the comments. Only the traced run times them.

use core::hint::black_box;
use cortex_m_semihosting::hprintln;
use kerf_app::bench::{kerf_trace_begin, kerf_trace_end, Counter};

core::arch::global_asm!(
    ".syntax unified",
    ".thumb",
    ".text",
    ".p2align 2",
    ".global kerf_check_empty",
    ".thumb_func",
    "kerf_check_empty:",
    "    bx lr",
    // ALU and multiplies: 6 × 1 = 6.
    ".global kerf_check_alu",
    ".thumb_func",
    "kerf_check_alu:",
    "    movs r0, #1",
    "    adds r0, r0, #2",
    "    add.w r0, r0, r0, lsl #2",
    "    mul r0, r0, r0",
    "    mla r0, r0, r0, r0",
    "    umull r0, r1, r0, r0",
    "    bx lr",
    // Loads and stores: sub 1, mov 1, ldr 2, ldr after ldr 1, str after ldr 1,
    // str after str 2, ldrd 3, push of 3 4, pop of 3 4, add 1 = 20.
    ".global kerf_check_loads",
    ".thumb_func",
    "kerf_check_loads:",
    "    sub sp, #16",
    "    mov r0, sp",
    "    ldr r1, [r0]",
    "    ldr r2, [r0, #4]",
    "    str r1, [r0, #8]",
    "    str r2, [r0, #12]",
    "    ldrd r1, r2, [r0]",
    "    push {{r4, r5, r6}}",
    "    pop {{r4, r5, r6}}",
    "    add sp, #16",
    "    bx lr",
    // Branches: movs 1; three passes of subs 1 + bne (taken 3, 3, then 1);
    // cmp 1; beq taken 3; cbz taken 3; nop 1 = 1 + 3 + 7 + 1 + 3 + 3 + 1 = 19.
    ".global kerf_check_branches",
    ".thumb_func",
    "kerf_check_branches:",
    "    movs r0, #3",
    "1:  subs r0, #1",
    "    bne 1b",
    "    cmp r0, #0",
    "    beq 2f",
    "    nop",
    "2:  cbz r0, 3f",
    "    nop",
    "3:  nop",
    "    bx lr",
    // IT: movs 1, cmp 1, it folded onto the 16-bit cmp 0, moveq 1, add.w 1,
    // it after a 32-bit instruction 1, addne (condition fails, still issued) 1 = 6.
    ".global kerf_check_it",
    ".thumb_func",
    "kerf_check_it:",
    "    movs r0, #1",
    "    cmp r0, #1",
    "    it eq",
    "    moveq r0, #2",
    "    add.w r0, r0, #1",
    "    it ne",
    "    addne r0, #1",
    "    bx lr",
    // FPU: vmov imm 1, vmov imm 1, vadd 1, vmul 1, vmla 3, vdiv 14, vsqrt 14,
    // vmov to core 1 = 36.
    ".global kerf_check_fpu",
    ".thumb_func",
    "kerf_check_fpu:",
    "    vmov.f32 s0, #1.0",
    "    vmov.f32 s1, #2.0",
    "    vadd.f32 s2, s0, s1",
    "    vmul.f32 s2, s2, s1",
    "    vmla.f32 s2, s0, s1",
    "    vdiv.f32 s2, s2, s1",
    "    vsqrt.f32 s2, s2",
    "    vmov r0, s2",
    "    bx lr",
    // Division, counted at the TRM's upper bound 12: movs 1, movs 1, udiv 12,
    // sdiv 12 = 26.
    ".global kerf_check_div",
    ".thumb_func",
    "kerf_check_div:",
    "    movs r0, #100",
    "    movs r1, #7",
    "    udiv r2, r0, r1",
    "    sdiv r2, r0, r1",
    "    bx lr",
);

extern "C" {
    fn kerf_check_empty();
    fn kerf_check_alu();
    fn kerf_check_loads();
    fn kerf_check_branches();
    fn kerf_check_it();
    fn kerf_check_fpu();
    fn kerf_check_div();
}

/// Times every check sequence in a traced run (keys `check:<name>`): each call and
/// the empty routine's go through the same out-of-line region, so their difference is
/// exactly the sequence.
#[inline(never)]
pub fn run(counter: &mut Counter) {
    if !counter.is_traced() {
        return;
    }
    let checks: [(&str, unsafe extern "C" fn()); 6] = [
        ("check:alu", kerf_check_alu),
        ("check:loads", kerf_check_loads),
        ("check:branches", kerf_check_branches),
        ("check:it", kerf_check_it),
        ("check:fpu", kerf_check_fpu),
        ("check:div", kerf_check_div),
    ];
    for (key, check) in checks {
        timed(black_box(kerf_check_empty));
        hprintln!("@ base 1 {}", key);
        timed(black_box(check));
        hprintln!("@ kernel 1 {}", key);
    }
}

/// One call of `f` between the trace markers.
#[inline(never)]
fn timed(f: unsafe extern "C" fn()) {
    kerf_trace_begin();
    // SAFETY: the routines above follow the AAPCS: they touch only r0–r2, s0–s2 and
    // flags, restore r4–r6 and the stack pointer, and return.
    unsafe { f() };
    kerf_trace_end();
}
