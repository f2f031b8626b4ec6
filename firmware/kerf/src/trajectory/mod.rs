//! What to follow: references evaluated once per control period.

pub mod quintic;
