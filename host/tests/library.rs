//! The host library's smaller functions a caller reads directly: the tracer's mask
//! (m-adjacency and pruning against their definitions), the words for refusals, the
//! telemetry log's marks and pictures.

use kerf::codec::link::{ModeCode, Refusal, TelemetrySample};
use kerf::kinematics::arrow::{ArrowConfig, ArrowError};
use kerf::machines::arrow::job::ArrowJobErrorKind;
use kerf::trajectory::feed::FeedError;
use kerf::trajectory::gcode::GcodeErrorKind;
use kerf::trajectory::task_spline::TaskSplineError;
use kerf_host::description::{ChannelInfo, Item, MachineDescription};
use kerf_host::gcode::{
    check, describe_gcode, describe_job, diagnose, format_diagnostic, has_errors,
};
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
    use kerf::app::host_link::{describe, SettingText};
    use kerf::machines::delta_slave::{link::SlaveSettings, DeltaSlave, DeltaSlaveConfig};
    let presets = SlaveSettings::of(&DeltaSlaveConfig::KEOPS.joints.axis);
    let mut d = MachineDescription::default();
    for index in 0.. {
        let mut text = SettingText::default();
        match describe::<DeltaSlave<f32>>(index, &presets, &mut text) {
            Some(item) => d.add(&Item::of(&item)),
            None => return d,
        }
    }
    d
}

