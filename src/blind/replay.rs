//! The calibration files held true to the code: a few recorded cases of
//! `docs/gap-calibration.json` or `docs/study-calibration.json` run again and compared with
//! their record exactly, and the Markdown beside each rendered again from its record.
//!
//! In: a calibration's JSON (every campaign's or study's result, as `simulate gap-calibration`
//! and `simulate study-calibration` write it) and its Markdown. Out: per case replayed, its
//! label and the first field where the replay differs from the record. Every case is seeded,
//! so a replay that differs means the code under the file has moved and the file must be made
//! again (issue 75: "a change that moves a calibration fails CI until the file is made again").

use super::campaigns::{self, Case, CaseResult};
use super::studies::{self, StudyKind, StudyResult};
use super::BlindError;
use crate::inertia::bike::LabBike;
use crate::sim::campaign::{BlindDesign, Withheld};
use serde_json::Value;

/// Errors of a calibration file.
#[derive(Debug, thiserror::Error)]
pub enum ReplayError {
    #[error("{}:{line}:{column}: not JSON: {message}", path.display())]
    Json {
        path: std::path::PathBuf,
        line: usize,
        column: usize,
        message: String,
    },
    #[error("not a calibration's results: {0}")]
    Malformed(String),
    #[error("{}: {what}", path.display())]
    NotResults {
        path: std::path::PathBuf,
        what: String,
    },
    #[error("entry {index}: {what}")]
    Entry { index: usize, what: String },
    #[error(transparent)]
    Run(#[from] BlindError),
}

/// A calibration's results from the text of its JSON file `path`.
pub fn parse_records(path: &std::path::Path, text: &str) -> Result<Value, ReplayError> {
    let records: Value = serde_json::from_str(text).map_err(|e| ReplayError::Json {
        path: path.to_path_buf(),
        line: e.line(),
        column: e.column(),
        message: e.to_string(),
    })?;
    calibration_of(&records).map_err(|e| ReplayError::NotResults {
        path: path.to_path_buf(),
        what: e.to_string(),
    })?;
    Ok(records)
}

/// Which calibration a file's results are.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Calibration {
    /// `simulate gap-calibration`: blind campaigns, one effect withheld each.
    Gap,
    /// `simulate study-calibration`: blind studies of a steer motor.
    Study,
}

/// A recorded case run again: its label, and the first difference from its record (`None`:
/// every number within [`REPLAY_RELATIVE`], everything else exactly).
#[derive(Debug, Clone, PartialEq)]
pub struct Replayed {
    pub case: String,
    pub difference: Option<String>,
}

/// The calibration a file's results come from, by their content: an array whose entries have
/// an `effect` (gap) or a `kind` (study).
pub fn calibration_of(records: &Value) -> Result<Calibration, ReplayError> {
    let first = records
        .as_array()
        .ok_or_else(|| ReplayError::Malformed("not an array of results".into()))?
        .first()
        .ok_or_else(|| ReplayError::Malformed("no results".into()))?;
    if first.get("effect").is_some() {
        Ok(Calibration::Gap)
    } else if first.get("kind").is_some() {
        Ok(Calibration::Study)
    } else {
        Err(ReplayError::Malformed(
            "its entries have neither `effect` (gap) nor `kind` (study)".into(),
        ))
    }
}

/// How far apart a recorded and a replayed number may be, as a fraction of the larger: the
/// same analysis compiled into another binary moves a last bit here and there (measured: 4 of
/// 6 replayed gap campaigns and 2 of 3 studies one ulp off their record after code elsewhere
/// moved between modules, the same on every rerun of either binary), while a change to the
/// analysis moves its results by far more (its fits stop at 1e-3 of a standard error).
/// Everything else — names, counts, flags, rankings — compares exactly.
pub const REPLAY_RELATIVE: f64 = 1e-9;

/// The first place where `replayed` differs from `recorded`, as a path into the record and
/// both values (`None` when they are equal). Numbers agree within [`REPLAY_RELATIVE`] of their
/// size (whole numbers exactly); the JSON writes an f64 in its shortest form that reads back to
/// the same bits.
pub fn first_difference(path: &str, recorded: &Value, replayed: &Value) -> Option<String> {
    match (recorded, replayed) {
        (Value::Number(a), Value::Number(b)) if a.is_f64() || b.is_f64() => {
            let (x, y) = (a.as_f64()?, b.as_f64()?);
            ((x - y).abs() > REPLAY_RELATIVE * x.abs().max(y.abs()))
                .then(|| format!("{path}: recorded {a}, replayed {b}"))
        }
        (Value::Object(a), Value::Object(b)) => {
            let keys: std::collections::BTreeSet<&String> = a.keys().chain(b.keys()).collect();
            keys.into_iter().find_map(|k| {
                let (x, y) = (
                    a.get(k).unwrap_or(&Value::Null),
                    b.get(k).unwrap_or(&Value::Null),
                );
                first_difference(&format!("{path}.{k}"), x, y)
            })
        }
        (Value::Array(a), Value::Array(b)) if a.len() == b.len() => a
            .iter()
            .zip(b)
            .enumerate()
            .find_map(|(i, (x, y))| first_difference(&format!("{path}[{i}]"), x, y)),
        (a, b) if a == b => None,
        (a, b) => Some(format!("{path}: recorded {a}, replayed {b}")),
    }
}

