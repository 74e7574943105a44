//! Issue 75, items 1–2: the stated model of the free response ([`Estimator::Projected`]: the
//! weave shared by roll and steer, one bounded castor mode, the slow motion as a polynomial)
//! solved by variable projection converges on every ride of `data/` and on the real
//! uncontrolled decays of `../shared/reference/rides`, and doubling its iteration limit moves
//! no ride's eigenvalue or mode shape by more than 0.05 of its standard error.

mod common;

use bikeproc::read::rides::RideManifest;
use bikeproc::ride::dynamic::{run_campaign, Analysed};
use bikeproc::ride::modal::{
    fit_modes, Estimator, ModalFit, ModalOptions, MAX_CURVE_TERMS, PROJECTED_ITERATIONS,
};
use common::root;
use std::path::Path;

/// The projected estimator with τ² and τ³ beside the trend, `iterations` per solve.
fn projected(iterations: usize) -> ModalOptions {
    ModalOptions {
        estimator: Estimator::Projected {
            curve_terms: MAX_CURVE_TERMS,
            iterations,
        },
        ..ModalOptions::default()
    }
}

/// Every IMU ride of `data/rides.toml` analysed with `modal`: (name, its modal fit).
fn data_rides(modal: &ModalOptions) -> Vec<(String, ModalFit)> {
    let manifest = RideManifest::load(&root().join("data/rides.toml")).unwrap();
    let model = bikeproc::read::bicycle::load(&manifest.bike_path()).unwrap();
    run_campaign(&manifest, &model, modal, &|_, _| {})
        .into_iter()
        .map(|r| match r.result {
            Ok(Analysed::Log(t)) => (r.name, t.fit),
            other => panic!("{}: {other:?}", r.name),
        })
        .collect()
}

/// The three free decays the balance-assist lab marked in its uncontrolled recording
/// (`fixtures/real/balanceassist_uncontrolled.toml`), roll and steer (degrees in the file)
/// fitted with `modal`.
fn reference_decays(modal: &ModalOptions) -> Vec<(String, ModalFit)> {
    let path = root().join("../shared/reference/rides/balanceassist_uncontrolled_18kmh.csv");
    let file = std::fs::File::open(&path).unwrap();
    let table = bikeproc::read::csv::CsvTable::read(file, &path).unwrap();
    let index = |name: &str| table.headers.iter().position(|h| h == name).unwrap();
    let cols = table
        .columns(&[index("time_s"), index("roll_rad"), index("steer_deg")])
        .unwrap();
    [(141.28, 142.71), (148.53, 149.94), (153.98, 155.50)]
        .into_iter()
        .map(|(from, to)| {
            let keep: Vec<usize> = (0..cols[0].len())
                .filter(|&i| (from..=to).contains(&cols[0][i]))
                .collect();
            let pick = |c: usize, scale: f64| keep.iter().map(|&i| scale * cols[c][i]).collect();
            let (t, roll, steer): (Vec<f64>, Vec<f64>, Vec<f64>) = (
                pick(0, 1.0),
                pick(1, 1.0),
                pick(2, std::f64::consts::PI / 180.0),
            );
            let fit = fit_modes(&t, &roll, &steer, modal).unwrap();
            (format!("{}:{from}–{to}", path_name(&path)), fit)
        })
        .collect()
}

fn path_name(p: &Path) -> String {
    p.file_name().unwrap().to_string_lossy().into_owned()
}

/// Every solve of every fit ends by its convergence test, none at the limit.
#[test]
fn the_projected_fit_converges_on_every_ride_of_data_and_the_real_decays() {
    let modal = projected(PROJECTED_ITERATIONS);
    let fits = [data_rides(&modal), reference_decays(&modal)].concat();
    assert!(fits.len() >= 19, "{} fits", fits.len());
    for (name, fit) in &fits {
        println!(
            "{name}: σ {:+.3} ± {:.3}, ω {:.3} ± {:.3}, |γ/θ| {:.3} ± {:.3}, {:?}, {:?}",
            fit.weave.re,
            fit.weave.re_se,
            fit.weave.im,
            fit.weave.im_se,
            fit.shape.ratio.value,
            fit.shape.ratio.se,
            fit.structure,
            fit.solver
        );
    }
    let stuck: Vec<_> = fits
        .iter()
        .filter(|(_, f)| !f.solver.converged)
        .map(|(n, f)| format!("{n}: {:?}", f.solver))
        .collect();
    assert!(stuck.is_empty(), "{stuck:#?}");
}

