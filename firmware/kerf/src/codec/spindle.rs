//! The grinding spindle's converter protocol (docs/codec.md §31, G app. B): binary
//! frames over RS-232 at 115200 8N1, every request answered by three bytes.
//!
//! Requests (as G's controller sends them):
//!
//! | request | bytes | reply value (b3 · 256 + b2) |
//! |---|---|---|
//! | set speed | 0x01, lo, hi of rpm/10 | — |
//! | start | 0x24 | — |
//! | duty rpm | 0x41 | × 10 rpm |
//! | converter's actual rpm | 0x42 | × 10 rpm |
//! | spindle rpm | 0x43 | × 10 rpm |
//! | load | 0x0C 0xA4 0x08 | × 0.1 % |
//! | current | 0x0C 0xB6 0x0B | × 0.01 A |
//!
//! The value sits in the reply's second and third bytes, low byte first (G
//! reads `strcat(hex(b3), hex(b2))`); the first byte is not used by G and is
//! not checked here. A converter that does not answer leaves the caller with fewer
//! than three bytes when its timeout expires: [`SpindleError::ShortReply`].

/// A request to the converter.
#[derive(Copy, Clone, Debug, PartialEq, Eq)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
pub enum SpindleRequest {
    /// Set the speed, rpm (sent as rpm/10, 16 bits: up to 655,350 rpm in steps of 10).
    SetSpeed {
        /// Spindle speed, rpm.
        rpm: u32,
    },
    /// Start the spindle at the set speed.
    Start,
    /// Read the duty (commanded) speed.
    DutyRpm,
    /// Read the converter's output speed.
    ActualRpm,
    /// Read the spindle's measured speed.
    SpindleRpm,
    /// Read the load, percent.
    LoadPercent,
    /// Read the motor current, A.
    Current,
}

/// What a reply says.
#[derive(Copy, Clone, Debug, PartialEq)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
pub enum SpindleReading {
    /// A set-speed or start was answered.
    Done,
    /// A speed, rpm.
    Rpm(u32),
    /// The load, percent.
    LoadPercent(f32),
    /// The current, A.
    CurrentA(f32),
}

/// Why a request or a reply was refused.
#[derive(Copy, Clone, Debug, PartialEq, Eq)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
pub enum SpindleError {
    /// A set speed beyond the 16-bit field (rpm/10 > 65,535).
    SpeedOutOfRange,
    /// Fewer than three reply bytes (the converter did not answer in time).
    ShortReply {
        /// Bytes received.
        got: u8,
    },
    /// More than three bytes where one reply was expected (a framing slip: resync
    /// by flushing the input).
    LongReply,
}

/// Bytes of a reply.
pub const REPLY_BYTES: usize = 3;

