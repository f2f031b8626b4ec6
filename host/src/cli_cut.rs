//! A part's cut settings on the command line (`kerf plan`, `kerf gcode`, `kerf check`,
//! `kerf run`): speed, laser and passes over what the job file says, and the check that
//! the machine takes the job so before anything is written or sent.

use crate::report::{say, Report};
use crate::Failure;
use kerf::codec::job::JobFile;
use kerf::control::laser::LaserMode;
use kerf::machines::delta_slave::product::{contour_defaults, JOB_LAPS};
use kerf::machines::delta_slave::DeltaSlaveConfig;
use kerf_host::check::{self, kind_words, Checked, Machine};
use kerf_host::job::{split, JobKind};
use kerf_host::job::{with_settings, CutLaser, CutSettings, JobFileError};
use kerf_host::output::OutputFile;

/// The kinds of job that carry cut settings.
const LASER_KINDS: [JobKind; 3] = [JobKind::Efd, JobKind::Points, JobKind::Moves];

/// How the parts are cut, over the job file's own settings (each option replaces the
/// file's for every part; without it the file's stay, and without those the
/// machine's presets apply).
#[derive(Debug, Clone, Default, clap::Args)]
pub struct CutArgs {
    /// Cutting speed along the path, mm/s.
    #[arg(long, value_name = "MM/S")]
    speed_mm_s: Option<f64>,
    /// Constant laser power, W, whatever the speed (grbl's M3).
    #[arg(long, value_name = "W", conflicts_with_all = ["energy_j_per_mm", "beam_off"])]
    power_w: Option<f64>,
    /// Constant energy per length, J/mm: the power follows the speed, so corners and
    /// ramps cut as deep as the straights (grbl's M4).
    #[arg(long, value_name = "J/MM", conflicts_with = "beam_off")]
    energy_j_per_mm: Option<f64>,
    /// The beam off: a dry run along the path.
    #[arg(long)]
    beam_off: bool,
    /// Times each closed contour is cut, one after the other without a stop (1 to 255).
    #[arg(long, value_name = "N", value_parser = clap::value_parser!(u8).range(1..))]
    passes: Option<u8>,
}

/// `value` (as given to `option`) times `scale`, as the file stores it (f32), when
/// `ok` and finite there; else the refusal of `option` in words.
fn stored(option: &str, value: f64, scale: f64, ok: bool, wanted: &str) -> Result<f32, Failure> {
    let v = (value * scale) as f32;
    if ok && v.is_finite() {
        Ok(v)
    } else if ok && value.is_finite() {
        Err(Failure::Input(format!(
            "{option} {value}: too large for the job file (f32)"
        )))
    } else {
        Err(Failure::Input(format!("{option} {value}: {wanted}")))
    }
}

impl CutArgs {
    /// The settings the options give (`MACHINE` fields where none is given).
    ///
    /// Errors: a speed not above zero, a power or energy below zero, or a number the
    /// job file cannot hold.
    pub(crate) fn settings(&self) -> Result<CutSettings, Failure> {
        let speed_m_s = self
            .speed_mm_s
            .map(|v| stored("--speed-mm-s", v, 1e-3, v > 0.0, "a speed above zero, mm/s"))
            .transpose()?;
        let laser = match (self.power_w, self.energy_j_per_mm, self.beam_off) {
            (_, _, true) => Some(CutLaser::Off),
            (Some(w), _, _) => Some(CutLaser::PowerW(stored(
                "--power-w",
                w,
                1.0,
                w >= 0.0,
                "a power of zero or more, W",
            )?)),
            (_, Some(e), _) => Some(CutLaser::EnergyJPerM(stored(
                "--energy-j-per-mm",
                e,
                1e3,
                e >= 0.0,
                "an energy per length of zero or more, J/mm",
            )?)),
            _ => None,
        };
        Ok(CutSettings {
            speed_m_s,
            laser,
            passes: self.passes,
            ..CutSettings::MACHINE
        })
    }
}

/// The program `bytes` with the options' settings over its parts'.
///
/// Errors: an option's value out of range; settings for parts that take none
/// (G-code), prefixed by `name`.
pub(crate) fn apply(name: &str, bytes: &[u8], cut: &CutArgs) -> Result<Vec<u8>, Failure> {
    let settings = cut.settings()?;
    if settings != CutSettings::MACHINE {
        let parts = split(bytes).map_err(|e| Failure::Input(format!("{name}: {e}")))?;
        let kinds = parts
            .iter()
            .filter_map(|p| JobFile::read(p).ok().map(|f| f.kind()));
        if let Some(kind) = kinds.into_iter().find(|k| !LASER_KINDS.contains(k)) {
            return Err(Failure::Input(format!(
                "{name}: a {} job takes no cut settings: --speed-mm-s, --power-w, --energy-j-per-mm, \
                 --beam-off and --passes are for laser parts (EFD, points and moves jobs)",
                kind_words(kind)
            )));
        }
    }
    with_settings(bytes, &settings).map_err(|e| match e {
        JobFileError::Settings => Failure::Input(format!(
            "{name}: {e} (--speed-mm-s, --power-w, --energy-j-per-mm, --beam-off and --passes are for laser parts)"
        )),
        e => Failure::Input(format!("{name}: {e}")),
    })
}

