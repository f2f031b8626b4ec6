//! Host-only (`std` feature): recording a scenario run and writing it as CSV for
//! plotting or comparing runs outside the test suite.

use crate::scenario::Period;
use std::io::{self, Write};
use std::vec::Vec;

/// Periods of one run, in order.
#[derive(Clone, Debug, Default)]
pub struct Recorder {
    periods: Vec<Period>,
}

impl Recorder {
    /// An empty recording.
    pub fn new() -> Self {
        Self::default()
    }

    /// Appends one period.
    pub fn push(&mut self, period: Period) {
        self.periods.push(period);
    }

    /// The recorded periods.
    pub fn periods(&self) -> &[Period] {
        &self.periods
    }

    /// Writes a header and one line per period: time (s), error (m), force (N),
    /// disturbance estimate (N), velocity estimate (m/s), measured position (m), the
    /// three raw Hall counts and the fault (empty when healthy).
    pub fn write_csv(&self, mut out: impl Write) -> io::Result<()> {
        writeln!(
            out,
            "t_s,error_m,force_n,disturbance_n,velocity_m_s,position_m,u1,u2,u3,fault"
        )?;
        for p in &self.periods {
            let fault = p.fault.map(|f| std::format!("{f:?}")).unwrap_or_default();
            writeln!(
                out,
                "{},{:e},{},{},{},{},{},{},{},{}",
                p.t_s,
                p.error_m,
                p.force_n,
                p.disturbance_n,
                p.velocity_m_s,
                p.position_m,
                p.hall_counts[0],
                p.hall_counts[1],
                p.hall_counts[2],
                fault
            )?;
        }
        Ok(())
    }
}
