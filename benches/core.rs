//! Benchmarks of the measurement core: reading a one-hour two-sensor log (360,000 rows) from
//! disk, and measuring one 60 s oscillation (spectrum, segment, fit).
//! Run: `cargo bench --bench core`.

use bikeproc::fit::{self, FitOptions};
use bikeproc::read::log::{Log, OutputMode, ReadOptions};
use bikeproc::signal::{self, Signal};
use bikeproc::sim::draw::{seeded, Draw};
use bikeproc::sim::imu::{self, FileSpec, LinkModel, Locale, Precision, SensorModel};
use bikeproc::sim::pendulum::{Pendulum, Placement, Release, Torsion};
use std::path::PathBuf;
use std::sync::OnceLock;

fn main() {
    divan::main();
}

fn torsion() -> Pendulum {
    Pendulum::Torsion(Torsion {
        inertia_kgm2: 1.8906,
        stiffness_nm_per_rad: 34.33,
        damping_ratio: 0.004,
        coulomb_nm: 0.0,
        swing: None,
    })
}

fn spec(sensors: usize, mode: OutputMode) -> FileSpec {
    let mut s = FileSpec::single_sensor(
        mode,
        Locale::Tab,
        Precision::Sensor,
        ("00300417", "frame"),
        51_234,
    );
    if sensors == 2 {
        s.sensors.push(("00300418".into(), "handlebar".into()));
    }
    s
}

/// A one-hour recording of two sensors (Euler), written once to a temporary file.
fn hour_log() -> &'static PathBuf {
    static PATH: OnceLock<PathBuf> = OnceLock::new();
    PATH.get_or_init(|| {
        let mut rng = seeded(1);
        let release = Release {
            rest_s: 5.0,
            ramp_s: 1.0,
            hold_s: 1.0,
            amplitude_deg: 8.0,
            duration_s: 3600.0,
        };
        let placement = Placement {
            body_rest: rng.rotation(),
            axis_heading_rad: 0.0,
            sensor_offset_m: nalgebra::Vector3::new(0.3, 0.0, 0.0),
        };
        let motion = torsion().motion(&release, &placement, 100.0);
        let data: Vec<_> = (0..2)
            .map(|_| SensorModel::typical(&mut rng).measure(&motion, 100.0, &mut rng))
            .collect();
        let packets = LinkModel::default().packets(motion.len(), 100.0, &mut rng);
        let text = imu::write_log(
            &spec(2, OutputMode::Euler),
            false,
            &data,
            &packets,
            None,
            &mut rng,
        );
        let path = std::env::temp_dir().join("bikeproc_bench_hour.log");
        std::fs::write(&path, text).expect("write bench log");
        path
    })
}

#[divan::bench(sample_count = 10)]
fn read_one_hour_two_sensor_log(bencher: divan::Bencher) {
    let path = hour_log();
    bencher.bench(|| Log::open(divan::black_box(path), &ReadOptions::default()).expect("reads"));
}

fn sixty_second_signal() -> &'static Signal {
    static SIG: OnceLock<Signal> = OnceLock::new();
    SIG.get_or_init(|| {
        let mut rng = seeded(2);
        let release = Release {
            rest_s: 3.0,
            ramp_s: 1.0,
            hold_s: 1.0,
            amplitude_deg: 8.0,
            duration_s: 60.0,
        };
        let placement = Placement {
            body_rest: rng.rotation(),
            axis_heading_rad: 0.0,
            sensor_offset_m: nalgebra::Vector3::new(0.3, 0.0, 0.0),
        };
        let rec = bikeproc::sim::simulate_pendulum(
            &torsion(),
            &release,
            &placement,
            &SensorModel::typical(&mut rng),
            &LinkModel::default(),
            &spec(1, OutputMode::Quaternion),
            2,
        );
        let log = Log::parse(
            rec.angles_log.as_bytes(),
            std::path::Path::new("bench.log"),
            &ReadOptions::default(),
        )
        .expect("reads");
        signal::dominant_rotation(&log, None).expect("signal")
    })
}

