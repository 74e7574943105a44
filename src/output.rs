//! Safe file output, at the side of the pipeline: every file bikeproc writes goes through here.
//!
//! In: a path and its bytes, or a folder and its whole set of files. Out: the file or the folder
//! in place, or an error naming the path; never a half-written file, never a file written
//! through a symlink or over a device, never a mix of an old and a new set. A file is written
//! to a uniquely named temporary file beside it (created exclusively, synced) and renamed over
//! the old one; a folder's set is written whole into a fresh hidden folder beside it and
//! exchanged with the old folder in one step (Linux `renameat2(RENAME_EXCHANGE)`; elsewhere
//! two renames), so a reader, a concurrent run or an interruption sees the old set or the new.

use std::io::Write as _;
use std::path::{Path, PathBuf};
use std::sync::atomic::{AtomicU64, Ordering};

/// Errors of writing output.
#[derive(Debug, thiserror::Error)]
pub enum OutputError {
    #[error("{path}: not a regular file{what}: bikeproc writes only regular files and folders")]
    NotRegular { path: PathBuf, what: &'static str },
    #[error("{path}: {source}")]
    Io {
        path: PathBuf,
        source: std::io::Error,
    },
    /// An output that is one of the command's inputs, or a folder to be replaced that holds
    /// one: writing it would destroy what the command reads.
    #[error(
        "{output}: refused as the output: it {how} {input}, which writing it would destroy; \
         name another file or folder"
    )]
    OverInput {
        output: PathBuf,
        input: PathBuf,
        how: &'static str,
    },
}

/// The identity of an existing file or folder (device and inode on Unix; its canonical path
/// elsewhere): two paths name the same place whatever their spelling, links or `..`.
fn identity(path: &Path) -> Option<(u64, u64, PathBuf)> {
    let meta = std::fs::metadata(path).ok()?;
    #[cfg(unix)]
    {
        use std::os::unix::fs::MetadataExt as _;
        Some((meta.dev(), meta.ino(), PathBuf::new()))
    }
    #[cfg(not(unix))]
    {
        let _ = meta;
        Some((0, 0, std::fs::canonicalize(path).ok()?))
    }
}

/// Whether `a` and `b` name the same existing file or folder.
pub fn same_place(a: &Path, b: &Path) -> bool {
    matches!((identity(a), identity(b)), (Some(x), Some(y)) if x == y)
}

/// Refuses, before any work, files to be written that are one of the command's `inputs`
/// (`bikeproc measured X.txt --out X.txt`): an output replaced whole would be the input lost.
pub fn refuse_files_over_inputs(outputs: &[&Path], inputs: &[&Path]) -> Result<(), OutputError> {
    for out in outputs {
        if let Some(input) = inputs.iter().find(|i| same_place(out, i)) {
            return Err(OutputError::OverInput {
                output: out.to_path_buf(),
                input: input.to_path_buf(),
                how: "is the input",
            });
        }
    }
    Ok(())
}

/// Refuses, before any work, a folder to be replaced whole ([`replace_dir`]) that is, or
/// holds, one of `inputs` or the working folder (`bikeproc report --out data`): its old set is
/// removed once the new one is in place. Also refuses what [`replace_dir`] would (a file, a
/// symlink), so that the refusal comes before the work, not after it.
pub fn refuse_folder_over_inputs(dir: &Path, inputs: &[&Path]) -> Result<(), OutputError> {
    if !check_destination(dir, true)? {
        return Ok(());
    }
    let Ok(root) = std::fs::canonicalize(dir) else {
        return Ok(());
    };
    let cwd = std::env::current_dir().ok();
    let working = cwd
        .as_deref()
        .map(|c| (c, "is or holds the working folder"));
    let named = inputs.iter().map(|i| (*i, "is or holds the input"));
    for (input, how) in named.chain(working) {
        let Ok(inside) = std::fs::canonicalize(input) else {
            continue;
        };
        if inside.starts_with(&root) {
            return Err(OutputError::OverInput {
                output: dir.to_path_buf(),
                input: input.to_path_buf(),
                how,
            });
        }
    }
    Ok(())
}

fn io(path: &Path) -> impl FnOnce(std::io::Error) -> OutputError + '_ {
    move |source| OutputError::Io {
        path: path.to_path_buf(),
        source,
    }
}

/// A name no other writer uses: the process, the time and a per-process count.
fn unique_suffix() -> String {
    static COUNT: AtomicU64 = AtomicU64::new(0);
    let nanos = std::time::SystemTime::now()
        .duration_since(std::time::UNIX_EPOCH)
        .map_or(0, |d| d.as_nanos());
    format!(
        "{}-{nanos}-{}",
        std::process::id(),
        COUNT.fetch_add(1, Ordering::Relaxed)
    )
}

