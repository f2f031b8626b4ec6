//! Generates lookup tables at build time (never typed by hand).
use std::{env, f64::consts::PI, fmt::Write, fs, path::PathBuf};

/// Intervals of the atan table over r = [0, 1] used by `sensing::hall::atan2_turns`.
const ATAN_INTERVALS: usize = 512;

/// Entries per full period of the `codec::dct` cosine tables: 4 × the largest
/// supported N (64), so every angle (2n+1)kπ/(2N) with N | 64 is an exact entry.
const COS_PERIOD: usize = 256;

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
        "/// atan(k / ATAN_INTERVALS) in units of 2^-32 turn, rounded to nearest; the last\n\
         /// entry repeats the one at ratio 1, so that every index up to ATAN_INTERVALS\n\
         /// has a successor (one bounds check per lookup)."
    )
    .unwrap();
    write!(
        src,
        "pub const ATAN_TURN_Q32: [u32; {}] = [",
        ATAN_INTERVALS + 2
    )
    .unwrap();
    for k in (0..=ATAN_INTERVALS).chain([ATAN_INTERVALS]) {
        let turns = (k as f64 / ATAN_INTERVALS as f64).atan() / (2.0 * PI);
        write!(src, "{}, ", (turns * 4294967296.0).round() as u64).unwrap();
    }
    writeln!(src, "];").unwrap();
    fs::write(out.join("tables.rs"), src).expect("write tables.rs");
    let mut cos = String::new();
    cosine_tables(&mut cos);
    fs::write(out.join("cos_tables.rs"), cos).expect("write cos_tables.rs");
    println!("cargo:rerun-if-changed=build.rs");
}

/// cos(2πj/COS_PERIOD) for one full period, as f32 and as Q15 (`i32`, so that
/// cos 0 = 1.0 is exactly 32768 instead of saturating to 32767).
fn cosine_tables(src: &mut String) {
    let angle = |j: usize| 2.0 * std::f64::consts::PI * j as f64 / COS_PERIOD as f64;
    writeln!(src, "/// Entries per full period of the cosine tables.").unwrap();
    writeln!(src, "pub const COS_PERIOD: usize = {COS_PERIOD};").unwrap();
    writeln!(src, "/// cos(2πj/COS_PERIOD), f32 rounded to nearest.").unwrap();
    write!(src, "pub static COS_F32: [f32; {COS_PERIOD}] = [").unwrap();
    for j in 0..COS_PERIOD {
        // `{:?}` prints the shortest string that round-trips the f32.
        write!(src, "{:?}, ", angle(j).cos() as f32).unwrap();
    }
    writeln!(src, "];").unwrap();
    writeln!(
        src,
        "/// cos(2πj/COS_PERIOD) in Q15 (×32768), rounded to nearest."
    )
    .unwrap();
    write!(src, "pub static COS_Q15: [i32; {COS_PERIOD}] = [").unwrap();
    for j in 0..COS_PERIOD {
        write!(src, "{}, ", (angle(j).cos() * 32768.0).round() as i32).unwrap();
    }
    writeln!(src, "];").unwrap();
}
