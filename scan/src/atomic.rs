//! Atomic file and folder publication: a reader sees either nothing or the
//! complete result, never a half-written file or bundle.
//!
//! Files are written to a hidden temporary name in the destination folder
//! (`.<name>.tmp-<pid>-<n>`), flushed to disk, renamed onto the final name,
//! and the folder is flushed so the rename survives a power cut. A whole
//! folder is built as a hidden temporary sibling ([`PendingDir`]) and renamed
//! into place in one step. Same-folder temporaries keep every rename on one
//! file system, where rename is atomic.
//!
//! Boundaries: no knowledge of what is written; callers bring the bytes.

use crate::error::ScanError;
use std::ffi::OsString;
use std::fs::{self, File};
use std::io::{BufWriter, Write};
use std::path::{Path, PathBuf};
use std::sync::atomic::{AtomicU64, Ordering};

/// Writes `bytes` to `path` atomically (see the module docs).
pub fn write_atomic(path: &Path, bytes: &[u8]) -> Result<(), ScanError> {
    write_atomic_with(path, |w| {
        w.write_all(bytes).map_err(|e| ScanError::io(path, e))
    })
}

/// Lets `write` fill a buffered temporary file, then renames it onto
/// `path`. On any error the temporary file is removed and `path` is left as
/// it was.
pub fn write_atomic_with<T>(
    path: &Path,
    write: impl FnOnce(&mut BufWriter<File>) -> Result<T, ScanError>,
) -> Result<T, ScanError> {
    let (dir, file_name) = split(path)?;
    let tmp = dir.join(temp_name(&file_name));
    let file = File::create(&tmp).map_err(|e| ScanError::io(&tmp, e))?;
    let result = fill_and_rename(file, &tmp, path, write);
    if result.is_err() {
        // The temporary may be gone already (a failed rename keeps it).
        let _ = fs::remove_file(&tmp);
    }
    let value = result?;
    sync_dir(&dir)?;
    Ok(value)
}

fn fill_and_rename<T>(
    file: File,
    tmp: &Path,
    path: &Path,
    write: impl FnOnce(&mut BufWriter<File>) -> Result<T, ScanError>,
) -> Result<T, ScanError> {
    let mut w = BufWriter::new(file);
    let value = write(&mut w)?;
    let file = w
        .into_inner()
        .map_err(|e| ScanError::io(tmp, e.into_error()))?;
    file.sync_all().map_err(|e| ScanError::io(tmp, e))?;
    drop(file);
    fs::rename(tmp, path).map_err(|e| ScanError::io(path, e))?;
    Ok(value)
}

/// A folder under construction: a hidden temporary sibling of its final
/// path that [`PendingDir::publish`] renames into place. Dropped
/// unpublished, it removes itself and everything written into it.
#[derive(Debug)]
pub struct PendingDir {
    temp: PathBuf,
    target: PathBuf,
    published: bool,
}

impl PendingDir {
    /// Creates the temporary folder next to `target` (creating `target`'s
    /// parent folders if needed). Fails if `target` already exists, so a
    /// long job does not discover that only at the end.
    pub fn create(target: impl Into<PathBuf>) -> Result<Self, ScanError> {
        let target = target.into();
        refuse_existing(&target)?;
        let (parent, name) = split(&target)?;
        fs::create_dir_all(&parent).map_err(|e| ScanError::io(&parent, e))?;
        let temp = parent.join(temp_name(&name));
        fs::create_dir(&temp).map_err(|e| ScanError::io(&temp, e))?;
        Ok(Self {
            temp,
            target,
            published: false,
        })
    }

    /// The temporary folder to write into.
    pub fn path(&self) -> &Path {
        &self.temp
    }

    /// The path the folder will have once published.
    pub fn target(&self) -> &Path {
        &self.target
    }

    /// Renames the folder onto its final path and returns that path.
    /// Refuses (and keeps the temporary folder until drop) if the final path
    /// has appeared meanwhile.
    pub fn publish(mut self) -> Result<PathBuf, ScanError> {
        refuse_existing(&self.target)?;
        sync_tree(&self.temp)?;
        fs::rename(&self.temp, &self.target).map_err(|e| ScanError::io(&self.target, e))?;
        self.published = true;
        let (parent, _) = split(&self.target)?;
        sync_dir(&parent)?;
        Ok(self.target.clone())
    }
}

impl Drop for PendingDir {
    fn drop(&mut self) {
        if !self.published {
            if let Err(e) = fs::remove_dir_all(&self.temp) {
                tracing::warn!(
                    "could not remove unpublished temporary folder {}: {e}",
                    self.temp.display()
                );
            }
        }
    }
}

fn refuse_existing(target: &Path) -> Result<(), ScanError> {
    // `symlink_metadata` so that a dangling link also counts as existing.
    if fs::symlink_metadata(target).is_ok() {
        return Err(ScanError::AlreadyExists {
            path: target.to_path_buf(),
        });
    }
    Ok(())
}

/// The folder of `path` (`.` for a bare name) and its file name.
fn split(path: &Path) -> Result<(PathBuf, OsString), ScanError> {
    let name = path.file_name().ok_or_else(|| {
        ScanError::format(path, "expected a path ending in a file or folder name")
    })?;
    let dir = match path.parent() {
        Some(p) if !p.as_os_str().is_empty() => p.to_path_buf(),
        _ => PathBuf::from("."),
    };
    Ok((dir, name.to_os_string()))
}

/// `.<name>.tmp-<pid>-<n>`: hidden, recognisable, unique per process and
/// call, so concurrent writers never share a temporary.
fn temp_name(name: &OsString) -> OsString {
    static COUNTER: AtomicU64 = AtomicU64::new(0);
    let n = COUNTER.fetch_add(1, Ordering::Relaxed);
    let mut s = OsString::from(".");
    s.push(name);
    s.push(format!(".tmp-{}-{n}", std::process::id()));
    s
}

/// Flushes every file below `dir` (and the folders themselves) to disk;
/// files written through [`write_atomic`] are flushed already, but callers
/// may have written into a [`PendingDir`] by other means.
fn sync_tree(dir: &Path) -> Result<(), ScanError> {
    let entries = fs::read_dir(dir).map_err(|e| ScanError::io(dir, e))?;
    for entry in entries {
        let entry = entry.map_err(|e| ScanError::io(dir, e))?;
        let path = entry.path();
        let kind = entry.file_type().map_err(|e| ScanError::io(&path, e))?;
        if kind.is_dir() {
            sync_tree(&path)?;
        } else if kind.is_file() {
            File::open(&path)
                .and_then(|f| f.sync_all())
                .map_err(|e| ScanError::io(&path, e))?;
        }
    }
    sync_dir(dir)
}

#[cfg(unix)]
fn sync_dir(dir: &Path) -> Result<(), ScanError> {
    File::open(dir)
        .and_then(|f| f.sync_all())
        .map_err(|e| ScanError::io(dir, e))
}

/// Folders cannot be opened for syncing on other systems; their renames
/// are made durable by the file system itself.
#[cfg(not(unix))]
fn sync_dir(_dir: &Path) -> Result<(), ScanError> {
    Ok(())
}
