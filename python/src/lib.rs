//! bikeproc in Python: the Rust core's calls behind a PyO3 module, nothing computed again.
//!
//! In: paths and numpy arrays from Python. Out: numpy arrays, and for every result the core
//! also prints with `--json` the same JSON made into Python dicts and lists (through Python's
//! `json`, which reads back every float Rust's `serde_json` wrote to the last bit), so a
//! notebook sees the command line's numbers. A file the core refuses raises
//! `bikeproc.BikeprocError` with the core's message (file, line, column).

use bikeproc::model::uncertain::Parametrized;
use numpy::ndarray::Array2;
use numpy::{Complex64, IntoPyArray, PyArray2, PyReadonlyArray1};
use pyo3::create_exception;
use pyo3::prelude::*;
use pyo3::types::PyDict;
use std::path::PathBuf;

create_exception!(
    bikeproc,
    BikeprocError,
    pyo3::exceptions::PyValueError,
    "A file or an input bikeproc refuses; the message names the file, line and column."
);

/// The core's error as a Python exception: the message with its causes, as the command line
/// prints it.
fn err(e: impl Into<anyhow::Error>) -> PyErr {
    BikeprocError::new_err(format!("{:#}", e.into()))
}

/// A value the core serializes for `--json`, as Python objects.
fn to_python<'py>(py: Python<'py>, value: &impl serde::Serialize) -> PyResult<Bound<'py, PyAny>> {
    let text = serde_json::to_string(value).map_err(err)?;
    py.import("json")?.call_method1("loads", (text,))
}

/// Reads an IMU log (the acquisition side's format) onto its sensors' sample grid.
///
/// Returns a dict: ``sample_rate_hz`` (Hz), ``mode`` (the output mode), ``time_s`` (s from the
/// first row, one per kept sample, float64 array), ``grid_index`` (each kept sample's place on
/// the grid, uint64 array: a hole is a dropped packet or a corrupt row), ``channels`` (column
/// name → float64 array in the file's unit: deg, deg/s, m/s², or quaternion components),
/// ``sensors`` (list of dicts: ``id``, ``label``, ``columns``), ``gaps`` (``missing_samples``,
/// ``gaps``, ``longest_gap_samples``, ``corrupt_rows``, ``time_off_rows``) and ``warnings``.
/// Raises BikeprocError naming the file, line and column of what it cannot read.
#[pyfunction]
fn read_log<'py>(py: Python<'py>, path: PathBuf) -> PyResult<Bound<'py, PyDict>> {
    let mut log =
        bikeproc::read::log::Log::open(&path, &bikeproc::read::log::ReadOptions::default())
            .map_err(err)?;
    let out = PyDict::new(py);
    out.set_item("path", path.display().to_string())?;
    out.set_item("sample_rate_hz", log.sample_rate_hz)?;
    out.set_item("mode", log.mode.name())?;
    out.set_item(
        "time_s",
        log.times_s().collect::<Vec<f64>>().into_pyarray(py),
    )?;
    out.set_item(
        "grid_index",
        std::mem::take(&mut log.grid_index).into_pyarray(py),
    )?;
    // The columns are moved into NumPy's arrays, not copied (a long log's are hundreds of MB).
    let channels = PyDict::new(py);
    for (name, values) in log.columns.iter().zip(std::mem::take(&mut log.data)) {
        channels.set_item(name, values.into_pyarray(py))?;
    }
    out.set_item("channels", channels)?;
    let sensors = log
        .sensors
        .iter()
        .map(|s| {
            let d = PyDict::new(py);
            d.set_item("id", &s.id)?;
            d.set_item("label", &s.label)?;
            let columns: Vec<&str> = s
                .channel_columns
                .iter()
                .map(|&c| log.columns[c].as_str())
                .collect();
            d.set_item("columns", columns)?;
            Ok(d)
        })
        .collect::<PyResult<Vec<_>>>()?;
    out.set_item("sensors", sensors)?;
    let g = &log.gaps;
    let gaps = PyDict::new(py);
    gaps.set_item("missing_samples", g.missing_samples)?;
    gaps.set_item("gaps", g.gaps)?;
    gaps.set_item("longest_gap_samples", g.longest_gap_samples)?;
    gaps.set_item("corrupt_rows", g.corrupt_rows)?;
    gaps.set_item("time_off_rows", g.time_off_rows)?;
    out.set_item("gaps", gaps)?;
    out.set_item("warnings", &log.warnings)?;
    Ok(out)
}

