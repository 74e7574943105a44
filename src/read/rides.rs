//! Campaign manifests (`rides.toml`): the bicycle, the rides' files with their noted speeds,
//! the speedometer, the controller and the known changes of a campaign.
//!
//! In: the manifest's path. Out: [`RideManifest`], checked where it is read (version, at least
//! one ride, readings in range, each file present, inside the manifest's folder unless allowed,
//! no ride twice, known masses on the bicycle, the controller's gains), its errors naming the
//! manifest's line.

use super::manifest::{from_toml, ManifestError};
use crate::model::control::{ControlError, ControllerEntry};
use crate::model::uncertain::Parametrized;
use crate::model::SteerControl;
use crate::ride::speed::{GivenSpeed, NotedReading};
use std::path::{Path, PathBuf};

/// A campaign of rides (`rides.toml`, version 1): the bicycle and each ride's log with the
/// speedometer's reading the lab noted at the release; optionally the speedometer's display
/// step and its error per reading (defaults: 0.1 m/s and 1 %, [`NotedReading::lab`]), another
/// instrument's CSV rides, a steer controller the bicycle carries ([`crate::model::control`])
/// and known added masses. The format, with an example:
/// [docs/formats/rides-manifest.md](../../docs/formats/rides-manifest.md).
#[derive(Debug, Clone, serde::Deserialize)]
#[serde(deny_unknown_fields)]
pub struct RideManifest {
    pub version: u32,
    pub bike: PathBuf,
    /// The speedometer's display step (m/s).
    #[serde(default = "default_resolution")]
    pub speedometer_resolution_mps: f64,
    /// The speedometer's random error per reading, as a fraction of it.
    #[serde(default = "default_se_fraction")]
    pub speedometer_se_fraction: f64,
    #[serde(rename = "ride")]
    pub rides: Vec<RideEntry>,
    /// The bicycle's steer controller, if it carries one.
    #[serde(default)]
    pub controller: Option<crate::model::control::ControllerEntry>,
    /// Known changes of this campaign's bicycle from the bicycle file: point masses at stated
    /// places (`[[known_mass]]`: `frame = "rear"` or `"front"`, `mass_kg`, `x_m`, `z_m` in the
    /// benchmark's axes, x forward and z down from the rear contact).
    #[serde(default, rename = "known_mass")]
    pub known_masses: Vec<crate::model::params::PointMass>,
    /// The bicycle's geared steer motor, if the lab declares it (`[steer_motor]`:
    /// `rotor_inertia_kg_m2`, `gear_ratio`): the gap diagnosis takes the inertia it adds about
    /// the steer axis from it.
    #[serde(default)]
    pub steer_motor: Option<crate::model::control::SteerMotorSpec>,
    /// The rides' files may lie outside the manifest's folder (refused unless set: a
    /// manifest from elsewhere cannot make bikeproc read any file on the machine).
    #[serde(default)]
    pub allow_outside_folder: bool,
    /// The controller, checked ([`SteerControl::NONE`] without one).
    #[serde(skip)]
    pub control: SteerControl,
    #[serde(skip)]
    pub dir: PathBuf,
}

fn default_resolution() -> f64 {
    NotedReading::lab(0.0).resolution_mps
}

fn default_se_fraction() -> f64 {
    NotedReading::lab(0.0).se_fraction
}

/// One ride of a campaign.
#[derive(Debug, Clone, serde::Deserialize)]
#[serde(deny_unknown_fields)]
pub struct RideEntry {
    /// The IMU log, or another instrument's CSV (by its content).
    pub log: PathBuf,
    /// The speedometer's reading noted at the release (m/s): an IMU log's ride needs it. A CSV
    /// ride needs it, `set_speed_mps` or a wheel-speed column (whose speed is used where
    /// there is one, the speed given shown beside it).
    #[serde(default)]
    pub noted_speed_mps: Option<f64>,
    /// The speed the lab set for a CSV ride (m/s; a treadmill's setting), with the
    /// speedometer's display step and error per reading: rides of one set speed repeat one
    /// set-up.
    #[serde(default)]
    pub set_speed_mps: Option<f64>,
    /// A CSV ride: columns by other names (as `--columns`).
    #[serde(default)]
    pub columns: Option<String>,
    /// A CSV ride: the free decay's window (s).
    #[serde(default)]
    pub window_s: Option<[f64; 2]>,
    /// A table without a time column: its sampling rate (Hz), as `--rate`.
    #[serde(default)]
    pub rate_hz: Option<f64>,
}

impl RideEntry {
    /// Whether the ride is another instrument's table of time series, by its content
    /// ([`super::kind::Kind::Table`]; a microcontroller's `.log` of comma-separated channels is
    /// one, whatever its name). `dir` is the manifest's folder.
    pub fn is_csv(&self, dir: &Path) -> bool {
        super::kind::recognise(&dir.join(&self.log)) == super::kind::Kind::Table
    }

