//! `kerf gcode FILE --machine keops-slave`: a laser program as the parts of a Keops
//! slave job ([`kerf_host::laser`]).

use crate::report::{say, Report};
use crate::{prepare, Failure};
use kerf_host::laser;
use kerf_host::output::io_words;
use kerf_host::plan::PlanConfig;
use std::io::Write;
use std::path::Path;

/// Reads the laser program `file`, reports its parts and writes them to `out`.
pub fn run(
    file: &Path,
    out: Option<&Path>,
    centre: bool,
    report: &mut Report,
) -> Result<(), Failure> {
    let name = file.display().to_string();
    let out = prepare(out, "job file")?;
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
    let parts = laser::parts(&program, &PlanConfig::default(), centre)
        .map_err(|e| Failure::Input(format!("{name}: {e}")))?;
    say!(report, "{name}: {} parts for keops-slave", parts.len());
    for note in &program.notes {
        say!(report, "note       {note}");
    }
    for (k, p) in parts.iter().enumerate() {
        let start = p.run.path_mm.first().copied().unwrap_or([0.0; 2]);
        say!(
            report,
            "part {:>3}   lines {}-{}, {}, starts at ({:.2}, {:.2}) mm, the fit within {:.3} mm of the program",
            k + 1,
            p.run.lines[0],
            p.run.lines[1],
            if p.run.closed { "closed (EFD)" } else { "open (spline)" },
            start[0],
            start[1],
            p.deviation_mm
        );
    }
    if let Some(out) = &out {
        let bytes =
            laser::to_bytes(&parts).map_err(|e| Failure::Input(format!("{}: {e}", out.shown())))?;
        out.write_bytes(&bytes)?;
        say!(
            report,
            "wrote {} ({} parts, {} bytes)",
            out.shown(),
            parts.len(),
            bytes.len()
        );
    }
    Ok(())
}
