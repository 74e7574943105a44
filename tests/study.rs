//! Issue 30: one bicycle in several conditions. A blind study (the lab's bicycle with a steer
//! motor whose reflected inertia and delivered gain are withheld, ridden unpowered and at three
//! controller gains, `sim::study`) against its sealed truth; the same rides one condition at a
//! time; the study's JSON.

use bikeproc::gap::{diagnose_campaign, diagnose_manifests, Diagnosis, Ranked};
use bikeproc::inertia::bike::LabBike;
use bikeproc::read::study::Study;
use bikeproc::sim::study::{blind_study_with, StudyMotor, StudyTruth};
use common::root;
use std::path::PathBuf;

mod common;

/// Simulates a study into a scratch folder (the motor drawn, or given) and loads it as the
/// user would (`bikeproc gap DIR/study.toml`).
fn study(seed: u64, motor: Option<(f64, f64)>) -> (PathBuf, Study, StudyTruth) {
    study_of(
        seed,
        StudyMotor {
            rotor_and_gain: motor,
            ..StudyMotor::DRAWN
        },
    )
}

/// [`study`] with the whole motor given ([`StudyMotor`]: its controller's speed sensor, its
/// lag).
fn study_of(seed: u64, motor: StudyMotor) -> (PathBuf, Study, StudyTruth) {
    let bike_path = root().join("data/lab_bike.toml");
    let lab = LabBike::load(&bike_path).unwrap();
    let (mut files, truth) = blind_study_with(&lab, "bike.toml", seed, motor).unwrap();
    files.push((
        "bike.toml".into(),
        std::fs::read_to_string(&bike_path).unwrap(),
    ));
    let dir = std::env::temp_dir().join(format!(
        "bikeproc_study_{}_{seed}_{}_{}_{}",
        std::process::id(),
        motor.rotor_and_gain.is_some(),
        motor.speed_sensor_scale,
        motor.lag_s
    ));
    std::fs::create_dir_all(&dir).unwrap();
    for (name, text) in &files {
        std::fs::write(dir.join(name), text).unwrap();
    }
    let s = Study::load(&dir.join("study.toml")).unwrap();
    (dir, s, truth)
}

fn diagnose(s: &Study) -> Diagnosis {
    let model = bikeproc::read::bicycle::load(&s.bike_path().unwrap()).unwrap();
    diagnose_manifests(&s.conditions, &model, &|_, _, _| {}).unwrap()
}

/// The diagnosis's first candidate is the steer motor's pair — three gains (one per powered
/// condition with rides), then the inertia — each value within 2 of its standard errors of
/// the truth.
fn names_the_motor<'d>(seed: u64, d: &'d Diagnosis, truth: &StudyTruth) -> &'d Ranked {
    let best = &d.ranking[0];
    assert_eq!(
        best.effect, "actuator_gain + steer_inertia",
        "seed {seed}: truth {truth:?}\n{}",
        d.verdict
    );
    let powered = d
        .conditions
        .iter()
        .filter(|c| c.controlled && c.rides_used > 0)
        .count();
    assert_eq!(best.params.len(), powered + 1, "{:?}", best.params);
    let truths =
        std::iter::repeat_n(truth.delivered, powered).chain([truth.reflected_inertia_kgm2]);
    for ((value, se), t) in best.params.iter().zip(&best.params_se).zip(truths) {
        let z = (value - t) / se;
        assert!(
            z.abs() <= 2.0,
            "seed {seed}: {value:.4} ± {se:.4} for {t:.4} (z {z:+.2}), {:?}",
            best.params
        );
    }
    best
}