#[divan::bench(sample_count = 50)]
fn fit_one_60_s_signal(bencher: divan::Bencher) {
    let sig = sixty_second_signal();
    bencher.bench(|| fit::analyse(divan::black_box(sig), &FitOptions::default()).expect("fits"));
}

/// One of the six shared real pendulum signals (`../shared/reference/signals`).
fn reference_signal(name: &str) -> Signal {
    let path = PathBuf::from(env!("CARGO_MANIFEST_DIR"))
        .join("../shared/reference/signals")
        .join(name);
    signal::load_signal(
        &path,
        &signal::Extract::DominantRotation,
        None,
        &ReadOptions::default(),
    )
    .expect("a reference signal")
    .signal
}

/// Issue 17: the period fit on the shared real signals, as `bikeproc period FILE.csv` runs it
/// (spectrum, σ grid, Levenberg–Marquardt, segment refinement, trend by BIC, secondary peaks).
#[divan::bench(
    sample_count = 30,
    args = [
        "browserins_fork_compound_first1_1000hz.csv",
        "browserins_fork_compound_first1_100hz.csv",
        "resonance_wheel_radial_torsional_500hz.csv",
        "resonance_wheel_radial_torsional_100hz.csv",
        "resonance_wheel_axial_compound_500hz.csv",
        "resonance_wheel_axial_compound_100hz.csv",
    ]
)]
fn period_fit_reference(bencher: divan::Bencher, name: &str) {
    let sig = reference_signal(name);
    bencher.bench(|| fit::analyse(divan::black_box(&sig), &FitOptions::default()).expect("fits"));
}

/// The benchmark bicycle's eigenvalues at 10,001 speeds (0–10 m/s), named and tracked.
#[divan::bench(sample_count = 30)]
fn sweep_10001_speeds(bencher: divan::Bencher) {
    let c =
        bikeproc::model::Canonical::from_benchmark(&bikeproc::model::Benchmark::meijaard_2007());
    let speeds: Vec<f64> = (0..=10_000).map(|i| i as f64 * 0.001).collect();
    bencher.bench(|| c.sweep(divan::black_box(&speeds)).expect("sweeps"));
}

/// `bikeproc stability --speeds 0:10:0.0001`'s work: a BicycleParameters bicycle's eigenvalues
/// at 100,001 speeds with their standard errors (issue 14: under 2 s and 150 MB; the bands used
/// to build the 800,008² covariance across speeds).
#[divan::bench(sample_count = 5)]
fn bands_100001_speeds(bencher: divan::Bencher) {
    let root = PathBuf::from(env!("CARGO_MANIFEST_DIR"));
    let p = bikeproc::read::bicycle::load(
        &root.join("../shared/reference/bicycleparameters/BenchmarkBenchmark.txt"),
    )
    .expect("the benchmark bicycle");
    let speeds: Vec<f64> = (0..=100_000).map(|i| i as f64 * 1e-4).collect();
    bencher.bench(|| p.bands(divan::black_box(&speeds)).expect("bands"));
}

/// `bikeproc stability --bike data/lab_bike.toml`'s whole report by the number of speeds (issue
/// 33: a million speeds in under 10 s; 35 s when every speed's standard errors took two
/// eigenvalue problems per measured input).
#[divan::bench(sample_count = 3, args = [10_001, 100_001, 1_000_001])]
fn stability_report_by_speeds(bencher: divan::Bencher, n: usize) {
    let root = PathBuf::from(env!("CARGO_MANIFEST_DIR"));
    let p = bikeproc::read::bicycle::load(&root.join("data/lab_bike.toml")).expect("lab bike");
    let step = 10.0 / (n - 1) as f64;
    bencher.bench(|| {
        bikeproc::model::report::StabilityReport::over(&p, divan::black_box((0.0, 10.0, step)))
            .expect("report")
    });
}

