//! QEMU remote slave: the slave side of remote machining (`RemoteSlave<f32>` on the
//! simulated Keops delta, `kerf_sim::remote`) fed the command frames a host run of the
//! remote scenario recorded (`data/remote_commands.krfr`: 20 ± 10 ms,
//! scale 0.5, 4 s of the master's job), each at the period it reached the slave there.
//! The slave calibrates its Hall sensors, approaches its start, then follows. The run
//! prints its tracking against the recorded scaled master in a fixed format and exits
//! non-zero when it misses its bounds or the machine faulted; `scripts/smoke` compares
//! the figures with the host's f64 replay of the same frames within
//! `kerf_sim::remote::REPLAY_F32_TOLERANCE_M`.
#![no_std]
#![no_main]

use cortex_m_rt::entry;
use cortex_m_semihosting::hprintln;
use kerf_app::exit;
use kerf_sim::remote::{replay, REPLAY_BOUNDS_M};

/// The recorded frames (host-tests `remote_replay` regenerates and checks them).
static RECORDING: &[u8] = include_bytes!("../../../../data/remote_commands.krfr");

#[entry]
fn main() -> ! {
    let run = match replay::<f32>(RECORDING) {
        Ok(run) => run,
        Err(e) => {
            hprintln!("kerf qemu remote: the replay did not run ({:?}) -> FAIL", e);
            exit(false)
        }
    };
    let within = run.fault.is_none()
        && run.refused == 0
        && run.max_m < REPLAY_BOUNDS_M.0
        && run.rms_m < REPLAY_BOUNDS_M.1;
    // Nanometres, printed as integers (no float formatting in the image).
    let nm = |m: f64| libm::round(m * 1e9) as i64;
    hprintln!(
        "kerf qemu remote (f32): {} periods, {} frames, tracking max {} rms {} (nm){}; bounds {} {} -> {}",
        run.periods,
        run.frames,
        nm(run.max_m),
        nm(run.rms_m),
        if run.fault.is_some() { ", FAULT" } else { "" },
        nm(REPLAY_BOUNDS_M.0),
        nm(REPLAY_BOUNDS_M.1),
        if within { "PASS" } else { "FAIL" }
    );
    exit(within)
}
