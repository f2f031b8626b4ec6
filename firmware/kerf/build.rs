//! Generates lookup tables at build time (never typed by hand).
use std::{env, f64::consts::PI, fmt::Write, fs, path::PathBuf};

/// Intervals of the atan table over r = [0, 1] used by `sensing::hall::atan2_turns`.
const ATAN_INTERVALS: usize = 512;

fn main() {
    let out = PathBuf::from(env::var("OUT_DIR").expect("OUT_DIR"));
    let mut src = String::new();
    writeln!(
        src,
        "/// Intervals of [`ATAN_TURN_Q32`] over the ratio range [0, 1]."
    )
    .unwrap();
    writeln!(src, "pub const ATAN_INTERVALS: usize = {ATAN_INTERVALS};").unwrap();
    writeln!(
        src,
        "/// atan(k / ATAN_INTERVALS) in units of 2^-32 turn, rounded to nearest."
    )
    .unwrap();
    write!(
        src,
        "pub const ATAN_TURN_Q32: [u32; {}] = [",
        ATAN_INTERVALS + 1
    )
    .unwrap();
    for k in 0..=ATAN_INTERVALS {
        let turns = (k as f64 / ATAN_INTERVALS as f64).atan() / (2.0 * PI);
        write!(src, "{}, ", (turns * 4294967296.0).round() as u64).unwrap();
    }
    writeln!(src, "];").unwrap();
    fs::write(out.join("tables.rs"), src).expect("write tables.rs");
    println!("cargo:rerun-if-changed=build.rs");
}
