//! The `bikeproc` command line: argument parsing, output and exit codes over the library.
//! Exit code 0 on success, 2 when an input is malformed or cannot be analysed, 1 otherwise.

use anyhow::{bail, Context, Result};
use bikeproc::fit::{self, FitOptions, Trend};
use bikeproc::inertia::{self, manifest::Kind, text};
use bikeproc::log::{OutputMode, ReadOptions};
use bikeproc::signal::{self, Extract};
use bikeproc::sim::{self, imu, pendulum};
use bikeproc::uncertainty::Measured;
use clap::{Args, Parser, Subcommand, ValueEnum};
use std::path::{Path, PathBuf};
use std::process::ExitCode;

#[derive(Parser)]
#[command(
    name = "bikeproc",
    version = concat!(env!("CARGO_PKG_VERSION"), " (", env!("BIKEPROC_BUILD"), ")"),
    about = "Bicycle-dynamics lab: IMU logs → inertias, eigenvalues, sim-to-real gap",
    after_help = concat!(
        "The lab's workflow: calibrate-bar → inertia → stability → dynamic → gap (see the README's tour). ",
        "Every number comes with its standard error; SI units. Section and equation numbers ",
        "(seed §5.4, eq. 65) are those of the lab's thesis, ../shared/seed beside the checkout.\n\n",
        "Exit codes: 0 done; 2 an input is malformed or cannot be analysed (the message names the ",
        "file, line and what); 1 anything else."
    )
)]
struct Cli {
    #[command(subcommand)]
    command: Command,
}

#[derive(Subcommand)]
enum Command {
    /// Measure the free oscillation in one log or CSV: frequency, damping, standard errors.
    #[command(after_help = concat!(
        "Examples:\n",
        "  bikeproc period data/frame_torsion/frame_torsion_1a.log\n",
        "  bikeproc period data/frame_torsion/        (the trials of each set-up combined)\n",
        "  bikeproc period ride_cal.log --channel Gyr_Z --segment 2.5:40\n\n",
        "JSON (--json): {\"period_s\", \"period_se_s\", \"freq_hz\", \"natural_freq_hz\", ",
        "\"damping_ratio\", …, \"segment_s\", \"receiver_time_off_rows\"}, one object per file ",
        "(trials of a set-up: their mean, scatter and flagged trials).\n\n",
        "Exit codes: 0 done; 2 an input is malformed or gives no period (named on stderr); 1 ",
        "anything else."
    ))]
    Period(PeriodArgs),
    /// Calibrate the torsion bar with the steel rod (and the empty fixture); writes
    /// DIR/calibration.toml for the other commands.
    #[command(after_help = concat!(
        "Example:\n",
        "  bikeproc calibrate-bar data/bar_calibration\n\n",
        "The folder's manifest.toml names the rod's mass (kg), diameter and length (m) and its ",
        "logs. Writes DIR/calibration.toml (stiffness N·m/rad, fixture inertia kg·m², their ",
        "standard errors and correlation).\n\n",
        "JSON (--json): {\"stiffness_nm_per_rad\", \"stiffness_se_nm_per_rad\", ",
        "\"rod_inertia_kgm2\", \"fixture_inertia_kgm2\", \"freq_hz\", …}.\n\n",
        "Exit codes: 0 done; 2 an input is malformed or cannot be analysed; 1 anything else."
    ))]
    CalibrateBar(CalibrateArgs),
    /// Moments and inertia tensors from a folder of torsion or compound-pendulum tests, or
    /// refresh the inertias of a bicycle file (--bike).
    #[command(after_help = concat!(
        "Examples:\n",
        "  bikeproc inertia data/frame_torsion\n",
        "  bikeproc inertia data/frame_torsion --orientations 1,2,4\n",
        "  bikeproc inertia data/rear_wheel_compound\n",
        "  bikeproc inertia --bike data/lab_bike.toml     (rewrites its inertias from its test folders)\n\n",
        "The folder's manifest.toml says torsion or compound, the body's mass (kg), the axes and ",
        "distances (m) and the logs; the bar's calibration comes from bar_calibration/ beside it.\n\n",
        "JSON (--json): {\"body\", \"ixx\", \"ixx_se\", \"ixz\", \"izz\", …, ",
        "\"orientations\", \"tensor\"} for torsion tests, {\"body\", \"ixx\", ",
        "\"iyy\", \"izz\", their _se, \"mass_kg\", \"tests\"} for compound ones (kg·m²).\n\n",
        "Exit codes: 0 done; 2 an input is malformed or cannot be analysed; 1 anything else."
    ))]
    Inertia(InertiaArgs),
    /// Benchmark parameters with standard errors from a BicycleParameters `*Measured.txt` (raw
    /// masses, distances, pendulum angles and periods), and the bicycle's stable speed range.
    #[command(after_help = concat!(
        "Examples:\n",
        "  bikeproc measured ../shared/reference/bicycleparameters/RigidMeasured.txt\n",
        "  bikeproc measured BrowserMeasured.txt --out BrowserBenchmark.txt\n",
        "  bikeproc stability --bike BrowserBenchmark.txt\n\n",
        "JSON (--json): {\"name\", \"parameters\": {\"IBxx\": {\"value\", \"se\"}, …}, ",
        "\"stable_ranges_mps\", \"weave_speed_mps\", \"weave_speed_se_mps\", ",
        "\"capsize_speed_mps\", \"capsize_speed_se_mps\"} (SI units: m, kg, kg·m², rad).\n\n",
        "Exit codes: 0 done; 2 a measurement is missing or malformed (named with its line); 1 ",
        "anything else."
    ))]
    Measured(MeasuredArgs),
    /// Stability of a bicycle against speed: stable range, weave and capsize speeds with standard
    /// errors, eigenvalues (linearized Whipple model, Meijaard et al. 2007).
    #[command(after_help = concat!(
        "Examples:\n",
        "  bikeproc stability --bike data/lab_bike.toml\n",
        "  bikeproc stability --bike ../shared/reference/bicycleparameters/BenchmarkBenchmark.txt --speeds 0:10:0.1\n",
        "  bikeproc stability --bike data/lab_bike.toml --cg-on-steer-axis\n\n",
        "JSON (--json): {\"bike\", \"weave_speed_mps\", \"weave_speed_se_mps\", ",
        "\"capsize_speed_mps\", \"capsize_speed_se_mps\", \"stable_ranges_mps\", ",
        "\"eigenvalues\": [{\"speed_mps\", \"weave\": {\"re\", \"im\", \"re_se\", \"im_se\"}, ",
        "\"capsize\", \"castor\", \"weave_steer_over_roll\", \"weave_steer_phase_deg\"}, …]} ",
        "(eigenvalues in 1/s).\n\n",
        "Exit codes: 0 done; 2 the bicycle file is malformed or gives no dynamics; 1 anything else."
    ))]
    Stability(StabilityArgs),
    /// Experimental weave eigenvalue of a ride (its angles log, `_cal` beside it) or of every
    /// ride of a campaign (rides.toml), against the model at the ride's speed.
    #[command(after_help = concat!(
        "Examples:\n",
        "  bikeproc dynamic data/ride_03.log --speed 3.9    (the speedometer's reading at the release, m/s)\n",
        "  bikeproc dynamic data/rides.toml                 (every ride of the campaign)\n",
        "  bikeproc dynamic ride.csv --window 141.3:143.8 --bike Balanceassistv1Benchmark.txt\n\n",
        "Without --bike a ride is compared with the lab_bike.toml beside its log, a campaign ",
        "with its manifest's bicycle.\n\n",
        "JSON (--json): {\"file\", \"speed_mps\", \"speed_se_mps\", \"speed_source\", ",
        "\"weave\": {\"re\", \"im\", \"re_se\", \"im_se\"}, \"mode_shape\", ",
        "\"model_weave\", …} (1/s); a campaign {\"rides\": [...], \"failures\": [...]}.\n\n",
        "Exit codes: 0 done; 2 a ride cannot be analysed (the reason named) or an input is ",
        "malformed; 1 anything else."
    ))]
    Dynamic(DynamicArgs),
    /// The sim-to-real gap of a campaign (rides.toml): where the rides part from the model,
    /// which unmodelled effect explains it, how far it shrinks on rides left out.
    #[command(after_help = concat!(
        "Examples:\n",
        "  bikeproc gap data/rides.toml\n",
        "  bikeproc gap fixtures/real/balanceassist_gain6.toml\n\n",
        "JSON (--json): {\"significant\", \"explained\", \"chi2\", \"dof\", \"p_value\", ",
        "\"residuals\", \"ranking\": [{\"effect\", \"params\", \"params_se\", ",
        "\"heldout_rms_before\", \"heldout_rms_after\", \"plausible\"}, …], \"verdict\"}.\n\n",
        "Exit codes: 0 done; 2 the manifest is malformed or no ride could be analysed; 1 ",
        "anything else."
    ))]
    Gap(GapArgs),
    /// Write simulated logs from physics.
    #[command(subcommand, after_help = concat!(
        "Examples:\n",
        "  bikeproc simulate torsion --out /tmp/rod.log\n",
        "  bikeproc simulate ride --bike data/lab_bike.toml --speed 4.5 --out /tmp/ride.log\n",
        "  bikeproc simulate blind --effect steer_damping --out /tmp/blind\n\n",
        "Exit codes: 0 done; 2 an input is malformed; 1 anything else (e.g. --out cannot be written)."
    ))]
    Simulate(SimCommand),
    /// Regenerate every report in reports/ from data/ and the reference signals.
    #[command(after_help = concat!(
        "Example:\n",
        "  bikeproc report                       (from the checkout: data/ and ../shared/reference)\n",
        "  bikeproc report --out /tmp/reports\n\n",
        "The new set replaces the folder as a whole (an interrupted run leaves the old one).\n\n",
        "Exit codes: 0 done; 2 an input is malformed; 1 anything else (e.g. ../shared/reference missing)."
    ))]
    Report(ReportArgs),
}

