//! The lab's pendulum campaign, simulated: a world whose physics gives the published
//! frequencies (Tables 1, 4; eqs. 66, 79–91), recorded as the lab recorded it (weights,
//! distances and axes of Tables 2, 5 and eqs. 73, 75), written as log pairs and manifests.
//!
//! The world: a bar of stiffness `k` that makes the rod (its inertia from its dimensions, eq.
//! 65) swing at 0.6782 Hz together with a light fixture (Cardan joint and clamp, 1.5e-4 kg·m²);
//! each torsion test's system inertia is what makes it swing at the published frequency; each
//! compound test's inertia about the pivot likewise, swinging with the full `sin θ`. Repeats
//! differ by a re-clamping spread of 0.05–0.2 % in frequency (the lab's FFT peaks agreed to
//! about that), release angles and noise. Nothing here calls an estimator.

use super::draw::{seeded, Draw, Rng};
use super::imu::{FileSpec, LinkModel, Locale, Precision, SensorModel};
use super::pendulum::{Compound, Pendulum, Placement, Release, Swing, Torsion};
use crate::read::log::OutputMode;
use std::f64::consts::PI;
use std::fmt::Write as _;
use std::path::PathBuf;

/// Files of a simulated campaign: path relative to its folder → contents.
pub type Files = Vec<(PathBuf, String)>;

/// Gravity of the simulated world (m/s²), as in eq. 92.
pub const GRAVITY_MPS2: f64 = 9.81;

/// The rod of eq. 65.
pub const ROD: (f64, f64, f64) = (22.31, 59.95e-3, 1.007);
/// The fixture's true inertia about the bar's axis (kg·m²).
pub const FIXTURE_INERTIA_KGM2: f64 = 1.5e-4;
/// The empty-fixture test's calibration weights: 1.000 kg at 0.100 m on a machined arm (±0.5 mm).
pub const FIXTURE_WEIGHTS: (f64, f64, f64) = (1.0, 0.100, 0.0005);

/// The bar's true stiffness: the rod and fixture at the published 0.6782 Hz (eq. 66).
pub fn true_stiffness() -> f64 {
    let (m, d, l) = ROD;
    let i_rod = m * (3.0 * (d / 2.0).powi(2) + l * l) / 12.0;
    4.0 * PI * PI * 0.6782f64.powi(2) * (i_rod + FIXTURE_INERTIA_KGM2)
}

/// One recording to simulate.
struct Shot {
    file: String,
    pendulum: Pendulum,
    release: Release,
    mode: OutputMode,
    locale: Locale,
    label: &'static str,
    sensor_id: &'static str,
}

fn spec(shot: &Shot, seed: u64) -> FileSpec {
    FileSpec {
        mode: shot.mode,
        locale: shot.locale,
        precision: Precision::Sensor,
        rate_hz: 100.0,
        sensors: vec![(shot.sensor_id.to_string(), shot.label.to_string())],
        first_counter: (seed.wrapping_mul(40_503) % 65_536) as u16,
        start: format!(
            "2009-03-{:02} {:02}:{:02}:{:02}",
            10 + seed % 8,
            9 + seed % 8,
            (seed * 7) % 60,
            (seed * 13) % 60
        ),
        extra_header: vec![],
        declare_decimal: seed % 2 == 0,
        jitter_s: 0.0005,
        late_bursts_per_minute: 0.0,
    }
}

fn record(shot: &Shot, seed: u64) -> (String, String) {
    let mut rng = seeded(seed);
    let sensor = SensorModel::typical(&mut rng);
    let placement = Placement {
        body_rest: rng.rotation(),
        axis_heading_rad: rng.range(0.0, 2.0 * PI),
        sensor_offset_m: nalgebra::Vector3::new(
            rng.range(0.1, 0.35),
            rng.range(-0.05, 0.05),
            rng.range(-0.1, 0.1),
        ),
    };
    let rec = super::simulate_pendulum(
        &shot.pendulum,
        &shot.release,
        &placement,
        &sensor,
        &LinkModel::default(),
        &spec(shot, seed),
        seed,
    );
    (rec.angles_log, rec.cal_log)
}

fn release(rng: &mut Rng, duration_s: f64, amplitude_deg: (f64, f64)) -> Release {
    Release {
        rest_s: rng.range(2.0, 4.0),
        ramp_s: rng.range(0.6, 1.2),
        hold_s: rng.range(0.4, 1.0),
        amplitude_deg: rng.range(amplitude_deg.0, amplitude_deg.1),
        duration_s,
    }
}

/// A torsion test of the lab's (system) inertia making it swing at `freq_hz`, with the Cardan
/// joint's swing lightly coupled.
fn torsion_at(freq_hz: f64, rng: &mut Rng) -> Pendulum {
    let k = true_stiffness();
    Pendulum::Torsion(Torsion {
        inertia_kgm2: k / (2.0 * PI * freq_hz).powi(2),
        stiffness_nm_per_rad: k,
        damping_ratio: rng.range(0.002, 0.006),
        coulomb_nm: 0.0,
        swing: Some(Swing {
            freq_hz: rng.range(1.1, 1.6) * freq_hz.max(0.8),
            damping_ratio: 0.03,
            coupling: 0.01,
            release_amplitude_deg: 0.5,
        }),
    })
}

fn compound_at(mass_kg: f64, pivot_to_cg_m: f64, freq_hz: f64, rng: &mut Rng) -> Pendulum {
    Pendulum::Compound(Compound {
        mass_kg,
        pivot_to_cg_m,
        inertia_about_pivot_kgm2: mass_kg * GRAVITY_MPS2 * pivot_to_cg_m
            / (2.0 * PI * freq_hz).powi(2),
        damping_ratio: rng.range(0.002, 0.005),
        coulomb_nm: 0.0,
    })
}

/// A folder's tests: (name, published frequency, repeats, manifest lines of the test).
struct FolderTest {
    name: &'static str,
    freq_hz: f64,
    repeats: usize,
    lines: String,
}

