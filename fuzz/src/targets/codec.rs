//! The device and packet codecs: SDCT packets, the spindle converter's replies, G-code
//! text and the hexapod's GCS replies. Seeds come from the codecs' own encoders and
//! from `hal-mock`'s simulated devices.

use crate::input::Seed;
use hal_mock::hexapod::{HexapodLimits, SimHexapod};
use hal_mock::spindle::SimSpindle;
use heapless::Vec;
use kerf::codec::gcs::{
    parse_axis_names, parse_axis_values, parse_error_code, parse_identification,
    parse_motion_status, parse_ready, parse_referenced, parse_value, reply, Axis, AxisSet,
    AxisValues, Command, MAX_REPLY_LEN,
};
use kerf::codec::packet::{self, parse, PacketDecoder, MAX_SAMPLE_ABS};
use kerf::codec::sdct::{Block, SdctConfig, SdctDecoder, SdctEncoder, Selection};
use kerf::codec::spindle::{SpindleReading, SpindleRequest};
use kerf::trajectory::gcode::{self, GcodePoint, Parser};

/// The packet CRC (CRC-16/IBM-3740), recomputed independently of kerf.
const CRC16: crc::Crc<u16> = crc::Crc::<u16>::new(&crc::CRC_16_IBM_3740);

fn reconstruct<const N: usize>(packet: &packet::Packet) {
    if let (Ok(block), Ok(dec)) = (packet.to_block::<N>(), SdctDecoder::<N>::new()) {
        let mut out = [0.0f32; N];
        dec.decode(&block, &mut out);
        assert_eq!(block.m(), usize::from(packet.m));
        // Every accepted packet decodes to finite samples inside the declared range.
        assert!(
            out.iter()
                .all(|x| x.is_finite() && x.abs() <= MAX_SAMPLE_ABS),
            "{out:?}"
        );
    }
}

/// `packet_decode`: one flag byte, two bytes that seed the decoder's last sequence
/// number, then the packet. With bit 0 of the flag set the packet's last two bytes are
/// overwritten with its CRC, so that mutations reach the header and index-set checks.
/// Stateless and stateful decoding agree; an accepted packet reconstructs to finite
/// samples within `MAX_SAMPLE_ABS` at every supported N. Returns the packets accepted.
pub fn packet_decode(data: &[u8]) -> usize {
    let mut decoder = PacketDecoder::new();
    let [flags, s0, s1, rest @ ..] = data else {
        return 0;
    };
    let mut patched = [0u8; 512];
    let rest = match patched.get_mut(..rest.len()) {
        Some(buf) if flags & 1 == 1 && rest.len() >= 2 => {
            buf.copy_from_slice(rest);
            let (body, crc) = buf.split_at_mut(rest.len() - 2);
            crc.copy_from_slice(&CRC16.checksum(body).to_le_bytes());
            &*buf
        }
        _ => rest,
    };
    // Prime the sequence state with a valid empty packet, then decode the rest.
    let mut primer = [0u8; 32];
    let block = Block::<8>::from_parts(0, [0.0; 8]);
    let sequence = u16::from_le_bytes([*s0, *s1]);
    if let Ok(len) = packet::encode(&block, sequence, 0, &mut primer) {
        assert!(decoder.decode(&primer[..len]).is_ok());
    }
    let stateless = parse(rest);
    let Ok(received) = decoder.decode(rest) else {
        return 0;
    };
    assert_eq!(stateless.as_ref().ok(), Some(&received.packet));
    let p = &received.packet;
    reconstruct::<8>(p);
    reconstruct::<16>(p);
    reconstruct::<32>(p);
    reconstruct::<64>(p);
    1
}

fn sine_block<const N: usize>(m: usize, scale: f32) -> Block<N> {
    let encoder = SdctEncoder::<N>::new(&SdctConfig {
        m,
        selection: Selection::Largest,
    })
    .expect("a valid m");
    let x: [f32; N] = core::array::from_fn(|k| scale * (0.3 * k as f32).sin() + 0.1 * k as f32);
    encoder.encode(&x).expect("finite samples")
}

/// Seeds of [`packet_decode`]: packets of every N, with the sequence right after the
/// primer's, as written (flag 0) and for the CRC patch (flag 1).
pub fn packet_decode_seeds() -> std::vec::Vec<std::vec::Vec<u8>> {
    let mut packets = std::vec::Vec::new();
    let mut buf = [0u8; packet::MAX_PACKET_LEN];
    let mut add = |len: Result<usize, _>, buf: &[u8]| packets.push(buf[..len.unwrap()].to_vec());
    add(
        packet::encode(&sine_block::<8>(3, 1.0), 8, 16, &mut buf),
        &buf,
    );
    add(
        packet::encode(&sine_block::<16>(16, 1e-3), 8, 16, &mut buf),
        &buf,
    );
    add(
        packet::encode(&sine_block::<32>(5, 250.0), 8, 32, &mut buf),
        &buf,
    );
    add(
        packet::encode(&sine_block::<64>(64, 1e12), 8, 64, &mut buf),
        &buf,
    );
    packets
        .iter()
        .flat_map(|p| [0u8, 1].map(|flag| Seed::new().u8(flag).u16(7).bytes(p).0))
        .collect()
}

