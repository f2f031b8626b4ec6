//! T 8.2.1 on the simulated Keops slave: gear, cam and octagon (about ±6 mm) at 8 mm/s,
//! independent joint control against contouring control (and joint PD with preview),
//! at the seed's 2.4 kHz and at 10 kHz.

use hal_mock::delta_plant::DeltaPlantParams;
use host_tests::machining::{run, scaled, ContourCase, ContourReport};
use kerf::app::delta_slave::ContourLaw;
use kerf::trajectory::shapes;

fn shapes() -> [(&'static str, Vec<[f64; 2]>); 3] {
    // T fig. 8.4 sizes: about ±6 mm (the stored shapes are ±10 mm).
    [
        ("gear", scaled(&shapes::gear(), 0.6)),
        ("cam", scaled(&shapes::cam(), 0.6)),
        ("octagon", scaled(&shapes::octagon(), 0.6)),
    ]
}

fn case(polygon: &[[f64; 2]], law: ContourLaw, period_s: f64) -> ContourCase {
    ContourCase {
        polygon: polygon.to_vec(),
        harmonics: 30,
        speed_m_s: 8e-3,
        law,
        period_s,
        plant: DeltaPlantParams::SLAVE,
    }
}

fn report(name: &str, law: ContourLaw, rate_hz: f64, r: &ContourReport) {
    println!(
        "{name:>8} {rate_hz:>6.0} Hz {law:>11?}: normal max {:7.3} µm rms {:7.3} µm, speed error max {:7.3} mm/s, peak force {:5.2} N{}",
        r.max_normal_m * 1e6,
        r.rms_normal_m * 1e6,
        r.max_speed_error_m_s * 1e3,
        r.peak_force_n,
        r.fault.map_or(String::new(), |f| format!(", FAULT {f:?}"))
    );
}

#[test]
fn contouring_against_joint_control() {
    for (name, polygon) in shapes() {
        for period_s in [1e-4, 1.0 / 2400.0] {
            for law in [
                ContourLaw::Joint,
                ContourLaw::Preview,
                ContourLaw::Contouring,
            ] {
                let r = run::<f32>(&case(&polygon, law, period_s)).unwrap();
                report(name, law, 1.0 / period_s, &r);
                assert!(r.fault.is_none());
            }
        }
    }
}
