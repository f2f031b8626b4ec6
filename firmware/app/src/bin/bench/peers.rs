//! Kernel rows against the peers a user would pick instead, on the same inputs in the
//! same run, each with its error against an f64 reference: idsp's integer `atan2` and
//! `cossin`, libm's `sqrtf` and the FPU's VSQRT, the printer (vertical-rail) delta IK
//! formula, and the EFD summed harmonic by harmonic with kerf's fast sine and cosine.

use super::{exit, row_with_errors, INPUTS};
use core::f64::consts::TAU;
use core::hint::black_box;
use kerf::kinematics::delta::{DeltaConfig, DeltaGeometry};
use kerf::kinematics::Vector3;
use kerf::scalar::{sin_cos_f32, sqrt_f32};
use kerf::trajectory::efd::Efd;
use kerf::trajectory::shapes;
use kerf_app::bench::Counter;
use kerf_peers::{efd_direct, efd_sample_flat, printer_inverse, Tower};

const MASK: u32 = INPUTS as u32 - 1;
/// 2^32: one turn of a phase word.
const TURN: f64 = 4_294_967_296.0;

/// Wrapped difference of two angles in turns, |·| ≤ 1/2.
fn turn_error(got: f64, exact: f64) -> f64 {
    let d = got - exact;
    libm::fabs(d - libm::round(d))
}

/// atan2, cos/sin, square root and the printer IK against their peers.
#[inline(never)]
pub fn rows(counter: &mut Counter, vectors: &[(i32, i32); INPUTS]) {
    // atan2 in turns: kerf's table and division against idsp's polynomial.
    let (mut e_kerf, mut e_idsp) = (0.0f64, 0.0f64);
    for &(y, x) in vectors {
        let exact = libm::atan2(f64::from(y), f64::from(x)) / TAU;
        let kerf = f64::from(kerf::sensing::hall::atan2_turns(y, x)) / TURN;
        let idsp = f64::from(idsp::atan2(y, x)) / TURN;
        e_kerf = e_kerf.max(turn_error(kerf, exact));
        e_idsp = e_idsp.max(turn_error(idsp, exact));
    }
    let input = |i: u32| black_box(vectors[(i & MASK) as usize]);
    row_with_errors(
        counter,
        "sensing::hall::atan2_turns (integer, table)",
        |i| {
            let (y, x) = input(i);
            black_box(kerf::sensing::hall::atan2_turns(y, x));
        },
        "idsp::atan2 0.23 (integer, polynomial)",
        |i| {
            let (y, x) = input(i);
            black_box(idsp::atan2(y, x));
        },
        (base(input), base(input)),
        Some((e_kerf, e_idsp, " turn")),
    );

    // cos and sin of a phase: kerf's f32 polynomial on radians against idsp's
    // table-and-interpolation on a 32-bit phase word, over one turn.
    let phases: [i32; INPUTS] =
        core::array::from_fn(|k| (k as u32).wrapping_mul(67_108_864).wrapping_add(12_345) as i32);
    let radians: [f32; INPUTS] = phases.map(|p| (f64::from(p) / TURN * TAU) as f32);
    let (mut e_kerf, mut e_idsp) = (0.0f64, 0.0f64);
    for (p, r) in phases.iter().zip(&radians) {
        let exact = f64::from(*p) / TURN * TAU;
        let (s, c) = sin_cos_f32(*r);
        let (ci, si) = idsp::cossin(*p);
        let (ec, es) = (libm::cos(exact), libm::sin(exact));
        // kerf's own argument rounding to f32 radians is part of its error.
        e_kerf = e_kerf.max(libm::fabs(f64::from(s) - es).max(libm::fabs(f64::from(c) - ec)));
        let full = 2_147_483_648.0;
        e_idsp = e_idsp
            .max(libm::fabs(f64::from(si) / full - es).max(libm::fabs(f64::from(ci) / full - ec)));
    }
    let radian = |i: u32| black_box(radians[(i & MASK) as usize]);
    let phase = |i: u32| black_box(phases[(i & MASK) as usize]);
    row_with_errors(
        counter,
        "scalar::sin_cos_f32 (f32 radians)",
        |i| {
            black_box(sin_cos_f32(radian(i)));
        },
        "idsp::cossin 0.23 (i32 phase)",
        |i| {
            black_box(idsp::cossin(phase(i)));
        },
        (base(radian), base(phase)),
        Some((e_kerf, e_idsp, " abs")),
    );

    // Square root over the magnitudes the delta IK sees (squared lengths, m²).
    let squares: [f32; INPUTS] = core::array::from_fn(|k| 1e-4 + 4e-3 * (k as f32 + 0.37));
    let (mut e_kerf, mut e_libm) = (0.0f64, 0.0f64);
    for x in squares {
        let exact = libm::sqrt(f64::from(x));
        e_kerf = e_kerf.max(libm::fabs(f64::from(sqrt_f32(x)) - exact) / exact);
        e_libm = e_libm.max(libm::fabs(f64::from(libm::sqrtf(x)) - exact) / exact);
    }
    let square = |i: u32| black_box(squares[(i & MASK) as usize]);
    row_with_errors(
        counter,
        "scalar::sqrt_f32 (Newton, FPU multiply/add)",
        |i| {
            black_box(sqrt_f32(square(i)));
        },
        "libm::sqrtf (software)",
        |i| {
            black_box(libm::sqrtf(square(i)));
        },
        (base(square), base(square)),
        Some((e_kerf, e_libm, " rel")),
    );
    hw_sqrt_rows(counter, &squares, e_kerf);
    printer_rows(counter);
}

