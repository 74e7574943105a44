//! `dynamic` and `gap`: rides (a log pair, another instrument's CSV, or a campaign manifest) to
//! their weave eigenvalues against the model, and a campaign to its sim-to-real gap.

use super::args::{DynamicArgs, GapArgs};
use super::io::{advance, emit, note, progress};
use super::model::load_model;
use super::{NoRideAnalysed, Refused};
use anyhow::Result;
use bikeproc::read::kind::{self, Kind};
use bikeproc::read::rides::RideManifest;
use bikeproc::read::study::Study;
use bikeproc::ride::csv::{self, KickReport};
use bikeproc::ride::dynamic::{self, DynamicOptions};
use bikeproc::ride::modal::ModalOptions;
use bikeproc::ride::speed::{GivenSpeed, NotedReading};

pub fn gap(a: GapArgs) -> Result<()> {
    let bar = progress(a.json);
    let study_file = match &a.files[..] {
        [one] => {
            kind::expect(
                one,
                &|k| matches!(k, Kind::RideManifest | Kind::StudyManifest),
                "a campaign of rides or a study of several",
            )?;
            (kind::recognise(one) == Kind::StudyManifest).then(|| one.clone())
        }
        many => {
            for f in many {
                kind::expect(
                    f,
                    &|k| matches!(k, Kind::RideManifest),
                    "a campaign of rides (one per condition)",
                )?;
            }
            None
        }
    };
    let options = bikeproc::gap::GapOptions {
        pairs: if a.every_triple {
            bikeproc::gap::PairSearch::EveryTriple
        } else if a.every_pair {
            bikeproc::gap::PairSearch::Every
        } else {
            bikeproc::gap::PairSearch::Standard
        },
        ..Default::default()
    };
    let d = if let (None, [file]) = (&study_file, &a.files[..]) {
        let manifest = RideManifest::load(file)?;
        let model = manifest.model(a.bike.as_deref())?;
        warn_if_exact(
            &model,
            &a.bike.clone().unwrap_or_else(|| manifest.bike_path()),
        );
        bikeproc::gap::diagnose_campaign_with(&manifest, &model, &options, &|what, done, total| {
            advance(&bar, what, done, total)
        })?
    } else {
        let study = match &study_file {
            Some(f) => Study::load(f)?,
            None => Study::from_manifests(&a.files)?,
        };
        let bike = match &a.bike {
            Some(b) => b.clone(),
            None => study.bike_path()?,
        };
        let model = bikeproc::read::bicycle::load(&bike)?;
        warn_if_exact(&model, &bike);
        bikeproc::gap::diagnose_manifests_with(
            &study.conditions,
            &model,
            &options,
            &|what, done, total| advance(&bar, what, done, total),
        )?
    };
    bar.finish_and_clear();
    emit(a.json, &d, || d.to_text())?;
    if d.rides_used == 0 {
        let file = study_file.unwrap_or_else(|| a.files[0].clone());
        return Err(NoRideAnalysed(file).into());
    }
    Ok(())
}

/// A bicycle file without a standard error anywhere: its model is taken as exact, which the
/// gap's tests then assume; said, since they read as if the measurement's errors were in.
fn warn_if_exact(model: &bikeproc::model::uncertain::Parametrized, bike: &std::path::Path) {
    let cov = model.inputs.covariance();
    if (0..cov.nrows()).all(|i| cov[(i, i)] == 0.0) {
        note!(
            "warning: {}: no standard errors in the bicycle file: its parameters are taken as \
             exact, and the tests carry the rides' errors alone",
            bike.display()
        );
    }
}

