//! Raw samples on the remote link: every link sample in its own frame, uncoded, with
//! no block to fill (`MasterLink::with_raw_samples`, `SlaveLink::with_raw_samples`). T
//! 5.3.1's delay-free law runs this way, as the baseline the SDCT blocks' latency (a
//! block of 16 samples at 1 kHz waits 16 ms for its last sample) is measured against.
//!
//! | frame | bytes |
//! |---|---|
//! | command | session u16, tick u32, flags u8 (bit 0: beam on), ẍ, ÿ, z̈ f32 (m/s²), CRC-32 |
//! | report | echo tick u32, session u16, flags u8 (bit 0: the echo is valid), x, y, z f32 (m), CRC-32 |
//!
//! All little-endian; the CRC-32 ([`crc32`], the stream frames' own) covers every byte
//! before it, so one flipped bit refuses the frame. 23 bytes a sample each way: at
//! 1 kHz, 23 kB/s, four times the SDCT stream's 5.8 kB/s.

use super::RemoteCommand;
use crate::codec::link::crc32;

/// Bytes of a raw command frame, and of a raw report frame.
pub const FRAME_LEN: usize = 23;

/// Bytes before the three values.
const HEAD: usize = 7;

fn f32_at(bytes: &[u8; FRAME_LEN], at: usize) -> f32 {
    let mut b = [0u8; 4];
    if let Some(s) = bytes.get(at..at + 4) {
        b.copy_from_slice(s);
    }
    f32::from_le_bytes(b)
}

/// A frame of `head` (the first seven bytes) and `values`, with its CRC.
fn frame(head: [u8; HEAD], values: [f32; 3]) -> [u8; FRAME_LEN] {
    let mut out = [0u8; FRAME_LEN];
    let (body, crc) = out.split_at_mut(FRAME_LEN - 4);
    let (h, v) = body.split_at_mut(HEAD);
    h.copy_from_slice(&head);
    for (chunk, value) in v.chunks_exact_mut(4).zip(values) {
        chunk.copy_from_slice(&value.to_le_bytes());
    }
    crc.copy_from_slice(&crc32(body).to_le_bytes());
    out
}

/// The frame's bytes when its length and CRC are right.
fn checked(bytes: &[u8]) -> Option<[u8; FRAME_LEN]> {
    let frame: [u8; FRAME_LEN] = bytes.try_into().ok()?;
    let (body, crc) = frame.split_last_chunk::<4>()?;
    (crc32(body) == u32::from_le_bytes(*crc)).then_some(frame)
}

fn values(frame: &[u8; FRAME_LEN]) -> [f32; 3] {
    [0, 1, 2].map(|k| f32_at(frame, HEAD + 4 * k))
}

/// The command frame of master tick `tick` in power-up `session`.
pub fn command_frame(session: u16, tick: u32, command: &RemoteCommand) -> [u8; FRAME_LEN] {
    let mut head = [0u8; HEAD];
    head[..2].copy_from_slice(&session.to_le_bytes());
    head[2..6].copy_from_slice(&tick.to_le_bytes());
    head[6] = u8::from(command.laser_on);
    frame(head, command.acceleration_m_s2)
}

/// (session, tick, command) of a command frame; `None` for a frame of another length
/// or whose CRC fails.
pub fn parse_command(bytes: &[u8]) -> Option<(u16, u32, RemoteCommand)> {
    let f = checked(bytes)?;
    Some((
        u16::from_le_bytes([f[0], f[1]]),
        u32::from_le_bytes([f[2], f[3], f[4], f[5]]),
        RemoteCommand {
            acceleration_m_s2: values(&f),
            laser_on: f[6] & 1 == 1,
        },
    ))
}

/// The report frame of the slave at `position_m`, executing the command of `echo`
/// (`None`: none of `session` has played).
pub fn report_frame(echo: Option<u32>, session: u16, position_m: [f32; 3]) -> [u8; FRAME_LEN] {
    let mut head = [0u8; HEAD];
    head[..4].copy_from_slice(&echo.unwrap_or(0).to_le_bytes());
    head[4..6].copy_from_slice(&session.to_le_bytes());
    head[6] = u8::from(echo.is_some());
    frame(head, position_m)
}

/// (echo, session, position) of a report frame; `None` for a frame of another length
/// or whose CRC fails.
pub fn parse_report(bytes: &[u8]) -> Option<(Option<u32>, u16, [f32; 3])> {
    let f = checked(bytes)?;
    let echo = u32::from_le_bytes([f[0], f[1], f[2], f[3]]);
    Some((
        (f[6] & 1 == 1).then_some(echo),
        u16::from_le_bytes([f[4], f[5]]),
        values(&f),
    ))
}

#[cfg(test)]
mod tests {
    use super::*;

    /// Both frames come back as they went out, field by field (values bit for bit),
    /// and every single flipped bit, a cut or a longer frame is refused.
    #[test]
    fn frames_round_trip_and_any_damage_is_refused() {
        let command = RemoteCommand {
            acceleration_m_s2: [0.125, -3.5e-3, 19.75],
            laser_on: true,
        };
        let c = command_frame(0xBEEF, 0xDEAD_BEEF, &command);
        assert_eq!(parse_command(&c), Some((0xBEEF, 0xDEAD_BEEF, command)));
        let r = report_frame(Some(77), 9, [0.02, -0.001, 0.06]);
        assert_eq!(parse_report(&r), Some((Some(77), 9, [0.02, -0.001, 0.06])));
        assert_eq!(
            parse_report(&report_frame(None, 9, [0.0; 3])).unwrap().0,
            None
        );
        for bit in 0..8 * FRAME_LEN {
            let (mut c2, mut r2) = (c, r);
            c2[bit / 8] ^= 1 << (bit % 8);
            r2[bit / 8] ^= 1 << (bit % 8);
            assert_eq!(parse_command(&c2), None, "bit {bit}");
            assert_eq!(parse_report(&r2), None, "bit {bit}");
        }
        assert_eq!(parse_command(&c[..FRAME_LEN - 1]), None);
        let mut longer = [0u8; FRAME_LEN + 1];
        longer[..FRAME_LEN].copy_from_slice(&c);
        assert_eq!(parse_command(&longer), None);
    }
}