/// Writes one folder: its logs and manifest. `make` builds the pendulum for a frequency.
#[allow(clippy::too_many_arguments)]
fn folder(
    files: &mut Files,
    dir: &str,
    header: &str,
    tests: &[FolderTest],
    make: &dyn Fn(f64, &mut Rng) -> Pendulum,
    duration_s: f64,
    amplitude_deg: (f64, f64),
    label: &'static str,
    seed: &mut u64,
    style: &dyn Fn(usize) -> (OutputMode, Locale),
) {
    let mut manifest = String::from(header);
    let mut count = 0;
    for t in tests {
        let mut rng = seeded(*seed ^ 0xC0FFEE);
        // Repeats spread symmetrically about the published frequency: re-clamping.
        let spread = rng.range(0.0005, 0.002);
        let mut logs = Vec::new();
        for r in 0..t.repeats {
            let offset = if t.repeats == 1 {
                0.0
            } else {
                spread * (2.0 * r as f64 / (t.repeats - 1) as f64 - 1.0)
            };
            let f = t.freq_hz * (1.0 + offset);
            let (mode, locale) = style(count);
            count += 1;
            let shot = Shot {
                file: format!("{dir}_{}{}.log", t.name, (b'a' + r as u8) as char),
                pendulum: make(f, &mut rng),
                release: release(&mut rng, duration_s, amplitude_deg),
                mode,
                locale,
                label,
                sensor_id: "00300417",
            };
            *seed += 1;
            let (angles, cal) = record(&shot, *seed);
            files.push((PathBuf::from(dir).join(&shot.file), angles));
            files.push((
                PathBuf::from(dir).join(shot.file.replace(".log", "_cal.log")),
                cal,
            ));
            logs.push(format!("\"{}\"", shot.file));
        }
        let _ = write!(
            manifest,
            "\n[[test]]\nname = \"{}\"\nlogs = [{}]\n{}",
            t.name,
            logs.join(", "),
            t.lines
        );
    }
    files.push((PathBuf::from(dir).join("manifest.toml"), manifest));
}

/// A torsion test as the lab recorded it: name, frequency (Hz), weights (kg), their distance
/// from the axis (m), the CG's distance from the axis (m), the axis in body coordinates.
type TorsionRow = (&'static str, f64, f64, f64, f64, [f64; 3]);

const PUBLISHED: &str =
    "# The lab's figures are in seed §5.3; this folder was simulated to reproduce them.\n";

/// The whole campaign (seed §5.3), deterministic.
pub fn lab_campaign() -> Files {
    let mut files = Files::new();
    let mut seed = 2009u64;
    let tab = |_: usize| (OutputMode::Euler, Locale::Tab);
    // Bar calibration and empty fixture.
    folder(
        &mut files,
        "bar_calibration",
        &format!(
            "# Torsion-bar calibration with the steel rod hung by its middle (seed §5.3.3.2).\n{PUBLISHED}version = 1\nkind = \"bar_calibration\"\nfixture = \"../empty_fixture\"\n\n[rod]\nmass_kg = {}\ndiameter_m = {}\nlength_m = {}\n\n[bar]\nshear_modulus_pa = 72e9\ndiameter_m = 0.010\nlength_m = 1.99\n",
            ROD.0, ROD.1, ROD.2
        ),
        &[FolderTest { name: "rod", freq_hz: 0.6782, repeats: 3, lines: String::new() }],
        &|f, rng| torsion_at(f, rng),
        60.0,
        (6.0, 10.0),
        "torsion bar",
        &mut seed,
        &|i| if i == 2 { (OutputMode::Quaternion, Locale::Tab) } else { (OutputMode::Euler, Locale::Tab) },
    );
    let k = true_stiffness();
    let (wm, wr, wse) = FIXTURE_WEIGHTS;
    let fix_f = (k / (FIXTURE_INERTIA_KGM2 + wm * wr * wr)).sqrt() / (2.0 * PI);
    folder(
        &mut files,
        "empty_fixture",
        "# The bare Cardan joint and clamp on the bar, with calibration weights on a machined arm.\n# (Not in the seed: the lab neglected the fixture's inertia.)\nversion = 1\nkind = \"empty_fixture\"\n# The calibration weights are weighed on a fine scale.\nmass_se_kg = 0.001\n",
        &[FolderTest { name: "empty", freq_hz: fix_f, repeats: 2, lines: format!("weights_kg = {wm}\nweights_distance_m = {wr}\nweights_distance_se_m = {wse}\n") }],
        &|f, rng| torsion_at(f, rng),
        30.0,
        (4.0, 6.0),
        "fixture",
        &mut seed,
        &tab,
    );
    // Frame torsion: Tables 1–2, eq. 73.
    let frame = [
        ("1", 0.8003, 3.231, 0.37, 0.2, [0.7964, 0.0, -0.6048]),
        ("2", 0.7485, 3.231, 0.385, 0.18, [-0.4097, 0.0, 0.9122]),
        ("3", 0.8695, 3.720, 0.205, 0.09, [-0.3768, 0.0, 0.9263]),
        ("4", 1.2160, 3.720, 0.17, 0.16, [0.9097, 0.0, 0.4153]),
    ];
    let torsion_tests = |rows: &[TorsionRow]| -> Vec<FolderTest> {
        rows.iter()
            .map(|&(name, f, wm, wr, cg, ax)| FolderTest {
                name,
                freq_hz: f,
                repeats: 2,
                lines: format!("axis = [{}, {}, {}]\nweights_kg = {wm}\nweights_distance_m = {wr}\ncg_distance_m = {cg}\n", ax[0], ax[1], ax[2]),
            })
            .collect()
    };
    let torsion_header = |body: &str, mass: f64, what: &str| {
        format!("# {what}\n{PUBLISHED}version = 1\nkind = \"torsion\"\nbody = \"{body}\"\nmass_kg = {mass}\ncalibration = \"../bar_calibration/calibration.toml\"\nmass_se_kg = 0.02\ndistance_se_m = 0.005\naxis_angle_se_deg = 1.0\n")
    };
    folder(
        &mut files,
        "frame_torsion",
        &torsion_header("frame", 5.48, "Torsion tests of the frame in four orientations (seed §5.3.3.4, Tables 1–3, eq. 73); tests 2 and 3 share an orientation."),
        &torsion_tests(&frame),
        &|f, rng| torsion_at(f, rng),
        40.0,
        (5.0, 9.0),
        "frame",
        &mut seed,
        &|i| match i {
            3 => (OutputMode::Matrix, Locale::Tab),
            5 => (OutputMode::Quaternion, Locale::Spanish),
            _ => (OutputMode::Euler, Locale::Tab),
        },
    );
    let handlebar = [
        ("1", 4.659, 0.0, 0.0, 0.015, [-0.0106, 0.0, 0.9999]),
        ("2", 1.392, 2.246, 0.17, 0.16, [-0.9993, 0.0, 0.0376]),
    ];
    folder(
        &mut files,
        "handlebar_torsion",
        &torsion_header("handlebar", 2.96, "Torsion tests of the handlebar in two orientations (seed §5.3.3.5, Tables 4–6, eq. 75); I_xz = −I_zz (eq. 74)."),
        &torsion_tests(&handlebar),
        &|f, rng| torsion_at(f, rng),
        40.0,
        (5.0, 9.0),
        "handlebar",
        &mut seed,
        &|i| if i == 1 { (OutputMode::Euler, Locale::Spanish) } else { (OutputMode::Euler, Locale::Tab) },
    );
    // Compound pendulums: eqs. 79–91.
    let compound_header = |body: &str, mass: f64, what: &str| {
        format!("# {what}\n{PUBLISHED}version = 1\nkind = \"compound\"\nbody = \"{body}\"\nmass_kg = {mass}\nmass_se_kg = 0.02\ndistance_se_m = 0.005\n")
    };
    let ct = |name: &'static str, f: f64, l: f64, moment: &str, repeats: usize| FolderTest {
        name,
        freq_hz: f,
        repeats,
        lines: format!("pivot_to_cg_m = {l}\nmoment = \"{moment}\"\n"),
    };
    for (dir, body, mass, l, what, tests) in [
        ("frame_compound", "frame", 5.48, 0.37, "The frame as a compound pendulum (seed §5.3.4.2, eqs. 79–80).", vec![ct("yy", 0.556, 0.37, "iyy", 3)]),
        ("handlebar_compound", "handlebar", 2.96, 0.14, "The handlebar as a compound pendulum (seed §5.3.4.3, eqs. 81–82).", vec![ct("yy", 0.6905, 0.14, "iyy", 2)]),
        (
            "rear_wheel_compound",
            "rear_wheel",
            2.52,
            0.354,
            "The rear wheel hung from its rim, in and across its plane (seed §5.3.4.4, eqs. 83–87).",
            vec![ct("in_plane", 0.7007, 0.354, "iyy", 2), ct("across", 0.7405, 0.354, "ixx_izz", 2)],
        ),
        (
            "front_wheel_compound",
            "front_wheel",
            1.96,
            0.354,
            "The front wheel hung from its rim, in and across its plane (seed §5.3.4.5, eqs. 88–91).",
            vec![ct("in_plane", 0.6876, 0.354, "iyy", 2), ct("across", 0.7605, 0.354, "ixx_izz", 2)],
        ),
    ] {
        let label = match body {
            "frame" => "frame",
            "handlebar" => "handlebar",
            _ => "wheel",
        };
        folder(
            &mut files,
            dir,
            &compound_header(body, mass, what),
            &tests,
            &move |f, rng| compound_at(mass, l, f, rng),
            30.0,
            (2.5, 4.0),
            label,
            &mut seed,
            &|i| if i == 1 { (OutputMode::Quaternion, Locale::Tab) } else { (OutputMode::Euler, Locale::Tab) },
        );
    }
    files.push((
        "lab_bike_seed.toml".into(),
        crate::inertia::bike::LabBike::seed().to_toml(),
    ));
    files.push((
        "lab_bike.toml".into(),
        crate::inertia::bike::LabBike::lab_template().to_toml(),
    ));
    files.push(("README.md".into(), DATA_README.into()));
    files.sort_by(|a, b| a.0.cmp(&b.0));
    files
}

