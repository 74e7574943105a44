//! The benchmark parameter set (Meijaard et al. 2007, Table 1): x forward, z down, origin at the
//! rear contact point; m, kg, kg·m², rad. Read and written in BicycleParameters' text format
//! (`name = value+/-sigma`, one a line) and in TOML (`name = value`, `name_se = sigma`).

use std::fmt::Write as _;
use std::path::{Path, PathBuf};

/// Errors of the model stage's inputs.
#[derive(Debug, Clone, PartialEq, thiserror::Error)]
pub enum ParamError {
    #[error("{path}:{line}: {message}")]
    Parse {
        path: PathBuf,
        line: usize,
        message: String,
    },
    #[error("{path}: missing parameter `{name}`")]
    Missing { path: PathBuf, name: String },
    #[error("{path}: {message}")]
    Invalid { path: PathBuf, message: String },
    /// A raw-measurement file's error (`*Measured.txt`), which names its file and line itself.
    #[error("{0}")]
    Measured(String),
    #[error("the mass matrix M is singular: the parameters give no dynamics")]
    SingularMass,
    #[error("the eigenvalues could not be computed (non-finite state matrix)")]
    NoEigenvalues,
}

/// The format a bicycle file is written in, from its name: what the readers take it for.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum BikeFileFormat {
    /// Benchmark TOML (`name = value`, `name_se = sigma`): a `*.toml` name.
    Toml,
    /// BicycleParameters' text (`IBxx = 0.53+/-0.002`): any other name.
    Text,
}

impl BikeFileFormat {
    /// The format of a bicycle file to be written at `path`; a name ending in `Measured.txt`
    /// is refused, since it is read back as raw measurements, not parameters.
    pub fn for_output(path: &Path) -> Result<BikeFileFormat, ParamError> {
        let name = path
            .file_name()
            .map(|n| n.to_string_lossy().into_owned())
            .unwrap_or_default();
        if name.ends_with("Measured.txt") {
            return Err(ParamError::Invalid {
                path: path.to_path_buf(),
                message: "a name ending in `Measured.txt` is read as a bicycle's raw \
                          measurements, not its parameters: name it `…Benchmark.txt` (or \
                          `.toml`)"
                    .into(),
            });
        }
        Ok(if crate::output::named_toml(path) {
            BikeFileFormat::Toml
        } else {
            BikeFileFormat::Text
        })
    }
}

