//! `tandem.RobotModel`: URDF models, forward kinematics and frame
//! Jacobians from Python.
//!
//! Single queries keep the GIL (they take well under a microsecond; handing
//! the GIL over would cost more) and reuse one kinematics workspace per
//! model; the batch queries (`frame_poses`, `frame_jacobians`) release it.

use crate::arrays::{Matrix, Vector, check_columns, fill_out, matrix_with, stack_with, write_pose};
use crate::errors::PyResultExt;
use nalgebra::{Matrix3xX, Matrix6xX, Point3};
use numpy::{PyArray1, PyArray2, PyArray3};
use pyo3::exceptions::{PyIndexError, PyValueError};
use pyo3::prelude::*;
use pyo3::types::PyString;
use std::collections::BTreeMap;
use std::path::PathBuf;
use std::sync::{Arc, Mutex};
use tandem::robot::{
    FrameId, JointLimits, KinematicsWorkspace, MeshSearchPath, ReferenceFrame, RobotDescription, RobotError, RobotModel,
};

/// A new or given 2-D float64 array.
type Array2<'py> = Bound<'py, PyArray2<f64>>;

/// A frame named by its URDF name or by its index in `frame_names`.
pub(crate) enum FrameArg<'py> {
    Name(Bound<'py, PyString>),
    Index(usize),
}

// By hand rather than derived: a derived extraction tries the string first
// and builds a Python exception for every index, which tripled the cost of
// a call with a frame index.
impl<'a, 'py> FromPyObject<'a, 'py> for FrameArg<'py> {
    type Error = PyErr;

    fn extract(obj: Borrowed<'a, 'py, PyAny>) -> PyResult<Self> {
        match obj.cast::<PyString>() {
            Ok(name) => Ok(FrameArg::Name(name.to_owned())),
            Err(_) => obj.extract::<usize>().map(FrameArg::Index).map_err(|_| {
                let kind = obj.get_type().name().map(|n| n.to_string()).unwrap_or_default();
                pyo3::exceptions::PyTypeError::new_err(format!("a frame is a name (str) or an index (int), got {kind}"))
            }),
        }
    }
}

/// The frame `frame` names in `model` (by name, or index in `frames()`).
pub(crate) fn frame_id(model: &RobotModel, frame: &FrameArg<'_>) -> PyResult<FrameId> {
    match frame {
        FrameArg::Name(name) => model.frame_id(name.to_str()?).py(),
        FrameArg::Index(i) => model.frame_ids().nth(*i).ok_or_else(|| {
            PyIndexError::new_err(format!("frame index {i} out of range (the model has {})", model.frames().len()))
        }),
    }
}

/// Per-model scratch space of single queries.
struct Scratch {
    kinematics: KinematicsWorkspace,
    jacobian: Matrix6xX<f64>,
    point_jacobian: Matrix3xX<f64>,
}

impl Scratch {
    fn new(model: &RobotModel) -> Scratch {
        Scratch {
            kinematics: KinematicsWorkspace::new(model),
            jacobian: Matrix6xX::zeros(model.nq()),
            point_jacobian: Matrix3xX::zeros(model.nq()),
        }
    }
}

/// A robot's kinematic model: a URDF with a choice of active joints (the
/// others held at fixed values). Configurations ``q`` hold one value per
/// active joint (rad or m) in ``joint_names`` order; poses are in the frame
/// of the URDF's root link ("world"). Immutable; safe to share between
/// threads.
#[pyclass(module = "tandem", name = "RobotModel", frozen)]
pub struct PyRobotModel {
    pub(crate) model: Arc<RobotModel>,
    scratch: Mutex<Scratch>,
}

impl PyRobotModel {
    pub(crate) fn new(model: Arc<RobotModel>) -> PyRobotModel {
        let scratch = Mutex::new(Scratch::new(&model));
        PyRobotModel { model, scratch }
    }

    pub(crate) fn frame(&self, frame: &FrameArg<'_>) -> PyResult<FrameId> {
        frame_id(&self.model, frame)
    }

