//! A known linear steer controller in the model: a steer motor (or a robot) that applies a
//! torque from the measured state, with gains that change with speed.
//!
//! In: the gains against speed, from a `[controller]` table of a campaign manifest or of its
//! own TOML file. Out: the gains at a speed, which [`super::Canonical::state_matrix`] closes
//! the loop with:
//!
//! ```text
//! M q̈ + v C₁ q̇ + (g K₀ + v² K₂) q = (0, T_δ),
//! T_δ = a (k_φ(v) φ + k_δ(v) δ + k_φ̇(v) φ̇ + k_δ̇(v) δ̇)
//! ```
//!
//! in the benchmark's signs (Meijaard et al. 2007: roll φ and steer δ positive to the right,
//! T_δ the torque on the front frame turning it right); `a` is the delivered torque over the
//! commanded one (1 for an ideal actuator; the gap's actuator-gain effect fits it). A controller
//! that steers into a fall has positive roll and roll-rate gains in these signs. BicycleParameters'
//! steer-control models write the same law as `T_δ = −(k_φ φ + … )`: their gains are these
//! with the sign changed.
//!
//! ```toml
//! [controller]
//! description = "balance assist, G = 6"
//! speeds_mps = [0.0, 4.7, 20.0]
//! roll_rate_nms_per_rad = [28.2, 0.0, 0.0]
//! roll_nm_per_rad = [0.0, 0.0, 10.71]
//! ```
//!
//! Each gain is interpolated linearly in speed between the points and held constant beyond
//! the first and the last; a gain not given is zero.

use crate::read::manifest::ManifestError;
use std::path::Path;

/// The most speed points a controller's table may have.
pub const MAX_POINTS: usize = 32;

/// The largest gain a controller file may hold (N·m/rad or N·m·s/rad): a steer motor on a
/// bicycle gives tens (the balance-assist bicycle's 28); 10⁴ leaves room for any real one.
pub const MAX_GAIN: f64 = 1e4;

/// The state the gains multiply, in the order of the model's state `(φ, δ, φ̇, δ̇)`.
pub const GAIN_KEYS: [&str; 4] = [
    "roll_nm_per_rad",
    "steer_nm_per_rad",
    "roll_rate_nms_per_rad",
    "steer_rate_nms_per_rad",
];

/// A linear steer controller with speed-scheduled gains (a fixed-size table, so that the model
/// that carries it stays `Copy`). [`SteerControl::NONE`] is the uncontrolled bicycle.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct SteerControl {
    points: usize,
    speeds_mps: [f64; MAX_POINTS],
    /// Per point, the gains on `(φ, δ, φ̇, δ̇)`: N·m/rad, N·m/rad, N·m·s/rad, N·m·s/rad.
    gains: [[f64; 4]; MAX_POINTS],
    /// The delivered torque over the commanded one.
    pub actuator_gain: f64,
    /// The speed the controller schedules its gains on over the bicycle's: its own speed
    /// sensor's scale (1 for a sensor that reads true; the gap's sensed-speed effect fits it).
    pub speed_sensor_scale: f64,
}

/// Errors of a controller's table.
#[derive(Debug, thiserror::Error)]
pub enum ControlError {
    #[error(transparent)]
    Toml(#[from] ManifestError),
    #[error("{path}: {message}")]
    Invalid {
        path: std::path::PathBuf,
        message: String,
    },
}

/// A `[controller]` table as written.
#[derive(Debug, Clone, serde::Deserialize)]
#[serde(deny_unknown_fields)]
pub struct ControllerSpec {
    /// What the controller is (for the reports).
    #[serde(default)]
    pub description: String,
    pub speeds_mps: Vec<f64>,
    #[serde(default)]
    pub roll_nm_per_rad: Option<Vec<f64>>,
    #[serde(default)]
    pub steer_nm_per_rad: Option<Vec<f64>>,
    #[serde(default)]
    pub roll_rate_nms_per_rad: Option<Vec<f64>>,
    #[serde(default)]
    pub steer_rate_nms_per_rad: Option<Vec<f64>>,
}

/// A campaign manifest's controller: its own `[controller]` table, or the path of a TOML file
/// holding one (`controller = "gains.toml"`, relative to the manifest), as a lab keeps one
/// controller's gains for several campaigns.
#[derive(Debug, Clone)]
pub enum ControllerEntry {
    /// `controller = "FILE"`.
    File(std::path::PathBuf),
    /// A `[controller]` table in the manifest.
    Table(ControllerSpec),
}

impl<'de> serde::Deserialize<'de> for ControllerEntry {
    /// A string is a file's path; a table is read as [`ControllerSpec`], its own errors (an
    /// unknown key, a missing list) kept as they are.
    fn deserialize<D: serde::Deserializer<'de>>(d: D) -> Result<Self, D::Error> {
        struct Entry;
        impl<'de> serde::de::Visitor<'de> for Entry {
            type Value = ControllerEntry;
            fn expecting(&self, f: &mut std::fmt::Formatter) -> std::fmt::Result {
                f.write_str("a [controller] table, or the path of a TOML file holding one")
            }
            fn visit_str<E: serde::de::Error>(self, s: &str) -> Result<ControllerEntry, E> {
                Ok(ControllerEntry::File(s.into()))
            }
            fn visit_map<A: serde::de::MapAccess<'de>>(
                self,
                map: A,
            ) -> Result<ControllerEntry, A::Error> {
                use serde::Deserialize as _;
                ControllerSpec::deserialize(serde::de::value::MapAccessDeserializer::new(map))
                    .map(ControllerEntry::Table)
            }
        }
        d.deserialize_any(Entry)
    }
}

