//! A generated core opened in this process: the C-ABI library of a model's full system
//! (`hamel_run::cache::prepare_library`, built by cargo once and kept in the private code
//! cache, its SHA-256 verified before it is opened), called through its functions
//! (`crates/hamel-codegen/abi/capi.rs`). No computer algebra: the library is straight-line
//! code over the vendored runtime.

use std::ffi::c_char;
use std::path::{Path, PathBuf};

/// The interface version this package speaks (`capi.rs`'s `ABI_VERSION`).
const ABI_VERSION: u32 = 1;

/// numbalsoda's right-hand side: `void f(double t, const double *y, double *dy, const double *data)`.
pub type RhsFn = unsafe extern "C" fn(f64, *const f64, *mut f64, *const f64);
type RhsChecked = unsafe extern "C" fn(*const f64, *mut f64, *const f64, *mut c_char, usize) -> i32;
type RhsStates = unsafe extern "C" fn(usize, *const f64, *mut f64, *const f64) -> usize;
type Prepare = unsafe extern "C" fn(*const f64, usize, *mut f64, usize, *mut c_char, usize) -> i32;
type EvalStates = unsafe extern "C" fn(
    usize,
    *const f64,
    *const f64,
    *const f64,
    *const EvalOut,
    *mut usize,
    *mut c_char,
    usize,
) -> i32;

/// `capi.rs`'s `EvalOut`: where `hamel_eval_states` writes (null: not wanted).
#[repr(C)]
struct EvalOut {
    eta_dot: *mut f64,
    q_dot: *mut f64,
    energy: *mut f64,
    eta_dot_paper: *mut f64,
    forces: *mut f64,
}

/// The sizes of a core.
#[derive(Clone, Copy, Debug)]
pub struct Dims {
    /// ℓ.
    pub ell: usize,
    /// σ.
    pub sigma: usize,
    /// Parameters.
    pub params: usize,
    /// Constraint forces.
    pub forces: usize,
    /// Doubles of a data block.
    pub data: usize,
}

/// An opened core.
pub struct Core {
    /// The library file (in the code cache).
    pub path: PathBuf,
    /// Its sizes.
    pub dims: Dims,
    /// Its coordinates, parameters and constraint forces, by name.
    pub coordinates: Vec<String>,
    /// Parameter names in the data block's order.
    pub parameters: Vec<String>,
    /// Constraint forces' names.
    pub forces: Vec<String>,
    /// `hamel_rhs`.
    pub rhs: RhsFn,
    rhs_checked: RhsChecked,
    rhs_states: RhsStates,
    prepare: Prepare,
    eval_states: EvalStates,
    /// Kept open while the function pointers live.
    _library: libloading::Library,
}

/// What [`Core::eval`] computes besides η̇, q̇ and the energy.
#[derive(Clone, Copy, Debug)]
pub struct Wanted {
    /// η̇ of the paper's equation (14).
    pub paper: bool,
    /// The constraint forces.
    pub forces: bool,
}

/// [`Core::eval`]'s arrays, row-major.
#[derive(Debug, Default)]
pub struct Evaluated {
    /// n × σ.
    pub eta_dot: Vec<f64>,
    /// n × ℓ.
    pub q_dot: Vec<f64>,
    /// n.
    pub energy: Vec<f64>,
    /// n × σ when wanted.
    pub eta_dot_paper: Option<Vec<f64>>,
    /// n × forces when wanted.
    pub forces: Option<Vec<f64>>,
}

impl Core {
    /// Open the library at `path` (verified by the code cache just before).
    pub fn open(path: &Path) -> Result<Core, String> {
        let fail = |e: libloading::Error| format!("cannot open the core {}: {e}", path.display());
        // SAFETY: the library is hamel's own build from the private code cache, its SHA-256
        // checked against the one recorded when it was built; its initialisers are Rust's.
        let library = unsafe { libloading::Library::new(path) }.map_err(fail)?;
        // SAFETY: the symbols have these types in `capi.rs` of the same ABI version, checked
        // first.
        unsafe {
            let version = *library
                .get::<extern "C" fn() -> u32>(b"hamel_abi_version")
                .map_err(fail)?;
            if version() != ABI_VERSION {
                return Err(format!(
                    "the core {} speaks interface {}, this package {ABI_VERSION}",
                    path.display(),
                    version()
                ));
            }
            let dims_fn = *library
                .get::<unsafe extern "C" fn(*mut usize)>(b"hamel_dims")
                .map_err(fail)?;
            let mut d = [0usize; 5];
            dims_fn(d.as_mut_ptr());
            let names_fn = *library
                .get::<unsafe extern "C" fn(u32, *mut c_char, usize) -> usize>(b"hamel_names")
                .map_err(fail)?;
            let names = |what| names(names_fn, what);
            Ok(Core {
                path: path.to_path_buf(),
                dims: Dims {
                    ell: d[0],
                    sigma: d[1],
                    params: d[2],
                    forces: d[3],
                    data: d[4],
                },
                coordinates: names(0),
                parameters: names(1),
                forces: names(2),
                rhs: *library.get::<RhsFn>(b"hamel_rhs").map_err(fail)?,
                rhs_checked: *library.get(b"hamel_rhs_checked").map_err(fail)?,
                rhs_states: *library.get(b"hamel_rhs_states").map_err(fail)?,
                prepare: *library.get(b"hamel_prepare").map_err(fail)?,
                eval_states: *library.get(b"hamel_eval_states").map_err(fail)?,
                _library: library,
            })
        }
    }

