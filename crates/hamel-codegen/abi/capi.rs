//! The C ABI of this core: what hamel's Python package opens (`Model.rhs`, `Model.eval`), and
//! through it numbalsoda, `numba.cfunc` and any C caller.
//!
//! The right-hand side has numbalsoda's signature `void f(double t, const double *y, double *dy,
//! const double *data)`, y = (q, η) with ℓ + σ values. `data` is the block [`hamel_prepare`]
//! fills: the parameters (in [`Parameters::NAMES`]' order) and their prepared constants, opaque
//! to the caller, [`hamel_data_len`] doubles long. A state the equations are not defined at
//! (A_Γ not positive definite, a value not finite) gives NaN in every `dy` from [`hamel_rhs`],
//! and an error message from the `_checked` functions. No function unwinds or keeps a pointer
//! it is given; every pointer must hold the length stated.

use std::os::raw::c_char;

use crate::model::{
    constraint_forces, energy, fast_with, full_into_with, rhs_fixed, CONSTRAINT_FORCES, COORDINATES, DIMS, LIVE,
    NF, Parameters, Prepared,
};

const ELL: usize = DIMS.ell;
const SIGMA: usize = DIMS.sigma;

/// The version of this interface (a caller checks it before anything else).
pub const ABI_VERSION: u32 = 1;

/// Doubles in a data block: the prepared parameters, rounded up.
const DATA_LEN: usize = std::mem::size_of::<Prepared>().div_ceil(8);

const _: () = assert!(std::mem::align_of::<Prepared>() <= 8);

#[unsafe(no_mangle)]
pub extern "C" fn hamel_abi_version() -> u32 {
    ABI_VERSION
}

/// ℓ, σ, the number of parameters, of constraint forces, and the data block's length.
///
/// # Safety
/// `out` holds 5 values.
#[unsafe(no_mangle)]
pub unsafe extern "C" fn hamel_dims(out: *mut usize) {
    let dims = [ELL, SIGMA, Parameters::NAMES.len(), NF, DATA_LEN];
    unsafe { std::ptr::copy_nonoverlapping(dims.as_ptr(), out, dims.len()) };
}

/// The names of `what` (0: coordinates, 1: parameters, 2: constraint forces), one per line,
/// into `buf` (`len` bytes, NUL-terminated when it fits); returns the length the text needs
/// without the NUL.
///
/// # Safety
/// `buf` holds `len` bytes (or is null with `len` 0).
#[unsafe(no_mangle)]
pub unsafe extern "C" fn hamel_names(what: u32, buf: *mut c_char, len: usize) -> usize {
    let names: &[&str] = match what {
        0 => &COORDINATES,
        1 => &Parameters::NAMES,
        2 => &CONSTRAINT_FORCES,
        _ => &[],
    };
    unsafe { write_text(&names.join("\n"), buf, len) }
}

/// Fill the data block `data` (`len` ≥ [`hamel_data_len`] doubles) for the parameter values
/// `params` (`n` = the number of parameters, in [`Parameters::NAMES`]' order). Returns 0, or
/// 1 with the reason in `err` (`err_len` bytes) when the parameters are refused (A_Γ not
/// positive definite for every state, a value not finite) or the lengths are wrong.
///
/// # Safety
/// `params` holds `n` values, `data` `len`, `err` `err_len` bytes.
#[unsafe(no_mangle)]
pub unsafe extern "C" fn hamel_prepare(
    params: *const f64,
    n: usize,
    data: *mut f64,
    len: usize,
    err: *mut c_char,
    err_len: usize,
) -> i32 {
    let fail = |why: String| {
        unsafe { write_text(&why, err, err_len) };
        1
    };
    if n != Parameters::NAMES.len() || len < DATA_LEN {
        return fail(format!(
            "{n} parameters for {} and a data block of {len} for {DATA_LEN}",
            Parameters::NAMES.len()
        ));
    }
    if !LIVE.is_empty() {
        return fail(format!("parameters set at every evaluation ({}) are not supported", LIVE.join(", ")));
    }
    let values = unsafe { std::slice::from_raw_parts(params, n) };
    let mut p = Parameters::default();
    for (name, &v) in Parameters::NAMES.iter().zip(values) {
        if !v.is_finite() {
            return fail(format!("parameter `{name}` = {v} is not finite"));
        }
        if let Err(e) = p.set(name, v) {
            return fail(e.to_string());
        }
    }
    match Prepared::new(&p) {
        Ok(prep) => {
            unsafe {
                std::ptr::write_bytes(data, 0, DATA_LEN);
                std::ptr::write_unaligned(data.cast::<Prepared>(), prep);
            }
            0
        }
        Err(e) => fail(e.to_string()),
    }
}

