//! Kernel rows against kerf's own references: delta kinematics in f32 against the
//! same code in f64, the codec against the FFT-based DCT-II, the naive
//! matrix-vector transforms and the Q15 path, and the FOC current loop against the
//! `foc` crate's.

use super::{exit, row, row_with_errors, INPUTS};
use core::f32::consts::PI;
use core::hint::black_box;
use kerf::codec::dct::{Dct, NaiveDct};
use kerf::codec::sdct::{SdctConfig, SdctDecoder, SdctEncoder, Selection};
use kerf::kinematics::delta::{DeltaConfig, DeltaGeometry};
use kerf::kinematics::Vector3;
use kerf_app::bench::Counter;
use kerf_peers::FftDct;

/// SDCT block codec (f32): the fast transforms, encode (transform + selection of m)
/// and decode (zero-fill + inverse), each against the naive matrix-vector DCT with a
/// precomputed cosine table; the forward transform also against the DCT-II through
/// microfft's real FFT (Makhoul's reordering), with both errors against the f64 sum;
/// and the Q15 integer transform. Array copies and output moves are in the baselines.
#[inline(never)]
pub fn codec_rows<const N: usize>(counter: &mut Counter, m: usize) {
    let config = SdctConfig {
        m,
        selection: Selection::Largest,
    };
    let (Ok(dct), Ok(naive), Ok(encoder), Ok(decoder), Some(fft)) = (
        Dct::<N>::new(),
        NaiveDct::<N>::new(),
        SdctEncoder::<N>::new(&config),
        SdctDecoder::<N>::new(),
        FftDct::<N>::new(),
    ) else {
        exit(false)
    };
    // A block of a two-tone force signal.
    let x: [f32; N] = core::array::from_fn(|n| {
        let t = n as f32 * 1e-4;
        0.6 * libm::sinf(2.0 * PI * 230.0 * t) + 0.25 * libm::sinf(2.0 * PI * 1700.0 * t + 0.4)
    });
    let x_q15: [i16; N] = x.map(|v| (v * 32767.0) as i16);
    let Ok(block) = encoder.encode(&x) else {
        exit(false)
    };
    let mut out = [0.0f32; N];
    let mut out_q15 = [0i32; N];
    let naive_forward = |_: u32| {
        let mut c = [0.0f32; N];
        naive.forward(black_box(&x), &mut c);
        black_box(c);
    };
    let naive_forward_base = |_: u32| {
        let c = [0.0f32; N];
        black_box(&x);
        black_box(c);
    };
    let naive_inverse = |_: u32| {
        let mut y = [0.0f32; N];
        naive.inverse(black_box(block.coefficients()), &mut y);
        black_box(y);
    };
    let naive_inverse_base = |_: u32| {
        let y = [0.0f32; N];
        black_box(block.coefficients());
        black_box(y);
    };
    let copy_x = |_: u32| {
        let c = black_box(x);
        black_box(c);
    };
    let copy_block = |_: u32| {
        let y = black_box(*block.coefficients());
        black_box(y);
    };
    let mut name = heapless::String::<64>::new();
    let mut named = |text: core::fmt::Arguments| -> heapless::String<64> {
        name.clear();
        let _ = core::fmt::write(&mut name, text);
        name.clone()
    };
    let (mut kerf_c, mut fft_c) = (x, x);
    dct.forward(&mut kerf_c);
    fft.forward(&mut fft_c);
    row_with_errors(
        counter,
        &named(format_args!("codec::dct::Dct::forward N={N} <f32>")),
        |_| {
            let mut c = black_box(x);
            dct.forward(&mut c);
            black_box(c);
        },
        "DCT-II via microfft::real::rfft (Makhoul)",
        |_| {
            let mut c = black_box(x);
            fft.forward(&mut c);
            black_box(c);
        },
        (copy_x, copy_x),
        Some((dct_error(&x, &kerf_c), dct_error(&x, &fft_c), " rel")),
    );
    row_with_errors(
        counter,
        &named(format_args!("codec::dct::Dct::forward N={N} <f32> (naive)")),
        |_| {
            let mut c = black_box(x);
            dct.forward(&mut c);
            black_box(c);
        },
        "naive matrix-vector DCT-II (cosine table)",
        naive_forward,
        (copy_x, naive_forward_base),
        None,
    );
    row_with_errors(
        counter,
        &named(format_args!("codec::dct::Dct::inverse N={N} <f32>")),
        |_| {
            let mut y = black_box(*block.coefficients());
            dct.inverse(&mut y);
            black_box(y);
        },
        "naive matrix-vector DCT-III (cosine table)",
        naive_inverse,
        (copy_block, naive_inverse_base),
        None,
    );
    row_with_errors(
        counter,
        &named(format_args!("codec::sdct::SdctEncoder::encode N={N} m={m}")),
        |_| {
            black_box(encoder.encode(black_box(&x)).ok());
        },
        "naive matrix-vector DCT-II (cosine table)",
        naive_forward,
        (
            |_| {
                black_box(black_box(&x));
            },
            naive_forward_base,
        ),
        None,
    );
    // The selection alone, on this block's coefficients.
    let mut c = x;
    dct.forward(&mut c);
    row(
        counter,
        &named(format_args!(
            "codec::sdct::select_largest N={N} m={m} (binade histogram)"
        )),
        |_| {
            black_box(kerf::codec::sdct::select_largest(black_box(&c), m));
        },
        "sorted buffer of the m largest, one insertion per new leader (kerf before)",
        |_| {
            black_box(select_by_insertion(black_box(&c), m));
        },
        |_| {
            black_box(black_box(&c));
        },
    );
    row_with_errors(
        counter,
        &named(format_args!("codec::sdct::SdctDecoder::decode N={N}")),
        |_| {
            decoder.decode(black_box(&block), &mut out);
            black_box(&out);
        },
        "naive matrix-vector DCT-III (cosine table)",
        naive_inverse,
        (
            |_| {
                black_box(black_box(&block));
            },
            naive_inverse_base,
        ),
        None,
    );
    row_with_errors(
        counter,
        &named(format_args!(
            "codec::dct::Dct::forward_q15 N={N} <Q15, i64 sum>"
        )),
        |_| {
            dct.forward_q15(black_box(&x_q15), &mut out_q15);
            black_box(&out_q15);
        },
        "naive matrix-vector DCT-II (cosine table)",
        naive_forward,
        (
            |_| {
                black_box(black_box(&x_q15));
            },
            naive_forward_base,
        ),
        None,
    );
}