/// The fit's trend option from its name.
fn trend(name: &str) -> PyResult<bikeproc::fit::Trend> {
    use bikeproc::fit::Trend;
    match name {
        "auto" => Ok(Trend::Auto),
        "on" => Ok(Trend::On),
        "off" => Ok(Trend::Off),
        other => Err(BikeprocError::new_err(format!(
            "trend `{other}`: expected \"auto\", \"on\" or \"off\""
        ))),
    }
}

/// Fits the free oscillation in the samples ``x`` at times ``t`` (s; advancing, on a uniform
/// grid with holes allowed): the free decay's segment, x(t) = a (+ d·t) + e^{−σt}(b sin ω_d t +
/// c cos ω_d t) by least squares, ``trend`` "auto" (by BIC), "on" or "off".
///
/// Returns the dict of ``bikeproc period --json``: ``period_s`` and ``period_se_s`` (s),
/// ``freq_hz``/``freq_se_hz`` (damped, Hz), ``natural_freq_hz``/``natural_freq_se_hz``,
/// ``damping_ratio``/``damping_ratio_se``, ``amplitude``/``amplitude_se`` (x's unit),
/// ``segment_s``, ``fft_peak_hz``, ``secondary_peaks_hz`` and the rest, every value with its
/// standard error.
#[pyfunction]
#[pyo3(signature = (t, x, trend="auto"))]
fn fit_period<'py>(
    py: Python<'py>,
    t: PyReadonlyArray1<'py, f64>,
    x: PyReadonlyArray1<'py, f64>,
    trend: &str,
) -> PyResult<Bound<'py, PyAny>> {
    let (t, x) = (t.as_array().to_vec(), x.as_array().to_vec());
    let signal = bikeproc::signal::Signal::from_samples("x", &t, &x).map_err(err)?;
    let options = bikeproc::fit::FitOptions {
        trend: self::trend(trend)?,
        ..Default::default()
    };
    let osc = bikeproc::fit::analyse(&signal, &options).map_err(err)?;
    to_python(py, &osc.summary(&signal))
}

/// ``bikeproc period FILE``: the free oscillation of one recording (a log, with its ``_cal``
/// partner where a calibrated channel is asked for, or a ``time_s,value`` CSV). ``channel``
/// names a column (e.g. "Gyr_Z"); by default the rotation about the dominant axis (rad).
/// ``sensor`` picks a sensor by id or label in a two-sensor log.
///
/// Returns the dict of ``bikeproc period FILE --json`` (see fit_period); raises BikeprocError
/// with the file and line of what it cannot read or fit.
#[pyfunction]
#[pyo3(signature = (path, channel=None, sensor=None, trend="auto"))]
fn period<'py>(
    py: Python<'py>,
    path: PathBuf,
    channel: Option<String>,
    sensor: Option<String>,
    trend: &str,
) -> PyResult<Bound<'py, PyAny>> {
    let extract = channel.map_or(
        bikeproc::signal::Extract::DominantRotation,
        bikeproc::signal::Extract::Channel,
    );
    let options = bikeproc::fit::FitOptions {
        trend: self::trend(trend)?,
        ..Default::default()
    };
    let (summary, _warnings) =
        bikeproc::fit::measure_file(&path, &extract, sensor.as_deref(), &options).map_err(err)?;
    to_python(py, &summary)
}

