//! The torsion bar's calibration file (`bikeproc calibrate-bar --out`, format version 1): its
//! stiffness and the fixture's inertia with their errors and correlation.
//!
//! In: the file's path. Out: the checked [`BarCalibration`]: every number finite and in its
//! physical range, its standard error from 0 to the value's size; errors name the line.

use super::manifest;
use crate::inertia::{BarCalibration, InertiaError};
use std::path::Path;

impl BarCalibration {
    /// Reads a calibration file.
    pub fn load(path: &Path) -> Result<BarCalibration, InertiaError> {
        #[derive(serde::Deserialize)]
        #[serde(deny_unknown_fields)]
        struct File {
            version: u32,
            stiffness_nm_per_rad: f64,
            stiffness_se_nm_per_rad: f64,
            fixture_inertia_kgm2: f64,
            fixture_inertia_se_kgm2: f64,
            stiffness_fixture_correlation: f64,
            freq_hz: f64,
            freq_se_hz: f64,
            rod_inertia_kgm2: f64,
            rod_inertia_se_kgm2: f64,
            theory_stiffness_nm_per_rad: Option<f64>,
        }
        let invalid = |message: String| InertiaError::Invalid {
            path: path.to_path_buf(),
            message,
        };
        let text = std::fs::read_to_string(path).map_err(|e| {
            invalid(format!(
                "cannot read the bar calibration ({e}); run `bikeproc calibrate-bar` first"
            ))
        })?;
        let f: File = toml::from_str(&text).map_err(|e| {
            let line = e
                .span()
                .map(|s| 1 + text[..s.start.min(text.len())].matches('\n').count())
                .unwrap_or(0);
            invalid(format!("line {line}: {}", e.message().replace('\n', " ")))
        })?;
        if f.version != 1 {
            return Err(invalid(format!(
                "version {}: this bikeproc reads version-1 calibrations",
                f.version
            )));
        }
        // Every number where it is read: finite, in its physical range, its standard error
        // from 0 to the value's size (a calibration with an error larger than its value has
        // measured nothing).
        let line_of = |key: &str| {
            text.lines()
                .position(|l| l.split('=').next().is_some_and(|k| k.trim() == key))
                .map_or(0, |i| i + 1)
        };
        let check = |key: &str, v: f64, ok: bool, expected: &str| -> Result<(), InertiaError> {
            if v.is_finite() && ok {
                Ok(())
            } else {
                Err(invalid(format!(
                    "line {}: {key} = {}: expected {expected}",
                    line_of(key),
                    manifest::number_text(v)
                )))
            }
        };
        let k = f.stiffness_nm_per_rad;
        check(
            "stiffness_nm_per_rad",
            k,
            k > 0.0 && k < 1e6,
            "a stiffness above 0 N·m/rad",
        )?;
        let se_ok = |se: f64, v: f64| se >= 0.0 && se <= v.abs();
        check(
            "stiffness_se_nm_per_rad",
            f.stiffness_se_nm_per_rad,
            se_ok(f.stiffness_se_nm_per_rad, k),
            "a standard error from 0 to the stiffness",
        )?;
        let rod = f.rod_inertia_kgm2;
        check(
            "rod_inertia_kgm2",
            rod,
            rod > 0.0,
            "an inertia above 0 kg·m²",
        )?;
        check(
            "rod_inertia_se_kgm2",
            f.rod_inertia_se_kgm2,
            se_ok(f.rod_inertia_se_kgm2, rod),
            "a standard error from 0 to the rod's inertia",
        )?;
        check(
            "fixture_inertia_kgm2",
            f.fixture_inertia_kgm2,
            f.fixture_inertia_kgm2.abs() <= rod,
            "an inertia smaller than the rod's (the empty fixture's, near 0)",
        )?;
        check(
            "fixture_inertia_se_kgm2",
            f.fixture_inertia_se_kgm2,
            se_ok(f.fixture_inertia_se_kgm2, rod),
            "a standard error from 0 to the rod's inertia",
        )?;
        check(
            "stiffness_fixture_correlation",
            f.stiffness_fixture_correlation,
            (-1.0..=1.0).contains(&f.stiffness_fixture_correlation),
            "a correlation from −1 to 1",
        )?;
        check(
            "freq_hz",
            f.freq_hz,
            f.freq_hz > 0.0,
            "a frequency above 0 Hz",
        )?;
        check(
            "freq_se_hz",
            f.freq_se_hz,
            se_ok(f.freq_se_hz, f.freq_hz),
            "a standard error from 0 to the frequency",
        )?;
        if let Some(t) = f.theory_stiffness_nm_per_rad {
            check(
                "theory_stiffness_nm_per_rad",
                t,
                t > 0.0 && t < 1e6,
                "a stiffness above 0 N·m/rad",
            )?;
        }
        Ok(BarCalibration {
            stiffness_nm_per_rad: f.stiffness_nm_per_rad,
            stiffness_se_nm_per_rad: f.stiffness_se_nm_per_rad,
            freq_hz: f.freq_hz,
            freq_se_hz: f.freq_se_hz,
            rod_inertia_kgm2: f.rod_inertia_kgm2,
            rod_inertia_se_kgm2: f.rod_inertia_se_kgm2,
            theory_stiffness_nm_per_rad: f.theory_stiffness_nm_per_rad,
            fixture_inertia_kgm2: f.fixture_inertia_kgm2,
            fixture_inertia_se_kgm2: f.fixture_inertia_se_kgm2,
            stiffness_fixture_correlation: f.stiffness_fixture_correlation,
            fixture_freq_hz: None,
            tests: vec![],
        })
    }
}