// The other way to reach VSQRT on stable: a routine of its own, called under the
// hard-float AAPCS (argument and result in s0). It costs the BL and BX, and the call
// clobbers s0–s15 in the caller.
core::arch::global_asm!(
    ".syntax unified",
    ".thumb",
    ".text",
    ".p2align 2",
    ".global kerf_bench_vsqrt_f32",
    ".thumb_func",
    "kerf_bench_vsqrt_f32:",
    "    vsqrt.f32 s0, s0",
    "    bx lr",
);

extern "C" {
    fn kerf_bench_vsqrt_f32(x: f32) -> f32;
}

/// √x through the out-of-line routine above.
#[inline(always)]
fn vsqrt_call(x: f32) -> f32 {
    // SAFETY: the routine follows the hard-float AAPCS: it reads and writes s0 only,
    // then returns.
    unsafe { kerf_bench_vsqrt_f32(x) }
}

/// The FPU's VSQRT.F32 on the square-root row's inputs, against kerf's Newton root:
/// inlined through kerf-vsqrt (what `Float::fsqrt` uses with kerf's `hw-sqrt`), and
/// called out of line. Both must be correctly rounded on every input (equal to the f64
/// root rounded to f32). A function of its own, so that the rows above keep their frame.
#[inline(never)]
fn hw_sqrt_rows(counter: &mut Counter, squares: &[f32; INPUTS], e_kerf: f64) {
    let square = |i: u32| black_box(squares[(i & MASK) as usize]);
    let mut e_hw = 0.0f64;
    for &x in squares {
        let exact = libm::sqrt(f64::from(x));
        let (hw, call) = (kerf_vsqrt::sqrt_f32(x), vsqrt_call(x));
        if hw.to_bits() != (exact as f32).to_bits() || call.to_bits() != hw.to_bits() {
            exit(false)
        }
        e_hw = e_hw.max(libm::fabs(f64::from(hw) - exact) / exact);
    }
    row_with_errors(
        counter,
        "kerf_vsqrt::sqrt_f32 (VSQRT.F32 inline, kerf hw-sqrt)",
        |i| {
            black_box(kerf_vsqrt::sqrt_f32(square(i)));
        },
        "scalar::sqrt_f32 (Newton, FPU multiply/add)",
        |i| {
            black_box(sqrt_f32(square(i)));
        },
        (base(square), base(square)),
        Some((e_hw, e_kerf, " rel")),
    );
    row_with_errors(
        counter,
        "VSQRT.F32 out of line (global_asm! routine, BL + BX)",
        |i| {
            black_box(vsqrt_call(square(i)));
        },
        "kerf_vsqrt::sqrt_f32 (VSQRT.F32 inline)",
        |i| {
            black_box(kerf_vsqrt::sqrt_f32(square(i)));
        },
        (base(square), base(square)),
        Some((e_hw, e_hw, " rel")),
    );
}

