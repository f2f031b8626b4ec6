//! The harnesses of kerf's fuzz targets, one per decoder of outside data on both
//! sides of the link, and the seeds they start from.
//!
//! Each target in `fuzz_targets/` calls one harness of [`TARGETS`]. A harness feeds
//! its input to the decoder and asserts the decoder's contract: a typed error, or a
//! value in its stated range (finite numbers, lengths within capacity, re-encoding
//! that gives the same bytes, floats compared bit for bit so that NaN cannot pass
//! unnoticed). It returns how many messages got past the integrity checks (CRC,
//! framing), which `gen_corpus --check` counts to show that the seeds, and the corpus
//! a run grew from them, reach the decoders behind those checks.
//!
//! The seeds are made by the public encoders and senders of the code under test (and
//! `hal-mock`'s simulated devices), never written by hand, so that after a format
//! change `cargo run --example gen_corpus` writes the corpus again.

pub mod input;
pub mod targets;

/// One fuzz target: its name (the binary and the corpus directory), its harness and
/// its seeds.
pub struct Target {
    /// The cargo-fuzz target and `corpus/<name>`.
    pub name: &'static str,
    /// Runs one input; returns the messages that got past the integrity checks.
    pub run: fn(&[u8]) -> usize,
    /// The seed inputs.
    pub seeds: fn() -> Vec<Vec<u8>>,
}

use targets::{codec, devices, host, job, link, replay, stream};

/// Every target, firmware side first.
pub const TARGETS: [Target; 17] = [
    Target {
        name: "packet_decode",
        run: codec::packet_decode,
        seeds: codec::packet_decode_seeds,
    },
    Target {
        name: "spindle_reply",
        run: codec::spindle_reply,
        seeds: codec::spindle_reply_seeds,
    },
    Target {
        name: "gcode_parse",
        run: codec::gcode_parse,
        seeds: codec::gcode_parse_seeds,
    },
    Target {
        name: "gcs_reply",
        run: codec::gcs_reply,
        seeds: codec::gcs_reply_seeds,
    },
    Target {
        name: "link_frame",
        run: link::link_frame,
        seeds: link::link_frame_seeds,
    },
    Target {
        name: "host_link",
        run: link::host_link,
        seeds: link::host_link_seeds,
    },
    Target {
        name: "job_file",
        run: job::job_file,
        seeds: job::job_file_seeds,
    },
    Target {
        name: "stream_frame",
        run: stream::stream_frame,
        seeds: stream::stream_frame_seeds,
    },
    Target {
        name: "remote_link",
        run: stream::remote_link,
        seeds: stream::remote_link_seeds,
    },
    Target {
        name: "playout",
        run: replay::playout,
        seeds: replay::playout_seeds,
    },
    Target {
        name: "grinding_devices",
        run: devices::grinding_devices,
        seeds: devices::grinding_devices_seeds,
    },
    Target {
        name: "arrow_gcode",
        run: job::arrow_gcode,
        seeds: job::arrow_gcode_seeds,
    },
    Target {
        name: "replay_recording",
        run: replay::replay_recording,
        seeds: replay::replay_recording_seeds,
    },
    Target {
        name: "host_reader",
        run: host::host_reader,
        seeds: host::host_reader_seeds,
    },
    Target {
        name: "telemetry_log",
        run: host::telemetry_log,
        seeds: host::telemetry_log_seeds,
    },
    Target {
        name: "host_job",
        run: job::host_job,
        seeds: job::job_file_seeds,
    },
    Target {
        name: "plan_image",
        run: host::plan_image,
        seeds: host::plan_image_seeds,
    },
];