/// Every problem of a program in one pass, in file order, each as
/// `FILE:LINE:COLUMN: severity: message`; a program with warnings only has no errors.
#[test]
fn a_program_is_diagnosed_whole_and_printed_as_compilers_print() {
    // Line 2: a tool change (a warning: nothing to change on ARROW); line 3: an
    // unknown word at column 8 (an error); line 4: a good move.
    let text = b"G21 G90\nT1 M6\nG1 X10 Q3 F600\nG1 X20 F600\n";
    let found = diagnose(text);
    let printed: Vec<String> = found
        .iter()
        .map(|d| format_diagnostic("part.nc", d))
        .collect();
    assert!(printed.len() >= 2, "{printed:?}");
    assert!(printed[0].starts_with("part.nc:2:"), "{printed:?}");
    assert!(printed[0].contains("warning"), "{printed:?}");
    let error = printed
        .iter()
        .find(|p| p.contains("error"))
        .expect("the error");
    assert!(error.starts_with("part.nc:3:8:"), "{error}");
    assert!(error.contains("'Q'"), "{error}");
    assert!(has_errors(&found));
    let warnings_only = diagnose(b"G21 G90\nT1 M6\nG1 X10 F600\n");
    assert!(!warnings_only.is_empty());
    assert!(!has_errors(&warnings_only));
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

/// ARROW's refusals say what to change in a machinist's words: where the workspace
/// ends (from the preset, in mm and degrees), which arm; never an equation number or
/// a type's name.
#[test]
fn arrow_refusals_name_the_limit_in_words() {
    let ws = ArrowConfig::ARROW.workspace;
    // A real program written around its own zero: Y below the workspace.
    let cap = std::fs::read(concat!(
        env!("CARGO_MANIFEST_DIR"),
        "/../data/gcode/cap.ngc"
    ))
    .expect("the corpus file");
    let refused = check(&cap).expect_err("outside ARROW's workspace");
    let y_words = format!(
        "Y must stay between {:.0} and {:.0} mm",
        (ws.y0_m - ws.y_half_m) * 1e3,
        (ws.y0_m + ws.y_half_m) * 1e3
    );
    assert_eq!(
        refused.message,
        format!("the path leaves the workspace: {y_words}")
    );
    assert_eq!(refused.to_string(), format!("7:1: {}", refused.message));
    let kinds = [
        ArrowJobErrorKind::Workspace(ArrowError::OutsideWorkspace(0)),
        ArrowJobErrorKind::Workspace(ArrowError::OutsideWorkspace(2)),
        ArrowJobErrorKind::Workspace(ArrowError::OutsideWorkspace(3)),
        ArrowJobErrorKind::Workspace(ArrowError::OutsideWorkspace(4)),
        ArrowJobErrorKind::Workspace(ArrowError::OutOfReach(2)),
        ArrowJobErrorKind::Workspace(ArrowError::ArmVertical(0)),
        ArrowJobErrorKind::Workspace(ArrowError::PlateSingular),
        ArrowJobErrorKind::Workspace(ArrowError::NotConverged),
        ArrowJobErrorKind::Spline(TaskSplineError::RepeatedPoint(3)),
        ArrowJobErrorKind::Feed(FeedError::TooLong),
        ArrowJobErrorKind::Feed(FeedError::NoLength),
        ArrowJobErrorKind::Singular,
        ArrowJobErrorKind::Empty,
        ArrowJobErrorKind::TooLarge,
    ];
    let mut words = Vec::new();
    for kind in kinds {
        words.push(describe_job(kind));
    }
    for w in &words {
        assert!(
            !w.contains("eq.") && !w.contains('{') && !w.contains("Error"),
            "{w}"
        );
    }
    let z = format!("Z must stay within ±{:.0} mm", ws.z_half_m * 1e3);
    assert!(words[1].ends_with(&z), "{}", words[1]);
    let rail = format!("(±{:.0} mm of travel)", ws.q_half_m * 1e3);
    assert!(words[0].contains(&rail), "{}", words[0]);
    let b = format!("±{:.0}°", ws.theta_z_half_rad.to_degrees());
    assert!(
        words[2].contains("B") && words[2].ends_with(&b),
        "{}",
        words[2]
    );
    assert!(words[3].contains("turntable A"), "{}", words[3]);
    assert_eq!(words[4], "arm 3 cannot reach the tool there");
    assert!(
        words[5].starts_with("arm 1 reaches a singular pose"),
        "{}",
        words[5]
    );
    assert!(
        words[8].starts_with("the tool point does not move between this point"),
        "{}",
        words[8]
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

/// Distance from `p` to the polyline `line` by brute force: the nearest of `line`
/// densified to `step` (within `step`/2 of the exact distance: the nearest point of
/// the line is at most half a step from a sample).
fn sampled_distance(p: [f64; 2], line: &[[f64; 2]], step: f64) -> f64 {
    let mut best = f64::INFINITY;
    for w in line.windows(2) {
        let d = (w[1][0] - w[0][0]).hypot(w[1][1] - w[0][1]);
        let n = (d / step).ceil().max(1.0) as usize;
        for k in 0..=n {
            let t = k as f64 / n as f64;
            let q = [
                w[0][0] + t * (w[1][0] - w[0][0]),
                w[0][1] + t * (w[1][1] - w[0][1]),
            ];
            best = best.min((p[0] - q[0]).hypot(p[1] - q[1]));
        }
    }
    best
}

/// `segment_distance` against the segment sampled every 1e-4 (of segments of a few
/// units: within 5e-5), for points beside, beyond either end and on the segment, and
/// for a segment of no length (the distance to its point).
#[test]
fn segment_distance_is_the_nearest_point_of_the_segment() {
    use kerf_host::plan::segment_distance;
    let step = 1e-4;
    let segments = [
        ([0.0, 0.0], [3.0, 0.0]),
        ([1.0, -2.0], [-1.5, 2.5]),
        ([2.0, 2.0], [2.0, 2.0]),
    ];
    let points = [
        [1.0, 1.0],
        [-2.0, 0.5],
        [4.0, -1.0],
        [0.2, 0.3],
        [2.0, 2.0],
        [-0.25, 0.25],
    ];
    for (a, b) in segments {
        for p in points {
            let want = sampled_distance(p, &[a, b], step);
            let got = segment_distance(p, a, b);
            assert!(
                (got - want).abs() <= step / 2.0,
                "{p:?} to {a:?}-{b:?}: {got} {want}"
            );
        }
    }
}

/// `deviation` against the brute force above over a square's outline: a point
/// beside the missing fourth side is far from the open polyline and near the closed
/// one; the largest of the points' distances is taken; nothing to stray from is
/// infinitely far.
#[test]
fn deviation_is_the_farthest_point_from_the_polyline() {
    use kerf_host::plan::deviation;
    let step = 1e-4;
    let square = [[0.0, 0.0], [1.0, 0.0], [1.0, 1.0], [0.0, 1.0]];
    let closed = [square.as_slice(), &square[..1]].concat();
    let points = [[0.5, 0.1], [-0.2, 0.5], [0.5, 0.5], [1.3, 1.4]];
    for (b_closed, line) in [(false, square.to_vec()), (true, closed)] {
        let want = points
            .iter()
            .map(|&p| sampled_distance(p, &line, step))
            .fold(0.0, f64::max);
        let got = deviation(&points, &square, b_closed);
        assert!(
            (got - want).abs() <= step / 2.0,
            "closed {b_closed}: {got} {want}"
        );
    }
    // Beside the open side: 0.2 from the closing side, 0.54 from the open polyline's
    // ends.
    assert!(deviation(&[[-0.2, 0.5]], &square, true) < deviation(&[[-0.2, 0.5]], &square, false));
    assert_eq!(deviation(&points, &[], false), f64::INFINITY);
}