/// The selection kerf used before the binade histogram, kept as the reference of the
/// selection row: one pass keeps the m largest magnitudes in a sorted buffer, whose
/// last entry is the threshold; then the same two passes build the mask (ties to the
/// lower index).
fn select_by_insertion<const N: usize>(c: &[f32; N], m: usize) -> u64 {
    if m == 0 || m >= N {
        return kerf::codec::prefix_mask(m.min(N));
    }
    let bits = c.map(|v| v.abs().to_bits());
    let mut top = [0u32; N];
    for &b in &bits {
        if top.get(m - 1).is_some_and(|&smallest| b > smallest) {
            let mut carry = b;
            for slot in top.iter_mut().take(m).skip_while(|t| **t >= b) {
                core::mem::swap(slot, &mut carry);
            }
        }
    }
    let threshold = top.get(m - 1).copied().unwrap_or(0);
    let (mut mask, mut left) = (0u64, m);
    for (k, &b) in bits.iter().enumerate() {
        if b > threshold {
            mask |= 1 << k;
            left -= 1;
        }
    }
    for (k, &b) in bits.iter().enumerate() {
        if left > 0 && b == threshold {
            mask |= 1 << k;
            left -= 1;
        }
    }
    mask
}

/// Largest error of a DCT-II `c` of `x` against the defining sum in f64, relative to
/// the largest exact coefficient.
fn dct_error<const N: usize>(x: &[f32; N], c: &[f32; N]) -> f64 {
    let (mut worst, mut peak) = (0.0f64, 0.0f64);
    for (k, ck) in c.iter().enumerate() {
        let scale = if k == 0 {
            1.0 / N as f64
        } else {
            2.0 / N as f64
        };
        let mut sum = 0.0f64;
        for (n, xn) in x.iter().enumerate() {
            let angle = core::f64::consts::PI * ((2 * n + 1) * k) as f64 / (2 * N) as f64;
            sum += f64::from(*xn) * libm::cos(angle);
        }
        let exact = libm::sqrt(scale) * sum;
        worst = worst.max(libm::fabs(f64::from(*ck) - exact));
        peak = peak.max(libm::fabs(exact));
    }
    worst / peak
}