    /// Runs `f` with the model's scratch space, or with a fresh one when
    /// another thread holds it; its error as a Python exception.
    fn with_scratch<R>(&self, f: impl FnOnce(&mut Scratch) -> Result<R, RobotError>) -> PyResult<R> {
        match self.scratch.try_lock() {
            Ok(mut scratch) => f(&mut scratch),
            Err(_) => f(&mut Scratch::new(&self.model)),
        }
        .py()
    }

    fn limits<'py>(&self, py: Python<'py>, part: fn(&JointLimits) -> f64) -> Bound<'py, PyArray1<f64>> {
        PyArray1::from_iter(py, self.model.limits().iter().map(part))
    }
}

fn reference_frame(name: &str) -> PyResult<ReferenceFrame> {
    match name {
        "world" | "world_aligned" | "local_world_aligned" => Ok(ReferenceFrame::WorldAligned),
        "local" => Ok(ReferenceFrame::Local),
        other => Err(PyValueError::new_err(format!("reference must be 'world' or 'local', got {other:?}"))),
    }
}

/// Fills the `out` array if given (checked: C-contiguous float64 of
/// `shape`), a new one otherwise, with `fill` (values row-major).
fn output<'py>(
    py: Python<'py>,
    out: Option<Bound<'py, PyArray2<f64>>>,
    shape: [usize; 2],
    fill: impl FnOnce(&mut [f64]) -> PyResult<()>,
) -> PyResult<Bound<'py, PyArray2<f64>>> {
    let Some(out) = out else {
        let mut result = Ok(());
        let array = matrix_with(py, shape[0], shape[1], |o| result = fill(o));
        return result.map(|()| array);
    };
    fill_out(&out, &shape, fill)?;
    Ok(out)
}

/// Builds a model over `description` with the given selection and held joints.
fn build(
    description: RobotDescription,
    chain: Option<(String, String)>,
    joints: Option<Vec<String>>,
    hold: BTreeMap<String, f64>,
) -> PyResult<RobotModel> {
    let mut builder = RobotModel::builder(Arc::new(description));
    builder = match (chain, joints) {
        (Some(_), Some(_)) => {
            return Err(PyValueError::new_err("give either chain=(root, tip) or joints=[...], not both"));
        }
        (Some((root, tip)), None) => builder.chain(root, tip),
        (None, Some(joints)) => builder.active_joints(joints),
        (None, None) => builder,
    };
    for (joint, value) in hold {
        builder = builder.hold(joint, value);
    }
    builder.build().py()
}

#[pymethods]
impl PyRobotModel {
    /// The embedded Franka Panda: 7 arm joints active, fingers held open
    /// (0.04 m), sphere-set collision shapes, gripper frame ``panda_hand_tcp``.
    #[staticmethod]
    fn panda() -> PyRobotModel {
        PyRobotModel::new(Arc::new(RobotModel::panda()))
    }

    /// Loads a URDF file. Meshes (``package://``, ``file://`` or relative)
    /// are looked up in ``package_dirs``, ``$ROS_PACKAGE_PATH`` (unless
    /// ``ros_package_path=False``) and the URDF's ancestors. Active joints:
    /// ``chain=(root_link, tip_frame)``, or ``joints=[names...]`` in that
    /// order, or by default every movable joint no mimic drives; ``hold``
    /// sets the values (rad or m) of inactive joints.
    #[staticmethod]
    #[pyo3(signature = (path, *, package_dirs=Vec::new(), chain=None, joints=None, hold=BTreeMap::new(), ros_package_path=true))]
    fn from_urdf(
        py: Python<'_>,
        path: PathBuf,
        package_dirs: Vec<PathBuf>,
        chain: Option<(String, String)>,
        joints: Option<Vec<String>>,
        hold: BTreeMap<String, f64>,
        ros_package_path: bool,
    ) -> PyResult<PyRobotModel> {
        let mut search = MeshSearchPath::new(package_dirs);
        if ros_package_path {
            search = search.with_ros_package_path();
        }
        let description = py.detach(|| RobotDescription::from_urdf_file(&path, &search)).py()?;
        Ok(PyRobotModel::new(Arc::new(build(description, chain, joints, hold)?)))
    }

