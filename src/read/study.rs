//! A study: one bicycle ridden in several conditions, each a campaign manifest of its own (its
//! controller off or at a gain, a known change). In: a study manifest (`version = 1`,
//! `conditions = ["uncontrolled.toml", "gain6.toml", …]`, each beside it) or the campaign
//! manifests themselves. Out: the conditions, named by their manifests' stems, loaded and
//! checked ([`RideManifest::load`]), and the bicycle they share.

use super::manifest::{from_toml, ManifestError};
use super::rides::RideManifest;
use std::path::{Path, PathBuf};

/// A study manifest as written.
#[derive(Debug, Clone, serde::Deserialize)]
#[serde(deny_unknown_fields)]
struct StudyFile {
    version: u32,
    /// What the study is (for the reports).
    #[serde(default)]
    description: String,
    conditions: Vec<PathBuf>,
}

/// The conditions of a study, each named by its manifest's stem, in the order given.
#[derive(Debug, Clone)]
pub struct Study {
    /// What the study is, as its manifest says (empty for manifests given one by one).
    pub description: String,
    pub conditions: Vec<(String, RideManifest)>,
}

impl Study {
    /// Reads a study manifest and every campaign it lists (beside it, or below it).
    pub fn load(path: &Path) -> Result<Study, ManifestError> {
        let text = super::manifest::read_text(path, "the study manifest")?;
        let file: StudyFile = from_toml(path, &text)?;
        let err = |needle: &str, message: String| ManifestError::at(path, &text, needle, message);
        super::manifest::check_version(path, &text, file.version)?;
        let dir = path.parent().unwrap_or(Path::new(""));
        for c in &file.conditions {
            if !super::manifest::within_folder(c) {
                return Err(err(
                    &c.display().to_string(),
                    format!(
                        "the condition {} lies outside the study manifest's folder",
                        c.display()
                    ),
                ));
            }
        }
        let paths: Vec<PathBuf> = file.conditions.iter().map(|c| dir.join(c)).collect();
        if paths.is_empty() {
            return Err(err(
                "conditions",
                "conditions = [] lists no campaign".into(),
            ));
        }
        Ok(Study {
            description: file.description,
            ..Study::from_manifests(&paths)?
        })
    }

    /// The conditions of the campaign manifests `paths` (two or more make a study): each loaded, names (their stems) distinct, no manifest twice.
    pub fn from_manifests(paths: &[PathBuf]) -> Result<Study, ManifestError> {
        let mut conditions: Vec<(String, RideManifest)> = Vec::with_capacity(paths.len());
        let mut seen: Vec<PathBuf> = Vec::new();
        for p in paths {
            let canonical = std::fs::canonicalize(p).unwrap_or_else(|_| p.clone());
            if seen.contains(&canonical) {
                return Err(ManifestError {
                    path: p.clone(),
                    line: None,
                    message: "is given twice: each condition once (its rides would count twice)"
                        .into(),
                });
            }
            seen.push(canonical);
            let name = p
                .file_stem()
                .map(|s| s.to_string_lossy().into_owned())
                .unwrap_or_default();
            if conditions.iter().any(|(n, _)| *n == name) {
                return Err(ManifestError {
                    path: p.clone(),
                    line: None,
                    message: format!(
                        "a second condition named \"{name}\" (conditions are named by their \
                         manifests' file names, which must differ)"
                    ),
                });
            }
            // A study's condition is a campaign: another kind of file is said as what it is
            // (a study, a log or a bicycle file used to get "unknown key `conditions`").
            if let Some(m) = crate::read::kind::mismatch(
                p,
                &|k| matches!(k, crate::read::kind::Kind::RideManifest),
                "a condition of a study: a campaign manifest of rides",
            ) {
                let prefix = format!("{}: ", p.display());
                return Err(ManifestError {
                    path: p.clone(),
                    line: None,
                    message: m.strip_prefix(&prefix).unwrap_or(&m).to_string(),
                });
            }
            let manifest = RideManifest::load(p)?;
            // One bicycle, one steer motor: conditions that declare it must agree.
            if let Some(motor) = manifest.steer_motor {
                let differing = conditions.iter().find_map(|(other, m)| {
                    m.steer_motor.filter(|o| *o != motor).map(|o| (other, o))
                });
                if let Some((other, theirs)) = differing {
                    return Err(ManifestError {
                        path: p.clone(),
                        line: None,
                        message: format!(
                            "[steer_motor] (rotor {} kg·m², ratio {}) differs from the \
                             condition \"{other}\"'s (rotor {} kg·m², ratio {}): a study is one \
                             bicycle, with one motor",
                            motor.rotor_inertia_kg_m2,
                            motor.gear_ratio,
                            theirs.rotor_inertia_kg_m2,
                            theirs.gear_ratio
                        ),
                    });
                }
            }
            // The same ride (its file, and its window where it has one) in two conditions
            // would be counted twice, and its repeat taken for a second observation.
            for ride in &manifest.rides {
                let file = manifest.dir.join(&ride.log);
                let file = std::fs::canonicalize(&file).unwrap_or(file);
                for (other, earlier) in &conditions {
                    let again = earlier.rides.iter().any(|r| {
                        let f = earlier.dir.join(&r.log);
                        std::fs::canonicalize(&f).unwrap_or(f) == file
                            && r.window_s == ride.window_s
                    });
                    if again {
                        return Err(ManifestError {
                            path: p.clone(),
                            line: None,
                            message: format!(
                                "the ride {}{} is also in the condition \"{other}\": a ride \
                                 belongs to one condition (it would count twice)",
                                ride.log.display(),
                                ride.window_s
                                    .map(|[a, b]| format!(" ({a}–{b} s)"))
                                    .unwrap_or_default()
                            ),
                        });
                    }
                }
            }
            conditions.push((name, manifest));
        }
        Ok(Study {
            description: String::new(),
            conditions,
        })
    }

    /// The bicycle the conditions share: every manifest's `bike` must be the same file (a
    /// known change between conditions is written in a condition's manifest, not as another
    /// bicycle file).
    pub fn bike_path(&self) -> Result<PathBuf, ManifestError> {
        let Some((first_name, first)) = self.conditions.first() else {
            return Err(ManifestError {
                path: PathBuf::new(),
                line: None,
                message: "a study without conditions".into(),
            });
        };
        let bike = first.bike_path();
        let canonical = |p: &Path| std::fs::canonicalize(p).unwrap_or_else(|_| p.to_path_buf());
        for (name, m) in self.conditions.iter().skip(1) {
            if canonical(&m.bike_path()) != canonical(&bike) {
                return Err(ManifestError {
                    path: m.bike_path(),
                    line: None,
                    message: format!(
                        "condition \"{name}\" rides another bicycle file than \"{first_name}\" \
                         ({}): a study's conditions share one bicycle (or give --bike)",
                        bike.display()
                    ),
                });
            }
        }
        Ok(bike)
    }
}