/// A baseline that fetches the input the same way and moves it out, without a kernel.
fn base<T>(input: impl Fn(u32) -> T + Copy) -> impl FnMut(u32) + Copy {
    move |i| {
        black_box(input(i));
    }
}

/// kerf's general delta IK on a printer geometry (Klipper/Marlin description) against
/// the printer formula z + √(l² − (x − xt)² − (y − yt)²), with kerf's square root and
/// with libm's.
#[inline(never)]
fn printer_rows(counter: &mut Counter) {
    let angles = [210.0f64, 330.0, 90.0].map(|a| a * TAU / 360.0);
    let (radius, arm) = (0.1, 0.25);
    let config = DeltaConfig::printer(radius, angles, [arm; 3], (0.0, 1.0));
    let Ok(geometry) = DeltaGeometry::<f32>::new(&config) else {
        exit(false)
    };
    let towers = angles.map(|a| Tower {
        x: (radius * libm::cos(a)) as f32,
        y: (radius * libm::sin(a)) as f32,
        arm2: (arm * arm) as f32,
    });
    // Effector positions over a 60 mm disc, z 80–120 mm.
    let poses: [[f32; 3]; INPUTS] = core::array::from_fn(|k| {
        let t = k as f64 / INPUTS as f64 * TAU;
        let r = 0.03 * libm::sqrt((k as f64 + 0.5) / INPUTS as f64);
        [
            r * libm::cos(3.0 * t),
            r * libm::sin(3.0 * t),
            0.1 + 0.02 * libm::sin(t),
        ]
        .map(|v| v as f32)
    });
    let exact = |p: &[f32; 3], i: usize| {
        let (xt, yt) = (radius * libm::cos(angles[i]), radius * libm::sin(angles[i]));
        let (dx, dy) = (f64::from(p[0]) - xt, f64::from(p[1]) - yt);
        f64::from(p[2]) + libm::sqrt(arm * arm - dx * dx - dy * dy)
    };
    let (mut e_kerf, mut e_fast, mut e_libm, mut e_hw) = (0.0f64, 0.0f64, 0.0f64, 0.0f64);
    for p in &poses {
        let Ok(q) = geometry.inverse(&Vector3::new(p[0], p[1], p[2])) else {
            exit(false)
        };
        let fast = printer_inverse(&towers, *p, sqrt_f32);
        let soft = printer_inverse(&towers, *p, libm::sqrtf);
        let hw = printer_inverse(&towers, *p, kerf_vsqrt::sqrt_f32);
        for i in 0..3 {
            let e = exact(p, i);
            e_kerf = e_kerf.max(libm::fabs(f64::from(q[i]) - e));
            e_fast = e_fast.max(libm::fabs(f64::from(fast[i]) - e));
            e_libm = e_libm.max(libm::fabs(f64::from(soft[i]) - e));
            e_hw = e_hw.max(libm::fabs(f64::from(hw[i]) - e));
        }
    }
    let vector = |i: u32| {
        let p = black_box(poses[(i & MASK) as usize]);
        Vector3::new(p[0], p[1], p[2])
    };
    let pose = |i: u32| black_box(poses[(i & MASK) as usize]);
    // One row per square root inside the printer formula; a macro rather than a loop
    // over function pointers, so that each row calls its square root directly, as a
    // user's code would.
    macro_rules! printer_row {
        ($name:expr, $reference:expr, $sqrt:path, $error:expr) => {
            row_with_errors(
                counter,
                $name,
                |i| {
                    black_box(geometry.inverse(&vector(i)).ok());
                },
                $reference,
                |i| {
                    black_box(printer_inverse(&towers, pose(i), $sqrt));
                },
                (base(vector), base(pose)),
                Some((e_kerf, $error, " m")),
            )
        };
    }
    printer_row!(
        "kinematics::delta::inverse <f32>, printer geometry",
        "printer formula z + √(l² − dx² − dy²), kerf sqrt_f32",
        sqrt_f32,
        e_fast
    );
    printer_row!(
        "kinematics::delta::inverse <f32>, printer geometry (VSQRT)",
        "printer formula z + √(l² − dx² − dy²), kerf_vsqrt::sqrt_f32",
        kerf_vsqrt::sqrt_f32,
        e_hw
    );
    printer_row!(
        "kinematics::delta::inverse <f32>, printer geometry (libm)",
        "printer formula z + √(l² − dx² − dy²), libm::sqrtf",
        libm::sqrtf,
        e_libm
    );
}