#[derive(Args)]
struct PeriodArgs {
    /// A `NAME.log` / `NAME_cal.log` file, or a CSV `time_s,value`; several files or a folder
    /// of them for repeated trials (`…1`, `…2`, … of one set-up are combined: mean, scatter,
    /// flagged trials).
    #[arg(required = true)]
    files: Vec<PathBuf>,
    /// Fit this column instead of the rotation about the dominant axis (e.g. Gyr_Z: read from
    /// the `_cal` file when the angles file does not have it).
    #[arg(long)]
    channel: Option<String>,
    /// Which sensor, by id or label, when the log has several.
    #[arg(long)]
    sensor: Option<String>,
    /// Linear trend beside the offset (gyro bias, heading drift).
    #[arg(long, value_enum, default_value_t = TrendArg::Auto)]
    trend: TrendArg,
    /// Fit this time range instead of finding the free decay, seconds `START:END`.
    #[arg(long, value_parser = parse_range)]
    segment: Option<(f64, f64)>,
    /// Print JSON instead of text (its shape: below).
    #[arg(long)]
    json: bool,
}

#[derive(Args)]
struct DynamicArgs {
    /// A ride's angles log (`ride_03.log`), a campaign manifest (`rides.toml`), or a CSV of
    /// time series from another instrument (`time_s`, `roll_rad`, `steer_deg`,
    /// `rear_wheel_speed_m_per_s`, …; --window picks one decay).
    file: PathBuf,
    /// A CSV ride: the free decay to fit, seconds `START:END` (without it a record of up to
    /// 10 s is one free decay; in a longer one every kick is found and each decay fitted).
    #[arg(long, value_parser = parse_range)]
    window: Option<(f64, f64)>,
    /// A CSV ride: columns by other names, `roll=ROLL_COL,steer=…,time=…,wheel_speed=…`
    /// (quantities: time, roll, roll_rate, steer, steer_rate, wheel_speed; a name ending in
    /// `_deg` is read as degrees).
    #[arg(long)]
    columns: Option<bikeproc::ride::csv::Columns>,
    /// The speedometer's reading at the release (m/s), as noted: carried to where the
    /// eigenvalue applies by the slowing the frame sensor measures. Without it the log's `Sync`
    /// pulses give the speed, or else the yaw rate against the steer (rolling kinematics).
    /// Campaigns use the readings of their manifest where a log has no `Sync`.
    #[arg(long, value_parser = parse_speed, allow_hyphen_values = true)]
    speed: Option<f64>,
    /// The speedometer's display step (m/s): a reading is uniform within ± half of it.
    #[arg(long, default_value_t = 0.1, value_parser = fraction_or_step(2.0))]
    speed_resolution: f64,
    /// The speedometer's random error per reading, as a fraction of the reading.
    #[arg(long, default_value_t = 0.01, value_parser = fraction_or_step(0.5))]
    speed_se_fraction: f64,
    /// The bicycle (lab TOML or BicycleParameters file); campaigns default to their manifest's.
    #[arg(long)]
    bike: Option<PathBuf>,
    /// A steer controller in the model (a TOML file with a `[controller]` table: gains on
    /// roll, steer and their rates against speed); campaigns take their manifest's.
    #[arg(long)]
    controller: Option<PathBuf>,
    /// Bootstrap resamples for the check of the standard errors (20 to 100,000).
    #[arg(long, default_value_t = 400, value_parser = clap::value_parser!(u32).range(20..=100_000))]
    resamples: u32,
    /// Print JSON instead of text (its shape: below).
    #[arg(long)]
    json: bool,
}

#[derive(Args)]
struct GapArgs {
    /// A campaign manifest (`rides.toml`).
    file: PathBuf,
    /// The bicycle (lab TOML or BicycleParameters file); defaults to the manifest's.
    #[arg(long)]
    bike: Option<PathBuf>,
    /// Print JSON instead of text (its shape: below).
    #[arg(long)]
    json: bool,
}