/// Delta kinematics of the Keops slave in f32, against the same code in f64 (software
/// double): FK, IK, Jx, J̇x and the FK + IK + Jx set a period needs.
#[inline(never)]
pub fn kinematics_rows(counter: &mut Counter) {
    let config = DeltaConfig::SLAVE_KEOPS;
    let (Ok(g32), Ok(g64)) = (
        DeltaGeometry::<f32>::new(&config),
        DeltaGeometry::<f64>::new(&config),
    ) else {
        exit(false)
    };
    let mask = INPUTS as u32 - 1;
    // Joint positions spread over the middle of the 0–40 mm travel.
    let q64: [Vector3<f64>; INPUTS] = core::array::from_fn(|k| {
        let t = k as f64 / INPUTS as f64 * core::f64::consts::TAU;
        Vector3::new(
            0.020 + 0.008 * libm::sin(t),
            0.020 + 0.008 * libm::sin(t + 2.1),
            0.020 + 0.008 * libm::cos(3.0 * t),
        )
    });
    let p64: [Vector3<f64>; INPUTS] =
        core::array::from_fn(|k| g64.forward(&q64[k]).unwrap_or_else(|_| exit(false)));
    let q32: [Vector3<f32>; INPUTS] = core::array::from_fn(|k| q64[k].map(|v| v as f32));
    let p32: [Vector3<f32>; INPUTS] = core::array::from_fn(|k| p64[k].map(|v| v as f32));
    let qd32 = Vector3::new(0.01f32, -0.02, 0.015);
    let qd64 = qd32.map(f64::from);
    macro_rules! pair {
        ($name:expr, |$k:ident| $f32:expr, |$k2:ident| $f64:expr) => {
            row(
                counter,
                $name,
                |i| {
                    let $k = (i & mask) as usize;
                    black_box($f32.ok());
                },
                "same <f64> (software double)",
                |i| {
                    let $k2 = (i & mask) as usize;
                    black_box($f64.ok());
                },
                |i| {
                    black_box(i);
                },
            )
        };
    }
    pair!(
        "kinematics::delta::forward <f32>",
        |k| g32.forward(black_box(&q32[k])),
        |k| g64.forward(black_box(&q64[k]))
    );
    pair!(
        "kinematics::delta::inverse <f32>",
        |k| g32.inverse(black_box(&p32[k])),
        |k| g64.inverse(black_box(&p64[k]))
    );
    pair!(
        "kinematics::delta::jacobian <f32>",
        |k| g32.jacobian(black_box(&q32[k]), &p32[k]),
        |k| g64.jacobian(black_box(&q64[k]), &p64[k])
    );
    pair!(
        "kinematics::delta::jacobian_derivative <f32>",
        |k| g32.jacobian_derivative(black_box(&q32[k]), &p32[k], &qd32),
        |k| g64.jacobian_derivative(black_box(&q64[k]), &p64[k], &qd64)
    );
    pair!(
        "kinematics::delta forward + inverse_with_jacobian (IK and Jx in one pass) <f32>",
        |k| g32
            .forward(black_box(&q32[k]))
            .and_then(|p| g32.inverse_with_jacobian(&p)),
        |k| g64
            .forward(black_box(&q64[k]))
            .and_then(|p| g64.inverse_with_jacobian(&p))
    );
    pair!(
        "kinematics::delta forward + inverse + jacobian <f32>",
        |k| g32
            .forward(black_box(&q32[k]))
            .and_then(|p| g32.inverse(&p).and_then(|q| g32.jacobian(&q, &p))),
        |k| g64
            .forward(black_box(&q64[k]))
            .and_then(|p| g64.inverse(&p).and_then(|q| g64.jacobian(&q, &p)))
    );
}

