//! Telemetry as the host keeps it: samples on the machine's own time base, written as
//! CSV, summarised, and drawn as SVG (plotters).
//!
//! A sample carries the low 32 bits of the machine's period count
//! ([`TelemetrySample::period`]); the log extends it to 64 bits by the forward
//! difference to the previous sample, so a run that crosses the wrap (5 days at
//! 10 kHz) keeps its time axis. Time is `period × period_s` from the machine's hello.
//!
//! The values are the machine's own channels, as it described them
//! ([`crate::description`]): the CSV has a column per channel, and the summary and the
//! picture use the channels a machine has — the path from `x`, `y` and `x_ref`,
//! `y_ref`, the tracking error from `error`, the forces from every channel in N, the
//! laser from `laser` (with the path, the energy per length); a machine without them
//! gets the panels it has.

use crate::description::ChannelInfo;
use crate::output::OutputFile;
use crate::plot::{dashed, err, legend, line, PlotError};
use kerf::codec::link::{ModeCode, TelemetrySample};
use plotters::prelude::*;
use std::io::Write;
use std::path::Path;

/// Slowest measured speed at which [`TelemetryLog::energy_per_length`] counts a
/// sample, m/s (0.5 mm/s).
pub const ENERGY_MIN_SPEED_M_S: f64 = 5e-4;

/// One sample on the host's time axis.
#[derive(Clone, Debug, PartialEq)]
pub struct Entry {
    /// The machine's period count, extended past the wire's 32 bits.
    pub period: u64,
    /// `period × period_s`, s.
    pub time_s: f64,
    /// The sample.
    pub sample: TelemetrySample,
}

/// The samples of a run.
#[derive(Clone, Debug, Default)]
pub struct TelemetryLog {
    period_s: f64,
    channels: Vec<ChannelInfo>,
    entries: Vec<Entry>,
    /// Index of the first entry that cut.
    cut_start: Option<usize>,
    marks: Vec<(f64, String)>,
    /// The path's plane, indices of x, y, z.
    plane: [usize; 2],
}

impl TelemetryLog {
    /// An empty log for a machine with control period `period_s` and telemetry
    /// `channels`.
    pub fn new(period_s: f64, channels: &[ChannelInfo]) -> Self {
        Self {
            period_s,
            channels: channels.to_vec(),
            entries: Vec::new(),
            cut_start: None,
            marks: Vec::new(),
            plane: [0, 1],
        }
    }

    /// The log drawing its path in `plane` (indices of x, y, z,
    /// [`crate::check::Machine::path_plane`]) instead of x and y.
    pub fn with_plane(mut self, plane: [usize; 2]) -> Self {
        self.plane = plane;
        self
    }

    /// Marks the time of the latest sample with `label` (a setting changed, a
    /// fault): drawn as a vertical line.
    pub fn mark(&mut self, label: &str) {
        let t = self.entries.last().map_or(0.0, |e| e.time_s);
        self.marks.push((t, label.to_owned()));
    }

    /// The marks: time (s) and label.
    pub fn marks(&self) -> &[(f64, String)] {
        &self.marks
    }

    /// Adds a sample; its period is extended from the previous one's.
    pub fn push(&mut self, sample: TelemetrySample) -> &Entry {
        let period = match self.entries.last() {
            None => u64::from(sample.period),
            Some(last) => last.period + u64::from(sample.period.wrapping_sub(last.period as u32)),
        };
        if self.cut_start.is_none() && sample.mode == ModeCode::Running {
            self.cut_start = Some(self.entries.len());
        }
        self.entries.push(Entry {
            period,
            time_s: period as f64 * self.period_s,
            sample,
        });
        let n = self.entries.len();
        &self.entries[n - 1]
    }

    /// Machine time of the latest sample, s; 0 before the first.
    pub fn latest_s(&self) -> f64 {
        self.entries.last().map_or(0.0, |e| e.time_s)
    }

    /// Machine time from the first sample that cut ([`ModeCode::Running`]) to the
    /// latest, s; 0 before the cut.
    pub fn since_cut_s(&self) -> f64 {
        let first = self.cut_start.and_then(|k| self.entries.get(k));
        match (first, self.entries.last()) {
            (Some(a), Some(b)) => b.time_s - a.time_s,
            _ => 0.0,
        }
    }

    /// The samples.
    pub fn entries(&self) -> &[Entry] {
        &self.entries
    }

    /// The telemetry channels.
    pub fn channels(&self) -> &[ChannelInfo] {
        &self.channels
    }

