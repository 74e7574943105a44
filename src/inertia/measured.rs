//! BicycleParameters' raw measurements (`NameMeasured.txt`) → the benchmark parameters, with
//! standard errors propagated from the measurements.
//!
//! In: a `*Measured.txt` file as BicycleParameters (J. K. Moore et al.) keeps it: `key =
//! value+/-sigma` a line, comma lists of repeated measurements (averaged), `#` comments, keys
//! that are not measurements (rider geometry) ignored. Out: [`MeasuredBicycle`], every benchmark
//! parameter (Meijaard et al. 2007) with its standard error, and the same conversion as a
//! [`Parametrized`] model, so that the errors reach the weave and capsize speeds with the
//! measurements' correlations.
//!
//! The method is BicycleParameters' (Moore 2012, *Human control of a bicycle*, ch. 2; its
//! `calculate_benchmark_from_measured`), on bikeproc's own pendulum equations:
//! - wheel radii from the rolling distance over `n` turns, `r = d / (2π n)`;
//! - geometry from the wheelbase `w`, head angle `γ` and fork offset `f` (`λ = 90° − γ`), or
//!   from the table-top heights and diameters `h1…h5`, `d1…d4`, `d` (the offsets `a`, `b`, `c`
//!   of the steer axis, `λ` the root of `sin λ = (r_F − r_R + c cos λ)/(a + b)`); trail
//!   `c = (r_F sin λ − f)/cos λ`;
//! - each body hung in several orientations: the line through its centre of mass in the
//!   benchmark frame from the angle `α` of the steer axis (or of the frame's reference) and the
//!   distance `a` from the pendulum axis, the centre of mass the mean of the lines' pairwise
//!   intersections;
//! - the torsion pendulum's stiffness from the calibration rod `k = 4π² I_rod / T_P²`
//!   ([`super::torsional_pendulum_stiffness`], [`super::rod_inertia`]), each orientation's
//!   moment `k T² / 4π²` ([`super::torsional_pendulum_inertia`]) and the in-plane tensor from
//!   them ([`super::solve_tensor`], eq. 69 of the seed);
//! - the moments about y of the wheels and bodies as compound pendulums about the axle (or
//!   handlebar reference), `I = m g l (T/2π)² − m l²` ([`super::compound_pendulum_inertia`],
//!   [`super::parallel_axis_removed`]);
//! - a handlebar (`G`) and fork (`S`) measured apart are combined into the front frame `H`;
//!   a flywheel `D` in the front wheel is the measurement with it less the wheel's; a
//!   lateral force point (`xcl`, `zcl`, already in the benchmark frame) is passed through.
//!
//! Standard errors: first-order propagation with the correlations
//! ([`crate::uncertainty::propagate`]); a comma list's mean has the error of a mean of
//! independent measurements, `√Σσᵢ² / n`. One convention is BicycleParameters' own and is kept
//! so that the errors agree with that lab's: with the `h`/`d` geometry, `λ` is an independent
//! quantity whose standard error is that of its starting guess `atan(c/(a + b))`.

use super::{
    compound_pendulum_inertia, parallel_axis_removed, rod_inertia, solve_tensor,
    torsional_pendulum_inertia, torsional_pendulum_stiffness,
};
use crate::model::uncertain::Parametrized;
use crate::model::Benchmark;
use crate::uncertainty::{propagate, Inputs, Measured};
use std::collections::BTreeMap;
use std::f64::consts::PI;
use std::path::{Path, PathBuf};

/// Errors of reading and converting a `*Measured.txt` file.
#[derive(Debug, Clone, PartialEq, thiserror::Error)]
pub enum MeasuredError {
    #[error("{path}: cannot read: {message}")]
    Read { path: PathBuf, message: String },
    #[error("{path}:{line}:{column}: {message}")]
    Parse {
        path: PathBuf,
        line: usize,
        column: usize,
        message: String,
    },
    #[error("{path}: missing measurement {}", missing_list(.keys))]
    Missing { path: PathBuf, keys: Vec<String> },
    #[error("{path}:{line}: `{key}`: {message}")]
    Invalid {
        path: PathBuf,
        line: usize,
        key: String,
        message: String,
    },
    #[error("{path}: {message}")]
    NoBicycle { path: PathBuf, message: String },
}

fn missing_list(keys: &[String]) -> String {
    match keys {
        [] => String::new(),
        [k] => format!("`{k}` ({})", describe(k)),
        [k, rest @ ..] => {
            let shown: Vec<String> = rest.iter().take(8).map(|r| format!("`{r}`")).collect();
            let others = rest.len().saturating_sub(8);
            format!(
                "`{k}` ({}) and {} more: {}{}",
                describe(k),
                rest.len(),
                shown.join(", "),
                if others > 0 {
                    format!(" and {others} others")
                } else {
                    String::new()
                }
            )
        }
    }
}

