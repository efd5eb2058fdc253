//! Output files appear whole or not at all.
//!
//! Every file hystid writes goes to a temporary name in the same directory
//! (`NAME.<pid>.tmp`) first and is renamed over the final name only when
//! complete, so an error (or a crash) never leaves a half-written result that
//! looks valid. An error removes the temporary; a process killed outright
//! (SIGKILL, power loss) cannot, so the next run that claims the directory
//! ([`OutDir::claim`]) removes the temporaries of processes no longer alive.
//! The standard is therefore: in an output directory, a file under its final
//! name is complete; anything else is a temporary (`NAME.<pid>.tmp`, or
//! `NAME.<pid>.tmp.png` for a bitmap whose encoder needs the extension) of a
//! dead run, removed by the next run, or of a live one.
//!
//! [`OutDir::claim`] also locks the directory, so that two runs writing to
//! the same `--out` at once do not mix their files: the second stops with an
//! error naming the directory and the process holding it.

use crate::error::{Error, Result};
use std::fs::File;
use std::io::{BufWriter, Read, Seek, Write};
use std::path::{Path, PathBuf};

/// The temporary name used while `path` is written.
pub fn temporary_path(path: &Path) -> PathBuf {
    let mut name = path
        .file_name()
        .map(|n| n.to_os_string())
        .unwrap_or_default();
    name.push(format!(".{}.tmp", std::process::id()));
    path.with_file_name(name)
}

/// Writes `path` through `write`, atomically.
pub fn write_atomic(
    path: &Path,
    write: impl FnOnce(&mut BufWriter<File>) -> Result<()>,
) -> Result<()> {
    let tmp = temporary_path(path);
    let result = (|| {
        let file = File::create(&tmp).map_err(|e| Error::io(&tmp, e))?;
        let mut w = BufWriter::new(file);
        write(&mut w)?;
        let file = w
            .into_inner()
            .map_err(|e| Error::io(&tmp, e.into_error()))?;
        file.sync_all().map_err(|e| Error::io(&tmp, e))?;
        std::fs::rename(&tmp, path).map_err(|e| Error::io(path, e))
    })();
    if result.is_err() {
        let _ = std::fs::remove_file(&tmp);
    }
    result
}

/// Writes bytes to `path`, atomically.
pub fn write_bytes(path: &Path, bytes: &[u8]) -> Result<()> {
    write_atomic(path, |w| w.write_all(bytes).map_err(|e| Error::io(path, e)))
}

/// A file being written under a temporary name; [`PendingFile::commit`]
/// renames it into place, dropping it without committing removes it.
#[derive(Debug)]
pub struct PendingFile {
    tmp: PathBuf,
    path: PathBuf,
    committed: bool,
}

impl PendingFile {
    /// Creates the temporary file for `path`.
    pub fn create(path: &Path) -> Result<(PendingFile, File)> {
        let tmp = temporary_path(path);
        let file = File::create(&tmp).map_err(|e| Error::io(&tmp, e))?;
        Ok((
            PendingFile {
                tmp,
                path: path.to_path_buf(),
                committed: false,
            },
            file,
        ))
    }

    /// The temporary path.
    pub fn temporary(&self) -> &Path {
        &self.tmp
    }

    /// The final path.
    pub fn path(&self) -> &Path {
        &self.path
    }

    /// Renames the finished file into place.
    pub fn commit(mut self) -> Result<()> {
        std::fs::rename(&self.tmp, &self.path).map_err(|e| Error::io(&self.path, e))?;
        self.committed = true;
        Ok(())
    }
}

impl Drop for PendingFile {
    fn drop(&mut self) {
        if !self.committed {
            let _ = std::fs::remove_file(&self.tmp);
        }
    }
}

/// The lock file of an output directory (hidden; removed when the run ends,
/// left behind unlocked by a killed run and then simply reused).
pub const LOCK_FILE: &str = ".hystid.lock";

/// An output directory claimed by this process: created if need be, locked
/// against other hystid runs for as long as the value lives, and cleared of
/// the temporaries dead runs left.
#[derive(Debug)]
pub struct OutDir {
    lock: File,
    lock_path: PathBuf,
}

impl OutDir {
    /// Creates `dir` (and its parents), locks it and removes stale
    /// temporaries.
    ///
    /// Errors: the directory cannot be created, or another process holds
    /// it (the message names the directory and that process).
    pub fn claim(dir: &Path) -> Result<OutDir> {
        std::fs::create_dir_all(dir).map_err(|e| Error::io(dir, e))?;
        let lock_path = dir.join(LOCK_FILE);
        let lock = loop {
            let mut f = std::fs::OpenOptions::new()
                .read(true)
                .write(true)
                .create(true)
                .truncate(false)
                .open(&lock_path)
                .map_err(|e| Error::io(&lock_path, e))?;
            match f.try_lock() {
                Ok(()) => {}
                Err(std::fs::TryLockError::WouldBlock) => {
                    let mut holder = String::new();
                    let _ = f.read_to_string(&mut holder);
                    let holder = match holder.trim() {
                        "" => "another hystid process".to_string(),
                        pid => format!("hystid process {pid}"),
                    };
                    return Err(Error::input(
                        dir.display().to_string(),
                        format!(
                            "{holder} is writing to this output directory \
                             (lock {LOCK_FILE}); wait for it to finish or choose another --out"
                        ),
                    ));
                }
                Err(std::fs::TryLockError::Error(e)) => return Err(Error::io(&lock_path, e)),
            }
            // The holder before us may have removed the file between our
            // open and our lock: then we hold a lock on a deleted file and
            // must lock the one now at the path.
            if same_file(&f, &lock_path) {
                f.set_len(0)
                    .and_then(|_| f.rewind())
                    .and_then(|_| write!(f, "{}", std::process::id()))
                    .map_err(|e| Error::io(&lock_path, e))?;
                break f;
            }
        };
        remove_stale_temporaries(dir)?;
        Ok(OutDir { lock, lock_path })
    }
}

