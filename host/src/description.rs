//! What a machine says of itself over the link ([`kerf::codec::link::Description`]):
//! its telemetry channels, job kinds, settings and the words for its codes. The host
//! holds no table of its own for any machine; everything it prints about one comes
//! from here, or from the link's own codes that every machine shares (board faults,
//! the link's job refusals).

use kerf::codec::link::{
    board_fault, CodeWords, Description, Event, JobKind, ModeCode, Refusal, SettingsOrigin,
    LINK_JOB_REFUSALS, VERSION,
};

/// A telemetry channel.
#[derive(Clone, Debug, PartialEq, Eq)]
pub struct ChannelInfo {
    /// Name (`x`, `force1`).
    pub name: String,
    /// Unit (`m`, `N`; `1` for a plain number).
    pub unit: String,
}

impl ChannelInfo {
    /// The CSV column of the channel: its name and unit (`x_m`, `force1_n`); a plain
    /// number has its name alone.
    pub fn column(&self) -> String {
        if self.unit.is_empty() || self.unit == "1" {
            self.name.clone()
        } else {
            format!(
                "{}_{}",
                self.name,
                self.unit.to_lowercase().replace('/', "_per_")
            )
        }
    }
}

/// A setting.
#[derive(Clone, Debug, PartialEq, Eq)]
pub struct SettingInfo {
    /// Its path.
    pub path: String,
    /// Its unit (empty for a switch).
    pub unit: String,
    /// The values the machine takes, in words (empty: any of its type).
    pub range: String,
    /// The value it starts with when nothing is saved, as `get` prints it.
    pub preset: String,
}

impl SettingInfo {
    /// The setting as JSON for scripts and the console: `{path, value, preset, unit,
    /// range}`, values as the machine gives them (a number, true or false; text the
    /// machine gave that is not JSON as a string), `value` omitted when not read.
    pub fn json(&self, value: Option<&str>) -> serde_json::Value {
        let parsed = |text: &str| {
            serde_json::from_str::<serde_json::Value>(text)
                .unwrap_or_else(|_| serde_json::Value::String(text.to_owned()))
        };
        let mut item = serde_json::json!({
            "path": self.path,
            "preset": parsed(&self.preset),
            "unit": self.unit,
            "range": self.range,
        });
        if let (Some(value), Some(map)) = (value, item.as_object_mut()) {
            map.insert("value".into(), parsed(value));
        }
        item
    }
}

/// A code and its words.
#[derive(Clone, Debug, PartialEq, Eq)]
pub struct Words {
    /// The code.
    pub code: u16,
    /// What it means.
    pub words: String,
    /// What a fault's detail holds (empty: nothing).
    pub detail: String,
}

/// One item of a machine's description ([`Description`]), owned.
#[derive(Clone, Debug, PartialEq, Eq)]
pub enum Item {
    /// A telemetry channel.
    Channel(ChannelInfo),
    /// A job kind.
    JobKind(JobKind),
    /// A setting.
    Setting(SettingInfo),
    /// A fault code.
    Fault(Words),
    /// A job refusal code.
    JobRefusal(Words),
}

impl Item {
    /// The item of `d`.
    pub fn of(d: &Description<'_>) -> Self {
        let words = |code, words: &str, detail: &str| Words {
            code,
            words: words.to_owned(),
            detail: detail.to_owned(),
        };
        match *d {
            Description::Channel { name, unit } => Self::Channel(ChannelInfo {
                name: name.to_owned(),
                unit: unit.to_owned(),
            }),
            Description::JobKind(kind) => Self::JobKind(kind),
            Description::Setting {
                path,
                unit,
                range,
                preset,
            } => Self::Setting(SettingInfo {
                path: path.to_owned(),
                unit: unit.to_owned(),
                range: range.to_owned(),
                preset: preset.to_owned(),
            }),
            Description::Fault {
                code,
                words: w,
                detail,
            } => Self::Fault(words(code, w, detail)),
            Description::JobRefusal { code, words: w } => Self::JobRefusal(words(code, w, "")),
        }
    }
}

/// Everything a machine described.
#[derive(Clone, Debug, Default, PartialEq, Eq)]
pub struct MachineDescription {
    /// Telemetry channels, in the order of a sample's values.
    pub channels: Vec<ChannelInfo>,
    /// Job kinds it takes.
    pub job_kinds: Vec<JobKind>,
    /// Settings.
    pub settings: Vec<SettingInfo>,
    /// Its fault codes.
    pub faults: Vec<Words>,
    /// Its job refusal codes.
    pub job_refusals: Vec<Words>,
}

