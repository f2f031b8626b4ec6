//! The host tool's readers of what comes from outside: the machine link's reader
//! (`host_reader`, `kerf_host::link::MachineLink`), the telemetry log it fills
//! (`telemetry_log`) and the planner's image input (`plan_image`).

use crate::input::{same_bits, Input, Seed};
use image::{GrayImage, ImageFormat, ImageReader, Limits, Luma};
use kerf::app::host_link::{describe, LinkMachine, SettingText};
use kerf::codec::link::{
    encode, ChannelValues, Event, MachineMessage, MachineStatus, ModeCode, Reply, TelemetrySample,
    MAX_CHANNELS, MAX_FRAME, VERSION,
};
use kerf::machines::delta_slave::link::SlaveSettings;
use kerf::machines::delta_slave::{DeltaSlaveConfig, CONTOUR_HARMONICS, OPEN_PATH_POINTS};
use kerf_host::description::ChannelInfo;
use kerf_host::job::Job;
use kerf_host::kerf_offset::KerfSide;
use kerf_host::link::{Heard, MachineLink};
use kerf_host::plan::{plan_image as plan, Format, PlanConfig};
use kerf_host::telemetry::TelemetryLog;
use std::io::Cursor;
use std::time::Duration;

/// `host_reader`: the host's end of the link reading a machine's byte stream: it
/// connects only on a hello of this link version with a finite period, asks for the
/// status and a setting, and takes everything else that came. Frames that did not
/// decode are counted, at most one per delimiter; replies, samples and events come
/// out as they were sent (samples' floats bit for bit). Returns the messages heard.
pub fn host_reader(data: &[u8]) -> usize {
    let delimiters = data.iter().filter(|&&b| b == 0).count() as u32;
    let reader = Box::new(Cursor::new(data.to_vec()));
    let Ok(mut machine) =
        MachineLink::connect(reader, Box::new(std::io::sink()), Duration::from_secs(5))
    else {
        return 0;
    };
    let hello = machine.hello().clone();
    assert_eq!(hello.version, VERSION);
    assert!(
        hello.period_s.is_finite() && hello.period_s >= 0.0,
        "{hello:?}"
    );
    let mut heard = 1;
    if machine.status().is_ok() {
        heard += 1;
    }
    if machine.get("/slave/dob/bandwidth_hz").is_ok() {
        heard += 1;
    }
    while let Ok(Some(message)) = machine.next(Duration::from_secs(5)) {
        heard += 1;
        if let Heard::Reply(_, kerf_host::link::OwnedReply::Hello(h)) = &message {
            assert!(h.period_s.is_finite());
        }
    }
    assert!(machine.bad_frames() + heard as u32 <= delimiters);
    heard
}

fn frame(message: &MachineMessage<'_>) -> Vec<u8> {
    let mut out = [0u8; MAX_FRAME];
    let n = encode(message, &mut out).expect("a message fits");
    out[..n].to_vec()
}

/// The Keops slave, whose description and samples the seeds carry.
type Slave = kerf::machines::delta_slave::DeltaSlave<f32>;

/// The slave's channels as the host keeps them.
fn slave_channels() -> Vec<ChannelInfo> {
    Slave::CHANNELS
        .iter()
        .map(|c| ChannelInfo {
            name: c.name.into(),
            unit: c.unit.into(),
        })
        .collect()
}

fn sample(period: u32, mode: ModeCode, k: f32) -> TelemetrySample {
    let (s, c) = (1e-3 * k.sin(), 1e-3 * k.cos());
    let values = [
        s,
        c,
        -0.25,
        s,
        c,
        -0.25,
        2e-7 * k.cos(),
        0.4 * k,
        -0.2,
        1.1,
        9.5,
    ];
    TelemetrySample {
        period,
        mode,
        values: values.into_iter().collect(),
    }
}

