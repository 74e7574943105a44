//! The command line's arguments (clap): every command, its options with their units, its help
//! with examples and the shape of its `--json`.

use bikeproc::fit::Trend;
use bikeproc::read::log::OutputMode;
use bikeproc::sim::imu::{Locale, Precision};
use bikeproc::stats::number_text;
use clap::{Args, Parser, Subcommand, ValueEnum};
use std::path::PathBuf;

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
pub struct Cli {
    #[command(subcommand)]
    pub command: Command,
}

#[derive(Subcommand)]
pub enum Command {
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
        "\"weave_second\", \"capsize\", \"castor\", \"all\": [{\"re\", \"im\"} ×4], ",
        "\"weave_steer_over_roll\", \"weave_steer_phase_deg\"}, …]} (eigenvalues in 1/s). ",
        "Every speed carries all four eigenvalues (`all`); the named ones are the weave's two (a ",
        "complex pair, or below the merge speed two real roots), capsize and castor (at low speed ",
        "possibly one complex pair).\n\n",
        "Exit codes: 0 done; 2 the bicycle file is malformed or gives no dynamics; 1 anything else."
    ))]
    Stability(StabilityArgs),
    /// How the weave and capsize speeds move with each benchmark parameter (the model's own
    /// derivatives), and each parameter's share of their uncertainty.
    #[command(after_help = concat!(
        "Examples:\n",
        "  bikeproc sensitivity --bike data/lab_bike.toml\n",
        "  bikeproc sensitivity --bike RigidBenchmark.txt --rider JasonRigidBenchmark.txt\n",
        "  bikeproc sensitivity --bike BenchmarkBenchmark.txt --speeds 4,5,6 --json\n\n",
        "Derivatives: the implicit function of the critical eigenvalue (Re λ(v, p) = 0, so ",
        "dv/dp = −(∂Re λ/∂p)/(∂Re λ/∂v)), the eigenvalue's by first-order perturbation theory, ",
        "the canonical matrices' by jets (automatic differentiation) through Meijaard et al. ",
        "2007's (A 1)–(A 27). Elasticity: (p/v) dv/dp. Variance share: g_k (C g)_k / gᵀCg, C the parameters' ",
        "covariance from the file's standard errors (propagated from the measurements for a lab ",
        "bicycle), g the gradient; the shares add up to 1.\n\n",
        "JSON (--json): {\"bike\", \"weave_speed_mps\": {\"value\", \"se\"}, ",
        "\"capsize_speed_mps\": {\"value\", \"se\"}, \"parameters\": {\"IBxx\": {\"name\", ",
        "\"unit\", \"value\", \"se\", \"d_weave_speed\", \"d_capsize_speed\", ",
        "\"weave_elasticity\", \"capsize_elasticity\", \"weave_variance_share\", ",
        "\"capsize_variance_share\"}, … all 26}, \"inputs\": [{\"input\", \"value\", \"se\", ",
        "\"weave_variance_share\", \"capsize_variance_share\"}], \"measurements\": ",
        "[{\"measurement\", \"weave_variance_share\", \"capsize_variance_share\", ",
        "\"repeats_to_halve_weave_se\"}], \"weave_derivatives\": [{\"speed_mps\", \"re\", ",
        "\"im\", \"d_re\": {\"IBxx\", …}, \"d_im\"}]} (derivatives in m/s, or 1/s, per the ",
        "parameter's unit).\n\n",
        "Exit codes: 0 done; 2 the bicycle or rider file is malformed or gives no dynamics; 1 ",
        "anything else."
    ))]
    Sensitivity(SensitivityArgs),
    /// Several bicycles side by side: weave and capsize speeds with standard errors, each
    /// against the first, and their continuation diagrams overlaid (--svg).
    #[command(after_help = concat!(
        "Examples:\n",
        "  bikeproc compare ../shared/reference/bicycleparameters/BenchmarkBenchmark.txt data/lab_bike.toml --svg both.svg\n",
        "  bikeproc compare RigidBenchmark.txt BrowserBenchmark.txt --rider JasonRigidBenchmark.txt\n\n",
        "A difference's standard error combines the two bicycles' in quadrature (measured ",
        "apart). The figure: real parts solid, imaginary parts dashed, ±2 SE thin, stable ",
        "ranges shaded, and under it a detail of the real parts near zero (seed Figs. 16–17).\n\n",
        "JSON (--json): {\"max_speed_mps\", \"bikes\": [{\"bike\", \"stable_ranges_mps\", ",
        "\"weave_speed_mps\": {\"value\", \"se\"}, \"capsize_speed_mps\", ",
        "\"weave_speed_difference_mps\": {\"value\", \"se\", \"z\"}, ",
        "\"capsize_speed_difference_mps\"}]} (m/s; the first bicycle's differences null).\n\n",
        "Exit codes: 0 done; 2 a bicycle or rider file is malformed or gives no dynamics; 1 ",
        "anything else."
    ))]
    Compare(CompareArgs),
    /// The smallest relative change of chosen parameters that makes a bicycle stable over a
    /// range of speeds, written as a bicycle file that `stability` reads.
    #[command(after_help = concat!(
        "Examples:\n",
        "  bikeproc design --bike data/lab_bike.toml --stable 2.5:5 --vary trail,head_angle --out lab_2.5.txt\n",
        "  bikeproc stability --bike lab_2.5.txt\n",
        "  bikeproc design --bike RigidBenchmark.txt --rider JasonRigidBenchmark.txt --stable 4:8 --vary trail,IFyy\n\n",
        "Variables: head_angle (the steer axis tilt λ, the fork kept: the trail follows, ",
        "c = (r_F sin λ − d)/cos λ), trail (another fork at the same head angle), wheelbase ",
        "(the front frame moving with the front wheel), or any benchmark parameter by its name ",
        "(mB, xB, IFyy, …). The change minimized is ‖x‖₂ of the relative changes, each within ",
        "±--max-change; the constraints (weave speed ≤ A, capsize speed ≥ B) are linearized with ",
        "the model's own derivatives, step by step. The file written is BicycleParameters text ",
        "(a rider already joined into the rear frame), with the original standard errors.\n\n",
        "JSON (--json): {\"bike\", \"target_mps\", \"reached\", \"reason\", \"changes\": ",
        "[{\"variable\", \"parameter\", \"from\", \"to\", \"relative\", \"at_bound\"}], ",
        "\"relative_change_norm\", \"before_stable_ranges_mps\", \"after_stable_ranges_mps\", ",
        "\"before_weave_speed_mps\", \"after_weave_speed_mps\", …}.\n\n",
        "Exit codes: 0 reached (the file written); 3 not reachable (the reason said; the closest ",
        "design written with --out); 2 a malformed input; 1 anything else."
    ))]
    Design(DesignArgs),
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
        "  bikeproc gap fixtures/real/balanceassist_gain6.toml\n",
        "  bikeproc gap fixtures/real/balanceassist_uncontrolled.toml fixtures/real/balanceassist_gain6.toml\n",
        "  bikeproc gap fixtures/real/balanceassist_study.toml\n\n",
        "A study: several campaign manifests of one bicycle (or a study manifest, `version = 1` ",
        "and `conditions = [\"a.toml\", …]` beside it), each a condition named by its file's ",
        "stem. The bicycle's effects are shared; a condition's own equipment (the actuator's ",
        "gain per controller, the speedometer's scale, the clock) is fitted per condition (a ",
        "condition none of whose rides gave an eigenvalue is left out, listed, and the verdict ",
        "says so); a ",
        "known change is written in the condition's manifest (its `[controller]`, and ",
        "`[[known_mass]]` tables: `frame = \"rear\"` or `\"front\"`, `mass_kg`, `x_m`, `z_m` in ",
        "the benchmark's axes). The ranking rests on each condition predicted from the others ",
        "(`heldout_rms_by_condition`: its rides whitened together, the measured parameters' ",
        "error moving them alike counted once); JSON adds `conditions` and, per candidate, ",
        "`params_by_condition` and `params_se_by_condition`. Repeated kicks at one set speed ",
        "carry the scatter between them (`between_kick_scatter`).\n\n",
        "The manifest (rides.toml, data/rides.toml for an example): `version = 1`, `bike = ",
        "\"lab_bike.toml\"` (the bicycle, beside it), optionally a `[controller]` table, then one ",
        "`[[ride]]` per ride: `log = \"ride_01.log\"` (the angles log, its `_cal` file beside it, ",
        "or a CSV with `columns = \"roll_rate=gyro_x,time=time\"`) and its speed: an IMU log's ",
        "`noted_speed_mps` (the speedometer's reading at the release, m/s); a CSV's wheel-speed ",
        "column where it has one, else `set_speed_mps` (the speed the lab set, a treadmill's) or ",
        "`noted_speed_mps` (a speed given beside a wheel column is shown beside the wheel's). The ",
        "controller may be a file: `controller = \"gains.toml\"` before the first table. A ",
        "geared steer motor may be declared, `[steer_motor]` with `rotor_inertia_kg_m2` and ",
        "`gear_ratio`: steer_inertia is then plausible at 0.8–2 times the rotor's inertia times ",
        "the ratio squared. Format: docs/formats/rides-manifest.md.\n\n",
        "Reading the ranking: `before` and `after` are the rides left out one at a time, predicted ",
        "without and with the candidate, as the RMS of their residuals in their standard errors ",
        "(about 1 when the model holds; an explanation brings `after` near 1); `plausible` says ",
        "that every parameter lies where a real bicycle's can (a fit outside is shown, marked ",
        "`no`); `prior` is what the values outside their plausible ranges cost in the order, ",
        "in χ² (0 inside; d²/(s² + SE²) at a distance d outside, s a quarter of the range's ",
        "width).\n\n",
        "JSON (--json): {\"significant\", \"explained\", \"chi2\", \"dof\", \"p_value\", ",
        "\"residuals\", \"ranking\": [{\"effect\", \"params\", \"params_se\", ",
        "\"heldout_rms_before\", \"heldout_rms_after\", \"plausible\", \"prior_penalty\", \"at_bound\", ",
        "\"not_needed\"}, …], \"detection_limits\", \"instrument\": [{\"condition\", ",
        "\"log_ratio\", \"phase_rad\", \"chi2\", \"misses\", \"convention\"}, …], \"verdict\"}.\n\n",
        "The instrument first: each condition's mode shape is checked against the model and ",
        "the candidates; where it misses every one by a common factor (|γ/θ| × k, arg + φ; χ² ",
        "over 27.6 on 2 degrees of freedom) it is recorded otherwise than the model assumes (the ",
        "steer's sign reversed, degrees read as radians, a controller's model), the condition is ",
        "diagnosed on its eigenvalue alone, and the verdict's `Instrument:` line says which.\n\n",
        "Ranking: candidates with no parameter at its search's bound first (in a study, candidates whose parameters of the ",
        "bicycle are all inside their search's range first: one where its search stopped at ",
        "an edge (`at_edge`) or within its standard error of one (`at_bound`) is a bound, and ",
        "ranks below; a condition's own equipment, as a gain its few rides barely tell, keeps ",
        "its place; a best fit outside its plausible range is shown and flagged in words), then by the ",
        "BIC of the fit to every ride plus the plausibility prior's penalty (in a study, by the held-out RMS normalized residual of its ",
        "conditions left out, those tied with the first by the BIC). Pairs are tried only when no single effect brings the held-out RMS ",
        "within 2: in a campaign every pair of the library (171; 253 with a controller), in a study the pairs a screen ",
        "chooses (the best single with every other effect, the next three among themselves, the ",
        "single of lowest χ² with every other, then each effect of the best pair with every ",
        "other; `--every-pair` for all of them), and where no pair ",
        "passes either, three effects: the best pair, the next three pairs (held out) and the pair ",
        "of lowest χ², each with every other effect (`--every-triple`: every three of the library). ",
        "A pair is kept only ",
        "when it beats the ",
        "best single on the rides left out by 6.63 in χ² and by the BIC (in a study, also where ",
        "it lowers the χ² of every ride significantly below each candidate one effect smaller ",
        "that it holds, Bonferroni over the effects that could extend it), and named ahead of the ",
        "single only when the tie test tells the two apart (the held-out χ² difference beyond ",
        "2 and beyond 2 of its standard deviations); otherwise it is listed after it, not needed. ",
        "A parameter within its standard error of its search's edge is shown as a bound, never as ",
        "plausible. With no significant gap the verdict gives, per candidate, the smallest size ",
        "these rides would have detected (80 % power).\n\n",
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
pub struct PeriodArgs {
    /// A `NAME.log` / `NAME_cal.log` file, or a CSV `time_s,value`; several files or a folder
    /// of them for repeated trials (`…1`, `…2`, … of one set-up are combined: mean, scatter,
    /// flagged trials).
    #[arg(required = true)]
    pub files: Vec<PathBuf>,
    /// Fit this column instead of the rotation about the dominant axis (e.g. Gyr_Z: read from
    /// the `_cal` file when the angles file does not have it).
    #[arg(long)]
    pub channel: Option<String>,
    /// Which sensor, by id or label, when the log has several.
    #[arg(long)]
    pub sensor: Option<String>,
    /// Linear trend beside the offset (gyro bias, heading drift).
    #[arg(long, value_enum, default_value_t = TrendArg::Auto)]
    pub trend: TrendArg,
    /// Fit this time range instead of finding the free decay, seconds `START:END`.
    #[arg(long, value_parser = parse_range, allow_hyphen_values = true)]
    pub segment: Option<(f64, f64)>,
    /// Print JSON instead of text (its shape: below).
    #[arg(long)]
    pub json: bool,
}

