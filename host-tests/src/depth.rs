//! Energy deposited per unit path length, the measure of cut depth (depth ∝ e = P / v,
//! docs/control.md §23, Laser power and cut depth), from a simulated run's per-period
//! samples.
//!
//! During period k the spot moves from s_k to s_{k+1} (arc length along the path, m,
//! either way) while the laser holds the power P_k; the period's energy P_k·Ts is
//! spread over the bins of length `bin_m` that stretch crosses, in proportion to the
//! distance covered in each. A period without motion puts all its energy into the bin
//! the spot stands in. Each bin's energy over its length is the energy per length
//! there, J/m; at constant P and v it is P / v.

use std::ops::Range;

/// Why [`deposit`] has no profile.
#[derive(Copy, Clone, Debug, PartialEq, Eq)]
pub enum DepthError {
    /// `positions_m` must hold one more sample than `power_w` (the end of the last
    /// period), and at least two.
    Lengths,
    /// A position, power or the period is NaN or infinite, or the period is ≤ 0, or a
    /// power is negative.
    BadSample,
    /// `bin_m` is not finite and strictly positive, or gives more than [`MAX_BINS`].
    BadBin,
}

impl std::fmt::Display for DepthError {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.write_str(match self {
            Self::Lengths => "positions must hold one more sample than powers",
            Self::BadSample => "a sample or the period is not finite, or out of range",
            Self::BadBin => "bin length not positive, or too many bins",
        })
    }
}

impl std::error::Error for DepthError {}

/// Fraction of a bin by which the first and last positions may pass the bins' range
/// (round-off in positions summed from speeds).
const EDGE_SLACK: f64 = 1e-9;

/// Most bins [`deposit`] makes.
pub const MAX_BINS: usize = 10_000_000;

/// Energy per unit length in consecutive bins along the path.
#[derive(Clone, Debug, PartialEq)]
pub struct EnergyProfile {
    /// Arc length where bin 0 starts, m (a multiple of `bin_m`).
    pub start_m: f64,
    /// Bin length, m.
    pub bin_m: f64,
    /// Energy per unit length in each bin, J/m.
    pub energy_j_per_m: Vec<f64>,
}

impl EnergyProfile {
    /// Arc length of bin `i`'s centre, m.
    pub fn centre_m(&self, i: usize) -> f64 {
        self.start_m + (i as f64 + 0.5) * self.bin_m
    }

    /// Total energy, J: Σ bins × bin length.
    pub fn total_j(&self) -> f64 {
        self.energy_j_per_m.iter().sum::<f64>() * self.bin_m
    }

    /// (bin centre in mm, energy per length in J/m) for [`crate::plot::along_path`].
    pub fn points_mm(&self) -> Vec<(f64, f64)> {
        (0..self.energy_j_per_m.len())
            .map(|i| (1e3 * self.centre_m(i), self.energy_j_per_m[i]))
            .collect()
    }

    /// Nominal energy per length and the worst deviation from it over the bins left
    /// after dropping `skip_bins` at each end (where the cut starts and stops
    /// part-way through a bin). `None` if no bin is left or the nominal is zero.
    pub fn summary(&self, skip_bins: usize) -> Option<DepthSummary> {
        let n = self.energy_j_per_m.len();
        if n <= 2 * skip_bins {
            return None;
        }
        self.summary_of(skip_bins..n - skip_bins)
    }

    /// The same over the bins lying wholly inside [`from_m`, `to_m`] of arc length
    /// (for example the cut from its first to its last point, or its cruise).
    pub fn summary_within(&self, from_m: f64, to_m: f64) -> Option<DepthSummary> {
        // Bin i is [start + i·bin, start + (i + 1)·bin]; round-off of 1e-9 bin allowed.
        let first = ((from_m - self.start_m) / self.bin_m - EDGE_SLACK)
            .ceil()
            .max(0.0) as usize;
        let end = ((to_m - self.start_m) / self.bin_m + EDGE_SLACK)
            .floor()
            .max(0.0) as usize;
        self.summary_of(first..end.min(self.energy_j_per_m.len()))
    }

