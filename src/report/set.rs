//! What the reports share: the set of files they make, and the ride campaign of `data/`
//! analysed once for the dynamic and the gap reports.

use super::error::Result;
use std::path::{Path, PathBuf};

/// Files of a report set, relative path → contents.
pub type Files = Vec<(PathBuf, Vec<u8>)>;

/// The ride campaign of `data/rides.toml`, analysed once for the dynamic and the gap reports.
pub(super) struct RideCampaign {
    pub(super) manifest: crate::read::rides::RideManifest,
    pub(super) model: crate::model::uncertain::Parametrized,
    pub(super) results: Vec<crate::ride::dynamic::CampaignRide>,
}

impl RideCampaign {
    /// Loads the manifest and its bicycle and runs every ride's dynamic test with the default
    /// options (the results do not depend on the number of threads: each ride's resampling is
    /// seeded).
    pub(super) fn analyse(data: &Path) -> Result<Self> {
        use crate::read::rides::RideManifest;
        use crate::ride::dynamic::run_campaign;
        let manifest = RideManifest::load(&data.join("rides.toml"))?;
        let model = manifest.model(None)?;
        let results = run_campaign(&manifest, &model, &Default::default(), &|_, _| {});
        Ok(RideCampaign {
            manifest,
            model,
            results,
        })
    }
}
