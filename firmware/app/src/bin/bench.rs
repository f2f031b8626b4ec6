//! Benchmarks: instructions per call of each kernel and of its reference, in the same
//! run, on QEMU's emulated Cortex-M4. Prints the rows of the BENCHMARKS.md table;
//! `scripts/bench` runs it under `-icount` and rewrites the table.
#![no_std]
#![no_main]

use core::f32::consts::PI;
use core::hint::black_box;
use cortex_m_semihosting::hprintln;
use kerf::app::axis::{AxisConfig, AxisLoop};
use kerf::control::dob::Dob;
use kerf::control::pd::{Pd, Reference};
use kerf::sensing::hall::{HallConfig, HallDecoder};
use kerf::{Real, Q32};
use kerf_app::bench::Counter;
use kerf_app::exit;

/// Number of distinct inputs cycled through (a power of two).
const INPUTS: usize = 64;

fn row(
    counter: &mut Counter,
    name: &str,
    kernel: impl FnMut(u32),
    reference_name: &str,
    reference: impl FnMut(u32),
) {
    let n = counter.per_call(kernel);
    let r = counter.per_call(reference);
    hprintln!("| {} | {:.0} | {} | {:.0} |", name, n, reference_name, r);
}

/// Hall samples over one pitch: an axis moving 1/64 pitch per period.
fn hall_inputs() -> [[u16; 3]; INPUTS] {
    let cfg = HallConfig::LM1247_16BIT;
    let mut out = [[0u16; 3]; INPUTS];
    for (k, s) in out.iter_mut().enumerate() {
        let phi = 2.0 * PI * k as f32 / INPUTS as f32;
        for (ch, shift) in [0.0, 2.0 * PI / 3.0, -2.0 * PI / 3.0]
            .into_iter()
            .enumerate()
        {
            s[ch] = (cfg.calibration.offset_counts[ch]
                + cfg.amplitude_counts as f32 * libm::sinf(phi + shift)) as u16;
        }
    }
    out
}

/// The comparison decoder: float Clarke and libm's `atan2f`, unwrapped in f32 turns.
struct Atan2fDecoder {
    offset: [f32; 3],
    last_turn: f32,
    turns: f32,
}

impl Atan2fDecoder {
    fn update(&mut self, raw: [u16; 3]) -> f32 {
        let u = [
            raw[0] as f32 - self.offset[0],
            raw[1] as f32 - self.offset[1],
            raw[2] as f32 - self.offset[2],
        ];
        let alpha = (2.0 * u[0] - u[1] - u[2]) * (1.0 / 3.0);
        let beta = (u[1] - u[2]) * (1.0 / 1.732_050_8);
        let turn = libm::atan2f(alpha, beta) * (0.5 / PI);
        let mut step = turn - self.last_turn;
        step -= libm::roundf(step);
        self.last_turn = turn;
        self.turns += step;
        self.turns
    }
}

/// References along a slow ramp, one per input.
fn references() -> [Reference<f32>; INPUTS] {
    core::array::from_fn(|k| Reference {
        position: 0.004 + 1e-5 * k as f32,
        velocity: 0.1,
        acceleration: 0.5,
    })
}

#[cortex_m_rt::entry]
fn main() -> ! {
    let Some(peripherals) = cortex_m::Peripherals::take() else {
        exit(false)
    };
    let mut counter = Counter::new(peripherals.SYST);
    hprintln!(
        "# calibration: {:.3} instructions per SysTick tick (40 expected at -icount shift=0)",
        counter.instructions_per_tick()
    );

    let hall = hall_inputs();
    let axis = AxisConfig::LM1247_SLAVE;
    let (
        Ok(mut decoder),
        Ok(pd32),
        Ok(mut dob32),
        Ok(pdq),
        Ok(mut dobq),
        Ok(mut loop32),
        Ok(mut loop64),
    ) = (
        HallDecoder::new(&axis.hall),
        Pd::<f32>::new(&axis.pd),
        Dob::<f32>::new(&axis.dob),
        Pd::<Q32>::new(&axis.pd),
        Dob::<Q32>::new(&axis.dob),
        AxisLoop::<f32>::new(&axis),
        AxisLoop::<f64>::new(&axis),
    )
    else {
        exit(false)
    };
    let mut atan2f = Atan2fDecoder {
        offset: [32768.0; 3],
        last_turn: 0.0,
        turns: 0.0,
    };
    let mask = INPUTS as u32 - 1;
    let vectors: [(i32, i32); INPUTS] = core::array::from_fn(|k| {
        let phi = 2.0 * PI * (k as f32 + 0.3) / INPUTS as f32;
        (
            (78642.0 * libm::sinf(phi)) as i32,
            (78642.0 * libm::cosf(phi)) as i32,
        )
    });
    row(
        &mut counter,
        "sensing::hall::atan2_turns (integer, table)",
        |i| {
            let (y, x) = black_box(vectors[(i & mask) as usize]);
            black_box(kerf::sensing::hall::atan2_turns(y, x));
        },
        "libm::atan2f",
        |i| {
            let (y, x) = black_box(vectors[(i & mask) as usize]);
            black_box(libm::atan2f(y as f32, x as f32));
        },
    );
    row(
        &mut counter,
        "sensing::hall::HallDecoder::update (integer path, per axis)",
        |i| {
            black_box(decoder.update(black_box(hall[(i & mask) as usize]), 0).ok());
        },
        "f32 Clarke + libm::atan2f + unwrap",
        |i| {
            black_box(atan2f.update(black_box(hall[(i & mask) as usize])));
        },
    );

    let refs = references();
    let refs_q: [Reference<Q32>; INPUTS] = core::array::from_fn(|k| Reference {
        position: Q32::from_f64(f64::from(refs[k].position)),
        velocity: Q32::from_f64(f64::from(refs[k].velocity)),
        acceleration: Q32::from_f64(f64::from(refs[k].acceleration)),
    });
    let positions: [f32; INPUTS] = core::array::from_fn(|k| 0.004 + 1.1e-5 * k as f32);
    let positions_q: [Q32; INPUTS] =
        core::array::from_fn(|k| Q32::from_f64(f64::from(positions[k])));
    row(
        &mut counter,
        "control::{pd,dob} one period <f32>",
        |i| {
            let k = (i & mask) as usize;
            let a = pd32.acceleration(&refs[k], black_box(positions[k]), black_box(0.099));
            black_box(dob32.update(a, 0.099));
        },
        "same law <Q32> (Q31.32 fixed point)",
        |i| {
            let k = (i & mask) as usize;
            let a = pdq.acceleration(
                &refs_q[k],
                black_box(positions_q[k]),
                black_box(Q32::from_q32(425_201_762)),
            );
            black_box(dobq.update(a, Q32::from_q32(425_201_762)));
        },
    );

    let refs64: [Reference<f64>; INPUTS] = core::array::from_fn(|k| Reference {
        position: f64::from(refs[k].position),
        velocity: f64::from(refs[k].velocity),
        acceleration: f64::from(refs[k].acceleration),
    });
    row(
        &mut counter,
        "app::axis::AxisLoop::step <f32> (decode + observer + PD + DOB)",
        |i| {
            let k = (i & mask) as usize;
            black_box(loop32.step(black_box(hall[k]), &refs[k]));
        },
        "same loop <f64> (software double)",
        |i| {
            let k = (i & mask) as usize;
            black_box(loop64.step(black_box(hall[k]), &refs64[k]));
        },
    );
    exit(true)
}