impl SteerControl {
    /// No controller.
    pub const NONE: SteerControl = SteerControl {
        points: 0,
        speeds_mps: [0.0; MAX_POINTS],
        gains: [[0.0; 4]; MAX_POINTS],
        actuator_gain: 1.0,
        speed_sensor_scale: 1.0,
    };

    /// Whether there is no controller (no gain anywhere differs from zero).
    pub fn is_none(&self) -> bool {
        self.gains[..self.points]
            .iter()
            .all(|g| g.iter().all(|&k| k == 0.0))
    }

    /// A controller from its table; `path` names the file for the errors. The speeds must
    /// increase, every gain list match them in length, every number be finite.
    pub fn from_spec(spec: &ControllerSpec, path: &Path) -> Result<SteerControl, ControlError> {
        let bad = |message: String| ControlError::Invalid {
            path: path.to_path_buf(),
            message: format!("[controller]: {message}"),
        };
        let n = spec.speeds_mps.len();
        if n == 0 || n > MAX_POINTS {
            return Err(bad(format!(
                "speeds_mps has {n} points (1 to {MAX_POINTS})"
            )));
        }
        if spec.speeds_mps.iter().any(|v| !v.is_finite() || *v < 0.0)
            || spec.speeds_mps.windows(2).any(|w| w[1] <= w[0])
        {
            return Err(bad(format!(
                "speeds_mps = {:?} must be speeds (m/s, ≥ 0) that increase",
                spec.speeds_mps
            )));
        }
        let lists = [
            &spec.roll_nm_per_rad,
            &spec.steer_nm_per_rad,
            &spec.roll_rate_nms_per_rad,
            &spec.steer_rate_nms_per_rad,
        ];
        if lists.iter().all(|l| l.is_none()) {
            return Err(bad(format!(
                "speeds and no gains: give at least one of {} (one value per speed)",
                GAIN_KEYS.join(", ")
            )));
        }
        let mut c = SteerControl {
            points: n,
            ..SteerControl::NONE
        };
        c.speeds_mps[..n].copy_from_slice(&spec.speeds_mps);
        for (j, (list, key)) in lists.iter().zip(GAIN_KEYS).enumerate() {
            let Some(list) = list else { continue };
            if list.len() != n {
                return Err(bad(format!(
                    "{key} has {} values for {n} speeds",
                    list.len()
                )));
            }
            if let Some(x) = list
                .iter()
                .find(|x| !(x.is_finite() && x.abs() <= MAX_GAIN))
            {
                return Err(bad(format!(
                    "{key} holds {x:e}, not a gain a steer motor gives (at most {MAX_GAIN:e} \
                     in size, SI units)"
                )));
            }
            for (k, &x) in list.iter().enumerate() {
                c.gains[k][j] = x;
            }
        }
        Ok(c)
    }

