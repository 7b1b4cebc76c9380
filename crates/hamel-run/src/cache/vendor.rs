//! The vendored crates of the cache's entries (`hamel-runtime`, `hamel-sim`), kept once.
//!
//! Every generated crate carries its own copy of them under `vendor/`. Written into each entry,
//! the copies are new files each time, so cargo (which judges a path dependency by its files'
//! times) compiled both again for every core although they are the same text; in one place,
//! named by the SHA-256 of their files, they compile once per hamel version. The directory
//! is `vendor/<hash>` under the cache's root, written whole (by rename), checked against its
//! name before an entry points at it and rewritten when it does not match.

use std::path::{Path, PathBuf};

use sha2::{Digest, Sha256};

use super::CacheError;

/// The files of a generated crate under `vendor/`: their paths below it, and text.
pub(super) struct Vendored<'g> {
    files: Vec<(&'g str, &'g str)>,
}

impl<'g> Vendored<'g> {
    /// The files of `files` (a generated crate's) under `vendor/`.
    pub(super) fn of(files: &'g [(String, String)]) -> Vendored<'g> {
        let files = (files.iter())
            .filter_map(|(p, t)| Some((p.strip_prefix("vendor/")?, t.as_str())))
            .collect();
        Vendored { files }
    }

    /// Whether the crate vendors nothing.
    pub(super) fn is_empty(&self) -> bool {
        self.files.is_empty()
    }

    /// SHA-256 of the files (paths and texts, in the order given), in hexadecimal.
    fn hash(&self) -> String {
        let mut h = Sha256::new();
        for (path, text) in &self.files {
            for part in [path.as_bytes(), text.as_bytes()] {
                h.update((part.len() as u64).to_le_bytes());
                h.update(part);
            }
        }
        super::hex(&h.finalize())
    }

    /// The shared copy under `root` (written when missing or not these files): its directory
    /// relative to an entry's (`../vendor/<hash>`).
    pub(super) fn shared(&self, root: &Path) -> Result<String, CacheError> {
        let name = self.hash()[..16].to_string();
        let dir = root.join("vendor").join(&name);
        let io = |e| CacheError::io(format!("cannot write {}", dir.display()), e);
        if !self.holds(&dir) {
            self.write(&dir).map_err(io)?;
        }
        Ok(format!("../vendor/{name}"))
    }

    /// Whether `dir` holds exactly these files' texts.
    fn holds(&self, dir: &Path) -> bool {
        (self.files.iter())
            .all(|(path, text)| std::fs::read(dir.join(path)).is_ok_and(|b| b == text.as_bytes()))
    }

    /// Write the files into `dir`, whole: into a directory of this process, then renamed. A
    /// `dir` that does not hold them is replaced; one that another process has just written
    /// (the same files) is kept.
    fn write(&self, dir: &Path) -> std::io::Result<()> {
        let tmp = PathBuf::from(format!("{}.tmp{}", dir.display(), std::process::id()));
        let _ = std::fs::remove_dir_all(&tmp);
        for (path, text) in &self.files {
            let file = tmp.join(path);
            std::fs::create_dir_all(file.parent().expect("a file in the directory"))?;
            std::fs::write(&file, text)?;
        }
        if dir.exists() && !self.holds(dir) {
            std::fs::remove_dir_all(dir)?;
        }
        match std::fs::rename(&tmp, dir) {
            Ok(()) => Ok(()),
            Err(_) if self.holds(dir) => std::fs::remove_dir_all(&tmp),
            Err(e) => Err(e),
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn files() -> Vec<(String, String)> {
        [
            ("Cargo.toml", "[package]"),
            ("vendor/hamel-runtime/src/lib.rs", "pub fn f() {}"),
            (
                "vendor/hamel-runtime/Cargo.toml",
                "[package]\nname = \"hamel-runtime\"",
            ),
        ]
        .map(|(p, t)| (p.to_string(), t.to_string()))
        .into()
    }

    #[test]
    fn the_vendored_files_are_kept_once_and_mended_when_altered() {
        let root = std::env::temp_dir().join(format!("hamel-vendor-test-{}", std::process::id()));
        let _ = std::fs::remove_dir_all(&root);
        let files = files();
        let vendored = Vendored::of(&files);
        assert_eq!(vendored.files.len(), 2);
        let rel = vendored.shared(&root).unwrap();
        let lib = (root.join(rel.strip_prefix("../").unwrap())).join("hamel-runtime/src/lib.rs");
        assert_eq!(std::fs::read_to_string(&lib).unwrap(), "pub fn f() {}");
        let written = std::fs::metadata(&lib).unwrap().modified().unwrap();
        // A second entry with the same files leaves them as they are (cargo sees them fresh).
        assert_eq!(vendored.shared(&root).unwrap(), rel);
        assert_eq!(
            std::fs::metadata(&lib).unwrap().modified().unwrap(),
            written
        );
        // Altered, they are written again.
        std::fs::write(&lib, "pub fn g() {}").unwrap();
        assert_eq!(vendored.shared(&root).unwrap(), rel);
        assert_eq!(std::fs::read_to_string(&lib).unwrap(), "pub fn f() {}");
        // Other files get a directory of their own.
        let mut other = files.clone();
        other[1].1 = "pub fn h() {}".into();
        assert_ne!(Vendored::of(&other).shared(&root).unwrap(), rel);
        std::fs::remove_dir_all(&root).unwrap();
    }
}
