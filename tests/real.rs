//! Issue 13: real recordings from other labs (`../shared/reference`, see its README), and the
//! lab habits they showed the simulator lacked.

use bikeproc::fit::{self, FitOptions};
use bikeproc::read::log::{Log, OutputMode, ReadOptions};
use bikeproc::signal::{self, Extract, Signal};
use bikeproc::sim::draw::{seeded, Draw};
use bikeproc::sim::imu::{FileSpec, LinkModel, Locale, Precision, SensorModel};
use bikeproc::sim::pendulum::{Pendulum, Placement, Release, Torsion};
use bikeproc::sim::simulate_pendulum;
use bikeproc::uncertainty::Measured;
use std::ffi::OsStr;
use std::path::{Path, PathBuf};

mod common;

fn robot_bicycle() -> PathBuf {
    PathBuf::from(env!("CARGO_MANIFEST_DIR")).join("../shared/reference/signals/robot_bicycle")
}

/// The mean of that lab's five rod periods, `TtP1` of its `RigidMeasured.txt` (s).
const TTP1_S: f64 = 0.95691904392;

/// Acceptance: every one of the 57 raw recordings gives a period (8 were refused as "no peak
/// above the noise": lightly damped swings recorded without a rest, whose smallest window
/// variance made the swing itself "quiet"); the rod's five trials average to `TtP1` within
/// 2e-5 relative (their mean's standard error from the scatter is 4e-4 relative, one fit's
/// 4e-6; 2e-5 is the acceptance's bar for two fits of the same five records); every set-up's
/// trials scatter by at most the 0.3 % the README states.
#[test]
fn every_robot_bicycle_recording_gives_a_period() {
    let mut files: Vec<PathBuf> = std::fs::read_dir(robot_bicycle())
        .unwrap()
        .map(|e| e.unwrap().path())
        .filter(|p| p.extension().is_some_and(|e| e == "csv"))
        .collect();
    files.sort();
    assert_eq!(files.len(), 57);
    let mut trials = Vec::new();
    let mut refused = Vec::new();
    for f in &files {
        let sig = signal::load_signal(f, &Extract::DominantRotation, None, &ReadOptions::default())
            .unwrap()
            .signal;
        match fit::analyse(&sig, &FitOptions::default()) {
            Ok(osc) => {
                let p = osc.fit.period_s();
                let name = f.file_stem().unwrap().to_string_lossy().into_owned();
                trials.push((name, Measured::new(p.value, p.se)));
            }
            Err(e) => refused.push(format!("{}: {e}", f.display())),
        }
    }
    assert!(refused.is_empty(), "refused: {refused:#?}");
    let setups = fit::group_trials(&trials);
    assert_eq!(setups.len(), 15, "set-ups (README's table with the rod)");
    for s in &setups {
        let c = &s.combined;
        println!(
            "{:<28} {:.6} ± {:.6} s, scatter {:.3} %, {} trials, flagged {:?}",
            s.setup,
            c.mean.value,
            c.mean.se,
            100.0 * c.sd / c.plain_mean,
            s.trials.len(),
            c.outlier
        );
        assert!(c.sd / c.plain_mean <= 0.003, "{}", s.setup);
    }
    let rod = setups
        .iter()
        .find(|s| s.setup == "UcdrodRodTorsionalFirst")
        .unwrap();
    assert_eq!(rod.trials.len(), 5);
    let mean = rod.combined.plain_mean;
    assert!(
        ((mean - TTP1_S) / TTP1_S).abs() < 2e-5,
        "rod {mean} s against TtP1 {TTP1_S} s"
    );
}

/// The habit behind the eight refusals, simulated: a lightly damped torsion swing (ζ 0.003,
/// 0.42 s, like the fork's) recorded from 1 s after the release for 5 s, no rest before or
/// after, on a 2.5 V offset, five sensors with the simulator's typical noise and bias. Its
/// frequency is the simulator's truth within 4 of the fit's standard errors (2e-5 relative).
#[test]
fn a_swing_recorded_without_rest_gives_its_period() {
    let w = 2.0 * std::f64::consts::PI / 0.42;
    let pendulum = Pendulum::Torsion(Torsion {
        inertia_kgm2: 2.0 / (w * w),
        stiffness_nm_per_rad: 2.0,
        damping_ratio: 0.003,
        coulomb_nm: 0.0,
        swing: None,
    });
    let release = Release {
        rest_s: 1.0,
        ramp_s: 0.5,
        hold_s: 0.5,
        amplitude_deg: 8.0,
        duration_s: 10.0,
    };
    let mut rng = seeded(13);
    let mut spec = FileSpec::single_sensor(
        OutputMode::Quaternion,
        Locale::Tab,
        Precision::Full,
        ("00300418", "fork"),
        65_300,
    );
    spec.extra_header = vec![];
    for seed in 1..=5 {
        let rec = simulate_pendulum(
            &pendulum,
            &release,
            &Placement {
                body_rest: rng.rotation(),
                axis_heading_rad: 0.2,
                sensor_offset_m: nalgebra::Vector3::new(0.05, 0.1, 0.0),
            },
            &SensorModel::typical(&mut rng),
            &LinkModel::perfect(),
            &spec,
            seed,
        );
        let log = Log::parse(
            rec.angles_log.as_bytes(),
            Path::new("sim.log"),
            &ReadOptions::default(),
        )
        .unwrap();
        let whole = signal::dominant_rotation(&log, None).unwrap();
        // Released at 2 s: keep 3–8 s, on an offset.
        let t = whole.times_s();
        let keep: Vec<usize> = (0..t.len())
            .filter(|&i| t[i] >= 3.0 && t[i] < 8.0)
            .collect();
        let cut = Signal {
            index: keep.iter().map(|&i| whole.index[i]).collect(),
            values: keep.iter().map(|&i| whole.values[i] + 2.5).collect(),
            ..whole.clone()
        };
        let osc = fit::analyse(&cut, &FitOptions::default())
            .unwrap_or_else(|e| panic!("seed {seed}: {e}"));
        let truth = pendulum.truth(&release).damped_freq_hz;
        let f = osc.fit.freq_hz();
        println!("seed {seed}: {} ± {} Hz, truth {truth}", f.value, f.se);
        assert!((f.value - truth).abs() < 4.0 * f.se, "seed {seed}");
        assert!(osc.segment_s.1 - osc.segment_s.0 > 4.5, "the whole record");
    }
}

/// Acceptance (item 2): the three free decays the other lab marked in its uncontrolled
/// balance-assist recording (treadmill at 18 km/h) each give a weave eigenvalue, mode shape and
/// speed. Independent checks: the rear wheel's speed is the treadmill's 5.000 m/s within 3 of
/// its standard errors and 0.02 m/s of the sensor's own error; the three decays, the same
/// bicycle at the same speed, agree in ω within 3 combined standard errors and in σ within 25 %
/// (issue 32's tolerance for two fits of one kick): their roll-rate σ (1.12, 1.11, 0.95 ± 0.03
/// 1/s) scatter beyond their errors, as repeated kicks of one set-up do (the study's
/// between-kick scatter, issue 30 item 5).
#[test]
fn the_uncontrolled_rides_free_decays_give_weave_eigenvalues() {
    use bikeproc::ride::csv::{fit_decay, read_csv_ride, Columns};
    use bikeproc::ride::modal::ModalOptions;
    let path = PathBuf::from(env!("CARGO_MANIFEST_DIR"))
        .join("../shared/reference/rides/balanceassist_uncontrolled_18kmh.csv");
    let ride = read_csv_ride(&path, &Columns::default(), None).unwrap();
    let mut weaves = Vec::new();
    for w in [(141.28, 142.71), (148.53, 149.94), (153.98, 155.50)] {
        let d = fit_decay(&ride, Some(w), &ModalOptions::default()).unwrap();
        let v = d.wheel_speed_mps.unwrap();
        let e = d.weave;
        println!(
            "{w:?}: {:.3} ± {:.3} + {:.3} ± {:.3}i at {:.3} ± {:.3} m/s, |γ/θ| {:.3}",
            e.re,
            e.re_se,
            e.im,
            e.im_se,
            v.value,
            v.se,
            d.shape.unwrap().ratio.value
        );
        assert!(
            (v.value - 5.0).abs() < 3.0 * v.se + 0.02,
            "{} ± {} m/s",
            v.value,
            v.se
        );
        weaves.push(e);
    }
    for (i, a) in weaves.iter().enumerate() {
        for b in &weaves[i + 1..] {
            assert!((a.re - b.re).abs() < 0.25 * a.re.abs().min(b.re.abs()));
            assert!((a.im - b.im).abs() < 3.0 * a.im_se.hypot(b.im_se));
        }
    }
}