/// One ARROW control period (`kerf::machines::arrow::ArrowLaw::period`: IK and Jm at the
/// desired pose, Jm⁺ and Rm, the inverse dynamic model, the regularized PID of the six
/// actuators and of the two table motors) in f32, beside the same period without the
/// feedforward (what the inverse dynamic model costs), on 64 desired poses along a
/// move with the measured joints 20 µm off. (The period in software f64, about half a
/// million instructions, would overflow SysTick's 24 bits over the 4,096 calls of a
/// loop.)
#[inline(never)]
pub fn arrow_rows(counter: &mut Counter) {
    use kerf::control::redundant_pid::{RedundantPid, RedundantPidConfig};
    use kerf::kinematics::arrow::{ArrowConfig, ArrowDynamics, ArrowGeometry, ArrowMasses, Pose};
    use kerf::machines::arrow::{ArrowDesired, ArrowLaw, ArrowLoopState};
    use kerf::Float;
    fn law<T: Float>() -> Option<ArrowLaw<T>> {
        let model = ArrowConfig::ARROW;
        Some(ArrowLaw {
            geometry: ArrowGeometry::new(&model).ok()?,
            dynamics: ArrowDynamics::new(
                &ArrowMasses::ARROW,
                model.arms[0].length_m,
                model.arms[2].length_m,
            )
            .ok()?,
            parallel: RedundantPid::new(&RedundantPidConfig::ARROW_PARALLEL, 2e-4).ok()?,
            turntable: RedundantPid::new(&RedundantPidConfig::ARROW_TURNTABLE, 2e-4).ok()?,
            feedforward: true,
        })
    }
    let (Some(law32), Some(law64)) = (law::<f32>(), law::<f64>()) else {
        exit(false)
    };
    let plain32 = ArrowLaw {
        feedforward: false,
        ..law32
    };
    let desired64: [ArrowDesired<f64>; INPUTS] = core::array::from_fn(|k| {
        let t = k as f64 / INPUTS as f64;
        ArrowDesired {
            pose: Pose::new(0.2 * t - 0.1, 0.5 + 0.05 * t, 0.02 * t, 0.3 * t),
            rate: Pose::new(0.2, 0.05, 0.02, 0.3),
            acceleration: Pose::new(0.5, -0.2, 0.1, 1.0),
            theta_x_rad: 0.2 * t,
            theta_x_accel_rad_s2: 0.5,
        }
    });
    let joints64: [kerf::kinematics::arrow::ActuatorVector<f64>; INPUTS] =
        core::array::from_fn(|k| {
            law64
                .geometry
                .inverse(&desired64[k].pose)
                .unwrap_or_else(|_| exit(false))
                .map(|q| q + 20e-6)
        });
    let desired32 = desired64.map(|d| ArrowDesired {
        pose: d.pose.map(|v| v as f32),
        rate: d.rate.map(|v| v as f32),
        acceleration: d.acceleration.map(|v| v as f32),
        theta_x_rad: d.theta_x_rad as f32,
        theta_x_accel_rad_s2: d.theta_x_accel_rad_s2 as f32,
    });
    let joints32 = joints64.map(|q| q.map(|v| v as f32));
    // Each call from the same loop state, so that a call costs the same however many
    // calls a run makes (software f64's cost depends on the values it meets).
    let s32 = ArrowLoopState::<f32>::default();
    let mask = INPUTS as u32 - 1;
    row_with_errors(
        counter,
        "machines::arrow::ArrowLaw::period <f32> (IK, Jm, Jm⁺, Rm, feedforward, PID ×6 + ×2)",
        |i| {
            let k = (i & mask) as usize;
            let table = [desired32[k].theta_x_rad, -desired32[k].theta_x_rad];
            let mut state = black_box(s32);
            black_box(
                law32
                    .period(&mut state, &desired32[k], black_box(&joints32[k]), table)
                    .ok(),
            );
        },
        "same period without the feedforward <f32>",
        |i| {
            let k = (i & mask) as usize;
            let table = [desired32[k].theta_x_rad, -desired32[k].theta_x_rad];
            let mut state = black_box(s32);
            black_box(
                plain32
                    .period(&mut state, &desired32[k], black_box(&joints32[k]), table)
                    .ok(),
            );
        },
        (
            |i| {
                black_box((i, black_box(s32)));
            },
            |i| {
                black_box((i, black_box(s32)));
            },
        ),
        None,
    );
}