    fn summary_of(&self, kept: Range<usize>) -> Option<DepthSummary> {
        let bins = self.energy_j_per_m.get(kept.clone())?;
        if bins.is_empty() {
            return None;
        }
        let nominal = bins.iter().sum::<f64>() / bins.len() as f64;
        if nominal == 0.0 {
            return None;
        }
        let (worst, deviation) = kept.clone().zip(bins).map(|(i, e)| (i, e - nominal)).fold(
            (kept.start, 0.0f64),
            |best, (i, d)| {
                if d.abs() > best.1.abs() {
                    (i, d)
                } else {
                    best
                }
            },
        );
        Some(DepthSummary {
            nominal_j_per_m: nominal,
            max_deviation_pct: 100.0 * deviation / nominal,
            at_m: self.centre_m(worst),
        })
    }
}

/// Summary of an [`EnergyProfile`] over its fully-cut bins.
#[derive(Copy, Clone, Debug, PartialEq)]
pub struct DepthSummary {
    /// Mean energy per length over the bins kept, J/m.
    pub nominal_j_per_m: f64,
    /// Largest deviation from the nominal in %, with its sign (+ deeper).
    pub max_deviation_pct: f64,
    /// Centre of the bin where it occurs, m of arc length (the first such bin).
    pub at_m: f64,
}

/// Bins the energy of a run: `positions_m[k]` → `positions_m[k + 1]` is the motion of
/// period k, `power_w[k]` the power held during it, `ts_s` the period.
///
/// Bin 0 starts at the multiple of `bin_m` at or below the smallest position; the
/// bins run up to the largest. Energy is conserved: [`EnergyProfile::total_j`] equals
/// Σ P_k·Ts to round-off.
pub fn deposit(
    positions_m: &[f64],
    power_w: &[f64],
    ts_s: f64,
    bin_m: f64,
) -> Result<EnergyProfile, DepthError> {
    if positions_m.len() != power_w.len() + 1 || power_w.is_empty() {
        return Err(DepthError::Lengths);
    }
    let samples_ok = positions_m.iter().all(|s| s.is_finite())
        && power_w.iter().all(|p| p.is_finite() && *p >= 0.0)
        && ts_s.is_finite()
        && ts_s > 0.0;
    if !samples_ok {
        return Err(DepthError::BadSample);
    }
    if !(bin_m.is_finite() && bin_m > 0.0) {
        return Err(DepthError::BadBin);
    }
    let lo = positions_m.iter().copied().fold(f64::INFINITY, f64::min);
    let hi = positions_m
        .iter()
        .copied()
        .fold(f64::NEG_INFINITY, f64::max);
    // Whole bins from lo to hi, with 1e-9 bin of slack at both ends so that round-off
    // in summed positions adds no sliver bin (the end bins take those points).
    let first = (lo / bin_m + EDGE_SLACK).floor();
    let count = ((hi - first * bin_m) / bin_m - EDGE_SLACK).ceil().max(1.0);
    if count > MAX_BINS as f64 {
        return Err(DepthError::BadBin);
    }
    let count = count as usize;
    let start_m = first * bin_m;
    let edge = |i: usize| start_m + i as f64 * bin_m;
    // Bin of arc length s (the top edge of the range belongs to the last bin).
    let bin_of = |s: f64| (((s - start_m) / bin_m).floor().max(0.0) as usize).min(count - 1);
    let mut energy_j = vec![0.0; count];
    for (k, &p) in power_w.iter().enumerate() {
        let e = p * ts_s;
        let (a, b) = (positions_m[k], positions_m[k + 1]);
        let (from, to) = (a.min(b), a.max(b));
        // Length of [from, to] inside bin i (≥ 0 also where round-off puts a point a
        // hair across an edge from the bin `bin_of` gives).
        let covered = |i: usize| (edge(i + 1).min(to) - edge(i).max(from)).max(0.0);
        let bins = bin_of(from)..bin_of(to) + 1;
        let total: f64 = bins.clone().map(covered).sum();
        if total > 0.0 {
            // Shares normalized by their own sum: the period's energy is kept exactly.
            for i in bins {
                energy_j[i] += e * covered(i) / total;
            }
        } else {
            energy_j[bin_of(a)] += e;
        }
    }
    Ok(EnergyProfile {
        start_m,
        bin_m,
        energy_j_per_m: energy_j.into_iter().map(|e| e / bin_m).collect(),
    })
}