/// A 10 s coast of the nonlinear Whipple bicycle at 5 m/s after a roll kick, sampled at 100 Hz.
#[divan::bench(sample_count = 20)]
fn nonlinear_ride_10_s(bencher: divan::Bencher) {
    use bikeproc::sim::whipple::{coast, upright_state, WhippleParams};
    let p = WhippleParams::from_benchmark(&bikeproc::model::Benchmark::meijaard_2007());
    let (q, qd) = upright_state(&p, 5.0, 0.0, 0.0, 0.5, 0.0).expect("upright");
    let y = bikeproc::sim::whipple::ride_state(&q, &qd);
    bencher
        .bench(|| coast(&p, divan::black_box(y), 10.0, 0.01, &Default::default()).expect("coasts"));
}

/// One of the campaign's rides, whole: a 12 s recording (2 s still, 3 s push, 6 s of coast on
/// compliant tyres with every effect, 1 s held after the catch), two sensors, the log pair.
#[divan::bench(sample_count = 10)]
fn simulated_lab_ride_12_s(bencher: divan::Bencher) {
    use bikeproc::sim::ride::{simulate_ride, Effects, RideSpec};
    let b = bikeproc::model::Benchmark::meijaard_2007();
    let spec = RideSpec::lab(5.0, Effects::realistic());
    bencher.bench(|| simulate_ride(&b, divan::black_box(&spec), 3).expect("rides"));
}

/// A ride with 10 s of coast on compliant tyres with every effect (a 16 s recording).
#[divan::bench(sample_count = 10)]
fn simulated_ride_10_s_coast(bencher: divan::Bencher) {
    use bikeproc::sim::ride::{simulate_ride, Effects, RideSpec};
    let b = bikeproc::model::Benchmark::meijaard_2007();
    let mut spec = RideSpec::lab(5.0, Effects::realistic());
    spec.coast_s = 10.0;
    bencher.bench(|| simulate_ride(&b, divan::black_box(&spec), 3).expect("rides"));
}

/// Issue 6: the whole `data/rides.toml` campaign (16 rides: read both files, find the window,
/// fit, resample 400 times, the model's weave with its standard error), on rayon's threads (two on this machine) as
/// `bikeproc dynamic data/rides.toml` runs it.
#[divan::bench(sample_count = 10)]
fn dynamic_campaign_16_rides(bencher: divan::Bencher) {
    use bikeproc::ride::dynamic::run_campaign;
    let (manifest, model) = data_campaign();
    let modal = bikeproc::ride::modal::ModalOptions::default();
    bencher.bench(|| run_campaign(&manifest, &model, &modal, &|_, _| {}));
}

/// Issue 7: diagnosing the 16-ride campaign of `data/rides.toml` (every candidate and pair
/// fitted and left one ride out at a time) from its rides' eigenvalues, on rayon's threads (two on this machine).
#[divan::bench(sample_count = 10)]
fn gap_diagnosis_16_rides(bencher: divan::Bencher) {
    use bikeproc::gap::{diagnose, GapOptions};
    let (model, rides) = data_campaign_observations();
    bencher.bench(|| diagnose(&rides, &[], &model, &GapOptions::default(), &|_, _| {}));
}

/// `data/rides.toml` and its bicycle's model.
fn data_campaign() -> (
    bikeproc::read::rides::RideManifest,
    bikeproc::model::uncertain::Parametrized,
) {
    let root = PathBuf::from(env!("CARGO_MANIFEST_DIR"));
    let manifest = bikeproc::read::rides::RideManifest::load(&root.join("data/rides.toml"))
        .expect("data/rides.toml");
    let model = bikeproc::read::bicycle::load(&manifest.bike_path()).expect("the bicycle");
    (manifest, model)
}

