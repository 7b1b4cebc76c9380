//! hamel's cache directory (SECURITY.md): the code cache of the scenes' compiled cores and the
//! store of derivations live in it.
//!
//! **Job**: say where the cache is ([`location`]), create it private to the user (mode 0700)
//! and refuse one that another user could write to ([`root`]), write an entry whole or not at
//! all ([`write_atomic`]), and hash content ([`sha256_hex`]). **Invariant**: nothing is read
//! from or written into a directory [`root`] has not checked. CAS-free, no hamel dependency.

use std::path::{Path, PathBuf};

/// Why the cache directory cannot be used.
#[derive(Clone, Debug, thiserror::Error)]
pub enum RootError {
    /// The directory is refused: another user could change what hamel reads from it.
    #[error(
        "refusing the cache {}: {why}. hamel runs code and reads derivations from it, so it must be a directory of your own that nobody else can write to (chmod 700 it, or set HAMEL_CACHE to another directory)",
        dir.display()
    )]
    Refused {
        /// The directory.
        dir: PathBuf,
        /// What is wrong with it.
        why: String,
    },
    /// It could not be created or read.
    #[error("the cache {}: {source}", dir.display())]
    Io {
        /// The directory.
        dir: PathBuf,
        /// The system's error.
        #[source]
        source: std::sync::Arc<std::io::Error>,
    },
}

/// Where the cache lives: `$HAMEL_CACHE`, else `$XDG_CACHE_HOME/hamel`, else
/// `~/.cache/hamel`, else `hamel-cache` in the temporary directory. Not checked: see [`root`].
pub fn location() -> PathBuf {
    if let Some(d) = std::env::var_os("HAMEL_CACHE").filter(|d| !d.is_empty()) {
        return PathBuf::from(d);
    }
    if let Some(d) = std::env::var_os("XDG_CACHE_HOME").filter(|d| !d.is_empty()) {
        return PathBuf::from(d).join("hamel");
    }
    if let Some(d) = std::env::var_os("HOME").filter(|d| !d.is_empty()) {
        return PathBuf::from(d).join(".cache").join("hamel");
    }
    std::env::temp_dir().join("hamel-cache")
}

/// The cache directory, created private (mode 0700) when missing; refused when another user
/// could write to it: not owned by the user running hamel, or writable by its group or by
/// others.
pub fn root() -> Result<PathBuf, RootError> {
    private(&location())
}

/// `dir` created private when missing, and checked as [`root`] checks the cache.
pub fn private(dir: &Path) -> Result<PathBuf, RootError> {
    if !dir.exists() {
        create_private(dir).map_err(|e| RootError::Io {
            dir: dir.to_path_buf(),
            source: std::sync::Arc::new(e),
        })?;
    }
    check_private(dir)?;
    Ok(dir.to_path_buf())
}

#[cfg(unix)]
fn create_private(dir: &Path) -> std::io::Result<()> {
    use std::os::unix::fs::DirBuilderExt;
    std::fs::DirBuilder::new()
        .recursive(true)
        .mode(0o700)
        .create(dir)
}

#[cfg(not(unix))]
fn create_private(dir: &Path) -> std::io::Result<()> {
    std::fs::create_dir_all(dir)
}

/// Refuse a directory (followed through symbolic links) that is not a directory, not owned by
/// the effective user, or writable by group or others, and a symbolic link to it that another
/// user owns.
#[cfg(unix)]
fn check_private(dir: &Path) -> Result<(), RootError> {
    use std::os::unix::fs::MetadataExt;
    let refuse = |why: String| {
        Err(RootError::Refused {
            dir: dir.to_path_buf(),
            why,
        })
    };
    let m = std::fs::metadata(dir).map_err(|e| RootError::Io {
        dir: dir.to_path_buf(),
        source: std::sync::Arc::new(e),
    })?;
    // SAFETY: geteuid has no preconditions and cannot fail.
    let me = unsafe { libc::geteuid() };
    if !m.is_dir() {
        return refuse("it is not a directory".into());
    }
    if m.uid() != me {
        return refuse(format!(
            "it is owned by user {}, not by you ({me})",
            m.uid()
        ));
    }
    // A link that someone else owns could be pointed elsewhere later.
    if let Ok(link) = std::fs::symlink_metadata(dir)
        && link.file_type().is_symlink()
        && link.uid() != me
    {
        return refuse(format!(
            "it is a symbolic link owned by user {}, not by you ({me})",
            link.uid()
        ));
    }
    if m.mode() & 0o022 != 0 {
        return refuse(format!(
            "it is writable by {} (mode {:04o})",
            if m.mode() & 0o002 != 0 {
                "all users"
            } else {
                "its group"
            },
            m.mode() & 0o7777
        ));
    }
    Ok(())
}

#[cfg(not(unix))]
fn check_private(_dir: &Path) -> Result<(), RootError> {
    Ok(())
}

