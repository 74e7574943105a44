//! Test manifests: what the lab did and wrote down for the tests in one folder
//! (`DIR/manifest.toml`, format version 1). SI units, the unit in every key's name.
//!
//! ```toml
//! version = 1
//! kind = "torsion"              # bar_calibration | torsion | compound | empty_fixture
//! body = "frame"
//! mass_kg = 5.48
//! calibration = "../bar_calibration/calibration.toml"   # torsion: the bar's stiffness
//! # Uncertainties of what was written down (defaults shown): scale, tape, photographs.
//! mass_se_kg = 0.02
//! distance_se_m = 0.005
//! axis_angle_se_deg = 1.0
//!
//! [[test]]                      # one orientation (torsion) or plane (compound)
//! name = "1"
//! logs = ["frame_1a.log", "frame_1b.log"]   # repeats
//! axis = [0.7964, 0.0, -0.6048] # torsion: the bar's axis in body coordinates (unit vector)
//! weights_kg = 3.231            # torsion: added weights, as point masses …
//! weights_distance_m = 0.37     # … at this distance from the bar's axis
//! cg_distance_m = 0.2           # torsion: the body's centre of gravity from the bar's axis
//! # compound: pivot_to_cg_m = 0.37 and moment = "iyy" (or "ixx_izz": a wheel across its plane)
//! ```
//!
//! A `bar_calibration` manifest has `[rod]` (`mass_kg`, `diameter_m`, `length_m`), `[bar]`
//! (`shear_modulus_pa`, `diameter_m`, `length_m`), optionally `fixture = "../empty_fixture"`,
//! and its `[[test]]`s. An `empty_fixture` manifest has tests of the bare Cardan joint and clamp,
//! with calibration weights (`weights_kg`, `weights_distance_m`, and their own
//! `weights_distance_se_m` when machined).

use serde::Deserialize;
use std::path::{Path, PathBuf};

/// The manifest's file name in a test folder.
pub const MANIFEST: &str = "manifest.toml";

/// What a folder's tests are.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Deserialize, serde::Serialize)]
#[serde(rename_all = "snake_case")]
pub enum Kind {
    BarCalibration,
    Torsion,
    Compound,
    EmptyFixture,
}

/// Which inertia a compound-pendulum test gives.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Deserialize, serde::Serialize)]
#[serde(rename_all = "snake_case")]
pub enum Moment {
    /// About the body's y axis (swinging in its plane).
    Iyy,
    /// A wheel swinging across its plane: I_xx = I_zz (eq. 83).
    IxxIzz,
}

#[derive(Debug, Clone, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct Rod {
    pub mass_kg: f64,
    pub diameter_m: f64,
    pub length_m: f64,
    /// Scale resolution for the rod (default 0.02 kg, like the bodies).
    pub mass_se_kg: Option<f64>,
    /// Calliper on the rod (default 0.0001 m).
    pub dimension_se_m: Option<f64>,
}

#[derive(Debug, Clone, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct Bar {
    pub shear_modulus_pa: f64,
    pub diameter_m: f64,
    pub length_m: f64,
}

/// One orientation or plane, with its repeats.
#[derive(Debug, Clone, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct Test {
    pub name: String,
    pub logs: Vec<PathBuf>,
    pub axis: Option<[f64; 3]>,
    pub weights_kg: Option<f64>,
    pub weights_distance_m: Option<f64>,
    pub weights_distance_se_m: Option<f64>,
    pub cg_distance_m: Option<f64>,
    pub pivot_to_cg_m: Option<f64>,
    pub moment: Option<Moment>,
    /// A channel to fit instead of the rotation about the dominant axis (e.g. `Gyr_Z`).
    pub channel: Option<String>,
    /// The sensor, by id or label, when the logs have several.
    pub sensor: Option<String>,
}