#[derive(Args)]
struct CalibrateArgs {
    /// The bar-calibration folder (its manifest.toml and logs).
    #[arg(default_value = "data/bar_calibration")]
    dir: PathBuf,
    /// Print JSON instead of text (its shape: below).
    #[arg(long)]
    json: bool,
}

#[derive(Args)]
struct MeasuredArgs {
    /// A BicycleParameters `NameMeasured.txt`.
    file: PathBuf,
    /// Print JSON: `{"name", "parameters": {"IBxx": {"value", "se"}, …}, …}`.
    /// Print JSON instead of text (its shape: below).
    #[arg(long)]
    json: bool,
    /// Also write the parameters in BicycleParameters' `*Benchmark.txt` format (which
    /// `bikeproc stability --bike` reads).
    #[arg(long)]
    out: Option<PathBuf>,
}

#[derive(Args)]
struct InertiaArgs {
    /// A test folder (manifest.toml and its logs).
    #[arg(required_unless_present = "bike")]
    dir: Option<PathBuf>,
    /// The tensor from these orientations only, e.g. 1,2,4.
    #[arg(long, value_delimiter = ',')]
    orientations: Vec<String>,
    /// Refresh the inertias of this bicycle file from the test folders it names.
    #[arg(long, conflicts_with = "dir")]
    bike: Option<PathBuf>,
    /// Print JSON instead of text (its shape: below).
    #[arg(long)]
    json: bool,
}

#[derive(Args)]
struct StabilityArgs {
    /// A bicycle: BicycleParameters text (`*Benchmark.txt`), benchmark TOML, or a lab bicycle
    /// (`data/lab_bike.toml`).
    #[arg(long)]
    bike: PathBuf,
    /// Speeds `START:END:STEP` in m/s.
    #[arg(long, default_value = "0:10:0.01", value_parser = parse_speeds)]
    speeds: (f64, f64, f64),
    /// Move the handlebar's centre of gravity onto the steer axis (the lab's model, seed §6.2).
    #[arg(long)]
    cg_on_steer_axis: bool,
    /// A steer controller closing the loop (a TOML file with a `[controller]` table).
    #[arg(long)]
    controller: Option<PathBuf>,
    /// Print JSON instead of text (its shape: below).
    #[arg(long)]
    json: bool,
}

fn parse_speeds(s: &str) -> Result<(f64, f64, f64), String> {
    let parts: Vec<f64> = s
        .split(':')
        .map(|p| {
            p.trim()
                .parse::<f64>()
                .map_err(|_| format!("`{p}` is not a number"))
        })
        .collect::<Result<_, _>>()?;
    match parts[..] {
        [a, b, st] if a >= 0.0 && b > a && st > 0.0 && (b - a) / st <= 1e6 => Ok((a, b, st)),
        _ => Err(
            "expected START:END:STEP with 0 ≤ START < END and 0 < STEP (at most a million speeds)"
                .into(),
        ),
    }
}

#[derive(Clone, Copy, ValueEnum)]
enum TrendArg {
    Auto,
    On,
    Off,
}

#[derive(Subcommand)]
enum SimCommand {
    /// A body on the torsion bar (defaults: the lab's calibration rod, eqs. 65–67).
    #[command(
        after_help = "Examples:\n  bikeproc simulate torsion --out /tmp/rod.log\n  bikeproc simulate torsion --inertia-kgm2 0.2 --locale spanish --out /tmp/wheel.log\n\nThe truth (the simulated body's parameters) is printed as JSON; the log pair is NAME.log and NAME_cal.log."
    )]
    Torsion(TorsionArgs),
    /// A body hung as a compound pendulum (defaults: the lab's frame, eq. 79).
    #[command(
        after_help = "Examples:\n  bikeproc simulate compound --out /tmp/frame.log\n  bikeproc simulate compound --mass-kg 2.0 --pivot-to-cg-m 0.3 --out /tmp/fork.log\n\nThe truth (the simulated body's parameters) is printed as JSON; the log pair is NAME.log and NAME_cal.log."
    )]
    Compound(CompoundArgs),
    /// A ride (seed §5.4): standstill, push, release, kick at the saddle, catch; the nonlinear
    /// Whipple bicycle with the chosen effects, recorded by a frame and a handlebar sensor.
    #[command(
        after_help = "Examples:\n  bikeproc simulate ride --bike data/lab_bike.toml --speed 4.5 --out /tmp/ride.log\n  bikeproc simulate ride --bike data/lab_bike.toml --speed 5 --effects none --sync --seed 7 --out /tmp/ride.log\n\nThe truth goes to truth/NAME.json beside the log (no analysis reads it)."
    )]
    Ride(RideArgs),
    /// The lab's ride campaign (seed §5.4) on the bicycle in DIR/lab_bike.toml, as data/ holds it.
    #[command(
        after_help = "Example:\n  bikeproc simulate rides --out /tmp/campaign     (the folder must hold lab_bike.toml)"
    )]
    Rides {
        /// Folder to write into (it holds lab_bike.toml).
        #[arg(long)]
        out: PathBuf,
    },
    /// Rides that went wrong (no kick, too short, sensors swapped, a sensor that did not
    /// move), as fixtures/rides/ holds them.
    #[command(after_help = "Example:\n  bikeproc simulate ride-faults --out /tmp/faults")]
    RideFaults {
        /// Folder to write into.
        #[arg(long)]
        out: PathBuf,
    },
    /// A blind campaign for `bikeproc gap`: 12 or 14 rides on the measured bicycle with one
    /// effect withheld, its truth sealed in OUT/truth.json.
    #[command(
        after_help = "Examples:\n  bikeproc simulate blind --effect steer_damping --out /tmp/blind\n  bikeproc simulate blind --effect tyres --design noted --seed 3 --out /tmp/blind\n  bikeproc gap /tmp/blind/rides.toml"
    )]
    Blind {
        /// The effect to withhold.
        #[arg(long, value_parser = withheld_effects())]
        effect: String,
        /// `sync`: 12 rides, the reed switch on every other; `noted`: 14 coasting rides, the
        /// speedometer's reading at the release rounded to 0.1 m/s, no reed switch.
        #[arg(long, default_value = "sync", value_parser = ["sync", "noted"])]
        design: String,
        /// Seed of the random numbers: the same seed, the same campaign.
        #[arg(long, default_value_t = 1)]
        seed: u64,
        /// The measured bicycle (copied beside the rides as bike.toml).
        #[arg(long, default_value = "data/lab_bike.toml")]
        bike: PathBuf,
        /// Folder to write into.
        #[arg(long)]
        out: PathBuf,
    },
    /// The lab's whole pendulum campaign (seed §5.3), as data/ holds it.
    #[command(after_help = "Example:\n  bikeproc simulate campaign --out /tmp/campaign")]
    Campaign {
        /// Folder to write into (`data` to regenerate the checked-in campaign).
        #[arg(long)]
        out: PathBuf,
    },
}

