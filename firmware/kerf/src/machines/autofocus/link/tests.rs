use super::*;
use crate::app::host_link::{describe, HostLink, HostLinkConfig, SettingText};
use crate::app::jobs::JobSlots;
use crate::app::supervisor::{Command, Machine, NonFiniteOutput};
use crate::codec::job::{write_gcode, write_schedule};
use crate::codec::link::{
    decode, encode, Description, HostFrame, MachineMessage, Refusal, Reply, Request, MAX_FRAME,
};
use crate::machines::autofocus::product::{CONFIG, LAW, LINK_JOB_BYTES, PERIOD_S};
use heapless::spsc::Queue;
use miniconf::json_core;
use std::format;
use std::string::String;
use std::vec::Vec;

type S = FocusStage<f64>;

fn schedule_file(steps: &[[f64; 2]]) -> Vec<u8> {
    let mut out = std::vec![0u8; 16 + 8 * steps.len()];
    let n = write_schedule(steps, &mut out).unwrap();
    out.truncate(n);
    out
}

fn load(bytes: &[u8]) -> Result<ZoomSchedule, u16> {
    let file = JobFile::read(bytes).unwrap();
    let mut job = ZoomSchedule::new();
    <S as LinkMachine>::load_job(&mut CONFIG.clone(), &file, &mut job).map(|()| job)
}

/// The words a refusal code is told in.
fn refusal_words(code: u16) -> &'static str {
    CodeWords::find(&JOB_REFUSALS, code).unwrap().words
}

/// The power-up settings give back the product's law exactly, and validate.
#[test]
fn the_settings_at_power_up_are_the_products_law() {
    let settings = StageSettings::POWER_UP;
    assert_eq!(settings.law(), LAW);
    let close = |a: f64, b: f64| (a - b).abs() <= 1e-14 * b.abs();
    assert!(close(
        settings.velocity().bandwidth_rad_s,
        TAU * product::VELOCITY_BANDWIDTH_HZ
    ));
    assert!(S::coefficients(&settings, PERIOD_S).is_ok());
}

/// A schedule loads; a job of another kind and one of too many steps are refused,
/// and the machine's own refusals of a schedule it cannot run, in words.
#[test]
fn a_schedule_loads_and_bad_ones_are_refused_in_words() {
    let job = load(&schedule_file(&[[1.0, 6.0], [2.0, 4.0]])).unwrap();
    assert_eq!(job.len(), 2);
    let mut gcode = [0u8; 64];
    let n = write_gcode(b"G0 X10\n", &mut gcode).unwrap();
    let code = load(&gcode[..n]).unwrap_err();
    assert!(refusal_words(code).contains("schedule jobs only"));
    let code = load(&schedule_file(&[[1.0, 1.0]; 17])).unwrap_err();
    assert!(refusal_words(code).contains("more steps than a job holds (16)"));
    let stage = S::new(
        &CONFIG,
        S::coefficients(&StageSettings::POWER_UP, PERIOD_S).unwrap(),
    )
    .unwrap();
    for (steps, words) in [
        (&[][..], "no step"),
        (&[[4.0, 1.0]], "outside the zoom's range"),
        (&[[2.0, 0.0]], "dwell is not positive"),
        (&[[2.0, 1e4]], "longer than 600 s"),
    ] {
        let job = load(&schedule_file(steps)).unwrap();
        let error = stage.check_job(&job).unwrap_err();
        assert!(
            refusal_words(S::job_error_code(&error)).contains(words),
            "{steps:?}"
        );
    }
}

/// Every code the machine sends has its words, once; its refusals are not the link's;
/// a fault is told in words, with its detail's meaning.
#[test]
fn every_code_has_its_words() {
    let faults = [
        StageFault::FrameMissing,
        StageFault::DarkFrame,
        StageFault::NoTexture,
        StageFault::NotFinite,
        StageFault::HardStop { upper: false },
        StageFault::NoPeak,
        StageFault::Output(NonFiniteOutput { index: 1 }),
    ];
    let codes: Vec<u16> = faults.iter().map(|f| S::fault_code(f).0).collect();
    assert_eq!(codes, [1, 2, 3, 4, 5, 6, 7]);
    let (code, detail) = S::fault_code(&StageFault::HardStop { upper: true });
    let entry = CodeWords::find(&FAULTS, code).unwrap();
    assert!(entry.words.contains("hard stop"));
    assert!(entry.detail.contains("1 the upper"));
    assert_eq!(detail, 1);
    let (code, _) = S::fault_code(&StageFault::NoTexture);
    assert!(CodeWords::find(&FAULTS, code)
        .unwrap()
        .words
        .contains("too little texture"));
    for e in [
        JobError::Empty,
        JobError::Magnification { step: 0 },
        JobError::Dwell { step: 3 },
    ] {
        assert!(CodeWords::find(&JOB_REFUSALS, S::job_error_code(&e)).is_some());
    }
    crate::app::host_link::test_support::assert_code_tables(&FAULTS, &JOB_REFUSALS);
}

