use super::*;
use crate::app::host_link::{describe, HostLink, HostLinkConfig, SettingText};
use crate::app::jobs::JobSlots;
use crate::app::supervisor::Command;
use crate::codec::job::{write_efd, write_gcode};
use crate::codec::link::{
    decode, encode, Description, HostFrame, MachineMessage, Refusal, Reply, Request,
    LINK_JOB_REFUSALS, MAX_FRAME,
};
use crate::machines::single_axis::product::{CONFIG, LINK_JOB_BYTES, PERIOD_S};
use heapless::spsc::Queue;
use miniconf::json_core;
use std::format;
use std::string::String;
use std::vec::Vec;

type A = Axis<f64>;

/// The moves the image and the host tests run.
const MOVES: &str = include_str!("../../../../../../data/axis_moves.gcode");

fn job_file(gcode: &[u8]) -> Vec<u8> {
    let mut out = std::vec![0u8; gcode.len() + 64];
    let n = write_gcode(gcode, &mut out).unwrap();
    out.truncate(n);
    out
}

fn load(bytes: &[u8]) -> Result<JointJob<1>, u16> {
    let file = JobFile::read(bytes).unwrap();
    let mut job = JointJob::new();
    <A as LinkMachine>::load_job(&mut CONFIG.clone(), &file, &mut job).map(|()| job)
}

/// The words a refusal code is told in.
fn refusal_words(code: u16) -> &'static str {
    CodeWords::find(&JOB_REFUSALS, code).unwrap().words
}

/// The preset's settings give back the preset exactly (the PD's gains are carried as
/// they are; the bandwidths through Hz within a few ulps), and its law.
#[test]
fn the_settings_of_the_preset_are_the_preset() {
    let config = AxisConfig::LM1247_SLAVE;
    let back = AxisSettings::of(&config).config();
    assert_eq!(back.pd, config.pd);
    let close = |a: f64, b: f64| (a - b).abs() <= 1e-14 * b.abs();
    assert!(close(back.dob.bandwidth_rad_s, config.dob.bandwidth_rad_s));
    assert!(close(
        back.velocity.bandwidth_rad_s,
        config.velocity.bandwidth_rad_s
    ));
    assert_eq!(back.dob.nominal_mass_kg, config.dob.nominal_mass_kg);
    assert!(A::coefficients(&AxisSettings::of(&config), PERIOD_S).is_ok());
}

/// The moves' file loads; a job of another kind, and programs the axis cannot run,
/// are refused with codes whose words say why.
#[test]
fn a_gcode_job_loads_and_bad_ones_are_refused_in_words() {
    let job = load(&job_file(MOVES.as_bytes())).unwrap();
    assert!(job.len() >= 4, "{job:?}");
    let total: f64 = job.iter().map(|s| s.duration_s).sum();
    assert!(total > 3.0 && total < 8.0, "{total} s");
    let mut efd = [0u8; 128];
    let n = write_efd([0.0, 0.0], &[[1e-3, 0.0, 0.0, 1e-3]], &mut efd).unwrap();
    let code = load(&efd[..n]).unwrap_err();
    assert!(refusal_words(code).contains("G-code jobs only"));
    for (program, words) in [
        (&b"G0 X10 Y5\n"[..], "X axis only"),
        (b"G0 X10\nG1 X20 F0\n", "a feed is zero"),
        (b"G0 X150\n", "outside the axis' travel"),
        (b"G21\n", "no move"),
        (b"G1 X10 Q3\n", "does not parse"),
    ] {
        let code = load(&job_file(program)).unwrap_err();
        assert!(refusal_words(code).contains(words), "{code:#x}");
    }
}

/// Every code the machine sends has its words, once; its refusals are not the link's;
/// a sensor fault is told as one, with its check in the detail.
#[test]
fn every_code_has_its_words() {
    let fault = |fault| JointFault { axis: 0, fault };
    let faults = [
        fault(AxisFault::Sensor(HallFault::AdcRail(0))),
        fault(AxisFault::ReferenceNotFinite),
        fault(AxisFault::CoastOutOfBound),
        fault(AxisFault::NotFinite),
    ];
    let codes: Vec<u16> = faults.iter().map(|f| A::fault_code(f).0).collect();
    assert_eq!(codes, [1, 2, 3, 4]);
    let (code, detail) = A::fault_code(&fault(AxisFault::Sensor(HallFault::StuckChannel(1))));
    let entry = CodeWords::find(&FAULTS, code).unwrap();
    assert!(entry.words.contains("Hall sensors"));
    assert!(entry.detail.contains("3-5 a channel stuck"));
    assert_eq!(detail, 4);
    for e in [
        JobError::Empty,
        JobError::NotFinite { segment: 0 },
        JobError::OutOfTravel {
            segment: 1,
            axis: 0,
        },
        JobError::TooFast {
            segment: 1,
            axis: 0,
        },
        JobError::TooLong { segment: 0 },
    ] {
        assert!(CodeWords::find(&JOB_REFUSALS, A::job_error_code(&e)).is_some());
    }
    let moving = A::job_error_code(&JobError::Moving { axis: 0 });
    assert!(CodeWords::find(&LINK_JOB_REFUSALS, moving).is_some());
    crate::app::host_link::test_support::assert_code_tables(&FAULTS, &JOB_REFUSALS);
}

