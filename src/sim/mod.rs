//! Simulation, at the side of the pipeline: the lab simulated from physics, writing logs in the
//! acquisition side's format.
//!
//! In: physical parameters (a [`pendulum::Pendulum`] and its [`pendulum::Release`]), a sensor
//! model, a link model, file settings and a seed. Out: the text of a log pair (`NAME.log`,
//! `NAME_cal.log`) and the truth it was made from. Same inputs and seed: byte-identical text.
//!
//! The simulator integrates its own equations and never calls the estimators
//! ([`crate::spectral`], [`crate::fit`]) or the analysis model: a test that recovers what the
//! simulator put in then proves something.

pub mod campaign;
pub mod draw;
pub mod imu;
pub mod linearize;
pub mod ode;
pub mod pendulum;
pub mod ride;
pub mod study;
pub mod whipple;

use draw::{seeded, Draw};
use imu::{FileSpec, LinkModel, SensorModel};
use pendulum::{Pendulum, PendulumTruth, Placement, Release};

/// A simulated recording: the two files' text and the truth.
#[derive(Debug, Clone)]
pub struct Recording {
    pub angles_log: String,
    pub cal_log: String,
    pub truth: PendulumTruth,
}

/// Simulates one pendulum test as the lab would record it with one sensor.
pub fn simulate_pendulum(
    pendulum: &Pendulum,
    release: &Release,
    placement: &Placement,
    sensor: &SensorModel,
    link: &LinkModel,
    spec: &FileSpec,
    seed: u64,
) -> Recording {
    let mut rng = seeded(seed);
    let mut sensor_rng = rng.fork(1);
    let mut link_rng = rng.fork(2);
    let mut file_rng = rng.fork(3);
    let motion = pendulum.motion(release, placement, spec.rate_hz);
    let imu = sensor.measure(&motion, spec.rate_hz, &mut sensor_rng);
    let packets = link.packets(imu.len(), spec.rate_hz, &mut link_rng);
    let data = [imu];
    let mut cal_rng = file_rng.fork(4);
    Recording {
        angles_log: imu::write_log(spec, false, &data, &packets, None, &mut file_rng),
        cal_log: imu::write_log(spec, true, &data, &packets, None, &mut cal_rng),
        truth: pendulum.truth(release),
    }
}

/// One pendulum test as `bikeproc simulate torsion|compound` writes it: the lab's typical sensor
/// with the given orientation noise, mounted at random (seeded) on the body, the lab's link (or a
/// perfect one) and the acquisition side's file at 100 Hz.
#[derive(Debug, Clone)]
pub struct SingleTest {
    pub pendulum: Pendulum,
    pub release: Release,
    /// The sensor's orientation noise (degrees, 1σ).
    pub noise_deg: f64,
    /// No dropped packets and no clock jitter.
    pub perfect_link: bool,
    pub mode: crate::read::log::OutputMode,
    pub locale: imu::Locale,
    pub precision: imu::Precision,
    pub sensor_id: String,
    pub label: String,
    pub seed: u64,
}

/// Simulates a [`SingleTest`] ([`simulate_pendulum`] with its sensor, mounting, link and file).
pub fn simulate_single(t: &SingleTest) -> Recording {
    let mut rng = seeded(t.seed ^ 0x5EED);
    let mut sensor = SensorModel::typical(&mut rng);
    sensor.orientation_noise_rad = t.noise_deg.to_radians();
    let placement = Placement {
        body_rest: rng.rotation(),
        axis_heading_rad: rng.range(0.0, std::f64::consts::TAU),
        sensor_offset_m: nalgebra::Vector3::new(0.3, 0.05, 0.02),
    };
    let link = if t.perfect_link {
        LinkModel::perfect()
    } else {
        LinkModel::default()
    };
    let spec = FileSpec {
        mode: t.mode,
        locale: t.locale,
        precision: t.precision,
        rate_hz: 100.0,
        sensors: vec![(t.sensor_id.clone(), t.label.clone())],
        first_counter: (t.seed.wrapping_mul(2654435761) % 65_536) as u16,
        start: "2009-03-12 11:42:07".into(),
        extra_header: vec![],
        declare_decimal: true,
        jitter_s: if t.perfect_link { 0.0 } else { 0.0005 },
        late_bursts_per_minute: 0.0,
    };
    simulate_pendulum(
        &t.pendulum,
        &t.release,
        &placement,
        &sensor,
        &link,
        &spec,
        t.seed,
    )
}
