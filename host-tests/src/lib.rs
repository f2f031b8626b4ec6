//! Shared helpers for the host scenario tests.

pub mod signals;
