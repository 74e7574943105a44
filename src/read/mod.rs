//! Reading: every file that comes from outside, in one place.
//!
//! In: paths (files or folders) the user or a manifest names. Out: parsed, checked values (every
//! number finite and in its physical range where it is read) that the stages take; errors that
//! name the file, the line and the column. A format is recognised by its content ([`kind`]),
//! never by the file's name (`tests/layering.rs` checks that no file outside this module looks
//! at an extension).
//!
//! - [`kind`]: what an input is, from its first kilobytes.
//! - [`log`]: the lab's IMU logs (`../shared/formats/imu-log.md`) → samples on the 100 Hz grid.
//! - [`csv`]: tables of time series (CSV) → a signal, a table, or rows as they stream.
//! - [`ride_csv`]: rides from other instruments (CSV with named columns) → a ride in SI
//!   units, or a long recording's kick series and the marks to come back to its kicks.
//! - [`manifest`]: pendulum test manifests, and the TOML reading every manifest shares
//!   (line-numbered errors, the version, files kept inside the manifest's folder).
//! - [`rides`]: campaign manifests (`rides.toml`); [`study`]: study manifests.
//! - [`bicycle`]: bicycle files of every format → the model's parameters.
//! - [`controller`]: steer controllers' files; [`calibration`]: the torsion bar's calibration.
//!
//! The stages take what these give; parsing a value's own text (`Benchmark::parse_text`,
//! `MeasuredFile::parse`) sits beside the value, called from here.

pub mod bicycle;
pub mod calibration;
pub mod controller;
pub mod csv;
pub mod kind;
pub mod log;
pub mod manifest;
pub mod ride_csv;
pub mod rides;
pub mod study;
