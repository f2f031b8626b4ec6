//! Shared helpers for the host scenario tests.

pub mod arrow;
pub mod bad_input;
pub mod contours;
pub mod depth;
pub mod fixed_point;
pub mod grinding;
pub mod hall;
pub mod link;
pub mod link_host;
pub mod machining;
pub mod plot;
pub mod remote;
pub mod signals;
pub mod webdriver;