/// Issue 32 item 2, acceptance: without a window, the kicks of the uncontrolled balance-assist
/// recording are found and their free decays start and end within 0.2 s of the three that lab
/// marked by hand (141.28–142.71, 148.53–149.94, 153.98–155.50 s), each with its reason.
#[test]
fn the_found_windows_are_the_marked_ones() {
    use bikeproc::ride::csv::{find_kicks, read_csv_ride, Columns};
    use bikeproc::ride::kicks::{DecayEnd, DecayStart};
    let path = PathBuf::from(env!("CARGO_MANIFEST_DIR"))
        .join("../shared/reference/rides/balanceassist_uncontrolled_18kmh.csv");
    let ride = read_csv_ride(&path, &Columns::default(), None).unwrap();
    let kicks = find_kicks(&ride).unwrap();
    for (a, b) in [(141.28, 142.71), (148.53, 149.94), (153.98, 155.50)] {
        let k = kicks
            .iter()
            .find(|k| (k.window_s.0 - a).abs() < 0.2)
            .unwrap_or_else(|| panic!("no window starting near {a} s: {kicks:?}"));
        println!("marked {a}–{b}: found {:?}", k);
        assert!(
            (k.window_s.1 - b).abs() < 0.2,
            "{:?} against {b}",
            k.window_s
        );
        // That lab's kicks are hand pushes (0.3–0.6 s of rising roll rate): the decay starts
        // at the swing back; each ends where the swinging stops.
        assert_eq!(k.starts, DecayStart::SwingBack);
        assert_eq!(k.ends, DecayEnd::Stalls);
    }
}

/// Issue 32 item 3: a window of a file with roll, steer and roll rate is fitted both ways: the
/// eigenvalue is the roll rate's, equal to the fit of the roll rate alone (the same file without
/// its angles), the roll-and-steer fit beside it, a disagreement beyond two combined standard
/// errors said, and the mode shape kept only where the two agree.
#[test]
fn both_fits_of_one_window_are_shown() {
    use bikeproc::ride::csv::{fit_decay, read_csv_ride, Columns, FittedFrom};
    use bikeproc::ride::modal::ModalOptions;
    let path = PathBuf::from(env!("CARGO_MANIFEST_DIR"))
        .join("../shared/reference/rides/balanceassist_uncontrolled_18kmh.csv");
    let ride = read_csv_ride(&path, &Columns::default(), None).unwrap();
    let rate_only = bikeproc::ride::csv::CsvRide {
        roll_rad: None,
        steer_rad: None,
        ..ride.clone()
    };
    let angles_only = bikeproc::ride::csv::CsvRide {
        roll_rate_rad_per_s: None,
        ..ride.clone()
    };
    for w in [(141.28, 142.71), (148.53, 149.94), (153.98, 155.50)] {
        let both = fit_decay(&ride, Some(w), &ModalOptions::default()).unwrap();
        let alone = fit_decay(&rate_only, Some(w), &ModalOptions::default()).unwrap();
        let angles = fit_decay(&angles_only, Some(w), &ModalOptions::default()).unwrap();
        assert_eq!(both.fitted_from, FittedFrom::RollRate);
        assert_eq!(alone.fitted_from, FittedFrom::RollRate);
        assert_eq!(angles.fitted_from, FittedFrom::RollAndSteer);
        let e = |w: &bikeproc::ride::modal::Eigenvalue| [w.re, w.im, w.re_se, w.im_se];
        assert_eq!(e(&both.weave), e(&alone.weave));
        let beside = both.roll_and_steer_weave.expect("the angles' fit beside");
        assert_eq!(e(&beside), e(&angles.weave));
        let (a, b) = (both.weave, beside);
        let apart = (a.re - b.re).abs() > 2.0 * a.re_se.hypot(b.re_se)
            || (a.im - b.im).abs() > 2.0 * a.im_se.hypot(b.im_se);
        assert_eq!(both.fits_disagree(), apart, "{w:?}");
        assert_eq!(both.shape.is_some(), !apart, "{w:?}");
        if let Some(s) = both.shape {
            assert_eq!(s.ratio.value, angles.shape.unwrap().ratio.value);
        }
        println!("{w:?}: {a:?} against {b:?}: disagree {apart}");
    }
}

/// Issue 32 item 3, which of the two fits is calibrated: 40 kicks of simulated treadmill
/// recordings (the lab's bicycle held at 3.5–6 m/s, four recordings of ten rides) written as
/// that lab's sensors give them: a gyro's roll rate (0.005 rad/s noise, a bias of 0.002 rad/s
/// drawn per ride), an IMU's fused roll (a complementary filter of time constant 0.5 s blending
/// the gyro with the accelerometer's apparent vertical, which the sensor's lateral acceleration
/// v ψ̇ + x ψ̈ + h φ̈ tilts, at x = 0.3 m, h = 0.7 m; ψ̇ from the steer by the bicycle's
/// kinematics), the steer in 0.1° steps on an offset. Found without windows, each kick's default
/// eigenvalue (the roll rate's) lies within two of its standard errors of the simulator's weave
/// at the speed for at least 80 % of the kicks in σ and in ω (measured 37 and 39 of 40; 95 % is
/// the nominal; the roll-and-steer fit of the same windows: 36 and 33 with the AR(1) sandwich,
/// 19 and 18 with errors of white residuals).
#[test]
fn the_roll_rates_fit_is_the_calibrated_one() {
    use bikeproc::ride::csv::{read_csv_ride, ride_decays, Columns, FittedFrom};
    use bikeproc::ride::modal::ModalOptions;
    use bikeproc::sim::ride::{simulate_ride, Effects, RideSpec};
    let bike = lab_benchmark();
    let (tau_s, sensor_x_m, sensor_h_m, step_deg) = (0.5, 0.3, 0.7, 0.1);
    let mut rng = seeded(11);
    let dir = std::env::temp_dir().join(format!("bikeproc_fused_{}", std::process::id()));
    std::fs::create_dir_all(&dir).unwrap();
    let (mut within, mut beside_within, mut kicks) = ([0usize; 2], [0usize; 2], 0usize);
    for rec in 0..4u64 {
        let mut csv =
            String::from("time_s,roll_rad,steer_deg,roll_rate_rad_per_s,wheel_speed_mps\n");
        let (mut t0, mut truths) = (0.0, Vec::new());
        let offset_deg = rng.range(-3.0, 3.0);
        for k in 0..10 {
            let v = 3.5 + 2.5 * rng.uniform();
            let mut spec = RideSpec::lab(v, Effects::default());
            spec.motion = bikeproc::sim::whipple::Motion::ImposedSpeed;
            let truth = simulate_ride(&bike, &spec, 1000 * rec + k).unwrap().truth;
            let (n, dt) = (truth.roll_rad.len(), 1.0 / truth.rate_hz);
            let (phi, delta) = (&truth.roll_rad, &truth.steer_rad);
            let yaw_rate = |i: usize| {
                (truth.speed_mps[i] * delta[i]
                    + bike.c * (delta[i + 1] - delta[i - 1]) / (2.0 * dt))
                    * bike.lambda.cos()
                    / bike.w
            };
            let gyro_bias = 0.002 * rng.normal();
            let mut fused = phi[0];
            for i in 2..n - 2 {
                let gyro =
                    (phi[i + 1] - phi[i - 1]) / (2.0 * dt) + gyro_bias + 0.005 * rng.normal();
                let roll_acc = (phi[i + 1] - 2.0 * phi[i] + phi[i - 1]) / (dt * dt);
                let yaw_acc = (yaw_rate(i + 1) - yaw_rate(i - 1)) / (2.0 * dt);
                let lateral =
                    truth.speed_mps[i] * yaw_rate(i) + sensor_x_m * yaw_acc + sensor_h_m * roll_acc;
                let apparent = phi[i] - lateral / 9.81 + 0.02 * rng.normal();
                fused += dt * (gyro + (apparent - fused) / tau_s);
                let steer = ((delta[i].to_degrees() + offset_deg) / step_deg).round() * step_deg;
                csv += &format!(
                    "{:.5},{fused:.6},{steer:.2},{gyro:.6},{:.3}\n",
                    t0 + i as f64 * dt,
                    truth.speed_mps[i] + 0.02 * rng.normal()
                );
            }
            truths.push((t0, v, truth.clone()));
            t0 += n as f64 * dt;
        }
        let path = dir.join(format!("treadmill_{rec}.csv"));
        std::fs::write(&path, csv).unwrap();
        let ride = read_csv_ride(&path, &Columns::default(), None).unwrap();
        for k in ride_decays(&ride, None, None, None, &ModalOptions::default()).unwrap() {
            let Some(d) = &k.decay else { continue };
            let (_, v, truth) = truths
                .iter()
                .rev()
                .find(|(t0, _, _)| *t0 <= k.kick.window_s.0)
                .unwrap();
            let want = truth.weave_at(*v).unwrap();
            assert_eq!(d.decay.fitted_from, FittedFrom::RollRate);
            let e = d.decay.weave;
            let b = d
                .decay
                .roll_and_steer_weave
                .expect("the angles' fit beside");
            for (j, (x, se, t)) in [(e.re, e.re_se, want.re), (e.im, e.im_se, want.im)]
                .into_iter()
                .enumerate()
            {
                within[j] += usize::from((x - t).abs() < 2.0 * se);
            }
            beside_within[0] += usize::from((b.re - want.re).abs() < 2.0 * b.re_se);
            beside_within[1] += usize::from((b.im - want.im).abs() < 2.0 * b.im_se);
            kicks += 1;
        }
    }
    std::fs::remove_dir_all(&dir).ok();
    println!("{kicks} kicks: within 2 SE, roll rate {within:?}, roll and steer {beside_within:?}");
    assert_eq!(kicks, 40, "one fitted decay per ride");
    for w in within {
        assert!(w as f64 >= 0.8 * kicks as f64, "{within:?} of {kicks}");
    }
}