#[derive(Debug, Clone, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct Manifest {
    pub version: u32,
    pub kind: Kind,
    pub body: Option<String>,
    pub mass_kg: Option<f64>,
    pub calibration: Option<PathBuf>,
    pub fixture: Option<PathBuf>,
    pub mass_se_kg: Option<f64>,
    pub distance_se_m: Option<f64>,
    pub axis_angle_se_deg: Option<f64>,
    pub rod: Option<Rod>,
    pub bar: Option<Bar>,
    #[serde(rename = "test")]
    pub tests: Vec<Test>,
    /// Free text: who, when, what was odd.
    pub notes: Option<String>,
    /// The tests' logs may lie outside the manifest's folder (refused unless set: a manifest
    /// from elsewhere cannot make bikeproc read any file on the machine).
    #[serde(default)]
    pub allow_outside_folder: bool,
    /// Where the manifest was read from (set by [`Manifest::load`]).
    #[serde(skip)]
    pub dir: PathBuf,
}

/// A problem with a manifest, naming the file, the line when known, and the key.
#[derive(Debug, Clone, thiserror::Error)]
#[error("{path}{}: {message}", line.map(|l| format!(":{l}")).unwrap_or_default())]
pub struct ManifestError {
    pub path: PathBuf,
    pub line: Option<usize>,
    pub message: String,
}

impl ManifestError {
    /// An error in the manifest `path` whose text is `text`, at the line of the first
    /// occurrence of `needle` (none when it does not occur).
    pub fn at(path: &Path, text: &str, needle: &str, message: String) -> ManifestError {
        ManifestError::at_nth(path, text, needle, 0, message)
    }

    /// [`ManifestError::at`] the line of the occurrence `nth` (from 0) of `needle`: the second
    /// listing of a name given twice, where the first is not the error.
    pub fn at_nth(
        path: &Path,
        text: &str,
        needle: &str,
        nth: usize,
        message: String,
    ) -> ManifestError {
        ManifestError {
            path: path.to_path_buf(),
            line: text
                .match_indices(needle)
                .nth(nth)
                .map(|(i, _)| 1 + text[..i].matches('\n').count()),
            message,
        }
    }
}

/// The text of the manifest `path`; `what` names the manifest in the error ("the ride
/// manifest").
pub fn read_text(path: &Path, what: &str) -> Result<String, ManifestError> {
    std::fs::read_to_string(path).map_err(|e| ManifestError {
        path: path.to_path_buf(),
        line: None,
        message: format!("cannot read {what}: {e}"),
    })
}

/// Checks a manifest's `version` (bikeproc reads version 1).
pub fn check_version(path: &Path, text: &str, version: u32) -> Result<(), ManifestError> {
    if version == 1 {
        Ok(())
    } else {
        Err(ManifestError::at(
            path,
            text,
            "version",
            format!("version {version} (bikeproc reads version 1)"),
        ))
    }
}

/// Unit suffixes people write, and the SI suffix bikeproc takes instead.
const UNIT_HINTS: &[(&str, &str)] = &[
    ("_g", "_kg"),
    ("_mm", "_m"),
    ("_cm", "_m"),
    ("_gpa", "_pa"),
    ("_mpa", "_pa"),
    ("_rad", "_deg"),
    ("_kgmm2", "_kgm2"),
];

/// Parses a manifest's TOML text, an error naming the file, the line and the key (with a hint
/// when a key carries a non-SI unit).
pub fn from_toml<T: serde::de::DeserializeOwned>(
    file: &Path,
    text: &str,
) -> Result<T, ManifestError> {
    toml::from_str(text).map_err(|e| {
        let line = e
            .span()
            .map(|s| 1 + text[..s.start.min(text.len())].matches('\n').count());
        let mut message = e.message().trim().to_string();
        if let Some(key) = message
            .strip_prefix("unknown field `")
            .and_then(|r| r.split('`').next())
        {
            // The hint only where the key it suggests is one this table takes (serde lists
            // them): `rol_nm_per_rad` is a typo of `roll_nm_per_rad`, not a unit to change.
            let want = UNIT_HINTS
                .iter()
                .find(|(bad, _)| key.ends_with(bad))
                .map(|(bad, good)| format!("{}{good}", &key[..key.len() - bad.len()]))
                .filter(|want| message.contains(&format!("`{want}`")));
            if let Some(want) = want {
                message = format!("`{key}`: wrong unit; bikeproc takes SI units, write `{want}`");
            } else {
                message = format!(
                    "unknown key `{key}` ({})",
                    message.lines().next().unwrap_or("")
                );
            }
        }
        ManifestError {
            path: file.to_path_buf(),
            line,
            message: message.replace('\n', " "),
        }
    })
}