/// Frame of the sharpness row: 80 × 64 pixels, the window its 64 × 64 columns 8–71.
const SHARPNESS_STRIDE: usize = 80;

/// Normalized variance (T 7.2.2 eq. 155) of a 64 × 64 window of an 8-bit frame:
/// kerf's exact integer sums and one f32 division against the f32 two-pass sum a
/// user would write (no no_std crate computes it on u8 frames: micromath's
/// `statistics::Variance` takes an f32 slice, so the window would first be copied
/// into 16 KB of f32). Errors relative to the exact ratio (f64 of the exact
/// integers; the kernel's own f64 result agrees with an f64 two-pass to 1e-12 in its
/// unit tests).
#[inline(never)]
pub fn sharpness_rows(counter: &mut Counter) {
    use kerf::sensing::sharpness::{normalized_variance, window_moments, Window};
    let window = Window {
        x_px: 8,
        y_px: 0,
        width_px: 64,
        height_px: 64,
    };
    // Texture about grey level 120, ±40 (xorshift32).
    let mut seed = 0x1234_5678u32;
    let frame: [u8; SHARPNESS_STRIDE * 64] = core::array::from_fn(|_| {
        seed ^= seed << 13;
        seed ^= seed >> 17;
        seed ^= seed << 5;
        (80 + (seed >> 24) % 81) as u8
    });
    let (Ok(moments), Ok(kernel)) = (
        window_moments(&frame, SHARPNESS_STRIDE, &window),
        normalized_variance(&frame, SHARPNESS_STRIDE, &window),
    ) else {
        exit(false)
    };
    let exact = moments.variance_numerator() as f64 / moments.mean_denominator() as f64;
    let reference = two_pass_f32(&frame, SHARPNESS_STRIDE, &window);
    let rel = |v: f32| libm::fabs(f64::from(v) - exact) / exact;
    row_with_errors(
        counter,
        "sensing::sharpness::normalized_variance 64×64 u8 window",
        |_| {
            black_box(normalized_variance(
                black_box(&frame),
                black_box(SHARPNESS_STRIDE),
                black_box(&window),
            ))
            .ok();
        },
        "f32 two-pass (mean, then Σ(i − μ)², / (n μ))",
        |_| {
            black_box(two_pass_f32(
                black_box(&frame),
                black_box(SHARPNESS_STRIDE),
                black_box(&window),
            ));
        },
        (
            |_| {
                black_box((
                    black_box(&frame),
                    black_box(SHARPNESS_STRIDE),
                    black_box(&window),
                ));
            },
            |_| {
                black_box((
                    black_box(&frame),
                    black_box(SHARPNESS_STRIDE),
                    black_box(&window),
                ));
            },
        ),
        Some((rel(kernel), rel(reference), " rel")),
    );
}

/// The reference: eq. 155 in f32, two passes over the window's rows.
#[inline(never)]
fn two_pass_f32(frame: &[u8], stride: usize, window: &kerf::sensing::sharpness::Window) -> f32 {
    let rows = || {
        frame
            .chunks_exact(stride)
            .skip(window.y_px)
            .take(window.height_px)
            .filter_map(|row| row.get(window.x_px..window.x_px + window.width_px))
    };
    let n = (window.width_px * window.height_px) as f32;
    let mut sum = 0.0f32;
    for row in rows() {
        for &p in row {
            sum += f32::from(p);
        }
    }
    let mean = sum / n;
    let mut squares = 0.0f32;
    for row in rows() {
        for &p in row {
            let d = f32::from(p) - mean;
            squares += d * d;
        }
    }
    squares / (n * mean)
}