/// Refuses a destination that exists and is a symlink or anything but `want_dir` (a folder)
/// or a regular file.
fn check_destination(path: &Path, want_dir: bool) -> Result<bool, OutputError> {
    match std::fs::symlink_metadata(path) {
        Ok(m) if m.file_type().is_symlink() => Err(OutputError::NotRegular {
            path: path.to_path_buf(),
            what: " (a symlink)",
        }),
        Ok(m) if want_dir && !m.is_dir() => Err(OutputError::NotRegular {
            path: path.to_path_buf(),
            what: " (not a folder)",
        }),
        Ok(m) if !want_dir && !m.is_file() => Err(OutputError::NotRegular {
            path: path.to_path_buf(),
            what: if m.is_dir() {
                " (a folder)"
            } else {
                " (a device, pipe or socket)"
            },
        }),
        Ok(_) => Ok(true),
        Err(e) if e.kind() == std::io::ErrorKind::NotFound => Ok(false),
        Err(e) => Err(io(path)(e)),
    }
}

/// Writes `bytes` to a new file at `path` (created exclusively) and syncs it.
fn write_new(path: &Path, bytes: &[u8]) -> Result<(), OutputError> {
    let mut f = std::fs::OpenOptions::new()
        .write(true)
        .create_new(true)
        .open(path)
        .map_err(io(path))?;
    f.write_all(bytes).map_err(io(path))?;
    f.sync_all().map_err(io(path))
}

/// Writes `path` whole: through a uniquely named temporary file beside it and a rename. A
/// symlink, a folder or a device at `path` is refused, not written through; the folder it
/// goes in is created.
pub fn write_atomic(path: &Path, bytes: &[u8]) -> Result<(), OutputError> {
    write_atomic_set(&[(path, bytes)])
}

/// Writes several files whole, as [`write_atomic`] one: every destination is checked before
/// any is written, and every temporary file written before any is renamed into place, so a
/// refused or failed one leaves none of the set behind (a log and its `_cal.log`, one of them
/// a symlink, used to leave the log written and the command failed).
pub fn write_atomic_set(files: &[(&Path, &[u8])]) -> Result<(), OutputError> {
    for (path, _) in files {
        check_destination(path, false)?;
    }
    let mut temps: Vec<PathBuf> = Vec::with_capacity(files.len());
    let staged = files.iter().try_for_each(|(path, bytes)| {
        if let Some(dir) = path.parent().filter(|d| !d.as_os_str().is_empty()) {
            std::fs::create_dir_all(dir).map_err(io(dir))?;
        }
        let name = path
            .file_name()
            .map(|n| n.to_string_lossy().into_owned())
            .unwrap_or_default();
        let tmp = path.with_file_name(format!(".{name}.{}.tmp", unique_suffix()));
        temps.push(tmp.clone());
        write_new(&tmp, bytes)
    });
    // Checked again: something may have appeared meanwhile.
    let result = staged
        .and_then(|()| {
            files
                .iter()
                .try_for_each(|(p, _)| check_destination(p, false).map(|_| ()))
        })
        .and_then(|()| {
            files
                .iter()
                .zip(&temps)
                .try_for_each(|((path, _), tmp)| std::fs::rename(tmp, path).map_err(io(path)))
        });
    if result.is_err() {
        for tmp in &temps {
            let _ = std::fs::remove_file(tmp);
        }
    }
    result
}

/// Replaces the folder `dir` by exactly `files` (paths relative to it): all are written into a
/// fresh hidden folder beside it, which is then exchanged with `dir` in one step and the old
/// set removed. A symlink or a file at `dir` is refused. Leftovers of runs that were killed
/// (hidden folders of processes that no longer exist) are removed first.
pub fn replace_dir(dir: &Path, files: &[(PathBuf, Vec<u8>)]) -> Result<(), OutputError> {
    let exists = check_destination(dir, true)?;
    let parent = match dir.parent().filter(|d| !d.as_os_str().is_empty()) {
        Some(p) => p.to_path_buf(),
        None => PathBuf::from("."),
    };
    std::fs::create_dir_all(&parent).map_err(io(&parent))?;
    let name = dir
        .file_name()
        .map(|n| n.to_string_lossy().into_owned())
        .unwrap_or_else(|| "out".into());
    remove_leftovers(&parent, &name);
    let staging = parent.join(format!(".{name}.new-{}", unique_suffix()));
    std::fs::create_dir(&staging).map_err(io(&staging))?;
    let result = (|| {
        for (rel, bytes) in files {
            let path = staging.join(rel);
            if let Some(d) = path.parent() {
                std::fs::create_dir_all(d).map_err(io(d))?;
            }
            write_new(&path, bytes)?;
        }
        if exists {
            exchange(&staging, dir)?;
        } else {
            std::fs::rename(&staging, dir).map_err(io(dir))?;
        }
        Ok(())
    })();
    // After an exchange the staging name holds the old set; after a failure, the partial new.
    let _ = std::fs::remove_dir_all(&staging);
    result
}

