//! The scenarios the fixed-point machines are compared with f64 and checked against
//! their signal formats over: the single axis' tracking profile, the same
//! with a 1 N load step mid-move, a hold with a 1 N load step; one Keops slave
//! carriage tracking and holding under its gravity load.

use hal_mock::hall_sensor::ChannelFault;
use kerf_sim::scenario::{Motion, Scenario};

/// The single axis' scenarios.
pub fn axis_scenarios() -> [(&'static str, Scenario); 3] {
    let tracking = Scenario::TRACKING;
    let mut loaded = tracking;
    loaded.load_step = Some((0.25, 1.0));
    let mut hold = tracking;
    hold.motion = Motion::Hold;
    hold.periods = 5000;
    hold.load_step = Some((0.2, 1.0));
    [
        ("tracking", tracking),
        ("tracking, 1 N load step", loaded),
        ("hold, 1 N load step", hold),
    ]
}

/// The Keops slave carriage's scenarios: the slave's configuration, plant share and
/// gravity.
pub fn joint_scenarios() -> [(&'static str, Scenario); 2] {
    let joint = Scenario::keops_joint();
    let mut hold = joint;
    hold.motion = Motion::Hold;
    hold.periods = 5000;
    [
        ("Keops joint tracking, gravity load", joint),
        ("Keops joint hold, gravity load", hold),
    ]
}

/// `scenario` with an open wire on channel 0 at 0.3 s (a fault: zero force from
/// then on).
pub fn with_open_wire(scenario: Scenario) -> Scenario {
    Scenario {
        sensor_fault: Some((0.3, ChannelFault::OpenWire(0))),
        ..scenario
    }
}
