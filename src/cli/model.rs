//! `stability`: a bicycle file to its eigenvalues against speed, the weave and capsize speeds
//! and the stable range, with standard errors; and the loading of a model (with a controller)
//! that the ride commands share.

use super::args::StabilityArgs;
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
    let p = with_controller(p, a.controller.as_deref())?;
    let report = model::report::StabilityReport::over(&p, a.speeds)?;
    emit(a.json, &report, || report.to_text())
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
