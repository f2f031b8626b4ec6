//! `kerf check JOB`: the job checked on the host as the machine checks it at load
//! ([`kerf_host::check`]), with its duration and a preview.

use crate::report::{say, Report};
use crate::{prepare, Failure};
use kerf_host::check::{kind_words, Machine};
use kerf_host::output::io_words;
use kerf_host::preview;
use std::path::PathBuf;

#[derive(Debug, clap::Args)]
pub struct CheckArgs {
    /// The job file (`kerf plan --out`, `kerf gcode --out`).
    job: PathBuf,
    /// The machine to check for [default: the one that takes the job's kind].
    #[arg(long, value_enum)]
    machine: Option<Machine>,
    /// Draw the workspace, the travel, the cut and its start into this SVG file.
    #[arg(long, value_name = "SVG")]
    preview: Option<PathBuf>,
    #[command(flatten)]
    cut: crate::cli_cut::CutArgs,
}

/// `kerf check JOB`.
pub fn run(args: &CheckArgs, report: &mut Report) -> Result<(), Failure> {
    let name = args.job.display().to_string();
    let svg = prepare(args.preview.as_deref(), "preview")?;
    let bytes = std::fs::read(&args.job).map_err(|e| {
        Failure::Input(format!(
            "{name}: cannot read the job file: {}",
            io_words(&e)
        ))
    })?;
    let (bytes, checked) = crate::cli_cut::settle(&name, &bytes, &args.cut, args.machine)?;
    match checked.parts {
        1 => say!(
            report,
            "job        {name}: {} job, {} bytes",
            kind_words(checked.kind),
            bytes.len()
        ),
        n => say!(
            report,
            "job        {name}: {n} parts ({}), {} bytes",
            kind_words(checked.kind),
            bytes.len()
        ),
    }
    say!(
        report,
        "machine    {} accepts it (its own load check, with the presets it is flashed with)",
        checked.machine.name()
    );
    say!(
        report,
        "duration   about {:.2} s from start to end (approaches included); cut {:.1} mm",
        checked.duration_s,
        checked.cut_length_m * 1e3
    );
    crate::cli_cut::report_settings(&bytes, report);
    if let Some(svg) = &svg {
        let title = args
            .job
            .file_name()
            .map_or(name.clone(), |n| n.to_string_lossy().into_owned());
        match preview::svg(&title, &checked)
            .map_err(|e| Failure::Output(format!("{}: {e}", svg.shown())))?
        {
            Some(text) => {
                svg.write_bytes(text.as_bytes())?;
                say!(report, "wrote      {}", svg.shown());
            }
            None => say!(
                report,
                "note       {} has no preview yet; {} not written",
                checked.machine.name(),
                svg.shown()
            ),
        }
    }
    Ok(())
}
