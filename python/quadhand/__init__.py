"""QuadHand from Python: whole-body trajectory planning for aerial manipulators.

The same planner as the ``quadhand-plan`` program, for notebooks and scripts::

    import numpy as np
    import quadhand

    robot = quadhand.Robot("meshes/quadhand/quadhand.urdf", sdf_dir="data/sdf/quadhand")
    scene = quadhand.Scene(np.load("cloud.npy"))          # N x 3, metres, world frame
    result = quadhand.plan("data/tasks/window_cup.yaml", robot=robot, scene=scene)
    if result.success:
        t, px = result.trajectory["t"], result.trajectory["px"]

Every bad input raises :class:`quadhand.Error` (a ``ValueError``) whose
message is the line the programs print after ``error:``, naming the argument
or file and the problem. A plan that ran but failed the post-check is not an
exception: ``result.success`` is False and ``result.report`` says why.
Reference: docs/python.md.
"""

import json
import os
import warnings
from collections.abc import Mapping

import numpy as np

from . import _core
from ._core import Error, representation_names, solver_names

__all__ = [
    "Error",
    "ExactClearance",
    "PlanResult",
    "Robot",
    "Scene",
    "exact_clearance",
    "generate_sdfs",
    "plan",
    "representation_names",
    "solver_names",
]
__version__ = "@QUADHAND_VERSION@"


def _path(name, value):
    if isinstance(value, (str, os.PathLike)):
        text = os.fspath(value)
        if text:
            return text
    raise Error(f"{name}: expected a file or folder path, got {type(value).__name__} {value!r}")


def _vector(name, value, size=None):
    """A 1-D float64 array of finite numbers (of `size` entries, if given)."""
    try:
        array = np.asarray(value, dtype=np.float64)
    except (TypeError, ValueError):
        raise Error(f"{name}: expected a list of numbers, got {value!r}") from None
    if array.ndim != 1 or (size is not None and array.shape[0] != size):
        want = f"{size} numbers" if size is not None else "a list of numbers"
        raise Error(f"{name}: expected {want}, got shape {array.shape}")
    if not np.all(np.isfinite(array)):
        raise Error(f"{name}: must be finite numbers (got {array.tolist()})")
    return array


class Robot(_core.Robot):
    """A robot from its URDF, with the folder of its link SDFs.

    ``Robot(urdf, sdf_dir=None)``: relative mesh paths in the URDF resolve
    against its folder, ``package://NAME/`` against an ancestor folder NAME or
    ROS_PACKAGE_PATH. ``sdf_dir`` holds one ``<link>.qhsdf`` per collision
    link (:func:`generate_sdfs` or ``quadhand-sdfgen`` makes them); it is
    needed to plan. Properties: ``name``, ``urdf``, ``sdf_dir``,
    ``joint_names`` (the actuated joints, in the order of every joint vector),
    ``joint_lower_limits``, ``joint_upper_limits``, ``link_names``,
    ``collision_link_names``.
    """

    def __init__(self, urdf, sdf_dir=None):
        urdf = _path("urdf", urdf)
        sdf_dir = "" if sdf_dir is None else _path("sdf_dir", sdf_dir)
        super().__init__(urdf, sdf_dir)

    def __repr__(self):
        return f"quadhand.Robot({self.urdf!r}, sdf_dir={self.sdf_dir!r})"


class Scene:
    """An obstacle point cloud: world frame, metres.

    ``Scene(points)`` takes an N x 3 array of floats (float64 or float32, any
    layout); the points are copied once into the scene, which every plan made
    with it then shares without copying. Non-finite rows are an error: drop
    them first (``points[np.isfinite(points).all(axis=1)]``).
    ``Scene.from_pcd(path)`` reads a PCD file (ascii, binary or
    binary_compressed) and drops non-finite points, counting them in
    ``dropped_non_finite``. ``scene.points`` is a read-only N x 3 view of the
    scene's own copy (no copy is made).
    """

    def __init__(self, points):
        array = np.asarray(points) if not isinstance(points, np.ndarray) else points
        if array.dtype.kind != "f" or array.dtype.itemsize not in (4, 8):
            raise Error(f"points: expected float64 or float32 values, got dtype {array.dtype}")
        if array.ndim != 2 or array.shape[1] != 3:
            raise Error(f"points: expected an N x 3 array, got shape {array.shape}")
        if array.shape[0] == 0:
            raise Error("points: the cloud is empty")
        bad = ~np.isfinite(array).all(axis=1)
        if bad.any():
            raise Error(
                f"points: {int(bad.sum())} row(s) are not finite, the first is row {int(np.argmax(bad))}; "
                "drop them with points[np.isfinite(points).all(axis=1)]"
            )
        self._core = _core.Scene._from_array(array)

    @classmethod
    def from_pcd(cls, path):
        scene = cls.__new__(cls)
        scene._core = _core.Scene._from_pcd(_path("path", path))
        return scene

    @property
    def points(self):
        return self._core.points

    @property
    def dropped_non_finite(self):
        return self._core.dropped_non_finite

    @property
    def source(self):
        return self._core.source

    def __len__(self):
        return len(self._core)

    def __repr__(self):
        return f"<quadhand.Scene {len(self)} points from {self.source}>"