/// What a measurement key is, in words (for the messages).
fn describe(key: &str) -> String {
    let part = |c: Option<char>| match c {
        Some('B') => "the frame",
        Some('H') => "the handlebar and fork",
        Some('G') => "the handlebar",
        Some('S') => "the fork",
        Some('F') => "the front wheel",
        Some('R') => "the rear wheel",
        Some('D') => "the front wheel with its flywheel",
        Some('P') => "the calibration rod",
        _ => "a part",
    };
    let mut chars = key.chars();
    let first = chars.next();
    let second = chars.next();
    match (first, key) {
        (_, "w") => "the wheelbase".into(),
        (_, "gamma") => "the head angle, degrees".into(),
        (_, "f") => "the fork offset".into(),
        (_, "g") => "the acceleration of gravity".into(),
        (_, "l") => "the distance from the front axle to the handlebar reference".into(),
        (_, "d") => "the steer axis' length between the offset lines".into(),
        _ if key.starts_with("alpha") => format!(
            "the angle of {} hung in orientation {}",
            part(key.chars().nth(5)),
            &key[6.min(key.len())..]
        ),
        (Some('T'), _) if key.starts_with("Tt") => {
            format!(
                "a torsional pendulum period of {}",
                part(key.chars().nth(2))
            )
        }
        (Some('T'), _) if key.starts_with("Tc") => {
            format!("a compound pendulum period of {}", part(key.chars().nth(2)))
        }
        (Some('m'), _) => format!("the mass of {}", part(second)),
        (Some('d'), _) if matches!(second, Some('F' | 'R')) => {
            format!("the rolling distance of {}", part(second))
        }
        (Some('n'), _) => format!("the number of turns of {}", part(second)),
        (Some('l'), _) => format!("the pendulum length of {}", part(second)),
        (Some('d'), "dP") => "the calibration rod's diameter".into(),
        (Some('a'), _) => format!("the pendulum axis' distance for {}", part(second)),
        (Some('h'), _) => "a table-top height of the geometry".into(),
        (Some('d'), _) => "a diameter of the geometry".into(),
        _ => "a measurement".into(),
    }
}

/// One key of a `*Measured.txt` file: its repeated values and where it was.
#[derive(Debug, Clone, PartialEq)]
pub struct Entry {
    /// `(value, standard error)` of each repeat; the error 0 when none was written.
    pub values: Vec<(f64, f64)>,
    pub line: usize,
}

impl Entry {
    /// The mean of the repeats and its standard error `√Σσᵢ² / n` (independent repeats), as
    /// BicycleParameters averages a comma list.
    pub fn mean(&self) -> Measured {
        let n = self.values.len() as f64;
        let value = self.values.iter().map(|v| v.0).sum::<f64>() / n;
        let var = self.values.iter().map(|v| v.1 * v.1).sum::<f64>();
        Measured::new(value, var.sqrt() / n)
    }
}

/// A parsed `*Measured.txt` file.
#[derive(Debug, Clone, PartialEq)]
pub struct MeasuredFile {
    pub path: PathBuf,
    pub entries: BTreeMap<String, Entry>,
}

/// Parses one number of a list; `col` is its column (1-based) for the message.
fn number(text: &str) -> Option<f64> {
    text.trim().parse::<f64>().ok().filter(|x| x.is_finite())
}

impl MeasuredFile {
    /// Parses the bytes of a file (`path` names it in messages).
    pub fn parse(bytes: &[u8], path: &Path) -> Result<MeasuredFile, MeasuredError> {
        let bytes = bytes.strip_prefix(b"\xEF\xBB\xBF").unwrap_or(bytes);
        let mut entries: BTreeMap<String, Entry> = BTreeMap::new();
        // Lines end in LF or CRLF, or in CR alone where a file has no LF (classic Mac OS text:
        // read as one line, its values ran into the next keys).
        let end = if bytes.contains(&b'\n') { b'\n' } else { b'\r' };
        for (i, raw) in bytes.split(|&b| b == end).enumerate() {
            let line_no = i + 1;
            let err = |column: usize, message: String| MeasuredError::Parse {
                path: path.to_path_buf(),
                line: line_no,
                column,
                message,
            };
            let text = std::str::from_utf8(raw).map_err(|e| {
                err(
                    e.valid_up_to() + 1,
                    "not UTF-8 text: a measurement file is plain text".into(),
                )
            })?;
            // A comment runs from `#` to the end of the line.
            let text = text.split('#').next().unwrap_or("");
            let text = text.trim_end_matches(['\r', ' ', '\t']);
            if text.trim().is_empty() {
                continue;
            }
            let Some((key_part, rest)) = text.split_once('=') else {
                return Err(err(
                    1,
                    format!("`{}`: expected `name = value+/-sigma`", excerpt(text)),
                ));
            };
            let key = key_part.trim();
            let key_col = 1 + key_part.len() - key_part.trim_start().len();
            if key.is_empty() || !key.chars().all(|c| c.is_ascii_alphanumeric() || c == '_') {
                return Err(err(
                    key_col,
                    format!("`{}` is not a parameter name", excerpt(key)),
                ));
            }
            if let Some(first) = entries.get(key) {
                return Err(err(
                    key_col,
                    format!(
                        "`{key}` is given twice (first on line {}): which is meant?",
                        first.line
                    ),
                ));
            }
            let mut values = Vec::new();
            let mut col = key_part.len() + 2;
            let mut with_se = None;
            for item in rest.split(',') {
                let item_col = col + item.len() - item.trim_start().len();
                col += item.len() + 1;
                let (v, s) = match item.split_once("+/-") {
                    Some((v, s)) => (v, Some(s)),
                    None => (item, None),
                };
                if let Some(prev) = with_se {
                    if prev != s.is_some() {
                        return Err(err(
                            item_col,
                            format!(
                                "`{key}`: some repeats have a standard error (`+/-`) and some \
                                 not: give one for each"
                            ),
                        ));
                    }
                }
                with_se = Some(s.is_some());
                let value = number(v).ok_or_else(|| {
                    err(
                        item_col,
                        format!("`{key}`: `{}` is not a number", excerpt(v.trim())),
                    )
                })?;
                let se = match s {
                    Some(s) => number(s).filter(|s| *s >= 0.0).ok_or_else(|| {
                        let se_col = item_col + item.trim_start().len() - s.len()
                            + (s.len() - s.trim_start().len());
                        err(
                            se_col,
                            format!(
                                "`{key}`: standard error `{}` is not a number ≥ 0",
                                excerpt(s.trim())
                            ),
                        )
                    })?,
                    None => 0.0,
                };
                if let Some(expected) = out_of_range(key, value, se) {
                    return Err(err(
                        item_col,
                        format!(
                            "`{key} = {}+/-{}`: expected {expected}",
                            excerpt(v.trim()),
                            s.map_or("0", |s| s.trim())
                        ),
                    ));
                }
                values.push((value, se));
            }
            entries.insert(
                key.to_string(),
                Entry {
                    values,
                    line: line_no,
                },
            );
        }
        Ok(MeasuredFile {
            path: path.to_path_buf(),
            entries,
        })
    }