/// The model of `data/rides.toml`'s bicycle and its rides' observations (their dynamic tests).
fn data_campaign_observations() -> (
    bikeproc::model::uncertain::Parametrized,
    Vec<bikeproc::gap::Observation>,
) {
    use bikeproc::gap::Observation;
    use bikeproc::ride::dynamic::run_campaign;
    let (manifest, model) = data_campaign();
    let modal = bikeproc::ride::modal::ModalOptions::default();
    let rides = run_campaign(&manifest, &model, &modal, &|_, _| {})
        .iter()
        .enumerate()
        .filter_map(|(k, r)| r.test().map(|t| Observation::from_test(&k.to_string(), t)))
        .collect();
    (model, rides)
}

/// Issues 17 and 33: the diagnosis's cost against the number of rides: the 16 rides of
/// `data/rides.toml` taken 1/2, 1, 2, … 64 times (the copies 0.02 m/s apart, their coasting
/// windows moved with them), every candidate and pair fitted and left one ride out at a time.
#[divan::bench(sample_count = 3, args = [8, 16, 32, 64, 128, 256, 512, 1000])]
fn gap_diagnosis_by_rides(bencher: divan::Bencher, n: usize) {
    use bikeproc::gap::{diagnose, GapOptions};
    let (model, base) = data_campaign_observations();
    let rides = bikeproc::gap::observe::copies(&base, n, 0.02, true);
    bencher.bench(|| diagnose(&rides, &[], &model, &GapOptions::default(), &|_, _| {}));
}

/// Issue 7: `bikeproc gap data/rides.toml` as a whole: the 16 rides' dynamic tests, the noted
/// speeds' correction and the diagnosis, on rayon's threads (two on this machine).
#[divan::bench(sample_count = 10)]
fn gap_campaign_16_rides(bencher: divan::Bencher) {
    let (manifest, model) = data_campaign();
    bencher.bench(|| bikeproc::gap::diagnose_campaign(&manifest, &model, &|_, _, _| {}));
}

/// Issue 76, item 1: the real balance-assist study (`fixtures/real/balanceassist_study.toml`,
/// four conditions, 66 kicks) as `bikeproc gap` runs it, with the pairs and triples a study
/// screens, with every pair of the library (`--every-pair`) and with every three
/// (`--every-triple`): the differences are the pairs' and the triples' stages.
#[divan::bench(sample_count = 2, args = ["screen", "every pair", "every triple"])]
fn gap_balance_assist_study_by_pair_search(bencher: divan::Bencher, pairs: &str) {
    let root = PathBuf::from(env!("CARGO_MANIFEST_DIR"));
    let study =
        bikeproc::read::study::Study::load(&root.join("fixtures/real/balanceassist_study.toml"))
            .expect("the study");
    let model = bikeproc::read::bicycle::load(&study.bike_path().expect("its bicycle"))
        .expect("its bicycle");
    let options = bikeproc::gap::GapOptions {
        pairs: match pairs {
            "screen" => bikeproc::gap::PairSearch::Screen,
            "every pair" => bikeproc::gap::PairSearch::Every,
            _ => bikeproc::gap::PairSearch::EveryTriple,
        },
        ..Default::default()
    };
    bencher.bench(|| {
        bikeproc::gap::diagnose_manifests_with(&study.conditions, &model, &options, &|_, _, _| {})
    });
}

/// Issue 15: `bikeproc measured` on one bicycle (Rigid: the table-top geometry, handlebar and
/// fork measured apart), from its file's bytes to the benchmark parameters with standard errors.
#[divan::bench]
fn measured_rigid_parameters(bencher: divan::Bencher) {
    use bikeproc::inertia::measured::{MeasuredBicycle, MeasuredFile};
    let path = PathBuf::from(env!("CARGO_MANIFEST_DIR"))
        .join("../shared/reference/bicycleparameters/RigidMeasured.txt");
    let bytes = std::fs::read(&path).expect("RigidMeasured.txt");
    bencher.bench(|| {
        let file = MeasuredFile::parse(&bytes, &path).expect("parses");
        MeasuredBicycle::from_file(&file).expect("converts")
    });
}

