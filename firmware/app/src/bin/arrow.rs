//! QEMU ARROW run: the pyramid of A §5 (`data/pyramid.gcode`, carried in
//! the image) parsed and checked on the MCU into a job, then machined by
//! `ArrowMachine<f32>` through the supervisor at 5 kHz against the simulated ARROW
//! (with its geometric error, one RK4 step per period: `kerf_sim::arrow`), the whole
//! job. The run prints the RMS tracking errors of A eq. 55–58 in a fixed format and
//! exits non-zero when it misses the published figures (A table 3) or the machine
//! faulted; `scripts/smoke` compares the figures with the host's f64 run of the same
//! scenario within `kerf_sim::arrow::ARROW_F32_TOLERANCE`.
#![no_std]
#![no_main]

use cortex_m_rt::entry;
use cortex_m_semihosting::hprintln;
use heapless::Vec;
use kerf::app::supervisor::Mode;
use kerf::machines::arrow::product::{load_job, Job, PROGRAM_POINTS};
use kerf_app::exit;
use kerf_sim::arrow::{run_job, ArrowScenario, TrackingSums, ARROW_SMOKE_BOUNDS, PYRAMID_GCODE};

#[entry]
fn main() -> ! {
    // The job and the parse buffer in static memory, not on the stack.
    let (Some(points), Some(job)) = (
        cortex_m::singleton!(: Vec<kerf::trajectory::gcode::GcodePoint, PROGRAM_POINTS> = Vec::new()),
        cortex_m::singleton!(: Job<f32> = Job::<f32>::default()),
    ) else {
        exit(false)
    };
    if let Err(e) = load_job(PYRAMID_GCODE.as_bytes(), points, job) {
        hprintln!(
            "kerf qemu arrow: the pyramid was refused at line {}: {:?} -> FAIL",
            e.line,
            e.kind
        );
        exit(false)
    }
    let mut sums = TrackingSums::default();
    let end = match run_job::<f32>(
        &ArrowScenario::smoke(),
        job,
        u64::MAX,
        &mut |_, _| {},
        &mut |p| sums.push(p),
    ) {
        Ok(end) => end,
        Err(e) => {
            hprintln!("kerf qemu arrow: the plant stopped: {:?} -> FAIL", e);
            exit(false)
        }
    };
    let r = sums.rms();
    let done = end.mode == Mode::Ready && end.periods == job.periods();
    let within = done && ARROW_SMOKE_BOUNDS.holds(&r);
    // Nanometres and micro-degrees, printed as integers (no float formatting).
    let nm = |m: f64| libm::round(m * 1e9) as i64;
    let udeg = |d: f64| libm::round(d * 1e6) as i64;
    hprintln!(
        "kerf qemu arrow (f32): {} periods, eq. 55 {} nm, eq. 56 {} udeg, eq. 57 {} nm (Rm q {} nm), eq. 58 {} udeg{}; bounds {} nm {} udeg -> {}",
        end.periods,
        nm(r.cartesian_m),
        udeg(r.cartesian_deg),
        nm(r.joint_m),
        nm(r.joint_consistent_m),
        udeg(r.joint_deg),
        if done { "" } else { ", NOT DONE" },
        nm(ARROW_SMOKE_BOUNDS.cartesian_m),
        udeg(ARROW_SMOKE_BOUNDS.cartesian_deg),
        if within { "PASS" } else { "FAIL" }
    );
    exit(within)
}