impl MachineDescription {
    /// Adds one item of the description.
    pub fn add(&mut self, item: &Item) {
        match item {
            Item::Channel(c) => self.channels.push(c.clone()),
            Item::JobKind(kind) => self.job_kinds.push(*kind),
            Item::Setting(s) => self.settings.push(s.clone()),
            Item::Fault(w) => self.faults.push(w.clone()),
            Item::JobRefusal(w) => self.job_refusals.push(w.clone()),
        }
    }

    /// The index of channel `name` in a sample's values.
    pub fn channel(&self, name: &str) -> Option<usize> {
        self.channels.iter().position(|c| c.name == name)
    }

    /// The setting at `path`.
    pub fn setting(&self, path: &str) -> Option<&SettingInfo> {
        self.settings.iter().find(|s| s.path == path)
    }

    /// The settings at or under `path`: the one setting of that path, or every
    /// setting of the branch (`/slave/dob` holds `/slave/dob/bandwidth_hz`, not
    /// `/slave/dobx`; `/` holds them all), in the machine's order.
    pub fn settings_under(&self, path: &str) -> Vec<&SettingInfo> {
        if let Some(one) = self.setting(path) {
            return vec![one];
        }
        let branch = path.trim_end_matches('/');
        self.settings
            .iter()
            .filter(|s| {
                s.path
                    .strip_prefix(branch)
                    .is_some_and(|rest| rest.starts_with('/'))
            })
            .collect()
    }

    /// A fault (code and detail) in words: the machine's own, or the board's.
    pub fn fault_words(&self, code: u16, detail: u16) -> String {
        if let Some(reason) = board_fault::reason(code) {
            return match board_fault::detail(code) {
                Some(what) => format!("{reason} ({what} {detail})"),
                None => reason.to_owned(),
            };
        }
        match self.faults.iter().find(|f| f.code == code) {
            Some(f) if f.detail.is_empty() => f.words.clone(),
            Some(f) => format!("{} ({} {detail})", f.words, f.detail),
            None => format!("fault {code} (detail {detail}), which the machine does not describe"),
        }
    }

    /// An event as the operator reads it (a fault in the machine's words).
    pub fn event_words(&self, event: &Event) -> String {
        match *event {
            Event::Mode { from, to } => format!("mode {} -> {}", mode_words(from), mode_words(to)),
            Event::Fault { code, detail } => {
                format!("fault {code}: {}", self.fault_words(code, detail))
            }
            Event::HostLost => "the machine lost the host".to_owned(),
            Event::NextJob => "the next part begins".to_owned(),
            Event::VersionRefused { version } => format!(
                "the machine refused a frame of link version {version} (it speaks {VERSION})"
            ),
        }
    }

    /// A job refusal code in words: the machine's own, or the link's.
    pub fn job_refusal_words(&self, code: u16) -> String {
        if let Some(r) = self.job_refusals.iter().find(|r| r.code == code) {
            return r.words.clone();
        }
        match CodeWords::find(&LINK_JOB_REFUSALS, code) {
            Some(r) => r.words.to_owned(),
            None => "a refusal the machine does not describe".to_owned(),
        }
    }

    /// A refusal in words; a refused setting names the range the machine announced.
    pub fn refusal_words(&self, refusal: &Refusal, path: Option<&str>) -> String {
        match refusal {
            Refusal::ChunkOffset { expected } => {
                format!("the machine expects the chunk at byte {expected}")
            }
            Refusal::TooLarge => "the job is larger than the machine holds".into(),
            Refusal::Incomplete => {
                "the uploaded bytes do not match the announced size or CRC".into()
            }
            Refusal::NoJob => "no upload in progress, or no job loaded".into(),
            Refusal::Job(code) => {
                format!("job code {code:#06x}: {}", self.job_refusal_words(*code))
            }
            Refusal::InvalidInMode => "not in the machine's present mode".into(),
            Refusal::NoStore => {
                "this machine keeps no settings across resets (its presets at power-up)".into()
            }
            Refusal::StoreFailed => {
                "the machine could not write its settings (the copy saved before is kept)".into()
            }
            Refusal::UnknownPath => {
                let paths: Vec<&str> = self.settings.iter().map(|s| s.path.as_str()).collect();
                format!(
                    "no setting at that path (the machine has {})",
                    paths.join(", ")
                )
            }
            Refusal::BadValue => match path.and_then(|p| self.setting(p)) {
                Some(s) if !s.range.is_empty() => format!(
                    "the value is refused: {} takes {}{}",
                    s.path,
                    s.range,
                    if s.unit.is_empty() {
                        String::new()
                    } else {
                        format!(" {}", s.unit)
                    }
                ),
                _ => "the value does not parse or fails the configuration's validation".into(),
            },
            Refusal::Busy => "the machine's command queue is full; try again".into(),
        }
    }
}