    /// The gains on `(φ, δ, φ̇, δ̇)` at the bicycle's speed `v` (m/s), times the actuator's
    /// gain: the table read at the speed the controller senses (`speed_sensor_scale` × v),
    /// linear between the table's speeds, constant beyond its ends; zeros without a controller.
    pub fn gains_at(&self, v: f64) -> [f64; 4] {
        let v = self.speed_sensor_scale * v;
        let n = self.points;
        if n == 0 {
            return [0.0; 4];
        }
        let s = &self.speeds_mps[..n];
        let g = if v <= s[0] {
            self.gains[0]
        } else if v >= s[n - 1] {
            self.gains[n - 1]
        } else {
            let k = s.partition_point(|&x| x <= v) - 1;
            let f = (v - s[k]) / (s[k + 1] - s[k]);
            std::array::from_fn(|j| {
                self.gains[k][j] + f * (self.gains[k + 1][j] - self.gains[k][j])
            })
        };
        g.map(|k| k * self.actuator_gain)
    }

    /// The table's speeds (m/s).
    pub fn speeds_mps(&self) -> &[f64] {
        &self.speeds_mps[..self.points]
    }
}

impl Default for SteerControl {
    fn default() -> Self {
        SteerControl::NONE
    }
}

/// A geared steer motor as a manifest declares it (`[steer_motor]`): its rotor's inertia from
/// the motor's data sheet and the gearbox's ratio. Powered or not, the rotor turns `gear_ratio`
/// times as fast as the steer, so it adds its inertia times the ratio squared about the steer
/// axis ([`SteerMotorSpec::reflected_inertia_kg_m2`]), from which the gap diagnosis's
/// `steer_inertia` then takes its plausible range (0.8–2 times it) instead of the library's
/// catalogue-wide one.
#[derive(Debug, Clone, Copy, PartialEq, serde::Deserialize)]
#[serde(deny_unknown_fields)]
pub struct SteerMotorSpec {
    /// The rotor's moment of inertia about its own axis (kg·m²): a data sheet's, 1e-6 to
    /// 1e-3 for the motors that steer a bicycle.
    pub rotor_inertia_kg_m2: f64,
    /// Rotor turns per steer turn (a 10–50:1 planetary or worm stage, or a belt).
    pub gear_ratio: f64,
}

/// The largest rotor inertia a declared steer motor may have (kg·m²): ten times a 200 W
/// servo motor's (about 1e-3); a larger value is a unit slip (g·cm² read as kg·m² is 1e7 too
/// large).
pub const MAX_ROTOR_INERTIA_KG_M2: f64 = 0.01;

/// The largest gear ratio a declared steer motor may have: a two-stage worm gear's; beyond
/// it the reflected inertia of even a small rotor exceeds a bicycle's front frame many times.
pub const MAX_GEAR_RATIO: f64 = 1000.0;

impl SteerMotorSpec {
    /// The inertia the motor adds about the steer axis: `J_r N²` (the rotor's kinetic energy
    /// ½ J_r (N δ̇)² seen as ½ J δ̇² at the steer), without the gearbox's own stages.
    pub fn reflected_inertia_kg_m2(&self) -> f64 {
        self.rotor_inertia_kg_m2 * self.gear_ratio * self.gear_ratio
    }

