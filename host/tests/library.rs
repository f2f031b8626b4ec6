//! The host library's smaller functions a caller reads directly: the tracer's mask
//! (m-adjacency and pruning against their definitions), the words for refusals, the
//! telemetry log's marks and pictures.

use kerf::codec::link::{ModeCode, Refusal, TelemetrySample};
use kerf::trajectory::gcode::GcodeErrorKind;
use kerf_host::description::{ChannelInfo, Item, MachineDescription};
use kerf_host::gcode::describe_gcode;
use kerf_host::mask::{Mask, Px};
use kerf_host::telemetry::TelemetryLog;
use std::collections::BTreeSet;

/// m-adjacency (the mask's module docs) by its definition: the four edge neighbours,
/// and a corner neighbour only when neither pixel it shares with `p` is set.
fn m_neighbours(mask: &Mask, p: Px) -> BTreeSet<Px> {
    let (x, y) = (i64::from(p.0), i64::from(p.1));
    let mut out = BTreeSet::new();
    for dy in -1..=1i64 {
        for dx in -1..=1i64 {
            if (dx, dy) == (0, 0) || !mask.get(x + dx, y + dy) {
                continue;
            }
            let corner = dx != 0 && dy != 0;
            if corner && (mask.get(x + dx, y) || mask.get(x, y + dy)) {
                continue;
            }
            out.insert(((x + dx) as u32, (y + dy) as u32));
        }
    }
    out
}

#[test]
fn neighbours_are_the_m_adjacent_set_pixels() {
    // A pseudo-random 12 × 9 mask, about 40 % set (a multiplicative hash of the
    // pixel's index), so that every corner case of the adjacency occurs.
    let mask = Mask::from_fn(12, 9, |x, y| {
        ((y * 12 + x).wrapping_mul(2_654_435_761) >> 16) % 5 < 2
    });
    let mut checked = 0;
    for y in 0..9 {
        for x in 0..12 {
            let got: Vec<Px> = mask.neighbours((x, y)).collect();
            let unique: BTreeSet<Px> = got.iter().copied().collect();
            assert_eq!(unique.len(), got.len(), "({x}, {y}) repeats a neighbour");
            assert_eq!(unique, m_neighbours(&mask, (x, y)), "({x}, {y})");
            checked += got.len();
        }
    }
    assert!(checked > 50, "{checked}");
}

/// A ring of pixels with a dangling branch and an isolated stroke: pruning keeps the
/// ring exactly.
#[test]
fn pruning_keeps_the_cycles_and_nothing_else() {
    let ring = |x: u32, y: u32| {
        (2..=8).contains(&x) && (2..=8).contains(&y) && (x == 2 || x == 8 || y == 2 || y == 8)
    };
    let branch = |x: u32, y: u32| y == 5 && (9..=13).contains(&x);
    let stroke = |x: u32, y: u32| x == 16 && (1..=9).contains(&y);
    let all = Mask::from_fn(20, 12, |x, y| ring(x, y) || branch(x, y) || stroke(x, y));
    let pruned = all.pruned_to_cycles();
    assert_eq!(pruned, Mask::from_fn(20, 12, ring));
    assert_eq!(pruned.count(), 24);
    // A tree has no cycle: nothing is left.
    let tree = Mask::from_fn(20, 12, |x, y| {
        branch(x, y) || stroke(x, y) || (y == 9 && x > 10)
    });
    assert_eq!(tree.pruned_to_cycles().count(), 0);
}

