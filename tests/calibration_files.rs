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
        Calibration::Study => 5,
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

/// The recorded results of a calibration file.
fn records<T: serde::de::DeserializeOwned>(json: &str) -> Vec<T> {
    let root = Path::new(env!("CARGO_MANIFEST_DIR"));
    let text = std::fs::read_to_string(root.join(json)).unwrap();
    serde_json::from_str(&text).unwrap()
}

/// Issue 75's bars on the gap calibration's record (held true to the code by the replay
/// above), over the effects they were set on (2,550 campaigns, before issue 76's hypotheses):
/// named at the right size beyond the detection limit in ≥ 96 % of the sync campaigns and
/// ≥ 91 % of the noted and varied ones, and the effect-free campaigns' test firing (p < 0.01)
/// in ≤ 2 % of each design's. A hypothesis added later ([`ADDED`]) is scored on its own rows:
/// its detection limit must hold its promise (significant in ≥ 80 % of the campaigns beyond
/// it); its right sizes are held at issue 76's 90 % where they reach it
/// ([`MEETS_ISSUE_76_BAR`]) and printed elsewhere (the head angle's 95, 83 and 76 %:
/// docs/decisions/2026-12-06-plausibility-prior.md). These are the statistical
/// runs the suite does not repeat; the smaller blind runs of tests/gap.rs that scored the same
/// before the calibration existed are kept out of the suite (`--ignored`).
#[test]
fn the_gap_calibration_meets_its_bars() {
    use bikeproc::blind::campaigns::{headline, CaseResult};
    use bikeproc::sim::campaign::BlindDesign;
    let results: Vec<CaseResult> = records("docs/gap-calibration.json");
    let (added, before): (Vec<CaseResult>, Vec<CaseResult>) = results
        .into_iter()
        .partition(|c| ADDED.contains(&c.effect.as_str()));
    for design in BlindDesign::ALL {
        let h = headline(&before, design);
        let bar = if design == BlindDesign::Sync { 96 } else { 91 };
        println!("{design:?}: {h:?}");
        assert!(h.beyond >= 300, "{design:?}: {} beyond the limit", h.beyond);
        assert!(
            h.right_beyond * 100 >= bar * h.beyond,
            "{design:?}: right beyond the limit in {} of {}, the bar {bar} %",
            h.right_beyond,
            h.beyond
        );
        assert!(h.controls >= 200, "{design:?}: {} controls", h.controls);
        assert!(
            h.controls_fired * 50 <= h.controls,
            "{design:?}: {} of {} effect-free campaigns below p 0.01",
            h.controls_fired,
            h.controls
        );
        for effect in ADDED {
            let rows: Vec<CaseResult> = added
                .iter()
                .filter(|c| c.effect == effect)
                .cloned()
                .collect();
            let a = headline(&rows, design);
            println!("{design:?} {effect}: {a:?}");
            // The broad draws reach down to the limit: 27–50 of each 50 lie beyond it.
            assert!(a.beyond >= 20, "{design:?} {effect}: {} beyond", a.beyond);
            assert!(
                a.significant_beyond * 10 >= 8 * a.beyond,
                "{design:?}: {effect} significant in {} of {} beyond its limit",
                a.significant_beyond,
                a.beyond
            );
            if MEETS_ISSUE_76_BAR
                .iter()
                .any(|&(e, designs)| e == effect && designs.contains(&design))
            {
                assert!(
                    a.right_beyond * 10 >= 9 * a.beyond,
                    "{design:?}: {effect} right in {} of {} beyond its limit",
                    a.right_beyond,
                    a.beyond
                );
            }
        }
    }
}

/// Of [`ADDED`], those named at the right size in ≥ 90 % of the campaigns beyond their limit
/// (issue 76's bar), and the designs where they are, held there: the dry friction in every
/// design (98, 98 and 94 %); on the steady rides the head angle (95 %), the rear frame's
/// inertia as a set (90 %) and the front frame's (95 %). On the coasting designs the slowing
/// rides' bias keeps those three at 76–86 % (docs/decisions/2026-12-04-coasting-and-new-hypotheses.md).
const MEETS_ISSUE_76_BAR: [(&str, &[bikeproc::sim::campaign::BlindDesign]); 4] = {
    use bikeproc::sim::campaign::BlindDesign::{Noted, Sync, Varied};
    [
        ("steer_friction", &[Sync, Noted, Varied]),
        ("head_angle", &[Sync]),
        ("frame_inertia", &[Sync]),
        ("front_inertia", &[Sync]),
    ]
};

/// Issue 76's hypotheses, added to the library after issue 75's bars were set.
const ADDED: [&str; 4] = [
    "head_angle",
    "frame_inertia",
    "front_inertia",
    "steer_friction",
];

/// Issue 75's bar on the study calibration's record: of the 50 blind studies, ≥ 45 name the
/// motor's pair with every value within 2 SE of its truth; of the effect-free studies, ≤ 2 %
/// below p 0.01. Issue 76's new hypotheses of a controlled bicycle, each withheld alone in 20
/// studies far beyond its detection limit: the speed a controller senses off by 3–15 % (its
/// fits' errors 0.001) and the actuator's lag of 0.01–0.08 s (its fits' errors about 0.0005 s); of each, ≥ 90 % carry it at the
/// right size in their first candidate. (Issue 76's bar, named alone at the right size, is
/// printed, not held, for the sensor: 16 of 20, the other 4 pair it with an effect of the
/// bicycle; docs/decisions/2026-12-03-controller-speed.md.)
#[test]
fn the_study_calibration_meets_its_bar() {
    use bikeproc::blind::studies::{
        named_within_2se, withheld_in_first, withheld_right, StudyKind, StudyResult,
    };
    let results: Vec<StudyResult> = records("docs/study-calibration.json");
    let blind: Vec<&StudyResult> = results
        .iter()
        .filter(|r| r.kind == StudyKind::Blind)
        .collect();
    let named = blind.iter().filter(|r| named_within_2se(r)).count();
    assert_eq!(blind.len(), 50);
    assert!(named >= 45, "{named} of {} blind studies", blind.len());
    let controls: Vec<&StudyResult> = results
        .iter()
        .filter(|r| r.kind == StudyKind::EffectFree)
        .collect();
    for kind in [StudyKind::ControllerSpeed, StudyKind::ActuatorLag] {
        let withheld: Vec<&StudyResult> = results.iter().filter(|r| r.kind == kind).collect();
        let in_first = withheld.iter().filter(|r| withheld_in_first(r)).count();
        let alone = withheld.iter().filter(|r| withheld_right(r)).count();
        println!("{kind:?}: alone {alone}, in the first candidate {in_first}");
        assert!(
            withheld.len() >= 20 && in_first * 10 >= 9 * withheld.len(),
            "{kind:?}: in the first candidate at the right size in {in_first} of {}",
            withheld.len()
        );
    }
    let fired = controls
        .iter()
        .filter(|r| r.campaign_p_value < 0.01)
        .count();
    assert!(
        controls.len() >= 50 && fired * 50 <= controls.len(),
        "{fired} of {}",
        controls.len()
    );
}
