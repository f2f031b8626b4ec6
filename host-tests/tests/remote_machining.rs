//! Remote machining end to end (`host_tests::remote`): run with `--nocapture` for the
//! tables.

use host_tests::remote::{run, RemoteCase};

#[test]
fn probe() {
    for m in [0, 1, 2, 3] {
        for obs_bw in [5.0, 10.0] {
            let mut case = RemoteCase::nominal();
            case.observer_hz = obs_bw;
            if m & 1 == 1 {
                case.slave_plant = hal_mock::delta_plant::DeltaPlantParams::SLAVE;
            }
            if m & 2 == 2 {
                case.network.delay_ms = 0;
                case.network.jitter_ms = 0;
            }
            let r = run(&case).unwrap();
            println!("m {m} obs {obs_bw}: {:?}", r.tracking_m(5.0));
        }
    }
    let case = RemoteCase::nominal();
    let r = run(&case).unwrap();
    println!(
        "{:?} {:?} {:?}",
        r.tracking_m(5.0),
        r.slave_mode,
        r.master_mode
    );
    println!(
        "bytes {:?} latency {:?} lost {} refused {}",
        r.bytes_per_s, r.latency_ms, r.lost_frames, r.refused_frames
    );
    for s in r.samples.iter().step_by(25000) {
        println!(
            "{:.2} across {:.1} µm speed {:.2} mm/s slave {:?} ref {:?} laser {:.2}",
            s.t_s,
            s.master_across_m * 1e6,
            s.master_speed_m_s * 1e3,
            s.slave_m.map(|c| (c * 1e6).round() / 1e3),
            s.slave_reference_m
                .map(|r| r.map(|c| (c * 1e6).round() / 1e3)),
            s.laser_w
        );
    }
}