    /// Checks the declared values: the rotor's inertia positive and at most
    /// [`MAX_ROTOR_INERTIA_KG_M2`], the ratio from 1 to [`MAX_GEAR_RATIO`]; an error gives the
    /// key at fault and a message naming it.
    pub fn check(&self) -> Result<(), (&'static str, String)> {
        let (j, n) = (self.rotor_inertia_kg_m2, self.gear_ratio);
        if !(j.is_finite() && j > 0.0 && j <= MAX_ROTOR_INERTIA_KG_M2) {
            return Err((
                "rotor_inertia_kg_m2",
                format!(
                    "rotor_inertia_kg_m2 = {j} is outside (0, {MAX_ROTOR_INERTIA_KG_M2}] kg·m² \
                 (a data sheet's g·cm² is 1e-7 kg·m²)"
                ),
            ));
        }
        if !(n.is_finite() && (1.0..=MAX_GEAR_RATIO).contains(&n)) {
            return Err((
                "gear_ratio",
                format!(
                    "gear_ratio = {n} is outside [1, {MAX_GEAR_RATIO}] (rotor turns per steer \
                     turn)"
                ),
            ));
        }
        Ok(())
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn spec(speeds: Vec<f64>, roll_rate: Vec<f64>) -> ControllerSpec {
        ControllerSpec {
            description: String::new(),
            speeds_mps: speeds,
            roll_nm_per_rad: None,
            steer_nm_per_rad: None,
            roll_rate_nms_per_rad: Some(roll_rate),
            steer_rate_nms_per_rad: None,
        }
    }

    /// Issue 33: a gain no steer motor gives (1e300 gave eigenvalues of −2e299 and "stable
    /// above 4.9965 m/s") and a table of speeds without gains (it acted as no controller) are
    /// refused, naming the key.
    #[test]
    fn absurd_gains_and_a_table_without_gains_are_refused() {
        let e = SteerControl::from_spec(
            &spec(vec![0.0, 4.7, 20.0], vec![1e300, 0.0, 0.0]),
            Path::new("c"),
        )
        .unwrap_err()
        .to_string();
        assert!(e.contains("roll_rate_nms_per_rad holds 1e300"), "{e}");
        let mut none = spec(vec![0.0, 4.7], vec![]);
        none.roll_rate_nms_per_rad = None;
        let e = SteerControl::from_spec(&none, Path::new("c"))
            .unwrap_err()
            .to_string();
        assert!(e.contains("speeds and no gains"), "{e}");
    }

    #[test]
    fn gains_are_interpolated_and_held_beyond_the_table() {
        let c = SteerControl::from_spec(
            &spec(vec![0.0, 4.7, 20.0], vec![28.2, 0.0, 0.0]),
            Path::new("c"),
        )
        .unwrap();
        // G (4.7 − v) with G = 6 is exact on the first segment.
        for v in [0.0, 1.0, 2.35, 4.0] {
            assert!((c.gains_at(v)[2] - 6.0 * (4.7 - v)).abs() < 1e-12);
        }
        assert_eq!(c.gains_at(30.0), [0.0; 4]);
        assert_eq!(c.gains_at(-1.0)[2], 28.2);
        assert!(!c.is_none());
        assert!(SteerControl::NONE.is_none());
    }

    /// A constant roll gain is a change of the stiffness `g K₀` (its steer row's roll entry
    /// less k_φ), a constant steer-rate gain one of the damping `v C₁` (its steer row's steer
    /// entry less k_δ̇): the closed loop's state matrix must equal the open loop's with those
    /// matrices changed (Meijaard et al. 2007's benchmark, to rounding).
    #[test]
    fn constant_gains_are_changes_of_the_canonical_matrices() {
        use crate::model::{Benchmark, Canonical};
        let open = Canonical::from_benchmark(&Benchmark::meijaard_2007());
        let (k_roll, k_steer_rate) = (7.5, -0.8);
        let control = SteerControl::from_spec(
            &ControllerSpec {
                roll_nm_per_rad: Some(vec![k_roll]),
                steer_rate_nms_per_rad: Some(vec![k_steer_rate]),
                ..spec(vec![3.0], vec![0.0])
            },
            Path::new("c"),
        )
        .unwrap();
        let closed = open.with_control(control);
        for v in [0.5, 2.0, 4.3, 6.1, 9.0] {
            let mut changed = open;
            changed.k0[(1, 0)] -= k_roll / open.g;
            changed.c1[(1, 1)] -= k_steer_rate / v;
            let (a, b) = (
                closed.state_matrix(v).unwrap(),
                changed.state_matrix(v).unwrap(),
            );
            assert!(
                (a - b).abs().max() < 1e-12,
                "at {v} m/s: {}",
                (a - b).abs().max()
            );
        }
        // The actuator's gain scales every gain.
        let half = SteerControl {
            actuator_gain: 0.5,
            ..control
        };
        assert_eq!(
            half.gains_at(3.0),
            [0.5 * k_roll, 0.0, 0.0, 0.5 * k_steer_rate]
        );
    }

    #[test]
    fn a_bad_table_is_refused_with_what_is_wrong() {
        let path = Path::new("c.toml");
        let e = SteerControl::from_spec(&spec(vec![0.0, 4.7], vec![1.0]), path).unwrap_err();
        assert!(
            e.to_string()
                .contains("roll_rate_nms_per_rad has 1 values for 2 speeds"),
            "{e}"
        );
        let e = SteerControl::from_spec(&spec(vec![4.7, 0.0], vec![1.0, 2.0]), path).unwrap_err();
        assert!(e.to_string().contains("increase"), "{e}");
        let e = SteerControl::from_spec(&spec(vec![], vec![]), path).unwrap_err();
        assert!(e.to_string().contains("0 points"), "{e}");
    }
}