/// One FOC current-loop period of one motor (`control::foc::Foc<f32>::step`, the
/// Keops stage's LM1247 at 20 kHz) against the `foc` crate's `Foc::update` (I16F16,
/// its own CORDIC sine and cosine, two-current Clarke, PI, space-vector PWM), on the
/// same currents, angles and force. The peer does less per call: no speed voltages,
/// voltage limit, shunt selection or dead-time compensation. kerf's angle is given as
/// its sine and cosine (`ElectricalAngle::from_rad` here, the G474's CORDIC on the
/// board), so the row includes kerf's `sin_cos_f32`.
#[inline(never)]
pub fn foc_rows(counter: &mut Counter) {
    use kerf::control::foc::{ElectricalAngle, Foc, FocConfig, FocInput, FocState};
    use kerf_peers::fixed::types::I16F16;
    use kerf_peers::foc::{pid::PIController, pwm::SpaceVector, Foc as PeerFoc};
    let Ok(foc) = Foc::<f32>::new(&FocConfig::KEOPS) else {
        exit(false)
    };
    let mut state = FocState::<f32>::default();
    let w = FocConfig::KEOPS.motor;
    let wc = 2.0 * core::f64::consts::PI * FocConfig::KEOPS.current_bandwidth_hz;
    let ts = 1.0 / FocConfig::KEOPS.stage.pwm_hz;
    let gain = |v: f64| I16F16::from_num(v);
    let pi = || PIController::new(gain(w.inductance_h * wc), gain(w.resistance_ohm * wc * ts));
    let mut peer = PeerFoc::<SpaceVector, 4250>::new(pi(), pi());
    let mask = INPUTS as u32 - 1;
    let inputs: [(f32, [f32; 3]); INPUTS] = core::array::from_fn(|k| {
        let theta = 2.0 * PI * (k as f32 + 0.3) / INPUTS as f32;
        let currents =
            core::array::from_fn(|x| -0.3 * libm::sinf(theta - 2.0 * PI * x as f32 / 3.0));
        (theta, currents)
    });
    row(
        counter,
        "control::foc::Foc::step <f32> (one motor, angle's sin/cos included)",
        |i| {
            let (theta, currents) = black_box(inputs[(i & mask) as usize]);
            let input = FocInput {
                phase_currents_a: currents,
                angle: ElectricalAngle::from_rad(theta),
                speed_m_s: 0.2,
                force_n: 3.0,
                bus_v: 24.0,
            };
            black_box(foc.step(&mut state, &input)).ok();
        },
        "foc 0.3 Foc::update (I16F16, CORDIC, PI, SVPWM)",
        |i| {
            let (theta, currents) = black_box(inputs[(i & mask) as usize]);
            black_box(peer.update(
                [gain(f64::from(currents[0])), gain(f64::from(currents[1]))],
                I16F16::from_num(theta - PI),
                gain(0.303),
                I16F16::ONE,
            ));
        },
        |i| {
            black_box(black_box(inputs[(i & mask) as usize]));
        },
    );
    // The board's case: the sine and cosine come from the CORDIC, outside the step.
    let angles: [ElectricalAngle<f32>; INPUTS] =
        core::array::from_fn(|k| ElectricalAngle::from_rad(inputs[k].0));
    let mut given = FocState::<f32>::default();
    row(
        counter,
        "control::foc::Foc::step <f32> (one motor, angle given as sin/cos)",
        |i| {
            let k = (i & mask) as usize;
            let (angle, (_, currents)) = black_box((angles[k], inputs[k]));
            let input = FocInput {
                phase_currents_a: currents,
                angle,
                speed_m_s: 0.2,
                force_n: 3.0,
                bus_v: 24.0,
            };
            black_box(foc.step(&mut given, &input)).ok();
        },
        "foc 0.3 Foc::update (I16F16, CORDIC, PI, SVPWM)",
        |i| {
            let (theta, currents) = black_box(inputs[(i & mask) as usize]);
            black_box(peer.update(
                [gain(f64::from(currents[0])), gain(f64::from(currents[1]))],
                I16F16::from_num(theta - PI),
                gain(0.303),
                I16F16::ONE,
            ));
        },
        |i| {
            let k = (i & mask) as usize;
            black_box(black_box((angles[k], inputs[k])));
        },
    );
}
