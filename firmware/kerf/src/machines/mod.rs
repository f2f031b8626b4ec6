//! The machines kerf runs, each a product on the framework of [`crate::app`]: its
//! configuration and presets, its jobs, its control period as a
//! [`Machine`](crate::app::supervisor::Machine), its binding to the host link
//! ([`LinkMachine`](crate::app::host_link::LinkMachine)) and its `product` module, the
//! one definition of the machine as it is flashed (control period, link capacities,
//! defaults, code tables).
//!
//! - [`delta_slave`]: the Keops slave, a linear delta that cuts closed contours with a
//!   laser;
//! - [`remote_master`] and [`remote_slave`]: remote machining, the virtual-fixture
//!   master and the slave that follows it over a delayed link ([`remote_link`], their
//!   messages);
//! - [`arrow`]: ARROW, the redundantly actuated parallel machining robot;
//! - [`grinding`]: the force-controlled grinding cell with its devices;
//! - [`single_axis`]: one Hall-sensed linear-motor axis;
//! - [`autofocus`]: a zoom camera's focus axis kept at the sharpness peak.

pub mod arrow;
pub mod autofocus;
pub mod delta_slave;
pub mod grinding;
pub mod remote_link;
pub mod remote_master;
pub mod remote_slave;
pub mod single_axis;
