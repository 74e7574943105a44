//! Bicycle files → the model's parameters: BicycleParameters' benchmark text
//! (`IBxx = 0.53+/-0.002`) and raw measurements (`*Measured.txt`), the benchmark in TOML
//! (`name = value`, `name_se = sigma`), the lab's bicycle (a TOML with a `[geometry]` table) and
//! rider files.
//!
//! In: a path. Out: a [`Parametrized`] model ([`load`], any of them), or one format's own value
//! ([`Benchmark::load`], [`Rider::load`], [`LabBike::load`], [`MeasuredFile::load`],
//! [`MeasuredBicycle::load`]). The format is the content's ([`super::kind::recognise`]), never
//! the file's name; each format's parser is beside its value and checks every number it reads.

use super::kind::{recognise, Kind};
use crate::inertia::bike::{check_numbers, LabBike};
use crate::inertia::measured::{MeasuredBicycle, MeasuredError, MeasuredFile};
use crate::inertia::InertiaError;
use crate::model::params::{Benchmark, ParamError, Rider};
use crate::model::uncertain::Parametrized;
use std::path::{Path, PathBuf};

/// Loads any bicycle file as a parametrized model, by what the file holds: a lab bicycle keeps
/// its measured inputs; BicycleParameters' raw measurements become their benchmark parameters
/// with standard errors (what `bikeproc measured --out` writes); anything else is read as
/// benchmark parameters, whose parser says what is wrong if they are not.
pub fn load(path: &Path) -> Result<Parametrized, ParamError> {
    let name = path
        .file_stem()
        .map(|s| s.to_string_lossy().into_owned())
        .unwrap_or_default();
    match recognise(path) {
        Kind::MeasuredBicycle => {
            let bike =
                MeasuredBicycle::load(path).map_err(|e| ParamError::Measured(e.to_string()))?;
            Ok(Parametrized::from_benchmark(&bike.name, &bike.benchmark()))
        }
        Kind::LabBike => {
            let bike = LabBike::load(path).map_err(|e| ParamError::Invalid {
                path: path.to_path_buf(),
                message: e.to_string(),
            })?;
            let p = Parametrized::from_lab(&name, &bike);
            p.benchmark_at(p.inputs.values()).validate(path)?;
            Ok(p)
        }
        _ => Ok(Parametrized::from_benchmark(&name, &Benchmark::load(path)?)),
    }
}

/// The text of `path`, or why it cannot be read.
fn text_of(path: &Path) -> Result<String, ParamError> {
    std::fs::read_to_string(path).map_err(|e| ParamError::Invalid {
        path: path.to_path_buf(),
        message: format!("cannot read: {e}"),
    })
}

/// Whether benchmark parameters are written as TOML rather than BicycleParameters' text: only
/// TOML has `name_se = sigma` keys or `[table]` headers, only the text has `value+/-sigma`.
/// Without either (`name = value` lines alone) both read the same values, and the text's
/// parser, which also knows a file of a rider's parameters, reads it.
fn is_toml(text: &str) -> bool {
    !text.contains("+/-")
        && text.lines().any(|l| {
            let l = l.trim_start();
            l.starts_with('[')
                || l.split_once('=')
                    .is_some_and(|(key, _)| key.trim().ends_with("_se"))
        })
}

impl Benchmark {
    /// Reads a file of benchmark parameters, TOML or BicycleParameters' text by its content
    /// ([`Benchmark::parse_toml`], [`Benchmark::parse_text`]). The lab's bicycle format is a
    /// parametrization that converts to this one and is refused here: [`load`] reads every
    /// format.
    pub fn load(path: &Path) -> Result<Benchmark, ParamError> {
        let text = text_of(path)?;
        if text.lines().any(|l| l.trim() == "[geometry]") {
            return Err(ParamError::Invalid {
                path: path.to_path_buf(),
                message: "a lab bicycle file (it has a [geometry] table), not benchmark \
                          parameters: they come from it through the lab's parametrization \
                          (seed §3)"
                    .into(),
            });
        }
        if is_toml(&text) {
            Benchmark::parse_toml(&text, path)
        } else {
            Benchmark::parse_text(&text, path)
        }
    }
}

impl Rider {
    /// Reads a rider file ([`Rider::parse_text`]).
    pub fn load(path: &Path) -> Result<Rider, ParamError> {
        Rider::parse_text(&text_of(path)?, path)
    }
}

impl Parametrized {
    /// The same bicycle with the rider of the file `path` ([`Rider::load`]) joined to its rear
    /// frame, named so ("NAME with the rider of FILE").
    pub fn with_rider_file(self, path: &Path) -> Result<Parametrized, ParamError> {
        let rider = Rider::load(path)?;
        let file = path.file_name().map_or_else(
            || path.display().to_string(),
            |f| f.to_string_lossy().into(),
        );
        let mut p = self.with_rider(&rider);
        p.name = format!("{} with the rider of {file}", p.name);
        Ok(p)
    }
}

impl LabBike {
    /// Reads the lab's bicycle file (format version 1; every number checked finite, its line
    /// named).
    pub fn load(path: &Path) -> Result<LabBike, InertiaError> {
        let invalid = |message: String| InertiaError::Invalid {
            path: path.to_path_buf(),
            message,
        };
        let text =
            std::fs::read_to_string(path).map_err(|e| invalid(format!("cannot read: {e}")))?;
        let bike: LabBike = toml::from_str(&text).map_err(|e| {
            let line = e
                .span()
                .map(|s| 1 + text[..s.start.min(text.len())].matches('\n').count())
                .unwrap_or(0);
            InertiaError::Invalid {
                path: PathBuf::from(format!("{}:{line}", path.display())),
                message: e.message().replace('\n', " "),
            }
        })?;
        if bike.version != 1 {
            return Err(invalid(format!(
                "version {}: this bikeproc reads version 1",
                bike.version
            )));
        }
        if let Ok(value) = text.parse::<toml::Table>() {
            check_numbers(&value, "").map_err(|(key, message)| {
                let line = text
                    .find(&format!("{} =", key.rsplit('.').next().unwrap_or(&key)))
                    .map_or(0, |i| 1 + text[..i].matches('\n').count());
                InertiaError::Invalid {
                    path: PathBuf::from(format!("{}:{line}", path.display())),
                    message: format!("`{key}`: {message}"),
                }
            })?;
        }
        Ok(bike)
    }
}

impl MeasuredFile {
    /// Reads a file.
    pub fn load(path: &Path) -> Result<MeasuredFile, MeasuredError> {
        let bytes = std::fs::read(path).map_err(|e| MeasuredError::Read {
            path: path.to_path_buf(),
            message: e.to_string(),
        })?;
        MeasuredFile::parse(&bytes, path)
    }
}

impl MeasuredBicycle {
    /// Reads and converts a `*Measured.txt` file.
    pub fn load(path: &Path) -> Result<MeasuredBicycle, MeasuredError> {
        MeasuredBicycle::from_file(&MeasuredFile::load(path)?)
    }
}
