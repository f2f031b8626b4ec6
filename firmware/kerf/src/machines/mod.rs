//! The machines kerf runs, each a product on the framework of [`crate::app`]: its
//! configuration and presets, its jobs, its control period as a
//! [`Machine`](crate::app::supervisor::Machine), its binding to the host link
//! ([`LinkMachine`](crate::app::host_link::LinkMachine)) and its `product` module, the
//! one definition of the machine as it is flashed (control period, link capacities,
//! defaults, code tables).
//!
//! - [`delta_slave`]: the Keops slave, a linear delta that cuts closed contours with a
//!   laser, and the same robot as the slave of remote machining
//!   ([`delta_slave::remote`]), following a master over a delayed link;
//! - [`remote_master`]: the virtual-fixture master of remote machining (the link's
//!   messages are the framework's, [`crate::app::remote_link`]);
//! - [`arrow`]: ARROW, the redundantly actuated parallel machining robot;
//! - [`grinding`]: the force-controlled grinding cell with its devices;
//! - [`single_axis`]: one Hall-sensed linear-motor axis;
//! - [`autofocus`]: a zoom camera's focus axis kept at the sharpness peak.
//!
//! No machine imports another's module: what two machines share is the framework's
//! (the remote link, the joints, the calibration).

pub mod arrow;
pub mod autofocus;
pub mod delta_slave;
pub mod grinding;
pub mod remote_master;
pub mod single_axis;
