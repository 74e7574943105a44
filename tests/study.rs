//! Issue 30: one bicycle in several conditions. A blind study (the lab's bicycle with a steer
//! motor whose reflected inertia and delivered gain are withheld, ridden unpowered and at three
//! controller gains, `sim::study`) against its sealed truth; the same rides one condition at a
//! time; the study's JSON.

use bikeproc::gap::{diagnose_campaign, diagnose_manifests, Diagnosis};
use bikeproc::inertia::bike::LabBike;
use bikeproc::model::uncertain;
use bikeproc::ride::study::Study;
use bikeproc::sim::study::{blind_study_with, StudyTruth};
use common::root;
use std::path::PathBuf;

mod common;

/// Simulates a study into a scratch folder (the motor drawn, or given) and loads it as the
/// user would (`bikeproc gap DIR/study.toml`).
fn study(seed: u64, motor: Option<(f64, f64)>) -> (PathBuf, Study, StudyTruth) {
    let bike_path = root().join("data/lab_bike.toml");
    let lab = LabBike::load(&bike_path).unwrap();
    let (mut files, truth) = blind_study_with(&lab, "bike.toml", seed, motor).unwrap();
    files.push((
        "bike.toml".into(),
        std::fs::read_to_string(&bike_path).unwrap(),
    ));
    let dir = std::env::temp_dir().join(format!(
        "bikeproc_study_{}_{seed}_{}",
        std::process::id(),
        motor.is_some()
    ));
    std::fs::create_dir_all(&dir).unwrap();
    for (name, text) in &files {
        std::fs::write(dir.join(name), text).unwrap();
    }
    let s = Study::load(&dir.join("study.toml")).unwrap();
    (dir, s, truth)
}

fn diagnose(s: &Study) -> Diagnosis {
    let model = uncertain::load(&s.bike_path().unwrap()).unwrap();
    diagnose_manifests(&s.conditions, &model, &|_, _, _| {}).unwrap()
}

/// The joint diagnosis of the four conditions names the steer motor's two effects together —
/// its delivered gain per controller, its inertia shared — on each of three seeds, with the
/// study's JSON (`params_by_condition`, `heldout_rms_by_condition`, `conditions`).
///
/// The values are a regression guard, not the acceptance: on seeds 1–6 the study's
/// inertia came out 2–31 % from its truth (within 2 of its standard errors in 4 of 6) and the
/// gains up to 0.09 from theirs (within 2 standard errors in 9 of 18; s3: 0.889 ± 0.013 for
/// 0.844), so the guard is half the inertia and 0.15 of the gain. The single-campaign
/// diagnoses of the same rides are printed (how often each names the pair), not asserted.
#[test]
fn a_blind_study_names_the_steer_motor() {
    let mut singles_naming_both = 0;
    for seed in 1..=3 {
        let (_, s, truth) = study(seed, None);
        let d = diagnose(&s);
        assert!(d.significant, "seed {seed}: {}", d.verdict);
        let best = &d.ranking[0];
        assert_eq!(
            best.effect, "actuator_gain + steer_inertia",
            "seed {seed}: truth {truth:?}\n{}",
            d.verdict
        );
        // Three gains (one per powered condition), then the inertia.
        assert_eq!(best.params.len(), 4, "{:?}", best.params);
        let j = best.params[3];
        assert!(
            (j - truth.reflected_inertia_kgm2).abs() < 0.5 * truth.reflected_inertia_kgm2,
            "seed {seed}: J {j} vs {truth:?}"
        );
        for a in &best.params[..3] {
            assert!(
                (a - truth.delivered).abs() < 0.15,
                "seed {seed}: a {a} vs {truth:?}"
            );
        }
        // Shared effects repeat their value in every condition; the unpowered condition has
        // no gain.
        let by = &best.params_by_condition;
        assert_eq!(by.len(), 4);
        assert_eq!(by["unpowered"], vec![None, Some(j)]);
        assert_eq!(by["gain_1"][1], Some(j));
        assert_eq!(best.heldout_rms_by_condition.len(), 4);
        assert!(best.heldout_rms_rides_out.is_some());
        assert_eq!(d.conditions.len(), 4);
        for (name, m) in &s.conditions {
            let model = m.model(None).unwrap();
            let one = diagnose_campaign(m, &model, &|_, _, _| {}).unwrap();
            if one.ranking.first().is_some_and(|b| {
                b.effects.len() == 2 && b.effect == "actuator_gain + steer_inertia"
            }) {
                singles_naming_both += 1;
                eprintln!("seed {seed}: {name} alone names both");
            }
        }
    }
    eprintln!("single campaigns naming actuator_gain + steer_inertia: {singles_naming_both} of 12");
}