/// The joint diagnosis of the four conditions names the steer motor's two effects together —
/// its delivered gain per controller, its inertia shared — on each of three seeds, with the
/// study's JSON (`params_by_condition`, `heldout_rms_by_condition`, `conditions`).
///
/// The values against their standard errors: each within 2 of them, as the blind
/// study asks (over 50 studies, docs/study-calibration.md: 47 of 50 name the pair with every
/// value within 2). Measured on seeds 1–3 (the draws with the delivered gain a tenth or more
/// from nominal, one coefficient of the motion's size per condition): the gains at +0.62,
/// +0.55, +0.99; +1.34, +0.11, +0.13; +1.18, +0.42, +0.25 and the inertia at −1.24, +1.10,
/// +0.34. With one coefficient for the study, seed 2's G = 1 gain lay at z +2.9. The
/// single-campaign diagnoses of the same rides name the pair in at most 4 of the 9 powered
/// conditions (23 of 150 over the 50 studies).
#[test]
fn a_blind_study_names_the_steer_motor() {
    let mut singles_naming_both = 0;
    for seed in 1..=3 {
        let (_, s, truth) = study(seed, None);
        let d = diagnose(&s);
        assert!(d.significant, "seed {seed}: {}", d.verdict);
        let best = names_the_motor(seed, &d, &truth);
        let j = best.params[3];
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
    eprintln!("single campaigns naming actuator_gain + steer_inertia: {singles_naming_both} of 9");
    assert!(
        singles_naming_both <= 4,
        "{singles_naming_both} of 9 powered conditions alone named both"
    );
}

/// A study of `motor` (an effect-free motor but for one effect of the library withheld) names
/// `effect` first, significant, its fit within 3 of its standard errors of `truth` and within
/// 30 % of the truth's deviation from `none` (the calibration's "right"); the diagnosis.
fn names_alone_at_its_size(
    seed: u64,
    motor: StudyMotor,
    effect: &str,
    truth: f64,
    none: f64,
) -> Diagnosis {
    let (_, s, _) = study_of(seed, motor);
    let d = diagnose(&s);
    assert!(d.significant, "{}", d.verdict);
    let best = &d.ranking[0];
    assert_eq!(best.effect, effect, "{}", d.verdict);
    let (k, se) = (best.params[0], best.params_se[0]);
    let z = (k - truth) / se;
    eprintln!("{effect} {truth:.4}: fitted {k:.4} ± {se:.4} (z {z:+.2})");
    assert!(z.abs() <= 3.0, "{k:.4} ± {se:.4} for {truth:.4}");
    assert!((k - truth).abs() <= 0.3 * (truth - none).abs());
    d
}

/// Issue 76, item 3: the speed a controller sees. Its firmware schedules the gains on a speed
/// sensor reading 1.084, 0.85 and 1.067 times the rear wheel's (seeds 3001's, 3002's and
/// 3011's draws), the rotor weightless and the torque as commanded. Each study names `controller_speed_scale`
/// first, within 3 of its standard errors of the truth and within 30 % of the truth's
/// deviation from 1 (the calibration's "right"); the motor's own effects, which the same rides
/// would need to mimic it, do not come first. Seed 3001's study named it beside frame_inertia
/// 1.095 ± 0.044, which lowered the χ² of every ride by 7.2 of 235.5 and its conditions left
/// out from 0.90 to 0.51: a study admits a larger candidate only where it lowers χ² significantly
/// below each smaller one it holds, Bonferroni over those tried. Seed 3011's put actuator_gain
/// first (χ² 15,376 on 160; its conditions left out at 1.47), tied with the sensor's single
/// (χ² 185.6; 1.48): the tie now goes to the lower BIC
/// (docs/decisions/2026-12-03-study-admission.md).
#[test]
fn a_controller_that_senses_its_speed_off_is_named_at_its_size() {
    for seed in [3001, 3002, 3011] {
        let scale = bikeproc::sim::study::sensor_scale_draw(seed);
        let motor = StudyMotor {
            speed_sensor_scale: scale,
            ..StudyMotor::EFFECT_FREE
        };
        names_alone_at_its_size(seed, motor, "controller_speed_scale", scale, 1.0);
    }
}

/// Issue 76, item 3: the actuator's delay. The motor's torque follows its command through a
/// first-order lag (seed 4001's draw, `sim::study::lag_draw`: 0.061 s), the rotor weightless
/// and the torque otherwise as commanded. The study names `actuator_lag` first, within 3 of
/// its standard errors of the truth and within 30 % of it (the calibration's "right"), and
/// its verdict says it explains the gap.
#[test]
fn a_motor_whose_torque_lags_is_named_at_its_size() {
    let lag = bikeproc::sim::study::lag_draw(4001);
    let motor = StudyMotor {
        lag_s: lag,
        ..StudyMotor::EFFECT_FREE
    };
    let d = names_alone_at_its_size(4001, motor, "actuator_lag", lag, 0.0);
    assert!(d.explained, "{}", d.verdict);
}

/// A controller's gain that its condition's rides barely tell does not hide the motor. With a
/// large rotor (0.078 and 0.084 kg·m²) and a weak motor (delivered 0.50 and 0.59), the
/// bicycle at G = 1 falls within a cycle in most rides, and the pair's gain there came out at
/// 0.59 ± 0.54 and at the search's edge 0.1 ± 0.49: within its standard error of the edge, so
/// the pair (held-out RMS 0.53 and 0.99, the best of all) ranked below `speed_scale +
/// steer_inertia` (1.83) and `frame_ixx + speed_scale + steer_inertia` (1.49). A study holds
/// a candidate back only where its search's edge holds the fit back (the χ²'s minimum more
/// than 2 SE beyond it: seed 37's lies 1.4 beyond). Where no ride of a condition was usable
/// (seed 7, G = 1: every ride falls within a cycle), the condition is left out of the
/// likelihood and said so. Kept in, its gain entered every candidate as a parameter no ride
/// constrained: it was printed at 0.672 with no standard error and counted in the BIC, and
/// `steer_inertia` alone ranked first (BIC 51.5). Left out, the pair is first (BIC 40.9, held
/// out 0.51 against 0.72) with every value within 2 SE of the truth.
#[test]
fn a_gain_its_rides_barely_tell_does_not_hide_the_motor() {
    for seed in [6, 37] {
        let (dir, s, truth) = study(seed, None);
        let d = diagnose(&s);
        std::fs::remove_dir_all(&dir).ok();
        names_the_motor(seed, &d, &truth);
    }
    let (dir, s, truth) = study(7, None);
    let d = diagnose(&s);
    std::fs::remove_dir_all(&dir).ok();
    let gain_1 = d.conditions.iter().find(|c| c.name == "gain_1").unwrap();
    assert_eq!((gain_1.rides_used, gain_1.rides_failed.len()), (0, 10));
    assert!(
        d.verdict
            .contains("Left out: condition gain_1 (10 rides, none usable)"),
        "{}",
        d.verdict
    );
    let best = names_the_motor(7, &d, &truth);
    assert!(!best.params_by_condition.contains_key("gain_1"));
    assert!(best.params_se.iter().all(|s| s.is_finite() && *s > 0.0));
}

/// The real balance-assist study from the command line (the acceptance command): one
/// entry per condition, and in every ranking entry each condition's parameters, their errors
/// and the condition predicted from the others.
/// A large effect's standard error is its model's: a rotor of 0.05 kg·m² on the steer axis
/// (the motor unpowered in every condition's law, its torque as commanded) moves the weave by
/// more than the measured parameters' errors, and the model's share of the residuals'
/// covariance is then taken where the fit puts the bicycle (`gap::fit::Campaign::at_fit`).
/// The steer inertia fitted alone lies within 2.5 of its standard errors of the truth on each
/// of seeds 1–4 (a calibrated error misses 2.5 in 1.2 % of studies). With the covariance of
/// the bicycle without the rotor, seed 4 came out at 0.0593 ± 0.0028 (z +3.4) and seed 2 at
/// z +2.4; with it, z −0.8, +1.7, +0.6, +1.7.
#[test]
fn a_large_effects_error_is_its_models() {
    const J: f64 = 0.05;
    for seed in 1..=4 {
        let (dir, s, _) = study(seed, Some((J, 1.0)));
        let d = diagnose(&s);
        std::fs::remove_dir_all(&dir).ok();
        let fit = d
            .ranking
            .iter()
            .find(|r| r.effect == "steer_inertia")
            .expect("steer_inertia is ranked");
        let z = (fit.params[0] - J) / fit.params_se[0];
        assert!(
            z.abs() < 2.5,
            "seed {seed}: J {:.4} ± {:.4} for {J} (z {z:+.2})",
            fit.params[0],
            fit.params_se[0]
        );
    }
}

#[test]
fn the_real_study_carries_its_conditions() {
    let d = common::run_json([
        "gap",
        "fixtures/real/balanceassist_uncontrolled.toml",
        "fixtures/real/balanceassist_gain6.toml",
        "fixtures/real/balanceassist_gain8.toml",
        "fixtures/real/balanceassist_gain10.toml",
        "--json",
    ]);
    let names = [
        "balanceassist_uncontrolled",
        "balanceassist_gain6",
        "balanceassist_gain8",
        "balanceassist_gain10",
    ];
    let conditions = d["conditions"].as_array().unwrap();
    assert_eq!(conditions.len(), 4);
    for (c, name) in conditions.iter().zip(names) {
        assert_eq!(c["name"], name);
        // Three marked decays uncontrolled; 21 segments per gain.
        let expected = if name.ends_with("uncontrolled") {
            3
        } else {
            21
        };
        assert_eq!(c["rides_used"], expected, "{c}");
    }
    let ranking = d["ranking"].as_array().unwrap();
    assert!(ranking.len() > 10);
    for r in ranking {
        for key in [
            "params_by_condition",
            "params_se_by_condition",
            "heldout_rms_by_condition",
        ] {
            let by = r[key].as_object().unwrap();
            assert_eq!(by.len(), 4, "{key} of {}", r["effect"]);
            for name in names {
                assert!(by.contains_key(name), "{key} of {}: {name}", r["effect"]);
            }
        }
        // A shared effect repeats its value in every condition.
        if r["effect"] == "steer_inertia" {
            let v = &r["params_by_condition"];
            assert_eq!(v[names[0]], v[names[3]]);
            assert_eq!(v[names[0]][0], r["params"][0]);
        }
        // The actuator's gain: none without the controller, its own per gain.
        if r["effect"] == "actuator_gain" {
            assert!(r["params_by_condition"][names[0]][0].is_null());
            assert_eq!(r["params"].as_array().unwrap().len(), 3);
        }
    }
}

/// Studies that cannot be: a condition given twice, conditions of two bicycles, a study
/// manifest naming a missing campaign, a known mass below the ground, one ride in two
/// conditions. Each refused (exit 2) with the file named.
#[test]
fn a_malformed_study_is_refused_with_its_file() {
    let dir = std::env::temp_dir().join(format!("bikeproc_study_refusals_{}", std::process::id()));
    std::fs::create_dir_all(&dir).unwrap();
    let data = root().join("data");
    let manifest = |bike: &str, ride: &str, extra: &str| {
        format!(
            "version = 1\nbike = \"{}\"\nallow_outside_folder = true\n{extra}\n\
             [[ride]]\nlog = \"{}\"\nnoted_speed_mps = 3.5\n",
            data.join(bike).display(),
            data.join(ride).display()
        )
    };
    std::fs::write(
        dir.join("a.toml"),
        manifest("lab_bike.toml", "ride_01.log", ""),
    )
    .unwrap();
    std::fs::write(
        dir.join("b.toml"),
        manifest("lab_bike_seed.toml", "ride_02.log", ""),
    )
    .unwrap();
    std::fs::write(
        dir.join("again.toml"),
        manifest("lab_bike.toml", "ride_01.log", ""),
    )
    .unwrap();
    std::fs::write(
        dir.join("heavy.toml"),
        manifest(
            "lab_bike.toml",
            "ride_03.log",
            "[[known_mass]]\nframe = \"rear\"\nmass_kg = 2.0\nx_m = 0.4\nz_m = 0.5\n",
        ),
    )
    .unwrap();
    std::fs::write(
        dir.join("study.toml"),
        "version = 1\nconditions = [\"a.toml\", \"missing.toml\"]\n",
    )
    .unwrap();
    let a = dir.join("a.toml");
    let cases: [(Vec<PathBuf>, &str); 5] = [
        (vec![a.clone(), a.clone()], "given twice"),
        (
            vec![a.clone(), dir.join("again.toml")],
            "is also in the condition",
        ),
        (vec![a.clone(), dir.join("b.toml")], "another bicycle file"),
        (vec![dir.join("study.toml")], "missing.toml"),
        (vec![dir.join("heavy.toml"), a.clone()], "known_mass"),
    ];
    for (files, words) in cases {
        let mut args = vec!["gap".to_string()];
        args.extend(files.iter().map(|f| f.display().to_string()));
        let out = common::run(&args);
        let err = String::from_utf8_lossy(&out.stderr);
        assert_eq!(out.status.code(), Some(2), "{args:?}: {err}");
        assert!(err.contains(words), "{args:?}: {err}");
    }
}

/// A controller kept in a file of its own (`controller = "gains.toml"`, as another lab keeps
/// one controller for several campaigns) is the same controller as the table written inline:
/// the model's eigenvalues bit for bit. A missing, malformed or outside file is refused with
/// the manifest and the controller file named.
#[test]
fn a_controller_from_a_file_is_the_inline_one() {
    use bikeproc::read::rides::RideManifest;
    let dir = std::env::temp_dir().join(format!("bikeproc_controller_file_{}", std::process::id()));
    let _ = std::fs::remove_dir_all(&dir);
    std::fs::create_dir_all(&dir).unwrap();
    let real = root().join("fixtures/real");
    let inline = std::fs::read_to_string(real.join("balanceassist_gain6.toml")).unwrap();
    // The same manifest beside the fixtures' (its relative paths kept), its table in a file.
    let start = inline.find("[controller]").unwrap();
    let end = start + inline[start..].find("\n\n").unwrap();
    let table = &inline[start..end];
    let gains = real.join(format!("gains_{}.toml", std::process::id()));
    let from_file = real.join(format!("from_file_{}.toml", std::process::id()));
    let name = gains.file_name().unwrap().to_str().unwrap().to_string();
    std::fs::write(&gains, format!("{table}\n")).unwrap();
    // The table out; `controller = …`, a key of the top table, before the first table.
    let manifest = inline.replacen(table, "", 1).replacen(
        "allow_outside_folder = true",
        &format!("allow_outside_folder = true\ncontroller = \"{name}\""),
        1,
    );
    std::fs::write(&from_file, &manifest).unwrap();
    let loaded = RideManifest::load(&from_file);
    let expected = RideManifest::load(&real.join("balanceassist_gain6.toml")).unwrap();
    let cleanup = || {
        let _ = std::fs::remove_file(&gains);
        let _ = std::fs::remove_file(&from_file);
    };
    let loaded = match loaded {
        Ok(m) => m,
        Err(e) => {
            cleanup();
            panic!("{e}");
        }
    };
    let (a, b) = (loaded.model(None).unwrap(), expected.model(None).unwrap());
    for v in [1.0, 2.5, 4.0, 6.0] {
        let (ea, eb) = (
            a.nominal_canonical().eigenvalues(v),
            b.nominal_canonical().eigenvalues(v),
        );
        assert_eq!(format!("{ea:?}"), format!("{eb:?}"), "at {v} m/s");
    }
    // A malformed controller file: its own name and line in the manifest's error.
    std::fs::write(
        &gains,
        "[controller]\nspeeds_mps = [0.0, 4.7]\nroll_gain = [1.0, 2.0]\n",
    )
    .unwrap();
    let err = RideManifest::load(&from_file).unwrap_err().to_string();
    let missing = {
        std::fs::remove_file(&gains).unwrap();
        RideManifest::load(&from_file).unwrap_err().to_string()
    };
    cleanup();
    assert!(err.contains(&name) && err.contains("roll_gain"), "{err}");
    assert!(
        err.contains(from_file.file_name().unwrap().to_str().unwrap()),
        "{err}"
    );
    assert!(
        missing.contains(&name) && missing.contains("cannot read"),
        "{missing}"
    );
    // Outside the manifest's folder without allow_outside_folder: refused.
    let outside = dir.join("outside.toml");
    std::fs::write(dir.join("r.log"), "").unwrap();
    std::fs::write(
        &outside,
        "version = 1\nbike = \"b.txt\"\ncontroller = \"../gains.toml\"\n\n[[ride]]\nlog = \"r.log\"\nnoted_speed_mps = 3.0\n",
    )
    .unwrap();
    let err = RideManifest::load(&outside).unwrap_err().to_string();
    assert!(err.contains("outside the manifest's folder"), "{err}");
}

/// Issue 76, item 2: ranges belong to the bicycle. A manifest's `[steer_motor]` (the rotor's
/// inertia and the gear ratio) sets the plausible range of the inertia the motor adds about the
/// steer axis to 0.8–2 times `J_r N²`: the balance-assist gain-6 campaign's `steer_inertia`
/// (0.144 ± 0.027 kg·m²) is plausible for a 1e-4 kg·m² rotor through 32:1 (0.102 kg·m²) and
/// pays the prior's closed form d²/(s² + SE²), s a quarter of the range's width, for a 1e-5
/// kg·m² rotor through 10:1 (0.001 kg·m²). A bicycle without a controller that declares its
/// motor has the rotor's inertia among its candidates. Values outside their ranges, an unknown
/// key, and two conditions of a study declaring different motors are refused, the file named.
#[test]
fn a_declared_steer_motor_sets_its_inertias_range() {
    let real = root().join("fixtures/real");
    let pid = std::process::id();
    let written = std::cell::RefCell::new(Vec::<PathBuf>::new());
    let with_motor = |stem: &str, name: &str, table: &str| -> PathBuf {
        let text = std::fs::read_to_string(real.join(format!("{stem}.toml"))).unwrap();
        let path = real.join(format!("{name}_{pid}.toml"));
        std::fs::write(&path, format!("{text}\n[steer_motor]\n{table}\n")).unwrap();
        written.borrow_mut().push(path.clone());
        path
    };
    let single = |v: &serde_json::Value, effect: &str| -> Option<serde_json::Value> {
        v["ranking"]
            .as_array()?
            .iter()
            .find(|r| r["effect"] == effect)
            .cloned()
    };
    let fitting = with_motor(
        "balanceassist_gain6",
        "motor_fits",
        "rotor_inertia_kg_m2 = 1e-4\ngear_ratio = 32",
    );
    let small = with_motor(
        "balanceassist_gain6",
        "motor_small",
        "rotor_inertia_kg_m2 = 1e-5\ngear_ratio = 10",
    );
    // An uncontrolled campaign of enough rides to be ranked: data/'s, its paths absolute.
    let uncontrolled = {
        let data = root().join("data");
        let text = std::fs::read_to_string(data.join("rides.toml"))
            .unwrap()
            .replace(
                "bike = \"lab_bike.toml\"",
                &format!(
                    "bike = \"{}\"\nallow_outside_folder = true",
                    data.join("lab_bike.toml").display()
                ),
            )
            .replace("log = \"", &format!("log = \"{}/", data.display()));
        let path = std::env::temp_dir().join(format!("bikeproc_motor_off_{pid}.toml"));
        std::fs::write(
            &path,
            format!("{text}\n[steer_motor]\nrotor_inertia_kg_m2 = 1e-4\ngear_ratio = 32\n"),
        )
        .unwrap();
        written.borrow_mut().push(path.clone());
        path
    };
    let bad = [
        (
            "rotor_inertia_kg_m2 = 5.0\ngear_ratio = 32",
            "rotor_inertia_kg_m2",
        ),
        ("rotor_inertia_kg_m2 = 1e-4\ngear_ratio = 0.5", "gear_ratio"),
        ("rotor_inertia_kg_m2 = 1e-4\ngear_ratio = nan", "gear_ratio"),
        (
            "rotor_inertia_kg_m2 = 1e-4\ngear_ratio = 32\nratio = 3",
            "ratio",
        ),
    ]
    .iter()
    .enumerate()
    .map(|(k, (table, words))| {
        (
            with_motor("balanceassist_gain6", &format!("motor_bad{k}"), table),
            *words,
        )
    })
    .collect::<Vec<_>>();
    let outcome = std::panic::catch_unwind(|| {
        let fits = common::run_json(["gap", "--json", fitting.to_str().unwrap()]);
        let pays = common::run_json(["gap", "--json", small.to_str().unwrap()]);
        let off = common::run_json(["gap", "--json", uncontrolled.to_str().unwrap()]);
        let r = single(&fits, "steer_inertia").expect("steer_inertia ranked");
        assert_eq!(r["plausible"], true, "{r}");
        assert_eq!(r["prior_penalty"].as_f64(), Some(0.0), "{r}");
        let r = single(&pays, "steer_inertia").expect("steer_inertia ranked");
        let (p, se) = (
            r["params"][0].as_f64().unwrap(),
            r["params_se"][0].as_f64().unwrap(),
        );
        let j = 1e-5 * 10.0 * 10.0;
        let (lo, hi) = (0.8 * j, 2.0 * j);
        let s = 0.25 * (hi - lo);
        let d = (p - hi).max(lo - p).max(0.0);
        let want = d * d / (s * s + se * se);
        let got = r["prior_penalty"].as_f64().unwrap();
        println!("steer_inertia {p:.4} ± {se:.4} kg·m²: prior {got:.2} (closed form {want:.2})");
        assert_eq!(r["plausible"], false, "{r}");
        assert!(
            want > 1.0 && (got - want).abs() <= 1e-9 * want,
            "{got} against {want}"
        );
        assert!(
            single(&off, "steer_inertia").is_some(),
            "no steer_inertia among an uncontrolled bicycle's candidates with its motor declared"
        );
        for (file, words) in &bad {
            let out = common::run(["gap", file.to_str().unwrap()]);
            let err = String::from_utf8_lossy(&out.stderr);
            let name = file.file_name().unwrap().to_str().unwrap();
            assert_eq!(out.status.code(), Some(2), "{name}: {err}");
            assert!(err.contains(name) && err.contains(words), "{name}: {err}");
        }
        let out = common::run(["gap", fitting.to_str().unwrap(), small.to_str().unwrap()]);
        let err = String::from_utf8_lossy(&out.stderr);
        assert_eq!(out.status.code(), Some(2), "{err}");
        assert!(
            err.contains("[steer_motor]") && err.contains(&format!("motor_fits_{pid}")),
            "{err}"
        );
    });
    for f in written.borrow().iter() {
        let _ = std::fs::remove_file(f);
    }
    if let Err(e) = outcome {
        std::panic::resume_unwind(e);
    }
}