    /// The bicycle's name: the file's name less `Measured.txt`.
    pub fn bicycle_name(&self) -> String {
        let stem = self
            .path
            .file_stem()
            .map(|s| s.to_string_lossy().into_owned())
            .unwrap_or_default();
        stem.strip_suffix("Measured").unwrap_or(&stem).to_string()
    }
}

/// What a measurement `key = value+/-se` should be when it is outside its physical range (the
/// families a bicycle's measurements have: masses `m…` in kg, pendulum periods `T…` in s,
/// angles `alpha…` and the head angle `gamma` in degrees), `None` when it is inside. Every
/// standard error is at most ten times its value plus one (an error of 1e308 made every
/// propagated error 0).
fn out_of_range(key: &str, value: f64, se: f64) -> Option<&'static str> {
    let family = |prefix: &str| {
        key.strip_prefix(prefix)
            .is_some_and(|rest| rest.starts_with(|c: char| c.is_ascii_uppercase()))
    };
    if !(se.is_finite() && se <= 10.0 * value.abs() + 1.0) {
        return Some("a standard error from 0 to ten times the value plus one");
    }
    if family("m") && !(value > 0.0 && value <= 1000.0) {
        return Some("a mass above 0 and at most 1000 kg");
    }
    if (family("Tc") || family("Tt") || family("T")) && !(0.01..=100.0).contains(&value) {
        return Some("a pendulum's period from 0.01 to 100 s");
    }
    if family("alpha") && !(-360.0..=360.0).contains(&value) {
        return Some("an angle within ±360°");
    }
    if key == "gamma" && !(value > 20.0 && value <= 90.0) {
        return Some("a head angle above 20° and at most 90° (from the ground)");
    }
    None
}

/// At most 40 characters of `s`, for messages.
fn excerpt(s: &str) -> String {
    if s.chars().count() <= 40 {
        s.to_string()
    } else {
        let head: String = s.chars().take(40).collect();
        format!("{head}… ({} bytes)", s.len())
    }
}

// ---------------------------------------------------------------------------------------------
// The conversion's layout: which inputs it reads, by index into the propagation's inputs.

/// How the steer axis and wheelbase were measured.
#[derive(Debug, Clone, Copy)]
enum GeometryLayout {
    /// Wheelbase `w`, head angle `gamma` (degrees), fork offset `f`.
    Direct { w: usize, gamma: usize, f: usize },
    /// Table-top heights `h1…h5`, diameters `d1…d4` and `d`; `lam` is the extra input that
    /// carries λ (BicycleParameters' convention, see the module doc).
    Offsets {
        h: [usize; 5],
        d: [usize; 5],
        lam: usize,
    },
}

/// The front frame: one body (`H`), or handlebar (`G`) and fork (`S`) measured apart.
#[derive(Debug, Clone, Copy)]
enum FrontLayout {
    Whole {
        m_h: usize,
        tc_h: usize,
    },
    Split {
        m_s: usize,
        m_g: usize,
        tc_s: usize,
        tc_g: usize,
        /// h6, h7, d5, d6, l: the handlebar reference point's place.
        reference: [usize; 5],
    },
}

/// A body hung in several orientations: per orientation its angle α (degrees), the pendulum
/// axis' distance `a` and the torsional period.
#[derive(Debug, Clone)]
struct PartLayout {
    part: char,
    orientations: Vec<[usize; 3]>,
}