/// `spindle_reply`: one byte choosing the request, then the reply. Never a panic; an
/// accepted load or current is finite and not negative; only three-byte replies are
/// accepted. Returns the replies accepted.
pub fn spindle_reply(data: &[u8]) -> usize {
    let Some((&which, reply)) = data.split_first() else {
        return 0;
    };
    match spindle_request(which).decode(reply) {
        Ok(SpindleReading::LoadPercent(v)) | Ok(SpindleReading::CurrentA(v)) => {
            assert!(v.is_finite() && v >= 0.0);
            1
        }
        Ok(_) => {
            assert_eq!(reply.len(), 3);
            1
        }
        Err(_) => {
            assert_ne!(reply.len(), 3);
            0
        }
    }
}

fn spindle_request(which: u8) -> SpindleRequest {
    match which % 7 {
        0 => SpindleRequest::SetSpeed { rpm: 25_000 },
        1 => SpindleRequest::Start,
        2 => SpindleRequest::DutyRpm,
        3 => SpindleRequest::ActualRpm,
        4 => SpindleRequest::SpindleRpm,
        5 => SpindleRequest::LoadPercent,
        _ => SpindleRequest::Current,
    }
}

/// Seeds of [`spindle_reply`]: the simulated converter's answer to every request.
pub fn spindle_reply_seeds() -> std::vec::Vec<std::vec::Vec<u8>> {
    let mut spindle = SimSpindle::new();
    (0u8..7)
        .filter_map(|which| {
            let mut buf = [0u8; 3];
            let request = spindle_request(which).encode(&mut buf).ok()?;
            let reply = spindle.transact(request)?;
            spindle.advance(0.5, 0.0);
            Some(Seed::new().u8(which).bytes(&reply).0)
        })
        .collect()
}

/// `gcode_parse`: any text gives points or a typed error naming a line inside the
/// input; every point is finite with a finite, non-negative feed; the same text read
/// line by line gives the same points; the whole-file reader (every problem reported)
/// names only lines inside the input, gives finite points, and reports an error
/// whenever the first-error parse refused. Returns the points read.
pub fn gcode_parse(data: &[u8]) -> usize {
    let lines = data.split(|&b| b == b'\n').count();
    let mut all: Vec<GcodePoint, 64> = Vec::new();
    let mut errors = 0usize;
    let read = gcode::read(data, &gcode::ReaderConfig::DEFAULT, &mut all, &mut |d| {
        assert!(d.line >= 1 && d.line as usize <= lines, "{d:?}");
        errors += usize::from(d.severity() == gcode::Severity::Error);
    });
    assert!(read.is_ok(), "the default configuration is valid");
    for p in &all {
        let coordinates = p.position_m.iter().chain(&p.angles_rad);
        assert!(coordinates.clone().all(|v| v.is_finite()), "{p:?}");
    }
    let first_error = gcode_parse_first(data, lines);
    if first_error {
        assert!(errors > 0, "parse refused what read reported no error for");
    }
    all.len()
}

/// The first-error parse and the line-by-line reader of [`gcode_parse`]; true when
/// the parse refused the text.
fn gcode_parse_first(data: &[u8], lines: usize) -> bool {
    let mut points: Vec<GcodePoint, 64> = Vec::new();
    let refused = match gcode::parse(data, &mut points) {
        Ok(program) => {
            assert!(program.lines as usize <= lines);
            for p in &points {
                let coordinates = p.position_m.iter().chain(&p.angles_rad);
                assert!(coordinates.clone().all(|v| v.is_finite()), "{p:?}");
                assert!(p.feed_m_s.is_finite() && p.feed_m_s >= 0.0, "{p:?}");
                assert!(p.line >= 1 && p.line as usize <= lines);
            }
            false
        }
        Err(e) => {
            assert!(e.line >= 1 && e.line as usize <= lines, "{e:?}");
            true
        }
    };
    // Line by line, up to the first refusal: the same points.
    let mut parser = Parser::new();
    let mut k = 0;
    for line in data.split(|&b| b == b'\n') {
        match parser.parse_line(line) {
            Ok(Some(p)) => {
                if let Some(q) = points.get(k) {
                    assert_eq!(p, *q);
                }
                k += 1;
            }
            Ok(None) => {}
            Err(_) => break,
        }
    }
    refused
}