/// The program `bytes` with the options' settings over its parts ([`apply`]), checked
/// for `machine` (the one that takes its kind when `None`) as the machine checks it at
/// load: the bytes to write or send and what the check found.
///
/// Errors: [`apply`]'s; a part the machine would refuse, in its words.
pub(crate) fn settle(
    name: &str,
    bytes: &[u8],
    cut: &CutArgs,
    machine: Option<Machine>,
) -> Result<(Vec<u8>, Checked), Failure> {
    let bytes = apply(name, bytes, cut)?;
    let checked =
        check::check(&bytes, machine).map_err(|e| Failure::Refused(format!("{name}: {e}")))?;
    Ok((bytes, checked))
}

/// Checks the program `bytes` with the options' settings for the laser delta, reports
/// what the machine would do with it, and writes it to `out` when given; a program the
/// machine would refuse is refused here and nothing is written.
pub(crate) fn write_program(
    name: &str,
    bytes: &[u8],
    cut: &CutArgs,
    out: Option<&OutputFile>,
    report: &mut Report,
) -> Result<(), Failure> {
    let shown = out.map_or(name, OutputFile::shown);
    let (bytes, checked) = settle(shown, bytes, cut, Some(Machine::KeopsSlave))?;
    say!(
        report,
        "check      {} takes it: about {:.2} s from start to end, cut {:.1} mm",
        checked.machine.name(),
        checked.duration_s,
        checked.cut_length_m * 1e3
    );
    if let Some(out) = out {
        out.write_bytes(&bytes)?;
        match checked.parts {
            1 => say!(report, "wrote {} ({} bytes)", out.shown(), bytes.len()),
            n => say!(
                report,
                "wrote {} ({n} parts, {} bytes)",
                out.shown(),
                bytes.len()
            ),
        }
    }
    Ok(())
}

/// The kerf offset and the lead-in of closed contours, from the command line.
#[derive(Debug, Clone, Default, clap::Args)]
pub struct KerfArgs {
    /// The width of the cut, mm: closed contours are moved off the drawn line by half
    /// of it, to the scrap's side, so the part comes out the size drawn.
    #[arg(long, value_name = "MM", default_value_t = 0.0)]
    pub kerf_mm: f64,
    /// Which side of the drawn line is scrap: outside an outline and inside its holes
    /// (the part is kept), or the other way (the hole is kept).
    #[arg(long, value_enum, default_value = "outside")]
    pub kerf_side: kerf_host::kerf_offset::KerfSide,
    /// A straight lead-in of this length, mm, from the scrap's side (as --kerf-side
    /// says) to each closed contour's start, so the beam comes on away from the part.
    #[arg(long, value_name = "MM", default_value_t = 0.0)]
    pub lead_in_mm: f64,
}

impl KerfArgs {
    /// Whether a kerf or a lead-in is asked for.
    pub(crate) fn is_set(&self) -> bool {
        self.kerf_mm != 0.0 || self.lead_in_mm != 0.0
    }
}

/// A part's settings in a machinist's words, the machine's own values where the part
/// leaves them to it.
pub(crate) fn settings_words(settings: &CutSettings) -> String {
    // What the Keops slave's loader cuts a part at where the part leaves it.
    let machine = contour_defaults(&DeltaSlaveConfig::KEOPS, JOB_LAPS);
    let machine_speed_m_s = machine.speed_m_s;
    let speed = settings.speed_m_s.map_or(
        format!("{:.1} mm/s (the machine's)", machine_speed_m_s * 1e3),
        |v| format!("{:.1} mm/s", f64::from(v) * 1e3),
    );
    let laser = match (settings.laser, machine.laser()) {
        (
            None,
            LaserMode::ConstantEnergy {
                energy_per_length_j_per_m: e,
            },
        ) => {
            format!("{:.3} J/mm (the machine's)", e * 1e-3)
        }
        (None, LaserMode::ConstantPower { power_w }) => format!("{power_w:.2} W (the machine's)"),
        (None, LaserMode::Off) => "beam off (the machine's)".into(),
        (Some(CutLaser::Off), _) => "beam off".into(),
        (Some(CutLaser::PowerW(w)), _) => format!("{w:.2} W (M3)"),
        (Some(CutLaser::EnergyJPerM(e)), _) => format!("{:.3} J/mm (M4)", f64::from(e) * 1e-3),
    };
    match settings.passes {
        Some(n) if n > 1 => format!("{speed}, {laser}, {n} passes"),
        _ => format!("{speed}, {laser}"),
    }
}

/// The laser parts' settings of the program `bytes`, a line for each run of parts
/// that share them (nothing for other kinds).
pub(crate) fn report_settings(bytes: &[u8], report: &mut Report) {
    let settings: Vec<CutSettings> = split(bytes)
        .unwrap_or_default()
        .iter()
        .filter_map(|p| JobFile::read(p).ok())
        .filter(|f| LASER_KINDS.contains(&f.kind()))
        .map(|f| f.settings())
        .collect();
    let mut first = 0;
    for (k, s) in settings.iter().enumerate() {
        if settings.get(k + 1) == Some(s) {
            continue;
        }
        let parts = match (settings.len(), first == k) {
            (1, _) => String::new(),
            (_, true) => format!("part {}: ", k + 1),
            (_, false) => format!("parts {}-{}: ", first + 1, k + 1),
        };
        say!(report, "settings   {parts}{}", settings_words(s));
        first = k + 1;
    }
}
