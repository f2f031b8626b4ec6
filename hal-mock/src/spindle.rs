//! The simulated spindle converter (G 3.1.3, app. B): it speaks the converter's
//! binary protocol (`kerf::codec::spindle`), so the cell's firmware talks to it as to
//! the real one. The spindle follows the set speed with a first-order lag once
//! started; load and current follow the cutting torque it is given.

/// The converter and spindle.
#[derive(Clone, Debug, PartialEq)]
pub struct SimSpindle {
    set_rpm: f64,
    running: bool,
    rpm: f64,
    /// Cutting torque at the tool, N·m (from the process).
    torque_n_m: f64,
    /// Spindle time constant, s.
    tau_s: f64,
    /// Torque at 100 % load, N·m.
    rated_torque_n_m: f64,
    /// Current per N·m plus the no-load current, A.
    amps_per_n_m: f64,
    idle_a: f64,
    /// Answers requests (false: a dead converter, no reply).
    pub answering: bool,
}

impl SimSpindle {
    /// G's class of spindle (G app. A: a 4 kW high-speed spindle): 0.5 s to
    /// reach speed, 1.5 N·m rated torque, 8 A per N·m over 0.8 A idle.
    pub fn new() -> Self {
        Self {
            set_rpm: 0.0,
            running: false,
            rpm: 0.0,
            torque_n_m: 0.0,
            tau_s: 0.5,
            rated_torque_n_m: 1.5,
            amps_per_n_m: 8.0,
            idle_a: 0.8,
            answering: true,
        }
    }

    /// Advances `dt_s` with the process's cutting torque.
    pub fn advance(&mut self, dt_s: f64, torque_n_m: f64) {
        let target = if self.running { self.set_rpm } else { 0.0 };
        self.rpm += (target - self.rpm) * (1.0 - libm::exp(-dt_s / self.tau_s));
        self.torque_n_m = torque_n_m;
    }

    /// The spindle's speed, rpm.
    pub fn rpm(&self) -> f64 {
        self.rpm
    }

    /// Takes a request's bytes; returns the reply's three bytes (or none, for a dead
    /// converter or bytes it does not know).
    pub fn transact(&mut self, request: &[u8]) -> Option<[u8; 3]> {
        if !self.answering {
            return None;
        }
        let value = |v: f64| {
            let code = libm::round(v).clamp(0.0, 65_535.0) as u16;
            let [lo, hi] = code.to_le_bytes();
            Some([request.first().copied().unwrap_or(0), lo, hi])
        };
        match request {
            [0x01, lo, hi] => {
                self.set_rpm = f64::from(u16::from_le_bytes([*lo, *hi])) * 10.0;
                Some([0x01, *lo, *hi])
            }
            [0x24] => {
                self.running = true;
                Some([0x24, 0, 0])
            }
            [0x41] => value(self.set_rpm / 10.0),
            [0x42] | [0x43] => value(self.rpm / 10.0),
            [0x0C, 0xA4, 0x08] => value(self.torque_n_m / self.rated_torque_n_m * 1000.0),
            [0x0C, 0xB6, 0x0B] => {
                value((self.idle_a + self.amps_per_n_m * self.torque_n_m.abs()) * 100.0)
            }
            _ => None,
        }
    }
}

impl Default for SimSpindle {
    fn default() -> Self {
        Self::new()
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use kerf::codec::spindle::{SpindleError, SpindleReading, SpindleRequest};

    fn ask(s: &mut SimSpindle, r: SpindleRequest) -> Result<SpindleReading, SpindleError> {
        let mut buf = [0u8; 3];
        let bytes = r.encode(&mut buf)?;
        let reply = s.transact(bytes);
        r.decode(reply.as_ref().map(|b| &b[..]).unwrap_or(&[]))
    }

    /// A conversation as G's controller has it: set 25,000 rpm, start, read the
    /// speed as it comes up, the load and current under a cutting torque; a dead
    /// converter is a typed error.
    #[test]
    fn conversation_through_the_protocol() {
        let mut s = SimSpindle::new();
        assert_eq!(
            ask(&mut s, SpindleRequest::SetSpeed { rpm: 25_000 }),
            Ok(SpindleReading::Done)
        );
        assert_eq!(
            ask(&mut s, SpindleRequest::DutyRpm),
            Ok(SpindleReading::Rpm(25_000))
        );
        assert_eq!(
            ask(&mut s, SpindleRequest::SpindleRpm),
            Ok(SpindleReading::Rpm(0))
        );
        assert_eq!(ask(&mut s, SpindleRequest::Start), Ok(SpindleReading::Done));
        for _ in 0..250 {
            s.advance(0.01, 0.0);
        }
        // After 2.5 s (5 time constants): within 1 % of the set speed, in steps of 10.
        match ask(&mut s, SpindleRequest::SpindleRpm) {
            Ok(SpindleReading::Rpm(rpm)) => assert!((24_750..=25_000).contains(&rpm), "{rpm}"),
            other => panic!("{other:?}"),
        }
        s.advance(0.01, 0.75);
        assert_eq!(
            ask(&mut s, SpindleRequest::LoadPercent),
            Ok(SpindleReading::LoadPercent(50.0))
        );
        // 0.8 A + 8 A/(N·m) × 0.75 N·m = 6.8 A: code 680, times 0.01 in f32.
        match ask(&mut s, SpindleRequest::Current) {
            Ok(SpindleReading::CurrentA(a)) => assert!((a - 6.8).abs() < 1e-5, "{a}"),
            other => panic!("{other:?}"),
        }
        s.answering = false;
        assert_eq!(
            ask(&mut s, SpindleRequest::SpindleRpm),
            Err(SpindleError::ShortReply { got: 0 })
        );
    }
}
