//! The operator's tools for kerf machines, behind the `kerf` command line.
//!
//! - [`plan`]: the image-to-contour planner of T 3.1 (smoothing, Canny edges, gap
//!   closing, start point, ordering, scaling into the workspace) ending in an EFD
//!   (T 3.2.2) or a point list (T 3.1.5) fitted with the firmware's own code;
//! - [`gcode`]: a G-code program checked with ARROW's own parser and job loader;
//!   [`laser`]: a laser program as the parts of a Keops slave job;
//! - [`parts`]: every closed contour of an image as the parts of one job, ordered;
//! - [`job`]: the versioned job file both write and the firmware loads;
//! - [`check`]: a job file checked as the machine checks it at load, with its
//!   duration; [`preview`]: its picture (workspace, travel, cut, start);
//! - [`trace`]: the edge skeleton walked into one ordered chain ([`mask`]: the
//!   binary images it works on);
//! - [`plot`]: an SVG picture of a plan;
//! - [`link`]: the host's end of the machine link (requests, replies, typed errors);
//!   [`session`]: a session with a board or the emulated machine ([`qemu`]) and a
//!   job's run on it; [`telemetry`]: the samples of a run as CSV, summary and SVG;
//! - [`serve`]: one process holding a machine open for several clients, with the web
//!   console and its HTTP API (`kerf serve`, `--session`);
//! - [`output`]: the files the tool writes, checked before the work and written whole.
//!
//! "T" is the thesis the planner comes from (pre-processing and motion control for
//! non-contact machining of complex contours), "A" the ARROW paper (Saied et al., "A
//! Redundant Parallel Robotic Machining Tool: Design, Control and Real-Time
//! Experiments", 2019), as the repository's docs/equations.md names them.

pub mod arrow_parts;
pub mod check;
pub mod description;
pub mod gcode;
pub mod job;
pub mod kerf_offset;
pub mod laser;
pub mod link;
pub mod mask;
pub mod output;
pub mod parts;
pub mod plan;
pub mod plot;
pub mod preview;
pub mod qemu;
pub mod relay;
pub mod serve;
pub mod session;
pub mod telemetry;
pub mod trace;