impl Drop for OutDir {
    fn drop(&mut self) {
        // Removed while still locked, so no one can lock the old file and
        // believe it holds the directory.
        let _ = std::fs::remove_file(&self.lock_path);
        let _ = self.lock.unlock();
    }
}

#[cfg(unix)]
fn same_file(f: &File, path: &Path) -> bool {
    use std::os::unix::fs::MetadataExt;
    match (f.metadata(), std::fs::metadata(path)) {
        (Ok(a), Ok(b)) => a.dev() == b.dev() && a.ino() == b.ino(),
        _ => false,
    }
}

#[cfg(not(unix))]
fn same_file(_: &File, path: &Path) -> bool {
    path.exists()
}

/// The process id in a temporary's name: `NAME.<pid>.tmp`, or
/// `NAME.<pid>.tmp.<ext>` where an encoder picks its format from the
/// extension (the plots' PNG); None for any other name.
pub fn temporary_pid(name: &str) -> Option<u32> {
    let stem = name.strip_suffix(".tmp").or_else(|| {
        let (rest, ext) = name.rsplit_once('.')?;
        if ext.is_empty() || !ext.bytes().all(|b| b.is_ascii_alphanumeric()) {
            return None;
        }
        rest.strip_suffix(".tmp")
    })?;
    let (_, pid) = stem.rsplit_once('.')?;
    pid.parse().ok()
}

/// Whether process `pid` may still be running (always yes where this
/// cannot be known, so only certainly-dead runs' files are removed).
fn alive(pid: u32) -> bool {
    let proc = Path::new("/proc");
    if pid == std::process::id() || !proc.join("self").exists() {
        return true;
    }
    proc.join(pid.to_string()).exists()
}

/// Removes the temporaries (`NAME.<pid>.tmp`) in `dir` whose process is
/// gone; returns them.
pub fn remove_stale_temporaries(dir: &Path) -> Result<Vec<PathBuf>> {
    let mut removed = Vec::new();
    for entry in std::fs::read_dir(dir).map_err(|e| Error::io(dir, e))? {
        let entry = entry.map_err(|e| Error::io(dir, e))?;
        let name = entry.file_name();
        let Some(pid) = name.to_str().and_then(temporary_pid) else {
            continue;
        };
        if !alive(pid) && entry.file_type().is_ok_and(|t| t.is_file()) {
            let p = entry.path();
            std::fs::remove_file(&p).map_err(|e| Error::io(&p, e))?;
            removed.push(p);
        }
    }
    Ok(removed)
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn failed_write_leaves_nothing() {
        let dir = tempfile::tempdir().unwrap();
        let p = dir.path().join("out.json");
        let r = write_atomic(&p, |w| {
            w.write_all(b"half").unwrap();
            Err(Error::input("x", "boom"))
        });
        assert!(r.is_err());
        assert!(!p.exists());
        assert_eq!(std::fs::read_dir(dir.path()).unwrap().count(), 0);
        write_bytes(&p, b"whole").unwrap();
        assert_eq!(std::fs::read(&p).unwrap(), b"whole");
    }

    #[test]
    fn stale_temporaries_of_dead_processes_go() {
        let dir = tempfile::tempdir().unwrap();
        let d = dir.path();
        // pid 0 is never a user process; our own temporary stays
        let dead = d.join("a.json.0.tmp");
        let ours = temporary_path(&d.join("b.json"));
        for p in [&dead, &ours] {
            std::fs::write(p, b"x").unwrap();
        }
        let dead_png = d.join("p.png.0.tmp.png");
        std::fs::write(&dead_png, b"x").unwrap();
        std::fs::write(d.join("c.tmp"), b"not ours").unwrap();
        std::fs::write(d.join("c.1.tmp.x.y"), b"not ours").unwrap();
        let _out = OutDir::claim(d).unwrap();
        assert!(!dead.exists() && !dead_png.exists());
        assert!(d.join("c.1.tmp.x.y").exists());
        assert!(ours.exists());
        assert!(d.join("c.tmp").exists());
    }

    #[test]
    fn a_claimed_directory_refuses_a_second_claim_until_released() {
        let dir = tempfile::tempdir().unwrap();
        let out = OutDir::claim(dir.path()).unwrap();
        let e = OutDir::claim(dir.path()).unwrap_err().to_string();
        assert!(e.contains(&std::process::id().to_string()), "{e}");
        assert!(e.contains(&dir.path().display().to_string()), "{e}");
        drop(out);
        assert!(!dir.path().join(LOCK_FILE).exists());
        let _again = OutDir::claim(dir.path()).unwrap();
    }
}