/// The description: the channels in a sample's order, G-code jobs, seven settings with
/// their units and ranges; the announced bound of a bandwidth is where validation
/// refuses at the axis' period.
#[test]
fn the_axis_describes_itself() {
    let (settings, count) =
        crate::app::host_link::test_support::described::<A>(&AxisSettings::of(&CONFIG.axis));
    assert_eq!(settings.len(), 7, "{settings:?}");
    assert!(settings.contains(&String::from("/pd/kp_per_s2 [1/s²] > 0")));
    assert!(settings.contains(&String::from("/dob/bandwidth_hz [Hz] > 0 and ≤ 3183")));
    assert_eq!(
        count,
        CHANNELS.len() + 1 + 7 + FAULTS.len() + JOB_REFUSALS.len()
    );
    let mut path = SettingText::default();
    assert_eq!(
        describe::<A>(
            CHANNELS.len() as u16,
            &AxisSettings::of(&CONFIG.axis),
            &mut path
        ),
        Some(Description::JobKind(JobKind::Gcode))
    );
    let settings = AxisSettings::of(&CONFIG.axis);
    for path in ["/dob/bandwidth_hz", "/velocity/bandwidth_hz"] {
        for (value, accepted) in [(&b"3183"[..], true), (&b"3184"[..], false)] {
            let mut candidate = settings;
            json_core::set(&mut candidate, path, value).unwrap();
            assert_eq!(
                A::coefficients(&candidate, PERIOD_S).is_ok(),
                accepted,
                "{path}"
            );
        }
    }
}

/// A sample carries the measured position, the reference and their difference, the
/// velocity, the force and the disturbance estimate, in the channels' order.
#[test]
fn a_sample_has_a_value_per_channel() {
    let t = JointTelemetry::<f64, 1> {
        reference: [crate::trajectory::Reference {
            position: 0.0125,
            velocity: 0.1,
            acceleration: 0.0,
        }],
        axes: [crate::app::axis::AxisOutput {
            force_n: 1.5,
            position_m: 0.0120,
            velocity_m_s: 0.09,
            disturbance_n: -0.25,
            saturated: false,
            status: crate::app::axis::AxisStatus::Running,
        }],
    };
    let mut values = ChannelValues::new();
    A::sample(&t, &mut values);
    assert_eq!(values.len(), CHANNELS.len());
    let at = |name: &str| values[CHANNELS.iter().position(|c| c.name == name).unwrap()];
    assert_eq!((at("position"), at("reference")), (0.0120, 0.0125));
    assert_eq!(
        (at("tracking_error"), at("velocity")),
        ((0.0125f64 - 0.0120) as f32, 0.09)
    );
    assert_eq!((at("force"), at("disturbance")), (1.5, -0.25));
}

/// Through the link itself: a path the tree does not have, and a value outside its
/// range, are refused, and the settings the link holds stay as they were; a value in
/// range is taken.
#[test]
fn bad_settings_are_refused_and_change_nothing() {
    let jobs = JobSlots::default();
    let mut commands = Queue::<Command<A>, 2>::new();
    let (mut to_machine, _from_link) = commands.split();
    let config = HostLinkConfig {
        period_s: PERIOD_S,
        heartbeat_timeout_s: 0.05,
    };
    let before = AxisSettings::of(&CONFIG.axis);
    let mut link = HostLink::<A, LINK_JOB_BYTES>::new(&config, before, CONFIG, &jobs).unwrap();
    let mut set = |seq: u16, path: &str, value: &[u8]| {
        let mut out = [0u8; MAX_FRAME];
        let request = Request::Set { path, value };
        let n = encode(&HostFrame { seq, request }, &mut out).unwrap();
        let mut replies = Vec::new();
        for &b in &out[..n] {
            link.receive(b, 0.0, &mut to_machine, &mut |f| {
                let mut raw = f[1..f.len() - 1].to_vec();
                if let Ok(MachineMessage::Reply { reply, .. }) = decode::<MachineMessage>(&mut raw)
                {
                    replies.push(format!("{reply:?}"));
                }
                true
            });
        }
        (replies, *link.settings())
    };
    let refused = |r: Refusal| std::vec![format!("{:?}", Reply::Refused(r))];
    for (seq, path, value, answer) in [
        (1, "/pd/ki", &b"5"[..], refused(Refusal::UnknownPath)),
        (2, "/gain", b"5", refused(Refusal::UnknownPath)),
        (3, "/dob/bandwidth_hz", b"4000", refused(Refusal::BadValue)),
        (4, "/pd/kd_per_s", b"-1", refused(Refusal::BadValue)),
        (5, "/dob/compensate", b"2", refused(Refusal::BadValue)),
    ] {
        let (replies, now) = set(seq, path, value);
        assert_eq!(replies, answer, "{path}");
        assert_eq!(now, before, "{path}");
    }
    // Taken: the command is queued for the machine, the link holds the new value.
    let (_, now) = set(6, "/pd/kd_per_s", b"600");
    assert_eq!(now.pd.kd_per_s, 600.0);
}
