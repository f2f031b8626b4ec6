//! Generates lookup tables at build time (never typed by hand).
use std::{env, fmt::Write, fs, path::PathBuf};

/// CORDIC vectoring iterations used by `sensing::hall`.
const CORDIC_STEPS: usize = 24;

fn main() {
    let out = PathBuf::from(env::var("OUT_DIR").expect("OUT_DIR"));
    let mut src = String::new();
    // atan(2^-i) as a fraction of a full turn in units of 2^-32 turn (u32 phase word).
    writeln!(
        src,
        "/// atan(2^-i) in units of 2^-32 turn, rounded to nearest."
    )
    .unwrap();
    write!(
        src,
        "pub const CORDIC_ATAN_TURN_Q32: [u32; {CORDIC_STEPS}] = ["
    )
    .unwrap();
    for i in 0..CORDIC_STEPS {
        let a = (2f64).powi(-(i as i32)).atan() / (2.0 * std::f64::consts::PI);
        write!(src, "{}, ", (a * 4294967296.0).round() as u64).unwrap();
    }
    writeln!(src, "];").unwrap();
    fs::write(out.join("tables.rs"), src).expect("write tables.rs");
    println!("cargo:rerun-if-changed=build.rs");
}
