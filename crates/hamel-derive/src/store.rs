//! A derivation as bytes: what the derivation store keeps (issue 59).
//!
//! **Job**: write a [`Derivation`] whole — every entry's text, tree and canonical form, the
//! ingredients of the structured evaluation, the contacts' map and the forces' uniqueness — and
//! read it back, so that a later command evaluates, generates code or simulates from it
//! without the computer algebra. **Format**: CBOR (self-describing, binary: entries are kept
//! whole, where JSON for a reader shows their text only, `Serializer::is_human_readable`),
//! behind a format number that changes whenever the layout does. **Invariant**: reading what
//! was written gives the same derivation: writing it again gives the same bytes
//! (tests/store.rs, every bundled model and choice).

use serde::{Deserialize, Serialize};

use crate::Derivation;
use crate::derivation::Ingredients;
use crate::uniqueness::Uniqueness;

/// The layout's number: a stored derivation of another number is not read.
pub const FORMAT: u32 = 1;

/// Why stored bytes are not a derivation.
#[derive(Debug, thiserror::Error)]
pub enum StoreError {
    /// Not CBOR of a stored derivation (truncated, corrupted, of another program).
    #[error("not a stored derivation: {0}")]
    Unreadable(String),
    /// Written by a hamel with another layout.
    #[error("a stored derivation of format {found}, this hamel reads format {FORMAT}")]
    Format {
        /// The format found.
        found: u32,
    },
    /// Could not be written.
    #[error("the derivation cannot be written: {0}")]
    Unwritable(String),
}

/// What is written: the derivation and the parts its reader's form leaves out.
#[derive(Serialize)]
struct Written<'a> {
    format: u32,
    derivation: &'a Derivation,
    ingredients: &'a Ingredients,
    contact_forces: &'a hamel_bodies::ContactForces,
    force_uniqueness: &'a Uniqueness,
}

/// What is read.
#[derive(Deserialize)]
struct Read {
    format: u32,
    derivation: Derivation,
    ingredients: Ingredients,
    contact_forces: hamel_bodies::ContactForces,
    force_uniqueness: Uniqueness,
}

/// Just the format number, read when the whole does not read.
#[derive(Deserialize)]
struct Header {
    format: u32,
}

/// Expression trees nest deeper than ciborium's default limit of 256.
const LIMIT: usize = 1 << 16;

/// A value read from CBOR (`reader`), with the recursion limit expression trees need.
pub fn from_cbor<T: serde::de::DeserializeOwned>(
    reader: impl std::io::Read,
) -> Result<T, ciborium::de::Error<std::io::Error>> {
    ciborium::de::from_reader_with_recursion_limit(reader, LIMIT)
}

/// The derivation as bytes.
pub fn to_bytes(d: &Derivation) -> Result<Vec<u8>, StoreError> {
    let mut out = Vec::new();
    let written = Written {
        format: FORMAT,
        derivation: d,
        ingredients: &d.ingredients,
        contact_forces: &d.contact_forces,
        force_uniqueness: &d.force_uniqueness,
    };
    ciborium::into_writer(&written, &mut out).map_err(|e| StoreError::Unwritable(e.to_string()))?;
    Ok(out)
}

/// The derivation the bytes hold.
pub fn from_bytes(bytes: &[u8]) -> Result<Derivation, StoreError> {
    let read: Result<Read, _> = from_cbor(bytes);
    let read = match read {
        Ok(r) if r.format == FORMAT => r,
        Ok(r) => return Err(StoreError::Format { found: r.format }),
        Err(e) => {
            // another layout may not read as this one: say so when its number says so
            let header: Result<Header, _> = from_cbor(bytes);
            return Err(match header {
                Ok(h) if h.format != FORMAT => StoreError::Format { found: h.format },
                _ => StoreError::Unreadable(e.to_string()),
            });
        }
    };
    let mut d = read.derivation;
    d.ingredients = read.ingredients;
    d.contact_forces = read.contact_forces;
    d.force_uniqueness = read.force_uniqueness;
    Ok(d)
}

/// What determines a derivation, the key of its entry in the store: hamel's build, the layout,
/// the model's text, the parameters' values (`--set`), the control laws closing its loop, the
/// choice's quasi-velocities as used (free functions defined), whether the supports are
/// released. The entry is named by its SHA-256 and holds the key itself, compared on reading.
#[derive(Clone, Debug, PartialEq, Eq)]
pub struct Key {
    text: String,
}