pub use crate::stats::number_text;

/// Whether the relative path `rel` stays inside the folder it is relative to: not absolute,
/// and no `..` that climbs above it.
pub fn within_folder(rel: &Path) -> bool {
    use std::path::Component;
    let mut depth = 0usize;
    for c in rel.components() {
        match c {
            Component::Normal(_) => depth += 1,
            Component::CurDir => {}
            Component::ParentDir if depth > 0 => depth -= 1,
            _ => return false,
        }
    }
    true
}

impl Manifest {
    /// Reads `DIR/manifest.toml` (or the file itself when `path` is a file) and checks it.
    pub fn load(path: &Path) -> Result<Manifest, ManifestError> {
        let file = if path.is_dir() {
            path.join(MANIFEST)
        } else {
            path.to_path_buf()
        };
        let dir = file.parent().map(Path::to_path_buf).unwrap_or_default();
        let text = std::fs::read_to_string(&file).map_err(|e| ManifestError {
            path: file.clone(),
            line: None,
            message: format!("cannot read the test manifest: {e}"),
        })?;
        let mut m: Manifest = from_toml(&file, &text)?;
        m.dir = dir;
        m.check(&file, &text)?;
        Ok(m)
    }

    fn check(&self, file: &Path, text: &str) -> Result<(), ManifestError> {
        // Line of the first occurrence of `needle` after the `[[test]]` holding test `name`.
        let line_of = |needle: &str, test: Option<&str>| -> Option<usize> {
            let start = test
                .and_then(|n| text.find(&format!("name = \"{n}\"")))
                .unwrap_or(0);
            text[start..]
                .find(needle)
                .map(|i| 1 + text[..start + i].matches('\n').count())
        };
        let err = |key: &str, test: Option<&str>, message: String| ManifestError {
            path: file.to_path_buf(),
            line: line_of(key, test),
            message,
        };
        if self.version != 1 {
            return Err(err(
                "version",
                None,
                format!(
                    "`version = {}`: this bikeproc reads manifest version 1",
                    self.version
                ),
            ));
        }
        if self.tests.is_empty() {
            return Err(err(
                "kind",
                None,
                "no `[[test]]`: a manifest lists at least one test".into(),
            ));
        }
        let positive =
            |key: &str, v: Option<f64>, test: Option<&str>| -> Result<f64, ManifestError> {
                match v {
                    None => Err(err(
                        if test.is_some() { "name" } else { "kind" },
                        test,
                        format!(
                            "missing key `{key}`{}",
                            test.map(|t| format!(" in test \"{t}\""))
                                .unwrap_or_default()
                        ),
                    )),
                    Some(x) if x.is_finite() && x > 0.0 => Ok(x),
                    Some(x) => Err(err(
                        key,
                        test,
                        format!("`{key} = {x}`: expected a positive number"),
                    )),
                }
            };
        // A standard error from 0 to `max`; `table` names the table the key is in.
        let standard_error = |table: &str, key: &str, v: Option<f64>, max: f64| match v {
            Some(x) if !(x.is_finite() && (0.0..=max).contains(&x)) => Err(err(
                key,
                None,
                format!(
                    "`{table}{key} = {}`: a standard error from 0 to {max}",
                    number_text(x)
                ),
            )),
            _ => Ok(()),
        };
        standard_error("", "mass_se_kg", self.mass_se_kg, 10.0)?;
        standard_error("", "distance_se_m", self.distance_se_m, 1.0)?;
        standard_error("", "axis_angle_se_deg", self.axis_angle_se_deg, 45.0)?;
        let mut names = std::collections::BTreeSet::new();
        for t in &self.tests {
            if !names.insert(t.name.as_str()) {
                return Err(ManifestError {
                    path: file.to_path_buf(),
                    line: text
                        .match_indices(&format!("name = \"{}\"", t.name))
                        .nth(1)
                        .map(|(i, _)| 1 + text[..i].matches('\n').count()),
                    message: format!("test \"{}\" twice: each test has its own name", t.name),
                });
            }
        }
        // A recording in two places (twice in a test, or in two tests) would count as two
        // repeats of one set-up, or give two set-ups the same period.
        let folder = file.parent().unwrap_or(Path::new("."));
        let mut logs: Vec<(PathBuf, &str)> = Vec::new();
        for t in &self.tests {
            for log in &t.logs {
                let path = folder.join(log);
                let key = std::fs::canonicalize(&path).unwrap_or(path);
                if let Some((_, first)) = logs.iter().find(|(k, _)| *k == key) {
                    let shown = log.display().to_string();
                    return Err(ManifestError {
                        path: file.to_path_buf(),
                        line: text
                            .match_indices(&shown)
                            .nth(1)
                            .map(|(i, _)| 1 + text[..i].matches('\n').count()),
                        message: if *first == t.name {
                            format!(
                                "test \"{}\" lists {shown} twice: each recording once",
                                t.name
                            )
                        } else {
                            format!(
                                "{shown} is in test \"{first}\" and in test \"{}\": each \
                                 recording belongs to one test",
                                t.name
                            )
                        },
                    });
                }
                logs.push((key, &t.name));
            }
        }
        let non_negative = |key: &str, v: Option<f64>, test: &str| -> Result<(), ManifestError> {
            match v {
                Some(x) if !(x.is_finite() && x >= 0.0) => Err(err(
                    key,
                    Some(test),
                    format!("`{key} = {x}`: expected zero or more"),
                )),
                _ => Ok(()),
            }
        };
        // Upper bounds of the physical range: a lab's bodies, weights and distances, a metal
        // bar's shear modulus (aluminium 26 GPa to steel 80 GPa, with room either side).
        let at_most = |key: &str, v: Option<f64>, max: f64, test: Option<&str>| match v {
            Some(x) if x > max => Err(err(
                key,
                test,
                format!(
                    "`{key} = {}`: expected at most {max} (SI units){}",
                    number_text(x),
                    test.map(|t| format!(" in test \"{t}\""))
                        .unwrap_or_default()
                ),
            )),
            _ => Ok(()),
        };
        at_most("mass_kg", self.mass_kg, 1000.0, None)?;
        if let Some(rod) = &self.rod {
            at_most("mass_kg", Some(rod.mass_kg), 1000.0, None)?;
            at_most("diameter_m", Some(rod.diameter_m), 1.0, None)?;
            at_most("length_m", Some(rod.length_m), 10.0, None)?;
            standard_error("[rod] ", "mass_se_kg", rod.mass_se_kg, rod.mass_kg.abs())?;
            standard_error(
                "[rod] ",
                "dimension_se_m",
                rod.dimension_se_m,
                rod.diameter_m.abs(),
            )?;
        }
        if let Some(bar) = &self.bar {
            let g = bar.shear_modulus_pa;
            if g.is_finite() && !(1e9..=2e11).contains(&g) {
                return Err(err(
                    "shear_modulus_pa",
                    None,
                    format!(
                        "`shear_modulus_pa = {}`: a metal bar's is 1e9 to 2e11 Pa (steel 8e10)",
                        number_text(g)
                    ),
                ));
            }
            at_most("diameter_m", Some(bar.diameter_m), 1.0, None)?;
            at_most("length_m", Some(bar.length_m), 10.0, None)?;
        }
        for t in &self.tests {
            let n = Some(t.name.as_str());
            at_most("cg_distance_m", t.cg_distance_m, 2.0, n)?;
            at_most("pivot_to_cg_m", t.pivot_to_cg_m, 3.0, n)?;
            at_most("weights_kg", t.weights_kg, 100.0, n)?;
            at_most("weights_distance_m", t.weights_distance_m, 2.0, n)?;
        }
        match self.kind {
            Kind::BarCalibration => {
                let rod = self.rod.as_ref().ok_or_else(|| {
                    err(
                        "kind",
                        None,
                        "missing table `[rod]` (mass_kg, diameter_m, length_m)".into(),
                    )
                })?;
                positive("rod.mass_kg", Some(rod.mass_kg), None)?;
                positive("rod.diameter_m", Some(rod.diameter_m), None)?;
                positive("rod.length_m", Some(rod.length_m), None)?;
                if let Some(bar) = &self.bar {
                    positive("bar.shear_modulus_pa", Some(bar.shear_modulus_pa), None)?;
                    positive("bar.diameter_m", Some(bar.diameter_m), None)?;
                    positive("bar.length_m", Some(bar.length_m), None)?;
                }
            }
            Kind::Torsion | Kind::Compound => {
                positive("mass_kg", self.mass_kg, None)?;
                if self.body.is_none() {
                    return Err(err(
                        "kind",
                        None,
                        "missing key `body` (frame, handlebar, rear_wheel, front_wheel, …)".into(),
                    ));
                }
            }
            Kind::EmptyFixture => {}
        }
        if self.kind == Kind::Torsion && self.calibration.is_none() {
            return Err(err("kind", None, "missing key `calibration`: the bar calibration file (written by `bikeproc calibrate-bar`)".into()));
        }
        for t in &self.tests {
            let n = Some(t.name.as_str());
            if t.logs.is_empty() {
                return Err(err(
                    "logs",
                    n,
                    format!("test \"{}\": `logs` is empty", t.name),
                ));
            }
            for log in &t.logs {
                let p = self.dir.join(log);
                if !p.is_file() {
                    return Err(err(
                        &log.display().to_string(),
                        n,
                        format!("test \"{}\": log {} does not exist", t.name, p.display()),
                    ));
                }
            }
            match self.kind {
                Kind::Torsion => {
                    let axis = t.axis.ok_or_else(|| {
                        err(
                            "name",
                            n,
                            format!("missing key `axis` in test \"{}\"", t.name),
                        )
                    })?;
                    let len = (axis[0] * axis[0] + axis[1] * axis[1] + axis[2] * axis[2]).sqrt();
                    if !axis.iter().all(|x| x.is_finite()) || (len - 1.0).abs() > 1e-3 {
                        return Err(err("axis", n, format!("test \"{}\": `axis` {axis:?} has length {len:.4}; expected a unit vector (within 0.001)", t.name)));
                    }
                    if axis[1].abs() > 1e-3 {
                        return Err(err("axis", n, format!("test \"{}\": `axis` {axis:?} leaves the body's xz plane of symmetry; the tensor solve (eq. 69) takes axes (x, 0, z)", t.name)));
                    }
                    if t.cg_distance_m.is_none() {
                        return Err(err(
                            "name",
                            n,
                            format!("missing key `cg_distance_m` in test \"{}\"", t.name),
                        ));
                    }
                    non_negative("cg_distance_m", t.cg_distance_m, &t.name)?;
                    non_negative("weights_kg", t.weights_kg, &t.name)?;
                    non_negative("weights_distance_m", t.weights_distance_m, &t.name)?;
                }
                Kind::Compound => {
                    positive("pivot_to_cg_m", t.pivot_to_cg_m, n)?;
                    if t.moment.is_none() {
                        return Err(err(
                            "name",
                            n,
                            format!(
                                "missing key `moment` in test \"{}\" (iyy or ixx_izz)",
                                t.name
                            ),
                        ));
                    }
                }
                Kind::EmptyFixture => {
                    non_negative("weights_kg", t.weights_kg, &t.name)?;
                    non_negative("weights_distance_m", t.weights_distance_m, &t.name)?;
                }
                Kind::BarCalibration => {}
            }
            if !self.allow_outside_folder {
                if let Some(log) = t.logs.iter().find(|l| !within_folder(l)) {
                    return Err(err(
                        &log.display().to_string(),
                        n,
                        format!(
                            "test \"{}\": log {} lies outside the manifest's folder (set \
                             `allow_outside_folder = true` if that is meant)",
                            t.name,
                            log.display()
                        ),
                    ));
                }
            }
        }
        Ok(())
    }

    /// The path of a log named in the manifest.
    pub fn log_path(&self, log: &Path) -> PathBuf {
        self.dir.join(log)
    }

    pub fn mass_se_kg(&self) -> f64 {
        self.mass_se_kg.unwrap_or(0.02)
    }

    pub fn distance_se_m(&self) -> f64 {
        self.distance_se_m.unwrap_or(0.005)
    }

    pub fn axis_angle_se_rad(&self) -> f64 {
        self.axis_angle_se_deg.unwrap_or(1.0).to_radians()
    }
}
