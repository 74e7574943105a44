//! `stability`: a bicycle file (and a rider) to its eigenvalues against speed, the weave and
//! capsize speeds and the stable range, with standard errors; `sensitivity`: how those speeds
//! move with every parameter; and the loading of a model (with a controller)
//! that the ride commands share.

use super::args::{CompareArgs, DesignArgs, SensitivityArgs, StabilityArgs};
use super::io::{emit, refuse_files_over_inputs, write_atomic};
use anyhow::Result;
use bikeproc::model::{self, uncertain::Parametrized};
use bikeproc::read::kind::{self, Kind};
use std::path::{Path, PathBuf};

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

pub fn compare(a: CompareArgs) -> Result<()> {
    if let Some(svg) = &a.svg {
        let bikes: Vec<&Path> = a.bikes.iter().map(PathBuf::as_path).collect();
        refuse_files_over_inputs(&[svg], &bikes, a.rider.as_deref())?;
    }
    let models = a
        .bikes
        .iter()
        .map(|b| with_rider(load_bike(b)?, a.rider.as_deref()))
        .collect::<Result<Vec<_>>>()?;
    let c = model::compare::compare(&models, a.max_speed)?;
    if let Some(svg) = &a.svg {
        write_atomic(svg, comparison_svg(&models, &c)?.as_bytes())?;
    }
    emit(a.json, &c, || c.to_text())
}

pub fn design(a: DesignArgs) -> Result<()> {
    use bikeproc::model::design::{design, DesignVariable};
    if let Some(out) = &a.out {
        refuse_files_over_inputs(&[out], &[&a.bike], a.rider.as_deref())?;
        model::params::BikeFileFormat::for_output(out)?;
    }
    let p = with_rider(load_bike(&a.bike)?, a.rider.as_deref())?;
    let vars = DesignVariable::parse_list(&a.vary)?;
    let d = design(&p.name, &p.nominal(), &vars, a.stable, a.max_change)?;
    if let Some(out) = &a.out {
        write_atomic(out, d.bicycle.to_file_text(out)?.as_bytes())?;
    }
    emit(a.json, &d, || d.to_text())?;
    if !d.reached {
        return Err(super::Unreached.into());
    }
    Ok(())
}

/// The overlaid continuation diagrams of `models` over the comparison's speeds (501 of them),
/// its stable ranges shaded, with the detail of their real parts near zero.
#[cfg(feature = "plot")]
fn comparison_svg(models: &[Parametrized], c: &model::compare::Comparison) -> Result<String> {
    use bikeproc::plot::{comparison_svg, Continuation};
    use plotters::style::RGBColor;
    // Weave colour and real modes' colour per bicycle, repeating after six.
    const COLOURS: [(RGBColor, RGBColor); 6] = [
        (RGBColor(30, 80, 200), RGBColor(200, 40, 40)),
        (RGBColor(20, 140, 60), RGBColor(110, 110, 110)),
        (RGBColor(230, 130, 0), RGBColor(140, 80, 20)),
        (RGBColor(130, 50, 170), RGBColor(220, 100, 160)),
        (RGBColor(0, 150, 160), RGBColor(60, 60, 60)),
        (RGBColor(180, 160, 0), RGBColor(100, 130, 30)),
    ];
    let speeds: Vec<f64> = (0..=500)
        .map(|i| i as f64 * c.max_speed_mps / 500.0)
        .collect();
    let bands = models
        .iter()
        .map(|m| m.bands(&speeds))
        .collect::<Result<Vec<_>, _>>()?;
    let conts: Vec<Continuation> = models
        .iter()
        .enumerate()
        .map(|(i, m)| Continuation {
            name: &m.name,
            bands: &bands[i],
            stable: &c.bikes[i].stable_ranges_mps,
            color: COLOURS[i % COLOURS.len()].0,
            color_real: COLOURS[i % COLOURS.len()].1,
        })
        .collect();
    let names: Vec<&str> = models.iter().map(|m| m.name.as_str()).collect();
    Ok(comparison_svg(
        &names.join(" vs "),
        &conts,
        (-10.0, 10.0),
        1.0,
    )?)
}

#[cfg(not(feature = "plot"))]
fn comparison_svg(_: &[Parametrized], _: &model::compare::Comparison) -> Result<String> {
    anyhow::bail!("this bikeproc was built without figures (the `plot` feature): no --svg")
}

/// `model` with the rider of the file `rider` joined to its rear frame, named in the model's
/// name.
fn with_rider(model: Parametrized, rider: Option<&Path>) -> Result<Parametrized> {
    Ok(match rider {
        Some(r) => model.with_rider_file(r)?,
        None => model,
    })
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
    Ok(bikeproc::read::bicycle::load(bike)?)
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