macro_rules! benchmark_params {
    ($( $field:ident : $name:literal, $doc:literal; )*) => {
        /// A bicycle in the benchmark form, with a standard error for every parameter.
        #[derive(Debug, Clone, Copy, PartialEq)]
        pub struct Benchmark {
            $( #[doc = $doc] pub $field: f64, )*
            /// Standard errors, in the order of [`Benchmark::NAMES`].
            pub se: [f64; 26],
        }

        impl Benchmark {
            /// Parameter names as BicycleParameters writes them, in a fixed order.
            pub const NAMES: [&'static str; 26] = [$( $name, )*];

            /// The values in the order of [`Benchmark::NAMES`].
            pub fn to_array(&self) -> [f64; 26] {
                [$( self.$field, )*]
            }

            /// A parameter set from values in the order of [`Benchmark::NAMES`] (no errors).
            pub fn from_array(v: &[f64; 26]) -> Benchmark {
                let mut it = v.iter().copied();
                Benchmark { $( $field: it.next().unwrap_or(0.0), )* se: [0.0; 26] }
            }
        }

        /// The benchmark parameters in any arithmetic ([`crate::jet::Scalar`]): `f64` for the
        /// model, jets for its derivatives.
        #[derive(Debug, Clone, Copy)]
        pub struct BenchmarkOf<T> {
            $( #[doc = $doc] pub $field: T, )*
        }

        impl<T: Copy> BenchmarkOf<T> {
            /// From values in the order of [`Benchmark::NAMES`].
            pub fn from_array(v: [T; 26]) -> BenchmarkOf<T> {
                let [$( $field, )*] = v;
                BenchmarkOf { $( $field, )* }
            }
        }
    };
}

benchmark_params! {
    w: "w", "Wheelbase (m).";
    c: "c", "Trail (m).";
    lambda: "lam", "Steer axis tilt from the vertical (rad).";
    g: "g", "Gravity (m/s²).";
    r_r: "rR", "Rear wheel radius (m).";
    m_r: "mR", "Rear wheel mass (kg).";
    i_rxx: "IRxx", "Rear wheel inertia about a diameter (kg·m²).";
    i_ryy: "IRyy", "Rear wheel spin inertia (kg·m²).";
    x_b: "xB", "Rear body (frame and rider) centre of mass, x (m).";
    z_b: "zB", "Rear body centre of mass, z, down (m).";
    m_b: "mB", "Rear body mass (kg).";
    i_bxx: "IBxx", "Rear body inertia (kg·m²).";
    i_byy: "IByy", "Rear body inertia (kg·m²).";
    i_bzz: "IBzz", "Rear body inertia (kg·m²).";
    i_bxz: "IBxz", "Rear body product of inertia, z down (kg·m²).";
    x_h: "xH", "Front frame (handlebar and fork) centre of mass, x (m).";
    z_h: "zH", "Front frame centre of mass, z, down (m).";
    m_h: "mH", "Front frame mass (kg).";
    i_hxx: "IHxx", "Front frame inertia (kg·m²).";
    i_hyy: "IHyy", "Front frame inertia (kg·m²).";
    i_hzz: "IHzz", "Front frame inertia (kg·m²).";
    i_hxz: "IHxz", "Front frame product of inertia, z down (kg·m²).";
    r_f: "rF", "Front wheel radius (m).";
    m_f: "mF", "Front wheel mass (kg).";
    i_fxx: "IFxx", "Front wheel inertia about a diameter (kg·m²).";
    i_fyy: "IFyy", "Front wheel spin inertia (kg·m²).";
}

/// The trail at steer axis tilt `lambda` of a fork whose trail was `trail` at `tilt`, its
/// offset kept: the offset (the front axle's distance from the steer axis) is
/// `d = r_F sin λ₀ − c₀ cos λ₀`, and the trail `c = (r_F sin λ − d)/cos λ` (Meijaard et al.
/// 2007, Appendix A). Any arithmetic, so that jets give its derivatives.
pub fn trail_keeping_offset<T: crate::jet::Scalar>(r_f: T, (tilt, trail): (T, T), lambda: T) -> T {
    let offset = r_f * tilt.sin() - trail * tilt.cos();
    (r_f * lambda.sin() - offset) / lambda.cos()
}

impl Benchmark {
    /// The benchmark bicycle of Meijaard et al. 2007, Table 1.
    pub fn meijaard_2007() -> Benchmark {
        Benchmark::from_array(&[
            1.02,
            0.08,
            std::f64::consts::PI / 10.0,
            9.81,
            0.3,
            2.0,
            0.0603,
            0.12,
            0.3,
            -0.9,
            85.0,
            9.2,
            11.0,
            2.8,
            2.4,
            0.9,
            -0.7,
            4.0,
            0.05892,
            0.06,
            0.00708,
            -0.00756,
            0.35,
            3.0,
            0.1405,
            0.28,
        ])
    }

    /// Reads BicycleParameters' text format. Keys that are not benchmark parameters (`lcs`,
    /// `hbb`, rider geometry) are skipped; a missing parameter is an error.
    pub fn parse_text(text: &str, path: &Path) -> Result<Benchmark, ParamError> {
        let (values, se) = parse_named(text, path, &Benchmark::NAMES)?;
        if let Some(k) = values.iter().position(|v| v.is_nan()) {
            if values[..4].iter().all(|v| v.is_nan()) {
                return Err(ParamError::Invalid {
                    path: path.to_path_buf(),
                    message: "no bicycle geometry (w, c, lam, g are missing): a rider's parameters? The model needs a whole bicycle".into(),
                });
            }
            return Err(ParamError::Missing {
                path: path.to_path_buf(),
                name: Benchmark::NAMES[k].into(),
            });
        }
        let mut b = Benchmark::from_array(&values);
        b.se = se;
        b.validate(path)?;
        Ok(b)
    }

    /// Writes BicycleParameters' text format.
    pub fn to_text(&self) -> String {
        let mut s = String::new();
        for ((name, v), e) in Benchmark::NAMES.iter().zip(self.to_array()).zip(self.se) {
            let _ = writeln!(s, "{name} = {v:?}+/-{e:?}");
        }
        s
    }

    /// Reads TOML: `name = value` and optionally `name_se = sigma`, BicycleParameters' names.
    pub fn parse_toml(text: &str, path: &Path) -> Result<Benchmark, ParamError> {
        let table: toml::Table = toml::from_str(text).map_err(|e| {
            let line = e
                .span()
                .map(|s| 1 + text[..s.start.min(text.len())].matches('\n').count())
                .unwrap_or(0);
            ParamError::Parse {
                path: path.to_path_buf(),
                line,
                message: e.message().replace('\n', " "),
            }
        })?;
        let mut values = [0.0; 26];
        let mut se = [0.0; 26];
        for (k, name) in Benchmark::NAMES.iter().enumerate() {
            let get = |key: &str| {
                table
                    .get(key)
                    .and_then(|v| v.as_float().or_else(|| v.as_integer().map(|i| i as f64)))
            };
            values[k] = get(name).ok_or_else(|| ParamError::Missing {
                path: path.to_path_buf(),
                name: (*name).into(),
            })?;
            se[k] = get(&format!("{name}_se")).unwrap_or(0.0);
        }
        let mut b = Benchmark::from_array(&values);
        b.se = se;
        b.validate(path)?;
        Ok(b)
    }

    /// These parameters as the text of a bicycle file named `path`, in the format its name
    /// says, so that [`crate::read::bicycle::load`] reads back what was written: benchmark
    /// TOML for `*.toml`, BicycleParameters' text otherwise. A name ending in `Measured.txt`
    /// is refused: it is read back as a bicycle's raw measurements.
    pub fn to_file_text(&self, path: &Path) -> Result<String, ParamError> {
        Ok(match BikeFileFormat::for_output(path)? {
            BikeFileFormat::Toml => self.to_toml(),
            BikeFileFormat::Text => self.to_text(),
        })
    }

    /// Writes TOML.
    pub fn to_toml(&self) -> String {
        let mut s = String::from("# Benchmark bicycle parameters (Meijaard et al. 2007): x forward, z down, origin at the rear contact.\n");
        for ((name, v), e) in Benchmark::NAMES.iter().zip(self.to_array()).zip(self.se) {
            let _ = writeln!(s, "{name} = {v:?}");
            if e != 0.0 {
                let _ = writeln!(s, "{name}_se = {e:?}");
            }
        }
        s
    }

    /// Physical checks: positive masses and radii (zero allowed for the two-mass-skate's
    /// massless wheels), positive-definite inertias, a wheelbase, a steer axis tilt within ±90°.
    pub fn validate(&self, path: &Path) -> Result<(), ParamError> {
        let bad = |message: String| {
            Err(ParamError::Invalid {
                path: path.to_path_buf(),
                message,
            })
        };
        let n = crate::stats::number_text;
        for ((name, v), se) in Benchmark::NAMES.iter().zip(self.to_array()).zip(self.se) {
            if !(se.is_finite() && se >= 0.0 && se <= 10.0 * v.abs() + 1.0) {
                return bad(format!(
                    "{name} = {} ± {}: a standard error from 0 to ten times the value plus one \
                     (SI units)",
                    n(v),
                    n(se)
                ));
            }
        }
        if !is_positive(self.w) {
            return bad(format!("wheelbase w = {} m: expected positive", n(self.w)));
        }
        if !is_positive(std::f64::consts::FRAC_PI_2 - self.lambda.abs()) {
            return bad(format!(
                "steer axis tilt lam = {} rad: expected within ±π/2",
                n(self.lambda)
            ));
        }
        if !is_positive(self.g) {
            return bad(format!("g = {}: expected positive", n(self.g)));
        }
        if !is_positive(self.m_b) {
            return bad(format!(
                "rear body mass mB = {} kg: expected positive",
                n(self.m_b)
            ));
        }
        for (name, v) in [
            ("mR", self.m_r),
            ("mH", self.m_h),
            ("mF", self.m_f),
            ("rR", self.r_r),
            ("rF", self.r_f),
        ] {
            if !is_non_negative(v) {
                return bad(format!("{name} = {}: expected zero or positive", n(v)));
            }
        }
        for (name, r, iyy) in [
            ("rear", self.r_r, self.i_ryy),
            ("front", self.r_f, self.i_fyy),
        ] {
            if r == 0.0 && iyy != 0.0 {
                return bad(format!(
                    "{name} wheel: zero radius with spin inertia {}: I/r has no limit",
                    n(iyy)
                ));
            }
        }
        for (body, xx, zz, xz) in [
            ("B", self.i_bxx, self.i_bzz, self.i_bxz),
            ("H", self.i_hxx, self.i_hzz, self.i_hxz),
        ] {
            if xx < 0.0 || zz < 0.0 || xx * zz - xz * xz < -1e-12 {
                return bad(format!(
                    "I{body}xx = {}, I{body}zz = {}, I{body}xz = {}: not positive semi-definite",
                    n(xx),
                    n(zz),
                    n(xz)
                ));
            }
        }
        // Centres of mass above the ground (z points down) and within a few metres of the
        // rear contact; a trail shorter than the wheelbase.
        for (name, m, x, z) in [
            ("B", self.m_b, self.x_b, self.z_b),
            ("H", self.m_h, self.x_h, self.z_h),
        ] {
            if m > 0.0 && !(z < 0.0 && z > -10.0) {
                return bad(format!(
                    "z{name} = {} m: the centre of mass of a body with mass is above the ground \
                     (z points down: expected from −10 m to below 0)",
                    n(z)
                ));
            }
            if x.abs() > 10.0 {
                return bad(format!(
                    "x{name} = {} m: expected within 10 m of the rear contact",
                    n(x)
                ));
            }
        }
        // Sizes no bicycle reaches (with a rider, a cargo load or a tandem's frame well inside):
        // beyond them the state matrix overflows and the model has nothing to say.
        let limits: [(&str, f64, f64, &str); 19] = [
            ("w", self.w, 10.0, "m"),
            ("rR", self.r_r, 5.0, "m"),
            ("rF", self.r_f, 5.0, "m"),
            ("mR", self.m_r, 1000.0, "kg"),
            ("mB", self.m_b, 1000.0, "kg"),
            ("mH", self.m_h, 1000.0, "kg"),
            ("mF", self.m_f, 1000.0, "kg"),
            ("IRxx", self.i_rxx, 1000.0, "kg·m²"),
            ("IRyy", self.i_ryy, 1000.0, "kg·m²"),
            ("IFxx", self.i_fxx, 1000.0, "kg·m²"),
            ("IFyy", self.i_fyy, 1000.0, "kg·m²"),
            ("IBxx", self.i_bxx, 1000.0, "kg·m²"),
            ("IByy", self.i_byy, 1000.0, "kg·m²"),
            ("IBzz", self.i_bzz, 1000.0, "kg·m²"),
            ("IBxz", self.i_bxz, 1000.0, "kg·m²"),
            ("IHxx", self.i_hxx, 1000.0, "kg·m²"),
            ("IHyy", self.i_hyy, 1000.0, "kg·m²"),
            ("IHzz", self.i_hzz, 1000.0, "kg·m²"),
            ("IHxz", self.i_hxz, 1000.0, "kg·m²"),
        ];
        for (name, v, most, unit) in limits {
            if v.abs() > most {
                return bad(format!(
                    "{name} = {} {unit}: beyond any bicycle's (at most {most} {unit} in size)",
                    n(v)
                ));
            }
        }
        if self.g >= 100.0 {
            return bad(format!("g = {} m/s²: expected below 100 m/s²", n(self.g)));
        }
        if self.c.abs() >= self.w {
            return bad(format!(
                "trail c = {} m: expected shorter than the wheelbase w = {} m",
                n(self.c),
                n(self.w)
            ));
        }
        for (name, v) in [
            ("IRxx", self.i_rxx),
            ("IRyy", self.i_ryy),
            ("IFxx", self.i_fxx),
            ("IFyy", self.i_fyy),
            ("IByy", self.i_byy),
            ("IHyy", self.i_hyy),
        ] {
            if v < 0.0 {
                return bad(format!("{name} = {}: expected zero or positive", n(v)));
            }
        }
        Ok(())
    }

    /// The handlebar's centre of mass moved onto the steer axis (its perpendicular projection),
    /// as the lab's model has it (seed §6.2); its inertia about its own centre is kept.
    pub fn with_handlebar_cg_on_steer_axis(&self) -> Benchmark {
        let mut b = *self;
        // The steer axis passes through the ground point (w + c, 0) with direction
        // (−sin λ, −cos λ) (upwards and backwards, z down).
        let (sl, cl) = self.lambda.sin_cos();
        let (px, pz) = (self.w + self.c, 0.0);
        let (dx, dz) = (-sl, -cl);
        let t = (self.x_h - px) * dx + (self.z_h - pz) * dz;
        b.x_h = px + t * dx;
        b.z_h = pz + t * dz;
        b
    }

    /// Standard errors as a vector.
    pub fn standard_errors(&self) -> [f64; 26] {
        self.se
    }
}

/// The values and standard errors of the parameters `names` in BicycleParameters' text format
/// (`name = value+/-sigma` or `name = value`, one a line; other keys skipped): NaN for a
/// parameter not given, 0 for a standard error not given.
fn parse_named<const N: usize>(
    text: &str,
    path: &Path,
    names: &[&str; N],
) -> Result<([f64; N], [f64; N]), ParamError> {
    let mut values = [f64::NAN; N];
    let mut se = [0.0; N];
    let mut first_line = [0usize; N];
    for (i, raw) in text.lines().enumerate() {
        let line = raw.trim();
        if line.is_empty() || line.starts_with('#') {
            continue;
        }
        let err = |message: String| ParamError::Parse {
            path: path.to_path_buf(),
            line: i + 1,
            message,
        };
        let (name, rest) = line
            .split_once('=')
            .ok_or_else(|| err(format!("`{line}`: expected `name = value+/-sigma`")))?;
        let name = name.trim();
        let (v, s) = match rest.split_once("+/-") {
            Some((v, s)) => (v.trim(), Some(s.trim())),
            None => (rest.trim(), None),
        };
        let Some(k) = names.iter().position(|n| *n == name) else {
            continue;
        };
        if first_line[k] > 0 {
            return Err(err(format!(
                "`{name}` is given twice (first on line {}): which is meant?",
                first_line[k]
            )));
        }
        first_line[k] = i + 1;
        let num = |t: &str| t.parse::<f64>().ok().filter(|x| x.is_finite());
        values[k] =
            num(v).ok_or_else(|| err(format!("`{name} = {}`: expected a number", rest.trim())))?;
        if let Some(s) = s {
            se[k] = num(s).filter(|x| *x >= 0.0).ok_or_else(|| {
                err(format!(
                    "`{name}`: standard error `{s}` is not a non-negative number"
                ))
            })?;
        }
    }
    Ok((values, se))
}

/// `x > 0`, and false for NaN.
fn is_positive(x: f64) -> bool {
    x > 0.0
}

/// `x ≥ 0`, and false for NaN.
fn is_non_negative(x: f64) -> bool {
    x >= 0.0
}

/// Which of the benchmark's two frames a load rides on.
#[derive(Debug, Clone, Copy, PartialEq, Eq, serde::Deserialize, serde::Serialize)]
#[serde(rename_all = "snake_case")]
pub enum Frame {
    /// The rear frame (body B: frame, saddle, rider).
    Rear,
    /// The front frame (body H: fork and handlebar).
    Front,
}

/// A point mass at a stated place on one frame, in the benchmark's axes (x forward, z down,
/// from the rear contact, upright): a lab's known change between conditions (a weight at the
/// saddle or the handlebar).
#[derive(Debug, Clone, Copy, PartialEq, serde::Deserialize, serde::Serialize)]
#[serde(deny_unknown_fields)]
pub struct PointMass {
    pub frame: Frame,
    pub mass_kg: f64,
    pub x_m: f64,
    pub z_m: f64,
}

/// A rigid body in the benchmark's axes (x forward, z down, from the rear contact, upright):
/// its mass, centre of mass and inertia about that centre (the product of inertia as the
/// tensor's off-diagonal element, as in Meijaard et al. 2007, Table 1).
#[derive(Debug, Clone, Copy, PartialEq, serde::Serialize)]
pub struct RigidBody {
    pub mass_kg: f64,
    pub x_m: f64,
    pub z_m: f64,
    pub ixx_kgm2: f64,
    pub iyy_kgm2: f64,
    pub izz_kgm2: f64,
    pub ixz_kgm2: f64,
}

impl RigidBody {
    /// The body's values in the order of [`Rider::NAMES`].
    pub fn to_array(&self) -> [f64; 7] {
        [
            self.mass_kg,
            self.x_m,
            self.z_m,
            self.ixx_kgm2,
            self.iyy_kgm2,
            self.izz_kgm2,
            self.ixz_kgm2,
        ]
    }

    /// A body from values in the order of [`Rider::NAMES`].
    pub fn from_array(v: &[f64; 7]) -> RigidBody {
        RigidBody {
            mass_kg: v[0],
            x_m: v[1],
            z_m: v[2],
            ixx_kgm2: v[3],
            iyy_kgm2: v[4],
            izz_kgm2: v[5],
            ixz_kgm2: v[6],
        }
    }
}

impl Benchmark {
    /// The bicycle with `p` added to its frame: [`Benchmark::with_body`] with no inertia of
    /// its own.
    pub fn with_point_mass(&self, p: &PointMass) -> Benchmark {
        let body = RigidBody {
            mass_kg: p.mass_kg,
            x_m: p.x_m,
            z_m: p.z_m,
            ixx_kgm2: 0.0,
            iyy_kgm2: 0.0,
            izz_kgm2: 0.0,
            ixz_kgm2: 0.0,
        };
        self.with_body(p.frame, &body)
    }

    /// The bicycle with `body` joined to `frame`: the frame's mass grows, its centre of mass
    /// moves to the joint one, and its inertia about that centre is each part's about its own
    /// centre plus its mass times its offset's parallel-axis term (Steiner; for an offset
    /// (dx, 0, dz) in the x–z plane: `I_xx += m dz²`, `I_yy += m (dx² + dz²)`, `I_zz += m dx²`,
    /// `I_xz −= m dx dz`, the product of inertia being the tensor's off-diagonal element as in
    /// Meijaard et al. 2007, Table 1).
    pub fn with_body(&self, frame: Frame, body: &RigidBody) -> Benchmark {
        let mut b = *self;
        let (m, x, z, ixx, iyy, izz, ixz) = match frame {
            Frame::Rear => (
                &mut b.m_b,
                &mut b.x_b,
                &mut b.z_b,
                &mut b.i_bxx,
                &mut b.i_byy,
                &mut b.i_bzz,
                &mut b.i_bxz,
            ),
            Frame::Front => (
                &mut b.m_h,
                &mut b.x_h,
                &mut b.z_h,
                &mut b.i_hxx,
                &mut b.i_hyy,
                &mut b.i_hzz,
                &mut b.i_hxz,
            ),
        };
        let total = *m + body.mass_kg;
        if total <= 0.0 {
            return b;
        }
        let centre = [
            (*m * *x + body.mass_kg * body.x_m) / total,
            (*m * *z + body.mass_kg * body.z_m) / total,
        ];
        *ixx += body.ixx_kgm2;
        *iyy += body.iyy_kgm2;
        *izz += body.izz_kgm2;
        *ixz += body.ixz_kgm2;
        for (mass, at) in [(*m, [*x, *z]), (body.mass_kg, [body.x_m, body.z_m])] {
            let (dx, dz) = (at[0] - centre[0], at[1] - centre[1]);
            *ixx += mass * dz * dz;
            *iyy += mass * (dx * dx + dz * dz);
            *izz += mass * dx * dx;
            *ixz -= mass * dx * dz;
        }
        (*m, *x, *z) = (total, centre[0], centre[1]);
        b
    }
}

/// A rider as BicycleParameters gives one (the `Jason*Benchmark.txt` files): a rigid body in
/// the benchmark's axes named as the rear frame's parameters (`mB`, `xB`, `zB`, `IBxx`,
/// `IByy`, `IBzz`, `IBxz`, each with `+/-sigma` or without), who joins the rear frame.
#[derive(Debug, Clone, Copy, PartialEq, serde::Serialize)]
pub struct Rider {
    pub body: RigidBody,
    /// Standard errors in the order of [`Rider::NAMES`] (0 where the file gives none).
    pub se: [f64; 7],
}

impl Rider {
    /// The rider's parameters as BicycleParameters names them.
    pub const NAMES: [&'static str; 7] = ["mB", "xB", "zB", "IBxx", "IByy", "IBzz", "IBxz"];

    /// Reads a rider file; every one of [`Rider::NAMES`] is needed, in a physical range (a
    /// mass of 1–300 kg, a centre of mass within 3 m of the rear contact and above the ground,
    /// inertias of 0–100 kg·m² that a body can have), and `yB`, where given, within 5 cm of the
    /// plane of symmetry (the model is symmetric).
    pub fn parse_text(text: &str, path: &Path) -> Result<Rider, ParamError> {
        let (values, se) = parse_named(text, path, &Rider::NAMES)?;
        let invalid = |message: String| ParamError::Invalid {
            path: path.to_path_buf(),
            message,
        };
        if let Some(k) = values.iter().position(|v| v.is_nan()) {
            return Err(ParamError::Missing {
                path: path.to_path_buf(),
                name: Rider::NAMES[k].into(),
            });
        }
        let (geometry, _) = parse_named(text, path, &["w", "c", "lam"])?;
        if geometry.iter().any(|v| !v.is_nan()) {
            return Err(invalid(
                "a bicycle's parameters (it gives w, c or lam), not a rider's: a rider file gives \
                 mB, xB, zB and the inertias IBxx, IByy, IBzz, IBxz alone"
                    .into(),
            ));
        }
        let (y, _) = parse_named(text, path, &["yB"])?;
        if y[0].abs() > 0.05 {
            return Err(invalid(format!(
                "yB = {} m: a rider off the plane of symmetry (the model is symmetric; at most 0.05 m)",
                y[0]
            )));
        }
        let body = RigidBody::from_array(&values);
        if !(1.0..=300.0).contains(&body.mass_kg) {
            return Err(invalid(format!(
                "mB = {} kg: a rider's mass is 1–300 kg",
                body.mass_kg
            )));
        }
        if body.x_m.abs() > 3.0 || !(-3.0..0.0).contains(&body.z_m) {
            return Err(invalid(format!(
                "the rider's centre of mass (xB, zB) = ({}, {}) m: within 3 m of the rear contact and above the ground (z down, negative)",
                body.x_m, body.z_m
            )));
        }
        let (ixx, iyy, izz) = (body.ixx_kgm2, body.iyy_kgm2, body.izz_kgm2);
        let principal_ok = [ixx, iyy, izz].iter().all(|i| (0.0..=100.0).contains(i))
            && body.ixz_kgm2.abs() <= 100.0
            // The x–z block positive semi-definite, and each moment at most the sum of the
            // other two (a body's inertia).
            && ixx * izz - body.ixz_kgm2 * body.ixz_kgm2 >= 0.0
            && iyy <= ixx + izz + 1e-9
            && ixx <= iyy + izz + 1e-9
            && izz <= ixx + iyy + 1e-9;
        if !principal_ok {
            return Err(invalid(format!(
                "the rider's inertia (IBxx, IByy, IBzz, IBxz) = ({ixx}, {iyy}, {izz}, {}) kg·m² is not a body's (0–100 kg·m², positive semi-definite, each moment at most the sum of the other two)",
                body.ixz_kgm2
            )));
        }
        for (k, (&s, &v)) in se.iter().zip(&values).enumerate() {
            if s > 10.0 * v.abs() + 1.0 {
                return Err(invalid(format!(
                    "`{}`: standard error {s} larger than ten times the value plus one",
                    Rider::NAMES[k]
                )));
            }
        }
        Ok(Rider { body, se })
    }
}

#[cfg(test)]
mod point_mass_tests {
    use super::*;

    /// Against the other route: both parts' inertia about the rear contact (each about its
    /// centre plus its own parallel-axis term there), less the joint mass's about the joint
    /// centre. A mass at the frame's own centre changes the mass alone.
    #[test]
    fn a_point_mass_joins_its_frame_by_parallel_axes() {
        let b = Benchmark::meijaard_2007();
        let p = PointMass {
            frame: Frame::Rear,
            mass_kg: 2.5,
            x_m: 0.9,
            z_m: -1.1,
        };
        let j = b.with_point_mass(&p);
        // About the origin, [xx, yy, zz, xz] of a mass m at (x, z).
        let about_origin =
            |m: f64, x: f64, z: f64| [m * z * z, m * (x * x + z * z), m * x * x, -m * x * z];
        let body = about_origin(b.m_b, b.x_b, b.z_b);
        let point = about_origin(p.mass_kg, p.x_m, p.z_m);
        let joint = about_origin(j.m_b, j.x_b, j.z_b);
        let own = [b.i_bxx, b.i_byy, b.i_bzz, b.i_bxz];
        let got = [j.i_bxx, j.i_byy, j.i_bzz, j.i_bxz];
        for k in 0..4 {
            let expected = own[k] + body[k] + point[k] - joint[k];
            assert!(
                (got[k] - expected).abs() < 1e-12,
                "{k}: {} vs {expected}",
                got[k]
            );
        }
        assert!((j.m_b - 87.5).abs() < 1e-12);
        let at_centre = b.with_point_mass(&PointMass {
            frame: Frame::Front,
            mass_kg: 1.0,
            x_m: b.x_h,
            z_m: b.z_h,
        });
        assert_eq!(at_centre.m_h, b.m_h + 1.0);
        assert_eq!(
            [
                at_centre.i_hxx,
                at_centre.i_hyy,
                at_centre.i_hzz,
                at_centre.i_hxz,
                at_centre.x_h
            ],
            [b.i_hxx, b.i_hyy, b.i_hzz, b.i_hxz, b.x_h]
        );
    }
}