#[derive(Args)]
pub struct DynamicArgs {
    /// A ride's angles log (`ride_03.log`), a campaign manifest (`rides.toml`), or a CSV of
    /// time series from another instrument (`time_s`, `roll_rad`, `steer_deg`,
    /// `rear_wheel_speed_m_per_s`, …; --window picks one decay).
    pub file: PathBuf,
    /// A CSV ride: the free decay to fit, seconds `START:END`; the file is read up to END only
    /// (without it a record of up to 10 s is one free decay; in a longer one every kick is found
    /// and each decay fitted, the recording read twice in 9 bytes a row, not held whole).
    #[arg(long, value_parser = parse_range, allow_hyphen_values = true)]
    pub window: Option<(f64, f64)>,
    /// A CSV ride: columns by other names, `roll=ROLL_COL,steer=…,time=…,wheel_speed=…`
    /// (quantities: time, roll, roll_rate, steer, steer_rate, wheel_speed). A unit may follow
    /// a name after a colon (`roll=lean_angle:deg`; rad or deg, rad_per_s or deg_per_s,
    /// m_per_s or km_per_h, s or ms); without one a name ending in `_deg` is read as degrees,
    /// any other as SI. Recognised without it: time_s, time, t; roll_*, lean_*,
    /// lean_angle_*; steer_*, steer_angle_*, fork_*, handlebar_*; roll_rate_*, lean_rate_*;
    /// steer_rate_*, fork_rate_*; rear_wheel_speed_*, wheel_speed_*, speed_* (each `_rad` or
    /// `_deg`, `_rad_per_s` or `_deg_per_s`, `_m_per_s` or `_km_per_h`).
    #[arg(long)]
    pub columns: Option<bikeproc::ride::csv::Columns>,
    /// A table without a time column (a microcontroller's line per control step, whatever the
    /// file's extension): its sampling rate (Hz); row k is at k / RATE s.
    #[arg(long, value_parser = parse_rate)]
    pub rate: Option<f64>,
    /// The speedometer's reading at the release (m/s), as noted: carried to where the
    /// eigenvalue applies by the slowing the frame sensor measures. Without it the log's `Sync`
    /// pulses give the speed, or else the yaw rate against the steer (rolling kinematics).
    /// Campaigns use the readings of their manifest where a log has no `Sync`.
    #[arg(long, value_parser = parse_speed, allow_hyphen_values = true)]
    pub speed: Option<f64>,
    /// A CSV ride's set speed (m/s): the speed the lab set, a treadmill's, with the display
    /// step and error of `--speed-resolution` and `--speed-se-fraction`. The wheel-speed
    /// column's speed is used where the file has one, the set speed shown beside it.
    #[arg(
        long,
        value_parser = parse_speed,
        allow_hyphen_values = true,
        conflicts_with = "speed"
    )]
    pub set_speed: Option<f64>,
    /// The speedometer's display step (m/s): a reading is uniform within ± half of it.
    #[arg(long, default_value_t = 0.1, value_parser = within(0.0, false, 2.0))]
    pub speed_resolution: f64,
    /// The speedometer's random error per reading, as a fraction of the reading.
    #[arg(long, default_value_t = 0.01, value_parser = within(0.0, false, 0.5))]
    pub speed_se_fraction: f64,
    /// The bicycle (lab TOML or BicycleParameters file); campaigns default to their manifest's.
    #[arg(long)]
    pub bike: Option<PathBuf>,
    /// A steer controller in the model (a TOML file with a `[controller]` table: gains on
    /// roll, steer and their rates against speed); campaigns take their manifest's.
    #[arg(long)]
    pub controller: Option<PathBuf>,
    /// Bootstrap resamples for the check of the standard errors (20 to 100,000).
    #[arg(long, default_value_t = 400, value_parser = clap::value_parser!(u32).range(20..=100_000))]
    pub resamples: u32,
    /// Print JSON instead of text (its shape: below).
    #[arg(long)]
    pub json: bool,
}