    /// The speed given for a CSV ride, with the manifest's display step and error per reading:
    /// its set speed, else its noted reading.
    pub fn given_speed(&self, manifest: &RideManifest) -> Option<GivenSpeed> {
        let reading = |speed_mps| NotedReading {
            speed_mps,
            resolution_mps: manifest.speedometer_resolution_mps,
            se_fraction: manifest.speedometer_se_fraction,
        };
        match (self.set_speed_mps, self.noted_speed_mps) {
            (Some(v), _) => Some(GivenSpeed::set(reading(v))),
            (None, Some(v)) => Some(GivenSpeed::noted(reading(v))),
            (None, None) => None,
        }
    }

    /// The ride's name: its log's file name without the extension (`ride_03`), and for a
    /// window of a longer recording its start (`uncontrolled_18kmh@141.28s`).
    pub fn name(&self) -> String {
        let stem = self
            .log
            .file_stem()
            .map(|s| s.to_string_lossy().into_owned())
            .unwrap_or_default();
        match self.window_s {
            Some([a, _]) => format!("{stem}@{a:.2}s"),
            None => stem,
        }
    }
}

impl RideManifest {
    /// Reads and checks a campaign manifest: version, at least one ride, positive speeds, the
    /// logs present.
    pub fn load(path: &Path) -> Result<RideManifest, ManifestError> {
        let text = crate::read::manifest::read_text(path, "the ride manifest")?;
        let mut m: RideManifest = from_toml(path, &text)?;
        m.dir = path.parent().map(Path::to_path_buf).unwrap_or_default();
        let line_of = |needle: &str| ManifestError::at(path, &text, needle, String::new()).line;
        let err = |needle: &str, message: String| ManifestError::at(path, &text, needle, message);
        crate::read::manifest::check_version(path, &text, m.version)?;
        for (key, x, range) in [
            (
                "speedometer_resolution_mps",
                m.speedometer_resolution_mps,
                0.0..=2.0,
            ),
            (
                "speedometer_se_fraction",
                m.speedometer_se_fraction,
                0.0..=0.5,
            ),
        ] {
            if !range.contains(&x) {
                return Err(err(key, format!("{key} = {x} is outside {:?}", range)));
            }
        }
        if m.rides.is_empty() {
            return Err(err("", "no [[ride]] in the manifest".into()));
        }
        if let Some(motor) = &m.steer_motor {
            if let Err((key, e)) = motor.check() {
                return Err(err(key, format!("[steer_motor]: {e}")));
            }
        }
        for r in &m.rides {
            let name = r.log.display().to_string();
            for (key, v) in [
                ("noted_speed_mps", r.noted_speed_mps),
                ("set_speed_mps", r.set_speed_mps),
            ] {
                if let Some(Err(e)) = v.map(crate::ride::speed::check_reading_mps) {
                    return Err(err(&name, format!("{name}: {key}: {e}")));
                }
            }
            if r.noted_speed_mps.is_some() && r.set_speed_mps.is_some() {
                return Err(err(
                    &name,
                    format!(
                        "{name}: noted_speed_mps and set_speed_mps: give one (a speedometer's \
                         reading at the release, or the speed the lab set, a treadmill's)"
                    ),
                ));
            }
            if !m.allow_outside_folder && !crate::read::manifest::within_folder(&r.log) {
                return Err(err(
                    &name,
                    format!(
                        "the log {name} lies outside the manifest's folder (set \
                         `allow_outside_folder = true` if that is meant)"
                    ),
                ));
            }
            if !m.dir.join(&r.log).exists() {
                return Err(err(&name, format!("the log {name} does not exist")));
            }
            if let Some(c) = &r.columns {
                if let Err(e) = c.parse::<crate::ride::csv::Columns>() {
                    return Err(err(c, format!("{name}: columns: {e}")));
                }
            }
            if let Some([a, b]) = r.window_s {
                if !(a.is_finite() && b.is_finite() && b > a) {
                    return Err(err(
                        "window_s",
                        format!("{name}: window_s = [{a}, {b}] is not a window"),
                    ));
                }
            }
            if let Some(rate) = r.rate_hz {
                if let Err(e) = crate::ride::csv::check_rate_hz(rate) {
                    return Err(err("rate_hz", format!("{name}: rate_hz: {e}")));
                }
            }
            if !r.is_csv(&m.dir) {
                if r.columns.is_some()
                    || r.window_s.is_some()
                    || r.rate_hz.is_some()
                    || r.set_speed_mps.is_some()
                {
                    return Err(err(
                        &name,
                        format!(
                            "{name}: columns, window_s, rate_hz and set_speed_mps are for CSV \
                             rides (an IMU log's ride takes noted_speed_mps)"
                        ),
                    ));
                }
                if r.noted_speed_mps.is_none() {
                    return Err(err(
                        &name,
                        format!(
                            "{name}: no noted_speed_mps: an IMU log's ride needs the \
                             speedometer's reading at the release (m/s)"
                        ),
                    ));
                }
            } else if r.given_speed(&m).is_none() {
                // Without a speed given the file must carry its own: its header is read for a
                // wheel-speed column (named, or mapped with `columns`).
                let columns = r
                    .columns
                    .as_deref()
                    .map_or(
                        Ok(Default::default()),
                        str::parse::<super::ride_csv::Columns>,
                    )
                    .unwrap_or_default();
                match super::ride_csv::quantities(&m.dir.join(&r.log), &columns, r.rate_hz) {
                    Ok(found) if found.contains(&super::ride_csv::Quantity::WheelSpeed) => {}
                    Ok(found) => {
                        return Err(err(
                            &name,
                            format!(
                                "{name}: no speed: the file has no wheel-speed column (it has {}); \
                                 give set_speed_mps (a treadmill's setting), noted_speed_mps, \
                                 or map the wheel's column with columns = \"wheel_speed=NAME\"",
                                found
                                    .iter()
                                    .map(|q| q.key())
                                    .collect::<Vec<_>>()
                                    .join(", ")
                            ),
                        ))
                    }
                    Err(e) => return Err(err(&name, format!("{name}: {e}"))),
                }
            }
        }
        // A ride twice (its log, and for a CSV its window) would count its evidence twice.
        let mut seen: Vec<(std::path::PathBuf, Option<[u64; 2]>)> = Vec::new();
        for (k, r) in m.rides.iter().enumerate() {
            let file = m.dir.join(&r.log);
            let key = (
                std::fs::canonicalize(&file).unwrap_or(file),
                r.window_s.map(|w| w.map(f64::to_bits)),
            );
            if seen.contains(&key) {
                let name = r.log.display().to_string();
                // The line of this listing, not the first one's: the rides before it that
                // wrote the same name.
                let nth = m.rides[..k].iter().filter(|o| o.log == r.log).count();
                return Err(ManifestError::at_nth(
                    path,
                    &text,
                    &name,
                    nth,
                    format!(
                        "{name} is listed twice{}: each ride once (its evidence would count \
                         twice)",
                        if r.window_s.is_some() {
                            " with the same window"
                        } else {
                            ""
                        }
                    ),
                ));
            }
            seen.push(key);
        }
        for k in &m.known_masses {
            let fine = (k.mass_kg.is_finite() && k.mass_kg > 0.0 && k.mass_kg <= 200.0)
                && (k.x_m.is_finite() && k.x_m.abs() <= 3.0)
                && (k.z_m.is_finite() && (-3.0..0.0).contains(&k.z_m));
            if !fine {
                return Err(err(
                    "[[known_mass]]",
                    format!(
                        "[[known_mass]] mass_kg = {}, x_m = {}, z_m = {}: a mass (0–200 kg) at a \
                         place on the bicycle (|x| ≤ 3 m, z from −3 m up to the ground, z down)",
                        k.mass_kg, k.x_m, k.z_m
                    ),
                ));
            }
        }
        match &m.controller {
            Some(ControllerEntry::Table(spec)) => {
                m.control = SteerControl::from_spec(spec, path).map_err(|e| ManifestError {
                    path: path.to_path_buf(),
                    line: line_of("[controller]"),
                    message: match e {
                        ControlError::Invalid { message, .. } => message,
                        other => other.to_string(),
                    },
                })?;
            }
            Some(ControllerEntry::File(file)) => {
                let named = format!("controller = \"{}\"", file.display());
                if !m.allow_outside_folder && !crate::read::manifest::within_folder(file) {
                    return Err(err(
                        "controller",
                        format!(
                            "{named}: the controller lies outside the manifest's folder (set \
                             `allow_outside_folder = true` if that is meant)"
                        ),
                    ));
                }
                // The controller file's own error names it, with its line.
                m.control = SteerControl::load(&m.dir.join(file))
                    .map_err(|e| err("controller", format!("{named}: {e}")))?
                    .0;
            }
            None => {}
        }
        Ok(m)
    }

    /// The bicycle file, relative to the manifest.
    pub fn bike_path(&self) -> PathBuf {
        self.dir.join(&self.bike)
    }

    /// The campaign's model: `bike` (the manifest's when `None`) with the manifest's
    /// controller.
    pub fn model(&self, bike: Option<&Path>) -> Result<Parametrized, crate::model::ParamError> {
        let path = bike.map_or_else(|| self.bike_path(), Path::to_path_buf);
        Ok(crate::read::bicycle::load(&path)?
            .with_masses(&self.known_masses)
            .with_control(self.control))
    }
}
