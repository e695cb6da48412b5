"""SimSerpent: a snake-robot simulator on MuJoCo 3.17, from Python.

The heavy lifting is the Rust library (``simserpent._core``, built with PyO3); this package adds
the Python conveniences:

- :func:`load_config` -- a config from a file (``.toml`` or the original tool's ``.json``), a
  dict, or the embedded default, with overrides like the CLI's ``--set``;
- :class:`World` -- the snake world stepped by actions (``reset(seed)``, ``step(action)``;
  observations as numpy arrays);
- :func:`run` -- a whole configured run, as ``simserpent run`` does, returning its summary
  (optionally with a Python controller instead of the configured gait);
- :func:`estimate` -- the contact estimator on a recorded run folder (``simserpent estimate``);
- :class:`Gait` -- the config's gait as a function of time (a base policy for RL);
- :func:`open_run` -- a run folder's tables as pandas DataFrames;
- :func:`plot` and :func:`render` -- a run folder's plots, pictures and video, the files
  ``simserpent plot`` and ``simserpent render`` make (the same code);
- :mod:`simserpent.envs` -- the Gymnasium environment ``SimSerpent-v0`` (registered on import)
  and a vector environment stepped in Rust on all cores;
- :mod:`simserpent.ray_sweep` -- sweeps and cross-entropy optimisation on a Ray cluster.

Errors are :class:`SimSerpentError` subclasses (:class:`ConfigError`, :class:`ModelError`,
:class:`SimulationError`, :class:`RecordError`, :class:`SweepError`, :class:`EstimateError`,
:class:`PlotError`, :class:`RenderError`) carrying the CLI's message.

The package carries its own MuJoCo 3.17 library (``mujoco_version()``); the ``mujoco`` Python
package is not needed, and any release of it can be installed beside (it is used only to draw
an environment, ``render_mode="rgb_array"``).
"""

from __future__ import annotations

import json
import math
import os
from collections.abc import Iterable, Mapping
from pathlib import Path
from typing import Any, Union

if os.name == "nt":
    # Windows finds DLLs beside the program, not through an rpath: the wheel carries mujoco.dll
    # beside the extension.
    os.add_dll_directory(os.path.dirname(os.path.abspath(__file__)))  # type: ignore[attr-defined,unused-ignore]

from . import _core  # noqa: E402
from ._core import (  # noqa: E402
    Config,
    ConfigError,
    EstimateError,
    ModelError,
    PlotError,
    RecordError,
    RenderError,
    SimSerpentError,
    SimulationError,
    SweepError,
    default_config_toml,
    mujoco_version,
)

__version__ = _core.__version__

#: The snake world stepped by actions: ``World(config)``, ``reset(seed) -> obs``,
#: ``step(action) -> (obs, reward, terminated, truncated, info)`` (``action``: a float64 or
#: float32 array or a list), plus its sizes, bounds, observation names, ``mjcf`` and
#: ``centre_of_mass``; the true state ``time``, ``qpos``, ``qvel``, ``act``, ``ctrl``,
#: ``integration_state()`` (MuJoCo's ``mjSTATE_INTEGRATION``, for ``mujoco.mj_setState``); and
#: ``get_state() -> WorldState`` / ``set_state(state)`` for branching rollouts (bit for bit;
#: a ``WorldState`` pickles for your own processes -- never unpickle one from others, unpickling
#: runs code -- and ``to_bytes()`` / ``WorldState.from_bytes(data)`` carry it across machines as
#: checked plain data);
#: ``contact_estimates()`` -- with ``[estimation] enabled`` the per-link contact estimates of the
#: latest step as numpy arrays (``obstacle_force_n`` (links x 3, N), ``contact`` (bool),
#: ``contact_point_along_m`` (NaN when unknown), ``contact_point_m``, ``external_force_n``,
#: ``floor_force_n``, ``self_contact_force_n`` (the other links' push), ``self_contact``, ``active``).
#: (The core of :class:`envs.SimSerpentEnv`.)
World = _core.Env
WorldState = _core.WorldState

#: The overrides ``[env] preset = "fast"`` applies (``--set`` syntax).
ENV_FAST_PRESET: list[str] = list(_core.ENV_FAST_PRESET)