#[derive(Args)]
pub struct GapArgs {
    /// A campaign manifest (`rides.toml`); or several, one per condition of one bicycle (a
    /// study); or a study manifest listing them.
    #[arg(required = true, num_args = 1..)]
    pub files: Vec<PathBuf>,
    /// The bicycle (lab TOML or BicycleParameters file); defaults to the manifest's.
    #[arg(long)]
    pub bike: Option<PathBuf>,
    /// Print JSON instead of text (its shape: below).
    #[arg(long)]
    pub json: bool,
    /// In a study, fit every pair of effects (253 with a controller, 171 without) where no
    /// single one closes the gap, not the screen's 20–40 (a single campaign always fits every
    /// pair): about twice the time. The screen's first five were the exhaustive search's on
    /// every study it was checked on.
    #[arg(long)]
    pub every_pair: bool,
    /// In a study, fit every pair and, where no pair closes the gap, every three effects of
    /// the library (1,771 with a controller, each from its pairs' fits), not the screen's 62:
    /// minutes where the screen takes seconds. On the balance-assist study it finds a first
    /// the screen misses.
    #[arg(long)]
    pub every_triple: bool,
}

#[derive(Args)]
pub struct CalibrateArgs {
    /// The bar-calibration folder (its manifest.toml and logs).
    #[arg(default_value = "data/bar_calibration")]
    pub dir: PathBuf,
    /// Print JSON instead of text (its shape: below).
    #[arg(long)]
    pub json: bool,
}