/// ``bikeproc calibrate-bar FOLDER``: the torsion bar's stiffness (N·m/rad) and the fixture's
/// inertia (kg·m²) from the steel rod's recordings, with standard errors and their correlation.
/// Unlike the command, it writes no ``calibration.toml``.
///
/// Returns the dict of ``bikeproc calibrate-bar --json``.
#[pyfunction]
fn calibrate_bar<'py>(py: Python<'py>, folder: PathBuf) -> PyResult<Bound<'py, PyAny>> {
    let cal = bikeproc::inertia::calibrate_bar(&folder).map_err(err)?;
    to_python(py, &bikeproc::inertia::text::calibration_json(&cal))
}

/// ``bikeproc inertia FOLDER``: a torsion folder's inertia tensor (kg·m², with standard errors
/// and the fit's χ²; ``orientations`` a list of the orientations to use, all by default) or a
/// compound-pendulum folder's moments about the pivot and the centre of gravity (kg·m²).
///
/// Returns the dict of ``bikeproc inertia FOLDER --json``.
#[pyfunction]
#[pyo3(signature = (folder, orientations=None))]
fn inertia<'py>(
    py: Python<'py>,
    folder: PathBuf,
    orientations: Option<Vec<String>>,
) -> PyResult<Bound<'py, PyAny>> {
    let r = bikeproc::inertia::analyse_folder(&folder, &orientations.unwrap_or_default())
        .map_err(err)?;
    to_python(py, &r.json())
}

/// ``bikeproc dynamic RIDE.log [--speed V]`` or ``bikeproc dynamic rides.toml``: a kicked
/// ride's weave (eigenvalue −σ ± iω, 1/s
/// and rad/s, with standard errors from the modal fit and its bootstrap), its speed from every
/// source (``speed`` the speedometer's reading in m/s, 0.1 m/s steps and 1 % per reading), and
/// the model's prediction at that speed. The bicycle is ``bike`` or the ``lab_bike.toml`` (or
/// ``rides.toml``'s bicycle) beside the log.
///
/// A campaign manifest (``.toml``) analyses every ride it lists with its noted speeds (the
/// manifest's bicycle unless ``bike``). Returns the dict of ``bikeproc dynamic PATH --json``.
#[pyfunction]
#[pyo3(signature = (path, speed=None, bike=None))]
fn dynamic<'py>(
    py: Python<'py>,
    path: PathBuf,
    speed: Option<f64>,
    bike: Option<PathBuf>,
) -> PyResult<Bound<'py, PyAny>> {
    use bikeproc::ride::dynamic;
    if let Some(v) = speed {
        bikeproc::ride::speed::check_reading_mps(v)
            .map_err(|e| BikeprocError::new_err(format!("speed: {e}")))?;
    }
    let modal = bikeproc::ride::modal::ModalOptions::default();
    if path.extension().is_some_and(|e| e == "toml") {
        let manifest = bikeproc::read::rides::RideManifest::load(&path).map_err(err)?;
        let bike = bike.unwrap_or_else(|| manifest.bike_path());
        let summary = py
            .detach(|| dynamic::campaign_summary(&manifest, &bike, &modal, &|_, _| {}))
            .map_err(err)?;
        return to_python(py, &summary);
    }
    let bike = match bike {
        Some(b) => b,
        None => dynamic::bike_beside(&path).map_err(err)?,
    };
    let model = bikeproc::read::bicycle::load(&bike).map_err(err)?;
    let options = dynamic::DynamicOptions {
        noted: speed.map(bikeproc::ride::speed::NotedReading::lab),
        prefer_sync: false,
        modal,
    };
    let summary = py
        .detach(|| dynamic::dynamic_test(&path, &model, &options).map(|t| t.summary()))
        .map_err(err)?;
    to_python(py, &summary)
}