#[derive(Args)]
struct RideArgs {
    /// The truth bicycle (BicycleParameters text, benchmark TOML or a lab bicycle).
    #[arg(long)]
    bike: PathBuf,
    /// Speed at release (m/s).
    #[arg(long)]
    speed: f64,
    /// The effects beyond the Whipple model: `none`; `realistic` (steer damping 0.3 N·m·s/rad,
    /// rolling resistance 0.004, drag area 0.08 m², the sensors' and speedometer's masses, a
    /// speedometer reading 3 % high, compliant tyres); or a TOML file of them, any left out
    /// off: steer_viscous_nms_per_rad, steer_coulomb_nm, steer_spring_nm_per_rad,
    /// rolling_resistance_coeff, drag_area_m2, speedometer_scale, clock_scale,
    /// [[extra_masses]] (mass_kg, body, x_m, z_m), [tyres].
    #[arg(long, default_value = "realistic")]
    effects: String,
    /// Seed of the random numbers (kick, noise, link): the same seed, the same files.
    #[arg(long, default_value_t = 1)]
    seed: u64,
    /// Output `NAME.log` (its `NAME_cal.log` beside it).
    #[arg(long)]
    out: PathBuf,
    /// Where the truth goes (default: `truth/NAME.json` beside the log); no analysis reads it.
    #[arg(long)]
    truth: Option<PathBuf>,
    /// Wire the reed switch: the `Sync` column and the wheel circumference.
    #[arg(long)]
    sync: bool,
    /// The sensors' orientation output: Euler angles, quaternion or rotation matrix.
    #[arg(long, value_enum, default_value_t = ModeArg::Euler)]
    mode: ModeArg,
    /// The acquisition PC's locale: tab-separated, or Spanish (`;` and decimal commas).
    #[arg(long, value_enum, default_value_t = LocaleArg::Tab)]
    locale: LocaleArg,
}

#[derive(Args)]
struct TorsionArgs {
    /// The body's inertia about the bar's axis (kg·m²).
    #[arg(long, default_value_t = 1.8906)]
    inertia_kgm2: f64,
    /// The bar's torsional stiffness (N·m/rad).
    #[arg(long, default_value_t = 34.33)]
    stiffness_nm_per_rad: f64,
    /// Viscous damping ratio ζ (dimensionless).
    #[arg(long, default_value_t = 0.004)]
    damping_ratio: f64,
    /// Dry (Coulomb) friction torque in the bearing (N·m).
    #[arg(long, default_value_t = 0.0)]
    coulomb_nm: f64,
    /// Frequency of the Cardan joint's swing mode (Hz); no swing mode when absent.
    #[arg(long)]
    swing_freq_hz: Option<f64>,
    /// How strongly the swing mode couples into the torsion (dimensionless, 0–1).
    #[arg(long, default_value_t = 0.03)]
    swing_coupling: f64,
    /// The swing mode's damping ratio (dimensionless).
    #[arg(long, default_value_t = 0.02)]
    swing_damping_ratio: f64,
    /// The swing mode's initial amplitude (degrees).
    #[arg(long, default_value_t = 1.0)]
    swing_amplitude_deg: f64,
    #[command(flatten)]
    common: SimCommon,
}

#[derive(Args)]
struct CompoundArgs {
    /// The body's mass (kg).
    #[arg(long, default_value_t = 5.48)]
    mass_kg: f64,
    /// Distance from the pivot to the centre of gravity (m).
    #[arg(long, default_value_t = 0.37)]
    pivot_to_cg_m: f64,
    /// Inertia about the pivot (kg·m²); eq. 79's frame: 0.8796 + 5.48·0.37².
    #[arg(long, default_value_t = 1.62982)]
    inertia_about_pivot_kgm2: f64,
    /// Viscous damping ratio ζ (dimensionless).
    #[arg(long, default_value_t = 0.003)]
    damping_ratio: f64,
    /// Dry (Coulomb) friction torque in the pivot (N·m).
    #[arg(long, default_value_t = 0.0)]
    coulomb_nm: f64,
    #[command(flatten)]
    common: SimCommon,
}

#[derive(Args)]
struct SimCommon {
    /// Output: `NAME.log` (its `NAME_cal.log` is written beside it).
    #[arg(long)]
    out: PathBuf,
    /// The release angle (degrees).
    #[arg(long, default_value_t = 8.0)]
    amplitude_deg: f64,
    /// Rest before the hand turns the body (s).
    #[arg(long, default_value_t = 3.0)]
    rest_s: f64,
    /// Time the hand takes to turn the body to the release angle (s).
    #[arg(long, default_value_t = 1.0)]
    ramp_s: f64,
    /// Time the body is held there before the release (s).
    #[arg(long, default_value_t = 1.0)]
    hold_s: f64,
    /// Length of the recording (s).
    #[arg(long, default_value_t = 60.0)]
    duration_s: f64,
    /// The sensor's orientation output: Euler angles, quaternion or rotation matrix.
    #[arg(long, value_enum, default_value_t = ModeArg::Euler)]
    mode: ModeArg,
    /// The acquisition PC's locale: tab-separated with decimal points, or Spanish (`;` and
    /// decimal commas).
    #[arg(long, value_enum, default_value_t = LocaleArg::Tab)]
    locale: LocaleArg,
    /// Digits written: as the sensor's software writes them, or full precision.
    #[arg(long, value_enum, default_value_t = PrecisionArg::Sensor)]
    precision: PrecisionArg,
    /// White noise of the orientation output (deg, per axis).
    #[arg(long, default_value_t = 0.05)]
    noise_deg: f64,
    /// A perfect link: no dropped packets, no corrupt rows, no clock jitter.
    #[arg(long)]
    perfect_link: bool,
    /// The sensor's id in the log's header.
    #[arg(long, default_value = "00300417")]
    sensor_id: String,
    /// The sensor's label in the log's header.
    #[arg(long, default_value = "torsion bar")]
    label: String,
    /// Seed of the random numbers (noise, dropped packets): the same seed, the same file.
    #[arg(long, default_value_t = 1)]
    seed: u64,
}

#[derive(Clone, Copy, ValueEnum)]
enum ModeArg {
    Euler,
    Quaternion,
    Matrix,
}

#[derive(Clone, Copy, ValueEnum)]
enum LocaleArg {
    Tab,
    Spanish,
}

#[derive(Clone, Copy, ValueEnum)]
enum PrecisionArg {
    Sensor,
    Full,
}

#[derive(Args)]
struct ReportArgs {
    /// Where the reports go.
    #[arg(long, default_value = "reports")]
    out: PathBuf,
    /// Where the reference material is (`../shared/reference` of the checkout).
    #[arg(long, default_value = "../shared/reference")]
    reference: PathBuf,
    /// The lab's data (the simulated campaign).
    #[arg(long, default_value = "data")]
    data: PathBuf,
}