#[cfg(test)]
mod tests {
    use super::*;

    const TS: f64 = 1e-3;
    const BIN: f64 = 1e-4; // 0.1 mm

    /// Positions at the period boundaries for the speeds of each period.
    fn integrate(speeds_m_s: &[f64]) -> Vec<f64> {
        let mut s = vec![0.0];
        for v in speeds_m_s {
            s.push(s.last().unwrap() + v * TS);
        }
        s
    }

    fn close(a: f64, b: f64, rel: f64) -> bool {
        (a - b).abs() <= rel * b.abs().max(1e-300)
    }

    #[test]
    fn constant_speed_deposits_p_over_v_everywhere() {
        // T's 20 W at 2 mm/s over 2 mm: e = P / v = 10 000 J/m in 20 bins.
        let v = vec![2e-3; 1000];
        let s = integrate(&v);
        let profile = deposit(&s, &vec![20.0; 1000], TS, BIN).unwrap();
        assert_eq!(profile.start_m, 0.0);
        let bins = &profile.energy_j_per_m;
        assert_eq!(bins.len(), 20);
        for (i, e) in bins.iter().enumerate() {
            assert!(close(*e, 10_000.0, 1e-9), "bin {i}: {e}");
        }
        let summary = profile.summary(1).unwrap();
        assert!(close(summary.nominal_j_per_m, 1e4, 1e-9));
        assert!(summary.max_deviation_pct.abs() < 1e-7);
    }

    #[test]
    fn halved_speed_doubles_the_energy_there() {
        // 2 mm/s, then 1 mm/s over [0.8, 1.2) mm, then 2 mm/s to 2 mm.
        let mut v = vec![2e-3; 400];
        v.extend(vec![1e-3; 400]);
        v.extend(vec![2e-3; 400]);
        let s = integrate(&v);
        let profile = deposit(&s, &vec![20.0; v.len()], TS, BIN).unwrap();
        assert_eq!(profile.energy_j_per_m.len(), 20);
        for (i, e) in profile.energy_j_per_m.iter().enumerate() {
            let want = if (8..12).contains(&i) {
                20_000.0
            } else {
                10_000.0
            };
            assert!(close(*e, want, 1e-9), "bin {i}: {e}");
        }
        // Mean over bins 1..19 (18 bins, 4 doubled): 10 000 · 22 / 18.
        let summary = profile.summary(1).unwrap();
        let nominal = 1e4 * 22.0 / 18.0;
        assert!(close(summary.nominal_j_per_m, nominal, 1e-9));
        assert!(close(
            summary.max_deviation_pct,
            100.0 * (2e4 - nominal) / nominal,
            1e-9
        ));
        // One of the four doubled bins (equal to round-off).
        assert!((0.8e-3..1.2e-3).contains(&summary.at_m), "{}", summary.at_m);
    }

    #[test]
    fn a_summary_within_an_arc_keeps_only_whole_bins() {
        // 2 mm/s over 0 → 2 mm, 1 mm/s over [0.8, 1.2) mm: bins 8..12 are doubled.
        let mut v = vec![2e-3; 400];
        v.extend(vec![1e-3; 400]);
        v.extend(vec![2e-3; 400]);
        let profile = deposit(&integrate(&v), &vec![20.0; v.len()], TS, BIN).unwrap();
        // [0.75, 1.25] mm holds bins 8..12 wholly (7 and 12 only in part): all doubled.
        let s = profile.summary_within(0.75e-3, 1.25e-3).unwrap();
        assert!(close(s.nominal_j_per_m, 2e4, 1e-9));
        assert!(s.max_deviation_pct.abs() < 1e-7);
        // Edges on bin boundaries are inclusive (within round-off).
        let s = profile.summary_within(0.0, 0.8e-3).unwrap();
        assert!(close(s.nominal_j_per_m, 1e4, 1e-9) && s.max_deviation_pct.abs() < 1e-7);
        // Less than one bin: nothing to summarize.
        assert_eq!(profile.summary_within(0.81e-3, 0.89e-3), None);
    }