#[derive(Args)]
pub struct MeasuredArgs {
    /// A BicycleParameters `NameMeasured.txt`.
    pub file: PathBuf,
    /// Print JSON: `{"name", "parameters": {"IBxx": {"value", "se"}, …}, …}`.
    /// Print JSON instead of text (its shape: below).
    #[arg(long)]
    pub json: bool,
    /// Also write the parameters, with their standard errors, in the format the name says
    /// (which `bikeproc stability --bike` reads): benchmark TOML for `*.toml`, else
    /// BicycleParameters' `*Benchmark.txt` text; never over the raw file read, never a name
    /// ending in `Measured.txt`.
    #[arg(long)]
    pub out: Option<PathBuf>,
}

#[derive(Args)]
pub struct InertiaArgs {
    /// A test folder (manifest.toml and its logs).
    #[arg(required_unless_present = "bike")]
    pub dir: Option<PathBuf>,
    /// The tensor from these orientations only, e.g. 1,2,4.
    #[arg(long, value_delimiter = ',')]
    pub orientations: Vec<String>,
    /// Refresh the inertias of this bicycle file from the test folders it names.
    #[arg(long, conflicts_with = "dir")]
    pub bike: Option<PathBuf>,
    /// Print JSON instead of text (its shape: below).
    #[arg(long)]
    pub json: bool,
}

#[derive(Args)]
pub struct StabilityArgs {
    /// A bicycle: BicycleParameters text (`*Benchmark.txt`), benchmark TOML, or a lab bicycle
    /// (`data/lab_bike.toml`).
    #[arg(long)]
    pub bike: PathBuf,
    /// Speeds `START:END:STEP` in m/s.
    #[arg(long, default_value = "0:10:0.01", value_parser = parse_speeds, allow_hyphen_values = true)]
    pub speeds: (f64, f64, f64),
    /// Move the handlebar's centre of gravity onto the steer axis (the lab's model, seed §6.2).
    #[arg(long)]
    pub cg_on_steer_axis: bool,
    /// A steer controller closing the loop (a TOML file with a `[controller]` table).
    #[arg(long)]
    pub controller: Option<PathBuf>,
    /// A rider joining the rear frame (BicycleParameters' benchmark form of a rider, as
    /// `JasonRigidBenchmark.txt`: mB, xB, zB, IBxx, IByy, IBzz, IBxz).
    #[arg(long)]
    pub rider: Option<PathBuf>,
    /// Print JSON instead of text (its shape: below).
    #[arg(long)]
    pub json: bool,
}

#[derive(Args)]
pub struct SensitivityArgs {
    /// A bicycle: BicycleParameters text (`*Benchmark.txt`), benchmark TOML, or a lab bicycle
    /// (`data/lab_bike.toml`).
    #[arg(long)]
    pub bike: PathBuf,
    /// A rider joining the rear frame (BicycleParameters' benchmark form of a rider).
    #[arg(long)]
    pub rider: Option<PathBuf>,
    /// Speeds (m/s, comma-separated, each above the weave's merge speed) at which to give the
    /// weave eigenvalue's derivatives by every parameter.
    #[arg(long, value_delimiter = ',', value_parser = within(0.0, true, 100.0))]
    pub speeds: Vec<f64>,
    /// The characteristic speeds are searched in 0 to this speed (m/s).
    #[arg(long, default_value_t = 10.0, value_parser = within(0.0, true, 100.0))]
    pub max_speed: f64,
    /// Print JSON instead of text (its shape: below).
    #[arg(long)]
    pub json: bool,
}