/// ``bikeproc gap rides.toml``: the sim-to-real gap of a ride campaign: each ride's weave
/// residual in combined standard errors, the campaign's test, the candidate effects fitted and
/// ranked by leave-one-ride-out prediction, ties, the rides that would tell them apart, and
/// the verdict.
///
/// Returns the dict of ``bikeproc gap rides.toml --json``.
#[pyfunction]
#[pyo3(signature = (manifest, bike=None))]
fn gap<'py>(
    py: Python<'py>,
    manifest: PathBuf,
    bike: Option<PathBuf>,
) -> PyResult<Bound<'py, PyAny>> {
    let m = bikeproc::read::rides::RideManifest::load(&manifest).map_err(err)?;
    let model = m.model(bike.as_deref()).map_err(err)?;
    let d = py
        .detach(|| bikeproc::gap::diagnose_campaign(&m, &model, &|_, _, _| {}))
        .map_err(err)?;
    to_python(py, &d)
}

/// A bicycle of the Whipple model with the standard errors of its parameters.
///
/// Bicycle.from_file(path) reads a lab bicycle (TOML), a benchmark TOML, or BicycleParameters'
/// ``*Benchmark.txt`` (values with ``+/-`` errors) or ``*Measured.txt``.
#[pyclass(module = "bikeproc", frozen)]
struct Bicycle {
    model: Parametrized,
}

#[pymethods]
impl Bicycle {
    /// Bicycle.from_file(path): the bicycle of a file (see the class).
    #[staticmethod]
    fn from_file(path: PathBuf) -> PyResult<Bicycle> {
        Ok(Bicycle {
            model: bikeproc::read::bicycle::load(&path).map_err(err)?,
        })
    }

    /// Bicycle.with_rider(path): the same bicycle with the rider of ``path`` (BicycleParameters'
    /// benchmark form of a rider, as ``JasonRigidBenchmark.txt``) joined to its rear frame, as
    /// ``--rider`` does; its standard errors carried.
    fn with_rider(&self, path: PathBuf) -> PyResult<Bicycle> {
        Ok(Bicycle {
            model: self.model.clone().with_rider_file(&path).map_err(err)?,
        })
    }

