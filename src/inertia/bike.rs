//! The assembled bicycle in the lab's parametrization (`data/lab_bike.toml`): the geometry of
//! seed §5.3.2 and Parametros.m, and each body's mass and inertia tensor (in the body's own
//! axes, eq. 68) with standard errors. The model stage converts it to the benchmark form;
//! `bikeproc inertia --bike FILE` refreshes its inertias from the test folders it names.

use super::{compound, torsion, InertiaError};
use crate::read::manifest::Moment;
use serde::{Deserialize, Serialize};
use std::path::{Path, PathBuf};

/// Geometry of the upright bicycle, x forward and z up from the rear hub (seed §5.3.2).
#[derive(Debug, Clone, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct Geometry {
    pub rear_wheel_radius_m: f64,
    pub front_wheel_radius_m: f64,
    /// The frame's (and handlebar's) axes are rotated by β about y (Parametros.m `betaf`).
    pub frame_axes_beta_rad: f64,
    pub frame_cg_from_rear_hub_m: [f64; 2],
    pub handlebar_cg_from_rear_hub_m: [f64; 2],
    pub front_hub_from_handlebar_cg_m: [f64; 2],
    /// The lab's model puts the handlebar's centre of gravity on the steer axis (seed §6.2):
    /// its geometry defines the steer axis as the handlebar's local z axis through G₄, so the
    /// conversion to the benchmark form requires `true` (the real G₄ is slightly off the axis,
    /// seed §5.2, but was not measured). For a benchmark-form bicycle the same assumption is
    /// `bikeproc stability --cg-on-steer-axis`.
    #[serde(default)]
    pub handlebar_cg_on_steer_axis: bool,
}

/// A body's mass and inertia tensor about its centre of gravity, in its own axes (eq. 68).
#[derive(Debug, Clone, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct Body {
    pub mass_kg: f64,
    pub mass_se_kg: f64,
    pub ixx_kgm2: f64,
    pub ixx_se_kgm2: f64,
    pub iyy_kgm2: f64,
    pub iyy_se_kgm2: f64,
    pub izz_kgm2: f64,
    pub izz_se_kgm2: f64,
    pub ixz_kgm2: f64,
    pub ixz_se_kgm2: f64,
    /// Where the numbers come from.
    pub source: String,
}

/// The test folders behind the inertias, relative to the bike file.
#[derive(Debug, Clone, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct Sources {
    pub frame_torsion: PathBuf,
    /// The frame tensor's orientations (the lab's final choice was 1, 3, 4; empty: all).
    #[serde(default)]
    pub frame_orientations: Vec<String>,
    pub frame_compound: PathBuf,
    pub handlebar_torsion: PathBuf,
    pub handlebar_compound: PathBuf,
    pub rear_wheel_compound: PathBuf,
    pub front_wheel_compound: PathBuf,
}

/// The bicycle file.
#[derive(Debug, Clone, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct LabBike {
    pub version: u32,
    pub name: String,
    pub gravity_mps2: f64,
    pub geometry: Geometry,
    pub rear_wheel: Body,
    pub frame: Body,
    pub handlebar: Body,
    pub front_wheel: Body,
    pub sources: Option<Sources>,
}

impl LabBike {
    pub fn to_toml(&self) -> String {
        let body = toml::to_string(self).unwrap_or_default();
        format!(
            "# The lab's bicycle (bikeproc format, version 1): geometry of seed §5.3.2 and Parametros.m,\n\
             # x forward and z up from the rear hub in the upright bicycle; masses (kg) and inertia\n\
             # tensors (kg·m²) about each body's centre of gravity in its own axes (eq. 68), with\n\
             # standard errors. `bikeproc inertia --bike FILE` refreshes the inertias from [sources].\n\n{body}"
        )
    }