/// Item 2 on the simulator's truth: a ride at constant speed written as another instrument
/// would write it (roll in rad with noise, steer in degrees in 0.1° steps on an offset, a
/// receiver clock jittering ±1 ms, a wheel-speed column), one free decay fitted from the CSV
/// gives the simulator's weave at that speed within 3 standard errors, five seeds.
#[test]
fn a_simulated_csv_ride_gives_the_simulators_weave() {
    use bikeproc::ride::csv::{fit_decay, read_csv_ride, Columns};
    use bikeproc::ride::modal::ModalOptions;
    use bikeproc::sim::ride::{simulate_ride, Effects, RideSpec};
    let bike = lab_benchmark();
    let dir = std::env::temp_dir().join(format!("bikeproc_real_{}", std::process::id()));
    std::fs::create_dir_all(&dir).unwrap();
    for seed in 1..=5u64 {
        let v = 4.0 + 0.4 * seed as f64;
        let mut spec = RideSpec::lab(v, Effects::default());
        spec.motion = bikeproc::sim::whipple::Motion::ImposedSpeed;
        let truth = simulate_ride(&bike, &spec, seed).unwrap().truth;
        let mut rng = seeded(100 + seed);
        let mut csv = String::from("time_s,roll_rad,steer_deg,rear_wheel_speed_m_per_s\n");
        for i in 0..truth.roll_rad.len() {
            let t = i as f64 / truth.rate_hz + rng.range(-0.001, 0.001);
            let steer_deg = (truth.steer_rad[i].to_degrees() + 1.7 + 0.05 * rng.normal()) * 10.0;
            csv += &format!(
                "{t:.5},{:.6},{:.1},{:.3}\n",
                truth.roll_rad[i] + 0.001 * rng.normal(),
                steer_deg.round() / 10.0,
                truth.speed_mps[i] + 0.02 * rng.normal()
            );
        }
        let path = dir.join(format!("ride_{seed}.csv"));
        std::fs::write(&path, csv).unwrap();
        let ride = read_csv_ride(&path, &Columns::default(), None).unwrap();
        let d = fit_decay(
            &ride,
            Some((truth.kick_s + 0.8, truth.kick_s + 3.3)),
            &ModalOptions::default(),
        )
        .unwrap();
        let want = truth.weave_at(v).unwrap();
        let e = d.weave;
        println!(
            "seed {seed}, {v} m/s: {:.3} ± {:.3} + {:.3} ± {:.3}i, truth {want:.3}",
            e.re, e.re_se, e.im, e.im_se
        );
        assert!((e.re - want.re).abs() < 3.0 * e.re_se, "seed {seed}");
        assert!((e.im - want.im).abs() < 3.0 * e.im_se, "seed {seed}");
        let s = d.wheel_speed_mps.unwrap();
        assert!((s.value - v).abs() < 3.0 * s.se + 1e-3, "seed {seed}");
        // The roll rate alone, as a rate gyro gives it (the roll's central difference, gyro
        // noise 0.005 rad/s), 1.5 s after the kick's first 0.8 s: the eigenvalue, no shape.
        let n = truth.roll_rad.len();
        let mut csv = String::from("time,gyro_x\n");
        for i in 1..n - 1 {
            let rate = (truth.roll_rad[i + 1] - truth.roll_rad[i - 1]) * truth.rate_hz / 2.0;
            csv += &format!(
                "{:.5},{:.6}\n",
                i as f64 / truth.rate_hz,
                rate + 0.005 * rng.normal()
            );
        }
        std::fs::write(&path, csv).unwrap();
        let cols: Columns = "roll_rate=gyro_x".parse().unwrap();
        let ride = read_csv_ride(&path, &cols, None).unwrap();
        let d = fit_decay(
            &ride,
            Some((truth.kick_s + 0.8, truth.kick_s + 2.3)),
            &ModalOptions::default(),
        )
        .unwrap();
        let e = d.weave;
        println!(
            "  roll rate alone: {:.3} ± {:.3} + {:.3} ± {:.3}i",
            e.re, e.re_se, e.im, e.im_se
        );
        assert!(d.shape.is_none());
        assert!((e.re - want.re).abs() < 3.0 * e.re_se, "seed {seed}");
        assert!((e.im - want.im).abs() < 3.0 * e.im_se, "seed {seed}");
    }
    std::fs::remove_dir_all(&dir).ok();
}

/// A bad field of a ride's CSV is named by file, line and column; a missing time column and a
/// column asked for that is not there are named too.
#[test]
fn a_bad_csv_ride_is_named_where() {
    use bikeproc::ride::csv::{read_csv_ride, Columns};
    let dir = std::env::temp_dir().join(format!("bikeproc_real_bad_{}", std::process::id()));
    std::fs::create_dir_all(&dir).unwrap();
    let path = dir.join("bad.csv");
    std::fs::write(&path, "time_s,roll_rad\n0.00,0.1\n0.01,x\n").unwrap();
    let e = read_csv_ride(&path, &Columns::default(), None)
        .unwrap_err()
        .to_string();
    assert!(e.contains("bad.csv:3:6"), "{e}");
    std::fs::write(&path, "when,roll_rad\n0.00,0.1\n").unwrap();
    let e = read_csv_ride(&path, &Columns::default(), None)
        .unwrap_err()
        .to_string();
    assert!(e.contains("no time column"), "{e}");
    let cols: Columns = "roll_rate=gyro_x".parse().unwrap();
    let e = read_csv_ride(&path, &cols, None).unwrap_err().to_string();
    assert!(e.contains("no column `gyro_x`"), "{e}");
    assert!("speed=x".parse::<Columns>().is_err());
    // Issue 33: values outside their physical range, by line and column; a roll rate that never
    // moves.
    for (text, want) in [
        (
            "time_s,roll_rate_rad_per_s,rear_wheel_speed_m_per_s\n0.00,0.1,4\n0.01,0.2,-5\n",
            "bad.csv:3:3: wheel_speed `rear_wheel_speed_m_per_s` = -5 m/s",
        ),
        (
            "time_s,roll_rate_rad_per_s,rear_wheel_speed_m_per_s\n0.00,0.1,1e9\n0.01,0.2,4\n",
            "bad.csv:2:3: wheel_speed `rear_wheel_speed_m_per_s` = 1000000000 m/s",
        ),
        (
            "time_s,roll_rate_rad_per_s\n0.00,0.5\n0.01,0.5\n0.02,0.5\n",
            "roll_rate `roll_rate_rad_per_s` is 0.5 in every row",
        ),
    ] {
        std::fs::write(&path, text).unwrap();
        let e = read_csv_ride(&path, &Columns::default(), None)
            .unwrap_err()
            .to_string();
        assert!(e.contains(want), "{e}");
    }
    std::fs::remove_dir_all(&dir).ok();
}