const DATA_README: &str = "# data/: the lab's campaign, simulated

The lab's raw files are not available, so this campaign was simulated from physics
(`bikeproc simulate campaign --out data`, deterministic) to reproduce the published figures of
the seed's §5.3: the bar calibration (eqs. 64–67), the frame's and handlebar's torsion tests
(Tables 1–6), the compound-pendulum tests (eqs. 79–91), plus an empty-fixture test the lab did
not make. Every folder holds its logs (`NAME.log` and `NAME_cal.log`, the acquisition side's
format) and a `manifest.toml` saying what the lab did and wrote down.

Derived files, regenerated by the commands and checked against them by the tests:

- `bar_calibration/calibration.toml`: `bikeproc calibrate-bar`
- `lab_bike.toml`: the bicycle with its measured inertias, `bikeproc inertia --bike data/lab_bike.toml`
- `lab_bike_seed.toml`: the bicycle exactly as published (eq. 92, Parametros.m)

Rides (seed §5.4): `ride_NN.log` with `_cal.log`, listed in `rides.toml` with the speed the lab
would have written down; simulated by `bikeproc simulate rides --out data` on the measured
bicycle in `lab_bike.toml` (with a truth that differs from it, see `src/sim/campaign.rs`). Their
truths are in `truth/`: never an input of the analysis.

To rebuild all of it: `bikeproc simulate campaign --out data && bikeproc calibrate-bar &&
bikeproc inertia --bike data/lab_bike.toml && bikeproc simulate rides --out data`.
";

/// A random body's torsion campaign with a known true tensor, recorded with errors at the
/// manifest's stated uncertainties (mass ±20 g, distances ±5 mm, axis angles ±1°).
pub struct RandomCampaign {
    pub files: Files,
    /// True (I_xx, I_xz, I_zz) about the centre of gravity (kg·m²).
    pub truth: [f64; 3],
    /// The calibration file's text (stiffness recorded with a 0.1 % standard error).
    pub calibration: String,
}

