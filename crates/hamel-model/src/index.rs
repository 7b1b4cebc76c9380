//! Typed indices within a model: a coordinate is a [`Coord`] (its place in
//! [`Model::coordinates`]), a parameter a [`Param`] (its place in [`Model::parameters`]). Names
//! are looked up once, where they come in (a file, a command line) and given back where they go
//! out (a report); between, the stages pass indices that cannot be mistaken for one another or
//! for a count.

use serde::{Deserialize, Serialize};

use crate::Model;

/// A coordinate of a model: its index in [`Model::coordinates`].
#[derive(Clone, Copy, Debug, PartialEq, Eq, PartialOrd, Ord, Hash, Serialize, Deserialize)]
#[serde(transparent)]
pub struct Coord(usize);

/// A parameter of a model: its index in [`Model::parameters`].
#[derive(Clone, Copy, Debug, PartialEq, Eq, PartialOrd, Ord, Hash, Serialize, Deserialize)]
#[serde(transparent)]
pub struct Param(usize);

impl Coord {
    /// The coordinate at index `k`.
    pub const fn new(k: usize) -> Coord {
        Coord(k)
    }

    /// Its index in [`Model::coordinates`] (and in every vector of coordinates in model order).
    pub const fn index(self) -> usize {
        self.0
    }
}

impl Param {
    /// The parameter at index `k`.
    pub const fn new(k: usize) -> Param {
        Param(k)
    }

    /// Its index in [`Model::parameters`].
    pub const fn index(self) -> usize {
        self.0
    }
}

impl Model {
    /// The coordinate named `name`, if the model has one.
    pub fn coordinate(&self, name: &str) -> Option<Coord> {
        self.coordinates.iter().position(|c| c == name).map(Coord)
    }

    /// Every coordinate, in order.
    pub fn coords(&self) -> impl Iterator<Item = Coord> + use<> {
        (0..self.coordinates.len()).map(Coord)
    }

    /// The name of coordinate `k`.
    pub fn coordinate_name(&self, k: Coord) -> &str {
        &self.coordinates[k.0]
    }

    /// The names of `ks`, in their order.
    pub fn coordinate_names(&self, ks: &[Coord]) -> Vec<String> {
        ks.iter().map(|&k| self.coordinates[k.0].clone()).collect()
    }

    /// The parameter named `name`, if the model has one.
    pub fn parameter(&self, name: &str) -> Option<Param> {
        self.parameters.get_index_of(name).map(Param)
    }

    /// The name of parameter `p`.
    pub fn parameter_name(&self, p: Param) -> &str {
        let (name, _) = self
            .parameters
            .get_index(p.0)
            .expect("a parameter of this model");
        name
    }
}