/// `k` of `len` positions spread evenly through them (the middles of `k` equal parts).
fn spread(len: usize, k: usize) -> Vec<usize> {
    let k = k.min(len);
    (0..k).map(|i| (2 * i + 1) * len / (2 * k)).collect()
}

fn entry_field<'a>(index: usize, entry: &'a Value, key: &str) -> Result<&'a Value, ReplayError> {
    entry.get(key).ok_or_else(|| ReplayError::Entry {
        index,
        what: format!("no `{key}`"),
    })
}

fn entry_str(index: usize, entry: &Value, key: &str) -> Result<String, ReplayError> {
    entry_field(index, entry, key)?
        .as_str()
        .map(str::to_string)
        .ok_or_else(|| ReplayError::Entry {
            index,
            what: format!("`{key}` is not text"),
        })
}

fn entry_seed(index: usize, entry: &Value) -> Result<u64, ReplayError> {
    entry_field(index, entry, "seed")?
        .as_u64()
        .ok_or_else(|| ReplayError::Entry {
            index,
            what: "`seed` is not a whole number".into(),
        })
}

/// The cases of a gap calibration's `records` to replay: per design, its first effect-free
/// campaign and `per_design` of its blind campaigns spread through the file (which holds them
/// effect by effect, so the picks are of different effects).
pub fn gap_cases(records: &[Value], per_design: usize) -> Result<Vec<(usize, Case)>, ReplayError> {
    let mut cases = Vec::with_capacity(records.len());
    for (index, entry) in records.iter().enumerate() {
        let effect = entry_str(index, entry, "effect")?;
        let design = entry_str(index, entry, "design")?;
        let withheld = Withheld::from_label(&effect).ok_or_else(|| ReplayError::Entry {
            index,
            what: format!("unknown effect `{effect}`"),
        })?;
        let design =
            serde_json::from_value::<BlindDesign>(Value::String(design.clone())).map_err(|_| {
                ReplayError::Entry {
                    index,
                    what: format!("unknown design `{design}`"),
                }
            })?;
        let seed = entry_seed(index, entry)?;
        cases.push((
            index,
            Case {
                withheld,
                design,
                seed,
            },
        ));
    }
    let mut picked = Vec::new();
    for design in BlindDesign::ALL {
        let of: Vec<&(usize, Case)> = cases.iter().filter(|c| c.1.design == design).collect();
        picked.extend(of.iter().find(|c| c.1.withheld == Withheld::None).copied());
        let blind: Vec<&(usize, Case)> = of
            .into_iter()
            .filter(|c| c.1.withheld != Withheld::None)
            .collect();
        picked.extend(
            spread(blind.len(), per_design)
                .into_iter()
                .map(|i| blind[i]),
        );
    }
    Ok(picked.into_iter().copied().collect())
}

/// The cases of a study calibration's `records` to replay: `per_kind` of each kind's studies,
/// spread through the file.
pub fn study_cases(
    records: &[Value],
    per_kind: usize,
) -> Result<Vec<(usize, u64, StudyKind)>, ReplayError> {
    let mut cases = Vec::with_capacity(records.len());
    for (index, entry) in records.iter().enumerate() {
        let kind = serde_json::from_value::<StudyKind>(entry_field(index, entry, "kind")?.clone())
            .map_err(|e| ReplayError::Entry {
                index,
                what: format!("`kind`: {e}"),
            })?;
        cases.push((index, entry_seed(index, entry)?, kind));
    }
    let mut picked = Vec::new();
    for kind in StudyKind::ALL {
        let of: Vec<_> = cases.iter().filter(|c| c.2 == kind).collect();
        picked.extend(spread(of.len(), per_kind).into_iter().map(|i| *of[i]));
    }
    Ok(picked)
}

/// Replays `per_design` cases of each design (gap) or kind (study) of `records` on the
/// measured bicycle `lab` (its file's text `bike_text`), each against its record, calling
/// `progress` before each.
pub fn replay(
    records: &Value,
    per_design: usize,
    lab: &LabBike,
    bike_text: &str,
    progress: &dyn Fn(&str),
) -> Result<Vec<Replayed>, ReplayError> {
    let calibration = calibration_of(records)?;
    let entries = records.as_array().map(Vec::as_slice).unwrap_or_default();
    let mut out = Vec::new();
    match calibration {
        Calibration::Gap => {
            for (index, case) in gap_cases(entries, per_design)? {
                let label = format!(
                    "{} {} seed {}",
                    case.withheld.label(),
                    case.design.label(),
                    case.seed
                );
                progress(&label);
                let result = campaigns::run_case(lab, bike_text, case)?;
                out.push(compared(label, &entries[index], &result));
            }
        }
        Calibration::Study => {
            for (index, seed, kind) in study_cases(entries, per_design)? {
                let label = format!("{} seed {seed}", kind.label());
                progress(&label);
                let result = studies::run_study(lab, bike_text, seed, kind)?;
                out.push(compared(label, &entries[index], &result));
            }
        }
    }
    Ok(out)
}