/// Indices of every measurement the conversion reads.
#[derive(Debug, Clone)]
struct Layout {
    d_f: usize,
    n_f: usize,
    d_r: usize,
    n_r: usize,
    g: usize,
    m_b: usize,
    m_f: usize,
    m_r: usize,
    l_f: usize,
    l_r: usize,
    rod: [usize; 4], // mP, dP, lP, TtP1
    tc_b: usize,
    tc_f: usize,
    tc_r: usize,
    tt_f: usize,
    tt_r: usize,
    flywheel: Option<[usize; 3]>, // mD, TcD1, TtD1
    /// The point where a lateral force was applied (`xcl`, `zcl`), passed through as
    /// BicycleParameters does: it is already in the benchmark frame.
    lateral_force_point: Option<[usize; 2]>,
    geometry: GeometryLayout,
    front: FrontLayout,
    parts: Vec<PartLayout>,
    names: Vec<&'static str>,
}

/// Collects the inputs the conversion needs, in the order first asked for, and the keys that
/// are missing.
struct Collector<'a> {
    file: &'a MeasuredFile,
    inputs: Inputs,
    index: BTreeMap<String, usize>,
    missing: Vec<String>,
}

impl Collector<'_> {
    fn get(&mut self, key: &str) -> usize {
        if let Some(&i) = self.index.get(key) {
            return i;
        }
        match self.file.entries.get(key) {
            Some(e) => {
                let i = self.inputs.push(e.mean());
                self.index.insert(key.to_string(), i);
                i
            }
            None => {
                if !self.missing.iter().any(|m| m == key) {
                    self.missing.push(key.to_string());
                }
                usize::MAX
            }
        }
    }

    fn has(&self, key: &str) -> bool {
        self.file.entries.contains_key(key)
    }
}

/// Keys that must be positive, with what they are.
const POSITIVE: [&str; 12] = [
    "dF", "dR", "nF", "nR", "g", "lF", "lR", "lP", "dP", "mP", "mB", "w",
];

/// A bicycle's benchmark parameters computed from its raw measurements.
pub struct MeasuredBicycle {
    pub name: String,
    pub path: PathBuf,
    /// Every parameter (the benchmark set, and the handlebar `G`, fork `S` and flywheel `D`
    /// when they were measured apart), by name in BicycleParameters' spelling, sorted.
    pub parameters: BTreeMap<String, Measured>,
    /// The bicycle as a model whose inputs are its benchmark parameters with their covariance
    /// from the measurements (the correlations the conversion makes are kept).
    pub model: Parametrized,
}

/// Newton's method on `sin λ − (r_F − r_R + c cos λ)/(a + b) = 0` from `atan(c/(a + b))`:
/// the steer axis tilt from the offsets `a`, `b`, `c` (Moore 2012, eq. 2.3). `NaN` when it
/// does not converge in 50 steps.
pub fn steer_axis_tilt_from_offsets(r_f: f64, r_r: f64, a: f64, b: f64, c: f64) -> f64 {
    let f = |lam: f64| lam.sin() - (r_f - r_r + c * lam.cos()) / (a + b);
    let df = |lam: f64| lam.cos() + c * lam.sin() / (a + b);
    let mut lam = (c / (a + b)).atan();
    for _ in 0..50 {
        let step = f(lam) / df(lam);
        if !step.is_finite() {
            return f64::NAN;
        }
        lam -= step;
        if step.abs() <= 1e-15 * lam.abs().max(1.0) {
            return lam;
        }
    }
    f64::NAN
}

/// The offsets of the steer axis from the table-top measurements (Moore 2012, fig. 2.6): the
/// rear wheel's `a`, the front wheel's `b` (the fork offset) and the axis length `c` between
/// their feet.
fn offsets(h: [f64; 5], d: [f64; 5]) -> (f64, f64, f64) {
    let [h1, h2, h3, h4, h5] = h;
    let [d1, d2, d3, d4, dd] = d;
    let a = h1 + h2 - h3 + 0.5 * d1 - 0.5 * d2;
    let b = h4 - 0.5 * d3 - h5 + 0.5 * d4;
    let c = ((dd + 0.5 * (d2 + d3)).powi(2) - (a - b).powi(2)).sqrt();
    (a, b, c)
}

/// The handlebar reference point from the front wheel centre, perpendicular to (`l1`) and
/// along (`l2`) the steer axis, from the table-top heights of the axle `h6` and of the reference
/// circle `h7`, their diameters `d5`, `d6` and their outer distance `l`.
fn handlebar_reference(r: [f64; 5]) -> (f64, f64) {
    let [h6, h7, d5, d6, l] = r;
    let (r5, r6) = (d5 / 2.0, d6 / 2.0);
    let l1 = h7 - h6 + r5 - r6;
    let l0 = l - r5 - r6;
    (l1, l0 * (l1 / l0).asin().cos())
}

/// `(l1, l2)` in the benchmark frame: the handlebar reference from the front wheel centre,
/// `(u1, u2)` back and up.
fn reference_in_benchmark(lam: f64, l1: f64, l2: f64) -> (f64, f64) {
    let u1 = l2 * lam.sin() - l1 * lam.cos();
    let u2 = u1 / lam.tan() + l1 / lam.sin();
    (u1, u2)
}