/// Seeds of [`host_reader`]: a slave's answers to the reader's hello, status and
/// get, with telemetry and events among them, and line noise before the hello.
pub fn host_reader_seeds() -> Vec<Vec<u8>> {
    let hello = Reply::Hello {
        version: VERSION,
        machine: "keops-slave",
        max_chunk: 192,
        period_ns: 100_000,
    };
    let status = MachineStatus {
        mode: ModeCode::Ready,
        period: 1234,
        ..Default::default()
    };
    let mut stream = vec![0x55, 0x13, 0x37];
    stream.extend(frame(&MachineMessage::Reply {
        seq: 1,
        reply: hello,
    }));
    // The description, item by item, and its end.
    let mut seq = 2;
    let presets = SlaveSettings::of(&DeltaSlaveConfig::KEOPS.joints.axis);
    for index in 0u16.. {
        let mut text = SettingText::default();
        let item = describe::<Slave>(index, &presets, &mut text);
        stream.extend(frame(&MachineMessage::Reply {
            seq,
            reply: Reply::Description { index, item },
        }));
        seq += 1;
        if item.is_none() {
            break;
        }
    }
    for message in [
        MachineMessage::Telemetry(sample(100, ModeCode::Ready, 0.0)),
        MachineMessage::Reply {
            seq,
            reply: Reply::Status(status),
        },
        MachineMessage::Event(Event::Mode {
            from: ModeCode::Ready,
            to: ModeCode::Running,
        }),
        MachineMessage::Reply {
            seq: seq + 1,
            reply: Reply::Value { value: b"120" },
        },
        MachineMessage::Telemetry(sample(200, ModeCode::Running, 1.0)),
        MachineMessage::Event(Event::Fault { code: 5, detail: 2 }),
        MachineMessage::Event(Event::HostLost),
    ] {
        stream.extend(frame(&message));
    }
    vec![stream]
}

/// A sample of the input: period, mode byte, a count byte (at most [`MAX_CHANNELS`]
/// values), then the floats.
fn read_sample(input: &mut Input<'_>) -> Option<TelemetrySample> {
    let period = input.u32()?;
    let mode = match input.u8()? % 6 {
        0 => ModeCode::Idle,
        1 => ModeCode::Calibrating,
        2 => ModeCode::Ready,
        3 => ModeCode::Running,
        4 => ModeCode::Stopping,
        _ => ModeCode::Fault,
    };
    let count = usize::from(input.u8()?) % (MAX_CHANNELS + 1);
    let mut values = ChannelValues::new();
    for _ in 0..count {
        values.push(input.f32()?).ok()?;
    }
    Some(TelemetrySample {
        period,
        mode,
        values,
    })
}

/// `telemetry_log`: samples as the link delivers them (any bits) into the host's log,
/// for a machine period of the first u32 in ns (as a hello carries it). The period
/// count moves forward by the wire's wrapping difference; the CSV has a row per
/// sample whose numbers read back to the sample's, bit for bit (NaN as NaN); the
/// summary counts the cutting samples, and is finite, with the RMS at most the
/// maximum, when their numbers are. Returns the samples logged.
pub fn telemetry_log(data: &[u8]) -> usize {
    let mut input = Input::new(data);
    let Some(period_ns) = input.u32() else {
        return 0;
    };
    let channels = slave_channels();
    let mut log = TelemetryLog::new(f64::from(period_ns) * 1e-9, &channels);
    let mut samples = Vec::new();
    while let Some(s) = read_sample(&mut input) {
        let previous = log.entries().last().map(|e| e.period);
        let entry = log.push(s.clone()).clone();
        if let Some(p) = previous {
            assert_eq!(entry.period - p, u64::from(s.period.wrapping_sub(p as u32)));
        }
        assert!(entry.time_s.is_finite() && entry.time_s >= 0.0);
        if s.mode == ModeCode::Fault {
            log.mark("fault");
        }
        samples.push(s);
    }
    let mut csv = Vec::new();
    log.write_csv(&mut csv).expect("a Vec takes the CSV");
    let text = String::from_utf8(csv).expect("the CSV is UTF-8");
    let rows: Vec<&str> = text.lines().collect();
    assert_eq!(rows.len(), samples.len() + 1);
    // A column per channel; a sample's values fill them in order, a missing one is
    // empty, one past the channels is not written.
    for (row, s) in rows[1..].iter().zip(&samples) {
        let fields: Vec<&str> = row.split(',').collect();
        assert_eq!(fields.len(), 3 + channels.len(), "{row}");
        for (k, field) in fields[3..].iter().enumerate() {
            match s.values.get(k) {
                Some(want) => {
                    let back: f32 = field.parse().unwrap();
                    let same = back.to_bits() == want.to_bits() || (back.is_nan() && want.is_nan());
                    assert!(same, "{row} for {s:?}");
                }
                None => assert!(field.is_empty(), "{row}"),
            }
        }
    }
    let summary = log.summary();
    let cutting: Vec<&TelemetrySample> = samples
        .iter()
        .filter(|s| s.mode == ModeCode::Running)
        .collect();
    assert_eq!(
        (summary.samples, summary.cutting_samples),
        (samples.len(), cutting.len())
    );
    assert!(log.since_cut_s() >= 0.0 && summary.cut_s >= 0.0);
    if cutting
        .iter()
        .all(|s| s.values.iter().all(|v| v.is_finite()))
    {
        let values = [
            summary.error_max_m,
            summary.error_rms_m,
            summary.force_peak_n,
            summary.laser_mean_w,
        ];
        assert!(values.iter().all(|v| v.is_finite()), "{summary:?}");
        assert!(
            summary.error_rms_m <= summary.error_max_m * (1.0 + 1e-12),
            "{summary:?}"
        );
    }
    samples.len()
}

