//! The arrays given from Python, checked before they are copied into Rust: real numbers only
//! (a complex array is refused, not cut to its real part), one dimension, the length required
//! (checked before anything is copied), and, for the per-particle arrays of the module's
//! functions, finite values and positive masses and volumes, each error naming the argument.

use crate::mpm_msg;
use numpy::{PyArray1, PyArrayDescrMethods, PyArrayMethods, PyUntypedArray, PyUntypedArrayMethods};
use pyo3::exceptions::PyTypeError;
use pyo3::prelude::*;
use pyo3::types::PyDict;
use sparse_mpm::MpmError;

/// What the values of a per-particle array must be besides finite.
#[derive(Clone, Copy, PartialEq, Eq)]
pub(crate) enum Sign {
    /// Any finite value (velocities, stresses, body forces).
    Any,
    /// Finite and positive (masses, volumes).
    Positive,
}

/// `obj` as a NumPy array (`numpy.asarray`; an array is not copied), its conversion's error a
/// `TypeError` naming the argument.
fn as_array<'py>(obj: &Bound<'py, PyAny>, name: &str) -> PyResult<Bound<'py, PyUntypedArray>> {
    let py = obj.py();
    let a = py
        .import("numpy")?
        .call_method1("asarray", (obj,))
        .map_err(|e| PyTypeError::new_err(format!("{name}: expected a 1-D array of real numbers ({e})")))?;
    a.cast_into::<PyUntypedArray>()
        .map_err(|_| PyTypeError::new_err(format!("{name}: expected a 1-D array of real numbers")))
}

/// The length an array must have.
#[derive(Clone, Copy)]
pub(crate) enum Len {
    /// Any length (the array that sets the particle count).
    Any,
    /// Exactly this many entries (one per particle).
    Exactly(usize),
    /// At most this many entries, the word for them (`"nodes"`) and what bounds them.
    AtMost(usize, &'static str, &'static str),
}

/// An error unless `a` is one-dimensional.
fn check_ndim(a: &Bound<'_, PyUntypedArray>, name: &str) -> PyResult<()> {
    if a.ndim() != 1 {
        return Err(mpm_msg(format!(
            "{name}: expected a 1-D array, found one of shape {:?}",
            a.shape()
        )));
    }
    Ok(())
}

/// An error unless the 1-D array `a` has the length `len` requires.
fn check_len(a: &Bound<'_, PyUntypedArray>, name: &'static str, len: Len) -> PyResult<()> {
    match len {
        Len::Exactly(n) if a.len() != n => Err(crate::mpm_err(MpmError::LengthMismatch {
            field: name,
            expected: n,
            found: a.len(),
        })),
        Len::AtMost(n, what, bound) if a.len() > n => Err(mpm_msg(format!(
            "{name}: {} entries, more than the {n} {what} {bound}",
            a.len()
        ))),
        _ => Ok(()),
    }
}

/// The 1-D array of real numbers `obj` (argument `name`) as float64 values, copied; its length
/// is checked against `len` before anything is copied. Floating-point arrays are taken as they
/// are, integer arrays (and lists of ints) converted to float64; a complex array is a
/// `TypeError` (its imaginary part would be lost), as is any other dtype (booleans, strings,
/// objects). More than one dimension (checked first) or a wrong length is an `MpmError`. The
/// values are not checked (see [`check_values`]).
pub(crate) fn real_vec(obj: &Bound<'_, PyAny>, name: &'static str, len: Len) -> PyResult<Vec<f64>> {
    let a = as_array(obj, name)?;
    check_ndim(&a, name)?;
    let dtype = a.dtype();
    match dtype.kind() {
        b'f' | b'i' | b'u' => {}
        b'c' => {
            return Err(PyTypeError::new_err(format!(
                "{name}: a complex array (dtype {dtype}) is refused: the values must be real (the imaginary \
                 part would be dropped)"
            )))
        }
        _ => {
            return Err(PyTypeError::new_err(format!(
                "{name}: expected an array of real numbers (float, or integers taken as floats), found dtype {dtype}"
            )))
        }
    }
    check_len(&a, name, len)?;
    let py = obj.py();
    let kwargs = PyDict::new(py);
    kwargs.set_item("dtype", "float64")?;
    let f = py
        .import("numpy")?
        .call_method("ascontiguousarray", (&a,), Some(&kwargs))?
        .cast_into::<PyArray1<f64>>()
        .map_err(|_| PyTypeError::new_err(format!("{name}: expected a 1-D array of real numbers")))?;
    let r = f
        .try_readonly()
        .map_err(|e| PyTypeError::new_err(format!("{name}: the array cannot be read ({e})")))?;
    Ok(r.as_slice()?.to_vec())
}

/// An error naming the argument, the particle and the value unless every value of `v` is
/// finite (and positive with [`Sign::Positive`]): the library's
/// [`MpmError::InvalidParticleValue`], as `Particles::validate` reports its fields.
pub(crate) fn check_values(name: &'static str, v: &[f64], sign: Sign) -> PyResult<()> {
    let bad = |p: usize, reason: &'static str| {
        crate::mpm_err(MpmError::InvalidParticleValue {
            particle: p,
            field: name,
            value: v[p],
            reason,
        })
    };
    if let Some(p) = v.iter().position(|x| !x.is_finite()) {
        return Err(bad(p, "values must be finite"));
    }
    if sign == Sign::Positive {
        if let Some(p) = v.iter().position(|&x| x <= 0.0) {
            return Err(bad(p, "must be positive"));
        }
    }
    Ok(())
}

/// The per-particle array `obj` (argument `name`) of `n` particles: real, one entry per particle
/// (checked before copying), every value finite and, with [`Sign::Positive`], positive.
pub(crate) fn particle_vec(obj: &Bound<'_, PyAny>, name: &'static str, n: usize, sign: Sign) -> PyResult<Vec<f64>> {
    let v = real_vec(obj, name, Len::Exactly(n))?;
    check_values(name, &v, sign)?;
    Ok(v)
}

/// Largest body index accepted (2⁵³: every integer below it is exact in float64).
const MAX_BODY: f64 = 9_007_199_254_740_992.0;

/// The body index of each of `n` particles (`body`): integers (float arrays holding whole
/// numbers are accepted), one per particle (checked before copying), none negative.
pub(crate) fn body_indices(obj: &Bound<'_, PyAny>, n: usize) -> PyResult<Vec<usize>> {
    let a = as_array(obj, "body")?;
    check_ndim(&a, "body")?;
    let kind = a.dtype().kind();
    if !matches!(kind, b'i' | b'u' | b'f') {
        return Err(PyTypeError::new_err(format!(
            "body: expected an array of body indices (integers), found dtype {}",
            a.dtype()
        )));
    }
    let v = real_vec(a.as_any(), "body", Len::Exactly(n))?;
    let mut out = Vec::with_capacity(n);
    for (k, &b) in v.iter().enumerate() {
        if b < 0.0 {
            return Err(mpm_msg(format!(
                "body[{k}] = {b}: particle {k} names a negative body index"
            )));
        }
        if !(b.is_finite() && b.fract() == 0.0) {
            return Err(mpm_msg(format!(
                "body[{k}] = {b}: particle {k} needs a body index, a whole number from 0"
            )));
        }
        // Read through float64: exact up to 2⁵³, far beyond any number of bodies.
        if b >= MAX_BODY {
            return Err(mpm_msg(format!(
                "body[{k}] = {b}: particle {k} names a body index above {MAX_BODY}, more bodies than any simulation has"
            )));
        }
        out.push(b as usize);
    }
    Ok(out)
}