/// The centre of mass as the mean of the pairwise intersections of the lines `z = m x + b`.
fn mean_intersection(lines: &[(f64, f64)]) -> (f64, f64) {
    let (mut sx, mut sz, mut n) = (0.0, 0.0, 0.0);
    for (i, &(mi, bi)) in lines.iter().enumerate() {
        for &(mj, bj) in &lines[i + 1..] {
            let x = (bj - bi) / (mi - mj);
            sx += x;
            sz += mi * x + bi;
            n += 1.0;
        }
    }
    (sx / n, sz / n)
}

/// The compound pendulum's moment about the centre of mass, `m g l (T/2π)² − m l²`.
fn compound_about_cg(m: f64, g: f64, l: f64, period_s: f64) -> f64 {
    parallel_axis_removed(compound_pendulum_inertia(m, l, 1.0 / period_s, g), m, l)
}

impl Layout {
    fn new(c: &mut Collector) -> Result<Layout, MeasuredError> {
        let path = c.file.path.clone();
        let d_f = c.get("dF");
        let n_f = c.get("nF");
        let d_r = c.get("dR");
        let n_r = c.get("nR");
        let direct = c.has("w") || c.has("gamma") || c.has("f");
        let geometry = if direct || !c.has("h1") {
            GeometryLayout::Direct {
                w: c.get("w"),
                gamma: c.get("gamma"),
                f: c.get("f"),
            }
        } else {
            let h = ["h1", "h2", "h3", "h4", "h5"].map(|k| c.get(k));
            let d = ["d1", "d2", "d3", "d4", "d"].map(|k| c.get(k));
            GeometryLayout::Offsets { h, d, lam: 0 }
        };
        let g = c.get("g");
        let m_b = c.get("mB");
        let m_f = c.get("mF");
        let m_r = c.get("mR");
        let split = c.has("mS") || c.has("mG");
        let front = if split {
            FrontLayout::Split {
                m_s: c.get("mS"),
                m_g: c.get("mG"),
                tc_s: c.get("TcS1"),
                tc_g: c.get("TcG1"),
                reference: ["h6", "h7", "d5", "d6", "l"].map(|k| c.get(k)),
            }
        } else {
            FrontLayout::Whole {
                m_h: c.get("mH"),
                tc_h: c.get("TcH1"),
            }
        };
        let l_f = c.get("lF");
        let l_r = c.get("lR");
        let tc_b = c.get("TcB1");
        let tc_f = c.get("TcF1");
        let tc_r = c.get("TcR1");
        let rod = ["mP", "dP", "lP", "TtP1"].map(|k| c.get(k));
        let tt_f = c.get("TtF1");
        let tt_r = c.get("TtR1");
        let flywheel = c
            .has("mD")
            .then(|| ["mD", "TcD1", "TtD1"].map(|k| c.get(k)));
        let lateral_force_point =
            (c.has("xcl") && c.has("zcl")).then(|| [c.get("xcl"), c.get("zcl")]);
        let part_names: &[char] = if split { &['B', 'G', 'S'] } else { &['B', 'H'] };
        let mut parts = Vec::new();
        for &p in part_names {
            let mut orientations = Vec::new();
            let mut n = 1;
            // The orientations are those with an angle (as BicycleParameters takes them: a
            // distance `a` without its angle is not an orientation).
            while c.has(&format!("alpha{p}{n}")) {
                orientations.push([
                    c.get(&format!("alpha{p}{n}")),
                    c.get(&format!("a{p}{n}")),
                    c.get(&format!("Tt{p}{n}")),
                ]);
                n += 1;
            }
            // An orientation numbered beyond a gap is a mistake, not an extra: the gap's
            // keys are reported missing.
            let beyond = c.file.entries.keys().any(|k| {
                k.strip_prefix(&format!("alpha{p}"))
                    .and_then(|r| r.parse::<usize>().ok())
                    .is_some_and(|m| m > n)
            });
            if beyond {
                for key in [
                    format!("alpha{p}{n}"),
                    format!("a{p}{n}"),
                    format!("Tt{p}{n}"),
                ] {
                    c.get(&key);
                }
            }
            if orientations.len() < 3 {
                for k in orientations.len() + 1..=3 {
                    for key in [
                        format!("alpha{p}{k}"),
                        format!("a{p}{k}"),
                        format!("Tt{p}{k}"),
                    ] {
                        c.get(&key);
                    }
                }
            }
            parts.push(PartLayout {
                part: p,
                orientations,
            });
        }
        if !c.missing.is_empty() {
            return Err(MeasuredError::Missing {
                path,
                keys: c.missing.clone(),
            });
        }
        let mut names: Vec<&'static str> = vec![
            "rF", "rR", "lam", "w", "c", "g", "mB", "mF", "mR", "mH", "xB", "zB", "xH", "zH",
            "IFyy", "IRyy", "IByy", "IHyy", "IFxx", "IRxx", "IBxx", "IBxz", "IBzz", "IHxx", "IHxz",
            "IHzz",
        ];
        if split {
            names.extend([
                "mG", "mS", "xG", "zG", "xS", "zS", "IGyy", "ISyy", "IGxx", "IGxz", "IGzz", "ISxx",
                "ISxz", "ISzz",
            ]);
        }
        if flywheel.is_some() {
            names.extend(["mD", "IDxx", "IDyy"]);
        }
        if lateral_force_point.is_some() {
            names.extend(["xcl", "zcl"]);
        }
        Ok(Layout {
            d_f,
            n_f,
            d_r,
            n_r,
            g,
            m_b,
            m_f,
            m_r,
            l_f,
            l_r,
            rod,
            tc_b,
            tc_f,
            tc_r,
            tt_f,
            tt_r,
            flywheel,
            lateral_force_point,
            geometry,
            front,
            parts,
            names,
        })
    }

    /// The wheel radii `(rF, rR)` from the rolling distances over `n` turns.
    fn radii(&self, x: &[f64]) -> (f64, f64) {
        (
            x[self.d_f] / (2.0 * PI * x[self.n_f]),
            x[self.d_r] / (2.0 * PI * x[self.n_r]),
        )
    }

    /// Every parameter in the order of `names` at the input values `x`.
    fn evaluate(&self, x: &[f64]) -> Vec<f64> {
        let mut out = BTreeMap::new();
        let (r_f, r_r) = self.radii(x);
        let (lam, w, fork_offset) = match self.geometry {
            GeometryLayout::Direct { w, gamma, f } => ((90.0 - x[gamma]).to_radians(), x[w], x[f]),
            GeometryLayout::Offsets { h, d, lam } => {
                let (a, b, c) = offsets(h.map(|i| x[i]), d.map(|i| x[i]));
                let lam = x[lam];
                (lam, (a + b) * lam.cos() + c * lam.sin(), b)
            }
        };
        let trail = (r_f * lam.sin() - fork_offset) / lam.cos();
        let g = x[self.g];
        out.insert("rF", r_f);
        out.insert("rR", r_r);
        out.insert("lam", lam);
        out.insert("w", w);
        out.insert("c", trail);
        out.insert("g", g);
        out.insert("mB", x[self.m_b]);
        out.insert("mF", x[self.m_f]);
        out.insert("mR", x[self.m_r]);
        let reference = match self.front {
            FrontLayout::Split { reference, .. } => {
                let (l1, l2) = handlebar_reference(reference.map(|i| x[i]));
                Some(reference_in_benchmark(lam, l1, l2))
            }
            FrontLayout::Whole { .. } => None,
        };
        // Centres of mass from the hanging lines.
        let mut cg = BTreeMap::new();
        let mut betas = BTreeMap::new();
        for p in &self.parts {
            let mut lines = Vec::new();
            let mut bs = Vec::new();
            for o in &p.orientations {
                let beta = lam - x[o[0]].to_radians();
                let a = x[o[1]];
                let slope = -beta.tan();
                let intercept = match p.part {
                    'B' => -a / beta.cos() - r_r,
                    'G' => {
                        let (u1, u2) = reference.unwrap_or((f64::NAN, f64::NAN));
                        -a / beta.cos() - (r_f + u2) + (w - u1) * beta.tan()
                    }
                    _ => -a / beta.cos() - r_f + w * beta.tan(),
                };
                lines.push((slope, intercept));
                bs.push(beta);
            }
            cg.insert(p.part, mean_intersection(&lines));
            betas.insert(p.part, bs);
        }
        let (x_b, z_b) = cg[&'B'];
        out.insert("xB", x_b);
        out.insert("zB", z_b);
        // The torsion pendulum, calibrated by the rod.
        let [m_p, d_p, l_p, t_p] = self.rod.map(|i| x[i]);
        let k = torsional_pendulum_stiffness(rod_inertia(m_p, d_p, l_p), 1.0 / t_p);
        let torsion = |t: f64| torsional_pendulum_inertia(k, 1.0 / t);
        // Wheels.
        let i_fyy = compound_about_cg(x[self.m_f], g, x[self.l_f], x[self.tc_f]);
        let i_fxx = torsion(x[self.tt_f]);
        out.insert("IFyy", i_fyy);
        out.insert(
            "IRyy",
            compound_about_cg(x[self.m_r], g, x[self.l_r], x[self.tc_r]),
        );
        out.insert("IFxx", i_fxx);
        out.insert("IRxx", torsion(x[self.tt_r]));
        if let Some([m_d, tc_d, tt_d]) = self.flywheel {
            out.insert("mD", x[m_d] - x[self.m_f]);
            out.insert(
                "IDyy",
                compound_about_cg(x[m_d], g, x[self.l_f], x[tc_d]) - i_fyy,
            );
            out.insert("IDxx", torsion(x[tt_d]) - i_fxx);
        }
        if let Some([xcl, zcl]) = self.lateral_force_point {
            out.insert("xcl", x[xcl]);
            out.insert("zcl", x[zcl]);
        }
        // The frame about the rear axle.
        let l_b = (x_b * x_b + (z_b + r_r).powi(2)).sqrt();
        out.insert("IByy", compound_about_cg(x[self.m_b], g, l_b, x[self.tc_b]));
        // In-plane tensors from the orientations.
        let mut tensors = BTreeMap::new();
        for p in &self.parts {
            let moments: Vec<f64> = p.orientations.iter().map(|o| torsion(x[o[2]])).collect();
            let axes: Vec<[f64; 3]> = betas[&p.part]
                .iter()
                .map(|b| [b.cos(), 0.0, -b.sin()])
                .collect();
            let t = solve_tensor(&axes, &moments, &vec![1.0; moments.len()], false)
                .unwrap_or([f64::NAN; 3]);
            tensors.insert(p.part, t);
        }
        match self.front {
            FrontLayout::Whole { m_h, tc_h } => {
                let (x_h, z_h) = cg[&'H'];
                let l_h = ((x_h - w).powi(2) + (z_h + r_f).powi(2)).sqrt();
                out.insert("mH", x[m_h]);
                out.insert("xH", x_h);
                out.insert("zH", z_h);
                out.insert("IHyy", compound_about_cg(x[m_h], g, l_h, x[tc_h]));
                let [xx, xz, zz] = tensors[&'H'];
                out.insert("IHxx", xx);
                out.insert("IHxz", xz);
                out.insert("IHzz", zz);
            }
            FrontLayout::Split {
                m_s,
                m_g,
                tc_s,
                tc_g,
                ..
            } => {
                let (u1, u2) = reference.unwrap_or((f64::NAN, f64::NAN));
                let ((x_s, z_s), (x_g, z_g)) = (cg[&'S'], cg[&'G']);
                let (m_s, m_g) = (x[m_s], x[m_g]);
                let l_s = ((x_s - w).powi(2) + (z_s + r_f).powi(2)).sqrt();
                let l_g = ((x_g - w + u1).powi(2) + (z_g + r_f + u2).powi(2)).sqrt();
                let i_syy = compound_about_cg(m_s, g, l_s, x[tc_s]);
                let i_gyy = compound_about_cg(m_g, g, l_g, x[tc_g]);
                let [sxx, sxz, szz] = tensors[&'S'];
                let [gxx, gxz, gzz] = tensors[&'G'];
                for (k, v) in [
                    ("mS", m_s),
                    ("mG", m_g),
                    ("xS", x_s),
                    ("zS", z_s),
                    ("xG", x_g),
                    ("zG", z_g),
                    ("ISyy", i_syy),
                    ("IGyy", i_gyy),
                    ("ISxx", sxx),
                    ("ISxz", sxz),
                    ("ISzz", szz),
                    ("IGxx", gxx),
                    ("IGxz", gxz),
                    ("IGzz", gzz),
                ] {
                    out.insert(k, v);
                }
                // The front frame: the two bodies combined about their joint centre of mass.
                let m_h = m_s + m_g;
                let x_h = (m_s * x_s + m_g * x_g) / m_h;
                let z_h = (m_s * z_s + m_g * z_g) / m_h;
                let steiner = |m: f64, dx: f64, dz: f64| [m * dz * dz, -m * dx * dz, m * dx * dx];
                let s = steiner(m_s, x_s - x_h, z_s - z_h);
                let gg = steiner(m_g, x_g - x_h, z_g - z_h);
                let dyy = |m: f64, xc: f64, zc: f64| m * ((xc - x_h).powi(2) + (zc - z_h).powi(2));
                out.insert("mH", m_h);
                out.insert("xH", x_h);
                out.insert("zH", z_h);
                out.insert("IHxx", sxx + s[0] + gxx + gg[0]);
                out.insert("IHxz", sxz + s[1] + gxz + gg[1]);
                out.insert("IHzz", szz + s[2] + gzz + gg[2]);
                out.insert(
                    "IHyy",
                    i_syy + dyy(m_s, x_s, z_s) + i_gyy + dyy(m_g, x_g, z_g),
                );
            }
        }
        let [xx, xz, zz] = tensors[&'B'];
        out.insert("IBxx", xx);
        out.insert("IBxz", xz);
        out.insert("IBzz", zz);
        self.names
            .iter()
            .map(|n| out.get(n).copied().unwrap_or(f64::NAN))
            .collect()
    }
}

