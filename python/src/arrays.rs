//! numpy in and out: vector and matrix arguments read in place when they
//! are contiguous float64 arrays (copied otherwise: lists, tuples, other
//! dtypes, strided views), and results written straight into new arrays.

use nalgebra::IsometryMatrix3;
use numpy::{PyArray1, PyArray2, PyArray3, PyArrayMethods, PyReadonlyArray2, PyUntypedArrayMethods};
use pyo3::exceptions::{PyTypeError, PyValueError};
use pyo3::prelude::*;

/// A 1-D float argument: a contiguous float64 array read in place, or
/// anything else convertible to floats, copied.
pub(crate) enum Vector<'py> {
    Borrowed(Bound<'py, PyArray1<f64>>),
    Owned(Vec<f64>),
}

impl Vector<'_> {
    pub(crate) fn as_slice(&self) -> &[f64] {
        match self {
            // SAFETY: contiguity was checked on extraction. The array is read
            // while this call holds the GIL and runs no Python code, as a C
            // extension reads its arguments; rust-numpy's borrow tracking
            // (`readonly()`) would cost about as much as the FK it guards.
            Vector::Borrowed(a) => unsafe { a.as_slice() }.unwrap_or(&[]),
            Vector::Owned(v) => v,
        }
    }
}

impl<'a, 'py> FromPyObject<'a, 'py> for Vector<'py> {
    type Error = PyErr;

    fn extract(obj: Borrowed<'a, 'py, PyAny>) -> PyResult<Self> {
        if let Ok(array) = obj.cast::<PyArray1<f64>>() {
            if array.is_contiguous() {
                return Ok(Vector::Borrowed(array.to_owned()));
            }
            return Ok(Vector::Owned(array.try_readonly()?.as_array().to_vec()));
        }
        if let Ok(array) = obj.cast::<numpy::PyUntypedArray>()
            && array.ndim() != 1
        {
            return Err(PyValueError::new_err(format!("expected a 1-D array, got shape {:?}", array.shape())));
        }
        obj.extract::<Vec<f64>>().map(Vector::Owned).map_err(|_| {
            let kind = obj.get_type().name().map(|n| n.to_string()).unwrap_or_default();
            PyTypeError::new_err(format!("expected a 1-D sequence of floats (numpy array, list or tuple), got {kind}"))
        })
    }
}

/// A 2-D float argument (rows × columns, row-major): a C-contiguous
/// float64 array borrowed in place, or anything else convertible, copied.
pub(crate) struct Matrix<'py> {
    borrowed: Option<PyReadonlyArray2<'py, f64>>,
    owned: Vec<f64>,
    pub(crate) rows: usize,
    pub(crate) cols: usize,
}

impl Matrix<'_> {
    /// All values, row after row.
    pub(crate) fn as_slice(&self) -> &[f64] {
        match &self.borrowed {
            Some(a) => a.as_slice().unwrap_or(&[]),
            None => &self.owned,
        }
    }

    /// Row `i`.
    pub(crate) fn row(&self, i: usize) -> &[f64] {
        &self.as_slice()[i * self.cols..(i + 1) * self.cols]
    }

    /// The rows as vectors (for APIs that take `&[Vec<f64>]`).
    pub(crate) fn to_rows(&self) -> Vec<Vec<f64>> {
        (0..self.rows).map(|i| self.row(i).to_vec()).collect()
    }
}

impl<'a, 'py> FromPyObject<'a, 'py> for Matrix<'py> {
    type Error = PyErr;

    fn extract(obj: Borrowed<'a, 'py, PyAny>) -> PyResult<Self> {
        if let Ok(array) = obj.cast::<PyArray2<f64>>() {
            let array = array.try_readonly()?;
            let [rows, cols] = [array.shape()[0], array.shape()[1]];
            if array.is_c_contiguous() {
                return Ok(Matrix { borrowed: Some(array), owned: Vec::new(), rows, cols });
            }
            let owned = array.as_array().iter().copied().collect();
            return Ok(Matrix { borrowed: None, owned, rows, cols });
        }
        if let Ok(array) = obj.cast::<numpy::PyUntypedArray>()
            && array.ndim() != 2
        {
            return Err(PyValueError::new_err(format!("expected a 2-D array, got shape {:?}", array.shape())));
        }
        let rows: Vec<Vec<f64>> = obj.extract().map_err(|_| {
            let kind = obj.get_type().name().map(|n| n.to_string()).unwrap_or_default();
            PyTypeError::new_err(format!("expected a 2-D array of floats (rows × columns), got {kind}"))
        })?;
        let cols = rows.first().map_or(0, Vec::len);
        if let Some((i, row)) = rows.iter().enumerate().find(|(_, r)| r.len() != cols) {
            return Err(PyValueError::new_err(format!("row {i} has {} values, row 0 has {cols}", row.len())));
        }
        Ok(Matrix { borrowed: None, rows: rows.len(), cols, owned: rows.concat() })
    }
}

/// Checks that a matrix argument has `cols` columns (one per joint).
pub(crate) fn check_columns(what: &str, m: &Matrix<'_>, cols: usize) -> PyResult<()> {
    if m.cols != cols && m.rows > 0 {
        return Err(PyValueError::new_err(format!("{what} has {} columns, expected {cols} (one per joint)", m.cols)));
    }
    Ok(())
}

