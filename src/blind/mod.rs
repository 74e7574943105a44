//! Blind checks, above the simulator and the analysis: campaigns and studies simulated from
//! physics ([`crate::sim`]), written to a scratch folder, diagnosed from their files alone as
//! `bikeproc gap` does ([`crate::gap`]), and only then compared with their sealed truth. The
//! simulator never runs the analysis; this module is where the two meet.
//!
//! - [`campaigns`]: blind campaigns, one effect withheld (`docs/gap-calibration.md`).
//! - [`studies`]: blind studies of a steer motor (`docs/study-calibration.md`).
//! - [`replay`]: a few recorded cases of either file run again and compared exactly, so that a
//!   change that moves a calibration fails until the file is made again.

pub mod campaigns;
pub mod replay;
pub mod studies;

/// Why a blind campaign or study could not be simulated into its scratch folder or diagnosed
/// from it.
#[derive(Debug, thiserror::Error)]
pub enum BlindError {
    #[error("{}: {source}", path.display())]
    Scratch {
        path: std::path::PathBuf,
        source: std::io::Error,
    },
    /// A stage's own error (the simulator's, a reader's, the gap's), as it says it.
    #[error(transparent)]
    Stage(Box<dyn std::error::Error + Send + Sync>),
}

/// A stage's error as a [`BlindError`].
pub fn stage(e: impl std::error::Error + Send + Sync + 'static) -> BlindError {
    BlindError::Stage(Box::new(e))
}

/// Runs `analyse` on a scratch folder (`name`, made unique to the process) holding a blind
/// campaign's or study's `files` without its sealed `truth.json`, and the measured bicycle as
/// `bike.toml`; the folder is removed afterwards.
pub fn in_scratch<T>(
    name: &str,
    files: &crate::sim::campaign::Files,
    bike_text: &str,
    analyse: &dyn Fn(&std::path::Path) -> Result<T, BlindError>,
) -> Result<T, BlindError> {
    let dir = std::env::temp_dir().join(format!("bikeproc_{name}_{}", std::process::id()));
    let scratch = |path: std::path::PathBuf| {
        move |source: std::io::Error| BlindError::Scratch { path, source }
    };
    std::fs::create_dir_all(&dir).map_err(scratch(dir.clone()))?;
    let result = (|| {
        for (p, text) in files {
            if p.as_os_str() != "truth.json" {
                std::fs::write(dir.join(p), text).map_err(scratch(dir.join(p)))?;
            }
        }
        let bike = dir.join("bike.toml");
        std::fs::write(&bike, bike_text).map_err(scratch(bike.clone()))?;
        analyse(&dir)
    })();
    std::fs::remove_dir_all(&dir).ok();
    result
}

/// Numbers of which some are `null` (serde_json's NaN), read with NaN in their place.
pub(crate) fn nan_for_null<'de, D: serde::Deserializer<'de>>(d: D) -> Result<Vec<f64>, D::Error> {
    let values: Vec<Option<f64>> = serde::Deserialize::deserialize(d)?;
    Ok(nans(values))
}

fn nans(values: Vec<Option<f64>>) -> Vec<f64> {
    values.into_iter().map(|v| v.unwrap_or(f64::NAN)).collect()
}

/// A number written `null` (serde_json's NaN) read back as NaN, so that a calibration's JSON
/// renders its Markdown again.
pub(crate) fn number_nan_for_null<'de, D: serde::Deserializer<'de>>(d: D) -> Result<f64, D::Error> {
    let v: Option<f64> = serde::Deserialize::deserialize(d)?;
    Ok(v.unwrap_or(f64::NAN))
}

/// A fit's values and standard errors (a study's motor fit) read back, `null` as NaN.
#[allow(clippy::type_complexity)]
pub(crate) fn fit_nan_for_null<'de, D: serde::Deserializer<'de>>(
    d: D,
) -> Result<Option<(Vec<f64>, Vec<f64>)>, D::Error> {
    let v: Option<(Vec<Option<f64>>, Vec<Option<f64>>)> = serde::Deserialize::deserialize(d)?;
    Ok(v.map(|(a, b)| (nans(a), nans(b))))
}
