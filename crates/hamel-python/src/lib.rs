//! hamel for Python (issue 61): the `hamel._hamel` extension module that the `hamel` package
//! (`python/hamel/`) wraps.
//!
//! **Job**: models, derivations and evaluation on numpy arrays, for notebooks and scripts the
//! way SymPy's and PyDy's users work. **Inputs**: model files or TOML text, arrays of states.
//! **Outputs**: names, printed equations (text, LaTeX), arrays; errors as Python exceptions
//! that carry the located diagnostic (`file`, `line`, `column`, `key`, `reason`).
//!
//! **Invariants**: the computer algebra never runs in the Python process. A derivation the
//! store lacks is made by `python -m hamel._worker derive-worker RESULT`, a process that exits
//! (`hamel_reduce::pass::derive_in_worker`), so a notebook never holds Symbolica's one licensed
//! thread while it computes numbers; the worker's output is the process's own, Symbolica's
//! notice untouched. Numeric work releases the GIL.

use pyo3::prelude::*;

mod core;
mod derivation;
mod ensemble;
mod errors;
mod model;
mod rhs;
mod scene;
mod search;
mod study;
mod worker;

/// The extension module.
#[pymodule]
mod _hamel {
    #[pymodule_export]
    use super::derivation::Derivation;
    #[pymodule_export]
    use super::errors::{HamelError, ModelError};
    #[pymodule_export]
    use super::model::Model;
    #[pymodule_export]
    use super::rhs::Rhs;
    #[pymodule_export]
    use super::scene::Scene;
    #[pymodule_export]
    use super::worker::work;

    use pyo3::prelude::*;

    /// hamel's version.
    #[pyfunction]
    fn version() -> &'static str {
        env!("CARGO_PKG_VERSION")
    }

    /// Whether this process has started the computer algebra (it never should: the tests
    /// check that derivations are made in worker processes).
    #[pyfunction]
    fn _cas_started() -> bool {
        hamel_cas::started()
    }

    /// Key the caches by this extension module's file (`path`: its size and modification
    /// time), not by the Python interpreter running it: a rebuilt extension generates anew.
    /// The package calls it once, at import.
    #[pyfunction]
    fn _use_identity(path: std::path::PathBuf) {
        hamel_cache::use_identity_of(path);
    }

    /// Derive in worker processes started as `python -m hamel._worker`, `python` the
    /// interpreter running this module.
    #[pymodule_init]
    fn init(m: &Bound<'_, PyModule>) -> PyResult<()> {
        let executable: std::path::PathBuf =
            m.py().import("sys")?.getattr("executable")?.extract()?;
        super::worker::use_workers(executable);
        Ok(())
    }
}

/// Run `f` with the GIL released (numeric work, waiting on a worker process).
pub(crate) fn detached<T: Send>(py: Python<'_>, f: impl FnOnce() -> T + Send) -> T {
    py.detach(f)
}