/// Runs `fill` on the values of `out`, a caller's array to overwrite
/// (row-major), once checked to be a writeable, C-contiguous float64 array
/// of `shape`.
pub(crate) fn fill_out<D: numpy::ndarray::Dimension, R>(
    out: &Bound<'_, numpy::PyArray<f64, D>>,
    shape: &[usize],
    fill: impl FnOnce(&mut [f64]) -> PyResult<R>,
) -> PyResult<R> {
    if out.shape() != shape {
        return Err(PyValueError::new_err(format!("out has shape {:?}, expected {shape:?}", out.shape())));
    }
    // numpy's F-contiguous arrays pass as slices too: the row-major fill needs C order.
    if !out.is_c_contiguous() {
        return Err(PyValueError::new_err("out must be C-contiguous"));
    }
    // SAFETY: reading the flags of a live array object.
    if unsafe { (*out.as_array_ptr()).fields.flags } & numpy::npyffi::NPY_ARRAY_WRITEABLE == 0 {
        return Err(PyValueError::new_err("out is read-only"));
    }
    // SAFETY: as for `Vector`: written while this call holds the GIL and
    // runs no Python code; rust-numpy's borrow tracking would cost more than
    // the kinematics it guards.
    fill(unsafe { out.as_slice_mut() }.map_err(|_| PyValueError::new_err("out must be C-contiguous"))?)
}

/// A new 1-D array holding `values`.
pub(crate) fn vector<'py>(py: Python<'py>, values: &[f64]) -> Bound<'py, PyArray1<f64>> {
    PyArray1::from_slice(py, values)
}

/// A new `rows × cols` array filled by `fill`, which receives the values row-major.
pub(crate) fn matrix_with<'py>(
    py: Python<'py>,
    rows: usize,
    cols: usize,
    fill: impl FnOnce(&mut [f64]),
) -> Bound<'py, PyArray2<f64>> {
    let array = PyArray2::<f64>::zeros(py, [rows, cols], false);
    // SAFETY: the array was just created here and is not shared yet.
    fill(unsafe { array.as_slice_mut() }.expect("a new array is contiguous"));
    array
}

/// A new `n × rows × cols` array filled by `fill` (values in C order).
pub(crate) fn stack_with<'py>(
    py: Python<'py>,
    shape: [usize; 3],
    fill: impl FnOnce(&mut [f64]),
) -> Bound<'py, PyArray3<f64>> {
    let array = PyArray3::<f64>::zeros(py, shape, false);
    // SAFETY: the array was just created here and is not shared yet.
    fill(unsafe { array.as_slice_mut() }.expect("a new array is contiguous"));
    array
}

/// A new `rows.len() × cols` array of the rows (all of length `cols`).
pub(crate) fn rows_matrix<'py>(py: Python<'py>, rows: &[Vec<f64>], cols: usize) -> Bound<'py, PyArray2<f64>> {
    matrix_with(py, rows.len(), cols, |out| {
        for (chunk, row) in out.chunks_exact_mut(cols.max(1)).zip(rows) {
            chunk.copy_from_slice(row);
        }
    })
}

/// Writes a pose as a row-major homogeneous 4 × 4 matrix.
pub(crate) fn write_pose(pose: &IsometryMatrix3<f64>, out: &mut [f64]) {
    let (r, t) = (pose.rotation.matrix(), &pose.translation.vector);
    for i in 0..3 {
        for j in 0..3 {
            out[4 * i + j] = r[(i, j)];
        }
        out[4 * i + 3] = t[i];
    }
    out[12..16].copy_from_slice(&[0.0, 0.0, 0.0, 1.0]);
}

/// A pose from a row-major homogeneous 4 × 4 matrix argument `what`: a
/// rotation (orthonormal, determinant 1, within 1e-6), a finite
/// translation and a last row of 0, 0, 0, 1.
pub(crate) fn pose_from_matrix(what: &str, m: &Matrix<'_>) -> PyResult<IsometryMatrix3<f64>> {
    if (m.rows, m.cols) != (4, 4) {
        return Err(PyValueError::new_err(format!("{what} must be a 4 × 4 matrix, got {} × {}", m.rows, m.cols)));
    }
    let a = m.as_slice();
    let h = nalgebra::Matrix4::from_row_slice(a);
    let r = h.fixed_view::<3, 3>(0, 0).into_owned();
    let orthonormal = (r.transpose() * r - nalgebra::Matrix3::identity()).abs().max() < 1e-6 && r.determinant() > 0.0;
    let last = (a[12], a[13], a[14], a[15]) == (0.0, 0.0, 0.0, 1.0);
    if !(a.iter().all(|v| v.is_finite()) && orthonormal && last) {
        return Err(PyValueError::new_err(format!(
            "{what} must be a homogeneous transform (a rotation, a finite translation, last row 0, 0, 0, 1), got {a:?}"
        )));
    }
    let rotation = nalgebra::Rotation3::from_matrix_unchecked(r);
    Ok(IsometryMatrix3::from_parts(nalgebra::Translation3::new(a[3], a[7], a[11]), rotation))
}

/// A pose as a new 4 × 4 array.
pub(crate) fn pose_matrix<'py>(py: Python<'py>, pose: &IsometryMatrix3<f64>) -> Bound<'py, PyArray2<f64>> {
    matrix_with(py, 4, 4, |out| write_pose(pose, out))
}
