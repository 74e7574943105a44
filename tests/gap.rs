//! Issue 7: the sim-to-real gap. Blind campaigns (one effect withheld, the diagnosis not told
//! which) against their sealed truth; the campaign in data/; campaigns that support no
//! conclusion; the diagnosis's tyres against the simulator's.

use bikeproc::blind::campaigns::{diagnose_blind, run_case, Case};
use bikeproc::gap::{diagnose_campaign, ride_contrasts, Diagnosis, GapOptions};
use bikeproc::inertia::bike::LabBike;
use bikeproc::read::rides::RideManifest;
use bikeproc::sim::campaign::{BlindDesign, BlindTruth, Draws, Withheld};
use common::root;
use std::path::PathBuf;

mod common;

fn scratch(name: &str) -> PathBuf {
    let dir = std::env::temp_dir().join(format!("bikeproc_gap_{}_{name}", std::process::id()));
    std::fs::create_dir_all(&dir).unwrap();
    dir
}

/// Simulates a blind campaign into a scratch folder and diagnoses it against the measured
/// bicycle (the diagnosis sees the logs and the manifest only).
fn blind_design(withheld: Withheld, design: BlindDesign, seed: u64) -> (Diagnosis, BlindTruth) {
    blind_plus(withheld, design, seed, &[])
}

/// [`blind_design`] with rides added at `extra` release speeds (m/s).
fn blind_plus(
    withheld: Withheld,
    design: BlindDesign,
    seed: u64,
    extra: &[f64],
) -> (Diagnosis, BlindTruth) {
    blind_drawn(withheld, design, seed, extra, Draws::Suite)
}

/// [`blind_plus`] with the effect's size from `draws` (the calibration's are `Draws::Broad`).
fn blind_drawn(
    withheld: Withheld,
    design: BlindDesign,
    seed: u64,
    extra: &[f64],
    draws: Draws,
) -> (Diagnosis, BlindTruth) {
    let bike_path = root().join("data/lab_bike.toml");
    let lab = LabBike::load(&bike_path).unwrap();
    let text = std::fs::read_to_string(&bike_path).unwrap();
    let case = Case {
        withheld,
        design,
        seed,
    };
    diagnose_blind(&lab, &text, case, extra, draws).unwrap()
}

/// The diagnosis found the withheld effect: a significant gap, and the effect first or among
/// the tied.
fn found(d: &Diagnosis, w: Withheld) -> bool {
    d.significant
        && if d.tied.len() > 1 {
            d.tied.iter().any(|t| t == w.label())
        } else {
            d.ranking.first().is_some_and(|r| r.effect == w.label())
        }
}

/// The effects of the library each blind test withholds and scores.
const COUNTED: [Withheld; 9] = [
    Withheld::SteerDamping,
    Withheld::Tyres,
    Withheld::FrontMass,
    Withheld::FrameMass,
    Withheld::WheelSpin,
    Withheld::FrontIxx,
    Withheld::FrameIxx,
    Withheld::Trail,
    Withheld::SpeedScale,
];
/// Run and printed, not counted: the sensor clock's time scale. At a size a real sensor's
/// crystal allows (±50 ppm) it changes nothing measurable, and at the 2.5–4 % it takes to be
/// seen it lies outside what the library calls plausible (3 %) and is nearly the speedometer's
/// twin (ω ∝ v makes ω(s v)/s ≈ ω(v) on the `Sync` rides).
const UNCOUNTED: [Withheld; 1] = [Withheld::TimeScale];
/// An effect the library does not have: a steer spring.
const OUTSIDE: [Withheld; 1] = [Withheld::SteerSpring];