    /// The value of channel `name` in `entry` (`None`: no such channel, or a sample
    /// without it).
    pub fn value(&self, entry: &Entry, name: &str) -> Option<f64> {
        let k = self.channels.iter().position(|c| c.name == name)?;
        entry.sample.values.get(k).map(|v| f64::from(*v))
    }

    /// The energy the beam put into each length of the cut, J/mm, over time (s):
    /// between each two samples with the beam on, the power of the second over the
    /// speed of the measured effector between them (from `x`, `y` and `laser`; none
    /// without them). Below [`ENERGY_MIN_SPEED_M_S`] the quotient says nothing (the
    /// beam fades with the speed at constant energy per length), and is left out.
    pub fn energy_per_length(&self) -> Vec<(f64, f64)> {
        self.entries
            .windows(2)
            .filter_map(|w| {
                let power_w = self.value(&w[1], "laser")?;
                let dt = w[1].time_s - w[0].time_s;
                let dx = self.value(&w[1], "x")? - self.value(&w[0], "x")?;
                let dy = self.value(&w[1], "y")? - self.value(&w[0], "y")?;
                let speed = dx.hypot(dy) / dt;
                (power_w > 0.0 && dt > 0.0 && speed >= ENERGY_MIN_SPEED_M_S)
                    .then(|| (w[1].time_s, power_w / speed * 1e-3))
            })
            .collect()
    }

    /// Whether the machine has a laser channel.
    fn has_laser(&self) -> bool {
        self.channels.iter().any(|c| c.name == "laser")
    }

    /// The indices of the channels in `unit`.
    fn in_unit(&self, unit: &str) -> Vec<usize> {
        (0..self.channels.len())
            .filter(|&k| self.channels[k].unit == unit)
            .collect()
    }

    /// Writes the log as CSV: a header row (period, time, mode, then a column per
    /// channel: [`ChannelInfo::column`]), then one row per sample (SI units).
    pub fn write_csv(&self, out: &mut dyn Write) -> std::io::Result<()> {
        let columns: Vec<String> = self.channels.iter().map(ChannelInfo::column).collect();
        writeln!(out, "period,time_s,mode,{}", columns.join(","))?;
        for e in &self.entries {
            write!(out, "{},{:.6},{:?}", e.period, e.time_s, e.sample.mode)?;
            for k in 0..self.channels.len() {
                match e.sample.values.get(k) {
                    Some(v) => write!(out, ",{v:e}")?,
                    None => write!(out, ",")?,
                }
            }
            writeln!(out)?;
        }
        Ok(())
    }

    /// What a run did while it cut (samples in [`ModeCode::Running`]).
    pub fn summary(&self) -> Summary {
        let running: Vec<&Entry> = self
            .entries
            .iter()
            .filter(|e| e.sample.mode == ModeCode::Running)
            .collect();
        let n = running.len();
        let errors = running
            .iter()
            .map(|e| self.value(e, "error").unwrap_or(0.0));
        let error_max_m = errors.clone().map(f64::abs).fold(0.0, f64::max);
        let error_rms_m = if n == 0 {
            0.0
        } else {
            (errors.map(|e| e * e).sum::<f64>() / n as f64).sqrt()
        };
        let forces = self.in_unit("N");
        let force_peak_n = running
            .iter()
            .flat_map(|e| forces.iter().filter_map(|&k| e.sample.values.get(k)))
            .map(|f| f64::from(*f).abs())
            .fold(0.0, f64::max);
        let laser_mean_w = if n == 0 {
            0.0
        } else {
            running
                .iter()
                .map(|e| self.value(e, "laser").unwrap_or(0.0))
                .sum::<f64>()
                / n as f64
        };
        let cut_s = match (running.first(), running.last()) {
            (Some(a), Some(b)) => b.time_s - a.time_s,
            _ => 0.0,
        };
        let mut energy: Vec<f64> = self.energy_per_length().iter().map(|e| e.1).collect();
        energy.sort_by(f64::total_cmp);
        let energy_median_j_per_mm = energy.get(energy.len() / 2).copied();
        Summary {
            samples: self.entries.len(),
            cutting_samples: n,
            cut_s,
            error_max_m,
            error_rms_m,
            force_peak_n,
            laser_mean_w,
            energy_median_j_per_mm,
            has: Channels {
                error: self.channels.iter().any(|c| c.name == "error"),
                forces: !forces.is_empty(),
                laser: self.channels.iter().any(|c| c.name == "laser"),
            },
        }
    }