    /// Re-measures every inertia from the test folders in `[sources]` (relative to `dir`).
    pub fn refresh(&mut self, dir: &Path) -> Result<Vec<String>, InertiaError> {
        let s = self.sources.clone().ok_or_else(|| InertiaError::Invalid {
            path: dir.to_path_buf(),
            message: "no [sources] table naming the test folders".into(),
        })?;
        let mut warnings = Vec::new();
        let frame_t = torsion(&dir.join(&s.frame_torsion), &s.frame_orientations)?;
        let hb_t = torsion(&dir.join(&s.handlebar_torsion), &[])?;
        let iyy = |folder: &PathBuf| -> Result<(f64, f64, String), InertiaError> {
            let c = compound(&dir.join(folder))?;
            let t = c
                .tests
                .iter()
                .find(|t| t.moment == Moment::Iyy)
                .ok_or_else(|| InertiaError::Invalid {
                    path: dir.join(folder),
                    message: "no test with moment = \"iyy\"".into(),
                })?;
            Ok((
                t.inertia_about_cg,
                t.inertia_about_cg_se,
                folder.display().to_string(),
            ))
        };
        let set_xz = |b: &mut Body, t: &super::TorsionResult, folder: &Path| {
            b.ixx_kgm2 = t.tensor.ixx;
            b.ixx_se_kgm2 = t.tensor.ixx_se;
            b.ixz_kgm2 = t.tensor.ixz;
            b.ixz_se_kgm2 = t.tensor.ixz_se;
            b.izz_kgm2 = t.tensor.izz;
            b.izz_se_kgm2 = t.tensor.izz_se;
            b.mass_kg = t.mass_kg;
            b.mass_se_kg = t.manifest.mass_se_kg();
            b.source = format!(
                "{} (orientations {})",
                folder.display(),
                t.tensor.orientations.join(", ")
            );
        };
        set_xz(&mut self.frame, &frame_t, &s.frame_torsion);
        set_xz(&mut self.handlebar, &hb_t, &s.handlebar_torsion);
        warnings.extend(
            frame_t
                .tensor
                .warnings
                .iter()
                .map(|w| format!("frame: {w}")),
        );
        warnings.extend(
            hb_t.tensor
                .warnings
                .iter()
                .map(|w| format!("handlebar: {w}")),
        );
        for (body, folder) in [
            (&mut self.frame, &s.frame_compound),
            (&mut self.handlebar, &s.handlebar_compound),
        ] {
            let (v, se, src) = iyy(folder)?;
            body.iyy_kgm2 = v;
            body.iyy_se_kgm2 = se;
            body.source = format!("{}; iyy from {src}", body.source);
        }
        for (body, folder) in [
            (&mut self.rear_wheel, &s.rear_wheel_compound),
            (&mut self.front_wheel, &s.front_wheel_compound),
        ] {
            let c = compound(&dir.join(folder))?;
            body.mass_kg = c.mass_kg;
            body.mass_se_kg = c.mass_se_kg;
            for t in &c.tests {
                match t.moment {
                    Moment::Iyy => {
                        body.iyy_kgm2 = t.inertia_about_cg;
                        body.iyy_se_kgm2 = t.inertia_about_cg_se;
                    }
                    Moment::IxxIzz => {
                        body.ixx_kgm2 = t.inertia_about_cg;
                        body.ixx_se_kgm2 = t.inertia_about_cg_se;
                        body.izz_kgm2 = t.inertia_about_cg;
                        body.izz_se_kgm2 = t.inertia_about_cg_se;
                    }
                }
            }
            body.ixz_kgm2 = 0.0;
            body.ixz_se_kgm2 = 0.0;
            body.source = format!("{} (I_xx = I_zz, eq. 83)", folder.display());
        }
        for (name, b) in [
            ("rear wheel", &self.rear_wheel),
            ("frame", &self.frame),
            ("handlebar", &self.handlebar),
            ("front wheel", &self.front_wheel),
        ] {
            if let Some(w) = validity(b) {
                warnings.push(format!("{name}: {w}"));
            }
        }
        Ok(warnings)
    }
}

/// Every number of a bicycle file finite, and every standard error (a key with `_se`) from 0
/// to 1000 (SI units: no bicycle quantity is that uncertain). The offending key, dotted.
pub(crate) fn check_numbers(table: &toml::Table, prefix: &str) -> Result<(), (String, String)> {
    for (k, v) in table {
        let key = format!("{prefix}{k}");
        match v {
            toml::Value::Table(t) => check_numbers(t, &format!("{key}."))?,
            toml::Value::Float(x) => {
                if !x.is_finite() {
                    return Err((key, format!("{x} is not a number")));
                }
                if k.contains("_se") && !(0.0..=1000.0).contains(x) {
                    return Err((key, format!("{x}: a standard error from 0 to 1000")));
                }
            }
            toml::Value::Integer(x) if k.contains("_se") && !(0..=1000).contains(x) => {
                return Err((key, format!("{x}: a standard error from 0 to 1000")));
            }
            _ => {}
        }
    }
    Ok(())
}