/// Swaps two folders in one step.
#[cfg(target_os = "linux")]
fn exchange(a: &Path, b: &Path) -> Result<(), OutputError> {
    use rustix::fs::{renameat_with, RenameFlags, CWD};
    match renameat_with(CWD, a, CWD, b, RenameFlags::EXCHANGE) {
        Ok(()) => Ok(()),
        // A file system without the exchange: the two renames.
        Err(rustix::io::Errno::INVAL) | Err(rustix::io::Errno::NOSYS) => exchange_by_renames(a, b),
        Err(e) => Err(io(b)(e.into())),
    }
}

#[cfg(not(target_os = "linux"))]
fn exchange(a: &Path, b: &Path) -> Result<(), OutputError> {
    exchange_by_renames(a, b)
}

/// `b` aside, `a` into its place, the old `b` to `a`'s name: a moment without `b`, never a mix.
fn exchange_by_renames(a: &Path, b: &Path) -> Result<(), OutputError> {
    let aside = b.with_file_name(format!(
        ".{}.old-{}",
        b.file_name().map_or("out".into(), |n| n.to_string_lossy()),
        unique_suffix()
    ));
    std::fs::rename(b, &aside).map_err(io(b))?;
    if let Err(e) = std::fs::rename(a, b) {
        let _ = std::fs::rename(&aside, b);
        return Err(io(b)(e));
    }
    std::fs::rename(&aside, a).map_err(io(a))
}

/// Removes `.NAME.new-PID-…` and `.NAME.old-PID-…` folders in `parent` whose process is gone
/// (Linux: no `/proc/PID`; elsewhere nothing is removed).
fn remove_leftovers(parent: &Path, name: &str) {
    let Ok(entries) = std::fs::read_dir(parent) else {
        return;
    };
    for e in entries.flatten() {
        let file = e.file_name().to_string_lossy().into_owned();
        let Some(rest) = file
            .strip_prefix(&format!(".{name}.new-"))
            .or_else(|| file.strip_prefix(&format!(".{name}.old-")))
        else {
            continue;
        };
        let Some(pid) = rest.split('-').next().and_then(|p| p.parse::<u32>().ok()) else {
            continue;
        };
        let gone = cfg!(target_os = "linux")
            && pid != std::process::id()
            && !Path::new(&format!("/proc/{pid}")).exists();
        if gone {
            let _ = std::fs::remove_dir_all(e.path());
        }
    }
}

/// Whether a file to be written is named as TOML (`*.toml`): it has no content yet to be
/// recognised by, so its name says the format the user asks for (the readers go by content,
/// [`crate::read::kind`]).
pub fn named_toml(path: &Path) -> bool {
    path.extension().is_some_and(|e| e == "toml")
}

#[cfg(test)]
mod tests {
    use super::*;

    fn scratch(name: &str) -> PathBuf {
        let d = std::env::temp_dir().join(format!("bikeproc_output_{name}_{}", std::process::id()));
        let _ = std::fs::remove_dir_all(&d);
        std::fs::create_dir_all(&d).unwrap();
        d
    }

    #[test]
    fn a_file_is_replaced_whole_and_no_temporary_is_left() {
        let d = scratch("file");
        let p = d.join("a.txt");
        write_atomic(&p, b"old").unwrap();
        write_atomic(&p, b"new").unwrap();
        assert_eq!(std::fs::read(&p).unwrap(), b"new");
        assert_eq!(std::fs::read_dir(&d).unwrap().count(), 1);
        std::fs::remove_dir_all(&d).unwrap();
    }

    #[cfg(unix)]
    #[test]
    fn a_symlink_or_a_device_is_refused_not_written_through() {
        let d = scratch("link");
        let target = d.join("target.txt");
        std::fs::write(&target, b"keep").unwrap();
        let link = d.join("link.txt");
        std::os::unix::fs::symlink(&target, &link).unwrap();
        let e = write_atomic(&link, b"x").unwrap_err().to_string();
        assert!(e.contains("a symlink"), "{e}");
        assert_eq!(std::fs::read(&target).unwrap(), b"keep");
        let e = write_atomic(Path::new("/dev/null"), b"x")
            .unwrap_err()
            .to_string();
        assert!(e.contains("device"), "{e}");
        let e = replace_dir(&link, &[]).unwrap_err().to_string();
        assert!(e.contains("a symlink"), "{e}");
        std::fs::remove_dir_all(&d).unwrap();
    }

    #[test]
    fn a_folder_is_replaced_by_exactly_the_new_set() {
        let d = scratch("dir");
        let out = d.join("reports");
        replace_dir(
            &out,
            &[
                ("a.md".into(), b"1".to_vec()),
                ("x/b.svg".into(), b"2".to_vec()),
            ],
        )
        .unwrap();
        replace_dir(&out, &[("a.md".into(), b"3".to_vec())]).unwrap();
        assert_eq!(std::fs::read(out.join("a.md")).unwrap(), b"3");
        assert!(!out.join("x").exists());
        // Nothing beside it but the folder.
        assert_eq!(std::fs::read_dir(&d).unwrap().count(), 1);
        std::fs::remove_dir_all(&d).unwrap();
    }
}