#: The joints' sign convention (checked by tests/test_envs.py::test_joint_sign_convention).
JOINT_SIGN_CONVENTION = (
    "Joint i connects link i-1 (towards the head) and link i; its angle is the rotation of link i "
    "relative to link i-1 about the joint's +z axis (yaw joints; right-hand rule). Seen from above "
    "with the head ahead, a positive angle swings the links behind the joint to the right, i.e. the "
    "head turns left relative to the tail. A positive gait offset (gait.*.offset_deg) bends the body "
    "that way on average and the snake turns right (clockwise seen from above; 10 links, bare floor, "
    "+15 deg: the head's yaw fell by 4.7 rad in 8 s, -15 deg: rose by 6.0 rad)."
)



def head_yaw(obs_or_quat: Any) -> float:
    """The heading of the head (rad, in (-pi, pi]): the direction of the head link's +x axis (it
    points forward, towards the snout) in the floor plane, measured from world +x,
    **counter-clockwise seen from above** (right-hand rule about +z). So a snake turning left
    has a rising yaw and one turning right a falling yaw (``JOINT_SIGN_CONVENTION``: a positive
    joint offset turns it right).

    ``obs_or_quat``: a controller's observation dict (its ``head_yaw_rad``, else its
    ``head_quat``) or a quaternion ``(w, x, y, z)`` such as ``obs["head_quat"]``. Every link's
    yaw: :func:`link_yaws`."""
    if isinstance(obs_or_quat, Mapping):
        if "head_yaw_rad" in obs_or_quat:
            return float(obs_or_quat["head_yaw_rad"])
        if "head_quat" not in obs_or_quat:
            raise KeyError(f"head_yaw: the observation has no head_quat; it has {sorted(obs_or_quat)}")
        obs_or_quat = obs_or_quat["head_quat"]
    try:
        w, x, y, z = (float(v) for v in obs_or_quat)
    except (TypeError, ValueError):
        raise TypeError(
            f"head_yaw: expected an observation dict or a quaternion (w, x, y, z), got {obs_or_quat!r}"
        ) from None
    return _core.yaw_rad([w, x, y, z])


def link_yaws(obs: Mapping[str, Any], joint_axes: str = "yaw") -> Any:
    """Every link's heading (rad, numpy array, head first), counter-clockwise seen from above as
    :func:`head_yaw`: the direction of each link's +x axis in the floor plane, from the head's
    orientation (``obs["head_quat"]``) turned by the joint angles along the chain (joint i turns
    link i relative to link i-1 about its own axis). Exact while the links tilt or roll: it
    equals ``links.csv``'s ``link_NN_yaw_rad`` of the same instant (python/tests/test_rl.py).
    Not wrapped to (-pi, pi].

    ``joint_axes``: the snake's ``snake.joint_axes``, ``"yaw"`` (every joint turns about the
    link's +z axis) or ``"alternating"`` (joints 1, 3, 5, … yaw, 2, 4, … pitch about +y). The
    sum ``head_yaw(obs) + sum(obs["joint_angle_rad"][:i])`` is this heading only while the head
    lies flat: a head tilted by 0.38 rad (a 6-link snake bending at once) puts the sum 0.07 rad
    off on the tail."""
    import numpy as np

    if joint_axes not in ("yaw", "alternating"):
        raise ValueError(f'link_yaws: joint_axes must be "yaw" or "alternating", got {joint_axes!r}')
    angles = np.asarray(obs["joint_angle_rad"], dtype=np.float64)
    try:
        w, x, y, z = (float(v) for v in obs["head_quat"])
    except KeyError:
        raise KeyError(f"link_yaws: the observation has no head_quat; it has {sorted(obs)}") from None
    n = math.sqrt(w * w + x * x + y * y + z * z)
    w, x, y, z = w / n, x / n, y / n, z / n
    rot = np.array(
        [
            [1 - 2 * (y * y + z * z), 2 * (x * y - w * z), 2 * (x * z + w * y)],
            [2 * (x * y + w * z), 1 - 2 * (x * x + z * z), 2 * (y * z - w * x)],
            [2 * (x * z - w * y), 2 * (y * z + w * x), 1 - 2 * (x * x + y * y)],
        ]
    )
    yaws = np.empty(len(angles) + 1)
    yaws[0] = math.atan2(rot[1, 0], rot[0, 0])
    for j, q in enumerate(angles):
        c, s = math.cos(q), math.sin(q)
        if joint_axes == "alternating" and j % 2 == 1:
            turn = np.array([[c, 0.0, s], [0.0, 1.0, 0.0], [-s, 0.0, c]])  # pitch: about +y
        else:
            turn = np.array([[c, -s, 0.0], [s, c, 0.0], [0.0, 0.0, 1.0]])  # yaw: about +z
        rot = rot @ turn
        yaws[j + 1] = math.atan2(rot[1, 0], rot[0, 0])
    # Continuous along the chain (as the joint angles are), from the head's yaw in (-pi, pi].
    return np.unwrap(yaws)


