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
