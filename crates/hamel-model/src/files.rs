//! Files written whole or not at all.
//!
//! A result goes to a temporary file (or directory) beside its destination, named
//! `.hamel-tmp.PID.NAME`, and is renamed into place once complete: a reader never sees half a
//! file. While it is being written its path is registered; [`remove_pending`] removes what is
//! registered, and the `hamel` binary calls it when interrupted (SIGINT), so that an
//! interrupted command leaves neither a partial result nor a temporary file behind.

use std::path::{Path, PathBuf};
use std::sync::Mutex;

static PENDING: Mutex<Vec<PathBuf>> = Mutex::new(Vec::new());

fn pending() -> std::sync::MutexGuard<'static, Vec<PathBuf>> {
    PENDING.lock().unwrap_or_else(|e| e.into_inner())
}

/// A temporary file or directory being written: registered while it lives.
#[derive(Debug)]
pub struct Temporary {
    path: PathBuf,
}

impl Temporary {
    /// The temporary path beside `destination`, registered.
    pub fn beside(destination: &Path) -> Temporary {
        let name = destination
            .file_name()
            .map(|n| n.to_string_lossy().into_owned())
            .unwrap_or_default();
        // The extension is kept: a writer may choose the format by it (PNG).
        let path = destination.with_file_name(format!(".hamel-tmp.{}.{name}", std::process::id()));
        pending().push(path.clone());
        Temporary { path }
    }

    /// Where to write.
    pub fn path(&self) -> &Path {
        &self.path
    }

    /// Rename into place: the destination then holds the whole result.
    pub fn commit(self, destination: &Path) -> std::io::Result<()> {
        std::fs::rename(&self.path, destination)
    }
}

impl Drop for Temporary {
    /// Unregistered; removed if it was not committed (an error on the way).
    fn drop(&mut self) {
        pending().retain(|p| p != &self.path);
        remove(&self.path);
    }
}

fn remove(path: &Path) {
    if path.is_dir() {
        let _ = std::fs::remove_dir_all(path);
    } else {
        let _ = std::fs::remove_file(path);
    }
}

/// Write `bytes` to `destination` through a temporary file renamed into place.
pub fn write_whole(destination: &Path, bytes: &[u8]) -> std::io::Result<()> {
    let tmp = Temporary::beside(destination);
    std::fs::write(tmp.path(), bytes)?;
    tmp.commit(destination)
}

/// Remove every temporary file and directory still being written (from a signal handler,
/// before the process exits).
pub fn remove_pending() {
    for p in pending().drain(..) {
        remove(&p);
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn a_result_is_whole_or_absent() {
        let dir = std::env::temp_dir().join(format!("hamel-files-{}", std::process::id()));
        std::fs::create_dir_all(&dir).unwrap();
        let out = dir.join("result.json");
        write_whole(&out, b"{}").unwrap();
        assert_eq!(std::fs::read(&out).unwrap(), b"{}");
        // Interrupted while writing: what the handler removes, nothing is left.
        let tmp = Temporary::beside(&dir.join("other.json"));
        std::fs::write(tmp.path(), b"half").unwrap();
        assert!(tmp.path().exists());
        remove_pending();
        assert!(!tmp.path().exists());
        drop(tmp);
        // An error on the way: the temporary file is removed, the destination untouched.
        let failed = write_whole(&dir.join("no/such/dir/x.json"), b"x");
        assert!(failed.is_err());
        let left: Vec<_> = std::fs::read_dir(&dir)
            .unwrap()
            .map(|e| e.unwrap().file_name())
            .collect();
        assert_eq!(left, ["result.json"]);
        std::fs::remove_dir_all(&dir).unwrap();
    }
}
