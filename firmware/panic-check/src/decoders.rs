//! Panic-free, proven at link time: the slower context's half.
//!
//! This image calls the code that reads outside data or fits a calibration: every
//! decoder of bytes from a host, a peer machine or a device (job files, link frames
//! both ways, the host link's request handling with its settings path, G-code, the
//! grinding devices' replies, the remote link's two receivers) and the Hall
//! self-calibration fit, on bytes and samples the optimiser cannot see through. It is
//! the control image's sibling (`src/main.rs`), with the same panic handler; the two
//! do not fit the flash of one image side by side.
//!
//! Unlike the control image it does not link yet: kerf's own arithmetic here is
//! written without a silent wrap (no overflow check remains), but panic paths stay in
//! code it calls: core's decimal float parser (`str::parse::<f64>`, the G-code and GCS
//! number readers), serde-json-core (the settings' float reader and serializer) and the
//! `cobs` crate's in-place decoding (`codec::link::decode`); the calibration fit has
//! none left.
//! `KERF_PANIC_CHECK_DECODERS=1 scripts/panic-check` lists them.
#![no_std]
#![no_main]

mod common;

use common::{opaque, sink, OpaqueLink};
use cortex_m_rt::entry;
use heapless::spsc::Queue;
use kerf::app::calibrate::{fit_sensors, CalibrationFit, HallSample};
use kerf::app::host_link::{HostLink, HostLinkConfig};
use kerf::app::remote_link::{MasterLink, RemoteCommand, SlaveLink};
use kerf::app::supervisor::{Command, Report};
use kerf::codec::gcs;
use kerf::codec::job::JobFile;
use kerf::codec::link::{decode, FrameReader, HostFrame, MachineMessage, MAX_FRAME};
use kerf::codec::sdct::{SdctConfig, Selection};
use kerf::codec::spindle::SpindleRequest;
use kerf::hal::{LinkError, Transact};
use kerf::kinematics::arrow::{ArrowConfig, ArrowGeometry};
use kerf::machines::arrow::job::{ArrowJob, ArrowJobConfig};
use kerf::machines::delta_slave::link::{ContourDefaults, SlaveSettings};
use kerf::machines::delta_slave::{ContourLaw, DeltaSlave, DeltaSlaveConfig};
use kerf::machines::grinding::devices::{
    DeviceDemand, DeviceLink, DeviceLinkConfig, DeviceLinkState,
};
use kerf::sensing::hall::HallConfig;
use kerf::trajectory::gcode::{self, GcodePoint};

/// The Hall sensors the fit starts from, in flash as on the board.
static HALL: [HallConfig; 3] = [HallConfig::LM1247_16BIT; 3];

/// Every decoder and the calibration fit, one chosen by a value the optimiser cannot see.
#[entry]
fn main() -> ! {
    loop {
        match opaque(0u8) {
            0 => calibration(),
            1 => files_and_frames(),
            2 => host_link(),
            3 => devices(),
            4 => programs(),
            _ => remote_link(),
        }
    }
}

/// Bytes the optimiser cannot see through, and how many of them count.
fn bytes<const N: usize>() -> [u8; N] {
    opaque([0u8; N])
}

/// The slower context's end of a calibration: streamed samples kept, then fitted.
fn calibration() {
    let mut samples = opaque(CalibrationFit::<3>::default());
    sink(samples.push(opaque(HallSample {
        axis: 0,
        counts: [0; 3],
    })));
    sink(fit_sensors::<f32, 3>(opaque(&HALL), &samples));
}

/// A job file read and its numbers taken; link frames of both directions read.
fn files_and_frames() {
    let file = bytes::<1024>();
    if let Some(file) = file.get(..opaque(0usize)) {
        if let Ok(job) = JobFile::read(file) {
            sink(job.kind());
            sink(job.harmonic(opaque(0)));
            sink(job.point(opaque(0)));
        }
    }
    let mut frame = bytes::<MAX_FRAME>();
    let len = opaque(0usize);
    if let Some(frame) = frame.get_mut(..len) {
        sink(decode::<HostFrame>(frame).is_ok());
    }
    let mut frame = bytes::<MAX_FRAME>();
    if let Some(frame) = frame.get_mut(..len) {
        sink(decode::<MachineMessage>(frame).is_ok());
    }
    let mut reader = opaque(FrameReader::<MAX_FRAME>::new());
    sink(reader.push(opaque(0)).map(|f| f.map(|f| f.len())));
}