impl SpindleRequest {
    /// The request's bytes, written into `out`; returns the used part.
    pub fn encode<'a>(&self, out: &'a mut [u8; 3]) -> Result<&'a [u8], SpindleError> {
        let len = match *self {
            Self::SetSpeed { rpm } => {
                let tenths = u16::try_from(rpm / 10).map_err(|_| SpindleError::SpeedOutOfRange)?;
                let [lo, hi] = tenths.to_le_bytes();
                *out = [0x01, lo, hi];
                3
            }
            Self::Start => {
                out[0] = 0x24;
                1
            }
            Self::DutyRpm => {
                out[0] = 0x41;
                1
            }
            Self::ActualRpm => {
                out[0] = 0x42;
                1
            }
            Self::SpindleRpm => {
                out[0] = 0x43;
                1
            }
            Self::LoadPercent => {
                *out = [0x0C, 0xA4, 0x08];
                3
            }
            Self::Current => {
                *out = [0x0C, 0xB6, 0x0B];
                3
            }
        };
        Ok(out.get(..len).unwrap_or(&[]))
    }

    /// The reading a reply to this request carries.
    pub fn decode(&self, reply: &[u8]) -> Result<SpindleReading, SpindleError> {
        let [_, lo, hi] = match reply {
            [a, b, c] => [*a, *b, *c],
            r if r.len() > REPLY_BYTES => return Err(SpindleError::LongReply),
            r => return Err(SpindleError::ShortReply { got: r.len() as u8 }),
        };
        let value = u16::from_le_bytes([lo, hi]);
        Ok(match self {
            Self::SetSpeed { .. } | Self::Start => SpindleReading::Done,
            Self::DutyRpm | Self::ActualRpm | Self::SpindleRpm => {
                SpindleReading::Rpm(u32::from(value) * 10)
            }
            Self::LoadPercent => SpindleReading::LoadPercent(f32::from(value) * 0.1),
            Self::Current => SpindleReading::CurrentA(f32::from(value) * 0.01),
        })
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// G's set-speed frame for 25,000 rpm, built G's way (hex digits of
    /// speed/10 = 0x9C4: low byte "C4", high byte "09").
    #[test]
    fn frames_match_the_seeds() {
        let mut buf = [0u8; 3];
        assert_eq!(
            SpindleRequest::SetSpeed { rpm: 25_000 }
                .encode(&mut buf)
                .unwrap(),
            &[0x01, 0xC4, 0x09]
        );
        assert_eq!(SpindleRequest::Start.encode(&mut buf).unwrap(), &[0x24]);
        assert_eq!(
            SpindleRequest::SpindleRpm.encode(&mut buf).unwrap(),
            &[0x43]
        );
        assert_eq!(
            SpindleRequest::LoadPercent.encode(&mut buf).unwrap(),
            &[0x0C, 0xA4, 0x08]
        );
        assert_eq!(
            SpindleRequest::Current.encode(&mut buf).unwrap(),
            &[0x0C, 0xB6, 0x0B]
        );
        assert_eq!(
            SpindleRequest::SetSpeed { rpm: 655_360 }.encode(&mut buf),
            Err(SpindleError::SpeedOutOfRange)
        );
    }

    /// Replies decode with G's scales; short, missing and long replies are
    /// typed errors; every 3-byte reply decodes (exhaustively over the value bytes).
    #[test]
    fn replies_decode_and_bad_ones_are_refused() {
        assert_eq!(
            SpindleRequest::SpindleRpm.decode(&[0x43, 0xC4, 0x09]),
            Ok(SpindleReading::Rpm(25_000))
        );
        assert_eq!(
            SpindleRequest::LoadPercent.decode(&[0, 0x77, 0x01]),
            Ok(SpindleReading::LoadPercent(37.5))
        );
        assert_eq!(
            SpindleRequest::Current.decode(&[0, 0xF4, 0x01]),
            Ok(SpindleReading::CurrentA(5.0))
        );
        assert_eq!(
            SpindleRequest::Start.decode(&[0, 0, 0]),
            Ok(SpindleReading::Done)
        );
        assert_eq!(
            SpindleRequest::ActualRpm.decode(&[]),
            Err(SpindleError::ShortReply { got: 0 })
        );
        assert_eq!(
            SpindleRequest::ActualRpm.decode(&[1, 2]),
            Err(SpindleError::ShortReply { got: 2 })
        );
        assert_eq!(
            SpindleRequest::ActualRpm.decode(&[1, 2, 3, 4]),
            Err(SpindleError::LongReply)
        );
        for lo in 0..=255u8 {
            for hi in 0..=255u8 {
                let expected = (u32::from(hi) * 256 + u32::from(lo)) * 10;
                assert_eq!(
                    SpindleRequest::DutyRpm.decode(&[0x41, lo, hi]),
                    Ok(SpindleReading::Rpm(expected))
                );
                if let Ok(SpindleReading::LoadPercent(p)) =
                    SpindleRequest::LoadPercent.decode(&[0, lo, hi])
                {
                    assert!(p.is_finite() && p >= 0.0);
                }
            }
        }
    }
}