/// Doubling the iteration limit moves no eigenvalue or mode shape by 0.05 of its error.
#[test]
fn doubling_the_projected_fits_limit_moves_no_ride() {
    let once = [
        data_rides(&projected(PROJECTED_ITERATIONS)),
        reference_decays(&projected(PROJECTED_ITERATIONS)),
    ]
    .concat();
    let twice = [
        data_rides(&projected(2 * PROJECTED_ITERATIONS)),
        reference_decays(&projected(2 * PROJECTED_ITERATIONS)),
    ]
    .concat();
    assert_eq!(once.len(), twice.len());
    for ((name, a), (_, b)) in once.iter().zip(&twice) {
        let parts = |f: &ModalFit| {
            [
                (f.weave.re, f.weave.re_se),
                (f.weave.im, f.weave.im_se),
                (f.shape.ratio.value, f.shape.ratio.se),
                (f.shape.phase_rad.value, f.shape.phase_rad.se),
            ]
        };
        for ((x, se), (y, _)) in parts(a).into_iter().zip(parts(b)) {
            assert!((x - y).abs() <= 0.05 * se, "{name}: {x} → {y} (SE {se})");
        }
    }
}

/// One simulated coasting ride released at a speed drawn from `released_mps` (seed `seed`,
/// knife-edge wheels, the lab's bicycle; made as tests/speed.rs makes them), analysed with
/// `modal`: `Ok(([σ z, ω z], converged))` against the simulator's own linearization at the
/// speed where the eigenvalue applies, and whether every solve of its fit converged; or the
/// ride's refusal.
fn coasting_ride_z(
    seed: u64,
    released_mps: (f64, f64),
    modal: &ModalOptions,
) -> Result<([f64; 2], bool), String> {
    use bikeproc::inertia::bike::LabBike;
    use bikeproc::model::lab::lab_to_benchmark;
    use bikeproc::ride::dynamic::{dynamic_test, DynamicOptions};
    use bikeproc::ride::speed::NotedReading;
    use bikeproc::sim::campaign::{coasting_ride, noted_reading, truth_bike};
    use bikeproc::sim::draw::{seeded, Draw};
    use bikeproc::sim::ride::{simulate_ride, Effects};
    let path = root().join("data/lab_bike.toml");
    let model = bikeproc::read::bicycle::load(&path).unwrap();
    let bike = lab_to_benchmark(&truth_bike(&LabBike::load(&path).unwrap()));
    let mut rng = seeded(seed);
    let v = rng.range(released_mps.0, released_mps.1);
    let spec = coasting_ride(&mut rng, v, Effects::default());
    let ride = simulate_ride(&bike, &spec, seed).unwrap();
    let noted = noted_reading(&mut rng, ride.truth.noted_speed_mps);
    let dir =
        std::env::temp_dir().join(format!("bikeproc_estimator_{}_{seed}", std::process::id()));
    std::fs::create_dir_all(&dir).unwrap();
    std::fs::write(dir.join("r.log"), &ride.angles_log).unwrap();
    std::fs::write(dir.join("r_cal.log"), &ride.cal_log).unwrap();
    let options = DynamicOptions {
        noted: Some(NotedReading::lab(noted)),
        modal: *modal,
        ..DynamicOptions::default()
    };
    let r = dynamic_test(&dir.join("r.log"), &model, &options).map_err(|e| e.to_string());
    std::fs::remove_dir_all(&dir).ok();
    let r = r?;
    let v_true = ride.truth.speed_at(r.fit.t_ref_s).unwrap();
    let truth = ride.truth.weave_at(v_true).unwrap();
    let w = &r.fit.weave;
    let z = [(w.re - truth.re) / w.re_se, (w.im - truth.im) / w.im_se];
    Ok((z, r.fit.solver.converged))
}

/// Below the weave speed (released at 3.0–3.5 m/s, the rides of tests/speed.rs's
/// `growing_weaves_are_fitted_in_the_linear_range_or_refused`), the projected fit holds that
/// test's bar: each ride refused, its reason named, or within 3.5 of its errors of the truth,
/// every solve of its fit converged. The windows that hold about half a weave cycle are where the polynomial can take the
/// motion (`ride::modal::MIN_WEAVE_SHARE`): without the test one ride read ω 3.7 of its
/// errors off.
#[test]
fn the_projected_fit_refuses_or_holds_growing_weaves() {
    let modal = projected(PROJECTED_ITERATIONS);
    let mut fitted = 0;
    for seed in 60_000..60_030 {
        match coasting_ride_z(seed, (3.0, 3.5), &modal) {
            Ok((z, converged)) => {
                fitted += 1;
                assert!(z.iter().all(|z| z.abs() < 3.5), "seed {seed}: z {z:?}");
                assert!(converged, "seed {seed}: a solve stopped at its limit");
            }
            Err(e) => assert!(e.contains("too short") || e.contains("no weave"), "{e}"),
        }
    }
    assert!(fitted >= 24, "{fitted} of 30 fitted");
}