impl MeasuredBicycle {
    /// Converts a parsed file.
    pub fn from_file(file: &MeasuredFile) -> Result<MeasuredBicycle, MeasuredError> {
        let mut c = Collector {
            file,
            inputs: Inputs::new(),
            index: BTreeMap::new(),
            missing: Vec::new(),
        };
        let mut layout = Layout::new(&mut c)?;
        // Values that must be positive, with their line.
        for key in POSITIVE {
            if let Some(e) = file.entries.get(key) {
                if let Some(bad) = e.values.iter().find(|v| v.0 <= 0.0) {
                    return Err(MeasuredError::Invalid {
                        path: file.path.clone(),
                        line: e.line,
                        key: key.into(),
                        message: format!("{} must be above zero, not {}", describe(key), bad.0),
                    });
                }
            }
        }
        // Masses and periods were checked where they were read (`out_of_range`).
        let mut inputs = c.inputs;
        if let GeometryLayout::Offsets { h, d, .. } = layout.geometry {
            // BicycleParameters' convention: λ is a quantity of its own, its standard error
            // that of the guess atan(c/(a + b)) (kept so that the errors agree with that lab's).
            let l = layout.clone();
            let values = inputs.values().to_vec();
            let (r_f, r_r) = l.radii(&values);
            let (a, b, cc) = offsets(h.map(|i| values[i]), d.map(|i| values[i]));
            let lam = steer_axis_tilt_from_offsets(r_f, r_r, a, b, cc);
            let (_, cov) = propagate(&inputs, |x| {
                let (a, b, c) = offsets(h.map(|i| x[i]), d.map(|i| x[i]));
                vec![(c / (a + b)).atan()]
            });
            let lam_index = inputs.push(Measured::new(lam, cov[(0, 0)].max(0.0).sqrt()));
            layout.geometry = GeometryLayout::Offsets {
                h,
                d,
                lam: lam_index,
            };
        }
        let (values, cov) = propagate(&inputs, |x| layout.evaluate(x));
        if let Some(k) = values.iter().position(|v| !v.is_finite()) {
            return Err(MeasuredError::NoBicycle {
                path: file.path.clone(),
                message: format!(
                    "the measurements give no `{}`: check the geometry's and the pendulums' \
                     numbers (a square root of a negative number, a division by zero or \
                     orientations that do not determine a tensor)",
                    layout.names[k]
                ),
            });
        }
        let parameters = layout
            .names
            .iter()
            .enumerate()
            .map(|(k, n)| {
                (
                    n.to_string(),
                    Measured::new(values[k], cov[(k, k)].max(0.0).sqrt()),
                )
            })
            .collect();
        let name = file.bicycle_name();
        // The model's inputs are the 26 benchmark parameters with their covariance from the
        // measurements: to first order the same propagation as from the measurements
        // themselves, at a quarter of the derivatives.
        let index: Vec<usize> = Benchmark::NAMES
            .iter()
            .map(|n| {
                layout
                    .names
                    .iter()
                    .position(|m| m == n)
                    .unwrap_or(usize::MAX)
            })
            .collect();
        let sub_values: Vec<f64> = index.iter().map(|&i| values[i]).collect();
        let sub_cov = nalgebra::DMatrix::from_fn(26, 26, |r, c| cov[(index[r], index[c])]);
        let mut model_inputs = Inputs::new();
        model_inputs.push_correlated(&sub_values, &sub_cov);
        let model = Parametrized::from_inputs(
            &name,
            model_inputs,
            std::sync::Arc::new(|x: &[f64]| {
                let mut a = [0.0; 26];
                a.copy_from_slice(&x[..26]);
                Benchmark::from_array(&a)
            }),
        );
        Ok(MeasuredBicycle {
            name,
            path: file.path.clone(),
            parameters,
            model,
        })
    }