impl Key {
    /// The key of `model`'s derivation for the choice `choice`, with the supports of its
    /// wheels released when `supports` (or already).
    pub fn new(
        model: &hamel_model::Model,
        choice: &str,
        supports: bool,
    ) -> Result<Key, hamel_model::ModelError> {
        let exe = hamel_cache::executable_identity();
        let chosen = model.choice(Some(choice))?;
        let eta: Vec<String> = chosen.eta.iter().map(|i| i.expr.to_string()).collect();
        let params: Vec<String> = (model.parameters.iter())
            .map(|(k, v)| format!("{k} = {:#018x}", v.to_bits()))
            .collect();
        Ok(Key {
            text: format!(
                "hamel {}; executable {exe}; store format {FORMAT}\nchoice {choice}: {}\nparameters: {}\nsupports released: {}\ncontrol:\n{}\nmodel {}:\n{}",
                env!("CARGO_PKG_VERSION"),
                eta.join(", "),
                params.join(", "),
                supports || model.contact_forces.released,
                model.control,
                model.file,
                model.source
            ),
        })
    }

    /// The key of what is made from the derivation for `purpose` (the analysis, the
    /// ingredients: `hamel_reduce::pass::Job`), which is stored under its own key.
    pub fn with(mut self, purpose: &str) -> Key {
        self.text = format!("{}\npurpose: {purpose}", self.text);
        self
    }

    /// The entry's file name.
    fn file(&self) -> String {
        format!(
            "{}.derivation",
            &hamel_cache::sha256_hex(self.text.as_bytes())[..32]
        )
    }
}

/// The store's directory inside the cache (private, checked: [`hamel_cache::private`]).
fn directory() -> Result<std::path::PathBuf, hamel_cache::RootError> {
    let root = hamel_cache::root()?;
    hamel_cache::private(&root.join("derivations"))
}

/// An entry: the key's text, the SHA-256 of the derivation's bytes, the bytes.
#[derive(Serialize, Deserialize)]
struct Entry {
    key: String,
    sha256: String,
    #[serde(with = "serde_bytes_vec")]
    bytes: Vec<u8>,
}

/// Bytes as one CBOR byte string (not a list of numbers).
mod serde_bytes_vec {
    pub fn serialize<S: serde::Serializer>(v: &[u8], s: S) -> Result<S::Ok, S::Error> {
        s.serialize_bytes(v)
    }
    pub fn deserialize<'de, D: serde::Deserializer<'de>>(d: D) -> Result<Vec<u8>, D::Error> {
        struct V;
        impl serde::de::Visitor<'_> for V {
            type Value = Vec<u8>;
            fn expecting(&self, f: &mut std::fmt::Formatter) -> std::fmt::Result {
                f.write_str("bytes")
            }
            fn visit_bytes<E: serde::de::Error>(self, v: &[u8]) -> Result<Vec<u8>, E> {
                Ok(v.to_vec())
            }
            fn visit_byte_buf<E: serde::de::Error>(self, v: Vec<u8>) -> Result<Vec<u8>, E> {
                Ok(v)
            }
        }
        d.deserialize_byte_buf(V)
    }
}

/// The stored value of `key` (an artefact of the one pass: `hamel_reduce::pass`), if the store
/// holds a sound one. An entry that does not read, whose key differs or whose bytes do not
/// match their hash is not trusted: a warning says so, and the caller derives anew (and
/// replaces it).
pub fn lookup<T: serde::de::DeserializeOwned>(key: &Key) -> Option<T> {
    let dir = match directory() {
        Ok(d) => d,
        Err(e) => {
            log::warn!("the derivation store is not used: {e}");
            return None;
        }
    };
    let path = dir.join(key.file());
    let raw = match hamel_cache::read_own(&path) {
        Ok(raw) => raw,
        Err(hamel_cache::EntryError::Io { .. }) => return None,
        Err(e) => {
            log::warn!("the stored derivation is refused ({e}): deriving anew");
            return None;
        }
    };
    let sound = ciborium::from_reader::<Entry, _>(raw.as_slice())
        .ok()
        .filter(|e| e.key == key.text && hamel_cache::sha256_hex(&e.bytes) == e.sha256)
        .map(|e| from_cbor::<T>(e.bytes.as_slice()));
    match sound {
        Some(Ok(d)) => {
            used(&path);
            Some(d)
        }
        _ => {
            log::warn!(
                "the stored derivation {} is corrupt or not this model's: deriving anew",
                path.display()
            );
            None
        }
    }
}

