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
    // Expression trees nest deeper than ciborium's default limit of 256.
    let limit = 1 << 16;
    let read: Result<Read, _> = ciborium::de::from_reader_with_recursion_limit(bytes, limit);
    let read = match read {
        Ok(r) if r.format == FORMAT => r,
        Ok(r) => return Err(StoreError::Format { found: r.format }),
        Err(e) => {
            // another layout may not read as this one: say so when its number says so
            let header: Result<Header, _> =
                ciborium::de::from_reader_with_recursion_limit(bytes, limit);
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

/// The stored derivation of `key`, if the store holds a sound one. An entry that does not
/// read, whose key differs or whose bytes do not match their hash is not trusted: a warning
/// says so, and the caller derives anew (and replaces it).
pub fn lookup(key: &Key) -> Option<Derivation> {
    let dir = match directory() {
        Ok(d) => d,
        Err(e) => {
            log::warn!("the derivation store is not used: {e}");
            return None;
        }
    };
    let path = dir.join(key.file());
    let raw = std::fs::read(&path).ok()?;
    let sound = ciborium::from_reader::<Entry, _>(raw.as_slice())
        .ok()
        .filter(|e| e.key == key.text && hamel_cache::sha256_hex(&e.bytes) == e.sha256)
        .map(|e| from_bytes(&e.bytes));
    match sound {
        Some(Ok(d)) => Some(d),
        _ => {
            log::warn!(
                "the stored derivation {} is corrupt or not this model's: deriving anew",
                path.display()
            );
            None
        }
    }
}

/// Store `d` under `key` (whole, or not at all); a failure is a warning, never an error: the
/// store only saves work.
pub fn put(key: &Key, d: &Derivation) {
    let write = || -> Result<(), String> {
        let dir = directory().map_err(|e| e.to_string())?;
        let bytes = to_bytes(d).map_err(|e| e.to_string())?;
        let entry = Entry {
            key: key.text.clone(),
            sha256: hamel_cache::sha256_hex(&bytes),
            bytes,
        };
        let mut out = Vec::new();
        ciborium::into_writer(&entry, &mut out).map_err(|e| e.to_string())?;
        hamel_cache::write_atomic(&dir, &key.file(), &out).map_err(|e| e.to_string())
    };
    if let Err(e) = write() {
        log::warn!("the derivation is not stored: {e}");
    }
}

/// How [`derive_stored`] derives.
#[derive(Clone, Copy, Debug, Default)]
pub struct Options {
    /// With the supports of the wheels the frames keep on the ground released
    /// (`Model::with_supports`: for the constraint forces); a stored derivation has them, so
    /// they are computed only when it must derive.
    pub supports: bool,
    /// Derive (and store) whatever the store holds (`--no-store`).
    pub fresh: bool,
}

/// The derivation of `model` for `choice` from the store, else derived ([`crate::derive`]) and
/// stored.
pub fn derive_stored(
    model: &hamel_model::Model,
    choice: &str,
    options: Options,
) -> Result<Derivation, hamel_model::ModelError> {
    let key = Key::new(model, choice, options.supports)?;
    if !options.fresh
        && let Some(d) = lookup(&key)
    {
        return Ok(d);
    }
    let d = if options.supports {
        crate::derive(&model.with_supports()?, Some(choice))?
    } else {
        crate::derive(model, Some(choice))?
    };
    put(&key, &d);
    Ok(d)
}