    /// ``bikeproc sensitivity --bike FILE [--speeds …] [--max-speed V]``: every benchmark
    /// parameter's derivative of the weave and capsize speeds (m/s per unit), elasticity and
    /// share of their variance, the budget by measurement, and the weave eigenvalue's
    /// derivatives at ``speeds`` (m/s).
    ///
    /// Returns the dict of ``bikeproc sensitivity --json``.
    #[pyo3(signature = (speeds=Vec::new(), max_speed=10.0))]
    fn sensitivity<'py>(
        &self,
        py: Python<'py>,
        speeds: Vec<f64>,
        max_speed: f64,
    ) -> PyResult<Bound<'py, PyAny>> {
        check_speeds(&speeds, max_speed)?;
        let s = py
            .detach(|| bikeproc::model::sensitivity::sensitivity(&self.model, &speeds, max_speed))
            .map_err(err)?;
        to_python(py, &s)
    }

    /// ``bikeproc design --bike FILE --stable A:B --vary … [--max-change F] [--out FILE]``: the
    /// smallest relative change of ``vary`` (head_angle, trail, wheelbase, or benchmark
    /// parameters by name) that makes the bicycle stable over ``stable`` = (A, B) m/s, or the
    /// closest design and why not (``reached`` False); ``out`` writes the changed bicycle.
    ///
    /// Returns the dict of ``bikeproc design --json``.
    #[pyo3(signature = (stable, vary, max_change=0.5, out=None))]
    fn design<'py>(
        &self,
        py: Python<'py>,
        stable: (f64, f64),
        vary: Vec<String>,
        max_change: f64,
        out: Option<PathBuf>,
    ) -> PyResult<Bound<'py, PyAny>> {
        use bikeproc::model::design::{design, DesignVariable};
        if !(max_change > 0.0 && max_change <= 0.95) {
            return Err(BikeprocError::new_err(format!(
                "max_change = {max_change}: a fraction above 0 and at most 0.95"
            )));
        }
        let vars = DesignVariable::parse_list(&vary).map_err(err)?;
        let bike = self.model.nominal();
        let d = py
            .detach(|| design(&self.model.name, &bike, &vars, stable, max_change))
            .map_err(err)?;
        if let Some(out) = out {
            bikeproc::output::write_atomic(&out, d.bicycle.to_text().as_bytes()).map_err(err)?;
        }
        to_python(py, &d)
    }

    /// The bicycle's name.
    #[getter]
    fn name(&self) -> String {
        self.model.name.clone()
    }

    /// The modes of eigenvalues()'s columns: "Weave", "WeaveConjugate", "Capsize", "Castor".
    #[getter]
    fn modes(&self) -> PyResult<Vec<String>> {
        let sweep = self.model.nominal_canonical().sweep(&[0.0]).map_err(err)?;
        Ok(sweep.modes.iter().map(|m| format!("{m:?}")).collect())
    }

    /// The nominal bicycle's eigenvalues (1/s) at each of ``speeds`` (m/s, a 1-D array),
    /// followed from speed to speed and named as ``modes``: a complex array of shape
    /// (len(speeds), 4).
    fn eigenvalues<'py>(
        &self,
        py: Python<'py>,
        speeds: PyReadonlyArray1<'py, f64>,
    ) -> PyResult<Bound<'py, PyArray2<Complex64>>> {
        let speeds = speeds.as_array().to_vec();
        if let Some((i, v)) = speeds.iter().enumerate().find(|(_, v)| !v.is_finite()) {
            return Err(BikeprocError::new_err(format!(
                "speeds[{i}] = {v}: expected finite speeds (m/s)"
            )));
        }
        let canonical = self.model.nominal_canonical();
        let sweep = py.detach(|| canonical.sweep(&speeds)).map_err(err)?;
        let flat: Vec<Complex64> = sweep
            .eigenvalues
            .iter()
            .flat_map(|row| row.iter().map(|z| Complex64::new(z.re, z.im)))
            .collect();
        let array = Array2::from_shape_vec((speeds.len(), 4), flat).map_err(err)?;
        Ok(array.into_pyarray(py))
    }

    /// ``bikeproc stability --speeds START:END:STEP``: the weave and capsize speeds (m/s) with
    /// standard errors from the parameters', the stable ranges, and the eigenvalues with their
    /// standard errors at START, START + STEP, … END.
    ///
    /// Returns the dict of ``bikeproc stability --json``.
    #[pyo3(signature = (start=0.0, end=10.0, step=0.01))]
    fn stability<'py>(
        &self,
        py: Python<'py>,
        start: f64,
        end: f64,
        step: f64,
    ) -> PyResult<Bound<'py, PyAny>> {
        let report = stability_report(py, &self.model, (start, end, step))?;
        to_python(py, &report)
    }

    /// ``stability`` as arrays for a notebook: a dict of ``speeds_mps`` (n,), ``eigenvalues``
    /// (n, 4) complex, its columns named by ``modes`` (all four at every speed: below the weave's
    /// merge speed its two real roots), ``re_se`` and ``im_se`` (n, 4) their standard errors
    /// from the parameters', and the weave and capsize speeds with their standard errors and the
    /// stable ranges as ``stability`` gives them (searched to ``end`` at 0.01 m/s, then refined).
    #[pyo3(signature = (start=0.0, end=10.0, step=0.01))]
    fn stability_table<'py>(
        &self,
        py: Python<'py>,
        start: f64,
        end: f64,
        step: f64,
    ) -> PyResult<Bound<'py, PyDict>> {
        check_grid((start, end, step))?;
        let speeds = bikeproc::model::report::speed_grid((start, end, step));
        let (bands, s) = py
            .detach(|| {
                Ok::<_, bikeproc::model::ParamError>((
                    self.model.bands(&speeds)?,
                    self.model.speeds(end, 0.01)?,
                ))
            })
            .map_err(err)?;
        let n = speeds.len();
        let table = |f: &dyn Fn(usize, usize) -> f64| -> PyResult<Bound<'py, PyArray2<f64>>> {
            let flat: Vec<f64> = (0..n)
                .flat_map(|i| (0..4).map(move |k| (i, k)))
                .map(|(i, k)| f(i, k))
                .collect();
            Ok(Array2::from_shape_vec((n, 4), flat)
                .map_err(err)?
                .into_pyarray(py))
        };
        let eigen: Vec<Complex64> = bands
            .sweep
            .eigenvalues
            .iter()
            .flat_map(|row| row.iter().map(|z| Complex64::new(z.re, z.im)))
            .collect();
        let d = PyDict::new(py);
        d.set_item("speeds_mps", numpy::PyArray1::from_vec(py, speeds.clone()))?;
        d.set_item(
            "eigenvalues",
            Array2::from_shape_vec((n, 4), eigen)
                .map_err(err)?
                .into_pyarray(py),
        )?;
        d.set_item("re_se", table(&|i, k| bands.se[i][k].0)?)?;
        d.set_item("im_se", table(&|i, k| bands.se[i][k].1)?)?;
        d.set_item("modes", self.modes()?)?;
        d.set_item("weave_speed_mps", s.stability.weave_speed_mps)?;
        d.set_item("weave_speed_se_mps", s.weave_speed_se_mps)?;
        d.set_item("capsize_speed_mps", s.stability.capsize_speed_mps)?;
        d.set_item("capsize_speed_se_mps", s.capsize_speed_se_mps)?;
        d.set_item("stable_ranges_mps", s.stability.stable_ranges_mps.clone())?;
        Ok(d)
    }

    /// The speed ranges (m/s) where the bicycle is self-stable, searched to ``end`` at 0.01
    /// m/s: a list of dicts ``low_mps``, ``high_mps`` (None when still stable at ``end``).
    #[pyo3(signature = (end=10.0))]
    fn stable_range<'py>(&self, py: Python<'py>, end: f64) -> PyResult<Vec<Bound<'py, PyDict>>> {
        self.speeds(py, end)?
            .stability
            .stable_ranges_mps
            .iter()
            .map(|(lo, hi)| {
                let d = PyDict::new(py);
                d.set_item("low_mps", lo)?;
                d.set_item("high_mps", hi)?;
                Ok(d)
            })
            .collect()
    }

    /// The weave speed (m/s), where the weave turns stable, with its standard error from the
    /// parameters': a dict ``value``, ``se`` (None when there is none below ``end``).
    #[pyo3(signature = (end=10.0))]
    fn weave_speed<'py>(&self, py: Python<'py>, end: f64) -> PyResult<Option<Bound<'py, PyDict>>> {
        let s = self.speeds(py, end)?;
        estimate(py, s.stability.weave_speed_mps, s.weave_speed_se_mps)
    }

    /// The capsize speed (m/s), where the capsize mode turns unstable, with its standard error:
    /// a dict ``value``, ``se`` (None when there is none below ``end``).
    #[pyo3(signature = (end=10.0))]
    fn capsize_speed<'py>(
        &self,
        py: Python<'py>,
        end: f64,
    ) -> PyResult<Option<Bound<'py, PyDict>>> {
        let s = self.speeds(py, end)?;
        estimate(py, s.stability.capsize_speed_mps, s.capsize_speed_se_mps)
    }

    fn __repr__(&self) -> String {
        format!("Bicycle({:?})", self.model.name)
    }
}

