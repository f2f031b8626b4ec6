//! `kerf gcode FILE --machine keops-slave`: a laser program as the parts of a Keops
//! slave job ([`kerf_host::laser`]).

use crate::report::{say, Report};
use crate::{prepare, Failure, GcodeArgs};
use kerf_host::kerf_offset::KerfSide;
use kerf_host::laser::{self, Beam, Corners};
use kerf_host::output::io_words;
use kerf_host::plan::PlanConfig;
use std::io::Write;

/// Reads the laser program of `args` (`--machine keops-slave`), reports its parts
/// (their settings from the program, `S` of `--s-max` as the source's full power, the
/// kerf and lead-in of its closed runs, and the cut settings over them), checks them
/// as the slave would and writes them to `--out`.
pub fn run(args: &GcodeArgs, report: &mut Report) -> Result<(), Failure> {
    let (file, centre, s_max, corners, cut) =
        (&args.file, args.centre, args.s_max, args.corners, &args.cut);
    let name = file.display().to_string();
    if !(s_max.is_finite() && s_max > 0.0) {
        return Err(Failure::Input(format!(
            "--s-max {s_max}: the S value of full power, above zero"
        )));
    }
    let kerf = &args.kerf;
    for (option, mm) in [
        ("--kerf-mm", kerf.kerf_mm),
        ("--lead-in-mm", kerf.lead_in_mm),
    ] {
        if !(mm.is_finite() && mm >= 0.0) {
            return Err(Failure::Input(format!(
                "{option} {mm}: a length of 0 or more, mm"
            )));
        }
    }
    if kerf.lead_in_mm > 0.0 && cut.settings()?.passes.is_some_and(|p| p > 1) {
        return Err(Failure::Input(
            "--passes with --lead-in-mm: a contour with its lead-in is cut once (the lead-in \
             would be cut again on every pass)"
                .into(),
        ));
    }
    let config = PlanConfig {
        kerf_mm: kerf.kerf_mm,
        kerf_side: kerf.kerf_side,
        lead_in_mm: kerf.lead_in_mm,
        ..PlanConfig::default()
    };
    let beam = Beam::keops(s_max);
    let out = prepare(args.out.as_deref(), "job file")?;
    let text = std::fs::read(file).map_err(|e| {
        Failure::Input(format!("{name}: cannot read the program: {}", io_words(&e)))
    })?;
    let program = laser::read(&text);
    let listed: Vec<String> = program
        .diagnostics
        .iter()
        .map(|d| format!("{name}:{d}"))
        .collect();
    if laser::has_errors(&program) {
        return Err(Failure::Input(listed.join("\n")));
    }
    for line in &listed {
        // Standard error may be closed: the report still follows.
        let _ = writeln!(std::io::stderr(), "{line}");
    }
    let parts = laser::parts(&program, &config, centre, &beam, corners)
        .map_err(|e| Failure::Input(format!("{name}: {e}")))?;
    match parts.len() {
        1 => say!(report, "{name}: 1 part for keops-slave"),
        n => say!(report, "{name}: {n} parts for keops-slave"),
    }
    let (lo, hi) = kerf_host::plan::bounds(parts.iter().flat_map(|p| p.run.path_mm.iter()));
    let holds_origin = lo[0] <= 0.0 && hi[0] >= 0.0 && lo[1] <= 0.0 && hi[1] >= 0.0;
    if !(centre || holds_origin) {
        say!(
            report,
            "note       the cuts span X {:.1} to {:.1} mm, Y {:.1} to {:.1} mm, away from the \
             workspace's centre (0, 0): --centre moves them there (a laser bed's origin is \
             its corner)",
            lo[0],
            hi[0],
            lo[1],
            hi[1]
        );
    }
    let (outline, hole) = match kerf.kerf_side {
        KerfSide::Outside => ("outside", "inside"),
        KerfSide::Inside => ("inside", "outside"),
    };
    if kerf.kerf_mm > 0.0 {
        say!(
            report,
            "kerf       {:.3} mm wide: each closed run {:.3} mm {outline} its drawn outline \
             ({hole} a hole), corners kept sharp",
            kerf.kerf_mm,
            kerf.kerf_mm / 2.0
        );
    }
    if kerf.lead_in_mm > 0.0 {
        say!(
            report,
            "lead-in    {:.2} mm straight into each closed run's start from {outline} an \
             outline ({hole} a hole): the part's first move",
            kerf.lead_in_mm
        );
    }
    if args.kerf.is_set() && program.runs.iter().any(|r| !r.closed) {
        say!(
            report,
            "note       the kerf and lead-in are for closed runs: the open ones are cut as drawn"
        );
    }
    for note in &program.notes {
        say!(report, "note       {note}");
    }
    let feed_changes = |r: &laser::LaserRun| r.feeds_m_s.iter().skip(1).any(|&f| f != r.feed_m_s);
    if corners == Corners::Fit && program.runs.iter().any(feed_changes) {
        say!(
            report,
            "note       F changes within a part: a fitted part is cut at its first move's feed"
        );
    }
    if corners == Corners::Fit && program.runs.iter().any(|r| r.joined) {
        say!(
            report,
            "note       S or M3/M4 changes within a run: fitted, each power is a part of its own, with a stop between"
        );
    }
    if program.runs.iter().any(|r| r.s > s_max) {
        say!(
            report,
            "note       S passes --s-max {s_max} in places: full power there"
        );
    }
    for (k, p) in parts.iter().enumerate() {
        let start = p.run.path_mm.first().copied().unwrap_or([0.0; 2]);
        let shape = match (&p.fit, p.run.closed) {
            (None, _) => {
                let ahead = usize::from(p.settings.continuity.lookahead_points);
                let moves = p.run.path_mm.len().saturating_sub(1 + ahead);
                match (p.settings.continuity.continues, ahead) {
                    (false, 0) => format!("{moves} moves, sharp corners"),
                    (true, 0) => format!("{moves} moves, sharp corners, on from the part before"),
                    (false, _) => format!("{moves} moves, sharp corners, {ahead} ahead"),
                    (true, _) => format!(
                        "{moves} moves, sharp corners, on from the part before, {ahead} ahead"
                    ),
                }
            }
            (Some(_), closed) => format!(
                "{}, the fit within {:.3} mm of the program",
                if closed {
                    "closed (EFD)"
                } else {
                    "open (spline)"
                },
                p.deviation_mm
            ),
        };
        say!(
            report,
            "part {:>3}   lines {}-{}, {shape}, starts at ({:.2}, {:.2}) mm; {}",
            k + 1,
            p.run.lines[0],
            p.run.lines[1],
            start[0],
            start[1],
            crate::cli_cut::settings_words(&p.settings)
        );
    }
    let bytes = laser::to_bytes(&parts).map_err(|e| Failure::Input(format!("{name}: {e}")))?;
    crate::cli_cut::write_program(&name, &bytes, cut, out.as_ref(), report)
}