ConfigLike = Union[str, "os.PathLike[str]", Mapping[str, Any], Config, None]
Overrides = Union[Iterable[str], Mapping[str, Any], None]

__all__ = [
    "Config",
    "ConfigError",
    "EstimateError",
    "ModelError",
    "PlotError",
    "RecordError",
    "RenderError",
    "Run",
    "SimSerpentError",
    "SimulationError",
    "SweepError",
    "World",
    "WorldState",
    "Gait",
    "ENV_FAST_PRESET",
    "JOINT_SIGN_CONVENTION",
    "default_config_toml",
    "estimate",
    "head_yaw",
    "link_yaws",
    "load_config",
    "make_world",
    "mujoco_version",
    "oal_bench",
    "open_run",
    "ProgressBar",
    "plot",
    "render",
    "run",
    "toml_literal",
]


def toml_literal(value: Any) -> str:
    """A Python value as a TOML literal, for ``key=value`` overrides."""
    if isinstance(value, bool):
        return "true" if value else "false"
    if isinstance(value, int):
        return str(value)
    if isinstance(value, float):
        if math.isnan(value):
            return "nan"
        if math.isinf(value):
            return "inf" if value > 0 else "-inf"
        return repr(value)
    if isinstance(value, str):
        return json.dumps(value)
    if isinstance(value, (list, tuple)):
        return "[" + ", ".join(toml_literal(v) for v in value) + "]"
    if hasattr(value, "item"):  # numpy scalars
        return toml_literal(value.item())
    if hasattr(value, "tolist"):  # numpy arrays
        return toml_literal(value.tolist())
    raise TypeError(f"cannot write {value!r} as a TOML value")


def _override_list(overrides: Overrides) -> list[str]:
    if overrides is None:
        return []
    if isinstance(overrides, Mapping):
        return [f"{k}={toml_literal(v)}" for k, v in overrides.items()]
    if isinstance(overrides, str):
        return [overrides]
    if not isinstance(overrides, Iterable):
        raise TypeError(
            "overrides must be a dict {'snake.n_links': 15}, a list of 'key.path=value' strings or None, "
            f"got {type(overrides).__name__} {overrides!r}"
        )
    return [str(o) for o in overrides]


def _fspath(function: str, name: str, value: Any) -> str:
    """A path argument as a string, or a TypeError naming the function, argument and value."""
    if not isinstance(value, (str, os.PathLike)):
        raise TypeError(f"{function}: {name} must be a path (str or os.PathLike), got {type(value).__name__} {value!r}")
    return os.fspath(value)


def _jsonable(value: Any) -> Any:
    if isinstance(value, Mapping):
        return {str(k): _jsonable(v) for k, v in value.items()}
    if isinstance(value, (list, tuple)):
        return [_jsonable(v) for v in value]
    if hasattr(value, "item") and not isinstance(value, (str, bytes)):
        return value.item()
    if hasattr(value, "tolist"):
        return value.tolist()
    return value