/// Store `value` under `key` (whole, or not at all); a failure is a warning, never an error:
/// the store only saves work.
pub fn put<T: Serialize>(key: &Key, value: &T) {
    let write = || -> Result<(), String> {
        let dir = directory().map_err(|e| e.to_string())?;
        let mut bytes = Vec::new();
        ciborium::into_writer(value, &mut bytes).map_err(|e| e.to_string())?;
        let entry = Entry {
            key: key.text.clone(),
            sha256: hamel_cache::sha256_hex(&bytes),
            bytes,
        };
        let mut out = Vec::new();
        ciborium::into_writer(&entry, &mut out).map_err(|e| e.to_string())?;
        hamel_cache::write_atomic(&dir, &key.file(), &out).map_err(|e| e.to_string())?;
        prune(&dir, limit(), &key.file());
        Ok(())
    };
    if let Err(e) = write() {
        log::warn!("the derivation is not stored: {e}");
    }
}

/// The store's size limit when `HAMEL_STORE_MAX_MB` does not set one: 1 GiB (a bicycle's
/// artefact is 3 to 4 MB, a knife's 20 kB).
pub const DEFAULT_LIMIT: u64 = 1 << 30;

/// The store's size limit in bytes: `HAMEL_STORE_MAX_MB` (mebibytes), else [`DEFAULT_LIMIT`].
pub fn limit() -> u64 {
    match std::env::var("HAMEL_STORE_MAX_MB").map(|v| v.trim().parse::<u64>()) {
        Ok(Ok(mb)) => mb.saturating_mul(1 << 20),
        Ok(Err(_)) => {
            log::warn!(
                "HAMEL_STORE_MAX_MB is not a whole number of mebibytes: the store keeps up to 1024"
            );
            DEFAULT_LIMIT
        }
        Err(_) => DEFAULT_LIMIT,
    }
}

/// An entry was used: its time is now, so that [`prune`] removes the least recently used
/// first. Best effort.
fn used(path: &std::path::Path) {
    if let Ok(f) = std::fs::File::options().append(true).open(path) {
        let _ = f.set_modified(std::time::SystemTime::now());
    }
}

/// Remove the least recently used entries of `dir` until the store holds at most `limit`
/// bytes; `keep` (the entry just written) stays whatever its size.
fn prune(dir: &std::path::Path, limit: u64, keep: &str) {
    let Ok(read) = std::fs::read_dir(dir) else {
        return;
    };
    let mut entries: Vec<(std::time::SystemTime, u64, std::path::PathBuf)> = read
        .filter_map(Result::ok)
        .filter(|e| e.file_name().to_string_lossy().ends_with(".derivation"))
        .filter_map(|e| {
            let m = e.metadata().ok()?;
            Some((m.modified().ok()?, m.len(), e.path()))
        })
        .collect();
    let mut total: u64 = entries.iter().map(|e| e.1).sum();
    entries.sort_by_key(|e| e.0);
    for (_, size, path) in entries {
        if total <= limit {
            break;
        }
        if path.file_name().is_some_and(|n| n == keep) {
            continue;
        }
        if std::fs::remove_file(&path).is_ok() {
            log::debug!(
                "derivation store over its limit: removed {}",
                path.display()
            );
            total -= size;
        }
    }
}

/// A [`Derivation`] inside a stored value: the derivation itself where it was made, its bytes
/// ([`to_bytes`]) where it was read from the store, decoded only when asked for (a command that
/// needs only what else was stored, `hamel eval`'s evaluator, never decodes its trees).
#[derive(Debug)]
pub enum Held {
    /// Made here.
    Decoded(Box<Derivation>),
    /// Read: the bytes of [`to_bytes`].
    Bytes(Vec<u8>),
}

impl Held {
    /// The derivation (decoded now when it was read).
    pub fn into_derivation(self) -> Result<Derivation, StoreError> {
        match self {
            Held::Decoded(d) => Ok(*d),
            Held::Bytes(b) => from_bytes(&b),
        }
    }
}

impl Serialize for Held {
    fn serialize<S: serde::Serializer>(&self, s: S) -> Result<S::Ok, S::Error> {
        match self {
            Held::Decoded(d) => {
                let bytes = to_bytes(d).map_err(serde::ser::Error::custom)?;
                s.serialize_bytes(&bytes)
            }
            Held::Bytes(b) => s.serialize_bytes(b),
        }
    }
}