/// Issue 15: the same and its stable range, weave and capsize speeds with standard errors
/// (0–10 m/s in steps of 0.01 m/s): what `bikeproc measured` prints.
#[divan::bench(sample_count = 20)]
fn measured_rigid_with_stability(bencher: divan::Bencher) {
    use bikeproc::inertia::measured::MeasuredBicycle;
    let path = PathBuf::from(env!("CARGO_MANIFEST_DIR"))
        .join("../shared/reference/bicycleparameters/RigidMeasured.txt");
    bencher.bench(|| {
        MeasuredBicycle::load(&path)
            .expect("converts")
            .report(10.0, 0.01)
            .expect("a stability")
    });
}

/// Issue 17: one whole padded spectrum of the 60 s signal (the period fit takes none since;
/// its three are [`bikeproc::spectral::ZoomSpectrum`]s).
#[divan::bench(sample_count = 50)]
fn spectrum_60_s_signal(bencher: divan::Bencher) {
    let sig = sixty_second_signal();
    bencher.bench(|| {
        bikeproc::spectral::Spectrum::of(
            divan::black_box(sig),
            bikeproc::spectral::Window::Rectangular,
        )
    });
}

/// Issue 17: the period fit's spectrum of the 60 s signal: the record's own transform and its
/// main peak on the padded grid (the same peak as the whole padded spectrum's).
#[divan::bench(sample_count = 50)]
fn zoom_spectrum_main_peak_60_s_signal(bencher: divan::Bencher) {
    let sig = sixty_second_signal();
    bencher.bench(|| {
        bikeproc::spectral::ZoomSpectrum::of(
            divan::black_box(sig),
            bikeproc::spectral::Window::Rectangular,
        )
        .main_peak(0.05)
    });
}

/// A treadmill recording of `rows` rows at 100 Hz as a microcontroller writes it (time, roll
/// rate, steer rate, wheel speed; a kick every 20 s whose weave decays at σ = 1.2 /s, ω = 5
/// rad/s over 0.02 rad/s of sway), written once per size to a temporary file.
fn treadmill_csv(rows: usize) -> PathBuf {
    let path = std::env::temp_dir().join(format!("bikeproc_bench_treadmill_{rows}.csv"));
    if !path.exists() {
        use std::io::Write;
        let mut rng = seeded(5);
        let mut out = std::io::BufWriter::new(std::fs::File::create(&path).expect("create"));
        writeln!(
            out,
            "time_s,roll_rate_rad_per_s,steer_rate_deg_per_s,rear_wheel_speed_m_per_s"
        )
        .expect("write");
        for i in 0..rows {
            let t = i as f64 / 100.0;
            let tau = t % 20.0 - 5.0;
            let kick = if (0.0..5.0).contains(&tau) {
                0.8 * (-1.2 * tau).exp() * (5.0 * tau + 1.3).sin() * (tau / 0.08).min(1.0)
            } else {
                0.0
            };
            let r = kick + 0.02 * rng.normal();
            writeln!(
                out,
                "{t:.2},{r:.4},{:.2},{:.3}",
                10.0 * r,
                5.0 + 0.02 * rng.normal()
            )
            .expect("write");
        }
    }
    path
}

/// Issue 32: a long recording read and searched for kicks in one pass (9 bytes a row), by rows.
#[divan::bench(args = [100_000, 1_000_000], sample_count = 5)]
fn find_kicks_by_rows(bencher: divan::Bencher, rows: usize) {
    use bikeproc::ride::csv::{find_kicks_file, Columns};
    let path = treadmill_csv(rows);
    bencher.bench(|| find_kicks_file(&path, &Columns::default(), None).expect("reads"));
}

/// A window of a ride: time (s), roll and steer (rad).
type Window = (Vec<f64>, Vec<f64>, Vec<f64>);