pub fn dynamic(a: DynamicArgs) -> Result<()> {
    let modal = ModalOptions {
        resamples: a.resamples as usize,
        ..ModalOptions::default()
    };
    kind::expect(
        &a.file,
        &|k| matches!(k, Kind::RideAngles | Kind::RideManifest | Kind::Table),
        "a ride (its angles log, a CSV of its signals, or a campaign's rides manifest)",
    )?;
    // What the file is, by its content: a table of time series whatever its name (another
    // lab's `.log` of channels), a campaign's manifest, or else an IMU log.
    let kind = kind::recognise(&a.file);
    if kind == Kind::Unknown {
        // Not recognised: a file that is not text at all is told so before anything else
        // (the bicycle beside it, the log reader).
        if let Err(e) = kind::open_text(&a.file) {
            let line = e.line.map_or(String::new(), |l| format!(":{l}"));
            return Err(kind::WrongKind(format!("{}{line}: {e}", a.file.display())).into());
        }
    }
    if kind == Kind::Table {
        return csv_ride(&a, &modal);
    }
    // What only a CSV ride takes is refused, not ignored, on a log or a manifest.
    for (given, flag) in [
        (
            a.rate.is_some(),
            "--rate is for a table of time series without a time column",
        ),
        (
            a.window.is_some(),
            "--window is for a CSV ride (a lab log's free decay is found from its kick and catch)",
        ),
        (
            a.columns.is_some(),
            "--columns is for a CSV ride (a lab log's columns are its sensors')",
        ),
        (
            a.set_speed.is_some(),
            "--set-speed is for a CSV ride (a treadmill's setting; a lab log's ride takes the \
             reading noted at the release, --speed)",
        ),
    ] {
        if given {
            return Err(Refused(format!(
                "{}: {flag}, not an IMU log or a manifest",
                a.file.display()
            ))
            .into());
        }
    }
    if kind == Kind::RideManifest || (kind == Kind::Unknown && kind::is_toml_document(&a.file)) {
        return campaign(&a, &modal);
    }
    let bike = match &a.bike {
        Some(b) => b.clone(),
        None => dynamic::bike_beside(&a.file)?,
    };
    let model = load_model(&bike, a.controller.as_deref())?;
    let options = DynamicOptions {
        noted: noted(&a),
        prefer_sync: false,
        modal,
    };
    let test = dynamic::dynamic_test(&a.file, &model, &options)?;
    for w in &test.warnings {
        note!("warning: {w}");
    }
    let summary = test.summary();
    emit(a.json, &summary, || summary.to_text())
}

/// The speedometer reading given with `--speed`, its step and error.
fn noted(a: &DynamicArgs) -> Option<NotedReading> {
    a.speed.map(|v| reading(a, v))
}

/// A reading of `speed_mps` with the display step and error given.
fn reading(a: &DynamicArgs, speed_mps: f64) -> NotedReading {
    NotedReading {
        speed_mps,
        resolution_mps: a.speed_resolution,
        se_fraction: a.speed_se_fraction,
    }
}

/// A CSV ride's speed given: `--set-speed` (a treadmill's setting) or `--speed` (a reading).
fn given(a: &DynamicArgs) -> Option<GivenSpeed> {
    match (a.set_speed, noted(a)) {
        (Some(v), _) => Some(GivenSpeed::set(reading(a, v))),
        (None, n) => n.map(GivenSpeed::noted),
    }
}

/// `bikeproc dynamic rides.toml`: every ride of a campaign manifest.
fn campaign(a: &DynamicArgs, modal: &ModalOptions) -> Result<()> {
    if a.speed.is_some() {
        return Err(Refused(format!(
            "{}: --speed is for one ride; a campaign's manifest notes each ride's speed \
             (noted_speed_mps)",
            a.file.display()
        ))
        .into());
    }
    let manifest = RideManifest::load(&a.file)?;
    let bike = a.bike.clone().unwrap_or_else(|| manifest.bike_path());
    let bar = progress(a.json);
    let summary = dynamic::campaign_summary(&manifest, &bike, modal, &|done, total| {
        advance(&bar, "rides", done, total)
    })?;
    bar.finish_and_clear();
    emit(a.json, &summary, || summary.to_text())?;
    if summary.rides.is_empty() {
        return Err(NoRideAnalysed(a.file.clone()).into());
    }
    Ok(())
}

/// `bikeproc dynamic FILE.csv [--window A:B]`: the free decays of another instrument's ride
/// (one with a window or a short record; every kick of a long recording without).
fn csv_ride(a: &DynamicArgs, modal: &ModalOptions) -> Result<()> {
    let model = match &a.bike {
        Some(bike) => Some(load_model(bike, a.controller.as_deref())?),
        None => None,
    };
    let mut kicks = csv::ride_decays_file(
        &a.file,
        &a.columns.clone().unwrap_or_default(),
        a.rate,
        a.window,
        given(a),
        model.as_ref(),
        modal,
    )?;
    // One decay of a window or a short record, given: the decay alone.
    let long =
        !matches!(&kicks[..], [k] if k.kick.starts == bikeproc::ride::kicks::DecayStart::Given);
    if !long {
        if let Some(summary) = kicks.pop().and_then(|k| k.decay) {
            return emit(a.json, &summary, || summary.to_text());
        }
    }
    let report = KickReport {
        file: a.file.display().to_string(),
        kicks,
    };
    emit(a.json, &report, || report.to_text())
}