/// EFD position with three derivatives (kerf's sin/cos recurrence) against the sum
/// with kerf's fast sine and cosine of kθ for every harmonic, on the gear contour.
#[inline(never)]
pub fn efd_rows(counter: &mut Counter) {
    fn pair<const N: usize>(counter: &mut Counter, name: &str) {
        let Ok(efd) = Efd::<f32, N>::from_polygon(&shapes::gear(), N) else {
            exit(false)
        };
        let thetas: [f32; INPUTS] = core::array::from_fn(|k| 0.1 + 6.2 * k as f32 / INPUTS as f32);
        // Errors against the direct sum in f64, relative to each output's largest value.
        let mut exact = [[0.0f64; 8]; INPUTS];
        let mut peak = [0.0f64; 8];
        for (k, theta) in thetas.iter().enumerate() {
            let theta = f64::from(*theta);
            for (n, [a, b, c, d]) in efd.coefficients().iter().copied().enumerate() {
                let h = (n + 1) as f64;
                let (s, co) = (libm::sin(h * theta), libm::cos(h * theta));
                let [a, b, c, d] = [a, b, c, d].map(f64::from);
                let (ux, uy, vx, vy) = (
                    a * co + b * s,
                    c * co + d * s,
                    b * co - a * s,
                    d * co - c * s,
                );
                let terms = [
                    ux,
                    uy,
                    h * vx,
                    h * vy,
                    -h * h * ux,
                    -h * h * uy,
                    -h * h * h * vx,
                    -h * h * h * vy,
                ];
                for (e, t) in exact[k].iter_mut().zip(terms) {
                    *e += t;
                }
            }
            for (p, e) in peak.iter_mut().zip(exact[k]) {
                *p = p.max(libm::fabs(e));
            }
        }
        let (mut e_kerf, mut e_direct) = (0.0f64, 0.0f64);
        for (k, theta) in thetas.iter().enumerate() {
            let s = efd.evaluate(*theta);
            let kerf = efd_sample_flat(&s);
            let direct = efd_direct(efd.coefficients(), *theta);
            for j in 0..8 {
                e_kerf = e_kerf.max(libm::fabs(f64::from(kerf[j]) - exact[k][j]) / peak[j]);
                e_direct = e_direct.max(libm::fabs(f64::from(direct[j]) - exact[k][j]) / peak[j]);
            }
        }
        let theta = |i: u32| black_box(thetas[(i & MASK) as usize]);
        row_with_errors(
            counter,
            name,
            |i| {
                black_box(efd.evaluate(theta(i)));
            },
            "direct sum, kerf sin_cos_f32 per harmonic",
            |i| {
                black_box(efd_direct(efd.coefficients(), theta(i)));
            },
            (base(theta), base(theta)),
            Some((e_kerf, e_direct, " rel")),
        );
    }
    pair::<10>(counter, "trajectory::efd::Efd::evaluate n=10 <f32>");
    pair::<30>(counter, "trajectory::efd::Efd::evaluate n=30 <f32>");
}