/// The real uncontrolled recording's three hand-marked decays (141.28–142.71 s, 148.53–149.94 s,
/// 153.98–155.50 s), read once.
fn marked_decays() -> &'static Vec<Window> {
    static DECAYS: OnceLock<Vec<Window>> = OnceLock::new();
    DECAYS.get_or_init(|| {
        let path = PathBuf::from(env!("CARGO_MANIFEST_DIR"))
            .join("../shared/reference/rides/balanceassist_uncontrolled_18kmh.csv");
        let text = std::fs::read_to_string(&path).expect("the reference recording");
        let rows: Vec<Vec<f64>> = text
            .lines()
            .skip(1)
            .map(|l| l.split(',').map(|f| f.parse().expect("a number")).collect())
            .collect();
        // Columns: time_s, roll_rad, …, steer_deg (9th).
        [(141.28, 142.71), (148.53, 149.94), (153.98, 155.50)]
            .iter()
            .map(|&(a, b)| {
                let w: Vec<&Vec<f64>> = rows.iter().filter(|r| (a..=b).contains(&r[0])).collect();
                (
                    w.iter().map(|r| r[0]).collect(),
                    w.iter().map(|r| r[1]).collect(),
                    w.iter().map(|r| r[8].to_radians()).collect(),
                )
            })
            .collect()
    })
}

/// Issue 32: the roll-and-steer modal fit of one kick (its structure search, the drift's check
/// and 400 resamples), on each of the real recording's marked decays: the cost that sets how
/// fast a long recording with angles is analysed (3,348 such fits in the 10-million-row one).
#[divan::bench(args = [0, 1, 2], sample_count = 20)]
fn modal_fit_marked_decay(bencher: divan::Bencher, k: usize) {
    bench_marked_decay(bencher, k, "capped");
}

/// The same fits with the stated model of issue 75 (`Estimator::Projected`, τ² and τ³).
#[divan::bench(args = [0, 1, 2], sample_count = 20)]
fn modal_fit_marked_decay_projected(bencher: divan::Bencher, k: usize) {
    bench_marked_decay(bencher, k, "projected");
}

/// The modal fit of marked decay `k` with the estimator `name` ([`estimator`]).
fn bench_marked_decay(bencher: divan::Bencher, k: usize, name: &str) {
    use bikeproc::ride::modal::{fit_modes, ModalOptions};
    let (t, roll, steer) = &marked_decays()[k];
    let options = ModalOptions {
        estimator: estimator(name),
        ..ModalOptions::default()
    };
    bencher.bench(|| fit_modes(divan::black_box(t), roll, steer, &options).expect("fits"));
}

/// Issue 34: `bikeproc sensitivity` on a real bicycle: the characteristic speeds (0–10 m/s
/// in steps of 0.01 m/s, refined), every parameter's derivatives and the variance budget
/// (acceptance: under 10 ms).
#[divan::bench]
fn sensitivity_rigid(bencher: divan::Bencher) {
    let path = PathBuf::from(env!("CARGO_MANIFEST_DIR"))
        .join("../shared/reference/bicycleparameters/RigidBenchmark.txt");
    let model = bikeproc::read::bicycle::load(&path).expect("RigidBenchmark.txt");
    bencher.bench(|| bikeproc::model::sensitivity::sensitivity(&model, &[5.0], 10.0).unwrap());
}

/// The estimators a bench compares: today's default and the stated model of issue 75.
fn estimator(name: &str) -> bikeproc::ride::modal::Estimator {
    use bikeproc::ride::modal::Estimator;
    match name {
        "capped" => Estimator::Capped,
        "projected" => Estimator::PROJECTED,
        other => panic!("no estimator named {other}"),
    }
}