    /// The data block for parameter values `params` (in [`Core::parameters`]' order).
    pub fn prepare(&self, params: &[f64]) -> Result<Vec<f64>, String> {
        let mut data = vec![0.0; self.dims.data];
        let mut err = ErrBuf::new();
        // SAFETY: lengths as the ABI states them.
        let code = unsafe {
            (self.prepare)(
                params.as_ptr(),
                params.len(),
                data.as_mut_ptr(),
                data.len(),
                err.ptr(),
                err.len(),
            )
        };
        if code == 0 { Ok(data) } else { Err(err.text()) }
    }

    /// d(q, η)/dt at `y` into `dy` (ℓ + σ each), or why the equations are not defined there.
    pub fn rhs(&self, y: &[f64], dy: &mut [f64], data: &[f64]) -> Result<(), String> {
        let n = self.dims.ell + self.dims.sigma;
        assert!(y.len() == n && dy.len() == n && data.len() == self.dims.data);
        // The plain call first (no message buffer on the hot path); the checked one says why.
        // SAFETY: lengths checked above.
        unsafe { (self.rhs)(0.0, y.as_ptr(), dy.as_mut_ptr(), data.as_ptr()) };
        if !dy.iter().any(|x| x.is_nan()) {
            return Ok(());
        }
        let mut err = ErrBuf::new();
        // SAFETY: lengths checked above.
        let code = unsafe {
            (self.rhs_checked)(
                y.as_ptr(),
                dy.as_mut_ptr(),
                data.as_ptr(),
                err.ptr(),
                err.len(),
            )
        };
        if code == 0 { Ok(()) } else { Err(err.text()) }
    }

    /// d(q, η)/dt at the rows of `y` (n × (ℓ + σ), row-major) into `dy`: the number of rows
    /// where the equations are not defined (NaN there).
    pub fn rhs_states(&self, y: &[f64], dy: &mut [f64], data: &[f64]) -> usize {
        let width = self.dims.ell + self.dims.sigma;
        assert!(
            y.len().is_multiple_of(width) && dy.len() == y.len() && data.len() == self.dims.data
        );
        // SAFETY: lengths checked above.
        unsafe { (self.rhs_states)(y.len() / width, y.as_ptr(), dy.as_mut_ptr(), data.as_ptr()) }
    }

    /// The outputs at `n` states (`q` n × ℓ, `eta` n × σ, row-major); an error names the state.
    pub fn eval(
        &self,
        q: &[f64],
        eta: &[f64],
        data: &[f64],
        wanted: Wanted,
    ) -> Result<Evaluated, String> {
        let Dims {
            ell, sigma, forces, ..
        } = self.dims;
        let n = q.len() / ell.max(1);
        assert!(q.len() == n * ell && eta.len() == n * sigma && data.len() == self.dims.data);
        let mut out = Evaluated {
            eta_dot: vec![0.0; n * sigma],
            q_dot: vec![0.0; n * ell],
            energy: vec![0.0; n],
            eta_dot_paper: wanted.paper.then(|| vec![0.0; n * sigma]),
            forces: wanted.forces.then(|| vec![0.0; n * forces]),
        };
        let opt =
            |v: &mut Option<Vec<f64>>| v.as_mut().map_or(std::ptr::null_mut(), |v| v.as_mut_ptr());
        let ptrs = EvalOut {
            eta_dot: out.eta_dot.as_mut_ptr(),
            q_dot: out.q_dot.as_mut_ptr(),
            energy: out.energy.as_mut_ptr(),
            eta_dot_paper: opt(&mut out.eta_dot_paper),
            forces: opt(&mut out.forces),
        };
        let (mut failed, mut err) = (0usize, ErrBuf::new());
        // SAFETY: every non-null pointer holds n rows of its width.
        let code = unsafe {
            (self.eval_states)(
                n,
                q.as_ptr(),
                eta.as_ptr(),
                data.as_ptr(),
                &ptrs,
                &mut failed,
                err.ptr(),
                err.len(),
            )
        };
        if code == 0 {
            Ok(out)
        } else {
            Err(format!("state {failed}: {}", err.text()))
        }
    }
}

/// The names `what` of a library (`hamel_names`).
///
/// # Safety
/// `f` is the library's `hamel_names`.
unsafe fn names(
    f: unsafe extern "C" fn(u32, *mut c_char, usize) -> usize,
    what: u32,
) -> Vec<String> {
    // SAFETY: a null buffer of length 0 asks for the length.
    let len = unsafe { f(what, std::ptr::null_mut(), 0) };
    let mut buf = vec![0u8; len + 1];
    // SAFETY: the buffer holds len + 1 bytes.
    unsafe { f(what, buf.as_mut_ptr().cast(), buf.len()) };
    buf.truncate(len);
    let text = String::from_utf8_lossy(&buf);
    if text.is_empty() {
        Vec::new()
    } else {
        text.split('\n').map(str::to_string).collect()
    }
}

/// A buffer for an error message from the library.
struct ErrBuf(Vec<u8>);

impl ErrBuf {
    fn new() -> ErrBuf {
        ErrBuf(vec![0; 1024])
    }
    fn ptr(&mut self) -> *mut c_char {
        self.0.as_mut_ptr().cast()
    }
    fn len(&self) -> usize {
        self.0.len()
    }
    fn text(&self) -> String {
        let end = self.0.iter().position(|&b| b == 0).unwrap_or(self.0.len());
        String::from_utf8_lossy(&self.0[..end]).into_owned()
    }
}