#[derive(Args)]
pub struct CompareArgs {
    /// Bicycles: BicycleParameters text (`*Benchmark.txt`, `*Measured.txt`), benchmark TOML,
    /// or lab bicycles (`data/lab_bike.toml`); the first is the reference.
    #[arg(required = true, num_args = 1..)]
    pub bikes: Vec<PathBuf>,
    /// A rider joining every bicycle's rear frame (BicycleParameters' benchmark form of a rider).
    #[arg(long)]
    pub rider: Option<PathBuf>,
    /// Speeds searched: 0 to this (m/s).
    #[arg(long, default_value_t = 10.0, value_parser = within(0.0, true, 100.0))]
    pub max_speed: f64,
    /// Write the overlaid continuation diagrams to this SVG file.
    #[arg(long)]
    pub svg: Option<PathBuf>,
    /// Print JSON instead of text (its shape: below).
    #[arg(long)]
    pub json: bool,
}

#[derive(Args)]
pub struct DesignArgs {
    /// A bicycle: BicycleParameters text (`*Benchmark.txt`, `*Measured.txt`), benchmark TOML,
    /// or a lab bicycle (`data/lab_bike.toml`).
    #[arg(long)]
    pub bike: PathBuf,
    /// A rider joining the rear frame (BicycleParameters' benchmark form of a rider).
    #[arg(long)]
    pub rider: Option<PathBuf>,
    /// The speeds `A:B` (m/s) over which the bicycle is to be stable.
    #[arg(long, value_parser = parse_speed_range, allow_hyphen_values = true)]
    pub stable: (f64, f64),
    /// What may change, comma-separated: head_angle, trail, wheelbase, or benchmark
    /// parameters by name.
    #[arg(long, value_delimiter = ',', required = true)]
    pub vary: Vec<String>,
    /// The largest relative change of any variable (0.5: ±50 %).
    #[arg(long, default_value_t = 0.5, value_parser = within(0.0, true, 0.95))]
    pub max_change: f64,
    /// Write the changed bicycle here, in the format the name says (which `stability`
    /// reads): benchmark TOML for `*.toml`, else BicycleParameters text; never over an input.
    #[arg(long)]
    pub out: Option<PathBuf>,
    /// Print JSON instead of text (its shape: below).
    #[arg(long)]
    pub json: bool,
}

/// `A:B` in m/s, 0 < A < B ≤ 100.
fn parse_speed_range(s: &str) -> Result<(f64, f64), ArgError> {
    let (a, b) = s
        .split_once(':')
        .ok_or_else(|| format!("`{s}`: expected A:B (m/s)"))?;
    let speed = within(0.0, true, 100.0);
    let (a, b) = (speed(a)?, speed(b)?);
    if a < b {
        Ok((a, b))
    } else {
        Err(format!("`{s}`: A below B (m/s)").into())
    }
}

pub fn parse_speeds(s: &str) -> Result<(f64, f64, f64), ArgError> {
    let parts: Vec<f64> = s
        .split(':')
        .map(|p| {
            p.trim()
                .parse::<f64>()
                .map_err(|_| format!("`{p}` is not a number"))
        })
        .collect::<Result<_, _>>()?;
    match parts[..] {
        [a, b, st] if bikeproc::model::report::valid_speed_grid((a, b, st)) => Ok((a, b, st)),
        _ => Err(bikeproc::model::report::SPEED_GRID_RULE.into()),
    }
}

#[derive(Clone, Copy, ValueEnum)]
pub enum TrendArg {
    Auto,
    On,
    Off,
}