/// Builds a random torsion campaign (3 or 4 well-spread orientations, 2 repeats of 30 s each).
pub fn random_torsion_campaign(seed: u64) -> RandomCampaign {
    let mut rng = seeded(seed);
    let mass = rng.range(2.0, 8.0);
    let (p1, p2) = (rng.range(0.05, 1.0), rng.range(0.05, 1.0));
    let phi = rng.range(0.0, PI);
    let (c, s) = (phi.cos(), phi.sin());
    let truth = [
        p1 * c * c + p2 * s * s,
        (p1 - p2) * c * s,
        p1 * s * s + p2 * c * c,
    ];
    let k = true_stiffness();
    let n = if rng.uniform() < 0.5 { 3 } else { 4 };
    let start = rng.range(0.0, PI);
    let mut manifest = format!("version = 1\nkind = \"torsion\"\nbody = \"random body\"\nmass_kg = {:.3}\ncalibration = \"calibration.toml\"\n", mass + 0.02 * rng.normal());
    let mut files = Files::new();
    for i in 0..n {
        let ang = start + PI * (i as f64 + rng.range(-0.15, 0.15)) / n as f64;
        let axis = [ang.cos(), 0.0, ang.sin()];
        let i_cg = truth[0] * axis[0] * axis[0]
            + 2.0 * truth[1] * axis[0] * axis[2]
            + truth[2] * axis[2] * axis[2];
        let (wm, wr, cg) = (
            rng.range(0.0, 4.0),
            rng.range(0.1, 0.4),
            rng.range(0.02, 0.3),
        );
        let i_sys = i_cg + mass * cg * cg + wm * wr * wr + FIXTURE_INERTIA_KGM2;
        let mut logs = Vec::new();
        for r in 0..2 {
            let name = format!("o{i}{}.log", (b'a' + r as u8) as char);
            let shot = Shot {
                file: name.clone(),
                pendulum: Pendulum::Torsion(Torsion {
                    inertia_kgm2: i_sys,
                    stiffness_nm_per_rad: k,
                    damping_ratio: rng.range(0.002, 0.01),
                    coulomb_nm: 0.0,
                    swing: None,
                }),
                release: release(&mut rng, 30.0, (4.0, 10.0)),
                mode: OutputMode::Quaternion,
                locale: Locale::Tab,
                label: "body",
                sensor_id: "00300417",
            };
            let (angles, _cal) = record(&shot, seed.wrapping_mul(1000) + (2 * i + r) as u64);
            files.push((PathBuf::from(&name), angles));
            logs.push(format!("\"{name}\""));
        }
        let da = rng.normal() * 1f64.to_radians();
        let rec_axis = [(ang + da).cos(), 0.0, (ang + da).sin()];
        let _ = write!(
            manifest,
            "\n[[test]]\nname = \"{i}\"\nlogs = [{}]\naxis = [{:.6}, 0.0, {:.6}]\nweights_kg = {:.3}\nweights_distance_m = {:.4}\ncg_distance_m = {:.4}\n",
            logs.join(", "),
            rec_axis[0],
            rec_axis[2],
            (wm + 0.02 * rng.normal()).max(0.0),
            wr + 0.005 * rng.normal(),
            (cg + 0.005 * rng.normal()).abs()
        );
    }
    files.push(("manifest.toml".into(), manifest));
    let k_se = 0.001 * k;
    let fix_se = 2e-5;
    let calibration = format!(
        "version = 1\nstiffness_nm_per_rad = {}\nstiffness_se_nm_per_rad = {k_se}\nfixture_inertia_kgm2 = {}\nfixture_inertia_se_kgm2 = {fix_se}\nstiffness_fixture_correlation = 0.0\nfreq_hz = 0.6782\nfreq_se_hz = 1e-5\nrod_inertia_kgm2 = 1.8903\nrod_inertia_se_kgm2 = 1e-4\n",
        k + k_se * rng.normal(),
        FIXTURE_INERTIA_KGM2 + fix_se * rng.normal()
    );
    RandomCampaign {
        files,
        truth,
        calibration,
    }
}

/// Writes files under `root`, each through a temporary file and a rename.
pub fn write_files(
    root: &std::path::Path,
    files: &Files,
) -> Result<(), crate::output::OutputError> {
    for (rel, text) in files {
        crate::output::write_atomic(&root.join(rel), text.as_bytes())?;
    }
    Ok(())
}

/// The campaign's truth bicycle: the measured one with the frame's I_xx 6 % higher (the seed's
/// spread between orientations).
pub fn truth_bike(measured: &crate::inertia::bike::LabBike) -> crate::inertia::bike::LabBike {
    let mut truth = measured.clone();
    truth.frame.ixx_kgm2 *= 1.06;
    truth
}

/// The lab's ride campaign (seed §5.4), simulated on the measured bicycle with a truth that
/// differs from it: 16 rides released at 3.4 to 6.5 m/s, each with the realistic effects
/// ([`super::ride::Effects::realistic`]) varied by ±15 % from ride to ride, the truth frame's
/// I_xx 6 % above the measured one (the seed's spread between orientations), one speedometer
/// reading 3 % high for all rides, the reed switch wired on every other ride. Files: `ride_NN.log`
/// and `_cal.log`, `rides.toml` with the speeds the lab would have written down (0.1 m/s), and
/// the sealed truths in `truth/`.
pub fn lab_rides(
    measured: &crate::inertia::bike::LabBike,
) -> Result<Files, super::ride::SimulationError> {
    use super::ride::{simulate_ride, Effects, RideSpec};
    let bike = crate::model::lab::lab_to_benchmark(&truth_bike(measured));
    let mut files = Files::new();
    let mut manifest = String::from(
        "# The lab's dynamic tests (seed §5.4), simulated: push, release, a kick at the saddle, catch.\n\
         # noted_speed_mps is what the lab wrote down from the speedometer at the release.\n\
         # The truth of every ride is in truth/ and is never an input of the analysis.\n\
         version = 1\nbike = \"lab_bike.toml\"\n",
    );
    let mut rng = seeded(1954);
    let speeds = [
        3.4, 3.6, 3.8, 4.0, 4.2, 4.4, 4.6, 4.8, 5.0, 5.2, 5.4, 5.6, 5.8, 6.0, 6.2, 6.5,
    ];
    for (k, &v) in speeds.iter().enumerate() {
        let mut e = Effects::realistic();
        let mut vary = |x: &mut f64| *x *= 1.0 + 0.15 * (2.0 * rng.uniform() - 1.0);
        vary(&mut e.steer_viscous_nms_per_rad);
        vary(&mut e.steer_coulomb_nm);
        vary(&mut e.rolling_resistance_coeff);
        vary(&mut e.drag_area_m2);
        let mut spec = RideSpec::lab(v, e);
        spec.sync = k % 2 == 1;
        spec.mode = match k {
            5 => OutputMode::Quaternion,
            11 => OutputMode::Matrix,
            _ => OutputMode::Euler,
        };
        spec.locale = if k == 8 { Locale::Spanish } else { Locale::Tab };
        spec.kick.peak_force_n = rng.range(12.0, 18.0);
        let ride = simulate_ride(&bike, &spec, 3000 + k as u64)?;
        let name = format!("ride_{:02}", k + 1);
        files.push((format!("{name}.log").into(), ride.angles_log));
        files.push((format!("{name}_cal.log").into(), ride.cal_log));
        files.push((
            format!("truth/{name}.json").into(),
            serde_json::to_string(&ride.truth).unwrap_or_default(),
        ));
        let _ = write!(
            manifest,
            "\n[[ride]]\nlog = \"{name}.log\"\nnoted_speed_mps = {:.1}\n",
            ride.truth.noted_speed_mps
        );
    }
    files.push(("rides.toml".into(), manifest));
    files.push((
        "truth/README.md".into(),
        "# Sealed truths of the simulated rides\n\nWritten by `bikeproc simulate rides` beside the ride logs: the true speed, roll and steer\nhistories, the effects and their values, and the truth's weave and capsize eigenvalues every\n0.05 m/s over the free motion's speeds (`modes`: the simulator's own equations with the ride's\nsmooth effects, linearized upright; Coulomb friction has no linearization and is left out).\nNo analysis command reads these files; tests compare with them.\n"
            .into(),
    ));
    files.sort_by(|a, b| a.0.cmp(&b.0));
    Ok(files)
}