/// Item 2 on the controlled rides: each of the 63 post-kick segments (roll rate only, that
/// lab's own column names, 0.5–2.6 s) gives a weave eigenvalue with finite standard errors and a
/// frequency inside the searched 1–20 rad/s (not on its edge), the roll rate's variance mostly
/// accounted for. (That lab's own fits are held out; this checks the reading and the fit run.)
#[test]
fn every_controlled_segment_gives_a_weave_eigenvalue() {
    use bikeproc::ride::csv::{fit_decay, read_csv_ride, Columns};
    use bikeproc::ride::modal::ModalOptions;
    let dir = PathBuf::from(env!("CARGO_MANIFEST_DIR"))
        .join("../shared/reference/rides/balanceassist_controlled");
    let cols: Columns = "roll_rate=gyro_x".parse().unwrap();
    let mut n = 0;
    let mut files: Vec<PathBuf> = std::fs::read_dir(&dir)
        .unwrap()
        .map(|e| e.unwrap().path())
        .collect();
    files.sort();
    for f in &files {
        let ride = read_csv_ride(f, &cols, None).unwrap();
        let d = fit_decay(&ride, None, &ModalOptions::default())
            .unwrap_or_else(|e| panic!("{}: {e}", f.display()));
        let e = d.weave;
        assert!(e.im > 1.05 && e.im < 19.95, "{}: ω {}", f.display(), e.im);
        assert!(e.re_se.is_finite() && e.re_se > 0.0 && e.im_se.is_finite() && e.im_se > 0.0);
        assert!(d.vaf[0] > 0.8, "{}: VAF {}", f.display(), d.vaf[0]);
        n += 1;
    }
    assert_eq!(n, 63);
}

/// Item 2, every kick of a long recording: three simulated rides (4.4, 5.0 and 5.6 m/s, the
/// speed held, pushed for 0.1, 0.3 and 0.45 s) written one after another into one CSV as a
/// rate gyro and a wheel encoder would give them (roll rate with 0.005 rad/s noise, wheel speed
/// with 0.02 m/s, a clock jittering ±1 ms). Without a window, each ride's free decay starts
/// after its push has ended and before the swing after it, nothing else is fitted, and each
/// fitted weave is the simulator's at the wheel's speed within 3 standard errors.
#[test]
fn every_kick_of_a_long_simulated_recording_is_found_and_fitted() {
    use bikeproc::ride::csv::{read_csv_ride, ride_decays, ride_decays_file, Columns};
    use bikeproc::ride::modal::ModalOptions;
    use bikeproc::sim::ride::{simulate_ride, Effects, RideSpec};
    let bike = lab_benchmark();
    let mut rng = seeded(7);
    let mut csv = String::from("time,gyro_x,wheel\n");
    let mut t0 = 0.0;
    let mut truths = Vec::new();
    for (k, (v, push_s)) in [(4.4, 0.1), (5.0, 0.3), (5.6, 0.45)]
        .into_iter()
        .enumerate()
    {
        let mut spec = RideSpec::lab(v, Effects::default());
        spec.motion = bikeproc::sim::whipple::Motion::ImposedSpeed;
        // The same impulse, spread over the push (the weave's frequency grows with the
        // swing's size: a larger one would be another test).
        spec.kick.peak_force_n *= 0.1 / push_s;
        spec.kick.duration_s = push_s;
        let truth = simulate_ride(&bike, &spec, 20 + k as u64).unwrap().truth;
        let n = truth.roll_rad.len();
        for i in 1..n - 1 {
            let rate = (truth.roll_rad[i + 1] - truth.roll_rad[i - 1]) * truth.rate_hz / 2.0;
            csv += &format!(
                "{:.5},{:.6},{:.3}\n",
                t0 + i as f64 / truth.rate_hz + rng.range(-0.001, 0.001),
                rate + 0.005 * rng.normal(),
                truth.speed_mps[i] + 0.02 * rng.normal()
            );
        }
        truths.push((t0, v, push_s, truth.clone()));
        t0 += n as f64 / truth.rate_hz;
    }
    let dir = std::env::temp_dir().join(format!("bikeproc_kicks_{}", std::process::id()));
    std::fs::create_dir_all(&dir).unwrap();
    let path = dir.join("long.csv");
    std::fs::write(&path, csv).unwrap();
    let cols: Columns = "roll_rate=gyro_x,wheel_speed=wheel".parse().unwrap();
    let ride = read_csv_ride(&path, &cols, None).unwrap();
    let kicks = ride_decays(&ride, None, None, None, &ModalOptions::default()).unwrap();
    // Read in two passes, in memory of the kicks' own size: the same kicks and fits.
    let streamed = ride_decays_file(
        &path,
        &cols,
        None,
        None,
        None,
        None,
        &ModalOptions::default(),
    )
    .unwrap();
    assert_eq!(streamed.len(), kicks.len());
    for (a, b) in streamed.iter().zip(&kicks) {
        assert_eq!(a.kick.window_s, b.kick.window_s);
        let weave = |k: &bikeproc::ride::csv::KickDecay| {
            k.decay.as_ref().map(|d| {
                let e = d.decay.weave;
                [e.re, e.im, e.re_se, e.im_se]
            })
        };
        assert_eq!(weave(a), weave(b));
    }
    for k in &kicks {
        println!(
            "kick at {:.2} s, window {:?}, fitted {}",
            k.kick.at_s,
            k.kick.window_s,
            k.decay.is_some()
        );
    }
    for (t0, v, _, truth) in &truths {
        println!(
            "ride from {t0:.2} s: kick at {:.2} s, caught at {:.2} s, weave {:?}",
            t0 + truth.kick_s,
            t0 + truth.catch_s,
            truth.weave_at(*v)
        );
    }
    let fitted: Vec<_> = kicks.iter().filter(|k| k.decay.is_some()).collect();
    assert_eq!(fitted.len(), 3, "one fitted decay per ride");
    for (k, (t0, v, push_s, truth)) in fitted.iter().zip(&truths) {
        // The free decay starts once the push is over (within the 0.05 s half-width of the
        // finder's smoothing) and no later than the swing after it (half a weave period on).
        let after_push = k.kick.window_s.0 - (t0 + truth.kick_s + push_s);
        let half_period = std::f64::consts::PI / truth.weave_at(*v).unwrap().im;
        println!(
            "{v} m/s, push {push_s} s: starts {after_push:.3} s after it ({:?})",
            k.kick.starts
        );
        assert!(
            (-0.05..half_period + 0.05).contains(&after_push),
            "decay starts {after_push:.3} s after the push"
        );
        let d = k.decay.as_ref().unwrap();
        let speed = d.speed_mps.unwrap();
        assert!(
            (speed.value - v).abs() < 3.0 * speed.se + 1e-3,
            "{speed:?} at {v}"
        );
        let want = truth.weave_at(*v).unwrap();
        let e = d.decay.weave;
        println!(
            "{v} m/s: {:.3} ± {:.3} + {:.3} ± {:.3}i, truth {want:.3}",
            e.re, e.re_se, e.im, e.im_se
        );
        assert!((e.re - want.re).abs() < 3.0 * e.re_se, "σ at {v} m/s");
        assert!((e.im - want.im).abs() < 3.0 * e.im_se, "ω at {v} m/s");
    }
    std::fs::remove_dir_all(&dir).ok();
}

/// Items 2 and 3 together: a campaign manifest of CSV rides with the lab's controller in a
/// `[controller]` table (`fixtures/real/balanceassist_gain6.toml`). Every segment is analysed,
/// and the model weave each is compared with is the closed loop's, checked against the
/// eigenvalues of a state matrix built here from the bicycle's M, C1, K0, K2 and that lab's
/// law written out by hand (steer torque G (4.7 − v) φ̇ below 4.7 m/s, 0.7 (v − 4.7) φ above,
/// benchmark signs), to 1e-9 relative.
#[test]
fn a_controlled_campaign_of_csv_rides_is_compared_with_the_closed_loop() {
    use bikeproc::model::control::SteerControl;
    use bikeproc::read::rides::RideManifest;
    use bikeproc::ride::dynamic::{run_campaign, Analysed};
    use bikeproc::ride::modal::ModalOptions;
    use nalgebra::{Matrix2, Matrix4, Vector2};
    let path =
        PathBuf::from(env!("CARGO_MANIFEST_DIR")).join("fixtures/real/balanceassist_gain6.toml");
    let manifest = RideManifest::load(&path).unwrap();
    let model = manifest.model(None).unwrap();
    let open = bikeproc::model::Canonical {
        control: SteerControl::NONE,
        ..model.nominal_canonical()
    };
    let closed_loop = |v: f64| {
        let (k_roll, k_roll_rate) = if v < 4.7 {
            (0.0, 6.0 * (4.7 - v))
        } else {
            (0.7 * (v - 4.7), 0.0)
        };
        let minv = open.m.try_inverse().unwrap();
        let b = minv * Vector2::new(0.0, 1.0);
        let kq = -minv * (open.g * open.k0 + v * v * open.k2)
            + b * Vector2::new(k_roll, 0.0).transpose();
        let cq = -minv * (v * open.c1) + b * Vector2::new(k_roll_rate, 0.0).transpose();
        let mut a = Matrix4::zeros();
        a.fixed_view_mut::<2, 2>(0, 2)
            .copy_from(&Matrix2::identity());
        a.fixed_view_mut::<2, 2>(2, 0).copy_from(&kq);
        a.fixed_view_mut::<2, 2>(2, 2).copy_from(&cq);
        a.complex_eigenvalues()
    };
    let rides = run_campaign(&manifest, &model, &ModalOptions::default(), &|_, _| {});
    assert_eq!(rides.len(), 21);
    for r in &rides {
        let Ok(Analysed::Csv(d)) = &r.result else {
            panic!("{}: {:?}", r.name, r.result.as_ref().err());
        };
        let v = d.speed_mps.unwrap().value;
        let m = d.model.as_ref().unwrap();
        let want = closed_loop(v)
            .iter()
            .copied()
            .filter(|l| l.im > 0.0)
            .min_by(|a, b| (a.im - m.im).abs().total_cmp(&(b.im - m.im).abs()))
            .unwrap();
        println!(
            "{}: {v:.3} m/s, model {:.4} + {:.4}i, by hand {want:.4}",
            r.name, m.re, m.im
        );
        assert!((m.re - want.re).abs() < 1e-9 * want.norm(), "{}", r.name);
        assert!((m.im - want.im).abs() < 1e-9 * want.norm(), "{}", r.name);
    }
}

