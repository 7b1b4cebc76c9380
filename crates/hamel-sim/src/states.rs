//! [`States`]: the states at the output times, stored in one buffer.

use serde::de::Error as _;
use serde::ser::SerializeSeq;
use serde::{Deserialize, Deserializer, Serialize, Serializer};

/// States of one dimension, one per output time, in one row-major buffer: recording an output
/// allocates nothing. `states[j]` is the state at output `j` as a slice; serialised as a list
/// of lists, like `Vec<Vec<f64>>`.
#[derive(Clone, Debug, Default, PartialEq)]
pub struct States {
    dim: usize,
    data: Vec<f64>,
}

impl States {
    /// No states yet, of dimension `dim`, with room for `capacity` of them.
    pub fn with_capacity(dim: usize, capacity: usize) -> Self {
        States {
            dim,
            data: Vec::with_capacity(dim * capacity),
        }
    }

    /// The dimension of every state.
    pub fn dim(&self) -> usize {
        self.dim
    }

    /// The number of states.
    pub fn len(&self) -> usize {
        self.data.len().checked_div(self.dim).unwrap_or(0)
    }

    /// Whether there are none.
    pub fn is_empty(&self) -> bool {
        self.data.is_empty()
    }

    /// Appends a state.
    ///
    /// # Panics
    /// If `y` is not of the dimension of the states (a bug of the caller).
    pub fn push(&mut self, y: &[f64]) {
        assert_eq!(y.len(), self.dim, "a state of the wrong dimension");
        self.data.extend_from_slice(y);
    }

    /// The states in order.
    pub fn iter(&self) -> std::slice::ChunksExact<'_, f64> {
        self.data.chunks_exact(self.dim.max(1))
    }

    /// The states in order, to change in place.
    pub fn iter_mut(&mut self) -> std::slice::ChunksExactMut<'_, f64> {
        self.data.chunks_exact_mut(self.dim.max(1))
    }

    /// The first state.
    pub fn first(&self) -> Option<&[f64]> {
        self.iter().next()
    }

    /// The last state.
    pub fn last(&self) -> Option<&[f64]> {
        self.iter().next_back()
    }

    /// Keeps the first `len` states.
    pub fn truncate(&mut self, len: usize) {
        self.data.truncate(len * self.dim);
    }

    /// Every component of every state, state after state.
    pub fn as_flat(&self) -> &[f64] {
        &self.data
    }

    /// Component `i` of every state.
    pub fn component(&self, i: usize) -> impl Iterator<Item = f64> + '_ {
        self.iter().map(move |y| y[i])
    }
}

impl std::ops::Index<usize> for States {
    type Output = [f64];
    fn index(&self, j: usize) -> &[f64] {
        &self.data[j * self.dim..(j + 1) * self.dim]
    }
}

impl std::ops::IndexMut<usize> for States {
    fn index_mut(&mut self, j: usize) -> &mut [f64] {
        &mut self.data[j * self.dim..(j + 1) * self.dim]
    }
}

impl<'a> IntoIterator for &'a States {
    type Item = &'a [f64];
    type IntoIter = std::slice::ChunksExact<'a, f64>;
    fn into_iter(self) -> Self::IntoIter {
        self.iter()
    }
}

impl Serialize for States {
    fn serialize<S: Serializer>(&self, serializer: S) -> Result<S::Ok, S::Error> {
        let mut seq = serializer.serialize_seq(Some(self.len()))?;
        for y in self {
            seq.serialize_element(y)?;
        }
        seq.end()
    }
}

impl<'de> Deserialize<'de> for States {
    fn deserialize<D: Deserializer<'de>>(deserializer: D) -> Result<Self, D::Error> {
        let rows = Vec::<Vec<f64>>::deserialize(deserializer)?;
        let dim = rows.first().map_or(0, Vec::len);
        let mut states = States::with_capacity(dim, rows.len());
        for (j, y) in rows.iter().enumerate() {
            if y.len() != dim {
                return Err(D::Error::custom(format!(
                    "state {j} has {} components, state 0 has {dim}",
                    y.len()
                )));
            }
            states.push(y);
        }
        Ok(states)
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn rows_index_iterate_and_round_trip_as_lists() {
        let mut s = States::with_capacity(2, 3);
        s.push(&[1.0, 2.0]);
        s.push(&[3.0, 4.0]);
        assert_eq!(
            (s.len(), &s[1], s.last()),
            (2, &[3.0, 4.0][..], Some(&[3.0, 4.0][..]))
        );
        assert_eq!(s.component(0).collect::<Vec<_>>(), [1.0, 3.0]);
        let text = serde_json::to_string(&s).unwrap();
        assert_eq!(text, "[[1.0,2.0],[3.0,4.0]]");
        assert_eq!(serde_json::from_str::<States>(&text).unwrap(), s);
        let ragged = serde_json::from_str::<States>("[[1.0],[2.0,3.0]]").unwrap_err();
        assert!(
            ragged.to_string().contains("state 1 has 2 components"),
            "{ragged}"
        );
        s.truncate(1);
        assert_eq!(s.iter().collect::<Vec<_>>(), [&[1.0, 2.0][..]]);
        assert!(States::default().is_empty() && States::default().iter().next().is_none());
    }
}