impl Bicycle {
    /// The stable ranges and the weave and capsize speeds with their standard errors, searched
    /// to `end` at 0.01 m/s (what `stability` reports them from).
    fn speeds(
        &self,
        py: Python<'_>,
        end: f64,
    ) -> PyResult<bikeproc::model::uncertain::SpeedsWithSe> {
        check_grid((0.0, end, 0.01))?;
        py.detach(|| self.model.speeds(end, 0.01)).map_err(err)
    }
}

/// Nothing, for a speed grid `stability` takes; otherwise the error saying what one must be.
fn check_grid(grid: (f64, f64, f64)) -> PyResult<()> {
    use bikeproc::model::report::{valid_speed_grid, SPEED_GRID_RULE};
    if valid_speed_grid(grid) {
        Ok(())
    } else {
        Err(BikeprocError::new_err(format!(
            "speeds {}:{}:{}: {SPEED_GRID_RULE}",
            grid.0, grid.1, grid.2
        )))
    }
}

/// [`bikeproc::model::report::StabilityReport::over`] the grid, checked first.
fn stability_report(
    py: Python<'_>,
    model: &Parametrized,
    grid: (f64, f64, f64),
) -> PyResult<bikeproc::model::report::StabilityReport> {
    check_grid(grid)?;
    py.detach(|| bikeproc::model::report::StabilityReport::over(model, grid))
        .map_err(err)
}

