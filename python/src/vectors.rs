//! Vector arguments as a user has them: a tuple, a list or a numpy array (any float dtype, any
//! layout; `camera.C` is one) for every vector an API function takes, read into fixed-size
//! values, or a TypeError naming the argument and what it takes.

use nalgebra::Vector3;
use numpy::{
    AllowTypeChange, PyArrayDescrMethods, PyArrayLike1, PyUntypedArray, PyUntypedArrayMethods,
};
use pyo3::exceptions::PyTypeError;
use pyo3::prelude::*;

/// What was passed, for an error message: its type, and a numpy array's dtype and shape.
fn described(value: &Bound<'_, PyAny>) -> String {
    if let Ok(a) = value.cast::<PyUntypedArray>() {
        return format!("a {} array of shape {:?}", a.dtype(), a.shape());
    }
    value
        .get_type()
        .name()
        .map_or_else(|_| "another type".to_owned(), |n| n.to_string())
}

/// The numbers of argument `name`: any sequence or 1-D array of numbers.
pub fn floats(value: &Bound<'_, PyAny>, name: &str) -> PyResult<Vec<f64>> {
    let refused = || {
        PyTypeError::new_err(format!(
            "{name}: expected numbers as a tuple, a list or a 1-D numpy array, got {}",
            described(value)
        ))
    };
    // (a string would be cast by numpy digit by digit, an (N, 1) array row by row)
    let array_of_other_rank = value.cast::<PyUntypedArray>().is_ok_and(|a| a.ndim() != 1);
    if array_of_other_rank || value.is_instance_of::<pyo3::types::PyString>() {
        return Err(refused());
    }
    let array: PyArrayLike1<'_, f64, AllowTypeChange> = value.extract().map_err(|_| refused())?;
    Ok(array.as_array().iter().copied().collect())
}

/// `N` numbers of argument `name`.
pub fn float_array<const N: usize>(value: &Bound<'_, PyAny>, name: &str) -> PyResult<[f64; N]> {
    let v = floats(value, name)?;
    v.as_slice().try_into().map_err(|_| {
        PyTypeError::new_err(format!(
            "{name}: expected {N} numbers, got {} ({})",
            v.len(),
            described(value)
        ))
    })
}

/// A point or direction of argument `name` (three numbers), if given.
pub fn vector3(value: Option<&Bound<'_, PyAny>>, name: &str) -> PyResult<Option<Vector3<f64>>> {
    value
        .filter(|v| !v.is_none())
        .map(|v| float_array::<3>(v, name).map(Vector3::from))
        .transpose()
}

/// `N` integers of argument `name`: a sequence of integers or a 1-D integer array (a float
/// is refused rather than truncated).
pub fn int_array<const N: usize>(value: &Bound<'_, PyAny>, name: &str) -> PyResult<[i64; N]> {
    let refused = || {
        PyTypeError::new_err(format!(
            "{name}: expected {N} integers as a tuple, a list or a 1-D numpy integer array, got {}",
            described(value)
        ))
    };
    let v: Vec<i64> = match value.cast::<PyUntypedArray>() {
        Ok(a) if a.ndim() == 1 && matches!(a.dtype().kind(), b'i' | b'u') => {
            let array: PyArrayLike1<'_, i64, AllowTypeChange> =
                value.extract().map_err(|_| refused())?;
            array.as_array().iter().copied().collect()
        }
        Ok(_) => return Err(refused()),
        Err(_) if value.is_instance_of::<pyo3::types::PyString>() => return Err(refused()),
        Err(_) => value.extract().map_err(|_| refused())?,
    };
    v.as_slice().try_into().map_err(|_| {
        PyTypeError::new_err(format!(
            "{name}: expected {N} integers, got {} ({})",
            v.len(),
            described(value)
        ))
    })
}

/// `N` non-negative integers below 2³² of argument `name` (pixel sizes).
pub fn size_array<const N: usize>(value: &Bound<'_, PyAny>, name: &str) -> PyResult<[u32; N]> {
    let v = int_array::<N>(value, name)?;
    let mut out = [0u32; N];
    for (o, &i) in out.iter_mut().zip(&v) {
        *o = u32::try_from(i).map_err(|_| {
            pyo3::exceptions::PyValueError::new_err(format!(
                "{name}: {i} is not a size in pixels (0 to {})",
                u32::MAX
            ))
        })?;
    }
    Ok(out)
}