/// A controller table that cannot be a controller is refused, naming the manifest: speeds
/// that do not increase, and a gain list of another length.
#[test]
fn a_bad_controller_table_is_named() {
    use bikeproc::read::rides::RideManifest;
    let dir = std::env::temp_dir().join(format!("bikeproc_ctrl_{}", std::process::id()));
    std::fs::create_dir_all(&dir).unwrap();
    let path = dir.join("rides.toml");
    std::fs::write(dir.join("ride_01.log"), "").unwrap();
    let head = "version = 1\nbike = \"bike.txt\"\n[controller]\n";
    for (table, says) in [
        (
            "speeds_mps = [0.0, 4.7, 4.0]\nroll_nm_per_rad = [0.0, 1.0, 2.0]\n",
            "increas",
        ),
        (
            "speeds_mps = [0.0, 4.7]\nroll_nm_per_rad = [0.0, 1.0, 2.0]\n",
            "roll_nm_per_rad",
        ),
    ] {
        let ride = "[[ride]]\nlog = \"ride_01.log\"\nnoted_speed_mps = 4.0\n";
        std::fs::write(&path, format!("{head}{table}{ride}")).unwrap();
        let e = RideManifest::load(&path).unwrap_err().to_string();
        println!("{e}");
        assert!(e.contains("rides.toml"), "{e}");
        assert!(e.contains(says), "{e}");
    }
    std::fs::remove_dir_all(&dir).ok();
}

/// Acceptance (item 3): `bikeproc gap` on a controlled campaign runs, with the controller in
/// the model and the actuator's gain among the candidates, and names where the gap lies (the
/// frequency: that lab's controlled rides sway 3–4 rad/s slower than the closed loop of
/// `Balanceassistv1`, beyond 2 standard errors in most segments) and its closest candidate with
/// a parameter and a finite standard error. Without the controller the same rides are compared
/// with the open loop, and the actuator's gain is no candidate.
#[test]
fn gap_on_a_controlled_campaign_names_where_and_which() {
    let root = PathBuf::from(env!("CARGO_MANIFEST_DIR"));
    let gap = |manifest: &Path| -> serde_json::Value {
        common::run_json([
            OsStr::new("gap"),
            OsStr::new("--json"),
            manifest.as_os_str(),
        ])
    };
    let names = |d: &serde_json::Value| -> Vec<String> {
        d["ranking"]
            .as_array()
            .unwrap()
            .iter()
            .map(|r| r["effect"].as_str().unwrap().to_string())
            .collect()
    };
    let d = gap(&root.join("fixtures/real/balanceassist_gain6.toml"));
    assert_eq!(d["rides_used"], 21);
    assert_eq!(d["significant"], true);
    let verdict = d["verdict"].as_str().unwrap();
    println!("{verdict}");
    // Issue 29 item 6: the first sentence says whether the gap is explained and why, the
    // numbers of the test that decides it with it; where the gap lies comes next.
    let first = verdict.lines().next().unwrap();
    assert!(
        first.starts_with("Explained: ") || first.starts_with("Not explained: "),
        "{verdict}"
    );
    assert_eq!(first.starts_with("Explained: "), d["explained"] == true);
    if d["explained"] == false {
        assert!(first.contains("fails the"), "{first}");
    }
    assert!(
        verdict
            .lines()
            .nth(1)
            .unwrap()
            .starts_with("Where: weave frequency lower than the model's by"),
        "{verdict}"
    );
    assert!(names(&d).iter().any(|n| n == "actuator_gain"));
    let best = &d["ranking"][0];
    for se in best["params_se"].as_array().unwrap() {
        assert!(
            se.as_f64().is_some_and(|s| s.is_finite() && s > 0.0),
            "{best}"
        );
    }
    assert!(
        best["heldout_rms_after"].as_f64().unwrap() < best["heldout_rms_before"].as_f64().unwrap()
    );
    if d["explained"] == true {
        assert!(best["heldout_rms_after"].as_f64().unwrap() <= 2.0);
    }
    // The same rides without the controller's table.
    let text =
        std::fs::read_to_string(root.join("fixtures/real/balanceassist_gain6.toml")).unwrap();
    let start = text.find("[controller]").unwrap();
    let end = text.find("[[ride]]").unwrap();
    let here = format!("\"{}/", root.join("fixtures/real").display());
    let open =
        format!("{}{}", &text[..start], &text[end..]).replace("\"../", &format!("{here}../"));
    let dir = std::env::temp_dir().join(format!("bikeproc_open_{}", std::process::id()));
    std::fs::create_dir_all(&dir).unwrap();
    let path = dir.join("gain6_open_loop.toml");
    std::fs::write(&path, open).unwrap();
    let d = gap(&path);
    std::fs::remove_dir_all(&dir).ok();
    assert_eq!(d["rides_used"], 21);
    assert!(!names(&d)
        .iter()
        .any(|n| n == "actuator_gain" || n == "steer_inertia"));
}

/// `bikeproc stability --controller FILE` reads the `[controller]` table of a campaign
/// manifest, names the controller beside the bicycle, and moves the weave speed: G = 6 rate
/// feedback below 4.7 m/s stabilises `Balanceassistv1`'s weave from under 1 m/s, where the
/// open loop's weave is stable only above 3.44 m/s. A file that is no TOML is refused with
/// exit code 2, naming the file and line.
#[test]
fn stability_with_a_controller_from_the_command_line() {
    let root = PathBuf::from(env!("CARGO_MANIFEST_DIR"));
    let bike = root.join("../shared/reference/bicycleparameters/Balanceassistv1Benchmark.txt");
    let args = |controller: Option<&Path>| {
        let mut a = vec![
            OsStr::new("stability"),
            OsStr::new("--json"),
            OsStr::new("--bike"),
        ];
        a.push(bike.as_os_str());
        if let Some(f) = controller {
            a.extend([OsStr::new("--controller"), f.as_os_str()]);
        }
        a.into_iter().map(OsStr::to_owned).collect::<Vec<_>>()
    };
    let weave = |d: serde_json::Value| -> (String, f64) {
        (
            d["bike"].as_str().unwrap().to_string(),
            d["weave_speed_mps"].as_f64().unwrap(),
        )
    };
    let gain6 = root.join("fixtures/real/balanceassist_gain6.toml");
    let (name, closed) = weave(common::run_json(args(Some(&gain6))));
    let (_, open) = weave(common::run_json(args(None)));
    println!("{name}: weave speed {closed:.3} m/s (open loop {open:.3})");
    assert!(name.contains("balance assist, G = 6"), "{name}");
    assert!(closed < 1.0 && open > 3.0, "{closed} {open}");
    let out = common::run(args(Some(&root.join("README.md"))));
    assert_eq!(out.status.code(), Some(2));
    assert!(String::from_utf8_lossy(&out.stderr).contains("README.md:"));
}