#[test]
fn refusals_are_told_apart_and_name_their_figures() {
    let refusals = [
        Refusal::ChunkOffset { expected: 4096 },
        Refusal::TooLarge,
        Refusal::Incomplete,
        Refusal::NoJob,
        Refusal::Job(3),
        Refusal::InvalidInMode,
        Refusal::UnknownPath,
        Refusal::BadValue,
        Refusal::Busy,
    ];
    let slave = keops_slave();
    let texts: BTreeSet<String> = refusals
        .iter()
        .map(|r| slave.refusal_words(r, None))
        .collect();
    assert_eq!(texts.len(), refusals.len(), "{texts:?}");
    let unknown = MachineDescription::default();
    assert!(unknown
        .refusal_words(&Refusal::ChunkOffset { expected: 4096 }, None)
        .contains("4096"));
    let job = slave.refusal_words(&Refusal::Job(3), None);
    assert!(job.starts_with("job code 0x0003: "), "{job}");
    assert!(job.ends_with(&slave.job_refusal_words(3)), "{job}");
    assert!(job.contains("workspace"), "{job}");
    // The slave's own words per code; a machine that described none has none.
    for code in 1..=11 {
        assert!(!slave.job_refusal_words(code).contains("does not describe"));
        assert!(unknown
            .job_refusal_words(code)
            .contains("does not describe"));
    }
    // A refused setting names the range the slave announced.
    let bad = slave.refusal_words(&Refusal::BadValue, Some("/slave/dob/bandwidth_hz"));
    assert!(bad.ends_with("takes > 0 and ≤ 3183 Hz"), "{bad}");
}

/// The Keops slave's description as the machine sends it, item by item.
fn keops_slave() -> MachineDescription {
    use kerf::app::host_link::{describe, SettingPath};
    let mut d = MachineDescription::default();
    for index in 0.. {
        let mut path = SettingPath::default();
        match describe::<kerf::app::delta_slave::DeltaSlave<f32>>(index, &mut path) {
            Some(item) => d.add(&Item::of(&item)),
            None => return d,
        }
    }
    d
}

#[test]
fn gcode_refusals_spell_the_code_and_the_byte() {
    let unsupported =
        |letter, code_x10| describe_gcode(GcodeErrorKind::Unsupported { letter, code_x10 });
    assert_eq!(unsupported(b'G', 641), "unsupported code G64.1");
    assert_eq!(unsupported(b'M', 60), "unsupported code M6");
    assert_eq!(unsupported(b'G', 5), "unsupported code G0.5");
    assert_eq!(
        describe_gcode(GcodeErrorKind::UnknownWord(b'Q')),
        "unknown word 'Q'"
    );
    assert_eq!(
        describe_gcode(GcodeErrorKind::UnexpectedByte(0x07)),
        "unexpected byte 0x07"
    );
    assert_eq!(
        describe_gcode(GcodeErrorKind::DuplicateWord(b'X')),
        "word 'X' given twice"
    );
}

fn sample(period: u32, mode: ModeCode) -> TelemetrySample {
    TelemetrySample {
        period,
        mode,
        values: [1e-6 * period as f32].into_iter().collect(),
    }
}

/// A mark is at the latest sample's time (0 before any), in order; the picture has
/// one line per mark, labelled.
#[test]
fn marks_sit_at_the_latest_sample_and_are_drawn() {
    let error = ChannelInfo {
        name: "error".into(),
        unit: "m".into(),
    };
    let mut log = TelemetryLog::new(1e-3, &[error]);
    log.mark("start");
    for period in 0..50 {
        log.push(sample(period * 10, ModeCode::Running));
    }
    log.mark("gain 2.0");
    log.push(sample(500, ModeCode::Running));
    log.push(sample(510, ModeCode::Stopping));
    log.mark("fault");
    assert_eq!(
        log.marks()
            .iter()
            .map(|(t, l)| (*t, l.as_str()))
            .collect::<Vec<_>>(),
        [(0.0, "start"), (0.49, "gain 2.0"), (0.51, "fault")]
    );
    let svg = log.svg("run").unwrap();
    assert!(svg.starts_with("<svg"), "{}", &svg[..40.min(svg.len())]);
    for label in ["gain 2.0", "fault", "run"] {
        assert!(svg.contains(label), "{label}");
    }
}