#[derive(Subcommand)]
pub enum SimCommand {
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
        /// speedometer's reading at the release rounded to 0.1 m/s, no reed switch; `varied`:
        /// as `noted`, 12–16 rides from 2.9–3.6 up to 5.8–6.5 m/s, each campaign its own plan.
        #[arg(long, default_value = "sync", value_parser = blind_designs())]
        design: String,
        /// `suite`: the effect at a size the campaign sees (the test suite's); `broad`: the
        /// sizes a lab meets, down to the detection limit, on a true bicycle off from the
        /// measured one by its measurement errors (the calibration's).
        #[arg(long, default_value = "suite", value_parser = ["suite", "broad"])]
        draws: String,
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
    /// A blind study for `bikeproc gap`: the measured bicycle with a steer motor whose
    /// reflected inertia and delivered gain are withheld, ridden unpowered and at three
    /// controller gains (a campaign each, listed in OUT/study.toml), the truth sealed in
    /// OUT/truth.json.
    #[command(after_help = "Example:
  bikeproc simulate blind-study --seed 3 --out /tmp/study
  bikeproc gap /tmp/study/study.toml")]
    BlindStudy {
        /// Seed of the random numbers: the same seed, the same study.
        #[arg(long, default_value_t = 1)]
        seed: u64,
        /// An effect-free study: the motor's rotor weightless, its torque as commanded (the
        /// control the diagnosis must stay quiet on).
        #[arg(long)]
        effect_free: bool,
        /// The speed the controller's firmware senses over the rear wheel's (1: true; the
        /// calibration's studies of it draw 0.85–0.97 or 1.03–1.15).
        #[arg(long, default_value_t = 1.0, value_parser = within(0.5, false, 2.0))]
        controller_speed_scale: f64,
        /// The lag (s) between the motor's command and its torque (0: none; the calibration's
        /// studies of it draw 0.01–0.08).
        #[arg(long, default_value_t = 0.0, value_parser = within(0.0, false, 0.5))]
        actuator_lag_s: f64,
        /// The measured bicycle (copied beside the rides as bike.toml).
        #[arg(long, default_value = "data/lab_bike.toml")]
        bike: PathBuf,
        /// Folder to write into.
        #[arg(long)]
        out: PathBuf,
    },
    /// The joint diagnosis of studies calibrated: blind studies (a steer motor withheld) and
    /// effect-free ones, diagnosed together and one condition at a time; writes the tallies
    /// (named, the values' coverage, the effect-free p-values) as Markdown.
    #[command(
        name = "study-calibration",
        after_help = "Example (docs/study-calibration.md, about 21 min on 2 cores):\n  bikeproc simulate study-calibration --studies 50 --near-nominal 20 --controls 50 --controller-speed 20 --actuator-lag 20 --out docs/study-calibration.md"
    )]
    StudyCalibration {
        /// Blind studies (seeds 1 to N).
        #[arg(long, default_value_t = 50)]
        studies: u64,
        /// Studies whose motor delivers within 5 % of the commanded torque (seeds 2001
        /// onwards): the rotor alone is the answer.
        #[arg(long, default_value_t = 20)]
        near_nominal: u64,
        /// Effect-free studies (seeds 1001 onwards).
        #[arg(long, default_value_t = 50)]
        controls: u64,
        /// Studies whose controller senses its speed off by a factor, nothing else withheld
        /// (seeds 3001 onwards).
        #[arg(long, default_value_t = 20)]
        controller_speed: u64,
        /// Studies whose motor's torque lags its command, nothing else withheld (seeds 4001
        /// onwards).
        #[arg(long, default_value_t = 20)]
        actuator_lag: u64,
        /// The measured bicycle.
        #[arg(long, default_value = "data/lab_bike.toml")]
        bike: PathBuf,
        /// The Markdown to write (every study's result beside it, `NAME.json`).
        #[arg(long)]
        out: PathBuf,
        /// Render the Markdown from this JSON of every study's result (a run's own, made by
        /// the same options) instead of running the studies again.
        #[arg(long)]
        results: Option<PathBuf>,
    },
    /// The gap diagnosis calibrated: blind campaigns of every effect at the broad sizes a lab
    /// meets, every design, diagnosed and compared with their truth; writes the tallies
    /// (named, right, tied, the standard errors' coverage, the controls' p-value histogram) as
    /// Markdown. About 1 s a campaign on 2 cores.
    #[command(
        name = "gap-calibration",
        after_help = "Example (docs/gap-calibration.md, about 35 min on 2 cores):\n  bikeproc simulate gap-calibration --campaigns 50 --controls 200 --out docs/gap-calibration.md"
    )]
    GapCalibration {
        /// Campaigns per effect and design.
        #[arg(long, default_value_t = 50)]
        campaigns: u64,
        /// Effect-free campaigns per design.
        #[arg(long, default_value_t = 200)]
        controls: u64,
        /// Only the effects named (labels, comma-separated); all by default.
        #[arg(long, value_delimiter = ',')]
        only: Vec<String>,
        /// The measured bicycle.
        #[arg(long, default_value = "data/lab_bike.toml")]
        bike: PathBuf,
        /// The Markdown file to write; every campaign's result goes beside it as JSON
        /// (`NAME.json`).
        #[arg(long)]
        out: PathBuf,
        /// Render the Markdown from this JSON of every campaign's result (a run's own, made by
        /// the same options) instead of running the campaigns again.
        #[arg(long)]
        results: Option<PathBuf>,
    },
    /// A calibration file held true to the code: a few of its recorded campaigns (studies) of
    /// each design (kind) run again and compared with their record (numbers to 1e-9 of their
    /// size, all else exactly), and the Markdown beside it rendered again from the record.
    /// Exits 1 on any difference: the code under the file has moved, and the file must be
    /// made again by the command it names.
    #[command(
        name = "check-calibration",
        after_help = "Example (as CI runs it, about 30 s on 2 cores):\n  bikeproc simulate check-calibration docs/gap-calibration.json docs/study-calibration.json"
    )]
    CheckCalibration {
        /// The calibrations' results (`NAME.json`, beside `NAME.md`).
        #[arg(required = true)]
        results: Vec<PathBuf>,
        /// Campaigns replayed per design beside its first effect-free one (gap); studies per
        /// kind (study).
        #[arg(long, default_value_t = 1)]
        per_design: usize,
        /// The measured bicycle the calibration was made on.
        #[arg(long, default_value = "data/lab_bike.toml")]
        bike: PathBuf,
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
pub struct RideArgs {
    /// The truth bicycle (BicycleParameters text, benchmark TOML or a lab bicycle).
    #[arg(long)]
    pub bike: PathBuf,
    /// Speed at release (m/s), a riding speed (0.1 to 30 m/s).
    #[arg(long, value_parser = parse_speed)]
    pub speed: f64,
    /// The effects beyond the Whipple model: `none`; `realistic` (steer damping 0.3 N·m·s/rad,
    /// rolling resistance 0.004, drag area 0.08 m², the sensors' and speedometer's masses, a
    /// speedometer reading 3 % high, compliant tyres); or a TOML file of them, any left out
    /// off: steer_viscous_nms_per_rad, steer_coulomb_nm, steer_spring_nm_per_rad,
    /// rolling_resistance_coeff, drag_area_m2, speedometer_scale, clock_scale,
    /// [[extra_masses]] (mass_kg, body, x_m, z_m), [tyres].
    #[arg(long, default_value = "realistic")]
    pub effects: String,
    /// Seed of the random numbers (kick, noise, link): the same seed, the same files.
    #[arg(long, default_value_t = 1)]
    pub seed: u64,
    /// Output `NAME.log` (its `NAME_cal.log` beside it).
    #[arg(long)]
    pub out: PathBuf,
    /// Where the truth goes (default: `truth/NAME.json` beside the log); no analysis reads it.
    #[arg(long)]
    pub truth: Option<PathBuf>,
    /// Wire the reed switch: the `Sync` column and the wheel circumference.
    #[arg(long)]
    pub sync: bool,
    /// The sensors' orientation output: Euler angles, quaternion or rotation matrix.
    #[arg(long, value_enum, default_value_t = ModeArg::Euler)]
    pub mode: ModeArg,
    /// The acquisition PC's locale: tab-separated, or Spanish (`;` and decimal commas).
    #[arg(long, value_enum, default_value_t = LocaleArg::Tab)]
    pub locale: LocaleArg,
}

#[derive(Args)]
pub struct TorsionArgs {
    /// The body's inertia about the bar's axis (kg·m²).
    #[arg(long, default_value_t = 1.8906, value_parser = within(0.0, true, 1e6))]
    pub inertia_kgm2: f64,
    /// The bar's torsional stiffness (N·m/rad).
    #[arg(long, default_value_t = 34.33, value_parser = within(0.0, true, 1e6))]
    pub stiffness_nm_per_rad: f64,
    /// Viscous damping ratio ζ (dimensionless).
    #[arg(long, default_value_t = 0.004, value_parser = within(0.0, false, 0.99))]
    pub damping_ratio: f64,
    /// Dry (Coulomb) friction torque in the bearing (N·m).
    #[arg(long, default_value_t = 0.0, value_parser = within(0.0, false, 1e3))]
    pub coulomb_nm: f64,
    /// Frequency of the Cardan joint's swing mode (Hz); no swing mode when absent.
    #[arg(long, value_parser = within(0.0, true, 1e3))]
    pub swing_freq_hz: Option<f64>,
    /// How strongly the swing mode couples into the torsion (dimensionless, 0–1).
    #[arg(long, default_value_t = 0.03, value_parser = within(0.0, false, 1.0))]
    pub swing_coupling: f64,
    /// The swing mode's damping ratio (dimensionless).
    #[arg(long, default_value_t = 0.02, value_parser = within(0.0, false, 0.99))]
    pub swing_damping_ratio: f64,
    /// The swing mode's initial amplitude (degrees).
    #[arg(long, default_value_t = 1.0, value_parser = within(0.0, false, 90.0))]
    pub swing_amplitude_deg: f64,
    #[command(flatten)]
    pub common: SimCommon,
}

#[derive(Args)]
pub struct CompoundArgs {
    /// The body's mass (kg).
    #[arg(long, default_value_t = 5.48, value_parser = within(0.0, true, 1e6))]
    pub mass_kg: f64,
    /// Distance from the pivot to the centre of gravity (m).
    #[arg(long, default_value_t = 0.37, value_parser = within(0.0, true, 1e6))]
    pub pivot_to_cg_m: f64,
    /// Inertia about the pivot (kg·m²); eq. 79's frame: 0.8796 + 5.48·0.37².
    #[arg(long, default_value_t = 1.62982, value_parser = within(0.0, true, 1e6))]
    pub inertia_about_pivot_kgm2: f64,
    /// Viscous damping ratio ζ (dimensionless).
    #[arg(long, default_value_t = 0.003, value_parser = within(0.0, false, 0.99))]
    pub damping_ratio: f64,
    /// Dry (Coulomb) friction torque in the pivot (N·m).
    #[arg(long, default_value_t = 0.0, value_parser = within(0.0, false, 1e3))]
    pub coulomb_nm: f64,
    #[command(flatten)]
    pub common: SimCommon,
}

#[derive(Args)]
pub struct SimCommon {
    /// Output: `NAME.log` (its `NAME_cal.log` is written beside it).
    #[arg(long)]
    pub out: PathBuf,
    /// The release angle (degrees).
    #[arg(long, default_value_t = 8.0, value_parser = within(0.0, true, 90.0))]
    pub amplitude_deg: f64,
    /// Rest before the hand turns the body (s).
    #[arg(long, default_value_t = 3.0, value_parser = within(0.0, false, 3600.0))]
    pub rest_s: f64,
    /// Time the hand takes to turn the body to the release angle (s).
    #[arg(long, default_value_t = 1.0, value_parser = within(0.0, false, 3600.0))]
    pub ramp_s: f64,
    /// Time the body is held there before the release (s).
    #[arg(long, default_value_t = 1.0, value_parser = within(0.0, false, 3600.0))]
    pub hold_s: f64,
    /// Length of the recording (s).
    #[arg(long, default_value_t = 60.0, value_parser = within(0.0, true, 86400.0))]
    pub duration_s: f64,
    /// The sensor's orientation output: Euler angles, quaternion or rotation matrix.
    #[arg(long, value_enum, default_value_t = ModeArg::Euler)]
    pub mode: ModeArg,
    /// The acquisition PC's locale: tab-separated with decimal points, or Spanish (`;` and
    /// decimal commas).
    #[arg(long, value_enum, default_value_t = LocaleArg::Tab)]
    pub locale: LocaleArg,
    /// Digits written: as the sensor's software writes them, or full precision.
    #[arg(long, value_enum, default_value_t = PrecisionArg::Sensor)]
    pub precision: PrecisionArg,
    /// White noise of the orientation output (deg, per axis).
    #[arg(long, default_value_t = 0.05, value_parser = within(0.0, false, 90.0))]
    pub noise_deg: f64,
    /// A perfect link: no dropped packets, no corrupt rows, no clock jitter.
    #[arg(long)]
    pub perfect_link: bool,
    /// The sensor's id in the log's header.
    #[arg(long, default_value = "00300417")]
    pub sensor_id: String,
    /// The sensor's label in the log's header.
    #[arg(long, default_value = "torsion bar")]
    pub label: String,
    /// Seed of the random numbers (noise, dropped packets): the same seed, the same file.
    #[arg(long, default_value_t = 1)]
    pub seed: u64,
}

#[derive(Clone, Copy, ValueEnum)]
pub enum ModeArg {
    Euler,
    Quaternion,
    Matrix,
}

#[derive(Clone, Copy, ValueEnum)]
pub enum LocaleArg {
    Tab,
    Spanish,
}

#[derive(Clone, Copy, ValueEnum)]
pub enum PrecisionArg {
    Sensor,
    Full,
}

#[derive(Args)]
pub struct ReportArgs {
    /// Where the reports go.
    #[arg(long, default_value = "reports")]
    pub out: PathBuf,
    /// Where the reference material is (`../shared/reference` of the checkout).
    #[arg(long, default_value = "../shared/reference")]
    pub reference: PathBuf,
    /// The lab's data (the simulated campaign).
    #[arg(long, default_value = "data")]
    pub data: PathBuf,
}

/// A value an option does not take, as clap shows it after the option's name: what was
/// given and what the option takes.
#[derive(Debug, Clone, PartialEq, thiserror::Error)]
#[error("{0}")]
pub struct ArgError(pub String);

impl From<String> for ArgError {
    fn from(message: String) -> ArgError {
        ArgError(message)
    }
}

impl From<&str> for ArgError {
    fn from(message: &str) -> ArgError {
        ArgError(message.to_string())
    }
}

/// A number, then `check`ed (the library's check of that quantity, with its message).
fn number_checked<E: std::fmt::Display>(
    s: &str,
    check: fn(f64) -> Result<f64, E>,
) -> Result<f64, ArgError> {
    let v: f64 = s
        .trim()
        .parse()
        .map_err(|_| format!("`{s}` is not a number"))?;
    check(v).map_err(|e| ArgError(e.to_string()))
}

/// `--speed`: a riding speed (m/s).
pub fn parse_speed(s: &str) -> Result<f64, ArgError> {
    number_checked(s, bikeproc::ride::speed::check_reading_mps)
}

/// `--rate`: a sampling rate (Hz) for a table without a time column.
pub fn parse_rate(s: &str) -> Result<f64, ArgError> {
    number_checked(s, bikeproc::ride::csv::check_rate_hz)
}

/// A number in `lo..=hi` (finite), for a physical argument: `lo_open` excludes `lo` itself (a
/// mass, an inertia, a stiffness, a duration must be above zero).
pub fn within(lo: f64, lo_open: bool, hi: f64) -> impl Fn(&str) -> Result<f64, ArgError> + Clone {
    move |s: &str| {
        let v: f64 = s
            .trim()
            .parse()
            .map_err(|_| format!("`{s}` is not a number"))?;
        let above = if lo_open { v > lo } else { v >= lo };
        if v.is_finite() && above && v <= hi {
            Ok(v)
        } else {
            let (v, lo, hi) = (number_text(v), number_text(lo), number_text(hi));
            Err(ArgError(if lo_open {
                format!("{v}: expected a number above {lo} and at most {hi}")
            } else {
                format!("{v}: expected a number from {lo} to {hi}")
            }))
        }
    }
}

pub fn parse_range(s: &str) -> Result<(f64, f64), ArgError> {
    let (a, b) = s.split_once(':').ok_or("expected START:END in seconds")?;
    let a: f64 = a
        .trim()
        .parse()
        .map_err(|_| format!("`{a}` is not a number"))?;
    let b: f64 = b
        .trim()
        .parse()
        .map_err(|_| format!("`{b}` is not a number"))?;
    if let Some(x) = [a, b].into_iter().find(|x| !x.is_finite()) {
        return Err(format!(
            "{}: START and END must be finite times in seconds",
            number_text(x)
        )
        .into());
    }
    if b > a {
        Ok((a, b))
    } else {
        Err("END must be after START".into())
    }
}

/// A campaign none of whose rides could be analysed: its input is at fault (exit 2).
/// The effects a blind campaign can withhold, by label.
pub fn withheld_effects() -> clap::builder::PossibleValuesParser {
    clap::builder::PossibleValuesParser::new(
        bikeproc::sim::campaign::Withheld::ALL.map(|w| w.label()),
    )
}

/// The blind campaigns' designs by name, for clap (the names [`BlindDesign::label`] gives).
///
/// [`BlindDesign::label`]: bikeproc::sim::campaign::BlindDesign::label
pub fn blind_designs() -> clap::builder::PossibleValuesParser {
    clap::builder::PossibleValuesParser::new(
        bikeproc::sim::campaign::BlindDesign::ALL.map(|d| d.label()),
    )
}

impl From<TrendArg> for Trend {
    fn from(t: TrendArg) -> Trend {
        match t {
            TrendArg::Auto => Trend::Auto,
            TrendArg::On => Trend::On,
            TrendArg::Off => Trend::Off,
        }
    }
}

impl From<ModeArg> for OutputMode {
    fn from(m: ModeArg) -> OutputMode {
        match m {
            ModeArg::Euler => OutputMode::Euler,
            ModeArg::Quaternion => OutputMode::Quaternion,
            ModeArg::Matrix => OutputMode::Matrix,
        }
    }
}

impl From<LocaleArg> for Locale {
    fn from(l: LocaleArg) -> Locale {
        match l {
            LocaleArg::Tab => Locale::Tab,
            LocaleArg::Spanish => Locale::Spanish,
        }
    }
}

impl From<PrecisionArg> for Precision {
    fn from(p: PrecisionArg) -> Precision {
        match p {
            PrecisionArg::Sensor => Precision::Sensor,
            PrecisionArg::Full => Precision::Full,
        }
    }
}