/// Rides that went wrong, for the analysis's diagnoses (`fixtures/rides/`): the lab's bicycle
/// at 4.5 m/s with the realistic effects, 4 s of coast, and one fault each: no kick
/// (`no_kick`), the recording stopped 0.9 s after the kick (`too_short`), the sensors' labels
/// exchanged (`sensors_swapped`), the handlebar sensor lying still off the bicycle
/// (`handlebar_still`).
pub fn ride_fault_fixtures(
    measured: &crate::inertia::bike::LabBike,
) -> Result<Files, super::ride::SimulationError> {
    use super::ride::{simulate_ride, Effects, Fault, RideSpec};
    let bike = crate::model::lab::lab_to_benchmark(measured);
    let mut files = Files::new();
    let cases: [(&str, Option<Fault>, f64); 4] = [
        ("no_kick", None, 0.0),
        ("too_short", Some(Fault::EndsAt(5.8 + 0.9)), 15.0),
        ("sensors_swapped", Some(Fault::SensorsSwapped), 15.0),
        ("handlebar_still", Some(Fault::HandlebarSensorStill), 15.0),
    ];
    let mut readme = String::from(
        "# Rides that went wrong\n\nWritten by `bikeproc simulate ride-faults --out fixtures/rides` \
         (deterministic): the lab's bicycle\n(`data/lab_bike.toml`) at 4.5 m/s, realistic effects, one \
         fault each. `bikeproc dynamic`\nmust name what is wrong (tests/dynamic.rs):\n\n",
    );
    for (k, (name, fault, force)) in cases.into_iter().enumerate() {
        let mut spec = RideSpec::lab(4.5, Effects::realistic());
        spec.coast_s = 4.0;
        spec.kick.peak_force_n = force;
        spec.fault = fault;
        let ride = simulate_ride(&bike, &spec, 7000 + k as u64)?;
        files.push((format!("{name}.log").into(), ride.angles_log));
        files.push((format!("{name}_cal.log").into(), ride.cal_log));
        let _ = writeln!(
            readme,
            "- `{name}.log`: {}",
            match name {
                "no_kick" => "nobody kicked: the bicycle coasts upright after the release",
                "too_short" => "the recording stops 0.9 s after the kick",
                "sensors_swapped" =>
                    "the headers call the handlebar sensor `frame` and the frame sensor `handlebar`",
                _ => "the handlebar sensor lay on the floor through the ride",
            }
        );
    }
    files.push(("README.md".into(), readme));
    Ok(files)
}

/// A ride as a lab without a reed switch makes it: released at `speed_mps` and left to coast
/// down at 0.05–0.2 m/s² (rolling resistance C_rr 0.004–0.018 on the lab's floor, drag area
/// 0.06–0.12 m²), kicked 1–1.5 s after the release with 12–18 N, sensors mounted 2–5° off, no
/// `Sync` column; `effects` gives the rest (its resistances are replaced).
pub fn coasting_ride(
    rng: &mut Rng,
    speed_mps: f64,
    mut effects: super::ride::Effects,
) -> super::ride::RideSpec {
    effects.rolling_resistance_coeff = rng.range(0.004, 0.018);
    effects.drag_area_m2 = rng.range(0.06, 0.12);
    let mut spec = super::ride::RideSpec::lab(speed_mps, effects);
    spec.kick.after_release_s = rng.range(1.0, 1.5);
    spec.kick.peak_force_n = rng.range(12.0, 18.0);
    spec.mounting_error_deg = Some(rng.range(2.0, 5.0));
    spec.sync = false;
    spec
}

/// What the lab writes down from the speedometer at the release: the display's reading
/// (`speedometer_reading`, the true speed times the speedometer's scale) with the display's
/// lag and averaging (1 % per reading) and its step of 0.1 m/s.
pub fn noted_reading(rng: &mut Rng, speedometer_reading: f64) -> f64 {
    let shown = speedometer_reading * (1.0 + 0.01 * rng.normal());
    (shown * 10.0).round() / 10.0
}

/// The bicycle a lab measured as `measured`, its masses and inertias each off by a normal draw
/// of its standard error: the truth behind a measurement. A wheel's I_xx and I_zz are one
/// measurement (one compound pendulum, I_xx = I_zz by symmetry) and move together.
pub fn measured_within_errors(
    measured: &crate::inertia::bike::LabBike,
    rng: &mut Rng,
) -> crate::inertia::bike::LabBike {
    let mut b = measured.clone();
    for (body, wheel) in [
        (&mut b.rear_wheel, true),
        (&mut b.frame, false),
        (&mut b.handlebar, false),
        (&mut b.front_wheel, true),
    ] {
        body.mass_kg += body.mass_se_kg * rng.normal();
        let dxx = body.ixx_se_kgm2 * rng.normal();
        body.iyy_kgm2 += body.iyy_se_kgm2 * rng.normal();
        let dzz = body.izz_se_kgm2 * rng.normal();
        body.ixz_kgm2 += body.ixz_se_kgm2 * rng.normal();
        body.ixx_kgm2 += dxx;
        body.izz_kgm2 += if wheel { dxx } else { dzz };
    }
    b
}

/// The fork and handlebar turned about the front axle by `d` (rad) in the bicycle's plane,
/// the top of the steer axis going back for `d > 0` (a slacker head angle): the axis, the
/// front frame's centre of mass and its inertia tensor turn with the fork, the perpendicular
/// from the axle to the axis (the fork's offset) with them, and the trail is where the turned
/// axis meets the ground. The wheels, the wheelbase and the rear frame stay. Built from the
/// geometry in three dimensions (x forward, z down, the front contact at (w, 0, 0)).
pub fn turn_fork_about_axle(bike: &mut crate::model::Benchmark, d: f64) {
    use nalgebra::{Matrix3, Point3, Rotation3, Vector3};
    let axis_up = |tilt: f64| Vector3::new(-tilt.sin(), 0.0, -tilt.cos());
    let (old, new) = (axis_up(bike.lambda), axis_up(bike.lambda + d));
    let turn = Rotation3::rotation_between(&old, &new).unwrap_or_else(Rotation3::identity);
    let axle = Point3::new(bike.w, 0.0, -bike.r_f);
    // The steer axis meets the ground `c` ahead of the contact; the foot of the perpendicular
    // from the axle onto it turns with the fork.
    let ground = Point3::new(bike.w + bike.c, 0.0, 0.0);
    let foot = ground + old * (axle - ground).dot(&old);
    let foot = axle + turn * (foot - axle);
    let to_ground = -foot.z / new.z;
    bike.c = foot.x + to_ground * new.x - bike.w;
    let cg = axle + turn * (Point3::new(bike.x_h, 0.0, bike.z_h) - axle);
    bike.x_h = cg.x;
    bike.z_h = cg.z;
    let inertia = Matrix3::new(
        bike.i_hxx, 0.0, bike.i_hxz, 0.0, bike.i_hyy, 0.0, bike.i_hxz, 0.0, bike.i_hzz,
    );
    let turned = turn.matrix() * inertia * turn.matrix().transpose();
    bike.i_hxx = turned[(0, 0)];
    bike.i_hzz = turned[(2, 2)];
    bike.i_hxz = turned[(0, 2)];
    bike.lambda += d;
}