    /// Draws the run: the path (measured over reference, mm), the contour error
    /// (µm), the three force commands (N) and, for a laser, the energy per length
    /// (J/mm, [`TelemetryLog::energy_per_length`]) over time, with the marks as
    /// vertical lines.
    pub fn write_svg(&self, path: &Path, title: &str) -> Result<(), PlotError> {
        let text = self.svg(title)?;
        OutputFile::prepare(path, "picture")
            .and_then(|f| f.write_bytes(text.as_bytes()))
            .map_err(PlotError::from)
    }

    /// The picture of [`TelemetryLog::write_svg`] as SVG text.
    pub fn svg(&self, title: &str) -> Result<String, PlotError> {
        let mut text = String::new();
        let height = if self.has_laser() { 1350 } else { 1100 };
        self.draw(
            SVGBackend::with_string(&mut text, (900, height)).into_drawing_area(),
            title,
        )?;
        Ok(text)
    }

    fn draw<DB: DrawingBackend>(
        &self,
        root: DrawingArea<DB, plotters::coord::Shift>,
        title: &str,
    ) -> Result<(), PlotError> {
        // The cut's start marked on the machine's time axis, with the run's marks.
        let cut = self.cut_start.and_then(|k| self.entries.get(k));
        let marks: Vec<(f64, String)> = cut
            .map(|e| (e.time_s, "cut starts".to_owned()))
            .into_iter()
            .chain(self.marks.iter().cloned())
            .collect();
        let marks = &marks;
        root.fill(&WHITE).map_err(err)?;
        let root = root.titled(title, ("sans-serif", 20)).map_err(err)?;
        let (top, bottom) = root.split_vertically(560);
        let (mid, low) = bottom.split_vertically(250);
        let (low, laser) = low.split_vertically(250);
        self.draw_path(&top)?;
        let t = |e: &Entry| e.time_s;
        let span = self.entries.first().map_or(0.0, t)..self.entries.last().map_or(1.0, t);
        // The errors: every channel in m whose name ends in `error` (the Keops
        // slave's contour error, ARROW's largest joint error).
        let error_channels: Vec<usize> = (0..self.channels.len())
            .filter(|&k| self.channels[k].unit == "m" && self.channels[k].name.ends_with("error"))
            .collect();
        let errors: Vec<Vec<(f64, f64)>> = error_channels
            .iter()
            .map(|&k| {
                self.entries
                    .iter()
                    .filter_map(|e| Some((e.time_s, f64::from(*e.sample.values.get(k)?) * 1e6)))
                    .collect()
            })
            .collect();
        let error_series: Vec<Series<'_>> = error_channels
            .iter()
            .zip(&errors)
            .map(|(&k, points)| Series {
                label: &self.channels[k].name,
                points,
                color: RGBColor(213, 94, 0),
            })
            .collect();
        draw_series(&mid, span.clone(), "error, µm", &error_series, marks)?;
        let colors = [
            RGBColor(0, 114, 178),
            RGBColor(0, 158, 115),
            RGBColor(204, 121, 167),
        ];
        let force_channels = self.in_unit("N");
        let forces: Vec<Vec<(f64, f64)>> = force_channels
            .iter()
            .map(|&k| {
                self.entries
                    .iter()
                    .filter_map(|e| Some((e.time_s, f64::from(*e.sample.values.get(k)?))))
                    .collect()
            })
            .collect();
        let series: Vec<Series<'_>> = force_channels
            .iter()
            .zip(&forces)
            .enumerate()
            .map(|(i, (&k, points))| Series {
                label: &self.channels[k].name,
                points,
                color: colors[i % colors.len()],
            })
            .collect();
        draw_series(&low, span.clone(), "force command, N", &series, marks)?;
        if self.has_laser() {
            // One line per stretch with the beam on: not drawn across the travels.
            let energy = self.energy_per_length();
            let step = energy
                .windows(2)
                .map(|w| w[1].0 - w[0].0)
                .fold(f64::INFINITY, f64::min);
            let series: Vec<Series<'_>> = energy
                .chunk_by(|a, b| b.0 - a.0 <= 3.0 * step)
                .enumerate()
                .map(|(k, points)| Series {
                    label: if k == 0 {
                        "power over measured speed"
                    } else {
                        ""
                    },
                    points,
                    color: RGBColor(230, 159, 0),
                })
                .collect();
            draw_series(&laser, span, "energy per length, J/mm", &series, marks)?;
        }
        root.present().map_err(err)?;
        Ok(())
    }