class ProgressBar:
    """A text progress bar on ``sys.stderr`` (``progress=True`` of :func:`run`,
    :func:`oal_bench` and :func:`simserpent.ray_sweep.sweep`): ``bar(done, total)`` redraws
    ``label [#####.....]  45% 450/1000 steps, 3 s, ETA 4 s`` on one line (at most 10 times a
    second) and ends the line when ``done == total``."""

    def __init__(self, label: str, unit: str, stream: Any = None) -> None:
        import sys
        import time

        self.label, self.unit = label, unit
        self.stream = stream if stream is not None else sys.stderr
        self._clock = time.monotonic
        self._started = self._clock()
        self._drawn = -1.0
        self._ended = False

    def __call__(self, done: int, total: int) -> None:
        now = self._clock()
        final = total > 0 and done >= total
        if self._ended or (not final and now - self._drawn < 0.1):
            return
        self._drawn = now
        fraction = min(1.0, done / total) if total > 0 else 0.0
        width = 30
        filled = int(round(fraction * width))
        elapsed = now - self._started
        eta = elapsed * (1.0 - fraction) / fraction if 0.0 < fraction < 1.0 else 0.0
        line = (
            f"\r{self.label} [{'#' * filled}{'.' * (width - filled)}] {100 * fraction:3.0f}% "
            f"{done}/{total} {self.unit}, {elapsed:.0f} s" + (f", ETA {eta:.0f} s" if not final else "")
        )
        self.stream.write(line + ("\n" if final else ""))
        self.stream.flush()
        self._ended = final


def _progress_callback(progress: Any, label: str, unit: str) -> Any:
    """The callable ``(done, total)`` that reports progress, or None (quiet).

    ``progress``: ``None`` (the default) shows a :class:`ProgressBar` on stderr when stderr is
    a terminal and stays quiet otherwise (pipes, log files, CI, notebooks); ``True`` always
    shows it; ``False`` is quiet; a callable ``progress(done, total)`` is called instead (e.g.
    to drive ``tqdm`` or a notebook widget)."""
    import sys

    if progress is None:
        isatty = getattr(sys.stderr, "isatty", None)
        return ProgressBar(label, unit) if callable(isatty) and isatty() else None
    if progress is True:
        return ProgressBar(label, unit)
    if progress is False:
        return None
    if callable(progress):
        return progress
    raise TypeError(
        "progress must be None (a bar on stderr when it is a terminal), True, False or a callable "
        f"progress(done, total), got {type(progress).__name__} {progress!r}"
    )


def load_config(source: ConfigLike = None, overrides: Overrides = None) -> Config:
    """Loads and validates a config.

    ``source``: a path to a ``.toml`` file (or the original tool's ``config.json``), a dict
    shaped like the TOML file (``{"snake": {"n_links": 5}}``), a :class:`Config`, or ``None``
    for the embedded default. ``overrides``: ``["snake.n_links=15", ...]`` (as the CLI's
    ``--set``) or a dict ``{"snake.n_links": 15}``.

    Raises :class:`ConfigError` with the CLI's message (key, value, what is allowed).
    """
    sets = _override_list(overrides)
    if isinstance(source, Config):
        return source.with_overrides(sets) if sets else source
    if source is None:
        return _core.load_config(overrides=sets)
    if isinstance(source, Mapping):
        return _core.load_config(json=json.dumps(_jsonable(source)), overrides=sets)
    if not isinstance(source, (str, os.PathLike)):
        raise TypeError(
            "load_config: source must be a path to a .toml or .json file, a dict, a simserpent.Config or None, "
            f"got {type(source).__name__} {source!r}"
        )
    return _core.load_config(path=os.fspath(source), overrides=sets)


def make_world(config: ConfigLike = None, overrides: Overrides = None) -> World:
    """Builds the world of a config for stepping with actions (see :data:`World`)."""
    return World(load_config(config, overrides))