/// A factor off from 1 by `lo`–`hi`, either way (one draw for the size, one for the sign).
fn off_by(rng: &mut Rng, lo: f64, hi: f64) -> f64 {
    let size = rng.range(lo, hi);
    if rng.range(0.0, 1.0) < 0.5 {
        1.0 - size
    } else {
        1.0 + size
    }
}

/// An effect withheld from the gap diagnosis, for its blind check; its label is the name the
/// diagnosis gives the effect it finds.
#[derive(Debug, Clone, Copy, PartialEq, Eq, serde::Serialize)]
#[serde(rename_all = "snake_case")]
pub enum Withheld {
    /// The control: the bicycle as measured, nothing added.
    None,
    /// Viscous steer damping 0.2–0.5 N·m·s/rad.
    SteerDamping,
    /// Compliant tyres: cornering 8–14 /rad, camber 0.6 /rad, relaxation 0.1–0.25 m
    /// ([`Draws::Broad`]: 6–16 /rad, 0.5–1 /rad, 0.05–0.3 m).
    Tyres,
    /// 1.5–3 kg at the front frame's centre of mass.
    FrontMass,
    /// 2.5–4 kg at the rear frame's centre of mass.
    FrameMass,
    /// The wheels' spin inertias 1.2–1.4 times what was measured.
    WheelSpin,
    /// The front frame's I_xx 1.25–1.45 times what was measured.
    FrontIxx,
    /// Inertia added to the front frame about its z axis (a handlebar bag, a lamp on a
    /// bracket, a steer damper's body): 0.3–0.5 of the measured I_zz ([`Draws::Broad`]:
    /// 0.2–0.5, or a pendulum misread by as much the other way).
    FrontIzz,
    /// The rear frame's I_xx 0.6–0.75 or 1.25–1.4 times what was measured (a pendulum
    /// misread).
    FrameIxx,
    /// The trail 0.8–0.88 or 1.12–1.2 times what was measured (a fork's offset or head angle
    /// measured off).
    Trail,
    /// A speedometer reading 4–8 % high.
    SpeedScale,
    /// The sensors sampling 2.5–4 % fast (far beyond a real sensor's crystal, ±50 ppm: at that
    /// size it would change nothing measurable).
    TimeScale,
    /// Not in the diagnosis's library: a spring on the steer, 0.5–1.5 N·m/rad (a stiff cable).
    SteerSpring,
    /// Coulomb friction in the headset, 0.01–0.02 N·m ([`Draws::Broad`]: 0.004–0.02 N·m, from
    /// about the detection limit, 0.003–0.0036 N·m on the lab's bicycle).
    SteerFriction,
    /// The head angle off by 1.5–2.5° either way ([`Draws::Broad`]: 0.75–2.5°): the fork and
    /// handlebar turned about the front axle, the fork's offset kept ([`turn_fork_about_axle`]).
    HeadAngle,
    /// The rear frame's I_xx, I_zz and I_xz together 0.6–0.75 or 1.25–1.4 times what was
    /// measured (the body re-measured; [`Draws::Broad`]: off by 0.15–0.4).
    FrameInertia,
    /// The front frame's I_xx, I_zz and I_xz together 0.6–0.75 or 1.25–1.4 times what was
    /// measured ([`Draws::Broad`]: off by 0.15–0.4).
    FrontInertia,
}

/// The sizes a blind campaign draws its withheld effect at.
#[derive(Debug, Clone, Copy, PartialEq, Eq, serde::Serialize)]
#[serde(rename_all = "snake_case")]
pub enum Draws {
    /// Each effect at a size a campaign of 12–14 rides sees (the ranges on [`Withheld`]'s
    /// variants): the sizes `tests/gap.rs` scores the diagnosis on.
    Suite,
    /// The ranges a lab meets, down to the detection limit and both ways where a measurement
    /// can be off both ways: steer damping 0.1–0.6 N·m·s/rad, cornering 6–16 /rad with a
    /// relaxation 0.05–0.3 m, 1–3 kg at either frame's centre of mass, the wheels' spin
    /// inertia 1.1–1.4 ×, the front frame's I_xx 1.15–1.45 ×, its I_zz off by 0.2–0.5, the rear
    /// frame's I_xx off by 0.15–0.4, either frame's in-plane inertia as a set off by 0.15–0.4,
    /// the trail off by 0.06–0.2, a speedometer 3–10 % off either way, the head angle off by
    /// 0.75–2.5° either way; the clock and the effects outside the library as in `Suite`. The
    /// calibration run (`bikeproc simulate gap-calibration`) draws these.
    Broad,
}

/// How a blind campaign's speeds are taken.
#[derive(Debug, Clone, Copy, PartialEq, Eq, serde::Serialize, serde::Deserialize)]
#[serde(rename_all = "snake_case")]
pub enum BlindDesign {
    /// 12 rides, `Sync` on every other one, no resistance to the coast.
    Sync,
    /// 14 rides as a lab without a reed switch makes them ([`coasting_ride`]): the reading
    /// noted at the release rounded to 0.1 m/s ([`noted_reading`]), coasting 0.05–0.2 m/s²,
    /// the kick 1–1.5 s after the release.
    Noted,
    /// As [`BlindDesign::Noted`], on a plan each campaign draws as labs plan theirs: 12–16
    /// rides released evenly from 2.9–3.6 up to 5.8–6.5 m/s, the slowest near or below the
    /// weave speed (the lab's bicycle's, 3.1 m/s: a growing weave, a short window, a ride
    /// that may be refused).
    Varied,
}

impl BlindDesign {
    pub const ALL: [BlindDesign; 3] = [BlindDesign::Sync, BlindDesign::Noted, BlindDesign::Varied];