/// The description: the channels in a sample's order, schedule jobs, nine settings
/// with their units and ranges; the announced bounds are where validation refuses at
/// the stage's period.
#[test]
fn the_stage_describes_itself() {
    let (settings, count) =
        crate::app::host_link::test_support::described::<S>(&StageSettings::POWER_UP);
    assert_eq!(settings.len(), 9, "{settings:?}");
    assert!(settings.contains(&String::from("/law/max_speed_m_s [m/s] > 0")));
    assert!(settings.contains(&String::from("/velocity/bandwidth_hz [Hz] > 0 and ≤ 318")));
    assert_eq!(
        count,
        CHANNELS.len() + 1 + 9 + FAULTS.len() + JOB_REFUSALS.len()
    );
    let mut path = SettingText::default();
    assert_eq!(
        describe::<S>(CHANNELS.len() as u16, &StageSettings::POWER_UP, &mut path),
        Some(Description::JobKind(JobKind::Schedule))
    );
    for (path, at, past) in [
        ("/velocity/bandwidth_hz", &b"318"[..], &b"319"[..]),
        ("/law/tracking_gain_per_s", b"1000", b"1001"),
        ("/law/window_excursion_m", b"0.0024", b"0.0025"),
        ("/law/search_speed_m_s", b"0.005", b"0.0051"),
    ] {
        for (value, accepted) in [(at, true), (past, false)] {
            let mut candidate = StageSettings::POWER_UP;
            json_core::set(&mut candidate, path, value).unwrap();
            assert_eq!(
                S::coefficients(&candidate, PERIOD_S).is_ok(),
                accepted,
                "{path}"
            );
        }
    }
}

/// A sample carries each value in its channel; no gradient is sent as 0 with the
/// law's mode beside it.
#[test]
fn a_sample_has_a_value_per_channel() {
    let mut t = StageTelemetry::<f64> {
        position_m: 4.5e-3,
        velocity_m_s: 1e-3,
        sharpness: 7.25,
        gradient: Some(-250.0),
        velocity_reference_m_s: 1.5e-3,
        acceleration_m_s2: -0.25,
        magnification: 2.0,
        mode: LawMode::Track,
        step: 1,
    };
    let mut values = ChannelValues::new();
    S::sample(&t, &mut values);
    assert_eq!(values.len(), CHANNELS.len());
    let at = |values: &ChannelValues, name: &str| {
        values[CHANNELS.iter().position(|c| c.name == name).unwrap()]
    };
    assert_eq!(at(&values, "position"), 4.5e-3);
    assert_eq!(at(&values, "sharpness"), 7.25);
    assert_eq!(at(&values, "gradient"), -250.0);
    assert_eq!(at(&values, "velocity_reference"), 1.5e-3);
    assert_eq!(at(&values, "velocity"), 1e-3);
    assert_eq!(at(&values, "acceleration"), -0.25);
    assert_eq!(at(&values, "magnification"), 2.0);
    assert_eq!((at(&values, "law_mode"), at(&values, "step")), (1.0, 1.0));
    t.gradient = None;
    t.mode = LawMode::Hold;
    S::sample(&t, &mut values);
    assert_eq!(
        (at(&values, "gradient"), at(&values, "law_mode")),
        (0.0, 2.0)
    );
}

/// Through the link itself: a path the tree does not have, and a value outside its
/// range, are refused, and the settings the link holds stay as they were; a value in
/// range is taken.
#[test]
fn bad_settings_are_refused_and_change_nothing() {
    let jobs = JobSlots::default();
    let mut commands = Queue::<Command<S>, 2>::new();
    let (mut to_machine, _from_link) = commands.split();
    let config = HostLinkConfig {
        period_s: PERIOD_S,
        heartbeat_timeout_s: 0.05,
    };
    let before = StageSettings::POWER_UP;
    let mut link = HostLink::<S, LINK_JOB_BYTES>::new(&config, before, CONFIG, &jobs).unwrap();
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
        (
            1,
            "/law/travel_m",
            &b"0.01"[..],
            refused(Refusal::UnknownPath),
        ),
        (2, "/gain", b"5", refused(Refusal::UnknownPath)),
        (
            3,
            "/velocity/bandwidth_hz",
            b"400",
            refused(Refusal::BadValue),
        ),
        (
            4,
            "/law/max_speed_m_s",
            b"0.0005",
            refused(Refusal::BadValue),
        ),
        (5, "/law/refocus_change", b"1", refused(Refusal::BadValue)),
        (
            6,
            "/law/min_sharpness",
            b"\"high\"",
            refused(Refusal::BadValue),
        ),
    ] {
        let (replies, now) = set(seq, path, value);
        assert_eq!(replies, answer, "{path}");
        assert_eq!(now, before, "{path}");
    }
    // Taken: the command is queued for the machine, the link holds the new value.
    let (_, now) = set(7, "/law/max_speed_m_s", b"0.002");
    assert_eq!(now.law.max_speed_m_s, 0.002);
}