impl<'de> Deserialize<'de> for Held {
    fn deserialize<D: serde::Deserializer<'de>>(d: D) -> Result<Held, D::Error> {
        serde_bytes_vec::deserialize(d).map(Held::Bytes)
    }
}

/// An entry of the store as `hamel store ls` shows it (from its key; not checked).
#[derive(Clone, Debug)]
pub struct Listed {
    /// The entry's file name.
    pub name: String,
    /// The model's file.
    pub model: String,
    /// The choice's name.
    pub choice: String,
    /// What was made (the analysis, the ingredients).
    pub purpose: String,
    /// The entry's size.
    pub bytes: u64,
}

/// The store's entries, by file name; an entry that does not read is listed as unreadable.
pub fn list() -> Result<Vec<Listed>, String> {
    let dir = directory().map_err(|e| e.to_string())?;
    let read = std::fs::read_dir(&dir).map_err(|e| format!("{}: {e}", dir.display()))?;
    let mut entries: Vec<Listed> = read
        .filter_map(Result::ok)
        .filter(|e| e.file_name().to_string_lossy().ends_with(".derivation"))
        .map(|e| listed(&e.path()))
        .collect();
    entries.sort_by(|a, b| a.name.cmp(&b.name));
    Ok(entries)
}

/// One entry, from the lines of its key.
fn listed(path: &std::path::Path) -> Listed {
    let bytes = std::fs::metadata(path).map_or(0, |m| m.len());
    let raw = std::fs::read(path).unwrap_or_default();
    let key = ciborium::from_reader::<Entry, _>(raw.as_slice()).map_or(String::new(), |e| e.key);
    let line = |prefix: &str| {
        key.lines()
            .find_map(|l| l.strip_prefix(prefix))
            .map_or("?".to_string(), |rest| {
                rest.trim_end_matches(':').to_string()
            })
    };
    let choice = line("choice ");
    Listed {
        name: path
            .file_name()
            .map_or(String::new(), |n| n.to_string_lossy().into()),
        model: if key.is_empty() {
            "(unreadable)".into()
        } else {
            line("model ")
        },
        choice: choice.split(':').next().unwrap_or("?").to_string(),
        purpose: line("purpose: "),
        bytes,
    }
}

/// Remove every entry of the store; how many were removed.
pub fn clear() -> Result<usize, String> {
    let dir = directory().map_err(|e| e.to_string())?;
    let read = std::fs::read_dir(&dir).map_err(|e| format!("{}: {e}", dir.display()))?;
    let mut n = 0;
    for e in read.filter_map(Result::ok) {
        if e.file_name().to_string_lossy().ends_with(".derivation") {
            std::fs::remove_file(e.path())
                .map_err(|err| format!("{}: {err}", e.path().display()))?;
            n += 1;
        }
    }
    Ok(n)
}

#[cfg(test)]
mod tests {
    use std::time::{Duration, SystemTime};

    /// The least recently used entries go first, until the store is within its limit; the
    /// entry just written stays whatever its size.
    #[test]
    fn pruning_removes_the_least_recently_used_first() {
        let dir = std::env::temp_dir().join(format!("hamel-prune-{}", std::process::id()));
        std::fs::create_dir_all(&dir).unwrap();
        let now = SystemTime::now();
        for (name, age) in [("a", 30), ("b", 10), ("c", 20), ("d", 40)] {
            let path = dir.join(format!("{name}.derivation"));
            std::fs::write(&path, [0u8; 100]).unwrap();
            let f = std::fs::File::options().append(true).open(&path).unwrap();
            f.set_modified(now - Duration::from_secs(age)).unwrap();
        }
        std::fs::write(dir.join("other.txt"), [0u8; 1000]).unwrap();
        // d (oldest) is the entry just written: kept; a (next oldest) then c go.
        super::prune(&dir, 250, "d.derivation");
        let mut left: Vec<String> = std::fs::read_dir(&dir)
            .unwrap()
            .map(|e| e.unwrap().file_name().to_string_lossy().into_owned())
            .collect();
        left.sort();
        assert_eq!(left, ["b.derivation", "d.derivation", "other.txt"]);
        std::fs::remove_dir_all(&dir).unwrap();
    }
}
