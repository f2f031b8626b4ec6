//! The harnesses, by what they read (see the crate docs).

pub mod codec;
pub mod devices;
pub mod host;
pub mod job;
pub mod link;
pub mod replay;
pub mod stream;