    /// The benchmark parameter set with its standard errors (the 26 of Meijaard et al. 2007).
    pub fn benchmark(&self) -> Benchmark {
        let mut a = [0.0; 26];
        let mut se = [0.0; 26];
        for (k, n) in Benchmark::NAMES.iter().enumerate() {
            if let Some(m) = self.parameters.get(*n) {
                a[k] = m.value;
                se[k] = m.se;
            }
        }
        let mut b = Benchmark::from_array(&a);
        b.se = se;
        b
    }

    /// BicycleParameters' `*Benchmark.txt` format: every parameter, sorted by name,
    /// `name = value+/-se` with the shortest text that reads back to the same number.
    pub fn to_benchmark_text(&self) -> String {
        self.parameters
            .iter()
            .map(|(n, m)| format!("{n} = {:?}+/-{:?}\n", m.value, m.se))
            .collect()
    }
}

/// A measured bicycle's parameters and its stability, as `bikeproc measured` gives them.
#[derive(Debug, Clone, serde::Serialize)]
pub struct MeasuredReport {
    pub name: String,
    pub source: PathBuf,
    /// Every parameter with its standard error, by BicycleParameters' name.
    pub parameters: BTreeMap<String, Measured>,
    /// Speed ranges (m/s) where the linearized Whipple model is stable, searched up to
    /// `max_speed_mps`; the upper end `None` when stable up to there.
    pub stable_ranges_mps: Vec<(f64, Option<f64>)>,
    pub max_speed_mps: f64,
    pub weave_speed_mps: Option<f64>,
    pub weave_speed_se_mps: Option<f64>,
    pub capsize_speed_mps: Option<f64>,
    pub capsize_speed_se_mps: Option<f64>,
}

impl MeasuredBicycle {
    /// The parameters and the stability up to `max_speed_mps` (searched in steps of `step_mps`),
    /// the weave and capsize speeds' standard errors propagated from the measurements.
    pub fn report(
        &self,
        max_speed_mps: f64,
        step_mps: f64,
    ) -> Result<MeasuredReport, crate::model::ParamError> {
        let s = self.model.speeds(max_speed_mps, step_mps)?;
        Ok(MeasuredReport {
            name: self.name.clone(),
            source: self.path.clone(),
            parameters: self.parameters.clone(),
            stable_ranges_mps: s.stability.stable_ranges_mps.clone(),
            max_speed_mps,
            weave_speed_mps: s.stability.weave_speed_mps,
            weave_speed_se_mps: s.weave_speed_se_mps,
            capsize_speed_mps: s.stability.capsize_speed_mps,
            capsize_speed_se_mps: s.capsize_speed_se_mps,
        })
    }
}

/// The unit of a parameter, by its BicycleParameters name.
pub fn unit(name: &str) -> &'static str {
    match name.chars().next() {
        Some('I') => "kg·m²",
        Some('m') => "kg",
        Some('g') => "m/s²",
        _ if name == "lam" => "rad",
        _ => "m",
    }
}