/// Seeds of [`telemetry_log`]: a cut at 10 kHz across the wire's 32-bit wrap.
pub fn telemetry_log_seeds() -> Vec<Vec<u8>> {
    let mut seed = Seed::new().u32(100_000);
    for k in 0..12u32 {
        let mode = if (2..10).contains(&k) {
            ModeCode::Running
        } else {
            ModeCode::Ready
        };
        let s = sample((u32::MAX - 500).wrapping_add(100 * k), mode, k as f32);
        seed = seed.u32(s.period).u8(mode as u8).u8(s.values.len() as u8);
        for v in &s.values {
            seed = seed.f32(*v);
        }
    }
    vec![seed.0]
}

/// The largest side of an image the harness plans (bounded: planning time).
const SIDE: u32 = 48;

/// The planner's settings from 8 input bytes, over the documented ranges and just
/// past them (so that the refusals are reached too).
fn config(b: &[u8]) -> PlanConfig {
    PlanConfig {
        sigma_px: f32::from(b[0] % 16) * 0.25,
        canny: (f32::from(b[1]) * 2.0, f32::from(b[2]) * 4.0),
        close_px: b[3] % 6,
        prune_px: usize::from(b[4] % 24),
        width_mm: f64::from(b[5]) * 0.1,
        harmonics: usize::from(b[6]) % (CONTOUR_HARMONICS + 2),
        start_px: (b[7] & 1 == 1).then(|| [f64::from(b[7] >> 1) * 0.5, f64::from(b[4])]),
        format: match b[7] % 6 {
            2 => Some(Format::Efd),
            4 => Some(Format::Points),
            _ => None,
        },
        // Mostly the largest; now and then one past those a small image has.
        contour: usize::from(b[6] >> 6),
        // Now and then a kerf (its offset is the slow step) and a lead-in.
        kerf_mm: if b[3] >= 0xe0 {
            f64::from(b[3] & 7) * 0.1
        } else {
            0.0
        },
        kerf_side: if b[3] & 8 == 0 {
            KerfSide::Outside
        } else {
            KerfSide::Inside
        },
        lead_in_mm: f64::from(b[1] >> 6) * 0.8,
        // Now and then ink and paper (0 included: refused).
        threshold: (b[0] & 0x80 != 0).then_some(b[2]),
    }
}