/// Issue 32 item 5: the second pass over a long recording keeps exactly the rows inside one of
/// the windows, whatever their order and overlap (each row's time against every window, here
/// by a plain scan, is the independent expectation), and reads nothing past the last end.
#[test]
fn the_windowed_reader_keeps_the_rows_of_every_window() {
    use bikeproc::ride::csv::{read_csv_ride, read_csv_ride_within, Columns};
    let dir = std::env::temp_dir().join(format!("bikeproc_within_{}", std::process::id()));
    std::fs::create_dir_all(&dir).unwrap();
    let path = dir.join("rows.csv");
    let mut text = String::from("time_s,roll_rate_rad_per_s\n");
    for i in 0..5000 {
        text += &format!("{:.2},{:.4}\n", i as f64 * 0.01, (i as f64 * 0.07).sin());
    }
    std::fs::write(&path, text).unwrap();
    let windows = [
        (30.0, 31.5),
        (2.0, 9.0),
        (5.0, 6.0),
        (8.5, 12.25),
        (40.0, 40.0),
    ];
    let all = read_csv_ride(&path, &Columns::default(), None).unwrap();
    let kept = read_csv_ride_within(&path, &Columns::default(), None, Some(&windows)).unwrap();
    let want: Vec<f64> = all
        .time_s
        .iter()
        .copied()
        .filter(|&t| windows.iter().any(|&(a, b)| t >= a && t <= b))
        .collect();
    assert_eq!(kept.time_s, want);
    assert_eq!(want.len(), 1026 + 151 + 1);
    std::fs::remove_dir_all(&dir).ok();
}

/// Issue 32 items 2 and 3, a controller's short decays: a roll-rate recording at 100 Hz without
/// a time column (read with `--rate`) holding 20 kicks whose free motion is a weave damped as
/// hard as a balance-assist controller damps it at low speed (σ 3.5 1/s, ω 6 rad/s: under 0.1
/// of its first swing after 0.65 s, then gyro noise of 0.005 rad/s), each an impulse (the
/// decay from its first peak). Every kick is found and fitted, and its weave agrees with the
/// closed form within the tolerances that lab's fits are held to (σ within 25 %, ω within 10 %)
/// for at least 17 of the 20 (measured 20). Before, none was found: the last half-swing, sunk
/// into the noise, counted as a stalled swing, and 0.8 s was the shortest decay taken.
#[test]
fn a_controllers_short_decays_are_found_and_fitted() {
    let kicks = ClosedFormKicks::new((3.5, 6.0), 20, 5.0, (0.4, 0.8), 4.0);
    closed_form_kicks_agree(kicks, 17, 17);
}

/// A roll-rate recording at 100 Hz without a time column (gyro noise 0.005 rad/s, the wheel at
/// 2.5 m/s), `kicks` kicks `spacing_s` apart (plus up to 1 s), each followed for `lasting_s` by
/// A e^{−σt} sin(ωt), A drawn in `amplitude` (rad/s); a kick found within 0.6 s of one written
/// is that one.
struct ClosedFormKicks {
    sigma: f64,
    omega: f64,
    kicks: usize,
    spacing_s: f64,
    amplitude: (f64, f64),
    lasting_s: f64,
}

impl ClosedFormKicks {
    /// `(σ, ω)`, then the other fields in their order.
    fn new(
        (sigma, omega): (f64, f64),
        kicks: usize,
        spacing_s: f64,
        amplitude: (f64, f64),
        lasting_s: f64,
    ) -> Self {
        ClosedFormKicks {
            sigma,
            omega,
            kicks,
            spacing_s,
            amplitude,
            lasting_s,
        }
    }
}

/// Writes `spec`'s recording, reads it with `--rate 100` and its columns named, finds every kick
/// without a window as `bikeproc dynamic` does, and asserts that it finds the kicks written and
/// no others, each fitted, and that for at least `at_least` of them the fit agrees with the
/// closed form within the tolerances that lab's fits are held to (σ within 25 %, ω within
/// 10 %).
/// The kicks of a treadmill recording written as a microcontroller logs it (`gyro_x,wheel`
/// over rows at 100 Hz, no time column), found and fitted without windows.
fn kicks_of_treadmill_log(name: &str, text: &str) -> Vec<bikeproc::ride::csv::KickDecay> {
    use bikeproc::ride::csv::{read_csv_ride, ride_decays, Columns};
    use bikeproc::ride::modal::ModalOptions;
    let dir = std::env::temp_dir().join(format!("bikeproc_{name}_{}", std::process::id()));
    std::fs::create_dir_all(&dir).unwrap();
    let path = dir.join("treadmill.log");
    std::fs::write(&path, text).unwrap();
    let cols: Columns = "roll_rate=gyro_x,wheel_speed=wheel".parse().unwrap();
    let ride = read_csv_ride(&path, &cols, Some(100.0)).unwrap();
    let kicks = ride_decays(&ride, None, None, None, &ModalOptions::default()).unwrap();
    std::fs::remove_dir_all(&dir).ok();
    kicks
}

fn closed_form_kicks_agree(spec: ClosedFormKicks, seed: u64, at_least: usize) {
    let mut rng = seeded(seed);
    let kicks_at: Vec<f64> = (0..spec.kicks)
        .map(|k| 0.6 * spec.spacing_s + spec.spacing_s * k as f64 + rng.range(0.0, 1.0))
        .collect();
    let amplitude: Vec<f64> = (0..spec.kicks)
        .map(|_| rng.range(spec.amplitude.0, spec.amplitude.1))
        .collect();
    let rows = ((kicks_at[spec.kicks - 1] + spec.lasting_s + spec.spacing_s) * 100.0) as usize;
    let mut text = String::from("gyro_x,wheel\n");
    for i in 0..rows {
        let t = i as f64 * 0.01;
        let mut x = 0.005 * rng.normal();
        for (&at, &a) in kicks_at.iter().zip(&amplitude) {
            if t >= at && t < at + spec.lasting_s {
                let tau = t - at;
                x += a * (-spec.sigma * tau).exp() * (spec.omega * tau).sin();
            }
        }
        text += &format!("{x:.5},{:.3}\n", 2.5 + 0.02 * rng.normal());
    }
    let kicks = kicks_of_treadmill_log(&format!("closed_{seed}"), &text);
    let mut agree = 0;
    for &at in &kicks_at {
        let k = kicks
            .iter()
            .find(|k| (k.kick.at_s - at).abs() < 0.6)
            .unwrap_or_else(|| panic!("no kick found near {at:.2} s"));
        let (w, e) = (
            k.kick.window_s,
            k.decay.as_ref().expect("fitted").decay.weave,
        );
        println!(
            "kick {at:.2}: window {:.2}–{:.2} ({:.2} s, {:?}): σ {:.3} ± {:.3}, ω {:.3} ± {:.3}",
            w.0,
            w.1,
            w.1 - w.0,
            k.kick.ends,
            -e.re,
            e.re_se,
            e.im,
            e.im_se
        );
        agree += usize::from(
            (-e.re - spec.sigma).abs() < 0.25 * spec.sigma.abs()
                && (e.im - spec.omega).abs() < 0.1 * spec.omega,
        );
    }
    println!("{agree} of {} agree", spec.kicks);
    assert_eq!(kicks.len(), spec.kicks);
    assert!(
        agree >= at_least,
        "{agree} of {} within 25 % (σ) and 10 % (ω)",
        spec.kicks
    );
}

/// The lab's measured bicycle (`data/lab_bike.toml`) in benchmark parameters: the simulator's
/// truth for the simulated recordings here.
fn lab_benchmark() -> bikeproc::model::Benchmark {
    let lab = bikeproc::inertia::bike::LabBike::load(
        &PathBuf::from(env!("CARGO_MANIFEST_DIR")).join("data/lab_bike.toml"),
    )
    .unwrap();
    bikeproc::model::lab::lab_to_benchmark(&lab)
}

/// Issue 32 item 2, a weave that grows: below its weave speed a bicycle's swings grow after the
/// kick until it is caught. A roll-rate recording (100 Hz, no time column) of 12 kicks on a
/// held, quiet bicycle, each followed by x = A e^{0.3 t} sin(3.2 t) (rad/s) for 5 s and a catch,
/// with 0.005 rad/s of gyro noise: every kick is found, and its fitted weave is the closed form's
/// within 25 % in σ and 10 % in ω for at least 10 of the 12. Before, the finder took the second
/// growing swing for a new push (and the second before the largest swing for the motion's
/// background) and found none.
#[test]
fn a_weave_that_grows_is_found_and_fitted() {
    let kicks = ClosedFormKicks::new((-0.3, 3.2), 12, 9.0, (0.15, 0.3), 5.0);
    closed_form_kicks_agree(kicks, 23, 10);
}