    /// The design's name as `--design` takes it: `sync`, `noted` or `varied`.
    pub fn label(self) -> &'static str {
        match self {
            BlindDesign::Sync => "sync",
            BlindDesign::Noted => "noted",
            BlindDesign::Varied => "varied",
        }
    }

    /// The design named `label` ([`BlindDesign::label`]).
    pub fn from_label(label: &str) -> Option<BlindDesign> {
        BlindDesign::ALL.into_iter().find(|d| d.label() == label)
    }
}

impl Withheld {
    pub const ALL: [Withheld; 17] = [
        Withheld::None,
        Withheld::SteerDamping,
        Withheld::Tyres,
        Withheld::FrontMass,
        Withheld::FrameMass,
        Withheld::WheelSpin,
        Withheld::FrontIxx,
        Withheld::FrontIzz,
        Withheld::FrameIxx,
        Withheld::Trail,
        Withheld::SpeedScale,
        Withheld::TimeScale,
        Withheld::SteerSpring,
        Withheld::SteerFriction,
        Withheld::HeadAngle,
        Withheld::FrameInertia,
        Withheld::FrontInertia,
    ];

    /// The name the diagnosis uses for the effect ("none" for the control).
    pub fn label(self) -> &'static str {
        match self {
            Withheld::None => "none",
            Withheld::SteerDamping => "steer_damping",
            Withheld::Tyres => "tyres",
            Withheld::FrontMass => "front_mass",
            Withheld::FrameMass => "frame_mass",
            Withheld::WheelSpin => "wheel_spin",
            Withheld::FrontIxx => "front_ixx",
            Withheld::FrontIzz => "front_izz",
            Withheld::FrameIxx => "frame_ixx",
            Withheld::Trail => "trail",
            Withheld::SpeedScale => "speed_scale",
            Withheld::TimeScale => "time_scale",
            Withheld::SteerSpring => "steer_spring",
            Withheld::SteerFriction => "steer_friction",
            Withheld::HeadAngle => "head_angle",
            Withheld::FrameInertia => "frame_inertia",
            Withheld::FrontInertia => "front_inertia",
        }
    }

    /// By label.
    pub fn from_label(label: &str) -> Option<Withheld> {
        Withheld::ALL.into_iter().find(|w| w.label() == label)
    }

    /// The effect's place in [`Withheld::ALL`] (0 for the control): it keys the effect's own
    /// stream of true bicycles ([`blind_campaign_plus`]).
    fn index(self) -> u64 {
        Withheld::ALL
            .iter()
            .position(|&w| w == self)
            .map_or(0, |i| i as u64)
    }
}

/// The sealed truth of a blind campaign.
#[derive(Debug, Clone, serde::Serialize)]
pub struct BlindTruth {
    pub effect: Withheld,
    pub design: BlindDesign,
    /// The effect's parameters as the diagnosis names them (e.g. the tyres' cornering
    /// stiffness and relaxation length; a factor; a mass in kg).
    pub params: Vec<f64>,
    pub seed: u64,
    pub draws: Draws,
}

/// A campaign of 12 rides (3.8–6.55 m/s; `Sync` on every other ride, the noted reading on the
/// rest) on the measured bicycle with one effect withheld at a magnitude drawn from its
/// realistic range, realistic sensors and noise, a receiver that stamps packets late in 6
/// bursts a minute, no drag (so the noted speed is the speed of
/// the window and only the withheld effect parts the rides from the model). Files: the
/// manifest (`rides.toml`, naming `bike_file`), the logs, and the sealed `truth.json`.
///
/// With [`BlindDesign::Noted`], 14 rides released at 3.8–6.5 m/s as [`coasting_ride`] makes
/// them, no `Sync`, the readings noted as [`noted_reading`] makes them; with
/// [`BlindDesign::Varied`], the same on a plan of the campaign's own (12–16 rides from 2.9–3.6
/// up to 5.8–6.5 m/s).
pub fn blind_campaign(
    measured: &crate::inertia::bike::LabBike,
    bike_file: &str,
    withheld: Withheld,
    design: BlindDesign,
    seed: u64,
) -> Result<(Files, BlindTruth), super::ride::SimulationError> {
    blind_campaign_plus(
        measured,
        bike_file,
        withheld,
        design,
        seed,
        &[],
        Draws::Suite,
    )
}