def run(
    config: ConfigLike = None,
    overrides: Overrides = None,
    run_folder: Union[str, "os.PathLike[str]", None] = None,
    controller: Any = None,
    progress: Any = None,
) -> dict[str, Any]:
    """Runs a whole configured simulation, as ``simserpent run`` does (the GIL is released
    while it runs). Returns the summary dict (``run_folder``, ``distance_m``,
    ``forward_speed_m_per_s``, ``peak_contact_force_10ms_n``, ``actuator_energy_j``, ...).

    ``progress``: ``None`` (default) draws a bar of the physics steps on stderr when stderr is
    a terminal and nothing otherwise (scripts piped to a file, CI, notebooks); ``True`` always,
    ``False`` never; or a callable ``progress(steps_done, steps_total)``, called every 1024
    steps and at the end (an exception in it is printed through ``sys.unraisablehook`` and does
    not stop the run).

    ``run_folder``: record into exactly this folder instead of a new
    ``<general.output_dir>/<run_name>-<UTC time>/``.

    ``controller``: a Python callable replacing the configured gait, recorded into the same run
    folder and tables as the built-in controller. It is called at every physics step with the
    measured observation, a dict (``time_secs``, ``joint_angle_rad``,
    ``joint_velocity_rad_per_s``, ``actuator_torque_nm``, ``head_position_m``, ``head_quat``,
    ``head_yaw_rad`` (the head's heading, counter-clockwise from +x seen from above:
    :func:`head_yaw`), ``head_velocity_m_per_s``; numpy arrays; with ``[estimation] enabled`` also ``contacts``,
    the contact estimates as in :meth:`World.contact_estimates`), and returns one command per joint for the
    actuators of ``control.method`` (e.g. target angles in rad for ``"position"``), or a dict
    of blocks (``{"position_rad": ..., "torque_nm": ...}``). An exception in it stops the run
    (the run folder is marked failed) and is raised as the cause of a :class:`SimSerpentError`.
    """
    cfg = load_config(config, overrides)
    if controller is not None and not callable(controller):
        raise TypeError(f"controller must be callable (obs dict -> command), got {type(controller).__name__}")
    folder = _fspath("run", "run_folder", run_folder) if run_folder is not None else None
    return _core.run(cfg, folder, controller, _progress_callback(progress, "run", "steps"))


def estimate(run_folder: Union[str, "os.PathLike[str]"], overrides: Overrides = None) -> dict[str, Any]:
    """Runs the contact estimator on a recorded run, as ``simserpent estimate RUN_FOLDER``
    does (same code, the GIL released): reads the run's ``config.toml`` (its ``[estimation]``
    settings, with ``overrides`` such as ``{"estimation.orientation": "true"}``),
    ``sensors.csv`` and ``links.csv`` (the run must be recorded as CSV with
    ``recording.imu_sensors`` and the link columns; best with ``recording.every_n_steps = 1``),
    and writes ``RUN_FOLDER/estimation/`` (``estimates.csv``, ``scores.csv``, ``scores.md``,
    plots). Returns a dict: ``folder``, ``rows``, the paths ``estimates_csv``,
    ``scores_csv``, ``scores_md``, and the scores ``total`` (all links) and ``per_link`` (a
    list), each a dict with ``hits``, ``misses``, ``false_alarms``, ``correct_rejections``,
    ``detection_rate``, ``false_alarm_rate``, ``relative_force_rmse`` (obstacle-force RMSE
    over its RMS), ``truth_rms_n``, ``point_within_rate``, ``mean_point_error_m``, ... (NaN
    where undefined, e.g. no contact at all).

    Raises :class:`EstimateError` naming the missing file or column (and the recording switch
    that writes it), or :class:`ConfigError` for a bad override.
    """
    return _core.estimate(_fspath("estimate", "run_folder", run_folder), _override_list(overrides))