/// Issue 32's held-out bars on the simulator: a treadmill recording of the balance-assist
/// bicycle (its BicycleParameters file) with that lab's controller (steer torque G (4.7 − v) φ̇
/// below 4.7 m/s, G = 8, the motor's rotor weightless), two kicks at each of six belt speeds
/// (6–16 km/h), written as that lab's microcontroller writes it: no time column, a roll-rate
/// gyro (0.005 rad/s of noise) and the wheel's speed, read at `--rate 100` without windows.
/// At least 90 % of the kicks are found (a fitted decay starting from the push's end to half a
/// weave period after it) and at least 85 % of those agree with the simulator's own linearized
/// weave at the belt's speed as the issue asks of that lab's fits: ω within 10 %, σ within
/// 25 % or 2 standard errors. Measured: 12 of 12 found, 11 of 12 agree (σ at 1.67 m/s 25 %
/// more damped than the linearized −2.89 /s). With the finder's level at a tenth of the kick's
/// peak (before 9909a01) 4 of 12 were found: at 1.7–3.3 m/s the push (0.1 s, a third of the
/// period) was taken for an impulse and its swing back ended the decay; with only the push's
/// rise measured from the background, 12 found and 10 agree (the decays cut at the tenth).
#[test]
fn a_controlled_treadmill_recording_meets_the_held_out_bars() {
    use bikeproc::sim::ride::{simulate_ride, Effects, MotorController, RideSpec, SteerMotor};
    let root = PathBuf::from(env!("CARGO_MANIFEST_DIR"));
    let bike = bikeproc::model::Benchmark::load(
        &root.join("../shared/reference/bicycleparameters/Balanceassistv1Benchmark.txt"),
    )
    .unwrap();
    let g = 8.0;
    let effects = Effects {
        steer_motor: Some(SteerMotor {
            reflected_inertia_kgm2: 0.0,
            controller: Some(MotorController {
                speeds_mps: vec![0.0, 4.7, 20.0],
                gains: vec![
                    [0.0, 0.0, 4.7 * g, 0.0],
                    [0.0; 4],
                    [0.7 * 15.3, 0.0, 0.0, 0.0],
                ],
                delivered: 1.0,
                speed_sensor_scale: 1.0,
                lag_s: 0.0,
            }),
        }),
        ..Effects::default()
    };
    let mut rng = seeded(32);
    let mut csv = String::from("gyro_x,wheel\n");
    let mut rows = 0usize;
    let mut truths = Vec::new();
    for (k, kmh) in [6.0, 8.0, 10.0, 12.0, 14.0, 16.0]
        .iter()
        .flat_map(|v| [v, v])
        .enumerate()
    {
        let v = kmh / 3.6;
        let mut spec = RideSpec::lab(v, effects.clone());
        spec.motion = bikeproc::sim::whipple::Motion::ImposedSpeed;
        spec.kick.peak_force_n = rng.range(100.0, 200.0);
        let truth = simulate_ride(&bike, &spec, 320 + k as u64).unwrap().truth;
        let n = truth.roll_rad.len();
        let t0 = rows as f64 / truth.rate_hz;
        for i in 1..n - 1 {
            let rate = (truth.roll_rad[i + 1] - truth.roll_rad[i - 1]) * truth.rate_hz / 2.0;
            csv += &format!(
                "{:.6},{:.3}\n",
                rate + 0.005 * rng.normal(),
                truth.speed_mps[i] + 0.02 * rng.normal()
            );
            rows += 1;
        }
        truths.push((t0, v, spec.kick.duration_s, truth));
    }
    let kicks = kicks_of_treadmill_log("held_out", &csv);
    for k in &kicks {
        println!(
            "kick at {:.2} s, window {:.2?}, {:?}, {:?}, {:?}",
            k.kick.at_s, k.kick.window_s, k.kick.starts, k.kick.ends, k.not_fitted
        );
    }
    let (mut found, mut agree) = (0, 0);
    for (t0, v, push_s, truth) in &truths {
        let want = truth.weave_at(*v).unwrap();
        let push_end = t0 + truth.kick_s + push_s;
        let half_period = std::f64::consts::PI / want.im;
        let Some(d) = kicks.iter().find_map(|k| {
            let after = k.kick.window_s.0 - push_end;
            (-0.05..half_period + 0.05)
                .contains(&after)
                .then_some(k.decay.as_ref()?)
        }) else {
            println!("{v:.2} m/s: not found (truth {want:.3})");
            continue;
        };
        found += 1;
        let e = d.decay.weave;
        let ok = (e.im - want.im).abs() <= 0.1 * want.im
            && ((e.re - want.re).abs() <= 0.25 * want.re.abs()
                || (e.re - want.re).abs() <= 2.0 * e.re_se);
        agree += usize::from(ok);
        println!(
            "{v:.2} m/s: {:.3} ± {:.3} + {:.3} ± {:.3}i, truth {want:.3}{}",
            e.re,
            e.re_se,
            e.im,
            e.im_se,
            if ok { "" } else { " (disagrees)" }
        );
    }
    println!(
        "{found} of {} found, {agree} of {found} agree",
        truths.len()
    );
    assert!(
        found * 10 >= 9 * truths.len(),
        "{found} of {} found",
        truths.len()
    );
    assert!(agree * 100 >= 85 * found, "{agree} of {found} agree");
}

/// A controller's push that lasts past its peak: that lab's segments gain10_10kmh_kick3 and
/// gain10_14kmh_kick3 (marked from the push's peak, 0.60 and 0.87 rad/s) swing back as far as
/// the push took them, where a free decay's second half-swing is smaller (σ −1.2 1/s, ω 11
/// rad/s: 0.71 of the first). Each set into a treadmill-like log (3 s of 0.005 rad/s noise
/// before and after, a 0.1 s rise into its first sample, a 0.3 s taper after its last) beside
/// kick1 of the same set-up: every one found, the forced ones from their swing back, with ω
/// within 10 % of the segment's own roll-rate fit. Before, the swing back was taken for a new
/// push and the decay ended 0.14 s after the peak: neither kick3 was found (the proxy of the
/// 63 segments: 58 found, 60 now).
#[test]
fn a_push_that_lasts_past_its_peak_starts_the_decay_at_the_swing_back() {
    use bikeproc::ride::csv::{read_csv_ride, ride_decays, Columns};
    use bikeproc::ride::kicks::DecayStart;
    use bikeproc::ride::modal::ModalOptions;
    let dir = PathBuf::from(env!("CARGO_MANIFEST_DIR"))
        .join("../shared/reference/rides/balanceassist_controlled");
    for set_up in ["gain10_10kmh", "gain10_14kmh"] {
        let mut rng = seeded(3);
        let mut text = String::from("gyro_x,wheel\n");
        let mut rows = 0usize;
        let mut marked = Vec::new();
        for kick in ["kick1", "kick3"] {
            let path = dir.join(format!("{set_up}_{kick}.csv"));
            let cols: Columns = "roll_rate=gyro_x,time=time".parse().unwrap();
            let segment = read_csv_ride(&path, &cols, None).unwrap();
            let x = segment.roll_rate_rad_per_s.clone().unwrap();
            let n = x.len();
            let own = ride_decays(
                &segment,
                Some((0.0, (n - 1) as f64 * 0.01)),
                None,
                None,
                &ModalOptions::default(),
            )
            .unwrap();
            let own = own[0].decay.as_ref().unwrap().decay.weave;
            let push = |v: f64, text: &mut String, rows: &mut usize| {
                *text += &format!("{v:.5},3.000\n");
                *rows += 1;
            };
            for _ in 0..300 {
                push(0.005 * rng.normal(), &mut text, &mut rows);
            }
            for i in 0..10 {
                let u = (i as f64 + 1.0) / 10.0;
                push(
                    x[0] * (std::f64::consts::FRAC_PI_2 * u).sin(),
                    &mut text,
                    &mut rows,
                );
            }
            let start_s = rows as f64 * 0.01;
            for &v in &x {
                push(v, &mut text, &mut rows);
            }
            for i in 0..30 {
                let u = (i as f64 + 1.0) / 30.0;
                push(
                    x[n - 1] * (1.0 - u) + 0.005 * rng.normal(),
                    &mut text,
                    &mut rows,
                );
            }
            marked.push((kick, start_s, start_s + (n - 1) as f64 * 0.01, own));
        }
        for _ in 0..300 {
            text += &format!("{:.5},3.000\n", 0.005 * rng.normal());
        }
        let kicks = kicks_of_treadmill_log(set_up, &text);
        for (kick, a, b, own) in marked {
            let found = kicks
                .iter()
                .find(|k| k.kick.window_s.0 < b && k.kick.window_s.1 > a)
                .and_then(|k| Some((k, k.decay.as_ref()?)))
                .unwrap_or_else(|| panic!("{set_up} {kick} ({a:.2}–{b:.2} s) not found"));
            let w = found.1.decay.weave;
            println!(
                "{set_up} {kick}: {:?} {:.2}–{:.2} s, {:.3} ± {:.3} + {:.3} ± {:.3}i; the segment's own {:.3} + {:.3}i",
                found.0.kick.starts,
                found.0.kick.window_s.0,
                found.0.kick.window_s.1,
                w.re,
                w.re_se,
                w.im,
                w.im_se,
                own.re,
                own.im
            );
            assert!(
                (w.im - own.im).abs() <= 0.1 * own.im,
                "{set_up} {kick}: ω {:.3} for the segment's {:.3}",
                w.im,
                own.im
            );
            if kick == "kick3" {
                assert_eq!(
                    found.0.kick.starts,
                    DecayStart::SwingBack,
                    "{set_up} {kick}"
                );
            }
        }
    }
}