/// What a blind test counted.
#[derive(Default)]
struct Score {
    cases: usize,
    right: usize,
    ties: usize,
    controls: usize,
    controls_quiet: usize,
    outside: usize,
    outside_unexplained: usize,
    /// Tied cases retried with the two recommended rides added, and those they untie with the
    /// withheld effect found.
    ties_retried: usize,
    ties_broken: usize,
    /// Over every tied pair retried: the squared separation (tie test's Σ|dᵢ|²) the diagnosis
    /// expected the two rides to add, and what they added.
    untie_expected: f64,
    untie_added: f64,
    /// (effect, seed, fitted, truth) of every parameter the diagnosis pins down (standard
    /// error under 30 % of its value).
    params: Vec<(&'static str, u64, f64, f64)>,
}

/// Runs the blind campaigns of `design` for seeds 1–5: the control, each effect of [`COUNTED`]
/// (scored), of [`UNCOUNTED`] (printed only) and of [`OUTSIDE`] (not in the library: scored as
/// "unexplained"), and prints every case.
fn score(design: BlindDesign) -> Score {
    let (counted, uncounted, outside) = (&COUNTED[..], &UNCOUNTED[..], &OUTSIDE[..]);
    let mut s = Score::default();
    for seed in 1..=5 {
        let (d, _) = blind_design(Withheld::None, design, seed);
        println!(
            "control seed {seed}: p {:.3} (χ² {:.3}, targeted {:?}), significant {}",
            d.campaign_p_value, d.p_value, d.targeted, d.significant
        );
        s.controls += 1;
        s.controls_quiet += usize::from(!d.significant);
        for &w in counted.iter().chain(uncounted).chain(outside) {
            let (d, truth) = blind_design(w, design, seed);
            let best = d.ranking.first();
            let ok = found(&d, w);
            println!(
                "{} seed {seed}: truth {:?}, best {} {:?} ± {:?}, tied {:?}, p {:.1e}, held-out {:.2} → {:.2}, fit p {:.1e}, explained {}: {}",
                w.label(),
                truth.params,
                best.map(|r| r.effect.clone()).unwrap_or_default(),
                best.map(|r| r.params.clone()),
                best.map(|r| r.params_se.clone()),
                d.tied,
                d.campaign_p_value,
                best.map_or(f64::NAN, |r| r.heldout_rms_before),
                best.map_or(f64::NAN, |r| r.heldout_rms_after),
                d.best_fit_p_value,
                d.explained,
                if ok { "right" } else { "not found" }
            );
            if outside.contains(&w) {
                s.outside += 1;
                s.outside_unexplained += usize::from(d.significant && !d.explained);
            } else if counted.contains(&w) {
                s.cases += 1;
                s.right += usize::from(ok);
                s.ties += usize::from(d.tied.len() > 1);
                if d.tied.len() > 1 && !d.next_rides.rides.is_empty() {
                    // Item 5: the two rides the diagnosis recommends, simulated and added.
                    let extra: Vec<f64> = d
                        .next_rides
                        .rides
                        .iter()
                        .map(|n| n.release_speed_mps)
                        .collect();
                    let (again, _) = blind_plus(w, design, seed, &extra);
                    let broken = again.tied.len() <= 1 && found(&again, w);
                    let (expected, added) = separation_added(&d, &again);
                    println!(
                        "  with rides released at {extra:?} (said to take {:?} rides): tied {:?}, best {}: {}; squared separation added {added:.2}, expected {expected:.2}",
                        d.next_rides.rides_needed,
                        again.tied,
                        again.ranking.first().map_or("", |r| r.effect.as_str()),
                        if broken { "broken" } else { "still tied" }
                    );
                    s.ties_retried += 1;
                    s.ties_broken += usize::from(broken);
                    s.untie_expected += expected;
                    s.untie_added += added;
                }
                if let Some(r) = d.ranking.iter().find(|r| r.effect == w.label()) {
                    for ((&fit, &se), &t) in r.params.iter().zip(&r.params_se).zip(&truth.params) {
                        if se.is_finite() && se < 0.3 * fit.abs() {
                            s.params.push((w.label(), seed, fit, t));
                        }
                    }
                }
            }
        }
    }
    println!(
        "{} of {} right, {} tied ({} of {} broken by the two rides recommended, which added a squared separation of {:.1} where {:.1} was expected), {} of {} controls quiet, {} of {} outside the library unexplained, {} parameters checked",
        s.right,
        s.cases,
        s.ties,
        s.ties_broken,
        s.ties_retried,
        s.untie_added,
        s.untie_expected,
        s.controls_quiet,
        s.controls,
        s.outside_unexplained,
        s.outside,
        s.params.len()
    );
    s
}

/// Over the pairs tied with the best in `before`: the squared separation in the tie test the
/// two recommended rides were expected to add, and what they added in `after` (the same
/// campaign with them): their own part of the tie test's Σ|dᵢ|², each predicted from the
/// other rides. (The rides already made move too, as every fit moves with two more rides: by
/// ±20 in either direction on campaigns with 11 tied candidates, which is not what the
/// recommendation promises.)
fn separation_added(before: &Diagnosis, after: &Diagnosis) -> (f64, f64) {
    let find = |d: &Diagnosis, name: &str| d.ranking.iter().find(|r| r.effect == name).cloned();
    let Some(best) = before.ranking.first() else {
        return (0.0, 0.0);
    };
    let new_rides: Vec<usize> = (0..after.residuals.len())
        .filter(|&i| {
            !before
                .residuals
                .iter()
                .any(|r| r.ride == after.residuals[i].ride)
        })
        .collect();
    let rivals = before.tied.iter().filter(|t| **t != best.effect);
    let (mut expected, mut added) = (0.0, 0.0);
    for (k, rival) in rivals.enumerate() {
        let (Some(b1), Some(r1)) = (find(after, &best.effect), find(after, rival)) else {
            continue;
        };
        expected += before
            .next_rides
            .rides
            .iter()
            .map(|n| n.separation_se[k].powi(2))
            .sum::<f64>();
        let per_ride = ride_contrasts(&b1, &r1);
        added += new_rides
            .iter()
            .filter_map(|&i| per_ride[i].map(|(_, d2)| d2))
            .sum::<f64>();
    }
    (expected, added)
}

/// The acceptance's bars: the withheld effect first (or among the tied) in ≥ 90 % of the
/// cases, ≤ 15 % tied, controls quiet in ≥ 90 %, every campaign with an effect outside the
/// library unexplained, every parameter the diagnosis pins down within 30 % of the truth.
fn assert_bars(s: &Score, min_params: usize) {
    assert!(s.right * 10 >= 9 * s.cases, "{} of {}", s.right, s.cases);
    assert!(
        s.controls_quiet * 10 >= 9 * s.controls,
        "{} of {} controls",
        s.controls_quiet,
        s.controls
    );
    assert!(
        s.ties * 100 <= 15 * s.cases,
        "{} of {} tied",
        s.ties,
        s.cases
    );
    assert_eq!(s.outside_unexplained, s.outside, "outside the library");
    // Item 5: the recommended rides set the tied candidates as far apart as the diagnosis said
    // (within a factor of 3 over the tied pairs: each is predicted from a refit without it, and
    // its own errors are those of the campaign's ride nearest its speed). Weighed by the fit's
    // errors alone, the recommendation expected about 20 per pair where the rides gave 1.
    assert!(
        s.ties_retried == 0
            || (s.untie_added > s.untie_expected / 3.0 && s.untie_added < 3.0 * s.untie_expected),
        "the recommended rides added a squared separation of {:.2}, {:.2} expected",
        s.untie_added,
        s.untie_expected
    );
    let off: Vec<_> = s
        .params
        .iter()
        .filter(|(_, _, fit, t)| (fit - t).abs() > 0.3 * t.abs())
        .collect();
    assert!(
        s.params.len() >= min_params && off.is_empty(),
        "{} checked; beyond 30 %: {off:?}",
        s.params.len()
    );
}

/// Acceptance, the design with a reed switch: 12 rides at 3.8–6.55 m/s, `Sync` on every other,
/// realistic sensors; nine kinds of effect in the library, one outside it (a steer spring),
/// and the control, five seeds each.
#[test]
#[ignore = "a long statistical run: docs/gap-calibration.md scores the same on 2,550 campaigns (tests/calibration_files.rs)"]
fn blind_campaigns_find_the_withheld_effect() {
    let s = score(BlindDesign::Sync);
    assert_bars(&s, 25);
}

/// Acceptance: on data/rides.toml (simulated with steer damping, tyres, two sensors' masses, a
/// speedometer 3 % high, the frame's I_xx 6 % above the measured, drag and rolling resistance)
/// the best explanation is made of effects the campaign has, and the held-out gap shrinks by
/// at least 70 %.
#[test]
fn the_campaign_in_data_is_explained_by_its_own_effects() {
    let manifest = RideManifest::load(&root().join("data/rides.toml")).unwrap();
    let model = bikeproc::read::bicycle::load(&manifest.bike_path()).unwrap();
    let d = diagnose_campaign(&manifest, &model, &|_, _, _| {}).unwrap();
    println!("{}", d.to_text());
    let simulated = [
        "steer_damping",
        "tyres",
        "front_mass",
        "frame_mass",
        "frame_ixx",
        "speed_scale",
    ];
    let best = &d.ranking[0];
    assert!(d.significant);
    // The best is made of effects the campaign has, or is tied with a candidate that is.
    let all_simulated =
        |r: &bikeproc::gap::Ranked| r.effects.iter().all(|e| simulated.contains(&e.name()));
    assert!(
        best.effects.iter().any(|e| simulated.contains(&e.name()))
            && (all_simulated(best)
                || d.ranking
                    .iter()
                    .any(|r| d.tied.contains(&r.effect) && all_simulated(r))),
        "best: {}, tied {:?}",
        best.effect,
        d.tied
    );
    let shrink = 1.0 - best.heldout_rms_after / best.heldout_rms_before;
    assert!(
        shrink >= 0.7,
        "held-out gap shrinks by {:.0} %",
        100.0 * shrink
    );
    // The time series agree: with the effect the eigenvalues account for about as much of θ
    // and γ as each ride's own free fit does (0.86–0.999).
    let (before, after) = (d.heldout_vaf_before.unwrap(), d.heldout_vaf_after.unwrap());
    assert!(after > before && after >= 0.9, "VAF {before} → {after}");
}

/// A manifest over some of data/'s logs (absolute paths), written to a scratch folder.
fn manifest_of(name: &str, logs: &[PathBuf]) -> RideManifest {
    let dir = scratch(name);
    let mut text = format!(
        "version = 1\nbike = \"{}\"\nallow_outside_folder = true\n",
        root().join("data/lab_bike.toml").display()
    );
    for (k, log) in logs.iter().enumerate() {
        text += &format!(
            "\n[[ride]]\nlog = \"{}\"\nnoted_speed_mps = {:.1}\n",
            log.display(),
            4.0 + 0.2 * k as f64
        );
    }
    std::fs::write(dir.join("rides.toml"), text).unwrap();
    let m = RideManifest::load(&dir.join("rides.toml")).unwrap();
    std::fs::remove_dir_all(&dir).ok();
    m
}

/// `n` copies of a ride log with its `_cal` file, under other names in a scratch folder `name`
/// (a campaign lists each file once): the same recording as `n` rides.
fn copies(name: &str, log: &std::path::Path, n: usize) -> Vec<PathBuf> {
    let dir = scratch(name);
    let cal = log.with_file_name(format!(
        "{}_cal.log",
        log.file_stem().unwrap().to_string_lossy()
    ));
    (0..n)
        .map(|k| {
            let copy = dir.join(format!("copy_{k}.log"));
            std::fs::copy(log, &copy).unwrap();
            if cal.exists() {
                std::fs::copy(&cal, dir.join(format!("copy_{k}_cal.log"))).unwrap();
            }
            copy
        })
        .collect()
}

fn inconclusive(m: &RideManifest) -> Diagnosis {
    let model = bikeproc::read::bicycle::load(&root().join("data/lab_bike.toml")).unwrap();
    let d = diagnose_campaign(m, &model, &|_, _, _| {}).unwrap();
    assert!(!d.conclusive, "{}", d.verdict);
    assert!(d.ranking.is_empty(), "a ranking built on nothing");
    assert!(d.verdict.starts_with("No conclusion: "), "{}", d.verdict);
    d
}

/// Acceptance: fewer than 4 usable rides, a single speed, most rides failed: a statement of
/// what cannot be concluded and why, no ranking.
#[test]
fn campaigns_that_support_no_conclusion_say_why() {
    let data = root().join("data");
    let ride = |k: usize| data.join(format!("ride_{k:02}.log"));
    let d = inconclusive(&manifest_of("three", &[ride(4), ride(8), ride(12)]));
    assert!(d.verdict.contains("3 usable rides"), "{}", d.verdict);
    let d = inconclusive(&manifest_of("single", &copies("single_logs", &ride(6), 5)));
    assert!(d.verdict.contains("a single speed"), "{}", d.verdict);
    std::fs::remove_dir_all(scratch("single_logs")).ok();
    let faults = root().join("fixtures/rides");
    let mut logs: Vec<PathBuf> = ["no_kick", "too_short", "sensors_swapped", "handlebar_still"]
        .iter()
        .map(|f| faults.join(format!("{f}.log")))
        .collect();
    logs.extend([ride(4), ride(8), ride(12)]);
    let d = inconclusive(&manifest_of("failed", &logs));
    assert_eq!(d.rides_failed.len(), 4);
    assert!(d.verdict.contains("3 usable rides"), "{}", d.verdict);
    let logs: Vec<PathBuf> = ["no_kick", "too_short", "sensors_swapped", "handlebar_still"]
        .iter()
        .map(|f| faults.join(format!("{f}.log")))
        .chain(copies("failed_again", &faults.join("no_kick.log"), 1))
        .chain([ride(2), ride(6), ride(10), ride(14)])
        .collect();
    let d = inconclusive(&manifest_of("most_failed", &logs));
    std::fs::remove_dir_all(scratch("failed_again")).ok();
    assert!(d.verdict.contains("5 of 9 rides failed"), "{}", d.verdict);
}

/// The diagnosis's compliant tyres (src/gap/linear.rs, linear equations built from the bodies)
/// and the simulator's (its nonlinear equations differentiated, src/sim/linearize.rs) are
/// separate code; on the lab's bicycle with realistic tyres their weave agrees to 1e-3 /s at
/// 4, 5 and 6 m/s.
#[test]
fn the_diagnosis_tyres_are_the_simulators() {
    use bikeproc::gap::linear::{LinearBike, LinearTyres};
    use bikeproc::sim::ride::{simulate_ride, Effects, RideSpec};
    let lab = LabBike::load(&root().join("data/lab_bike.toml")).unwrap();
    let bike = bikeproc::model::lab::lab_to_benchmark(&lab);
    let tyres = Effects::realistic().tyres.unwrap();
    for v in [4.0, 5.0, 6.0] {
        let mut spec = RideSpec::lab(
            v,
            Effects {
                tyres: Some(tyres),
                ..Effects::default()
            },
        );
        spec.motion = bikeproc::sim::whipple::Motion::ImposedSpeed;
        let truth = simulate_ride(&bike, &spec, 1).unwrap().truth;
        let sim = truth.weave_at(v).unwrap();
        let linear = LinearBike {
            tyres: Some(LinearTyres {
                cornering_per_rad: tyres.cornering_per_rad,
                camber_per_rad: tyres.camber_per_rad,
                relaxation_length_m: tyres.relaxation_length_m,
            }),
            ..LinearBike::whipple(&bike)
        };
        let ours = linear.weave_near(v, sim).unwrap();
        println!("{v}: simulator {sim}, diagnosis {ours}");
        assert!((ours.re - sim.re).abs() < 1e-3 && (ours.im - sim.im).abs() < 1e-3);
    }
}

/// `bikeproc gap --json` carries the keys the lab's scripts read.
#[test]
fn gap_json_has_the_documented_keys() {
    let v = common::run_json(["gap", "--json", "data/rides.toml"]);
    assert!(v["significant"].is_boolean());
    assert!(v["verdict"].is_string());
    let first = &v["ranking"][0];
    for key in [
        "effect",
        "params",
        "params_se",
        "heldout_rms_before",
        "heldout_rms_after",
        "plausible",
        "prior_penalty",
    ] {
        assert!(!first[key].is_null(), "ranking[0].{key} missing");
    }
}

/// Acceptance (issue 12), the lab's other design: 14 coasting rides with no reed switch, each
/// speed the speedometer's reading at the release rounded to 0.1 m/s, the kick 1–1.5 s after
/// it; nine kinds of effect in the library, two outside it (a steer spring, headset
/// friction), and the control, five seeds each.
#[test]
#[ignore = "a long statistical run: docs/gap-calibration.md scores the same on 2,550 campaigns (tests/calibration_files.rs)"]
fn blind_noted_campaigns() {
    let s = score(BlindDesign::Noted);
    assert_bars(&s, 25);
}

/// Issue 29 item 3, the smaller run of `docs/gap-calibration.md` (`bikeproc simulate
/// gap-calibration`): 14 effect-free campaigns of each design, with every realism of the
/// simulator (a true bicycle off from the measured one by its measurement errors; coasting
/// rides, noted readings and sensors mounted off in the `noted` and `varied` designs, rides
/// near the weave speed in the second). The campaign's test must fire on at most 4 of the 42
/// at the 1 % level: with a true rate of 2 % (the acceptance's bar) 5 or more happen 0.15 % of
/// the time; a test firing at 10 % fails it 4 times in 10. These seeds are the calibration's
/// first 14 of each design and hold 4 of its 8 firings among 600 controls (1.3 %; sync 1010,
/// noted 1004 and 1014, varied 1004, at p 0.003–0.008): bars of 2 and then 3 failed on them,
/// each while the 600 put the rate at 1.0–1.3 %. The rate itself is the calibration's to
/// measure; this run guards against a test that fires several times as often. The p-values'
/// histogram is printed.
#[test]
#[ignore = "a long statistical run: docs/gap-calibration.md scores the same on 2,550 campaigns (tests/calibration_files.rs)"]
fn effect_free_campaigns_are_quiet() {
    let bike_path = root().join("data/lab_bike.toml");
    let lab = LabBike::load(&bike_path).unwrap();
    let text = std::fs::read_to_string(&bike_path).unwrap();
    let mut ps = Vec::new();
    for design in BlindDesign::ALL {
        for seed in 1001..1015 {
            let case = Case {
                withheld: Withheld::None,
                design,
                seed,
            };
            let r = run_case(&lab, &text, case).unwrap();
            ps.push(r.campaign_p_value);
        }
    }
    let bins: Vec<usize> = (0..10)
        .map(|b| {
            ps.iter()
                .filter(|&&p| (p * 10.0).floor().min(9.0) as usize == b)
                .count()
        })
        .collect();
    let fired = ps.iter().filter(|&&p| p < 0.01).count();
    println!(
        "p-values by tenths: {bins:?}; {fired} of {} below 0.01",
        ps.len()
    );
    assert!(fired <= 4, "{fired} of {} below 0.01", ps.len());
}

/// Issue 29 item 7: the `varied` design plans each campaign as a lab would, 12–16 rides
/// released evenly from 2.9–3.6 up to 5.8–6.5 m/s. Over eight seeds the manifests hold 12–16
/// rides and not all the same count, their noted readings rise from at most 3.8 m/s (the
/// slowest release, its reading rounded and read by a speedometer within a few percent) to at
/// least 5.5.
#[test]
fn a_varied_design_draws_its_own_plan() {
    let bike_path = root().join("data/lab_bike.toml");
    let lab = LabBike::load(&bike_path).unwrap();
    let mut counts = Vec::new();
    for seed in 1001..1009 {
        let (files, _) = bikeproc::sim::campaign::blind_campaign_plus(
            &lab,
            "bike.toml",
            Withheld::None,
            BlindDesign::Varied,
            seed,
            &[],
            Draws::Broad,
        )
        .unwrap();
        let manifest = &files
            .iter()
            .find(|(p, _)| p.as_os_str() == "rides.toml")
            .unwrap()
            .1;
        let noted: Vec<f64> = manifest
            .lines()
            .filter_map(|l| l.strip_prefix("noted_speed_mps = "))
            .map(|v| v.parse().unwrap())
            .collect();
        let logs = manifest.lines().filter(|l| l.starts_with("log = ")).count();
        assert_eq!(logs, noted.len());
        assert!((12..=16).contains(&logs), "seed {seed}: {logs} rides");
        assert!(noted[0] <= 3.8, "seed {seed}: slowest {noted:?}");
        assert!(noted[logs - 1] >= 5.5, "seed {seed}: fastest {noted:?}");
        counts.push(logs);
    }
    println!("rides per campaign: {counts:?}");
    assert!(counts.iter().any(|&c| c != counts[0]), "{counts:?}");
}

/// Issue 29: steer damping's size on coasting rides. A damped bicycle slowing through its
/// window reads σ 0.13–0.15 1/s too damped where the ride's fit holds real modes, which the
/// measured bicycle's coasting correction does not know; a damped candidate has the change of
/// its own replay in its prediction (`gap::coasting`). Over the first 10 noted campaigns of
/// `docs/gap-calibration.md` (broad draws: 0.1–0.6 N·m·s/rad, the true bicycle off by its
/// measurement errors) the fitted damping's normalized error had mean +1.21 (8 of 10 within
/// 2 SE) without it, +0.23 (10 of 10) with it; +0.26 (10 of 10) since each effect draws its own
/// true bicycles. The mean must lie within ±0.7 (the mean of 10 honest errors has a standard
/// deviation of 0.32) and 8 of 10 within 2 SE.
#[test]
fn noted_steer_damping_is_unbiased() {
    let bike_path = root().join("data/lab_bike.toml");
    let lab = LabBike::load(&bike_path).unwrap();
    let text = std::fs::read_to_string(&bike_path).unwrap();
    let z: Vec<f64> = (1001..1011)
        .map(|seed| {
            let case = Case {
                withheld: Withheld::SteerDamping,
                design: BlindDesign::Noted,
                seed,
            };
            let r = run_case(&lab, &text, case).unwrap();
            let fit = r.true_fit.expect("the damping's own fit");
            (fit.params[0] - r.truth[0]) / fit.params_se[0]
        })
        .collect();
    let mean = z.iter().sum::<f64>() / z.len() as f64;
    let within = z.iter().filter(|z| z.abs() <= 2.0).count();
    println!("normalized errors {z:.2?}: mean {mean:+.2}, {within} of 10 within 2 SE");
    assert!(mean.abs() <= 0.7, "mean {mean:+.2}");
    assert!(within >= 8, "{within} of 10 within 2 SE");
}

/// A campaign whose rides give the eigenvalue alone (one ride's unusable shape makes every
/// ride of its condition so; here asked for) with a damped candidate first, whose coasting
/// shifts have four parts per ride: the residuals after it carry each ride's own shift error on
/// the two parts the ride has, never beyond them (they once read the next ride's, and past the
/// last ride an index out of bounds). Noted design (coasting rides), 0.1–0.6 N·m·s/rad.
#[test]
fn eigenvalue_only_rides_take_their_own_coasting_errors() {
    use bikeproc::gap::{diagnose, observe::observations};
    use bikeproc::ride::dynamic::run_campaign;
    use bikeproc::ride::modal::ModalOptions;
    let bike_path = root().join("data/lab_bike.toml");
    let lab = LabBike::load(&bike_path).unwrap();
    let text = std::fs::read_to_string(&bike_path).unwrap();
    let (files, truth) = bikeproc::sim::campaign::blind_campaign_plus(
        &lab,
        "bike.toml",
        Withheld::SteerDamping,
        BlindDesign::Noted,
        1003,
        &[],
        Draws::Broad,
    )
    .unwrap();
    let d = bikeproc::blind::in_scratch("eigenvalue_only", &files, &text, &|dir| {
        use bikeproc::blind::stage;
        let manifest = RideManifest::load(&dir.join("rides.toml")).map_err(stage)?;
        let model = bikeproc::read::bicycle::load(&dir.join("bike.toml")).map_err(stage)?;
        let results = run_campaign(&manifest, &model, &ModalOptions::default(), &|_, _| {});
        let (rides, failed) = observations(&results);
        diagnose(
            &rides,
            &failed,
            &model,
            &GapOptions {
                shape: false,
                ..GapOptions::default()
            },
            &|_, _| {},
        )
        .map_err(stage)
    })
    .unwrap();
    assert_eq!(d.parts_per_ride, 2);
    let best = &d.ranking[0];
    assert!(best
        .effects
        .contains(&bikeproc::gap::effects::Effect::SteerDamping));
    println!(
        "{}: {:?} (truth {:.3})",
        best.effect, best.params, truth.params[0]
    );
    assert_eq!(d.residuals.len(), d.residuals_after.len());
    let mut widened = 0;
    for (b, a) in d.residuals.iter().zip(&d.residuals_after) {
        assert!(a.re_se >= b.re_se && a.im_se >= b.im_se, "{}", b.ride);
        widened += usize::from(a.re_se > b.re_se);
    }
    assert!(widened > 0, "no ride carries a shift error");
}

/// Issue 29: a campaign's candidates are ordered by the fit to every ride, in the full
/// covariance. A point mass at the rear frame's centre of mass (noted blind campaign of the
/// broad draws, seed 1012: 1.73 kg) moves the weave in a pattern across rides that only the
/// model's correlated error tells from the measured parameters' own: its χ² is the lowest of
/// the library, while the rides left out one at a time, each weighed alone, favoured a trail
/// 0.80 × measured and ranked the mass tenth. Named first now, within 30 % of the truth
/// (the generator's sealed size) and within two of its standard errors.
#[test]
fn a_mass_seen_across_rides_is_named_first_at_its_size() {
    let (d, truth) = blind_drawn(
        Withheld::FrameMass,
        BlindDesign::Noted,
        1012,
        &[],
        Draws::Broad,
    );
    let best = &d.ranking[0];
    let lowest = d
        .ranking
        .iter()
        .filter(|r| r.plausible && r.effects.len() == 1)
        .min_by(|a, b| a.bic.total_cmp(&b.bic))
        .unwrap();
    println!(
        "best {} {:?} ± {:?} (truth {:.3}); held-out RMS {:.2}",
        best.effect, best.params, best.params_se, truth.params[0], best.heldout_rms_after
    );
    assert!(d.significant, "p {}", d.campaign_p_value);
    assert_eq!(best.effect, "frame_mass");
    assert_eq!(lowest.effect, best.effect);
    let (fit, se, m) = (best.params[0], best.params_se[0], truth.params[0]);
    assert!((fit - m).abs() <= 0.3 * m, "{fit} kg for {m} kg");
    assert!((fit - m).abs() <= 2.0 * se, "{fit} ± {se} kg for {m} kg");
}

/// Issue 33: a campaign of many rides refits each ride left out by a Newton step taken
/// unchecked (`gap::fit::refit_near`), which spares every ride's prediction at a parameter
/// set no other refit shares. On the 16 rides of `data/rides.toml` taken eight times (the
/// copies 0.02 m/s apart, as the divan benchmark `gap_diagnosis_by_rides` builds them), the
/// diagnosis is the checked refits' (`trusted_newton_rides: usize::MAX`): the same ranking,
/// the same ties, and each free candidate's held-out Σz² within 1e-6 of itself (the screen's
/// pairs; measured: all but one of the 23 candidates and pairs equal to the last digit; steer damping 4.6e-8
/// apart, where a checked step was refused and Nelder–Mead refitted). A candidate with a
/// parameter at its search's edge holds the bound where the free step is clamped: within
/// 1e-3 (steer damping with a rear frame mass at 8 kg, 2.0e-4: Σz² 8,457.0 against 8,455.3
/// over 128 rides, 0.003 per ride's part, where the next candidate lies 3,000 away).
#[test]
fn a_large_campaigns_refits_trust_the_newton_step() {
    let newton = |trusted_newton_rides: usize| GapOptions {
        trusted_newton_rides,
        ..GapOptions::default()
    };
    let (rides, [trusted, checked]) = diagnosed_copies(8, false, [newton(128), newton(usize::MAX)]);
    let (mut worst, mut worst_at_bound): (f64, f64) = (0.0, 0.0);
    for t in &trusted.ranking {
        if let Some(c) = checked.ranking.iter().find(|c| c.effect == t.effect) {
            let rel = (t.heldout_chi2_after - c.heldout_chi2_after).abs() / c.heldout_chi2_after;
            if t.at_bound.iter().any(|&b| b) {
                worst_at_bound = worst_at_bound.max(rel);
            } else {
                worst = worst.max(rel);
            }
        }
    }
    assert_same_ranking_and_ties(&trusted, &checked);
    assert!(worst < 1e-6, "held-out Σz² apart by {worst:.1e} of itself");
    assert!(
        worst_at_bound < 1e-3,
        "held-out Σz² apart by {worst_at_bound:.1e} of itself with a bound held"
    );
    println!(
        "{rides} rides, {} candidates: held-out Σz² within {worst:.1e}, {worst_at_bound:.1e} \
         with a bound held",
        trusted.ranking.len()
    );
}

/// Issue 33: a condition with many rides is predicted from a grid of speeds
/// (`gap::speed_grid`), each ride interpolated where the grid's error estimate is below
/// `speed_grid::TOLERANCE` (1e-6), a thousandth of the best standard error a ride's weave
/// has: a residual off by it moves its z by at most 2e-4 (standard errors from 0.005), a Σz² of
/// N parts near N by at most 2 · 2e-4 · √(N Σz²), 4e-4 of itself. On the 16 rides of
/// `data/rides.toml` taken 20 times (the copies 0.02 m/s apart, their coasting windows moved
/// with them: 320 rides), the diagnosis is the one that solves every ride's eigenproblem: the
/// same ranking and ties, every fitted parameter within 5e-3 of its standard error (measured:
/// 1e-14 with the white residuals' errors, Nelder–Mead taking the same steps; 2.6e-3 with the
/// AR(1) sandwich's, the searches parting somewhere below their tolerance, not traced), every
/// held-out Σz² within 4e-4 of itself (measured: 1.4e-5, then 3.8e-5).
#[test]
fn a_large_campaigns_grid_of_speeds_is_its_rides_own_eigenproblems() {
    let grid = |speed_grid: bool| GapOptions {
        speed_grid,
        ..GapOptions::default()
    };
    let (rides, [grid, own]) = diagnosed_copies(20, true, [grid(true), grid(false)]);
    assert_same_ranking_and_ties(&grid, &own);
    let (mut param, mut heldout): (f64, f64) = (0.0, 0.0);
    for (g, o) in grid.ranking.iter().zip(&own.ranking) {
        for ((pg, po), se) in g.params.iter().zip(&o.params).zip(&o.params_se) {
            param = param.max((pg - po).abs() / se);
        }
        heldout =
            heldout.max((g.heldout_chi2_after - o.heldout_chi2_after).abs() / o.heldout_chi2_after);
    }
    println!(
        "{rides} rides, {} candidates: parameters within {param:.1e} of their errors, held-out \
         Σz² within {heldout:.1e}",
        grid.ranking.len()
    );
    assert!(param <= 5e-3, "a parameter {param:.1e} of its error apart");
    assert!(
        heldout <= 4e-4,
        "held-out Σz² {heldout:.1e} of itself apart"
    );
}

/// The 16 rides of `data/rides.toml` taken `times` times (`gap::observe::copies`, the copies
/// 0.02 m/s apart, their coasting windows moved with them where `move_windows`) and diagnosed
/// with each of `options`: the number of rides and the diagnoses.
fn diagnosed_copies<const N: usize>(
    times: usize,
    move_windows: bool,
    options: [GapOptions; N],
) -> (usize, [Diagnosis; N]) {
    use bikeproc::gap::diagnose;
    use bikeproc::gap::observe::{copies, observations};
    use bikeproc::ride::dynamic::run_campaign;
    use bikeproc::ride::modal::ModalOptions;
    let manifest = RideManifest::load(&root().join("data/rides.toml")).unwrap();
    let model = bikeproc::read::bicycle::load(&manifest.bike_path()).unwrap();
    let results = run_campaign(&manifest, &model, &ModalOptions::default(), &|_, _| {});
    let (base, _) = observations(&results);
    let rides = copies(&base, times * base.len(), 0.02, move_windows);
    // The screen's pairs, as these tests were set: they hold the grid and the Newton step,
    // not the search, and every pair of the library (the default in a campaign) takes minutes
    // at 320 rides (tests/gap.rs 391 s in CI against a few minutes before).
    let diagnoses = options.map(|o| {
        let o = GapOptions {
            pairs: bikeproc::gap::PairSearch::Screen,
            ..o
        };
        diagnose(&rides, &[], &model, &o, &|_, _| {}).unwrap()
    });
    (rides.len(), diagnoses)
}

/// Two diagnoses name the same candidates in the same order and tie the same ones.
fn assert_same_ranking_and_ties(a: &Diagnosis, b: &Diagnosis) {
    let names = |d: &Diagnosis| {
        d.ranking
            .iter()
            .map(|r| r.effect.clone())
            .collect::<Vec<_>>()
    };
    assert_eq!(names(a), names(b));
    assert_eq!(a.tied, b.tied);
}

/// The head angle's two descriptions agree: the library's closed form (the front frame's
/// centre of mass and tensor turned about the front axle, the trail from the kept offset) and
/// the simulator's geometry (the steer axis's foot from the axle turned in three dimensions,
/// the trail where the turned axis meets the ground), on the lab's bicycle, to rounding; and
/// both keep what a turn about the axle keeps: the fork's offset `r_F sin λ − c cos λ`, the
/// centre of mass's distance from the axle, the tensor's trace and determinant.
#[test]
fn the_head_angle_turns_the_fork_about_its_axle_in_both_descriptions() {
    use bikeproc::gap::effects::{Change, Effect};
    use bikeproc::model::Benchmark;
    let lab = LabBike::load(&root().join("data/lab_bike.toml")).unwrap();
    let measured = bikeproc::model::lab::lab_to_benchmark(&lab);
    let Change::Bicycle(library) = Effect::HeadAngle.definition().change else {
        panic!("the head angle changes the bicycle's parameters");
    };
    let offset = |b: &Benchmark| b.r_f * b.lambda.sin() - b.c * b.lambda.cos();
    let from_axle = |b: &Benchmark| (b.x_h - b.w).hypot(b.z_h + b.r_f);
    let tensor = |b: &Benchmark| {
        nalgebra::Matrix3::new(
            b.i_hxx, 0.0, b.i_hxz, 0.0, b.i_hyy, 0.0, b.i_hxz, 0.0, b.i_hzz,
        )
    };
    for deg in [-2.0f64, -0.5, 1.0, 2.0] {
        let d = deg.to_radians();
        let (mut a, mut b) = (measured, measured);
        library(&mut a, d);
        bikeproc::sim::campaign::turn_fork_about_axle(&mut b, d);
        for (name, x, y) in [
            ("lambda", a.lambda, b.lambda),
            ("c", a.c, b.c),
            ("x_h", a.x_h, b.x_h),
            ("z_h", a.z_h, b.z_h),
            ("i_hxx", a.i_hxx, b.i_hxx),
            ("i_hzz", a.i_hzz, b.i_hzz),
            ("i_hxz", a.i_hxz, b.i_hxz),
        ] {
            assert!(
                (x - y).abs() <= 1e-12 * x.abs().max(1e-3),
                "{deg}°: {name} {x} against {y}"
            );
        }
        assert!((a.lambda - measured.lambda - d).abs() < 1e-15);
        assert!(
            (offset(&a) - offset(&measured)).abs() < 1e-14,
            "{deg}°: the offset moved"
        );
        assert!((from_axle(&a) - from_axle(&measured)).abs() < 1e-14);
        let (t0, t1) = (tensor(&measured), tensor(&a));
        assert!((t1.trace() - t0.trace()).abs() < 1e-14 * t0.trace());
        assert!((t1.determinant() - t0.determinant()).abs() < 1e-12 * t0.determinant().abs());
        // A slacker axis lengthens the trail.
        assert_eq!(
            a.c > measured.c,
            d > 0.0,
            "{deg}°: trail {} from {}",
            a.c,
            measured.c
        );
        // Nothing else moves.
        let mut rest = a;
        for (to, from) in [
            (&mut rest.lambda, measured.lambda),
            (&mut rest.c, measured.c),
            (&mut rest.x_h, measured.x_h),
            (&mut rest.z_h, measured.z_h),
            (&mut rest.i_hxx, measured.i_hxx),
            (&mut rest.i_hzz, measured.i_hzz),
            (&mut rest.i_hxz, measured.i_hxz),
        ] {
            *to = from;
        }
        assert_eq!(rest, measured);
    }
}

/// Seeds 1–3 of every design with `w` withheld at the suite's sizes: how many name it, first or
/// tied at the top, at its size (within 30 % of the truth, `size_right`); where named, its fit
/// lies within 3 of its standard errors of the truth.
fn named_at_its_size(w: Withheld) -> usize {
    use bikeproc::blind::campaigns::{library_effect, size_right};
    let effect = library_effect(w).expect("in the library");
    let mut right = 0;
    for design in BlindDesign::ALL {
        for seed in 1..=3 {
            let (d, truth) = blind_design(w, design, seed);
            let fit = d.ranking.iter().find(|r| r.effect == w.label());
            println!(
                "{} {} seed {seed}: truth {:?}, first {:?}, its fit {:?} ± {:?}, tied {:?}",
                w.label(),
                design.label(),
                truth.params,
                d.ranking.first().map(|r| &r.effect),
                fit.map(|r| &r.params),
                fit.map(|r| &r.params_se),
                d.tied
            );
            let Some(fit) = fit.filter(|_| found(&d, w)) else {
                continue;
            };
            let z = (fit.params[0] - truth.params[0]) / fit.params_se[0];
            assert!(z.abs() < 3.0, "{} seed {seed}: z {z:+.2}", design.label());
            right += usize::from(size_right(effect, &fit.params, &truth.params));
        }
    }
    right
}

/// Issue 76, item 3: a head angle off by 1.5–2.5° (the suite's draws; the fork and handlebar
/// turned about the front axle by the simulator's own geometry) is named at its size in at
/// least 8 of 9 campaigns ([`named_at_its_size`]; measured 14 of 15 over seeds 1–5, the miss a
/// varied plan whose first is the trail).
#[test]
fn a_head_angle_off_is_named_at_its_size() {
    let right = named_at_its_size(Withheld::HeadAngle);
    assert!(right >= 8, "{right} of 9 named at their size");
}

/// Issue 76, item 2: plausibility is a prior in the evidence, not a reordering. A head angle
/// 2.4° off (blind sync campaign 1010 of the calibration's broad draws), beyond the ±2° the
/// library takes as plausible, is named at its size: its fit (0.051 ± 0.005 rad) is flagged
/// outside the plausible range and pays the prior's penalty in the order, its closed form
/// d²/(s² + SE²), and still comes first. Set behind every plausible candidate (before
/// 2026-12-06) it ranked 16th, after front_mass.
#[test]
fn a_head_angle_beyond_its_plausible_range_pays_its_prior_and_is_named() {
    let (d, truth) = blind_drawn(
        Withheld::HeadAngle,
        BlindDesign::Sync,
        1010,
        &[],
        Draws::Broad,
    );
    let best = &d.ranking[0];
    let (fit, se, dl) = (best.params[0], best.params_se[0], truth.params[0]);
    println!(
        "best {} {fit:.4} ± {se:.4} rad (truth {dl:.4}), prior {:.2}, BIC {:.1}",
        best.effect, best.prior_penalty, best.bic
    );
    assert!(d.significant, "p {}", d.campaign_p_value);
    assert_eq!(best.effect, "head_angle");
    assert!(!best.plausible, "{fit} ± {se} rad flagged as plausible");
    let s = 0.25 * 0.07;
    let d_out = fit.abs() - 0.035;
    let want = d_out * d_out / (s * s + se * se);
    assert!(want > 0.0 && (best.prior_penalty - want).abs() < 1e-9 * want.max(1.0));
    assert!((fit - dl).abs() <= 0.3 * dl.abs(), "{fit} rad for {dl} rad");
    assert!(
        (fit - dl).abs() <= 3.0 * se,
        "{fit} ± {se} rad for {dl} rad"
    );
}

/// Issue 76, item 3: a body's inertia in the bicycle's plane off by one factor (0.6–0.75 or
/// 1.25–1.4: the rear frame's, then the front frame's) is named at its size in at least 8 of 9
/// campaigns each ([`named_at_its_size`]; measured 9 of 9 first for both).
#[test]
fn a_bodys_inertia_off_as_a_set_is_named_at_its_size() {
    for w in [Withheld::FrameInertia, Withheld::FrontInertia] {
        let right = named_at_its_size(w);
        assert!(
            right >= 8,
            "{}: {right} of 9 named at their size",
            w.label()
        );
    }
}

/// Issue 76, item 3: a dry steer friction's equivalent damping, 4F/(πωA), takes from a swing
/// γ = A sin ωt the energy the friction takes per cycle (4FA: a constant torque over four
/// swings of A), both integrated here over a cycle by the midpoint rule.
#[test]
fn dry_frictions_damping_takes_its_energy_per_cycle() {
    use bikeproc::gap::effects::coulomb_damping_nms_per_rad;
    for (friction_nm, omega, amplitude_rad) in
        [(0.015, 5.2, 0.02), (0.1, 9.0, 0.004), (0.3, 3.0, 0.1)]
    {
        let c = coulomb_damping_nms_per_rad(friction_nm, omega, amplitude_rad);
        let n = 100_000;
        let dt = std::f64::consts::TAU / omega / n as f64;
        let (mut dry, mut viscous) = (0.0, 0.0);
        for k in 0..n {
            let rate = amplitude_rad * omega * (omega * (k as f64 + 0.5) * dt).cos();
            dry += friction_nm * rate.abs() * dt;
            viscous += c * rate * rate * dt;
        }
        assert!((dry / (4.0 * friction_nm * amplitude_rad) - 1.0).abs() < 1e-6);
        assert!(
            (viscous / dry - 1.0).abs() < 1e-6,
            "{viscous} against {dry}"
        );
    }
}

/// Issue 76, item 3: a dry steer friction of 0.01–0.02 N·m (the suite's draws; the simulator's
/// friction a steep tanh of the steer rate) is named at its size in at least 8 of 9 campaigns
/// ([`named_at_its_size`]; measured 9 of 9 first, fitted at 0.80–1.15 of the truth:
/// docs/decisions/2026-12-03-steer-friction.md).
#[test]
fn a_dry_steer_friction_is_named_at_its_size() {
    let right = named_at_its_size(Withheld::SteerFriction);
    assert!(right >= 8, "{right} of 9 named at their size");
}