/// `--speed`: a riding speed (m/s).
fn parse_speed(s: &str) -> Result<f64, String> {
    let v: f64 = s
        .trim()
        .parse()
        .map_err(|_| format!("`{s}` is not a number"))?;
    bikeproc::ride::speed::check_reading_mps(v)
}

/// A number from 0 to `max`.
fn fraction_or_step(max: f64) -> impl Fn(&str) -> Result<f64, String> + Clone {
    move |s: &str| {
        let v: f64 = s
            .trim()
            .parse()
            .map_err(|_| format!("`{s}` is not a number"))?;
        if v.is_finite() && (0.0..=max).contains(&v) {
            Ok(v)
        } else {
            Err(format!("{v}: expected a number from 0 to {max}"))
        }
    }
}

fn parse_range(s: &str) -> Result<(f64, f64), String> {
    let (a, b) = s.split_once(':').ok_or("expected START:END in seconds")?;
    let a: f64 = a
        .trim()
        .parse()
        .map_err(|_| format!("`{a}` is not a number"))?;
    let b: f64 = b
        .trim()
        .parse()
        .map_err(|_| format!("`{b}` is not a number"))?;
    if b > a {
        Ok((a, b))
    } else {
        Err("END must be after START".into())
    }
}

/// A campaign none of whose rides could be analysed: its input is at fault (exit 2).
#[derive(Debug, thiserror::Error)]
#[error("no ride of {} could be analysed (the reasons are listed above)", .0.display())]
struct NoRideAnalysed(PathBuf);

fn main() -> ExitCode {
    let cli = Cli::parse();
    match run(cli) {
        Ok(()) => ExitCode::SUCCESS,
        Err(e) => {
            eprintln!("error: {e:#}");
            let input = e.chain().any(|c| {
                c.is::<bikeproc::log::LogError>()
                    || c.is::<signal::SignalError>()
                    || c.is::<fit::FitError>()
                    || c.is::<inertia::InertiaError>()
                    || c.is::<inertia::manifest::ManifestError>()
                    || c.is::<inertia::measured::MeasuredError>()
                    || c.is::<bikeproc::model::ParamError>()
                    || c.is::<bikeproc::ride::RideError>()
                    || c.is::<bikeproc::model::control::ControlError>()
                    || c.is::<NoRideAnalysed>()
            });
            ExitCode::from(if input { 2 } else { 1 })
        }
    }
}

fn run(cli: Cli) -> Result<()> {
    match cli.command {
        Command::Period(a) => period(a),
        Command::CalibrateBar(a) => calibrate_bar(a),
        Command::Inertia(a) => inertia_cmd(a),
        Command::Measured(a) => measured(a),
        Command::Stability(a) => stability(a),
        Command::Dynamic(a) => dynamic(a),
        Command::Gap(a) => gap(a),
        Command::Simulate(s) => simulate(s),
        Command::Report(r) => {
            let written = bikeproc::report::regenerate(&r.out, &r.data, &r.reference, &mut |m| {
                eprintln!("{m}")
            })?;
            eprintln!("wrote {} files under {}", written.len(), r.out.display());
            Ok(())
        }
    }
}

fn period(a: PeriodArgs) -> Result<()> {
    let extract = a
        .channel
        .clone()
        .map_or(Extract::DominantRotation, Extract::Channel);
    let options = FitOptions {
        trend: match a.trend {
            TrendArg::Auto => Trend::Auto,
            TrendArg::On => Trend::On,
            TrendArg::Off => Trend::Off,
        },
        segment_s: a.segment,
        min_freq_hz: None,
    };
    let measure = |file: &Path| -> Result<fit::OscillationSummary> {
        let loaded =
            signal::load_signal(file, &extract, a.sensor.as_deref(), &ReadOptions::default())?;
        for w in &loaded.warnings {
            eprintln!("warning: {w}");
        }
        let sig = &loaded.signal;
        let osc = fit::analyse(sig, &options).with_context(|| format!("{}", file.display()))?;
        let mut summary = osc.summary(sig);
        summary.receiver_time_off_rows = loaded.time_off_rows;
        Ok(summary)
    };
    if let [file] = a.files.as_slice() {
        if !file.is_dir() {
            let summary = measure(file)?;
            return emit(a.json, &summary, || summary.to_text(file));
        }
    }
    let files = trial_files(&a.files)?;
    let total = files.len();
    let mut trials = Vec::new();
    let mut failed = Vec::new();
    for (k, file) in files.iter().enumerate() {
        progress_bar("recordings", k + 1, total);
        match measure(file) {
            Ok(s) => trials.push((file.clone(), s)),
            Err(e) => failed.push(format!("{e:#}")),
        }
    }
    let named: Vec<(String, Measured)> = trials
        .iter()
        .map(|(f, s)| {
            let stem = f
                .file_stem()
                .map_or(String::new(), |x| x.to_string_lossy().into_owned());
            (stem, Measured::new(s.period_s, s.period_se_s))
        })
        .collect();
    let setups = fit::group_trials(&named);
    #[derive(serde::Serialize)]
    struct Batch<'a> {
        setups: &'a [fit::SetupPeriods],
        failed: &'a [String],
    }
    emit(
        a.json,
        &Batch {
            setups: &setups,
            failed: &failed,
        },
        || setups_text(&setups),
    )?;
    for f in &failed {
        eprintln!("error: {f}");
    }
    if failed.is_empty() {
        Ok(())
    } else {
        bail!("{} of {total} recordings gave no period", failed.len())
    }
}

/// The recordings named (files, and the `.csv` and `.log` files of folders, `_cal` logs left to
/// their angles log), in name order within each folder.
fn trial_files(paths: &[PathBuf]) -> Result<Vec<PathBuf>> {
    let mut out = Vec::new();
    for p in paths {
        if p.is_dir() {
            let mut inside: Vec<PathBuf> = std::fs::read_dir(p)
                .with_context(|| format!("{}", p.display()))?
                .filter_map(|e| e.ok().map(|e| e.path()))
                .filter(|f| {
                    let ext = f.extension().and_then(|e| e.to_str());
                    let stem = f.file_stem().and_then(|e| e.to_str()).unwrap_or("");
                    matches!(ext, Some("csv") | Some("log")) && !stem.ends_with("_cal")
                })
                .collect();
            inside.sort();
            if inside.is_empty() {
                bail!("{}: no .csv or .log recordings in the folder", p.display());
            }
            out.extend(inside);
        } else {
            out.push(p.clone());
        }
    }
    Ok(out)
}