class PlanResult:
    """The outcome of :func:`plan`.

    ``success`` (bool: the plan passed the post-check), ``status``
    (``"success"``, ``"post_check_failed"`` or ``"solver_failed"``),
    ``message``, ``report`` (the dict quadhand-plan writes as the report
    JSON, docs/plan.md), ``columns`` (the plan file's column names) and
    ``table`` (one row per sample, as in the plan CSV) or None when no plan
    is returned, ``trajectory`` (a dict from column name to a 1-D array),
    ``cautions`` (the lines quadhand-plan prints as "caution:" about a valid
    task that may not plan as meant, e.g. a voxel leaf coarser than the
    safety distance; each is also issued as a :class:`UserWarning`).
    """

    def __init__(self, output):
        self.success = output.success
        self.status = output.status
        self.message = output.message
        self.report = json.loads(output.report_json)
        self.columns = list(output.columns)
        self.table = None if output.table is None else np.ascontiguousarray(output.table)
        if self.table is not None:
            self.table.setflags(write=False)
        self.trajectory = None if self.table is None else {
            name: self.table[:, i] for i, name in enumerate(self.columns)
        }
        self._csv = output.csv
        self.cautions = list(output.cautions)

    def csv(self):
        """The plan file's text, exactly as quadhand-plan writes it."""
        if self.table is None:
            raise Error("plan: no trajectory was returned (the plan failed the post-check; see report)")
        return self._csv

    def write_csv(self, path):
        """Writes the plan file (see :meth:`csv`) to ``path``."""
        text = self.csv()
        with open(_path("path", path), "w", encoding="ascii") as f:
            f.write(text)

    def __repr__(self):
        return f"<quadhand.PlanResult {self.status}: {self.message}>"


def _yaml_text(arg, value, base_dir=None):
    """(text, name, base directory) of a YAML file given as a path or a mapping."""
    if isinstance(value, (str, os.PathLike)):
        path = _path(arg, value)
        try:
            with open(path, "rb") as f:
                data = f.read()
        except OSError as e:
            raise Error(f"{path}: cannot read: {e.strerror}") from None
        try:
            text = data.decode("utf-8")
        except UnicodeDecodeError:
            raise Error(f"{path}: not valid YAML: not UTF-8 text") from None
        return text, path, os.path.dirname(path) or "."
    if isinstance(value, Mapping):

        def plain(item):
            if isinstance(item, np.ndarray):
                return item.tolist()
            if isinstance(item, np.generic):
                return item.item()
            if isinstance(item, os.PathLike):
                return os.fspath(item)
            raise Error(f"{arg}: a value of type {type(item).__name__} is not a number, list, mapping or string")

        # JSON is YAML: the same reader checks it. NaN and infinity come out as
        # words the reader rejects by key ("task: start.yaw: expected a number").
        return json.dumps(value, default=plain), arg, os.fspath(base_dir) if base_dir is not None else os.getcwd()
    raise Error(f"{arg}: expected a dict or a path to a YAML file, got {type(value).__name__}")


