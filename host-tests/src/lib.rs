//! Shared helpers for the host scenario tests.