/// The ARROW pyramid program's first lines (the firmware's own test program), and
/// small programs of every word the reader knows.
pub const GCODE_SEEDS: [&str; 3] = [
    "%\n(ARROW pyramid)\nN10 G21 G90 G17 G94 (mm, absolute)\nN20 M3 S18000\n\
     N30 G0 X13.333 Y464.604 Z-13.333 A-15.000 B15.000 (approach)\n\
     N40 G1 X13.333 Y484.604 Z-13.333 A-15.000 B15.000 F600 (plunge)\nN50 F1500\n\
     N60 X13.333 Y484.604 Z-7.333 A0.000 B30.000\nN70 X13.333 Y484.604 Z7.333 A0.000 B30.000\n\
     N80 X13.333 Y484.604 Z13.333 A15.000 B15.000\n",
    "G20 G91\nG1 X1 Y0.5 F10\nX-1 Y+2.25e0\nM5\n",
    "G21 G90\nG0 X0 Y500 Z0 A0 B0\nG1 Y510 F300 ; comment\nG1 X5 Y510 Z5 A10 B-10\nM30\n",
];

/// Real programs (`data/gcode`, see its SOURCES.md): arcs in every plane, offsets,
/// comments, the words a CAM header carries.
const GCODE_CORPUS: [&[u8]; 4] = [
    include_bytes!("../../../data/gcode/arc-arc-planeswitch.ngc"),
    include_bytes!("../../../data/gcode/dodecagon_0.1in.ngc"),
    include_bytes!("../../../data/gcode/sawtooth.ngc"),
    include_bytes!("../../../data/gcode/spindle-wait.ngc"),
];

/// Seeds of [`gcode_parse`].
pub fn gcode_parse_seeds() -> std::vec::Vec<std::vec::Vec<u8>> {
    GCODE_SEEDS
        .iter()
        .map(|s| s.as_bytes().to_vec())
        .chain(GCODE_CORPUS.iter().map(|f| f.to_vec()))
        .collect()
}

/// `gcs_reply`: one selector byte, then a reply to one of the GCS reply parsers (or a
/// command to the controller side's parser). Never a panic; accepted values are
/// finite; accepted axis values written back parse to the same axes; an
/// identification is printable. Returns the replies accepted.
pub fn gcs_reply(data: &[u8]) -> usize {
    let Some((selector, bytes)) = data.split_first() else {
        return 0;
    };
    let ok = match selector % 9 {
        0 => parse_axis_values(bytes).is_ok_and(|values| {
            assert!(values.iter().all(|(_, v)| v.is_finite()));
            let mut buf = [0u8; MAX_REPLY_LEN];
            // Values beyond the writer's range are refused, not mangled.
            if let Ok(len) = reply::encode_axis_values(&values, &mut buf) {
                if len > 0 {
                    let back = parse_axis_values(&buf[..len]).unwrap();
                    assert_eq!(back.axes(), values.axes());
                }
            }
            true
        }),
        1 => parse_value(bytes).is_ok_and(|v| {
            assert!(v.is_finite());
            true
        }),
        2 => parse_error_code(bytes).is_ok(),
        3 => parse_referenced(bytes).is_ok_and(|(all, referenced)| {
            assert!(referenced.iter().all(|a| all.contains(a)));
            true
        }),
        4 => parse_axis_names(bytes).is_ok(),
        5 => parse_identification(bytes).is_ok_and(|text| {
            assert!(text.bytes().all(|b| (b' '..=b'~').contains(&b)));
            true
        }),
        6 => parse_motion_status(bytes).is_ok(),
        7 => parse_ready(bytes).is_ok(),
        _ => Command::parse(bytes).is_ok_and(|command| {
            // Whatever the controller side accepts, the firmware side can write
            // (values of a parsed command are finite by construction).
            let mut buf = [0u8; 512];
            let _ = command.encode(&mut buf);
            true
        }),
    };
    usize::from(ok)
}

/// Seeds of [`gcs_reply`]: the simulated H-824's reply to the query of each selector,
/// and a MOV command for the controller side.
pub fn gcs_reply_seeds() -> std::vec::Vec<std::vec::Vec<u8>> {
    let mut hexapod = SimHexapod::new(HexapodLimits::H824);
    let mut mov = AxisValues::uniform(AxisSet::EMPTY.with(Axis::X).with(Axis::Z), 0.25);
    mov.set(Axis::Z, -1.5);
    let queries = [
        (0u8, Command::PosQuery(AxisSet::EMPTY)),
        (1, Command::VlsQuery),
        (2, Command::ErrQuery),
        (3, Command::FrfQuery(AxisSet::EMPTY)),
        (4, Command::SaiQuery),
        (5, Command::IdnQuery),
        (6, Command::MotionStatus),
        (7, Command::ControllerReady),
    ];
    let mut seeds = std::vec::Vec::new();
    for (selector, query) in queries {
        let (mut request, mut reply) = ([0u8; 128], [0u8; MAX_REPLY_LEN]);
        let n = query.encode(&mut request).expect("a query fits");
        let got = hexapod.handle(&request[..n], &mut reply);
        seeds.push(Seed::new().u8(selector).bytes(&reply[..got]).0);
    }
    let mut request = [0u8; 128];
    let n = Command::Mov(mov).encode(&mut request).expect("a MOV fits");
    seeds.push(Seed::new().u8(8).bytes(&request[..n]).0);
    seeds
}