/// The doubles a data block needs.
#[unsafe(no_mangle)]
pub extern "C" fn hamel_data_len() -> usize {
    DATA_LEN
}

/// The prepared parameters of a data block (read in place when aligned).
///
/// # Safety
/// `data` is a block [`hamel_prepare`] filled.
#[inline(always)]
unsafe fn prepared<R>(data: *const f64, with: impl FnOnce(&Prepared) -> R) -> R {
    let ptr = data.cast::<Prepared>();
    if ptr.is_aligned() {
        with(unsafe { &*ptr })
    } else {
        with(&unsafe { std::ptr::read_unaligned(ptr) })
    }
}

/// d(q, η)/dt at y = (q, η) into `dy` (numbalsoda's and `numba.cfunc`'s signature); NaN in
/// every value where the equations are not defined. `t` is unused: the model is autonomous.
///
/// # Safety
/// `y` and `dy` hold ℓ + σ values, `data` is a block [`hamel_prepare`] filled.
#[unsafe(no_mangle)]
pub unsafe extern "C" fn hamel_rhs(t: f64, y: *const f64, dy: *mut f64, data: *const f64) {
    let _ = t;
    let (y, dy) = unsafe {
        (std::slice::from_raw_parts(y, ELL + SIGMA), std::slice::from_raw_parts_mut(dy, ELL + SIGMA))
    };
    let ok = unsafe { prepared(data, |prep| full_into_with(y, dy, prep)) };
    if ok.is_err() {
        dy.fill(f64::NAN);
    }
}

/// [`hamel_rhs`] that says why: 0, or 1 with the reason in `err` (`err_len` bytes).
///
/// # Safety
/// As [`hamel_rhs`]; `err` holds `err_len` bytes.
#[unsafe(no_mangle)]
pub unsafe extern "C" fn hamel_rhs_checked(
    y: *const f64,
    dy: *mut f64,
    data: *const f64,
    err: *mut c_char,
    err_len: usize,
) -> i32 {
    let (y, dy) = unsafe {
        (std::slice::from_raw_parts(y, ELL + SIGMA), std::slice::from_raw_parts_mut(dy, ELL + SIGMA))
    };
    match unsafe { prepared(data, |prep| full_into_with(y, dy, prep)) } {
        Ok(()) => 0,
        Err(e) => {
            unsafe { write_text(&e.to_string(), err, err_len) };
            1
        }
    }
}

/// [`hamel_rhs`] at `n` states: `y` and `dy` n × (ℓ + σ), row-major. Returns the number of
/// states where the equations are not defined (their rows NaN).
///
/// # Safety
/// `y` and `dy` hold n rows, `data` is a block [`hamel_prepare`] filled.
#[unsafe(no_mangle)]
pub unsafe extern "C" fn hamel_rhs_states(n: usize, y: *const f64, dy: *mut f64, data: *const f64) -> usize {
    let width = ELL + SIGMA;
    let (y, dy) = unsafe { (std::slice::from_raw_parts(y, n * width), std::slice::from_raw_parts_mut(dy, n * width)) };
    unsafe {
        prepared(data, |prep| {
            let mut bad = 0;
            for (y, dy) in y.chunks_exact(width).zip(dy.chunks_exact_mut(width)) {
                if full_into_with(y, dy, prep).is_err() {
                    dy.fill(f64::NAN);
                    bad += 1;
                }
            }
            bad
        })
    }
}

