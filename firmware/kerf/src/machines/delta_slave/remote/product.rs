//! The remote slave as it is flashed: its configuration, the link to the master it
//! plays commands from (block length, playout capacity), and what its host link holds
//! — the job buffer of a recorded master session, how often telemetry is reported.
//! The QEMU images, the simulator and the host tool take these from here.

use super::recording::RECORDING_HEADER_LEN;
use super::RemoteSlaveConfig;
use crate::app::remote_link::SlaveLink;
use crate::codec::job::HEADER_BYTES;

/// The slave: the Keops delta over a 1 kHz command stream ([`RemoteSlaveConfig::KEOPS`]).
pub const CONFIG: RemoteSlaveConfig = RemoteSlaveConfig::KEOPS;

/// The control period, s (10 kHz).
pub const PERIOD_S: f64 = CONFIG.slave.joints.period_s;

pub use crate::app::remote_link::BLOCK;

/// Commands the slave's playout holds: 256 ms of 1 kHz samples, past any delay the
/// remote scenarios use.
pub const PLAYOUT_CAPACITY: usize = 256;

/// The slave's end of the link to the master.
pub type SlaveEnd = SlaveLink<BLOCK, PLAYOUT_CAPACITY>;

/// Bytes of command frames a session job holds (each frame with its arrival and
/// length): 12 KiB, about 2 s of the recorded 1 kHz stream in 16-sample blocks
/// (a 91–93 byte frame every 16 ms, 6.1 KB/s). A session is an uploaded job: the
/// link's buffer, the supervisor's copy and the command slot's each hold one, which
/// the board's 128 KiB bounds.
pub const SESSION_FRAME_BYTES: usize = 12 * 1024;

/// Bytes of an uploaded job the slave holds: a recording's header and
/// [`SESSION_FRAME_BYTES`] of frames in a job file (no master references: the slave
/// does not need them).
pub const LINK_JOB_BYTES: usize = HEADER_BYTES + RECORDING_HEADER_LEN + SESSION_FRAME_BYTES + 4;

/// The supervisor reports telemetry every this many control periods (1 kHz at the
/// 10 kHz period); the host link decimates further to the rate the host asks for.
pub const TELEMETRY_DECIMATION: u32 = 10;