/// The slave's host link taking a byte (requests, uploads, settings get and set),
/// its tick and a report forwarded.
fn host_link() {
    let machine = opaque(DeltaSlaveConfig::KEOPS);
    let config = opaque(HostLinkConfig {
        period_s: machine.joints.period_s,
        heartbeat_timeout_s: HostLinkConfig::DEFAULT_TIMEOUT_S,
    });
    let context = ContourDefaults {
        machine,
        centre_m: opaque([0.0, 0.0, 0.05]),
        speed_m_s: opaque(8e-3),
        accel_m_s2: opaque(0.1),
        jerk_m_s3: opaque(10.0),
        approach_s: opaque(0.3),
        laps: opaque(1.0),
        junction_deviation_m: opaque(10e-6),
        law: ContourLaw::Contouring,
        laser_power_w: opaque(10.0),
    };
    let jobs = kerf::app::jobs::JobSlots::default();
    let Ok(link) = HostLink::<DeltaSlave<f32>, 1024>::new(
        &config,
        SlaveSettings::of(&machine.joints.axis),
        context.into(),
        &jobs,
    ) else {
        return;
    };
    let mut link = opaque(link);
    let mut commands = Queue::<Command<DeltaSlave<f32>>, 4>::new();
    let (mut command_in, _command_out) = commands.split();
    let mut send = |frame: &[u8]| {
        sink(frame);
        opaque(true)
    };
    match opaque(0u8) {
        0 => link.receive(opaque(0), opaque(0.0), &mut command_in, &mut send),
        1 => link.tick(opaque(0.0), &mut command_in, &mut send),
        _ => link.report(&opaque(Report::<DeltaSlave<f32>>::SweepDone), &mut send),
    }
    sink(link.counters());
}

/// A device whose replies the optimiser cannot predict.
struct OpaqueDevice;

impl Transact for OpaqueDevice {
    fn transact(&mut self, request: &[u8], reply: &mut [u8]) -> Result<usize, LinkError> {
        sink(request);
        for b in reply.iter_mut() {
            *b = opaque(0);
        }
        if opaque(false) {
            Err(LinkError::Down)
        } else {
            Ok(opaque(reply.len()))
        }
    }
}

/// The grinding devices' tick (hexapod GCS and spindle replies), and the GCS and
/// spindle reply parsers on their own.
fn devices() {
    if let Ok(link) = DeviceLink::new(&opaque(DeviceLinkConfig::PUBLISHED)) {
        let mut state = opaque(DeviceLinkState::new());
        let demand = opaque(DeviceDemand {
            feed_m_s: 0.0,
            spindle_rpm: 0.0,
            halt: false,
        });
        sink(link.tick(&mut state, &demand, &mut OpaqueDevice, &mut OpaqueDevice));
    }
    let reply = bytes::<{ gcs::MAX_REPLY_LEN }>();
    let Some(reply) = reply.get(..opaque(0usize)) else {
        return;
    };
    match opaque(0u8) {
        0 => sink(gcs::parse_number(reply)),
        1 => sink(gcs::parse_axis_values(reply)),
        2 => sink(gcs::parse_referenced(reply)),
        3 => sink(gcs::parse_value(reply)),
        4 => sink(gcs::parse_error_code(reply)),
        5 => sink(gcs::parse_axis_names(reply)),
        6 => sink(gcs::parse_identification(reply).map(str::len)),
        7 => sink(gcs::parse_motion_status(reply)),
        8 => sink(gcs::parse_ready(reply)),
        _ => sink(opaque(SpindleRequest::ActualRpm).decode(reply)),
    }
}

/// A G-code program parsed, and read into ARROW's job (the load-time path).
fn programs() {
    let text = bytes::<512>();
    let Some(text) = text.get(..opaque(0usize)) else {
        return;
    };
    let mut points = heapless::Vec::<GcodePoint, 64>::new();
    if opaque(true) {
        sink(gcode::parse(text, &mut points));
        return;
    }
    let Ok(geometry) = ArrowGeometry::<f64>::new(&opaque(ArrowConfig::ARROW)) else {
        return;
    };
    let job = ArrowJob::<f32, 16, 2>::from_gcode(
        text,
        &mut points,
        &geometry,
        &opaque(ArrowJobConfig::ARROW),
    );
    sink(job.map(|j| j.periods()));
}

/// The remote link's ends (SDCT blocks or raw samples, copies or not: the ends are
/// opaque): the master reading the slave's reports and sending a command, the slave
/// reading the master's commands into its playout and reporting.
fn remote_link() {
    let sdct = opaque(SdctConfig {
        m: 8,
        selection: Selection::Largest,
    });
    if opaque(true) {
        if let Ok(link) = MasterLink::<16>::new(&sdct, opaque(1), opaque(1e-3)) {
            let mut link = opaque(link);
            sink(link.receive(&mut OpaqueLink));
            link.send(opaque(Some((1, RemoteCommand::default()))), &mut OpaqueLink);
        }
    } else if let Ok(link) = SlaveLink::<16, 8>::new(&sdct, opaque(10), opaque(4)) {
        let mut link = opaque(link);
        sink(link.receive(opaque(0), &mut OpaqueLink));
        link.report(opaque(Some([0.0; 3])), &mut OpaqueLink);
    }
}
