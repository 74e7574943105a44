//! `period`, `calibrate-bar`, `inertia`, `measured`: recordings and measurement folders to
//! periods, the bar's stiffness, inertia tensors and a bicycle's benchmark parameters.

use super::args::{CalibrateArgs, InertiaArgs, MeasuredArgs, PeriodArgs};
use super::io::{advance, emit, note, progress, refuse_files_over_inputs, write_atomic};
use anyhow::{bail, Context, Result};
use bikeproc::fit::{self, FitOptions, PeriodBatch};
use bikeproc::inertia::{self, text};
use bikeproc::read::kind::{self, Kind};
use bikeproc::signal::Extract;
use bikeproc::uncertainty::Measured;
use std::path::{Path, PathBuf};

pub fn period(a: PeriodArgs) -> Result<()> {
    let extract = a
        .channel
        .clone()
        .map_or(Extract::DominantRotation, Extract::Channel);
    let options = FitOptions {
        trend: a.trend.into(),
        segment_s: a.segment,
        min_freq_hz: None,
    };
    let measure = |file: &Path| -> Result<fit::OscillationSummary> {
        let (summary, warnings) = fit::measure_file(file, &extract, a.sensor.as_deref(), &options)?;
        for w in &warnings {
            note!("warning: {w}");
        }
        Ok(summary)
    };
    if let [file] = a.files.as_slice() {
        if !file.is_dir() {
            let summary = measure(file)?;
            return emit(a.json, &summary, || summary.to_text(file));
        }
    }
    let files = trial_files(&a.files)?;
    let bar = progress(a.json);
    let (mut trials, mut failed) = (Vec::new(), Vec::new());
    for (k, file) in files.iter().enumerate() {
        advance(&bar, "recordings", k + 1, files.len());
        match measure(file) {
            Ok(s) => trials.push((stem(file), Measured::new(s.period_s, s.period_se_s))),
            Err(e) => failed.push(format!("{e:#}")),
        }
    }
    bar.finish_and_clear();
    let batch = PeriodBatch::new(&trials, failed);
    emit(a.json, &batch, || batch.to_text())?;
    for f in &batch.failed {
        note!("error: {f}");
    }
    if !batch.failed.is_empty() {
        bail!(
            "{} of {} recordings gave no period",
            batch.failed.len(),
            files.len()
        )
    }
    Ok(())
}

fn stem(file: &Path) -> String {
    file.file_stem()
        .map_or(String::new(), |x| x.to_string_lossy().into_owned())
}

/// The recordings named (files, and the IMU logs and CSV tables of folders, by their content;
/// a `_cal` log beside its angles log left to it), in name order within each folder.
fn trial_files(paths: &[PathBuf]) -> Result<Vec<PathBuf>> {
    let mut out = Vec::new();
    for p in paths {
        if !p.is_dir() {
            out.push(p.clone());
            continue;
        }
        let mut inside: Vec<PathBuf> = std::fs::read_dir(p)
            .with_context(|| format!("{}", p.display()))?
            .filter_map(|e| e.ok().map(|e| e.path()))
            // Recordings by their content: IMU logs (not a ride's calibrated companion) and
            // tables of time series.
            .filter(|f| {
                let companion = kind::angles_beside(f);
                matches!(
                    kind::recognise(f),
                    Kind::PendulumLog | Kind::RideAngles | Kind::Table
                ) && (companion == *f || !companion.is_file())
            })
            .collect();
        inside.sort();
        if inside.is_empty() {
            bail!(
                "{}: no recordings in the folder (IMU logs or CSV tables)",
                p.display()
            );
        }
        out.extend(inside);
    }
    Ok(out)
}

pub fn calibrate_bar(a: CalibrateArgs) -> Result<()> {
    kind::expect(
        &a.dir,
        &|k| matches!(k, Kind::TestFolder(t) | Kind::TestManifest(t) if t == "bar_calibration" || t == "empty_fixture"),
        "a bar-calibration folder",
    )?;
    let cal = inertia::calibrate_bar(&a.dir)?;
    let out = a.dir.join(inertia::CALIBRATION_FILE);
    write_atomic(&out, cal.to_toml().as_bytes())?;
    emit(a.json, &text::calibration_json(&cal), || {
        text::calibration_text(&cal)
    })?;
    note!("wrote {}", out.display());
    Ok(())
}

pub fn inertia(a: InertiaArgs) -> Result<()> {
    if let Some(bike_path) = a.bike {
        let mut bike = inertia::bike::LabBike::load(&bike_path)?;
        let dir = bike_path
            .parent()
            .map(Path::to_path_buf)
            .unwrap_or_default();
        for w in &bike.refresh(&dir)? {
            note!("warning: {w}");
        }
        write_atomic(&bike_path, bike.to_toml().as_bytes())?;
        emit(a.json, &bike, || bike.to_toml())?;
        note!("refreshed the inertias of {}", bike_path.display());
        return Ok(());
    }
    let dir = a.dir.unwrap_or_default();
    kind::expect(
        &dir,
        &|k| {
            matches!(
                k,
                Kind::TestFolder(_) | Kind::TestManifest(_) | Kind::Folder
            )
        },
        "a pendulum test folder",
    )?;
    let r = inertia::analyse_folder(&dir, &a.orientations)?;
    for w in r.warnings() {
        note!("warning: {w}");
    }
    emit(a.json, &r.json(), || r.text())
}

pub fn measured(a: MeasuredArgs) -> Result<()> {
    kind::expect(
        &a.file,
        &|k| matches!(k, Kind::MeasuredBicycle),
        "a bicycle's raw measurements",
    )?;
    let format = match &a.out {
        Some(out) => {
            refuse_files_over_inputs(&[out], &[&a.file], None)?;
            Some(bikeproc::model::params::BikeFileFormat::for_output(out)?)
        }
        None => None,
    };
    let bike = inertia::measured::MeasuredBicycle::load(&a.file)?;
    let report = bike.report(10.0, 0.01)?;
    if let (Some(out), Some(format)) = (&a.out, format) {
        let text = match format {
            bikeproc::model::params::BikeFileFormat::Toml => bike.benchmark().to_toml(),
            bikeproc::model::params::BikeFileFormat::Text => bike.to_benchmark_text(),
        };
        write_atomic(out, text.as_bytes())?;
        note!("wrote {}", out.display());
    }
    emit(a.json, &report, || inertia::text::measured_text(&report))
}
