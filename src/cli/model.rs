//! `stability`: a bicycle file (and a rider) to its eigenvalues against speed, the weave and
//! capsize speeds and the stable range, with standard errors; `sensitivity`: how those speeds
//! move with every parameter; and the loading of a model (with a controller)
//! that the ride commands share.

use super::args::{SensitivityArgs, StabilityArgs};
use super::io::emit;
use anyhow::Result;
use bikeproc::kind::{self, Kind};
use bikeproc::model::{self, uncertain::Parametrized};
use std::path::Path;

pub fn stability(a: StabilityArgs) -> Result<()> {
    let mut p = load_bike(&a.bike)?;
    if a.cg_on_steer_axis {
        let b = p.nominal().with_handlebar_cg_on_steer_axis();
        p = Parametrized::from_benchmark(&p.name, &b);
    }
    let p = with_rider(p, a.rider.as_deref())?;
    let p = with_controller(p, a.controller.as_deref())?;
    let report = model::report::StabilityReport::over(&p, a.speeds)?;
    emit(a.json, &report, || report.to_text())
}

pub fn sensitivity(a: SensitivityArgs) -> Result<()> {
    let p = with_rider(load_bike(&a.bike)?, a.rider.as_deref())?;
    let s = model::sensitivity::sensitivity(&p, &a.speeds, a.max_speed)?;
    emit(a.json, &s, || s.to_text())
}

/// `model` with the rider of the file `rider` joined to its rear frame, named in the model's
/// name.
fn with_rider(mut model: Parametrized, rider: Option<&Path>) -> Result<Parametrized> {
    if let Some(r) = rider {
        let rider = model::Rider::load(r)?;
        let file = r
            .file_name()
            .map_or_else(|| r.display().to_string(), |f| f.to_string_lossy().into());
        model.name = format!("{} with the rider of {file}", model.name);
        model = model.with_rider(&rider);
    }
    Ok(model)
}

/// A bicycle file as a model, with the controller of `controller` (a TOML `[controller]`
/// table) closing the loop when given.
pub fn load_model(bike: &Path, controller: Option<&Path>) -> Result<Parametrized> {
    with_controller(load_bike(bike)?, controller)
}

/// A bicycle file as a model; a file of another kind is told what it is.
fn load_bike(bike: &Path) -> Result<Parametrized> {
    kind::expect(
        bike,
        &|k| matches!(k, Kind::LabBike | Kind::Benchmark | Kind::MeasuredBicycle),
        "a bicycle file",
    )?;
    Ok(model::uncertain::load(bike)?)
}

/// `model` with the steer controller of the file `controller` closing the loop, named in the
/// model's name.
fn with_controller(mut model: Parametrized, controller: Option<&Path>) -> Result<Parametrized> {
    if let Some(c) = controller {
        kind::expect(
            c,
            &|k| matches!(k, Kind::Controller | Kind::RideManifest),
            "a controller file",
        )?;
        if kind::recognise(c) == Kind::RideManifest
            && !std::fs::read_to_string(c)?
                .lines()
                .any(|l| l.trim() == "[controller]")
        {
            return Err(kind::WrongKind(format!(
                "{}: this is a campaign of rides without a [controller] table, not a controller \
                 file (a [controller] table: speeds_mps and the gains per speed)",
                c.display()
            ))
            .into());
        }
        let (control, description) = model::SteerControl::load(c)?;
        model.name = format!("{} with the controller `{description}`", model.name);
        model = model.with_control(control);
    }
    Ok(model)
}