/// Where the machine's settings came from at power-up, in words.
pub fn settings_origin_words(origin: SettingsOrigin) -> String {
    let skipped = |n: u16| match n {
        0 => String::new(),
        1 => " (1 value it no longer takes left at its preset)".into(),
        n => format!(" ({n} values it no longer takes left at their presets)"),
    };
    match origin {
        SettingsOrigin::NoStore => "its presets: this machine keeps no settings".into(),
        SettingsOrigin::Presets => "its presets: never saved".into(),
        SettingsOrigin::Saved {
            sequence,
            skipped: n,
        } => {
            format!("saved (copy {sequence}){}", skipped(n))
        }
        SettingsOrigin::FellBack {
            sequence,
            skipped: n,
        } => format!(
            "the copy before the last save (copy {sequence}): the last save was cut short{}",
            skipped(n)
        ),
        SettingsOrigin::Damaged => "its presets: the saved settings are damaged".into(),
    }
}

/// A mode as the operator reads it.
pub fn mode_words(mode: ModeCode) -> &'static str {
    match mode {
        ModeCode::Idle => "idle",
        ModeCode::Calibrating => "calibrating",
        ModeCode::Ready => "ready",
        ModeCode::Running => "running",
        ModeCode::Stopping => "stopping",
        ModeCode::Fault => "fault",
    }
}