/// Physical validity of a full tensor: positive definite and the triangle inequalities of its
/// principal moments (each at most the sum of the other two). Names the entries at fault.
pub fn validity(b: &Body) -> Option<String> {
    let t = nalgebra::Matrix3::new(
        b.ixx_kgm2, 0.0, b.ixz_kgm2, 0.0, b.iyy_kgm2, 0.0, b.ixz_kgm2, 0.0, b.izz_kgm2,
    );
    let eig = t
        .iter()
        .all(|x| x.is_finite())
        .then(|| {
            nalgebra::SymmetricEigen::try_new(t, f64::EPSILON, crate::MAX_DECOMPOSITION_ITERATIONS)
        })
        .flatten();
    let Some(eig) = eig else {
        return Some(format!(
            "I_xx, I_yy, I_zz, I_xz = {}, {}, {}, {}: not a tensor (a moment is not a number)",
            b.ixx_kgm2, b.iyy_kgm2, b.izz_kgm2, b.ixz_kgm2
        ));
    };
    let mut p: Vec<f64> = eig.eigenvalues.iter().copied().collect();
    p.sort_by(f64::total_cmp);
    if p[0] <= 0.0 {
        return Some(format!("not positive definite (principal moments {:.4}, {:.4}, {:.4} kg·m²): I_xx, I_zz and I_xz = {:.4} are inconsistent", p[0], p[1], p[2], b.ixz_kgm2));
    }
    if p[2] > p[0] + p[1] + 1e-12 {
        let excess = p[2] - p[0] - p[1];
        let se = (b.ixx_se_kgm2.powi(2)
            + b.iyy_se_kgm2.powi(2)
            + b.izz_se_kgm2.powi(2)
            + 4.0 * b.ixz_se_kgm2.powi(2))
        .sqrt();
        let sigmas = if se > 0.0 {
            format!(", {:.1} standard errors", excess / se)
        } else {
            String::new()
        };
        return Some(format!(
            "breaks the triangle inequality: the largest principal moment {:.4} exceeds the sum of the others {:.4} + {:.4} by {excess:.4} kg·m²{sigmas}; \
             I_yy = {:.4} and (I_xx, I_zz, I_xz) = ({:.4}, {:.4}, {:.4}) cannot belong to one rigid body",
            p[2], p[0], p[1], b.iyy_kgm2, b.ixx_kgm2, b.izz_kgm2, b.ixz_kgm2
        ));
    }
    None
}

impl LabBike {
    /// The lab's bicycle exactly as published: eq. 92 and Parametros.m (no standard errors were
    /// published; they are zero here). The frame's tensor is Table 3's (1,3,4) row, as
    /// Parametros.m uses it, with Parametros.m's sign of I_xz.
    pub fn seed() -> LabBike {
        let body = |m: f64, ixx: f64, iyy: f64, izz: f64, ixz: f64, source: &str| Body {
            mass_kg: m,
            mass_se_kg: 0.0,
            ixx_kgm2: ixx,
            ixx_se_kgm2: 0.0,
            iyy_kgm2: iyy,
            iyy_se_kgm2: 0.0,
            izz_kgm2: izz,
            izz_se_kgm2: 0.0,
            ixz_kgm2: ixz,
            ixz_se_kgm2: 0.0,
            source: source.into(),
        };
        LabBike {
            version: 1,
            name: "the lab's bicycle as published (seed eq. 92, Parametros.m)".into(),
            gravity_mps2: 9.81,
            geometry: Geometry {
                rear_wheel_radius_m: 0.3,
                front_wheel_radius_m: 0.3,
                frame_axes_beta_rad: 5.96817301822878,
                frame_cg_from_rear_hub_m: [0.389976, 0.158258],
                handlebar_cg_from_rear_hub_m: [0.893746, 0.349845],
                front_hub_from_handlebar_cg_m: [0.129668, -0.349845],
                handlebar_cg_on_steer_axis: true,
            },
            rear_wheel: body(2.52, 0.0884, 0.1357, 0.0884, 0.0, "seed eqs. 85, 87, 92"),
            frame: body(
                5.48,
                0.3215,
                0.8796,
                0.9538,
                0.1131,
                "seed Table 3 (tests 1, 3, 4) and eq. 80, as in Parametros.m",
            ),
            handlebar: body(
                2.96,
                0.3056,
                0.158,
                0.0385,
                -0.0385,
                "seed Table 6 and eq. 82",
            ),
            front_wheel: body(1.96, 0.0525, 0.119, 0.0525, 0.0, "seed eqs. 89, 91, 92"),
            sources: None,
        }
    }

    /// The measured bicycle before its first refresh: the seed's numbers and the campaign's
    /// test folders.
    pub fn lab_template() -> LabBike {
        let mut b = LabBike::seed();
        b.name = "the lab's bicycle, inertias measured from data/ by bikeproc".into();
        b.sources = Some(Sources {
            frame_torsion: "frame_torsion".into(),
            frame_orientations: vec![],
            frame_compound: "frame_compound".into(),
            handlebar_torsion: "handlebar_torsion".into(),
            handlebar_compound: "handlebar_compound".into(),
            rear_wheel_compound: "rear_wheel_compound".into(),
            front_wheel_compound: "front_wheel_compound".into(),
        });
        b
    }
}
