//! The checked-in calibrations hold for today's code (issue 75): each Markdown is what its
//! JSON of per-campaign (per-study) results renders to, and a few recorded cases of every
//! design (kind), run again from their seeds, give their record (numbers within 1e-9 of their
//! size, names, counts and flags exactly). A change that moves a calibration fails here until
//! the file is made again by the command it names (`bikeproc simulate check-calibration` runs
//! the same check from the command line).

use bikeproc::blind::replay::{calibration_of, check, Calibration};
use bikeproc::inertia::bike::LabBike;
use std::path::Path;

fn check_file(json: &str, expected: Calibration) {
    let root = Path::new(env!("CARGO_MANIFEST_DIR"));
    let text = std::fs::read_to_string(root.join(json)).unwrap();
    let records: serde_json::Value = serde_json::from_str(&text).unwrap();
    assert_eq!(calibration_of(&records).unwrap(), expected);
    let md_path = root.join(Path::new(json).with_extension("md"));
    let md = std::fs::read_to_string(&md_path).unwrap();
    let bike_path = root.join("data/lab_bike.toml");
    let lab = LabBike::load(&bike_path).unwrap();
    let bike_text = std::fs::read_to_string(&bike_path).unwrap();
    let checked = check(&records, &md, 1, &lab, &bike_text, &|_| {}).unwrap();
    let command = &checked.command;
    assert!(
        checked.renders_the_same,
        "{} is not what {json} renders to: make both again with `{command}`",
        md_path.display()
    );
    let replayed = checked.replayed;
    // Gap: per design its first effect-free campaign and one blind one; study: one per kind.
    let cases = match expected {
        Calibration::Gap => 6,
        Calibration::Study => 3,
    };
    assert_eq!(replayed.len(), cases);
    let differ: Vec<String> = replayed
        .iter()
        .filter_map(|r| r.difference.as_ref().map(|d| format!("{}: {d}", r.case)))
        .collect();
    assert!(
        differ.is_empty(),
        "{json} no longer holds for this code; make it again with `{command}`:\n  {}",
        differ.join("\n  ")
    );
}

#[test]
fn the_gap_calibration_replays_its_record() {
    check_file("docs/gap-calibration.json", Calibration::Gap);
}

#[test]
fn the_study_calibration_replays_its_record() {
    check_file("docs/study-calibration.json", Calibration::Study);
}