def oal_bench(
    controller: Any = None,
    name: str = "mine",
    out: Union[str, "os.PathLike[str]"] = "runs",
    quick: bool = True,
    estimation: bool = True,
    tuning_fields: Union[int, None] = None,
    held_out_fields: Union[int, None] = None,
    duration_secs: Union[float, None] = None,
    floors: Union[Iterable[str], None] = None,
    families: Union[Iterable[str], None] = None,
    laws: bool = True,
    true_contacts: bool = True,
    passive_kp_nm_per_rad: Union[Iterable[float], None] = None,
    threads: int = 0,
    overrides: Overrides = None,
    law_servo_kp_nm_per_rad: Union[float, None] = None,
    progress: Any = None,
) -> dict[str, Any]:
    """The obstacle-aided locomotion benchmark (``simserpent experiment oal-bench``) with your
    controller plugged in as condition ``name`` beside feedback off (``open_loop``), passive
    compliance (the open-loop gait on soft servos, the gain chosen on the tuning fields) and the
    built-in contact laws (``laws``; with ``true_contacts`` also fed the true contacts), on the
    same paired fields.

    ``controller(config)`` is called once per run with the run's :class:`Config` (the benchmark's
    base gait in ``gait.sine_wave``, its servos in ``control``, ``estimation.enabled =
    estimation``) and returns the step callable, as for :func:`run` (observation dict -> one
    command per joint; ``obs["contacts"]`` holds the contact estimates when ``estimation``).

    ``quick`` starts from the CI size (1 tuning and 2 held-out fields per family, 6-s runs),
    otherwise from the full one (10 and 30, 60 s; every held-out run with its bare-floor twin,
    the passive gains with their speed-matched open loops, each law's gains tuned on the tuning
    fields); ``tuning_fields``, ``held_out_fields``, ``duration_secs``, ``floors``
    (``"isotropic"``, ``"anisotropic"``), ``families`` (``"lattice"``, ``"random"``, ``"row"``)
    and ``passive_kp_nm_per_rad`` change it. ``overrides``
    (``--set`` syntax) go onto the default config first (e.g. a contact law's gains).
    ``law_servo_kp_nm_per_rad`` puts the built-in laws on soft servos of that kp (kv = kp/100)
    instead of the stiff ones (with a passive gain, their feedback-off run is that baseline's).
    ``threads``: 0 = all cores. ``progress``: as for :func:`run`, counted in runs (a bar on
    stderr when it is a terminal by default; ``progress(runs_done, runs_total)`` after every run).

    Writes ``<out>/oal-bench-<UTC time>/`` (``report.md``, ``oal_runs.csv``, ``oal_summary.csv``,
    ``oal_paired.csv``, ``oal_heading.csv``, ``oal_bare.csv``, ``plots/``); returns
    ``{"folder": ..., "report": <the report as Markdown>}``. An exception in your controller stops the benchmark and is raised as the cause
    of a :class:`SimSerpentError`.
    """
    if controller is not None and not callable(controller):
        raise TypeError(f"controller must be callable (config -> step callable), got {type(controller).__name__}")
    return _core.oal_bench(
        controller,
        name,
        os.fspath(out),
        quick,
        estimation,
        tuning_fields,
        held_out_fields,
        duration_secs,
        None if floors is None else list(floors),
        None if families is None else list(families),
        laws,
        true_contacts,
        None if passive_kp_nm_per_rad is None else [float(k) for k in passive_kp_nm_per_rad],
        threads,
        _override_list(overrides),
        None if law_servo_kp_nm_per_rad is None else float(law_servo_kp_nm_per_rad),
        _progress_callback(progress, "oal-bench", "runs"),
    )


class Gait:
    """The config's gait (``[gait]``) as a function of time, e.g. a base policy for RL:
    ``Gait(config).targets(t_secs) -> (angles_rad, velocities_rad_per_s)`` are the joint
    targets the built-in controller follows; ``action(t_secs)`` the same target angles as an
    action of the environment of this config (normalised to [-1, 1] by
    ``snake.joint_range_deg`` when ``env.normalize_action``, clipped)."""

    def __init__(self, config: ConfigLike = None, overrides: Overrides = None) -> None:
        self.config = load_config(config, overrides)
        self._core = _core.Gait(self.config)
        cfg = json.loads(self.config.to_json())
        self._range_rad = math.radians(cfg["snake"]["joint_range_deg"])
        self._normalised = bool(cfg["env"]["normalize_action"])
        self.n_joints: int = self._core.n_joints

    def targets(self, t_secs: float) -> tuple[Any, Any]:
        try:
            t = float(t_secs)
        except (TypeError, ValueError):
            raise TypeError(f"Gait.targets: t_secs must be a number of seconds, got {type(t_secs).__name__} {t_secs!r}") from None
        return self._core.targets(t)

    def __call__(self, t_secs: float) -> Any:
        return self.targets(t_secs)[0]

    def action(self, t_secs: float) -> Any:
        import numpy as np

        angles = np.clip(self.targets(t_secs)[0], -self._range_rad, self._range_rad)
        if self._normalised:
            return (angles / self._range_rad).astype(np.float32)
        return angles