/// Repeated trials by set-up, as text.
fn setups_text(setups: &[fit::SetupPeriods]) -> String {
    use std::fmt::Write as _;
    let mut out = String::new();
    let _ = writeln!(
        out,
        "{:<28} {:>22} {:>24} {:>9}  trials (damped period T, s; * flagged, left out)",
        "set-up", "mean T (s)", "", "scatter"
    );
    for s in setups {
        let c = &s.combined;
        let trials: Vec<String> = s
            .each_trial()
            .map(|(name, p, flagged)| {
                format!(
                    "{}{name} {:.6} ± {:.6}",
                    if flagged { "*" } else { "" },
                    p.value,
                    p.se
                )
            })
            .collect();
        let _ = writeln!(
            out,
            "{:<28} {:>11.6} ± {:<8.6} {:>24} {:>8.3}%  {}",
            s.setup,
            c.mean.value,
            c.mean.se,
            if c.scatter_dominates {
                "(SE from the scatter)"
            } else {
                "(SE from the fits)"
            },
            100.0 * c.sd / c.plain_mean,
            trials.join(", ")
        );
    }
    out
}

fn calibrate_bar(a: CalibrateArgs) -> Result<()> {
    let cal = inertia::calibrate_bar(&a.dir)?;
    let out = a.dir.join(inertia::CALIBRATION_FILE);
    write_atomic(&out, cal.to_toml().as_bytes())?;
    emit(a.json, &text::calibration_json(&cal), || {
        text::calibration_text(&cal)
    })?;
    eprintln!("wrote {}", out.display());
    Ok(())
}

fn inertia_cmd(a: InertiaArgs) -> Result<()> {
    if let Some(bike_path) = a.bike {
        let mut bike = inertia::bike::LabBike::load(&bike_path)?;
        let dir = bike_path
            .parent()
            .map(Path::to_path_buf)
            .unwrap_or_default();
        let warnings = bike.refresh(&dir)?;
        for w in &warnings {
            eprintln!("warning: {w}");
        }
        write_atomic(&bike_path, bike.to_toml().as_bytes())?;
        emit(a.json, &bike, || bike.to_toml())?;
        eprintln!("refreshed the inertias of {}", bike_path.display());
        return Ok(());
    }
    let dir = a.dir.unwrap_or_default();
    let m = inertia::manifest::Manifest::load(&dir)?;
    match m.kind {
        Kind::Torsion => {
            let r = inertia::torsion(&dir, &a.orientations)?;
            for w in &r.tensor.warnings {
                eprintln!("warning: {w}");
            }
            emit(a.json, &text::torsion_json(&r), || text::torsion_text(&r))?;
        }
        Kind::Compound => {
            let r = inertia::compound(&dir)?;
            emit(a.json, &text::compound_json(&r), || text::compound_text(&r))?;
        }
        Kind::BarCalibration | Kind::EmptyFixture => {
            anyhow::bail!(inertia::InertiaError::Invalid {
                path: dir.join(inertia::manifest::MANIFEST),
                message: "a bar-calibration or empty-fixture folder: use `bikeproc calibrate-bar`"
                    .into()
            })
        }
    }
    Ok(())
}

fn measured(a: MeasuredArgs) -> Result<()> {
    use bikeproc::inertia::measured::MeasuredBicycle;
    let bike = MeasuredBicycle::load(&a.file)?;
    let report = bike.report(10.0, 0.01)?;
    if let Some(out) = &a.out {
        write_atomic(out, bike.to_benchmark_text().as_bytes())?;
        eprintln!("wrote {}", out.display());
    }
    emit(a.json, &report, || inertia::text::measured_text(&report))
}

fn stability(a: StabilityArgs) -> Result<()> {
    use bikeproc::model::{self, uncertain};
    let mut p = uncertain::load(&a.bike)?;
    if a.cg_on_steer_axis {
        let b = p.nominal().with_handlebar_cg_on_steer_axis();
        p = uncertain::Parametrized::from_benchmark(&p.name, &b);
    }
    let p = with_controller(p, a.controller.as_deref())?;
    let (lo, hi, step) = a.speeds;
    let speeds: Vec<f64> = (0..=((hi - lo) / step).round() as usize)
        .map(|i| lo + i as f64 * step)
        .collect();
    let s = p.speeds(hi, step.min(0.01))?;
    let bands = p.bands(&speeds)?;
    let canonical = p.nominal_canonical();
    let report = model::report::StabilityReport::new(&p.name, &s, &bands, &canonical);
    emit(a.json, &report, || report.to_text())
}

/// A progress bar on standard error when it is a terminal: `[####    ] done/total what`.
fn progress_bar(what: &str, done: usize, total: usize) {
    use std::io::IsTerminal;
    if std::io::stderr().is_terminal() {
        let width = 30;
        let filled = done * width / total.max(1);
        eprint!(
            "\r[{}{}] {done}/{total} {what}",
            "#".repeat(filled),
            " ".repeat(width - filled)
        );
        if done == total {
            eprintln!();
        }
    }
}

fn gap(a: GapArgs) -> Result<()> {
    use bikeproc::ride::dynamic::RideManifest;
    let manifest = RideManifest::load(&a.file)?;
    let model = manifest.model(a.bike.as_deref())?;
    let threads = std::thread::available_parallelism().map_or(1, |n| n.get());
    let d = bikeproc::gap::diagnose_campaign(&manifest, &model, threads, &progress_bar)?;
    emit(a.json, &d, || d.to_text())?;
    if d.rides_used == 0 {
        return Err(NoRideAnalysed(a.file.clone()).into());
    }
    Ok(())
}

fn dynamic(a: DynamicArgs) -> Result<()> {
    use bikeproc::ride::dynamic::{self as dynamic, DynamicOptions, RideManifest};
    use bikeproc::ride::modal::ModalOptions;
    let modal = ModalOptions {
        resamples: a.resamples as usize,
        ..ModalOptions::default()
    };
    if a.file
        .extension()
        .is_some_and(|e| e.eq_ignore_ascii_case("csv"))
    {
        return csv_ride(&a, &modal);
    }
    if a.file.extension().is_some_and(|e| e == "toml") {
        let manifest = RideManifest::load(&a.file)?;
        let bike = a.bike.clone().unwrap_or_else(|| manifest.bike_path());
        let model = manifest.model(Some(&bike))?;
        let threads = std::thread::available_parallelism().map_or(1, |n| n.get());
        let results = dynamic::run_campaign(&manifest, &model, &modal, threads, &|done, total| {
            progress_bar("rides", done, total)
        });
        /// A log ride's summary or a CSV ride's decay, as the JSON lists them.
        #[derive(serde::Serialize)]
        #[serde(untagged)]
        enum RideOut {
            Log(Box<dynamic::Summary>),
            Csv(Box<bikeproc::ride::csv::DecaySummary>),
        }
        let mut rides = Vec::new();
        let mut failures = Vec::new();
        for r in &results {
            match &r.result {
                Ok(dynamic::Analysed::Log(t)) => rides.push(RideOut::Log(Box::new(t.summary()))),
                Ok(dynamic::Analysed::Csv(d)) => rides.push(RideOut::Csv(d.clone())),
                Err(e) => failures.push(format!("{}: {e}", r.name)),
            }
        }
        #[derive(serde::Serialize)]
        struct Campaign<'a> {
            bike: String,
            rides: &'a [RideOut],
            failures: &'a [String],
        }
        let out = Campaign {
            bike: bike.display().to_string(),
            rides: &rides,
            failures: &failures,
        };
        emit(a.json, &out, || {
            let mut text: String = rides
                .iter()
                .map(|r| match r {
                    RideOut::Log(s) => s.to_text() + "\n",
                    RideOut::Csv(d) => d.to_text() + "\n",
                })
                .collect();
            for f in &failures {
                text += &format!("not analysed: {f}\n");
            }
            text
        })?;
        if rides.is_empty() {
            return Err(NoRideAnalysed(a.file.clone()).into());
        }
        return Ok(());
    }
    let bike = match &a.bike {
        Some(b) => b.clone(),
        None => bike_beside(&a.file)?,
    };
    let model = load_model(&bike, a.controller.as_deref())?;
    let options = DynamicOptions {
        noted: a.speed.map(|v| bikeproc::ride::speed::NotedReading {
            speed_mps: v,
            resolution_mps: a.speed_resolution,
            se_fraction: a.speed_se_fraction,
        }),
        prefer_sync: false,
        modal,
    };
    let test = dynamic::dynamic_test(&a.file, &model, &options)?;
    let summary = test.summary();
    emit(a.json, &summary, || summary.to_text())
}