/// Write `bytes` to `dir/name` whole or not at all: into a temporary file of this process (and
/// of this call: threads may write the same entry) in the same directory, then renamed over the
/// entry.
pub fn write_atomic(dir: &Path, name: &str, bytes: &[u8]) -> std::io::Result<()> {
    static CALLS: std::sync::atomic::AtomicU64 = std::sync::atomic::AtomicU64::new(0);
    let call = CALLS.fetch_add(1, std::sync::atomic::Ordering::Relaxed);
    let tmp = dir.join(format!("{name}.tmp{}-{call}", std::process::id()));
    std::fs::write(&tmp, bytes)?;
    std::fs::rename(&tmp, dir.join(name)).inspect_err(|_| {
        let _ = std::fs::remove_file(&tmp);
    })
}

/// Why an entry of the cache is not read.
#[derive(Debug, thiserror::Error)]
pub enum EntryError {
    /// It cannot be read (missing, or the system refused).
    #[error("{}: {source}", path.display())]
    Io {
        /// The entry.
        path: PathBuf,
        /// The system's error.
        #[source]
        source: std::io::Error,
    },
    /// Another user could have written it.
    #[error("{}: {why}", path.display())]
    Refused {
        /// The entry.
        path: PathBuf,
        /// What is wrong with it.
        why: String,
    },
}

/// The bytes of the entry `path`, refused unless it is a regular file (not a link) owned by
/// the effective user and writable by nobody else: only what this user wrote is read.
pub fn read_own(path: &Path) -> Result<Vec<u8>, EntryError> {
    let io = |source| EntryError::Io {
        path: path.to_path_buf(),
        source,
    };
    let m = std::fs::symlink_metadata(path).map_err(io)?;
    if let Some(why) = not_own(&m) {
        return Err(EntryError::Refused {
            path: path.to_path_buf(),
            why,
        });
    }
    std::fs::read(path).map_err(io)
}

/// Why the file of metadata `m` is not one this user alone wrote, if it is not.
#[cfg(unix)]
fn not_own(m: &std::fs::Metadata) -> Option<String> {
    use std::os::unix::fs::MetadataExt;
    // SAFETY: geteuid has no preconditions and cannot fail.
    let me = unsafe { libc::geteuid() };
    if !m.file_type().is_file() {
        return Some("it is not a regular file".into());
    }
    if m.uid() != me {
        return Some(format!(
            "it is owned by user {}, not by you ({me})",
            m.uid()
        ));
    }
    (m.mode() & 0o022 != 0)
        .then(|| format!("it is writable by others (mode {:04o})", m.mode() & 0o7777))
}

#[cfg(not(unix))]
fn not_own(_m: &std::fs::Metadata) -> Option<String> {
    None
}

/// The file whose identity keys this process's entries when it is not the running executable
/// ([`use_identity_of`]).
static IDENTITY_FILE: std::sync::OnceLock<PathBuf> = std::sync::OnceLock::new();

/// Key this process's cache entries by `file` instead of the running executable: a library
/// that carries hamel into another program (the Python extension module inside `python`)
/// names itself, so that a rebuilt library keys its entries anew. The first call wins.
pub fn use_identity_of(file: PathBuf) {
    let _ = IDENTITY_FILE.set(file);
}

/// The running executable's identity for a cache key (or that of the file given to
/// [`use_identity_of`]): its size and modification time (a rebuilt hamel keys its entries
/// anew); "unknown" when it cannot be read.
pub fn executable_identity() -> String {
    let file = match IDENTITY_FILE.get() {
        Some(file) => Ok(file.clone()),
        None => std::env::current_exe(),
    };
    file.and_then(std::fs::metadata)
        .map(|m| {
            let modified = (m.modified().ok())
                .and_then(|t| t.duration_since(std::time::UNIX_EPOCH).ok())
                .map_or(0, |d| d.as_nanos());
            format!("{} bytes, modified {modified}", m.len())
        })
        .unwrap_or_else(|_| "unknown".into())
}

/// SHA-256 of `bytes`, in hexadecimal.
pub fn sha256_hex(bytes: &[u8]) -> String {
    use sha2::Digest;
    sha2::Sha256::digest(bytes)
        .iter()
        .map(|b| format!("{b:02x}"))
        .collect()
}

#[cfg(all(test, unix))]
mod tests {
    use super::*;
    use std::os::unix::fs::PermissionsExt;

    #[test]
    fn a_directory_others_can_write_to_is_refused() {
        let dir = std::env::temp_dir().join(format!("hamel-cache-test-{}", std::process::id()));
        let _ = std::fs::remove_dir_all(&dir);
        assert!(private(&dir).is_ok());
        assert_eq!(
            std::fs::metadata(&dir).unwrap().permissions().mode() & 0o777,
            0o700
        );
        std::fs::set_permissions(&dir, std::fs::Permissions::from_mode(0o777)).unwrap();
        assert!(matches!(private(&dir), Err(RootError::Refused { .. })));
        std::fs::set_permissions(&dir, std::fs::Permissions::from_mode(0o700)).unwrap();
        write_atomic(&dir, "entry", b"whole").unwrap();
        assert_eq!(std::fs::read(dir.join("entry")).unwrap(), b"whole");
        assert_eq!(sha256_hex(b"").len(), 64);
        let _ = std::fs::remove_dir_all(&dir);
    }
}
