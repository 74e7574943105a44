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
pub mod imu;
pub mod jet;
pub mod linearize;
pub mod ode;
pub mod pendulum;
pub mod ride;
pub mod rng;
pub mod whipple;

use imu::{FileSpec, LinkModel, SensorModel};
use pendulum::{Pendulum, PendulumTruth, Placement, Release};
use rng::Rng;

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
    let mut rng = Rng::new(seed);
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