/// Where [`hamel_eval_states`] writes: each pointer null (not wanted) or holding n rows.
#[repr(C)]
pub struct EvalOut {
    /// η̇, n × σ.
    pub eta_dot: *mut f64,
    /// q̇, n × ℓ.
    pub q_dot: *mut f64,
    /// The energy, n.
    pub energy: *mut f64,
    /// η̇ of the paper's equation (14) (the term it drops left out), n × σ.
    pub eta_dot_paper: *mut f64,
    /// The constraint forces, n × [`NF`].
    pub forces: *mut f64,
}

/// η̇, q̇, the energy, the paper's η̇ and the constraint forces at `n` states (`q` n × ℓ, `eta`
/// n × σ, row-major), each where its pointer in `out` is not null. Returns 0, or 1 with the
/// failing state's index in `failed` and the reason in `err` (the rows before it written).
///
/// # Safety
/// `q`, `eta` and the non-null pointers of `out` hold n rows; `data` is a block
/// [`hamel_prepare`] filled; `err` holds `err_len` bytes.
#[unsafe(no_mangle)]
pub unsafe extern "C" fn hamel_eval_states(
    n: usize,
    q: *const f64,
    eta: *const f64,
    data: *const f64,
    out: *const EvalOut,
    failed: *mut usize,
    err: *mut c_char,
    err_len: usize,
) -> i32 {
    let (q, eta, out) = unsafe {
        (std::slice::from_raw_parts(q, n * ELL), std::slice::from_raw_parts(eta, n * SIGMA), &*out)
    };
    let result = unsafe { prepared(data, |prep| (0..n).try_for_each(|i| one(i, q, eta, prep, out).map_err(|e| (i, e)))) };
    match result {
        Ok(()) => 0,
        Err((i, e)) => {
            unsafe {
                *failed = i;
                write_text(&e, err, err_len);
            }
            1
        }
    }
}

/// State `i` of [`hamel_eval_states`].
#[inline(always)]
fn one(i: usize, q: &[f64], eta: &[f64], prep: &Prepared, out: &EvalOut) -> Result<(), String> {
    let (q, eta) = (&q[i * ELL..(i + 1) * ELL], &eta[i * SIGMA..(i + 1) * SIGMA]);
    let row = |ptr: *mut f64, width: usize| {
        (!ptr.is_null()).then(|| unsafe { std::slice::from_raw_parts_mut(ptr.add(i * width), width) })
    };
    let (eta_dot, q_dot) = fast_with(q, eta, prep).map_err(|e| e.to_string())?;
    if let Some(r) = row(out.eta_dot, SIGMA) {
        r.copy_from_slice(&eta_dot);
    }
    if let Some(r) = row(out.q_dot, ELL) {
        r.copy_from_slice(&q_dot);
    }
    crate::runtime::finite("the right-hand side", &eta_dot).map_err(|e| e.to_string())?;
    crate::runtime::finite("the right-hand side", &q_dot).map_err(|e| e.to_string())?;
    if let Some(r) = row(out.energy, 1) {
        r[0] = energy(q, eta, &prep.p).map_err(|e| e.to_string())?;
    }
    if let Some(r) = row(out.eta_dot_paper, SIGMA) {
        let paper = rhs_fixed(q, eta, &prep.p, true).map_err(|e| e.to_string())?;
        r.copy_from_slice(&paper.eta_dot_paper);
    }
    if let Some(r) = row(out.forces, NF) {
        r.copy_from_slice(&constraint_forces(q, eta, &prep.p).map_err(|e| e.to_string())?);
    }
    Ok(())
}

/// `text` into `buf` (`len` bytes), cut at a character boundary and NUL-terminated when
/// `len` > 0; returns the text's full length.
///
/// # Safety
/// `buf` holds `len` bytes, or `len` is 0.
unsafe fn write_text(text: &str, buf: *mut c_char, len: usize) -> usize {
    if len > 0 && !buf.is_null() {
        let mut n = text.len().min(len - 1);
        while !text.is_char_boundary(n) {
            n -= 1;
        }
        unsafe {
            std::ptr::copy_nonoverlapping(text.as_ptr().cast::<c_char>(), buf, n);
            *buf.add(n) = 0;
        }
    }
    text.len()
}