    /// The path drawn: the names of its plane's axes, the measured points and the
    /// reference's runs (mm), each marked whether the tool cut along it (a laser's
    /// beam on; a machine without a laser channel cuts all along), of the samples
    /// while the machine moves along its job (at rest it reports no reference, zeros,
    /// which the tool never travelled to). A run shares its first point with the end
    /// of the one before, so the runs join.
    fn path_mm(&self) -> ([&'static str; 2], PathMm, Vec<(bool, PathMm)>) {
        let moving = self
            .entries
            .iter()
            .filter(|e| matches!(e.sample.mode, ModeCode::Running | ModeCode::Stopping));
        let [a, b] = self
            .plane
            .map(|k| ["x", "y", "z"].get(k).copied().unwrap_or("x"));
        let mm =
            |e: &Entry, x: &str, y: &str| Some((self.value(e, x)? * 1e3, self.value(e, y)? * 1e3));
        let (a_ref, b_ref) = (format!("{a}_ref"), format!("{b}_ref"));
        let measured = moving.clone().filter_map(|e| mm(e, a, b)).collect();
        let mut runs: Vec<(bool, PathMm)> = Vec::new();
        for e in moving {
            let Some(p) = mm(e, &a_ref, &b_ref) else {
                continue;
            };
            let cutting = self.value(e, "laser").is_none_or(|w| w > 0.0);
            match runs.last_mut() {
                Some((c, run)) if *c == cutting => run.push(p),
                last => {
                    let join = last.and_then(|(_, run)| run.last().copied());
                    runs.push((cutting, join.into_iter().chain([p]).collect()));
                }
            }
        }
        ([a, b], measured, runs)
    }

    fn draw_path<DB: DrawingBackend>(
        &self,
        area: &DrawingArea<DB, plotters::coord::Shift>,
    ) -> Result<(), PlotError> {
        let ([a, b], measured, runs) = self.path_mm();
        let reference = runs.iter().flat_map(|(_, run)| run);
        let (lo, hi) = measured.iter().chain(reference).fold(
            ([f64::INFINITY; 2], [f64::NEG_INFINITY; 2]),
            |(lo, hi), p| {
                (
                    [lo[0].min(p.0), lo[1].min(p.1)],
                    [hi[0].max(p.0), hi[1].max(p.1)],
                )
            },
        );
        let (a_words, b_words) = (format!("{a}, mm"), format!("{b}, mm"));
        let axes = [a_words.as_str(), b_words.as_str()];
        let mut chart = crate::plot::workspace_chart(area, None, axes, lo, hi, 1.05)?;
        let grey = RGBColor(120, 120, 120);
        let (mut cut_label, mut travel_label) = ("reference", "travel, beam off");
        for (cutting, run) in &runs {
            let points = run.iter().copied();
            if *cutting {
                line(&mut chart, points, std::mem::take(&mut cut_label), grey, 4)?;
            } else {
                dashed(
                    &mut chart,
                    points,
                    std::mem::take(&mut travel_label),
                    grey,
                    2,
                )?;
            }
        }
        // A machine that reports no measured position (ARROW) has no such line.
        if !measured.is_empty() {
            let blue = RGBColor(0, 114, 178);
            line(&mut chart, measured.iter().copied(), "measured", blue, 1)?;
        }
        legend(&mut chart)
    }
}

/// Points of a path in its plane, mm.
type PathMm = Vec<(f64, f64)>;

/// A line of a panel.
struct Series<'a> {
    label: &'a str,
    points: &'a [(f64, f64)],
    color: RGBColor,
}

/// A label row's share of a panel's height (a 12 px label on a panel of some 200).
const LABEL_ROW_SHARE: f64 = 0.07;

/// Width of a label's character, px (12 px sans-serif), with room after it.
const LABEL_CHAR_PX: f64 = 6.5;

/// The row of each mark's label (0 the top), so that no two labels of a row overlap:
/// each goes to the first row whose last label ends before it starts, given a time
/// axis `span_s` wide over `width_px`. When every row is taken (marks crowded into
/// less than a label's width), the row whose label ends first is reused.
fn label_rows(marks: &[(f64, String)], span_s: f64, width_px: f64) -> Vec<usize> {
    const ROWS: usize = 8;
    let s_per_px = if span_s > 0.0 && width_px > 0.0 {
        span_s / width_px
    } else {
        0.0
    };
    let mut ends = [f64::NEG_INFINITY; ROWS];
    let mut order: Vec<usize> = (0..marks.len()).collect();
    order.sort_by(|&a, &b| marks[a].0.total_cmp(&marks[b].0));
    let mut rows = vec![0; marks.len()];
    for i in order {
        let (t, label) = &marks[i];
        let width_s = (label.chars().count() as f64 + 1.0) * LABEL_CHAR_PX * s_per_px;
        let row = (0..ROWS).find(|&r| ends[r] <= *t).unwrap_or_else(|| {
            (0..ROWS)
                .min_by(|&a, &b| ends[a].total_cmp(&ends[b]))
                .unwrap_or(0)
        });
        ends[row] = t + width_s;
        rows[i] = row;
    }
    rows
}