class Run:
    """A run folder: ``manifest`` (dict), ``config_toml`` (text), ``model_xml`` (text) and the
    tables as pandas DataFrames, by name (``run.links``, ``run["joints"]``, ``run.tables``).

    Tables are read when first asked for: ``<name>.csv``, or ``<name>.parquet`` (a folder of
    part files, read as one table) when there is no CSV (Parquet needs pyarrow).
    """

    def __init__(self, path: Union[str, "os.PathLike[str]"]) -> None:
        self.path = Path(_fspath("open_run", "run_dir", path))
        manifest = self.path / "manifest.json"
        if not manifest.is_file():
            raise RecordError(f"{self.path}: not a run folder (no manifest.json)")
        self.manifest: dict[str, Any] = json.loads(manifest.read_text())
        self._cache: dict[str, Any] = {}

    @property
    def status(self) -> str:
        return str(self.manifest.get("status", ""))

    @property
    def summary(self) -> dict[str, Any] | None:
        return self.manifest.get("summary")

    @property
    def config_toml(self) -> str:
        return (self.path / "config.toml").read_text()

    @property
    def model_xml(self) -> str:
        return (self.path / "model.xml").read_text()

    @property
    def table_names(self) -> list[str]:
        names = {p.stem for p in self.path.glob("*.csv")} | {p.stem for p in self.path.glob("*.parquet")}
        return sorted(names)

    @property
    def tables(self) -> dict[str, Any]:
        return {name: self[name] for name in self.table_names}

    def __getitem__(self, name: str) -> Any:
        if name not in self._cache:
            import pandas as pd

            csv, parquet = self.path / f"{name}.csv", self.path / f"{name}.parquet"
            if csv.is_file():
                self._cache[name] = pd.read_csv(csv)
            elif parquet.exists():
                self._cache[name] = pd.read_parquet(parquet)
            else:
                raise KeyError(f"{self.path} has no table {name!r}; it has {self.table_names}")
        return self._cache[name]

    def __getattr__(self, name: str) -> Any:
        if name.startswith("_"):
            raise AttributeError(name)
        try:
            return self[name]
        except KeyError as e:
            raise AttributeError(str(e)) from None

    def __repr__(self) -> str:
        return f"simserpent.Run({str(self.path)!r}, status={self.status!r}, tables={self.table_names})"


def open_run(run_dir: Union[str, "os.PathLike[str]"]) -> Run:
    """Opens a run folder; its tables are pandas DataFrames (``open_run(p).links``)."""
    return Run(run_dir)


def plot(run_dir: Union[str, "os.PathLike[str]"]) -> list[Path]:
    """Plots a run folder as ``simserpent plot RUN_FOLDER`` does (same code, the GIL released):
    the standard panels as PNG and SVG into ``RUN_DIR/plots/``. Returns the files written. A
    panel whose columns were not recorded is left out with a :class:`UserWarning` saying why.

    Raises :class:`PlotError` naming the missing file or table (plots are made from the CSV
    tables: ``recording.enabled = true`` with a CSV format)."""
    import warnings

    files, skipped = _core.plot_run_folder(_fspath("plot", "run_dir", run_dir))
    for panel, reason in skipped:
        warnings.warn(f"{os.fspath(run_dir)}: plot {panel} left out: {reason}", UserWarning, stacklevel=2)
    return [Path(f) for f in files]


def render(
    run_dir: Union[str, "os.PathLike[str]"],
    video: bool = True,
    images: bool = False,
    overrides: Overrides = None,
) -> list[Path]:
    """Replays a run folder's ``state.csv`` into pictures, as ``simserpent render RUN_FOLDER``
    does (same code, offscreen through EGL, the GIL released): a video (``video``:
    ``RUN_DIR/video_<camera>.mp4`` or ``.gif`` by ``video.format``, at ``video.frames_per_sec``)
    and/or the images at ``render.image_times_secs`` (``images``:
    ``RUN_DIR/images/<camera>_<t>s.png``). ``overrides`` change the run's config for the
    pictures (``{"render.camera": "top", "render.image_times_secs": [0.5, 2.0]}``). Returns the
    files written.

    Raises :class:`RenderError` (no ``state.csv``, no EGL, encoder failed) or
    :class:`ConfigError` (a bad override; ``images=True`` with no image times)."""
    folder = _fspath("render", "run_dir", run_dir)
    return [Path(f) for f in _core.render_run_folder(folder, bool(video), bool(images), _override_list(overrides))]


# Registers SimSerpent-v0 with Gymnasium (when gymnasium is installed).
try:
    from . import envs as envs  # noqa: E402
except ImportError:  # pragma: no cover - gymnasium is a dependency, but keep the core usable
    envs = None  # type: ignore[assignment]