/// Issue 75: the balance-assist study's repeated kicks, Cochran's Q per condition. Each
/// condition's Q and degrees of freedom are its own set-ups' share of the pooled ones, so
/// they add up to them exactly; every condition with repeats has one, a controlled condition's
/// 7 set-ups of 3 kicks give 2 × 7 × 2 = 28 degrees of freedom (σ and ω), and each Q/dof is
/// above 1 (the repeats scatter beyond their fits' errors: 1,118 on 88 pooled).
#[test]
fn the_studys_repeated_kicks_scatter_per_condition() {
    let d = balance_assist_study();
    let s = d.between_kick_scatter.as_ref().expect("repeated kicks");
    let q: f64 = s.by_condition.iter().map(|c| c.q).sum();
    let dof: usize = s.by_condition.iter().map(|c| c.q_dof).sum();
    assert!((q - s.q).abs() <= 1e-9 * s.q, "{q} against {}", s.q);
    assert_eq!(dof, s.q_dof);
    assert_eq!(s.by_condition.len(), d.conditions.len());
    for c in &s.by_condition {
        if d.conditions[c.condition].controlled {
            assert_eq!(c.q_dof, 28, "{}", d.conditions[c.condition].name);
        }
        assert!(c.q / c.q_dof as f64 > 1.0, "{c:?}");
    }
}

/// The balance-assist study's diagnosis (`fixtures/real/balanceassist_study.toml`), made once
/// for the tests that read it.
fn balance_assist_study() -> &'static bikeproc::gap::Diagnosis {
    static D: std::sync::OnceLock<bikeproc::gap::Diagnosis> = std::sync::OnceLock::new();
    D.get_or_init(|| balance_assist_study_with(bikeproc::gap::PairSearch::Standard))
}

/// The balance-assist study diagnosed with the pairs and triples `pairs` chooses.
fn balance_assist_study_with(pairs: bikeproc::gap::PairSearch) -> bikeproc::gap::Diagnosis {
    let root = PathBuf::from(env!("CARGO_MANIFEST_DIR"));
    let study =
        bikeproc::read::study::Study::load(&root.join("fixtures/real/balanceassist_study.toml"))
            .unwrap();
    let model = bikeproc::read::bicycle::load(&study.bike_path().unwrap()).unwrap();
    let options = bikeproc::gap::GapOptions {
        pairs,
        ..Default::default()
    };
    bikeproc::gap::diagnose_manifests_with(&study.conditions, &model, &options, &|_, _, _| {})
        .unwrap()
}

/// Issue 76, item 2: in the balance-assist study no candidate with a parameter of the bicycle
/// at its search's edge or within its standard error of it (shown as a bound) ranks above one
/// whose bicycle is inside its ranges; the first is such a fit. On landed main before the
/// change the first was frame_cg_height + frame_cg_x, frame_cg_x at the edge 0.5; with the
/// edge alone and triples beyond the best pair's, frame_cg_height + frame_cg_x +
/// actuator_gain, frame_cg_x ≤ 0.652 within its SE of 0.5.
#[test]
fn the_studys_ranking_puts_no_bound_above_an_interior_fit() {
    let d = balance_assist_study();
    let bounded: Vec<bool> = d.ranking.iter().map(|r| r.bicycle_at_edge()).collect();
    assert!(
        !bounded.is_empty() && !bounded[0],
        "first: {}",
        d.ranking[0].effect
    );
    let first_bound = bounded.iter().position(|&b| b).unwrap_or(bounded.len());
    assert!(
        bounded[first_bound..].iter().all(|&b| b),
        "an interior fit below a bound: {:?}",
        d.ranking
            .iter()
            .map(|r| (r.effect.as_str(), r.bicycle_at_edge()))
            .collect::<Vec<_>>()
    );
    // The bounded fits are still shown, below: the search found them.
    assert!(d
        .ranking
        .iter()
        .any(|r| r.effect == "frame_cg_height + frame_cg_x"));
}

/// Issue 76, item 1: the balance-assist study's screen (62 candidates ranked) returns the
/// first five of fitting every pair of the library (more ranked; `bikeproc gap --every-pair`),
/// in order, each needed or not alike, with the same fitted values.
#[test]
fn the_studys_screen_finds_the_first_five_of_every_pair() {
    let screened = balance_assist_study();
    let every = balance_assist_study_with(bikeproc::gap::PairSearch::Every);
    assert!(screened.ranking.len() < every.ranking.len());
    for (a, b) in screened.ranking.iter().zip(&every.ranking).take(5) {
        assert_eq!((&a.effect, a.not_needed), (&b.effect, b.not_needed));
        // The same fit of the same candidate: only rounding in a different order of work.
        for (x, y) in a.params.iter().zip(&b.params) {
            assert!(
                (x - y).abs() <= 1e-9 * x.abs().max(1.0),
                "{}: {x} {y}",
                a.effect
            );
        }
    }
}

/// Issue 76, item 1: the balance-assist study's screen of three effects (the best pair, the
/// next three, the pair of the lowest χ², each with every other effect: about 70) returns the
/// first five of every three effects of the library (1,771; `bikeproc gap --every-triple`), in
/// order, each tied or not alike, their values within a tenth of their standard errors (the two
/// start their fits apart: the screen's triples from a grid, every triple from its pairs'
/// fits). Both admit a larger candidate by a Bonferroni over the effects that could extend
/// the smaller one; over the candidates tried, the screen admitted steer_damping +
/// actuator_lag + front_inertia 4th, which every triple did not. Kept out of the suite for its
/// 40 s on 2 cores (90 s before); measured: docs/decisions/2026-12-04-study-joint-whitening.md.
#[test]
#[ignore = "about 40 s on 2 cores: every three effects of the library"]
fn the_studys_screen_finds_the_first_five_of_every_triple() {
    let screened = balance_assist_study();
    let every = balance_assist_study_with(bikeproc::gap::PairSearch::EveryTriple);
    assert_eq!(screened.ranking[0].effects.len(), 3);
    assert_eq!(screened.tied, every.tied);
    for (a, b) in screened.ranking.iter().zip(&every.ranking).take(5) {
        assert_eq!((&a.effect, a.not_needed), (&b.effect, b.not_needed));
        for ((x, y), se) in a.params.iter().zip(&b.params).zip(&b.params_se) {
            assert!((x - y).abs() <= 0.1 * se, "{}: {x} {y} ± {se}", a.effect);
        }
    }
}

/// Issue 76, item 4: a condition's χ² in the study and alone differ, and the study says why.
/// Each controlled condition's `scatter_alone` is the between-kick scatter that condition gets
/// diagnosed alone (the same estimator on the same rides: to 1e-9), and where it differs from
/// the study's pooled scatter the study names both beside that condition's χ².
#[test]
fn a_conditions_chi2_in_the_study_says_why_it_differs_alone() {
    let d = balance_assist_study();
    let pooled = &d.between_kick_scatter.as_ref().expect("repeats").per_part;
    let root = PathBuf::from(env!("CARGO_MANIFEST_DIR"));
    for name in ["gain6", "gain8", "gain10"] {
        let path = root.join(format!("fixtures/real/balanceassist_{name}.toml"));
        let m = bikeproc::read::rides::RideManifest::load(&path).unwrap();
        let model = bikeproc::read::bicycle::load(&m.bike_path()).unwrap();
        let alone =
            bikeproc::gap::diagnose_manifests(&[(name.to_string(), m)], &model, &|_, _, _| {})
                .unwrap();
        let own = &alone
            .between_kick_scatter
            .as_ref()
            .expect("repeats")
            .per_part;
        let c = d
            .conditions
            .iter()
            .find(|c| c.name.ends_with(name))
            .expect("the condition");
        for (a, b) in c.scatter_alone.iter().zip(own).take(2) {
            assert!((a - b).abs() <= 1e-9 * b.abs(), "{name}: {a} against {b}");
        }
        let why = c.why_chi2_differs(pooled).expect("the scatters differ");
        assert!(why.contains("pooled"), "{why}");
    }
}
