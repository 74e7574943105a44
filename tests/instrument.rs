//! Issue 76, item 4: the instrument checked before the bicycle. A campaign of rides simulated
//! with a known effect (viscous steer damping) and written as another lab's instrument writes
//! them (a CSV: time, roll and steer angles, the rear wheel's speed), once as recorded, once
//! with the steer's sign reversed (a sensor mounted the other way), once with the steer in
//! degrees under a column that says radians. The mode shape of the last two misses every
//! candidate by a common factor; the diagnosis says which convention, sets the shape aside and
//! still names the bicycle's effect from the eigenvalues.

mod common;

use bikeproc::gap::instrument::{Convention, SHAPE_MISS_CHI2};
use bikeproc::gap::{diagnose_campaign_with, Diagnosis, GapOptions};
use bikeproc::read::rides::RideManifest;
use bikeproc::sim::draw::{seeded, Draw};
use bikeproc::sim::ride::{simulate_ride, Effects, RideSpec};
use common::root;
use std::path::{Path, PathBuf};

/// The simulated damping (N·m·s/rad): several times a headset's, well beyond what ten rides
/// detect from their eigenvalues alone (docs/gap-calibration.md's detection limits).
const DAMPING_NMS_PER_RAD: f64 = 0.8;

#[derive(Clone, Copy)]
enum Steer {
    AsRecorded,
    SignReversed,
    DegreesAsRadians,
}

/// Ten rides at 3.6–6.3 m/s on the lab bicycle with [`DAMPING_NMS_PER_RAD`], at imposed speed,
/// written to `dir` with the steer as `steer` says and a manifest naming each free decay's
/// window (0.8–3.3 s after the kick); the manifest's path.
fn campaign(dir: &Path, steer: Steer) -> PathBuf {
    let _ = std::fs::remove_dir_all(dir);
    std::fs::create_dir_all(dir).unwrap();
    std::fs::copy(root().join("data/lab_bike.toml"), dir.join("lab_bike.toml")).unwrap();
    let lab = bikeproc::inertia::bike::LabBike::load(&root().join("data/lab_bike.toml")).unwrap();
    let bike = bikeproc::model::lab::lab_to_benchmark(&lab);
    let mut manifest = String::from("version = 1\nbike = \"lab_bike.toml\"\n");
    for k in 0..10u64 {
        let v = 3.6 + 0.3 * k as f64;
        let effects = Effects {
            steer_viscous_nms_per_rad: DAMPING_NMS_PER_RAD,
            ..Effects::default()
        };
        let mut spec = RideSpec::lab(v, effects);
        spec.motion = bikeproc::sim::whipple::Motion::ImposedSpeed;
        let truth = simulate_ride(&bike, &spec, 40 + k).unwrap().truth;
        let mut rng = seeded(700 + k);
        let mut csv = String::from("time_s,roll_rad,steer_rad,rear_wheel_speed_m_per_s\n");
        for i in 0..truth.roll_rad.len() {
            let steer_rad = truth.steer_rad[i] + 0.0005 * rng.normal();
            let steer = match steer {
                Steer::AsRecorded => steer_rad,
                Steer::SignReversed => -steer_rad,
                Steer::DegreesAsRadians => steer_rad.to_degrees(),
            };
            csv += &format!(
                "{:.5},{:.6},{steer:.6},{:.3}\n",
                i as f64 / truth.rate_hz,
                truth.roll_rad[i] + 0.0005 * rng.normal(),
                truth.speed_mps[i] + 0.02 * rng.normal()
            );
        }
        std::fs::write(dir.join(format!("ride_{k}.csv")), csv).unwrap();
        manifest += &format!(
            "\n[[ride]]\nlog = \"ride_{k}.csv\"\nwindow_s = [{:.2}, {:.2}]\n",
            truth.kick_s + 0.8,
            truth.kick_s + 3.3
        );
    }
    let path = dir.join("rides.toml");
    std::fs::write(&path, manifest).unwrap();
    path
}

fn diagnose(path: &Path, shape: bool) -> Diagnosis {
    let manifest = RideManifest::load(path).unwrap();
    let model = manifest.model(None).unwrap();
    let options = GapOptions {
        shape,
        ..GapOptions::default()
    };
    diagnose_campaign_with(&manifest, &model, &options, &|_, _, _| {}).unwrap()
}

#[test]
fn a_shape_recorded_otherwise_is_named_and_set_aside() {
    let base = std::env::temp_dir().join(format!("bikeproc_instrument_{}", std::process::id()));
    let cases = [
        (Steer::AsRecorded, None),
        (Steer::SignReversed, Some(Convention::SignReversed)),
        (Steer::DegreesAsRadians, Some(Convention::SteerInDegrees)),
    ];
    let mut eigenvalue_alone: Option<Diagnosis> = None;
    for (k, (steer, convention)) in cases.into_iter().enumerate() {
        let path = campaign(&base.join(k.to_string()), steer);
        let d = diagnose(&path, true);
        println!(
            "{}\n{:?}\nfailed: {:?}",
            d.verdict, d.instrument, d.rides_failed
        );
        assert!(d.significant, "the damping is beyond the detection limit");
        let check = &d.instrument[0];
        let best = &d.ranking[0];
        match convention {
            None => {
                // Recorded as the model assumes: the shape agrees with a candidate, and the
                // diagnosis rests on the eigenvalue and the shape.
                assert!(!check.misses && check.chi2 <= SHAPE_MISS_CHI2, "{check:?}");
                assert_eq!(d.parts_per_ride, 4);
                assert!(best.effects.iter().any(|e| e.name() == "steer_damping"));
            }
            Some(c) => {
                assert!(check.misses, "{check:?}");
                assert_eq!(check.convention, Some(c), "{check:?}");
                assert_eq!(d.parts_per_ride, 2, "the shape set aside");
                assert!(d.verdict.contains("Instrument: "), "{}", d.verdict);
                // Set aside, the diagnosis is the eigenvalue's alone, exactly: the same
                // ranking as the as-recorded rides diagnosed without their shape (the
                // eigenvalues do not depend on the steer's sign or units).
                // A reversed sign leaves every eigenvalue as it was (the fit's steer
                // amplitudes change sign, nothing else): set aside, the diagnosis is then the
                // as-recorded rides' without their shape, exactly.
                if c == Convention::SignReversed {
                    let alone = eigenvalue_alone
                        .get_or_insert_with(|| diagnose(&base.join("0").join("rides.toml"), false));
                    assert_eq!(best.effect, alone.ranking[0].effect);
                    for (a, b) in best.params.iter().zip(&alone.ranking[0].params) {
                        assert!((a - b).abs() <= 1e-9 * b.abs().max(1.0), "{a} against {b}");
                    }
                }
                assert!(best.effects.iter().any(|e| e.name() == "steer_damping"));
                // Degrees beyond π under a column of radians are refused where they are read,
                // by file, line and column; the rides that stay below π enter and are caught
                // here.
                for f in &d.rides_failed {
                    assert!(
                        f.contains(".csv:") && f.contains("expected from -3.1416 to 3.1416 rad"),
                        "{f}"
                    );
                }
            }
        }
    }
    std::fs::remove_dir_all(&base).ok();
}
