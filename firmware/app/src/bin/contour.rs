//! QEMU contour run: the Keops slave machine (`DeltaSlave<f32>`) cuts a quarter of the
//! octagon of T fig. 8.4 under contouring control, with the simulated delta and its
//! Hall sensors in the same image (`kerf_sim::contour`): nominal decoders installed as
//! a stored calibration (the 128 KB of RAM hold the slave's queues and state but not
//! the fit's working set besides; the axis image runs the calibration), approach,
//! contour. The run prints the contour error summary in a fixed format and
//! exits non-zero when it misses its bounds or the machine faulted. `scripts/smoke`
//! compares the printed figures with the host's f64 run of the same scenario within
//! `kerf_sim::contour::CONTOUR_F32_TOLERANCE_M` (the image has no room for a second,
//! f64 machine: both together pass the 512 KiB flash).
#![no_std]
#![no_main]

use cortex_m_rt::entry;
use cortex_m_semihosting::hprintln;
use kerf_app::exit;
use kerf_sim::contour::{run_octagon, CONTOUR_BOUNDS_M, SMOKE_LAPS, SMOKE_SUBSTEPS};

#[entry]
fn main() -> ! {
    let Ok(run) = run_octagon::<f32>(SMOKE_LAPS, SMOKE_SUBSTEPS, false) else {
        hprintln!("kerf qemu contour: the scenario did not run -> FAIL");
        exit(false)
    };
    let within = run.fault.is_none()
        && run.max_normal_m < CONTOUR_BOUNDS_M.0
        && run.rms_normal_m < CONTOUR_BOUNDS_M.1;
    // Tenths of a nanometre, printed as integers (no float formatting in the image).
    let tenths = |m: f64| libm::round(m * 1e10) as i64;
    hprintln!(
        "kerf qemu contour (f32): {} periods, contour error max {} rms {} (0.1 nm){}; bounds {} {} -> {}",
        run.periods,
        tenths(run.max_normal_m),
        tenths(run.rms_normal_m),
        if run.fault.is_some() { ", FAULT" } else { "" },
        tenths(CONTOUR_BOUNDS_M.0),
        tenths(CONTOUR_BOUNDS_M.1),
        if within { "PASS" } else { "FAIL" }
    );
    exit(within)
}
