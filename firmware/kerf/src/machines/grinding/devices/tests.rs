use super::*;
use crate::codec::gcs::reply;
use std::string::String;
use std::vec;
use std::vec::Vec;

/// A scripted hexapod controller: MOV lands at once, ERR? answers `error` (then 0),
/// POS? answers the position or, when set, `garbage`; every request is logged.
#[derive(Default)]
struct FakeHexapod {
    x_mm: f64,
    error: i32,
    garbage: Option<&'static [u8]>,
    log: Vec<String>,
}

impl Transact for FakeHexapod {
    fn transact(&mut self, request: &[u8], out: &mut [u8]) -> Result<usize, LinkError> {
        self.log
            .push(String::from_utf8_lossy(request).trim_end().into());
        let n = match Command::parse(request) {
            Ok(Command::Mov(v)) => {
                self.x_mm = v.get(Axis::X).unwrap_or(self.x_mm);
                0
            }
            Ok(Command::Hlt(_)) => {
                self.error = gcs::code::STOPPED;
                0
            }
            Ok(Command::ErrQuery) => {
                reply::encode_error_code(core::mem::take(&mut self.error), out).unwrap()
            }
            Ok(Command::PosQuery(_)) => match self.garbage {
                Some(g) => {
                    out[..g.len()].copy_from_slice(g);
                    g.len()
                }
                None => {
                    reply::encode_axis_values(&AxisValues::uniform(AxisSet::ALL, self.x_mm), out)
                        .unwrap()
                }
            },
            _ => 0,
        };
        assert!(out.len() >= n);
        Ok(n)
    }
}

/// A converter that echoes set speed and start, answers its measured speed with
/// `rpm`, or stays silent.
#[derive(Default)]
struct FakeSpindle {
    rpm: u16,
    silent: bool,
    log: Vec<Vec<u8>>,
}

impl Transact for FakeSpindle {
    fn transact(&mut self, request: &[u8], out: &mut [u8]) -> Result<usize, LinkError> {
        self.log.push(request.to_vec());
        if self.silent {
            return Ok(0);
        }
        let [lo, hi] = (self.rpm / 10).to_le_bytes();
        out[..3].copy_from_slice(&[request[0], lo, hi]);
        Ok(3)
    }
}

fn link() -> DeviceLink {
    DeviceLink::new(&DeviceLinkConfig::PUBLISHED).unwrap()
}

fn feed(feed_m_s: f64, spindle_rpm: f64) -> DeviceDemand {
    DeviceDemand {
        feed_m_s,
        spindle_rpm,
        halt: false,
    }
}

/// The bytes of a feeding tick, in order: the origin read once, VLS only when the
/// feed changes, MOV to the end of the tick's stretch (0.1 mm/s × 10 ms = 1 µm),
/// ERR?, POS?; the spindle's set speed and start once, its speed read every tick.
#[test]
fn a_feeding_tick_sends_the_seeds_commands() {
    let (l, mut s) = (link(), DeviceLinkState::new());
    let (mut hex, mut sp) = (
        FakeHexapod {
            x_mm: 2.5,
            ..Default::default()
        },
        FakeSpindle {
            rpm: 25_000,
            ..Default::default()
        },
    );
    let r = l
        .tick(&mut s, &feed(1e-4, 25_000.0), &mut hex, &mut sp)
        .unwrap();
    assert_eq!(
        hex.log,
        ["POS? X", "VLS 0.1", "MOV X 2.501", "ERR?", "POS? X"]
    );
    // The fake lands at once: POS? after the MOV reads its target.
    assert_eq!((r.position_mm, r.path_mm), (2.501, 2.501));
    assert_eq!(r.spindle_rpm, Some(25_000));
    assert_eq!(sp.log, [vec![0x01, 0xC4, 0x09], vec![0x24], vec![0x43]]);
    hex.log.clear();
    sp.log.clear();
    let r = l
        .tick(&mut s, &feed(1e-4, 25_000.0), &mut hex, &mut sp)
        .unwrap();
    assert_eq!(hex.log, ["MOV X 2.502", "ERR?", "POS? X"]);
    assert!((r.position_mm - 2.502).abs() < 1e-12);
    assert_eq!(sp.log, [vec![0x43]]);
    // The feed stops: nothing moves, the platform is checked where the path ends.
    hex.log.clear();
    l.tick(&mut s, &feed(0.0, 25_000.0), &mut hex, &mut sp)
        .unwrap();
    assert_eq!(hex.log, ["ERR?", "POS? X"]);
}