def plan(task, robot=None, scene=None, *, solver="lbfgs", representation="mrc_sdf", dt=0.01, seed=0,
         config=None, base_dir=None, verbose=False, keep_failed_plan=False):
    """Plans a whole-body trajectory, as ``quadhand-plan`` does.

    task: a task YAML path, or a dict with the same keys (docs/task_format.md).
        With ``robot`` given, the keys robot and sdf_dir may be left out (the
        Robot's are used); with ``scene`` given, the key scene. Relative paths
        in a dict resolve against ``base_dir`` (default: the working folder),
        in a file against its folder.
    robot: a :class:`Robot` (with sdf_dir), or None for the task's.
    scene: a :class:`Scene`, an N x 3 array, or None for the task's PCD.
    solver: ``lbfgs``, ``ceres``, ``ipopt``, ``nlopt``, ``nlopt:ALGORITHM``
        (docs/solvers.md). representation: ``mrc_sdf``, ``esdf`` or ``sfc``.
    dt: sampling step of the returned table and bound on the post-check's
        step, seconds. seed: seed of every random choice.
    config: the planner configuration, a YAML path or a dict with the same
        keys (docs/configuration.md); keys left out keep their defaults.
    keep_failed_plan: also return the trajectory of a plan that failed the
        post-check (for inspection only).
    Returns a :class:`PlanResult`; raises :class:`Error` for bad input.
    """
    text, name, folder = _yaml_text("task", task, base_dir)
    config_text, config_name = "", ""
    if config is not None:
        config_text, config_name, _ = _yaml_text("config", config)
        if not config_text.strip():
            config_text = "{}"
    if robot is not None and not isinstance(robot, Robot):
        raise Error(f"robot: expected a quadhand.Robot, got {type(robot).__name__}")
    if scene is not None and not isinstance(scene, Scene):
        scene = Scene(scene)
    for arg, value in (("solver", solver), ("representation", representation)):
        if not isinstance(value, str):
            raise Error(f"{arg}: expected a name, got {type(value).__name__}")
    if isinstance(dt, bool) or not isinstance(dt, (int, float, np.floating, np.integer)):
        raise Error(f"dt: expected a number of seconds, got {dt!r}")
    if isinstance(seed, bool) or not isinstance(seed, (int, np.integer)) or not 0 <= int(seed) < 2**32:
        raise Error(f"seed: expected an integer in [0, 2^32), got {seed!r}")
    output = _core._plan(text, name, folder, robot, None if scene is None else scene._core, solver, representation,
                         float(dt), int(seed), bool(verbose), bool(keep_failed_plan), config_text, config_name)
    result = PlanResult(output)
    for caution in result.cautions:
        warnings.warn(caution, UserWarning, stacklevel=2)
    return result


def generate_sdfs(urdf, out_dir, *, resolution=0.002, padding=0.08, threads=0, links=None, allow_unsigned=False):
    """Writes one signed distance field per collision link of ``urdf`` into
    ``out_dir`` (created if missing), as ``quadhand-sdfgen --urdf`` does: all
    files or none. ``links`` limits it to those link names. Returns the paths
    written. A fine grid takes a while (2 mm, the default: about half a
    minute for the reference robot on two cores)."""
    if links is None:
        links = []
    elif isinstance(links, str) or not all(isinstance(link, str) for link in links):
        raise Error("links: expected a list of link names")
    for arg, value in (("resolution", resolution), ("padding", padding)):
        if isinstance(value, bool) or not isinstance(value, (int, float, np.floating, np.integer)):
            raise Error(f"{arg}: expected a number of metres, got {value!r}")
    if isinstance(threads, bool) or not isinstance(threads, (int, np.integer)) or threads < 0:
        raise Error(f"threads: expected a non-negative integer, got {threads!r}")
    return _core._generate_sdfs(_path("urdf", urdf), _path("out_dir", out_dir), float(resolution), float(padding),
                                int(threads), list(links), bool(allow_unsigned))


def _attitude(yaw, attitude):
    if attitude is not None:
        if yaw is not None:
            raise Error("attitude: give either yaw or attitude, not both")
        q = _vector("attitude", attitude, 4)
        if abs(np.linalg.norm(q) - 1.0) > 1e-3:
            raise Error(f"attitude: expected a unit quaternion [w, x, y, z] (norm {np.linalg.norm(q):.6g})")
        return q
    yaw = float(_vector("yaw", [0.0 if yaw is None else yaw], 1)[0])
    return np.array([np.cos(yaw / 2), 0.0, 0.0, np.sin(yaw / 2)])


class ExactClearance:
    """Exact distances between a robot's link meshes and a scene's points, as
    the post-check measures them (signed: negative when a point is inside a
    link). Build it once per robot and scene, then :meth:`query` states."""

    def __init__(self, robot, scene):
        if not isinstance(robot, Robot):
            raise Error(f"robot: expected a quadhand.Robot, got {type(robot).__name__}")
        if not isinstance(scene, Scene):
            scene = Scene(scene)
        self._robot = robot
        self._core = _core._Clearance(robot, scene._core)

    def query(self, position, joints, *, yaw=None, attitude=None, reach=1.0):
        """(distance in metres, closest link name) for the base at
        ``position`` with ``yaw`` (level) or ``attitude`` ([w, x, y, z]) and
        the actuated ``joints``; (reach, "") when no point is within ``reach``."""
        reach = float(_vector("reach", [reach], 1)[0])
        if reach <= 0:
            raise Error("reach: must be positive")
        q = _attitude(yaw, attitude)
        joints = _vector("joints", joints, len(self._robot.joint_names))
        return self._core.query(_vector("position", position, 3), q, joints, reach)


def exact_clearance(robot, scene, position, joints, *, yaw=None, attitude=None, reach=1.0):
    """One-off :meth:`ExactClearance.query`; build an :class:`ExactClearance`
    to query many states of the same robot and scene."""
    return ExactClearance(robot, scene).query(position, joints, yaw=yaw, attitude=attitude, reach=reach)
