//! Where a device's reply ends on a serial line, so that a request/reply exchange
//! (`kerf::hal::Transact`) returns as soon as the reply is whole instead of waiting
//! out its timeout.
//!
//! - A GCS controller (the hexapod's) answers in lines; a multi-line answer ends
//!   every line but the last with a space before the line feed, so the reply is whole
//!   at a line feed not preceded by a space.
//! - The spindle's converter answers with a fixed number of bytes (the length of the
//!   reply buffer the exchange gives).

/// How a reply ends.
#[derive(Copy, Clone, Debug, PartialEq, Eq)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
pub enum ReplyEnd {
    /// At a line feed not preceded by a space (GCS).
    Line,
    /// After as many bytes as the reply buffer holds.
    Fixed,
}

impl ReplyEnd {
    /// Whether `received` (the bytes so far) is a whole reply for a buffer of
    /// `capacity` bytes. A full buffer always ends the reply.
    pub fn complete(self, received: &[u8], capacity: usize) -> bool {
        if received.len() >= capacity {
            return true;
        }
        match self {
            Self::Fixed => false,
            Self::Line => match received {
                [.., before, b'\n'] => *before != b' ',
                [b'\n'] => true,
                _ => false,
            },
        }
    }
}

#[cfg(test)]
mod tests {
    use super::ReplyEnd;

    /// GCS: one line, a multi-line answer (continuation lines end in " \n"), and
    /// partial input.
    #[test]
    fn a_gcs_reply_ends_at_its_last_line_feed() {
        let end = ReplyEnd::Line;
        assert!(end.complete(b"0\n", 256));
        assert!(end.complete(b"\n", 256));
        assert!(!end.complete(b"X=1.000000 \n", 256));
        assert!(end.complete(b"X=1.000000 \nY=2.000000\n", 256));
        assert!(!end.complete(b"X=1.0000", 256));
        assert!(!end.complete(b"", 256));
        // A full buffer ends it whatever the bytes.
        assert!(end.complete(b"X=1", 3));
    }

    /// The spindle: three bytes, not fewer.
    #[test]
    fn a_fixed_reply_ends_at_its_length() {
        let end = ReplyEnd::Fixed;
        assert!(!end.complete(b"\x01\x02", 3));
        assert!(end.complete(b"\x01\x02\x03", 3));
        assert!(!end.complete(b"\n", 3));
    }
}