/// [`blind_campaign`] with more rides after its own, released at `extra_speeds_mps` (the
/// rides a diagnosis recommends next); the campaign's own rides are the same.
pub fn blind_campaign_plus(
    measured: &crate::inertia::bike::LabBike,
    bike_file: &str,
    withheld: Withheld,
    design: BlindDesign,
    seed: u64,
    extra_speeds_mps: &[f64],
    draws: Draws,
) -> Result<(Files, BlindTruth), super::ride::SimulationError> {
    use super::ride::{simulate_ride, Effects, PointMass, RideSpec};
    let broad = draws == Draws::Broad;
    use super::whipple::{Body, TyreModel};
    let mut rng = seeded(7_000 + seed);
    // A lab's bicycle is what its pendulums measured it to be only within their errors: with
    // broad draws the true bicycle is the measured one off by a draw of those errors (its own
    // stream, so the rides' draws stay those of the seed). Each effect draws its own bicycles:
    // one shared draw per seed made every effect's campaigns of that seed err alike, so that a
    // calibration's rows moved together (50 noted clocks' mean normalized error −0.36 on the
    // shared bicycles, −0.02 on 50 others).
    let truth = match draws {
        Draws::Broad => measured_within_errors(
            measured,
            &mut seeded(11_000 + seed + (withheld.index() << 32)),
        ),
        Draws::Suite => measured.clone(),
    };
    let mut bike = crate::model::lab::lab_to_benchmark(&truth);
    let mut effects = Effects::default();
    let params = match withheld {
        Withheld::None => vec![],
        Withheld::SteerDamping => {
            let c = if broad {
                rng.range(0.1, 0.6)
            } else {
                rng.range(0.2, 0.5)
            };
            effects.steer_viscous_nms_per_rad = c;
            vec![c]
        }
        Withheld::Tyres => {
            let (ca, sigma, camber) = if broad {
                // Real tyres' camber stiffness spans 0.5–1 /rad (drum tests); the diagnosis
                // assumes one value and must carry the others in its errors.
                (
                    rng.range(6.0, 16.0),
                    rng.range(0.05, 0.3),
                    rng.range(0.5, 1.0),
                )
            } else {
                (rng.range(8.0, 14.0), rng.range(0.1, 0.25), 0.6)
            };
            effects.tyres = Some(TyreModel {
                cornering_per_rad: ca,
                camber_per_rad: camber,
                relaxation_length_m: sigma,
            });
            vec![ca, sigma]
        }
        Withheld::FrontMass => {
            let m = if broad {
                rng.range(1.0, 3.0)
            } else {
                rng.range(1.5, 3.0)
            };
            effects.extra_masses.push(PointMass {
                body: Body::Fork,
                mass_kg: m,
                x_m: bike.x_h,
                z_m: bike.z_h,
            });
            vec![m]
        }
        Withheld::FrameMass => {
            let m = if broad {
                rng.range(1.0, 3.0)
            } else {
                rng.range(2.5, 4.0)
            };
            effects.extra_masses.push(PointMass {
                body: Body::Frame,
                mass_kg: m,
                x_m: bike.x_b,
                z_m: bike.z_b,
            });
            vec![m]
        }
        Withheld::WheelSpin => {
            let k = if broad {
                rng.range(1.1, 1.4)
            } else {
                rng.range(1.2, 1.4)
            };
            bike.i_ryy *= k;
            bike.i_fyy *= k;
            vec![k]
        }
        Withheld::FrontIxx => {
            let k = if broad {
                rng.range(1.15, 1.45)
            } else {
                rng.range(1.25, 1.45)
            };
            bike.i_hxx *= k;
            vec![k]
        }
        Withheld::FrontIzz => {
            let k = if broad {
                off_by(&mut rng, 0.2, 0.5)
            } else {
                1.0 + rng.range(0.3, 0.5)
            };
            bike.i_hzz *= k;
            vec![k]
        }
        Withheld::FrameIxx => {
            let k = if broad {
                off_by(&mut rng, 0.15, 0.4)
            } else {
                off_by(&mut rng, 0.25, 0.4)
            };
            bike.i_bxx *= k;
            vec![k]
        }
        Withheld::Trail => {
            let k = if broad {
                off_by(&mut rng, 0.06, 0.2)
            } else {
                off_by(&mut rng, 0.12, 0.2)
            };
            bike.c *= k;
            vec![k]
        }
        Withheld::SpeedScale => {
            let k = if broad {
                off_by(&mut rng, 0.03, 0.1)
            } else {
                rng.range(1.04, 1.08)
            };
            effects.speedometer_scale = k;
            vec![k]
        }
        Withheld::TimeScale => {
            let s = rng.range(1.025, 1.04);
            effects.clock_scale = s;
            vec![s]
        }
        Withheld::SteerSpring => {
            let k = rng.range(0.5, 1.5);
            effects.steer_spring_nm_per_rad = k;
            vec![k]
        }
        Withheld::SteerFriction => {
            let f = if broad {
                rng.range(0.004, 0.02)
            } else {
                rng.range(0.01, 0.02)
            };
            effects.steer_coulomb_nm = f;
            vec![f]
        }
        Withheld::HeadAngle => {
            let size_deg = if broad {
                rng.range(0.75, 2.5)
            } else {
                rng.range(1.5, 2.5)
            };
            let sign = if rng.range(0.0, 1.0) < 0.5 { -1.0 } else { 1.0 };
            let d = (sign * size_deg).to_radians();
            turn_fork_about_axle(&mut bike, d);
            vec![d]
        }
        Withheld::FrameInertia | Withheld::FrontInertia => {
            let k = if broad {
                off_by(&mut rng, 0.15, 0.4)
            } else {
                off_by(&mut rng, 0.25, 0.4)
            };
            if withheld == Withheld::FrameInertia {
                bike.i_bxx *= k;
                bike.i_bzz *= k;
                bike.i_bxz *= k;
            } else {
                bike.i_hxx *= k;
                bike.i_hzz *= k;
                bike.i_hxz *= k;
            }
            vec![k]
        }
    };
    let mut files = Files::new();
    let mut manifest = format!(
        "# A blind campaign: one effect withheld (sealed in truth.json).\nversion = 1\nbike = \"{bike_file}\"\n{}",
        match design {
            // The simulated speedometer of this design reads the release speed exactly (to the
            // written 0.01 m/s), and nothing slows the coast.
            BlindDesign::Sync => "speedometer_resolution_mps = 0.01\nspeedometer_se_fraction = 0.0\n",
            BlindDesign::Noted | BlindDesign::Varied => "",
        }
    );
    // The plan: how many rides, and ride k's release speed (m/s).
    let (rides, varied) = match design {
        BlindDesign::Sync => (12, None),
        BlindDesign::Noted => (14, None),
        BlindDesign::Varied => {
            let rides = (12 + (5.0 * rng.range(0.0, 1.0)) as usize).min(16);
            (rides, Some((rng.range(2.9, 3.6), rng.range(5.8, 6.5))))
        }
    };
    let planned = |k: usize| match (design, varied) {
        (_, Some((first, last))) => first + (last - first) * k as f64 / (rides - 1) as f64,
        (BlindDesign::Sync, _) => 3.8 + 0.25 * k as f64,
        _ => 3.8 + 2.7 * k as f64 / 13.0,
    };
    for k in 0..rides + extra_speeds_mps.len() {
        let extra = k.checked_sub(rides).map(|e| extra_speeds_mps[e]);
        let spec = match design {
            BlindDesign::Sync => {
                let mut spec = RideSpec::lab(extra.unwrap_or(planned(k)), effects.clone());
                spec.sync = k % 2 == 1;
                spec.kick.peak_force_n = rng.range(12.0, 18.0);
                spec
            }
            BlindDesign::Noted | BlindDesign::Varied => {
                coasting_ride(&mut rng, extra.unwrap_or(planned(k)), effects.clone())
            }
        };
        // A Bluetooth receiver that gets packets late now and then.
        let mut spec = spec;
        spec.receiver_late_bursts_per_minute = 6.0;
        let ride = simulate_ride(&bike, &spec, 100 * seed + k as u64)?;
        let name = format!("ride_{:02}", k + 1);
        files.push((format!("{name}.log").into(), ride.angles_log));
        files.push((format!("{name}_cal.log").into(), ride.cal_log));
        let noted = match design {
            BlindDesign::Sync => format!("{:.2}", ride.truth.noted_speed_mps),
            BlindDesign::Noted | BlindDesign::Varied => {
                format!("{:.1}", noted_reading(&mut rng, ride.truth.noted_speed_mps))
            }
        };
        let _ = write!(
            manifest,
            "\n[[ride]]\nlog = \"{name}.log\"\nnoted_speed_mps = {noted}\n"
        );
    }
    files.push(("rides.toml".into(), manifest));
    let truth = BlindTruth {
        effect: withheld,
        design,
        params,
        seed,
        draws,
    };
    files.push((
        "truth.json".into(),
        serde_json::to_string(&truth).unwrap_or_default(),
    ));
    files.sort_by(|a, b| a.0.cmp(&b.0));
    Ok((files, truth))
}