/// A job kind as the operator reads it (what `kerf` makes of it).
pub fn job_kind_words(kind: JobKind) -> &'static str {
    match kind {
        JobKind::Efd => "closed contours (EFD)",
        JobKind::Points => "open paths (points)",
        JobKind::Gcode => "G-code programs",
        JobKind::Recording => "recorded master sessions",
        JobKind::Schedule => "setpoint schedules",
        JobKind::Moves => "programs of straight moves (sharp corners)",
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use kerf::codec::link::{BOARD_FAULT, JOB_NOT_AT_REST};

    fn described() -> MachineDescription {
        let mut d = MachineDescription::default();
        for item in [
            Description::Channel {
                name: "x",
                unit: "m",
            },
            Description::Channel {
                name: "count",
                unit: "1",
            },
            Description::Channel {
                name: "feed",
                unit: "m/s",
            },
            Description::JobKind(JobKind::Efd),
            Description::Setting {
                path: "/dob/bandwidth_hz",
                unit: "Hz",
                range: "> 0 and ≤ 3183",
                preset: "150.0",
            },
            Description::Fault {
                code: 5,
                words: "a carriage fell behind",
                detail: "carriage",
            },
            Description::Fault {
                code: 4,
                words: "the effector left the contour",
                detail: "",
            },
            Description::JobRefusal {
                code: 3,
                words: "a move leaves the workspace",
            },
        ] {
            d.add(&Item::of(&item));
        }
        d
    }

    #[test]
    fn where_the_settings_came_from_is_said_in_words() {
        let words = |o| settings_origin_words(o);
        assert_eq!(words(SettingsOrigin::Presets), "its presets: never saved");
        assert_eq!(
            words(SettingsOrigin::Saved {
                sequence: 3,
                skipped: 0
            }),
            "saved (copy 3)"
        );
        assert_eq!(
            words(SettingsOrigin::Saved {
                sequence: 3,
                skipped: 2
            }),
            "saved (copy 3) (2 values it no longer takes left at their presets)"
        );
        assert!(words(SettingsOrigin::FellBack {
            sequence: 7,
            skipped: 1
        })
        .starts_with(
            "the copy before the last save (copy 7): the last save was cut short (1 value"
        ));
        assert!(words(SettingsOrigin::Damaged).contains("damaged"));
        assert!(words(SettingsOrigin::NoStore).contains("keeps no settings"));
    }

    /// A setting as scripts read it: value and preset as JSON numbers or switches, text
    /// that is not JSON kept as a string, no `value` where none was read.
    #[test]
    fn a_setting_as_json_keeps_the_machines_values() {
        let info = SettingInfo {
            path: "/dob/bandwidth_hz".into(),
            unit: "Hz".into(),
            range: "> 0".into(),
            preset: "150.0".into(),
        };
        let read = info.json(Some("120.5"));
        assert_eq!(read["value"], 120.5);
        assert_eq!(read["preset"], 150.0);
        assert_eq!(read["unit"], "Hz");
        assert_eq!(read["range"], "> 0");
        assert!(info.json(None).get("value").is_none());
        assert_eq!(info.json(Some("not json"))["value"], "not json");
        let switch = SettingInfo {
            preset: "true".into(),
            ..info
        };
        assert_eq!(switch.json(Some("false"))["preset"], true);
    }

    #[test]
    fn a_branch_holds_the_settings_below_it_only() {
        let mut d = MachineDescription::default();
        for path in [
            "/slave/dob/bandwidth_hz",
            "/slave/dobx",
            "/slave/kp",
            "/link/hold_s",
        ] {
            d.add(&Item::of(&Description::Setting {
                path,
                unit: "",
                range: "",
                preset: "0",
            }));
        }
        let paths = |p: &str| -> Vec<String> {
            d.settings_under(p).iter().map(|s| s.path.clone()).collect()
        };
        assert_eq!(paths("/slave/dob"), ["/slave/dob/bandwidth_hz"]);
        assert_eq!(paths("/slave/dob/"), ["/slave/dob/bandwidth_hz"]);
        assert_eq!(paths("/slave/dobx"), ["/slave/dobx"]);
        assert_eq!(
            paths("/slave"),
            ["/slave/dob/bandwidth_hz", "/slave/dobx", "/slave/kp"]
        );
        assert_eq!(paths("/").len(), 4);
        assert!(paths("/sla").is_empty());
        assert!(paths("/nothing").is_empty());
    }

    #[test]
    fn codes_are_told_in_the_machines_words_with_their_detail() {
        let d = described();
        assert_eq!(d.fault_words(5, 2), "a carriage fell behind (carriage 2)");
        assert_eq!(d.fault_words(4, 0), "the effector left the contour");
        let panic = d.fault_words(BOARD_FAULT | board_fault::PANIC, 123);
        assert!(panic.contains("panicked") && panic.ends_with("(source line 123)"));
        assert!(d.fault_words(9, 1).contains("does not describe"));
        assert_eq!(
            d.refusal_words(&Refusal::Job(3), None),
            "job code 0x0003: a move leaves the workspace"
        );
        assert!(d.job_refusal_words(JOB_NOT_AT_REST).contains("still moves"));
        assert!(d.job_refusal_words(77).contains("does not describe"));
    }

    #[test]
    fn a_refused_setting_names_its_range_and_an_unknown_path_the_paths() {
        let d = described();
        let bad = d.refusal_words(&Refusal::BadValue, Some("/dob/bandwidth_hz"));
        assert_eq!(
            bad,
            "the value is refused: /dob/bandwidth_hz takes > 0 and ≤ 3183 Hz"
        );
        let unknown = d.refusal_words(&Refusal::UnknownPath, Some("/nope"));
        assert!(
            unknown.ends_with("(the machine has /dob/bandwidth_hz)"),
            "{unknown}"
        );
        assert_eq!(d.channel("feed"), Some(2));
        let columns: Vec<String> = d.channels.iter().map(ChannelInfo::column).collect();
        assert_eq!(columns, ["x_m", "count", "feed_m_per_s"]);
    }

    #[test]
    fn events_modes_and_kinds_read_as_words() {
        let d = described();
        let mode = Event::Mode {
            from: ModeCode::Ready,
            to: ModeCode::Running,
        };
        assert_eq!(d.event_words(&mode), "mode ready -> running");
        let fault = Event::Fault { code: 5, detail: 1 };
        assert_eq!(
            d.event_words(&fault),
            "fault 5: a carriage fell behind (carriage 1)"
        );
        let refused = d.event_words(&Event::VersionRefused { version: 9 });
        assert!(
            refused.ends_with(&format!("(it speaks {VERSION})")),
            "{refused}"
        );
        assert!(d.event_words(&Event::HostLost).contains("lost the host"));
        assert!(d.event_words(&Event::NextJob).contains("next part"));
        let modes = [
            ModeCode::Idle,
            ModeCode::Calibrating,
            ModeCode::Ready,
            ModeCode::Running,
            ModeCode::Stopping,
            ModeCode::Fault,
        ]
        .map(mode_words);
        assert_eq!(mode_words(ModeCode::Fault), "fault");
        assert_eq!(
            modes,
            [
                "idle",
                "calibrating",
                "ready",
                "running",
                "stopping",
                "fault"
            ]
        );
        assert!(job_kind_words(JobKind::Moves).contains("sharp corners"));
        assert!(job_kind_words(JobKind::Gcode).contains("G-code"));
    }
}