/// The bicycle of a ride given without `--bike`: the `lab_bike.toml` beside its log, or the
/// bicycle of the campaign manifest (`rides.toml`) beside it.
fn bike_beside(ride: &Path) -> Result<PathBuf> {
    let dir = ride.parent().unwrap_or(Path::new(""));
    let dir = if dir.as_os_str().is_empty() {
        Path::new(".")
    } else {
        dir
    };
    let lab = dir.join("lab_bike.toml");
    if lab.is_file() {
        return Ok(lab);
    }
    let manifest = dir.join("rides.toml");
    if manifest.is_file() {
        return Ok(bikeproc::ride::dynamic::RideManifest::load(&manifest)?.bike_path());
    }
    Err(bikeproc::model::ParamError::Invalid {
        path: ride.to_path_buf(),
        message: format!(
            "no bicycle to compare with: give --bike (there is no lab_bike.toml or rides.toml in {})",
            dir.display()
        ),
    }
    .into())
}

/// `bikeproc dynamic FILE.csv [--window A:B]`: the free decays of another instrument's ride
/// (one with a window or a short record; every kick of a long recording without).
fn csv_ride(a: &DynamicArgs, modal: &bikeproc::ride::modal::ModalOptions) -> Result<()> {
    use bikeproc::ride::csv;
    let ride = csv::read_csv_ride(&a.file, &a.columns.clone().unwrap_or_default())?;
    let given = a.speed.map(|v| bikeproc::ride::speed::NotedReading {
        speed_mps: v,
        resolution_mps: a.speed_resolution,
        se_fraction: a.speed_se_fraction,
    });
    let model = match &a.bike {
        Some(bike) => Some(load_model(bike, a.controller.as_deref())?),
        None => None,
    };
    let long = a.window.is_none()
        && ride
            .time_s
            .last()
            .zip(ride.time_s.first())
            .is_some_and(|(l, f)| l - f > csv::WHOLE_RECORD_MAX_S);
    let mut decays = csv::ride_decays(&ride, a.window, given, model.as_ref(), modal)?;
    if !long {
        if let Some(summary) = decays.pop().and_then(|k| k.decay) {
            return emit(a.json, &summary, || summary.to_text());
        }
    }
    #[derive(serde::Serialize)]
    struct Kicks<'a> {
        file: String,
        kicks: &'a [csv::KickDecay],
    }
    let out = Kicks {
        file: a.file.display().to_string(),
        kicks: &decays,
    };
    emit(a.json, &out, || {
        let mut text = format!("{}: {} kicks found\n", out.file, decays.len());
        for (k, d) in decays.iter().enumerate() {
            text += &format!(
                "\nkick {} at {:.2} s (roll rate {:+.3} rad/s), free decay {:.2} – {:.2} s\n",
                k + 1,
                d.kick.at_s,
                d.kick.peak_roll_rate_rad_per_s,
                d.kick.window_s.0,
                d.kick.window_s.1
            );
            match (&d.decay, &d.not_fitted) {
                (Some(s), _) => text += &s.to_text(),
                (None, Some(why)) => text += &format!("not fitted: {why}\n"),
                (None, None) => {}
            }
        }
        text
    })
}

/// A bicycle file as a model, with the controller of `controller` (a TOML `[controller]`
/// table) closing the loop when given.
fn load_model(
    bike: &Path,
    controller: Option<&Path>,
) -> Result<bikeproc::model::uncertain::Parametrized> {
    with_controller(bikeproc::model::uncertain::load(bike)?, controller)
}

/// `model` with the steer controller of the file `controller` (a `[controller]` table) closing
/// the loop, named in the model's name.
fn with_controller(
    mut model: bikeproc::model::uncertain::Parametrized,
    controller: Option<&Path>,
) -> Result<bikeproc::model::uncertain::Parametrized> {
    if let Some(c) = controller {
        let (control, description) = bikeproc::model::SteerControl::load(c)?;
        model.name = format!("{} with the controller `{description}`", model.name);
        model = model.with_control(control);
    }
    Ok(model)
}

/// The effects a blind campaign can withhold, by label.
fn withheld_effects() -> clap::builder::PossibleValuesParser {
    clap::builder::PossibleValuesParser::new(sim::campaign::Withheld::ALL.map(|w| w.label()))
}

/// Writes generated files under `out` and says how many.
fn write_generated(out: &Path, files: &sim::campaign::Files) -> Result<()> {
    sim::campaign::write_files(out, files)
        .with_context(|| format!("writing under {}", out.display()))?;
    eprintln!("wrote {} files under {}", files.len(), out.display());
    Ok(())
}