/// `plan_image`: the planner on a small grey image, given as pixels (mode bit 0 clear:
/// width, height, grey levels) or as an image file (PNG or JPEG, refused past 48
/// pixels a side), with settings from the input. A plan is a job that the job file
/// carries and reads back unchanged, within the firmware's capacities, whose contour
/// is finite with its larger side the requested width, traced inside the image.
/// Anything else is a typed error. Returns 1 for a plan.
pub fn plan_image(data: &[u8]) -> usize {
    let mut input = Input::new(data);
    let (Some(mode), Some(settings)) = (input.u8(), input.bytes(8)) else {
        return 0;
    };
    let config = config(settings);
    let gray = if mode & 1 == 0 {
        let (Some(w), Some(h)) = (input.u8(), input.u8()) else {
            return 0;
        };
        let (w, h) = (1 + u32::from(w) % SIDE, 1 + u32::from(h) % SIDE);
        let pixels = input.rest();
        GrayImage::from_fn(w, h, |x, y| {
            Luma([pixels.get((y * w + x) as usize).copied().unwrap_or(0)])
        })
    } else {
        let mut reader = match ImageReader::new(Cursor::new(input.rest())).with_guessed_format() {
            Ok(r) => r,
            Err(_) => return 0,
        };
        let mut limits = Limits::default();
        limits.max_image_width = Some(SIDE);
        limits.max_image_height = Some(SIDE);
        limits.max_alloc = Some(1 << 20);
        reader.limits(limits);
        match reader.decode() {
            Ok(image) => image.to_luma8(),
            Err(_) => return 0,
        }
    };
    let Ok(p) = plan(&gray, &config, &mut |_| {}) else {
        return 0;
    };
    let bytes = p.job.to_bytes().expect("a planned job is written");
    let back = Job::from_bytes(&bytes).expect("and read");
    assert_eq!(back.kind(), p.job.kind());
    match (&p.job, &back) {
        (
            Job::Efd {
                centre_m: a,
                coefficients: ca,
            },
            Job::Efd {
                centre_m: b,
                coefficients: cb,
            },
        ) => {
            assert!(same_bits(a, b) && same_bits(ca.as_flattened(), cb.as_flattened()));
            assert!(!ca.is_empty() && ca.len() <= config.harmonics.min(CONTOUR_HARMONICS));
            assert!(p.closed);
        }
        (Job::Path { points_m: a }, Job::Path { points_m: b }) => {
            assert!(same_bits(a.as_flattened(), b.as_flattened()));
            assert!(
                a.len() >= 2 && a.len() <= OPEN_PATH_POINTS,
                "{} points",
                a.len()
            );
        }
        other => panic!("the planner wrote {other:?}"),
    }
    let (w, h) = (f64::from(gray.width()), f64::from(gray.height()));
    assert!(p
        .chain_px
        .iter()
        .all(|q| (0.0..w).contains(&q[0]) && (0.0..h).contains(&q[1])));
    assert!(p.contour_mm.iter().flatten().all(|v| v.is_finite()));
    let side = |k: usize| {
        let (lo, hi) = p
            .contour_mm
            .iter()
            .fold((f64::INFINITY, f64::NEG_INFINITY), |(lo, hi), q| {
                (lo.min(q[k]), hi.max(q[k]))
            });
        hi - lo
    };
    let larger = side(0).max(side(1));
    assert!(
        (larger - config.width_mm).abs() <= 1e-9 * config.width_mm,
        "{larger} mm against {}",
        config.width_mm
    );
    1
}

fn disc(side: u32) -> GrayImage {
    let c = f64::from(side) / 2.0;
    GrayImage::from_fn(side, side, |x, y| {
        let r = (f64::from(x) + 0.5 - c).hypot(f64::from(y) + 0.5 - c);
        Luma([if r < 0.35 * f64::from(side) { 0 } else { 255 }])
    })
}

fn stroke(side: u32) -> GrayImage {
    GrayImage::from_fn(side, side, |x, y| {
        let on = y.abs_diff(side / 2 + x / 4) <= 1 && (4..side - 4).contains(&x);
        Luma([if on { 0 } else { 255 }])
    })
}

/// Seeds of [`plan_image`]: a disc (a closed contour: EFD, and points) and a stroke
/// (an open contour from its left end) as pixels, and the disc as PNG.
pub fn plan_image_seeds() -> Vec<Vec<u8>> {
    let defaults = [4u8, 20, 25, 3, 10, 120, 12, 0];
    let as_pixels = |settings: [u8; 8], image: &GrayImage| {
        Seed::new()
            .u8(0)
            .bytes(&settings)
            .u8(image.width() as u8 - 1)
            .u8(image.height() as u8 - 1)
            .bytes(image.as_raw())
            .0
    };
    let mut png = Vec::new();
    disc(40)
        .write_to(&mut Cursor::new(&mut png), ImageFormat::Png)
        .expect("PNG of a small image");
    let mut points = defaults;
    points[7] = 4;
    let mut open = defaults;
    open[7] = 4 << 1 | 1;
    open[4] = 24;
    vec![
        as_pixels(defaults, &disc(40)),
        as_pixels(points, &disc(32)),
        as_pixels(open, &stroke(40)),
        Seed::new().u8(1).bytes(&defaults).bytes(&png).0,
    ]
}
