//! The oscillation signal does not depend on how the sensor sits on the body, nor on the output
//! mode or the locale the receiver wrote.

use bikeproc::fit::{self, FitOptions};
use bikeproc::read::log::{Log, OutputMode, ReadOptions};
use bikeproc::signal::{self, Signal};
use bikeproc::sim::draw::{seeded, Draw};
use bikeproc::sim::imu::{FileSpec, LinkModel, Locale, Precision, SensorModel};
use bikeproc::sim::pendulum::{Pendulum, Placement, Release, Swing, Torsion};
use bikeproc::sim::simulate_pendulum;
use std::path::Path;

fn spec(mode: OutputMode, locale: Locale, precision: Precision) -> FileSpec {
    let mut s = FileSpec::single_sensor(mode, locale, precision, ("00300418", "handlebar"), 65_300);
    s.extra_header = vec![("Operator".into(), "lab".into())];
    s
}

/// The handlebar on the torsion bar (Table 6, test 1: 4.659 Hz) with a Cardan swing mode.
fn pendulum() -> (Pendulum, Release) {
    let w = 2.0 * std::f64::consts::PI * 4.659;
    (
        Pendulum::Torsion(Torsion {
            inertia_kgm2: 34.33 / (w * w),
            stiffness_nm_per_rad: 34.33,
            damping_ratio: 0.006,
            coulomb_nm: 0.0,
            swing: Some(Swing {
                freq_hz: 1.3,
                damping_ratio: 0.02,
                coupling: 0.02,
                release_amplitude_deg: 1.0,
            }),
        }),
        Release {
            rest_s: 2.0,
            ramp_s: 0.8,
            hold_s: 0.7,
            amplitude_deg: 6.0,
            duration_s: 30.0,
        },
    )
}

fn read(text: &str) -> Log {
    Log::parse(
        text.as_bytes(),
        Path::new("sim.log"),
        &ReadOptions::default(),
    )
    .unwrap()
}

#[test]
fn frequency_does_not_depend_on_the_sensor_mounting() {
    let (pend, release) = pendulum();
    let mut rng = seeded(2024);
    let placement = Placement {
        body_rest: rng.rotation(),
        axis_heading_rad: 0.4,
        sensor_offset_m: nalgebra::Vector3::new(0.1, 0.3, 0.0),
    };
    let mut freqs = Vec::new();
    for _ in 0..20 {
        // The same motion, no sensor noise; only the mounting changes (what the log holds is
        // then the same rotation seen from another sensor frame).
        let sensor = SensorModel::ideal(rng.rotation());
        let rec = simulate_pendulum(
            &pend,
            &release,
            &placement,
            &sensor,
            &LinkModel::perfect(),
            &spec(OutputMode::Quaternion, Locale::Tab, Precision::Full),
            7,
        );
        let sig = signal::dominant_rotation(&read(&rec.angles_log), None).unwrap();
        let osc = fit::analyse(&sig, &FitOptions::default()).unwrap();
        freqs.push(osc.fit.freq_hz().value);
    }
    let f0 = freqs[0];
    for f in &freqs {
        assert!(((f - f0) / f0).abs() < 1e-6, "{f} vs {f0}");
    }
    // And it is the torsion mode of the coupled system (the swing shifts it by O(κ²)).
    let truth = pend.truth(&release).damped_freq_hz;
    assert!(((f0 - truth) / truth).abs() < 1e-5, "{f0} vs truth {truth}");
}

#[test]
fn every_mode_and_locale_reads_to_the_same_signal() {
    let (pend, release) = pendulum();
    let mut rng = seeded(99);
    let placement = Placement {
        body_rest: rng.rotation(),
        axis_heading_rad: 1.0,
        sensor_offset_m: nalgebra::Vector3::new(0.1, 0.3, 0.0),
    };
    let sensor = SensorModel::typical(&mut rng);
    let link = LinkModel::default();
    let mut signals: Vec<(String, Signal)> = Vec::new();
    let mut gyros: Vec<Signal> = Vec::new();
    for mode in [
        OutputMode::Euler,
        OutputMode::Quaternion,
        OutputMode::Matrix,
    ] {
        for locale in [Locale::Tab, Locale::Spanish] {
            let rec = simulate_pendulum(
                &pend,
                &release,
                &placement,
                &sensor,
                &link,
                &spec(mode, locale, Precision::Full),
                11,
            );
            let log = read(&rec.angles_log);
            assert_eq!(log.spanish_locale, locale == Locale::Spanish);
            assert!(
                log.gaps.missing_samples > 0,
                "the link should have dropped packets"
            );
            signals.push((
                format!("{mode:?}/{locale:?}"),
                signal::dominant_rotation(&log, None).unwrap(),
            ));
            gyros.push(signal::channel(&read(&rec.cal_log), "Gyr_X", None).unwrap());
        }
    }
    let (ref_name, reference) = &signals[0];
    for (name, s) in &signals[1..] {
        assert!(
            s.index == reference.index,
            "{name}: different gaps than {ref_name}"
        );
        let worst = s
            .values
            .iter()
            .zip(&reference.values)
            .map(|(a, b)| (a - b).abs())
            .fold(0.0, f64::max);
        assert!(
            worst < 1e-9,
            "{name} differs from {ref_name} by {worst:e} rad"
        );
    }
    for g in &gyros[1..] {
        assert!(
            g.values == gyros[0].values && g.index == gyros[0].index,
            "the gyro differs between locales"
        );
    }
}