fn simulate(s: SimCommand) -> Result<()> {
    let (p, c) = match s {
        SimCommand::Ride(r) => return simulate_ride(r),
        SimCommand::Rides { out } => {
            let bike = inertia::bike::LabBike::load(&out.join("lab_bike.toml"))?;
            return write_generated(&out, &sim::campaign::lab_rides(&bike)?);
        }
        SimCommand::Blind {
            effect,
            design,
            seed,
            bike,
            out,
        } => {
            let withheld = sim::campaign::Withheld::from_label(&effect)
                .ok_or_else(|| anyhow::anyhow!("unknown effect `{effect}`"))?;
            let design = if design == "noted" {
                sim::campaign::BlindDesign::Noted
            } else {
                sim::campaign::BlindDesign::Sync
            };
            let lab = inertia::bike::LabBike::load(&bike)?;
            let (mut files, _) =
                sim::campaign::blind_campaign(&lab, "bike.toml", withheld, design, seed)?;
            let text = std::fs::read_to_string(&bike)
                .with_context(|| format!("reading {}", bike.display()))?;
            files.push(("bike.toml".into(), text));
            return write_generated(&out, &files);
        }
        SimCommand::RideFaults { out } => {
            let bike = inertia::bike::LabBike::load(Path::new("data/lab_bike.toml"))?;
            return write_generated(&out, &sim::campaign::ride_fault_fixtures(&bike)?);
        }
        SimCommand::Campaign { out } => {
            return write_generated(&out, &sim::campaign::lab_campaign());
        }
        SimCommand::Torsion(t) => (
            pendulum::Pendulum::Torsion(pendulum::Torsion {
                inertia_kgm2: t.inertia_kgm2,
                stiffness_nm_per_rad: t.stiffness_nm_per_rad,
                damping_ratio: t.damping_ratio,
                coulomb_nm: t.coulomb_nm,
                swing: t.swing_freq_hz.map(|f| pendulum::Swing {
                    freq_hz: f,
                    damping_ratio: t.swing_damping_ratio,
                    coupling: t.swing_coupling,
                    release_amplitude_deg: t.swing_amplitude_deg,
                }),
            }),
            t.common,
        ),
        SimCommand::Compound(k) => (
            pendulum::Pendulum::Compound(pendulum::Compound {
                mass_kg: k.mass_kg,
                pivot_to_cg_m: k.pivot_to_cg_m,
                inertia_about_pivot_kgm2: k.inertia_about_pivot_kgm2,
                damping_ratio: k.damping_ratio,
                coulomb_nm: k.coulomb_nm,
            }),
            k.common,
        ),
    };
    let release = pendulum::Release {
        rest_s: c.rest_s,
        ramp_s: c.ramp_s,
        hold_s: c.hold_s,
        amplitude_deg: c.amplitude_deg,
        duration_s: c.duration_s,
    };
    let mut rng = sim::rng::Rng::new(c.seed ^ 0x5EED);
    let mut sensor = imu::SensorModel::typical(&mut rng);
    sensor.orientation_noise_rad = c.noise_deg.to_radians();
    let placement = pendulum::Placement {
        body_rest: rng.rotation(),
        axis_heading_rad: rng.range(0.0, std::f64::consts::TAU),
        sensor_offset_m: nalgebra::Vector3::new(0.3, 0.05, 0.02),
    };
    let link = if c.perfect_link {
        imu::LinkModel::perfect()
    } else {
        imu::LinkModel::default()
    };
    let spec = imu::FileSpec {
        mode: match c.mode {
            ModeArg::Euler => OutputMode::Euler,
            ModeArg::Quaternion => OutputMode::Quaternion,
            ModeArg::Matrix => OutputMode::Matrix,
        },
        locale: match c.locale {
            LocaleArg::Tab => imu::Locale::Tab,
            LocaleArg::Spanish => imu::Locale::Spanish,
        },
        precision: match c.precision {
            PrecisionArg::Sensor => imu::Precision::Sensor,
            PrecisionArg::Full => imu::Precision::Full,
        },
        rate_hz: 100.0,
        sensors: vec![(c.sensor_id.clone(), c.label.clone())],
        first_counter: (c.seed.wrapping_mul(2654435761) % 65_536) as u16,
        start: "2009-03-12 11:42:07".into(),
        extra_header: vec![],
        declare_decimal: true,
        jitter_s: if c.perfect_link { 0.0 } else { 0.0005 },
        late_bursts_per_minute: 0.0,
    };
    let rec = sim::simulate_pendulum(&p, &release, &placement, &sensor, &link, &spec, c.seed);
    let cal = bikeproc::log::Log::cal_path(&c.out);
    write_atomic(&c.out, rec.angles_log.as_bytes())?;
    write_atomic(&cal, rec.cal_log.as_bytes())?;
    out(&(serde_json::to_string_pretty(&rec.truth)? + "\n"))?;
    eprintln!("wrote {} and {}", c.out.display(), cal.display());
    Ok(())
}

fn simulate_ride(r: RideArgs) -> Result<()> {
    use bikeproc::sim::ride;
    let bike = bikeproc::model::uncertain::load(&r.bike)?.nominal();
    let effects = match r.effects.as_str() {
        "none" => ride::Effects::default(),
        "realistic" => ride::Effects::realistic(),
        file => {
            let text =
                std::fs::read_to_string(file).with_context(|| format!("reading effects {file}"))?;
            toml::from_str(&text).map_err(|e| anyhow::anyhow!("{file}: {}", e.message()))?
        }
    };
    let mut spec = ride::RideSpec::lab(r.speed, effects);
    spec.sync = r.sync;
    spec.mode = match r.mode {
        ModeArg::Euler => OutputMode::Euler,
        ModeArg::Quaternion => OutputMode::Quaternion,
        ModeArg::Matrix => OutputMode::Matrix,
    };
    spec.locale = match r.locale {
        LocaleArg::Tab => imu::Locale::Tab,
        LocaleArg::Spanish => imu::Locale::Spanish,
    };
    let ride = ride::simulate_ride(&bike, &spec, r.seed)?;
    let truth = r.truth.clone().unwrap_or_else(|| {
        let stem = r
            .out
            .file_stem()
            .map(|s| s.to_string_lossy().into_owned())
            .unwrap_or_default();
        r.out.with_file_name("truth").join(format!("{stem}.json"))
    });
    write_atomic(&r.out, ride.angles_log.as_bytes())?;
    write_atomic(
        &bikeproc::log::Log::cal_path(&r.out),
        ride.cal_log.as_bytes(),
    )?;
    write_atomic(&truth, serde_json::to_string(&ride.truth)?.as_bytes())?;
    eprintln!(
        "wrote {} (release {:.2} s, kick {:.2} s, catch {:.2} s; speedometer {:.2} m/s) and the truth {}",
        r.out.display(),
        ride.truth.release_s,
        ride.truth.kick_s,
        ride.truth.catch_s,
        ride.truth.noted_speed_mps,
        truth.display()
    );
    Ok(())
}

/// Writes through a temporary file and a rename: a reader never sees half a file.
fn write_atomic(path: &Path, bytes: &[u8]) -> Result<()> {
    Ok(bikeproc::output::write_atomic(path, bytes)?)
}

/// Prints JSON (`--json`) or the plain text.
fn emit<T: serde::Serialize>(json: bool, value: &T, text: impl FnOnce() -> String) -> Result<()> {
    if json {
        out(&(serde_json::to_string_pretty(value)? + "\n"))
    } else {
        out(&text())
    }
}

/// Writes to standard output: a reader that has gone (`bikeproc … | head`) or a full disk is
/// an error (exit 1) naming standard output, never a panic.
fn out(text: &str) -> Result<()> {
    use std::io::Write as _;
    let mut stdout = std::io::stdout().lock();
    stdout
        .write_all(text.as_bytes())
        .and_then(|()| stdout.flush())
        .map_err(|e| match e.kind() {
            std::io::ErrorKind::BrokenPipe => {
                anyhow::anyhow!(
                    "standard output: its reader has gone (broken pipe); output cut short"
                )
            }
            _ => anyhow::anyhow!("standard output: {e}"),
        })
}