/// One panel of time series, with vertical marks.
fn draw_series<DB: DrawingBackend>(
    area: &DrawingArea<DB, plotters::coord::Shift>,
    span: std::ops::Range<f64>,
    y_desc: &str,
    series: &[Series<'_>],
    marks: &[(f64, String)],
) -> Result<(), PlotError> {
    let (lo, hi) = series
        .iter()
        .flat_map(|s| s.points.iter())
        .fold((f64::INFINITY, f64::NEG_INFINITY), |(lo, hi), p| {
            (lo.min(p.1), hi.max(p.1))
        });
    let (lo, hi) = if lo.is_finite() && hi > lo {
        (lo - 0.05 * (hi - lo), hi + 0.05 * (hi - lo))
    } else {
        (-1.0, 1.0)
    };
    let span = if span.end > span.start {
        span
    } else {
        0.0..1.0
    };
    let mut chart = ChartBuilder::on(area)
        .margin(10)
        .x_label_area_size(40)
        .y_label_area_size(50)
        .build_cartesian_2d(span.clone(), lo..hi)
        .map_err(err)?;
    chart
        .configure_mesh()
        .x_desc("machine time, s")
        .y_desc(y_desc)
        .draw()
        .map_err(err)?;
    let (width_px, _) = area.dim_in_pixel();
    let rows = label_rows(marks, span.end - span.start, f64::from(width_px));
    for ((t, label), row) in marks.iter().zip(rows) {
        let grey = RGBColor(90, 90, 90);
        chart
            .draw_series(std::iter::once(PathElement::new(
                [(*t, lo), (*t, hi)],
                grey.stroke_width(1),
            )))
            .map_err(err)?;
        // Rows from the top down, a label's height apart.
        let y = hi - (hi - lo) * LABEL_ROW_SHARE * row as f64;
        chart
            .draw_series(std::iter::once(Text::new(
                label.clone(),
                (*t, y),
                ("sans-serif", 12).into_font().color(&grey),
            )))
            .map_err(err)?;
    }
    for s in series {
        line(&mut chart, s.points.iter().copied(), s.label, s.color, 1)?;
    }
    legend(&mut chart)
}

/// What a run did while cutting.
#[derive(Copy, Clone, Debug, PartialEq)]
pub struct Summary {
    /// Samples logged.
    pub samples: usize,
    /// Of them, while cutting.
    pub cutting_samples: usize,
    /// From the first to the last cutting sample, s.
    pub cut_s: f64,
    /// Largest contour error while cutting, m.
    pub error_max_m: f64,
    /// Its RMS, m.
    pub error_rms_m: f64,
    /// Largest force command while cutting, N.
    pub force_peak_n: f64,
    /// Mean laser power while cutting, W.
    pub laser_mean_w: f64,
    /// The median of [`TelemetryLog::energy_per_length`], J/mm (`None`: no sample
    /// with the beam on and moving).
    pub energy_median_j_per_mm: Option<f64>,
    /// Which of these the machine's channels carry (the others are 0).
    pub has: Channels,
}

/// Which figures of a [`Summary`] the machine's channels carry.
#[derive(Copy, Clone, Debug, PartialEq, Eq)]
pub struct Channels {
    /// A tracking (contour) error, `error`.
    pub error: bool,
    /// Forces (channels in N).
    pub forces: bool,
    /// A laser, `laser`.
    pub laser: bool,
}

impl std::fmt::Display for Summary {
    /// The figures the machine's channels carry, in the order error, force, laser.
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        write!(
            f,
            "{} samples ({} while cutting, {:.3} s)",
            self.samples, self.cutting_samples, self.cut_s,
        )?;
        let mut parts = Vec::new();
        if self.has.error {
            parts.push(format!(
                "contour error max {:.3} µm, rms {:.3} µm",
                self.error_max_m * 1e6,
                self.error_rms_m * 1e6
            ));
        }
        if self.has.forces {
            parts.push(format!("force peak {:.2} N", self.force_peak_n));
        }
        if self.has.laser {
            parts.push(format!("laser mean {:.2} W", self.laser_mean_w));
        }
        if let Some(e) = self.energy_median_j_per_mm {
            parts.push(format!("energy per length median {e:.3} J/mm"));
        }
        if !parts.is_empty() {
            write!(f, ": {}", parts.join("; "))?;
        }
        Ok(())
    }
}

#[cfg(test)]
mod tests;
