//! Steer controllers' files: a TOML holding a `[controller]` table (the gains on roll, steer and
//! their rates against speed), kept once for a lab's campaigns.
//!
//! In: the file's path. Out: the checked [`SteerControl`] and its description
//! ([`SteerControl::from_spec`] checks every gain); errors name the file and the line.

use super::manifest::from_toml;
use crate::model::control::{ControlError, ControllerSpec};
use crate::model::SteerControl;
use std::path::Path;

/// A TOML file holding a `[controller]` table: a file of its own, or a campaign manifest that
/// carries one (its other keys are the manifest's business; the table's own are checked).
#[derive(Debug, Clone, serde::Deserialize)]
struct ControllerFile {
    controller: ControllerSpec,
}

impl SteerControl {
    /// Reads a TOML file that holds a `[controller]` table.
    pub fn load(path: &Path) -> Result<(SteerControl, String), ControlError> {
        let text = std::fs::read_to_string(path).map_err(|e| ControlError::Invalid {
            path: path.to_path_buf(),
            message: format!("cannot read the controller: {e}"),
        })?;
        let file: ControllerFile = from_toml(path, &text)?;
        Ok((
            SteerControl::from_spec(&file.controller, path)?,
            file.controller.description,
        ))
    }
}