    #[test]
    fn a_dwell_is_a_spike_in_one_bin() {
        // Stop for 50 periods at 1.05 mm (mid-bin 10), beam on.
        let mut v = vec![2e-3; 525];
        v.extend(vec![0.0; 50]);
        v.extend(vec![2e-3; 475]);
        let s = integrate(&v);
        let profile = deposit(&s, &vec![20.0; v.len()], TS, BIN).unwrap();
        assert_eq!(profile.energy_j_per_m.len(), 20);
        for (i, e) in profile.energy_j_per_m.iter().enumerate() {
            // 50 · 20 W · 1 ms = 1 J extra in 0.1 mm: +10 000 J/m.
            let want = if i == 10 { 20_000.0 } else { 10_000.0 };
            assert!(close(*e, want, 1e-9), "bin {i}: {e}");
        }
        let summary = profile.summary(1).unwrap();
        assert!(close(summary.at_m, 1.05e-3, 1e-9));
        assert!(summary.max_deviation_pct > 80.0);
    }

    #[test]
    fn a_stretch_inside_one_bin_and_backward_motion() {
        // 0.02 → 0.05 mm in one period: all in bin 0. Then back 0.05 → 0.15 → 0.05 mm
        // (1 J each way): bin 0 gets 0.5 J + 0.5 J, bin 1 the rest.
        let s = [2e-5, 5e-5, 15e-5, 5e-5];
        let p = [1.0 / TS, 1.0 / TS, 1.0 / TS];
        let profile = deposit(&s, &p, TS, BIN).unwrap();
        assert_eq!(profile.energy_j_per_m.len(), 2);
        assert!(close(profile.energy_j_per_m[0] * BIN, 2.0, 1e-12));
        assert!(close(profile.energy_j_per_m[1] * BIN, 1.0, 1e-12));
        // Negative arc lengths: bins start at a multiple of the bin length below.
        let profile = deposit(&[-1.5e-4, 0.5e-4], &[1.0], 1.0, BIN).unwrap();
        assert_eq!(profile.start_m, -2e-4);
        assert_eq!(profile.energy_j_per_m.len(), 3);
        let joules: Vec<f64> = profile.energy_j_per_m.iter().map(|e| e * BIN).collect();
        for (got, want) in joules.iter().zip([0.25, 0.5, 0.25]) {
            assert!(close(*got, want, 1e-12), "{joules:?}");
        }
    }

    #[test]
    fn energy_is_conserved_on_a_wandering_path() {
        // Deterministic pseudo-random steps, forwards and backwards, with stops.
        let mut x = 0.3_f64;
        let mut s = vec![0.0];
        let mut p = Vec::new();
        for k in 0..5000 {
            x = (x * 3.9 * (1.0 - x)).clamp(1e-6, 1.0 - 1e-6); // logistic map
            let step = if k % 97 == 0 { 0.0 } else { (x - 0.4) * 7e-6 };
            s.push(s.last().unwrap() + step);
            p.push(20.0 * x);
        }
        let profile = deposit(&s, &p, TS, BIN).unwrap();
        let deposited: f64 = p.iter().map(|p| p * TS).sum();
        assert!(close(profile.total_j(), deposited, 1e-12));
        assert!(profile.energy_j_per_m.iter().all(|e| *e >= 0.0));
    }

    #[test]
    fn bad_input_is_refused() {
        let s = [0.0, 1e-4, 2e-4];
        let p = [1.0, 1.0];
        assert_eq!(deposit(&s, &p[..1], TS, BIN), Err(DepthError::Lengths));
        assert_eq!(deposit(&s[..1], &[], TS, BIN), Err(DepthError::Lengths));
        assert_eq!(
            deposit(&[0.0, f64::NAN, 1.0], &p, TS, BIN),
            Err(DepthError::BadSample)
        );
        assert_eq!(
            deposit(&s, &[1.0, -1.0], TS, BIN),
            Err(DepthError::BadSample)
        );
        assert_eq!(deposit(&s, &p, 0.0, BIN), Err(DepthError::BadSample));
        assert_eq!(deposit(&s, &p, TS, 0.0), Err(DepthError::BadBin));
        assert_eq!(deposit(&s, &p, TS, 1e-20), Err(DepthError::BadBin));
        let profile = deposit(&s, &p, TS, BIN).unwrap();
        assert_eq!(profile.summary(5), None);
    }
}