    /// Parses URDF text; relative mesh paths resolve against ``package_dirs``
    /// only. Other arguments as :meth:`from_urdf`.
    #[staticmethod]
    #[pyo3(signature = (text, *, package_dirs=Vec::new(), chain=None, joints=None, hold=BTreeMap::new()))]
    fn from_urdf_string(
        text: &str,
        package_dirs: Vec<PathBuf>,
        chain: Option<(String, String)>,
        joints: Option<Vec<String>>,
        hold: BTreeMap<String, f64>,
    ) -> PyResult<PyRobotModel> {
        let description = RobotDescription::from_urdf_str(text, &MeshSearchPath::new(package_dirs)).py()?;
        Ok(PyRobotModel::new(Arc::new(build(description, chain, joints, hold)?)))
    }

    /// The ``name`` attribute of the URDF's ``<robot>``.
    #[getter]
    fn name(&self) -> &str {
        self.model.description().name()
    }

    /// Number of active joints: the length of ``q``.
    #[getter]
    fn nq(&self) -> usize {
        self.model.nq()
    }

    /// Names of the active joints, in ``q`` order.
    #[getter]
    fn joint_names(&self) -> Vec<String> {
        self.model.joint_names().to_vec()
    }

    /// Lower position limits of the active joints (rad or m; -inf for continuous joints).
    #[getter]
    fn lower_limits<'py>(&self, py: Python<'py>) -> Bound<'py, PyArray1<f64>> {
        self.limits(py, |l| l.lower)
    }

    /// Upper position limits of the active joints (rad or m; inf for continuous joints).
    #[getter]
    fn upper_limits<'py>(&self, py: Python<'py>) -> Bound<'py, PyArray1<f64>> {
        self.limits(py, |l| l.upper)
    }

    /// Velocity limits of the active joints (rad/s or m/s).
    #[getter]
    fn velocity_limits<'py>(&self, py: Python<'py>) -> Bound<'py, PyArray1<f64>> {
        self.limits(py, |l| l.velocity)
    }

    /// Effort limits of the active joints (N·m or N).
    #[getter]
    fn effort_limits<'py>(&self, py: Python<'py>) -> Bound<'py, PyArray1<f64>> {
        self.limits(py, |l| l.effort)
    }

    /// Every frame: one per link, then one per joint, in URDF order (the
    /// index accepted wherever a frame is).
    #[getter]
    fn frame_names(&self) -> Vec<String> {
        self.model.frames().iter().map(|f| f.name.clone()).collect()
    }

    /// Name of the URDF's root link: the world frame.
    #[getter]
    fn root_link(&self) -> &str {
        self.model.description().root_link()
    }

    /// Index of a frame in ``frame_names`` (link names win over joint names).
    fn frame_index(&self, name: &str) -> PyResult<usize> {
        Ok(self.model.frame_id(name).py()?.index())
    }

    /// A configuration in the middle of the limits (0 where 0 is within them).
    fn neutral_configuration<'py>(&self, py: Python<'py>) -> Bound<'py, PyArray1<f64>> {
        PyArray1::from_vec(py, self.model.neutral_configuration())
    }

    /// True when ``q`` has one value per joint, each within its limits.
    fn within_limits(&self, q: Vector<'_>) -> bool {
        self.model.within_limits(q.as_slice())
    }

    /// Raises ``ConfigurationError`` unless ``q`` has one finite value per joint.
    fn check_configuration(&self, q: Vector<'_>) -> PyResult<()> {
        self.model.check_configuration(q.as_slice()).py()
    }

    /// World pose of ``frame`` (name or index) at ``q``: a 4 × 4
    /// homogeneous matrix (m). ``out``: a C-contiguous float64 4 × 4 array
    /// to write into instead of allocating.
    #[pyo3(signature = (q, frame, *, out=None))]
    fn frame_pose<'py>(
        &self,
        py: Python<'py>,
        q: Vector<'_>,
        frame: FrameArg<'_>,
        out: Option<Bound<'py, PyArray2<f64>>>,
    ) -> PyResult<Bound<'py, PyArray2<f64>>> {
        let id = self.frame(&frame)?;
        output(py, out, [4, 4], |o| {
            let pose = self.with_scratch(|s| {
                self.model.forward_kinematics(&mut s.kinematics, q.as_slice())?;
                Ok(self.model.frame_pose(&s.kinematics, id))
            });
            write_pose(&pose?, o);
            Ok(())
        })
    }

    /// Geometric Jacobian of ``frame`` at ``q``: 6 × nq, linear velocity
    /// rows (m/s) then angular (rad/s). ``reference="world"``: the frame
    /// origin's velocity in world axes (Pinocchio's LOCAL_WORLD_ALIGNED);
    /// ``"local"``: in the frame's own axes (LOCAL).
    #[pyo3(signature = (q, frame, reference="world", *, out=None))]
    fn frame_jacobian<'py>(
        &self,
        py: Python<'py>,
        q: Vector<'_>,
        frame: FrameArg<'_>,
        reference: &str,
        out: Option<Bound<'py, PyArray2<f64>>>,
    ) -> PyResult<Bound<'py, PyArray2<f64>>> {
        let (id, reference, n) = (self.frame(&frame)?, reference_frame(reference)?, self.model.nq());
        output(py, out, [6, n], |o| {
            self.with_scratch(|s| {
                self.model.forward_kinematics(&mut s.kinematics, q.as_slice())?;
                self.model.frame_jacobian(&s.kinematics, id, reference, &mut s.jacobian)?;
                transpose_into(&s.jacobian, o);
                Ok(())
            })
        })
    }

    /// ``(frame_pose, frame_jacobian)`` from one forward kinematics pass.
    #[pyo3(signature = (q, frame, reference="world"))]
    fn frame_pose_jacobian<'py>(
        &self,
        py: Python<'py>,
        q: Vector<'_>,
        frame: FrameArg<'_>,
        reference: &str,
    ) -> PyResult<(Array2<'py>, Array2<'py>)> {
        let (id, reference, n) = (self.frame(&frame)?, reference_frame(reference)?, self.model.nq());
        let mut pose = None;
        let jacobian = output(py, None, [6, n], |o| {
            let found = self.with_scratch(|s| {
                self.model.forward_kinematics(&mut s.kinematics, q.as_slice())?;
                let pose = self.model.frame_jacobian(&s.kinematics, id, reference, &mut s.jacobian)?;
                transpose_into(&s.jacobian, o);
                Ok(pose)
            });
            pose = Some(found?);
            Ok(())
        })?;
        let pose = pose.expect("set by a successful fill");
        Ok((matrix_with(py, 4, 4, |o| write_pose(&pose, o)), jacobian))
    }

    /// Jacobian (3 × nq, world axes, m/s per joint velocity) of the
    /// velocity of a point fixed on ``frame``, given in that frame's
    /// coordinates (m); also returns the point's world position.
    fn point_jacobian<'py>(
        &self,
        py: Python<'py>,
        q: Vector<'_>,
        frame: FrameArg<'_>,
        point: [f64; 3],
    ) -> PyResult<(Bound<'py, PyArray1<f64>>, Array2<'py>)> {
        let (id, n) = (self.frame(&frame)?, self.model.nq());
        let (world, jacobian) = self.with_scratch(|s| {
            self.model.forward_kinematics(&mut s.kinematics, q.as_slice())?;
            let p = Point3::from(point);
            let world = self.model.point_jacobian(&s.kinematics, id, &p, &mut s.point_jacobian)?;
            Ok((world, s.point_jacobian.clone()))
        })?;
        let out = matrix_with(py, 3, n, |o| {
            for (i, row) in o.chunks_exact_mut(n.max(1)).enumerate() {
                row.iter_mut().enumerate().for_each(|(k, v)| *v = jacobian[(i, k)]);
            }
        });
        Ok((PyArray1::from_slice(py, world.coords.as_slice()), out))
    }

    /// World poses of every frame at ``q``, in ``frame_names`` order: F × 4 × 4.
    fn frame_placements<'py>(&self, py: Python<'py>, q: Vector<'_>) -> PyResult<Bound<'py, PyArray3<f64>>> {
        let mut result = Ok(());
        let out = stack_with(py, [self.model.frames().len(), 4, 4], |data| {
            result = self.with_scratch(|s| {
                self.model.forward_kinematics(&mut s.kinematics, q.as_slice())?;
                self.model.update_frame_placements(&mut s.kinematics);
                for (pose, chunk) in s.kinematics.frame_poses().iter().zip(data.chunks_exact_mut(16)) {
                    write_pose(pose, chunk);
                }
                Ok(())
            });
        });
        result.map(|()| out)
    }

    /// World poses of ``frame`` at each row of ``qs`` (N × nq): N × 4 × 4.
    /// Releases the GIL.
    fn frame_poses<'py>(
        &self,
        py: Python<'py>,
        qs: Matrix<'_>,
        frame: FrameArg<'_>,
    ) -> PyResult<Bound<'py, PyArray3<f64>>> {
        let id = self.frame(&frame)?;
        check_columns("qs", &qs, self.model.nq())?;
        let (model, rows, cols) = (&self.model, qs.rows, qs.cols);
        let data = qs.as_slice();
        let mut result: Result<(), RobotError> = Ok(());
        let out = stack_with(py, [rows, 4, 4], |out| {
            result = py.detach(|| {
                let mut ws = KinematicsWorkspace::new(model);
                for (q, chunk) in data.chunks_exact(cols.max(1)).zip(out.chunks_exact_mut(16)) {
                    model.forward_kinematics(&mut ws, q)?;
                    write_pose(&model.frame_pose(&ws, id), chunk);
                }
                Ok(())
            })
        });
        result.py()?;
        Ok(out)
    }

    /// Jacobians of ``frame`` at each row of ``qs`` (N × nq): N × 6 × nq,
    /// ``reference`` as in :meth:`frame_jacobian`. Releases the GIL.
    #[pyo3(signature = (qs, frame, reference="world"))]
    fn frame_jacobians<'py>(
        &self,
        py: Python<'py>,
        qs: Matrix<'_>,
        frame: FrameArg<'_>,
        reference: &str,
    ) -> PyResult<Bound<'py, PyArray3<f64>>> {
        let (id, reference, n) = (self.frame(&frame)?, reference_frame(reference)?, self.model.nq());
        check_columns("qs", &qs, n)?;
        let (model, rows) = (&self.model, qs.rows);
        let data = qs.as_slice();
        let mut result: Result<(), RobotError> = Ok(());
        let out = stack_with(py, [rows, 6, n], |out| {
            result = py.detach(|| {
                let (mut ws, mut jac) = (KinematicsWorkspace::new(model), Matrix6xX::zeros(n));
                for (q, chunk) in data.chunks_exact(n.max(1)).zip(out.chunks_exact_mut((6 * n).max(1))) {
                    model.forward_kinematics(&mut ws, q)?;
                    model.frame_jacobian(&ws, id, reference, &mut jac)?;
                    transpose_into(&jac, chunk);
                }
                Ok(())
            })
        });
        result.py()?;
        Ok(out)
    }

    fn __repr__(&self) -> String {
        format!("RobotModel(name={:?}, nq={}, joints={:?})", self.name(), self.model.nq(), self.model.joint_names())
    }
}

/// Writes a column-major 6 × n Jacobian row-major into `out`.
fn transpose_into(jacobian: &Matrix6xX<f64>, out: &mut [f64]) {
    let n = jacobian.ncols();
    for (k, column) in jacobian.as_slice().chunks_exact(6).enumerate() {
        for (i, v) in column.iter().enumerate() {
            out[i * n + k] = *v;
        }
    }
}