/// A controller error mid-pass: the tick faults with its code, HLT and the
/// spindle's set speed 0 follow at once, and the fault stays latched (no further
/// traffic) until reset.
#[test]
fn a_controller_error_halts_and_latches() {
    let (l, mut s) = (link(), DeviceLinkState::new());
    let (mut hex, mut sp) = (FakeHexapod::default(), FakeSpindle::default());
    sp.rpm = 25_000;
    for _ in 0..3 {
        l.tick(&mut s, &feed(1e-4, 25_000.0), &mut hex, &mut sp)
            .unwrap();
    }
    hex.log.clear();
    sp.log.clear();
    hex.error = gcs::code::POS_OUT_OF_LIMITS;
    let fault = DeviceFault::Hexapod(HexapodFault::Controller(7));
    assert_eq!(
        l.tick(&mut s, &feed(1e-4, 25_000.0), &mut hex, &mut sp),
        Err(fault)
    );
    assert_eq!(hex.log, ["MOV X 0.004", "ERR?", "HLT", "ERR?"]);
    assert_eq!(sp.log, [vec![0x01, 0, 0]]);
    hex.log.clear();
    sp.log.clear();
    assert_eq!(
        l.tick(&mut s, &feed(1e-4, 25_000.0), &mut hex, &mut sp),
        Err(fault)
    );
    assert!(hex.log.is_empty() && sp.log.is_empty());
    assert_eq!(s.fault(), Some(fault));
    s.reset();
    assert!(l.tick(&mut s, &feed(0.0, 0.0), &mut hex, &mut sp).is_ok());
}

/// Replies that do not parse are typed faults: a truncated POS?, a NaN position.
#[test]
fn bad_replies_fault() {
    for (garbage, error) in [
        (&b"X=1.0 \n"[..], GcsError::Truncated),
        (&b"X=nan\n"[..], GcsError::MalformedNumber),
        (&b"Q=1\n"[..], GcsError::UnknownAxis(b'Q')),
    ] {
        let (l, mut s) = (link(), DeviceLinkState::new());
        let (mut hex, mut sp) = (FakeHexapod::default(), FakeSpindle::default());
        hex.garbage = Some(garbage);
        assert_eq!(
            l.tick(&mut s, &feed(1e-4, 0.0), &mut hex, &mut sp),
            Err(DeviceFault::Hexapod(HexapodFault::Reply(error)))
        );
        assert_eq!(hex.log.last().map(String::as_str), Some("ERR?"));
    }
}

/// A silent converter faults on the fifth silent tick in a row (not before), a
/// single answer in between restarts the count; a spindle off speed faults on the
/// tenth tick after the 2 s spin-up, not during it.
#[test]
fn spindle_silence_and_speed() {
    let (l, mut s) = (link(), DeviceLinkState::new());
    let (mut hex, mut sp) = (FakeHexapod::default(), FakeSpindle::default());
    sp.rpm = 25_000;
    l.tick(&mut s, &feed(0.0, 25_000.0), &mut hex, &mut sp)
        .unwrap();
    sp.silent = true;
    for _ in 0..4 {
        assert!(l
            .tick(&mut s, &feed(0.0, 25_000.0), &mut hex, &mut sp)
            .is_ok());
    }
    sp.silent = false;
    l.tick(&mut s, &feed(0.0, 25_000.0), &mut hex, &mut sp)
        .unwrap();
    sp.silent = true;
    let mut ticks = 0;
    let fault = loop {
        ticks += 1;
        if let Err(f) = l.tick(&mut s, &feed(0.0, 25_000.0), &mut hex, &mut sp) {
            break f;
        }
    };
    assert_eq!(ticks, 5);
    assert_eq!(
        fault,
        DeviceFault::Spindle(SpindleFault::Silent { ticks: 5 })
    );
    assert_eq!(hex.log.last().map(String::as_str), Some("ERR?"));

    // Off speed: 20,000 rpm measured against 25,000 (beyond 10 %).
    let mut s = DeviceLinkState::new();
    sp.silent = false;
    sp.rpm = 20_000;
    let mut ticks = 0;
    let fault = loop {
        ticks += 1;
        if let Err(f) = l.tick(&mut s, &feed(0.0, 25_000.0), &mut hex, &mut sp) {
            break f;
        }
        assert!(ticks < 1000);
    };
    // 200 ticks of spin-up, then 10 off speed.
    assert_eq!(ticks, 210);
    assert_eq!(
        fault,
        DeviceFault::Spindle(SpindleFault::Speed {
            commanded_rpm: 25_000,
            measured_rpm: 20_000
        })
    );
}