/// Issue 75: the ride stage's CPU per ride: the 16 rides of `data/rides.toml` (read both
/// files, find the window, fit, resample, the model's weave) on one thread, so that the time
/// over 16 is one ride's CPU (the bound: 5 ms), with each estimator.
#[divan::bench(sample_count = 10, args = ["capped", "projected"])]
fn ride_stage_16_rides_one_thread(bencher: divan::Bencher, name: &str) {
    use bikeproc::ride::dynamic::run_campaign;
    let (manifest, model) = data_campaign();
    let modal = bikeproc::ride::modal::ModalOptions {
        estimator: estimator(name),
        ..Default::default()
    };
    let pool = rayon::ThreadPoolBuilder::new()
        .num_threads(1)
        .build()
        .expect("one thread");
    bencher.bench(|| pool.install(|| run_campaign(&manifest, &model, &modal, &|_, _| {})));
}

/// A campaign of `rides` rides in a temporary folder: `data/`'s 16 ride logs (and their
/// calibration logs) copied as many times as it takes, each copy with its ride's noted speed,
/// and the bicycle; its manifest's path.
fn copied_campaign(rides: usize) -> PathBuf {
    let root = PathBuf::from(env!("CARGO_MANIFEST_DIR")).join("data");
    let dir = std::env::temp_dir().join(format!("bikeproc_bench_copied_{rides}"));
    let manifest = dir.join("rides.toml");
    if manifest.exists() {
        return manifest;
    }
    std::fs::create_dir_all(&dir).expect("scratch folder");
    std::fs::copy(root.join("lab_bike.toml"), dir.join("lab_bike.toml")).expect("copy");
    let data = std::fs::read_to_string(root.join("rides.toml")).expect("data/rides.toml");
    let table: toml::Table = data.parse().expect("data/rides.toml is TOML");
    let entries = table["ride"].as_array().expect("[[ride]]");
    let mut text = String::from("version = 1\nbike = \"lab_bike.toml\"\n");
    for k in 0..rides {
        let entry = &entries[k % entries.len()];
        let log = entry["log"].as_str().expect("log");
        let stem = log.trim_end_matches(".log");
        let copy = format!("{stem}_c{k:04}");
        for (from, to) in [
            (format!("{stem}.log"), format!("{copy}.log")),
            (format!("{stem}_cal.log"), format!("{copy}_cal.log")),
        ] {
            if root.join(&from).exists() {
                std::fs::copy(root.join(&from), dir.join(to)).expect("copy");
            }
        }
        text += &format!("\n[[ride]]\nlog = \"{copy}.log\"\n");
        if let Some(v) = entry.get("noted_speed_mps") {
            text += &format!("noted_speed_mps = {v}\n");
        }
    }
    std::fs::write(&manifest, text).expect("write the manifest");
    manifest
}

/// Issue 75: `bikeproc gap` on 1,000 rides (data/'s logs copied, the noted speeds kept as they
/// are): every ride's dynamic test and the diagnosis, on rayon's threads (two on this
/// machine). The bound: 10 s wall.
#[divan::bench(sample_count = 1)]
fn gap_campaign_1000_copied_rides(bencher: divan::Bencher) {
    use bikeproc::read::rides::RideManifest;
    let manifest = RideManifest::load(&copied_campaign(1000)).expect("the copied campaign");
    let model = bikeproc::read::bicycle::load(&manifest.bike_path()).expect("the bicycle");
    bencher.bench(|| bikeproc::gap::diagnose_campaign(&manifest, &model, &|_, _, _| {}));
}

/// Issue 75: a long treadmill recording as `bikeproc dynamic FILE.csv` analyses it: read,
/// kicks found, every kick's decay fitted. The bound: 10 s for 10 million rows.
#[divan::bench(args = [1_000_000, 10_000_000], sample_count = 1)]
fn csv_ride_decays_by_rows(bencher: divan::Bencher, rows: usize) {
    use bikeproc::ride::csv::{ride_decays_file, Columns};
    let path = treadmill_csv(rows);
    let modal = bikeproc::ride::modal::ModalOptions::default();
    bencher.bench(|| {
        ride_decays_file(&path, &Columns::default(), None, None, None, None, &modal).expect("reads")
    });
}
