//! The healthy-residual table against the health row computed forwards from the true
//! phase (the table is made backwards, from each linear phase to the true one).

use super::*;
use crate::sensing::hall::calibration::ChannelModel;

/// Sensors with per-channel third and fifth harmonics of different phases (the health
/// row sees them): at 2000 true phases off the table's grid, the table read at the
/// sample's own linear phase word gives w·(u − o) computed directly from the channel
/// values, to within the table's stated systematic error; that error is below 1 % of
/// the residual's swing (so the comparison is not vacuous: a table of zeros, or of
/// the wrong scale, is thousands of counts off; interpolating a harmonic of order n
/// on 128 entries errs by (2πn/128)²/8 of its amplitude, 0.75 % at n = 5).
#[test]
fn the_table_is_the_health_row_of_the_healthy_sensor() {
    let a = 26214.4;
    let channel =
        |offset: f64, amplitude: f64, phase: f64, h3: f64, p3: f64, h5: f64| ChannelModel {
            offset_counts: offset,
            amplitude_counts: amplitude,
            phase_rad: phase,
            harmonic3: h3,
            harmonic3_phase_rad: p3,
            harmonic5: h5,
            harmonic5_phase_rad: -p3,
        };
    let model = SensorModel {
        channels: [
            channel(32768.0 + 0.03 * a, 1.05 * a, 0.0, 0.03, 0.2, 0.02),
            channel(
                32768.0 - 0.02 * a,
                0.96 * a,
                2.0 * PI / 3.0 + 0.01,
                0.01,
                -0.4,
                0.01,
            ),
            channel(32768.0, a, -2.0 * PI / 3.0 - 0.015, 0.022, 1.0, 0.015),
        ],
    };
    let linear = model.linear_calibration().unwrap();
    let table = model.residual_table(&linear);
    let (mut lowest, mut highest) = (f64::MAX, f64::MIN);
    for i in 0..2000 {
        let phi = 2.0 * PI * (f64::from(i) + 0.37) / 2000.0;
        let u = model.predict(phi);
        let direct: f64 = (0..3)
            .map(|k| f64::from(linear.sum_row[k]) * (u[k] - f64::from(linear.offset_counts[k])))
            .sum();
        let (s, c) = linear.demodulate_f64(u);
        let turns = libm::atan2(s, c) / (2.0 * PI);
        let word = ((turns - libm::floor(turns)) * 4_294_967_296.0) as u32;
        let read = f64::from(table.at(word)) / 16.0;
        // The table quantizes the row to 2^-16 and the offsets to 1/16 count as the
        // decoder does: 3 · (2^-17 · 1.2 A + 1/32 · |w|) < 0.9 count more.
        assert!(
            (read - direct).abs() < f64::from(table.systematic_counts) + 0.9,
            "{phi}: table {read}, direct {direct}"
        );
        lowest = lowest.min(direct);
        highest = highest.max(direct);
    }
    assert!(
        f64::from(table.systematic_counts) < 0.01 * (highest - lowest),
        "{} against {lowest}..{highest}",
        table.systematic_counts
    );
}
