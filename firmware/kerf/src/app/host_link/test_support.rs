//! What every machine's link tests check of its description, written once.

extern crate std;
use super::{describe, LinkMachine, SettingText};
use crate::codec::link::{CodeWords, Description, LINK_JOB_REFUSALS};
use miniconf::json_core;
use std::format;
use std::string::String;
use std::vec::Vec;

/// Every setting `M` describes, as `path [unit] range`, and the number of items its
/// description has in all (channels, job kinds, settings, fault and refusal codes).
/// Each setting's announced preset is checked against `presets` the way `Set` takes
/// a value: the text set into a copy must leave it equal to `presets` (a preset
/// announced wrong, or for another path, changes the copy).
pub(crate) fn described<M: LinkMachine>(presets: &M::Settings) -> (Vec<String>, usize)
where
    M::Settings: PartialEq + core::fmt::Debug,
{
    let mut settings = Vec::new();
    let mut count = 0;
    for index in 0.. {
        let mut text = SettingText::default();
        match describe::<M>(index, presets, &mut text) {
            Some(Description::Setting {
                path,
                unit,
                range,
                preset,
            }) => {
                assert!(!preset.is_empty(), "{path}: no preset");
                let mut back = *presets;
                json_core::set(&mut back, path, preset.as_bytes())
                    .unwrap_or_else(|e| panic!("{path} = {preset}: {e:?}"));
                assert_eq!(back, *presets, "{path} = {preset}");
                settings.push(format!("{path} [{unit}] {range}"))
            }
            Some(_) => {}
            None => break,
        }
        count += 1;
    }
    (settings, count)
}

/// A machine's fault and job refusal tables: within each, no code and no words twice;
/// no refusal code is one of the link's own (which the host would name instead).
pub(crate) fn assert_code_tables(faults: &[CodeWords], job_refusals: &[CodeWords]) {
    for table in [faults, job_refusals] {
        for (i, a) in table.iter().enumerate() {
            assert!(
                table[..i]
                    .iter()
                    .all(|b| b.code != a.code && b.words != a.words),
                "{:#x} ({}) twice",
                a.code,
                a.words
            );
        }
    }
    assert!(job_refusals
        .iter()
        .all(|r| CodeWords::find(&LINK_JOB_REFUSALS, r.code).is_none()));
}