/// Speeds for the weave's derivatives: finite, above 0, at most ``max_speed`` (itself in
/// (0, 100] m/s).
fn check_speeds(speeds: &[f64], max_speed: f64) -> PyResult<()> {
    if !(max_speed > 0.0 && max_speed <= 100.0) {
        return Err(BikeprocError::new_err(format!(
            "max_speed = {max_speed}: a speed above 0 and at most 100 m/s"
        )));
    }
    if let Some((i, v)) = speeds
        .iter()
        .enumerate()
        .find(|(_, v)| !(v.is_finite() && **v > 0.0 && **v <= 100.0))
    {
        return Err(BikeprocError::new_err(format!(
            "speeds[{i}] = {v}: a speed above 0 and at most 100 m/s"
        )));
    }
    Ok(())
}

/// ``bikeproc compare A B …``: the bicycles' weave and capsize speeds with standard errors,
/// each against the first in combined standard errors (``bicycles``: a list of ``Bicycle``).
///
/// Returns the dict of ``bikeproc compare --json``.
#[pyfunction]
#[pyo3(signature = (bicycles, max_speed=10.0))]
fn compare<'py>(
    py: Python<'py>,
    bicycles: Vec<Py<Bicycle>>,
    max_speed: f64,
) -> PyResult<Bound<'py, PyAny>> {
    check_speeds(&[], max_speed)?;
    let models: Vec<Parametrized> = bicycles.iter().map(|b| b.get().model.clone()).collect();
    let c = py
        .detach(|| bikeproc::model::compare::compare(&models, max_speed))
        .map_err(err)?;
    to_python(py, &c)
}

/// A value with its standard error as a dict, None without a value.
fn estimate<'py>(
    py: Python<'py>,
    value: Option<f64>,
    se: Option<f64>,
) -> PyResult<Option<Bound<'py, PyDict>>> {
    value
        .map(|v| {
            let d = PyDict::new(py);
            d.set_item("value", v)?;
            d.set_item("se", se)?;
            Ok(d)
        })
        .transpose()
}

/// bikeproc: from raw IMU logs of a bicycle-dynamics lab to inertias, Whipple-model eigenvalues
/// and the sim-to-real gap. SI units throughout; every estimate with its standard error.
#[pymodule]
#[pyo3(name = "bikeproc")]
fn bikeproc_module(m: &Bound<'_, PyModule>) -> PyResult<()> {
    m.add("BikeprocError", m.py().get_type::<BikeprocError>())?;
    m.add_function(wrap_pyfunction!(read_log, m)?)?;
    m.add_function(wrap_pyfunction!(fit_period, m)?)?;
    m.add_function(wrap_pyfunction!(period, m)?)?;
    m.add_function(wrap_pyfunction!(calibrate_bar, m)?)?;
    m.add_function(wrap_pyfunction!(inertia, m)?)?;
    m.add_function(wrap_pyfunction!(dynamic, m)?)?;
    m.add_function(wrap_pyfunction!(gap, m)?)?;
    m.add_function(wrap_pyfunction!(compare, m)?)?;
    m.add_class::<Bicycle>()?;
    m.add("__version__", env!("CARGO_PKG_VERSION"))?;
    Ok(())
}
