//! The command's report on standard output.
//!
//! Standard output may be a pipe whose reader has gone (`kerf plan … | head -1`):
//! `println!` would then panic. A line that cannot be written ends the report, not the
//! command: the job, the picture and the telemetry are still written and a run goes
//! on to its end, and the command then exits with 1 and says that the report was cut
//! short.

use kerf_host::output::io_words;
use std::fmt;
use std::io::{self, Write};

/// Standard output, until a write fails.
pub struct Report {
    lost: Option<io::Error>,
}

impl Report {
    /// The report on this process's standard output.
    pub fn new() -> Self {
        Report { lost: None }
    }

    /// Writes one line; after a failed write, nothing.
    pub fn line(&mut self, args: fmt::Arguments<'_>) {
        self.with(|w| writeln!(w, "{args}"));
    }

    /// Writes what `fill` writes; after a failed write, nothing.
    pub fn with(&mut self, fill: impl FnOnce(&mut dyn Write) -> io::Result<()>) {
        if self.lost.is_none() {
            let mut out = io::stdout().lock();
            if let Err(e) = fill(&mut out).and_then(|()| out.flush()) {
                self.lost = Some(e);
            }
        }
    }

    /// Why the report was cut short, if it was.
    pub fn lost(&self) -> Option<String> {
        self.lost.as_ref().map(|e| {
            format!(
                "the report on standard output was cut short: {} (everything else was done and written)",
                io_words(e)
            )
        })
    }
}

/// `say!(report, "format", args…)`: one line of the report.
macro_rules! say {
    ($report:expr, $($arg:tt)*) => {
        $report.line(format_args!($($arg)*))
    };
}
pub(crate) use say;