fn compared(case: String, recorded: &Value, result: &impl serde::Serialize) -> Replayed {
    let difference = match serde_json::to_value(result) {
        Ok(replayed) => first_difference("", recorded, &replayed),
        Err(e) => Some(format!("the replay does not write as JSON: {e}")),
    };
    Replayed { case, difference }
}

/// The command a calibration's Markdown says it was made by (its first `` Made by `…` ``).
pub fn made_by(markdown: &str) -> Option<&str> {
    let start = markdown.find("Made by `")? + "Made by `".len();
    let len = markdown[start..].find('`')?;
    Some(&markdown[start..start + len])
}

/// The Markdown a calibration's `records` render to, made by `command` (as the file says).
pub fn render(records: &Value, command: &str) -> Result<String, ReplayError> {
    let malformed = |e: serde_json::Error| ReplayError::Malformed(e.to_string());
    Ok(match calibration_of(records)? {
        Calibration::Gap => {
            let results: Vec<CaseResult> =
                serde_json::from_value(records.clone()).map_err(malformed)?;
            campaigns::markdown(&results, &[], command)
        }
        Calibration::Study => {
            let results: Vec<StudyResult> =
                serde_json::from_value(records.clone()).map_err(malformed)?;
            studies::study_markdown(&results, &[], command)
        }
    })
}

/// What [`check`] found of one calibration file.
#[derive(Debug, Clone, PartialEq)]
pub struct Checked {
    /// The command its Markdown says it was made by.
    pub command: String,
    /// The Markdown is what the results render to, byte for byte.
    pub renders_the_same: bool,
    /// The cases replayed ([`replay`]).
    pub replayed: Vec<Replayed>,
}

/// A calibration file held to the code: its `markdown` rendered again from its `records` by
/// the command it names, and `per_design` cases of each design (kind) replayed ([`replay`]).
pub fn check(
    records: &Value,
    markdown: &str,
    per_design: usize,
    lab: &LabBike,
    bike_text: &str,
    progress: &dyn Fn(&str),
) -> Result<Checked, ReplayError> {
    let command = made_by(markdown)
        .ok_or_else(|| ReplayError::Malformed("its Markdown has no \"Made by `…`\" line".into()))?;
    Ok(Checked {
        command: command.to_string(),
        renders_the_same: render(records, command)? == markdown,
        replayed: replay(records, per_design, lab, bike_text, progress)?,
    })
}

#[cfg(test)]
mod tests {
    use super::*;
    use serde_json::json;

    /// A number changed deep in a record is found, with its path and both values; equal
    /// records (NaN written as null on both sides) have none, nor do numbers a last bit apart.
    #[test]
    fn the_first_difference_names_its_path() {
        let a = json!({"seed": 3, "fit": {"params": [1.0, 2.5], "se": [null, 0.1]}, "best": "x"});
        let mut b = a.clone();
        assert_eq!(first_difference("", &a, &b), None);
        b["fit"]["params"][1] = json!(2.5000000000000004);
        assert_eq!(first_difference("", &a, &b), None);
        b["fit"]["params"][1] = json!(2.50000001);
        assert_eq!(
            first_difference("", &a, &b).as_deref(),
            Some(".fit.params[1]: recorded 2.5, replayed 2.50000001")
        );
        b["fit"]["params"][1] = json!(2.5);
        b["seed"] = json!(4);
        assert_eq!(
            first_difference("", &a, &b).as_deref(),
            Some(".seed: recorded 3, replayed 4")
        );
        let mut c = a.clone();
        c["best"] = json!("y");
        assert_eq!(
            first_difference("", &a, &c).as_deref(),
            Some(".best: recorded \"x\", replayed \"y\"")
        );
    }

    /// The picks are spread: 2 of 10 are the 3rd and 8th (middles of the halves); never more
    /// than there are.
    #[test]
    fn picks_are_spread_through_the_file() {
        assert_eq!(spread(10, 2), vec![2, 7]);
        assert_eq!(spread(3, 5), vec![0, 1, 2]);
        assert_eq!(spread(0, 2), Vec::<usize>::new());
    }

    #[test]
    fn the_command_is_read_from_the_markdown() {
        let md = "# T\n\nMade by `bikeproc simulate x --out y.md` (2 campaigns).";
        assert_eq!(made_by(md), Some("bikeproc simulate x --out y.md"));
        assert_eq!(made_by("no command"), None);
    }
}
