"""The figures of every scene, computed the same way for both engines.

A run is a dict of numpy arrays (see `simserpent_side.read_run` and `drake_side.simulate`):
time_s (rows), position / velocity / angular_velocity (rows x links x 3: centre of mass, world
frame), quat (rows x links x 4: body frame, w x y z) or rotation (rows x links x 3 x 3), floor_force / obstacle_force (rows x links x
3, on the link, world frame), joint_velocity (rows x joints). The first row (t = 0) is left out of
every figure: it holds the state before the first step, whose forces the two engines report
differently (SimSerpent: the first evaluation, before its floor friction; Drake: none).
"""

from __future__ import annotations

import math

import numpy as np

from mjcf_model import Model

# A link-step is airborne when the floor carries less than this share of the link's weight.
AIRBORNE_SHARE_OF_WEIGHT = 1e-3


def _rotations(run: dict) -> np.ndarray:
    """The links' rotation matrices (rows x links x 3 x 3): the run's own, or from its quaternions."""
    return run["rotation"] if "rotation" in run else _rot(run["quat"])


def _rot(quat: np.ndarray) -> np.ndarray:
    """Rotation matrices (rows x links x 3 x 3) of quaternions (rows x links x 4)."""
    w, x, y, z = (quat[..., k] for k in range(4))
    r = np.empty(quat.shape[:-1] + (3, 3))
    r[..., 0, 0] = 1 - 2 * (y * y + z * z)
    r[..., 0, 1] = 2 * (x * y - w * z)
    r[..., 0, 2] = 2 * (x * z + w * y)
    r[..., 1, 0] = 2 * (x * y + w * z)
    r[..., 1, 1] = 1 - 2 * (x * x + z * z)
    r[..., 1, 2] = 2 * (y * z - w * x)
    r[..., 2, 0] = 2 * (x * z - w * y)
    r[..., 2, 1] = 2 * (y * z + w * x)
    r[..., 2, 2] = 1 - 2 * (x * x + y * y)
    return r


def capsule_inertia(mass: float, radius: float, core_length: float) -> np.ndarray:
    """Inertia of a solid capsule about its centre, axis along x (kg m^2)."""
    r, h = radius, core_length
    v_cyl, v_caps = math.pi * r * r * h, 4.0 / 3.0 * math.pi * r**3
    mc, ms = mass * v_cyl / (v_cyl + v_caps), mass * v_caps / (v_cyl + v_caps)
    axial = mc * r * r / 2 + ms * 2 * r * r / 5
    perp = mc * (r * r / 4 + h * h / 12) + ms * (2 * r * r / 5 + h * h / 4 + 3 * h * r / 8)
    return np.diag([axial, perp, perp])


def _skip_first(run: dict) -> slice:
    return slice(1, None)


def normal_load(run: dict) -> np.ndarray:
    """Floor normal force on each link (rows x links, N)."""
    return run["floor_force"][:, :, 2]


def weights(model: Model) -> np.ndarray:
    return np.array([model.link_weight_n(i) for i in range(len(model.links))])


def airborne(run: dict, model: Model, t0: float = 0.0, t1: float = math.inf) -> float:
    """Share of link-steps in [t0, t1) with no floor contact (%)."""
    s = _skip_first(run)
    t = run["time_s"][s]
    sel = (t >= t0 - 1e-12) & (t < t1 - 1e-12)
    if not sel.any():
        return math.nan
    off = normal_load(run)[s][sel] < AIRBORNE_SHARE_OF_WEIGHT * weights(model)
    return 100.0 * off.mean()


def airborne_windows(run: dict, model: Model, width: float, t_end: float) -> list[float]:
    n = int(round(t_end / width))
    return [airborne(run, model, k * width, (k + 1) * width) for k in range(n)]


def lowest_point_heights(run: dict, model: Model) -> np.ndarray:
    """Height above the floor of each link's lowest point (rows x links, m; < 0: in the floor)."""
    R = _rotations(run)
    out = np.empty(run["position"].shape[:2])
    for i, link in enumerate(model.links):
        ends = [link.core_from_m - link.centre_m, link.core_to_m - link.centre_m]
        zs = [run["position"][:, i, 2] + (R[:, i] @ e)[:, 2] for e in ends]
        out[:, i] = np.minimum(*zs) - link.radius_m
    return out


def largest_lift_mm(run: dict, model: Model, t0: float = 0.0, t1: float = math.inf) -> float:
    s = _skip_first(run)
    t = run["time_s"][s]
    sel = (t >= t0) & (t < t1)
    return 1000.0 * max(0.0, float(lowest_point_heights(run, model)[s][sel].max()))


def peak_load_per_weight(run: dict, model: Model, t0: float = 0.0, t1: float = math.inf) -> float:
    """Largest floor normal force on any link as a multiple of that link's weight."""
    s = _skip_first(run)
    t = run["time_s"][s]
    sel = (t >= t0) & (t < t1)
    return float((normal_load(run)[s][sel] / weights(model)).max())


def total_load_range(run: dict, model: Model, t0: float = 0.0, t1: float = math.inf) -> tuple[float, float]:
    """Smallest and largest Σ N / W over the steps in [t0, t1)."""
    s = _skip_first(run)
    t = run["time_s"][s]
    sel = (t >= t0) & (t < t1)
    ratio = normal_load(run)[s][sel].sum(axis=1) / weights(model).sum()
    return float(ratio.min()), float(ratio.max())


def total_load_mean(run: dict, model: Model) -> float:
    """Σ N / W averaged over time (the floor's impulse over the weight's)."""
    s = _skip_first(run)
    return float(normal_load(run)[s].sum(axis=1).mean() / weights(model).sum())


def per_link_load(run: dict, model: Model, t0: float, t1: float) -> np.ndarray:
    """Mean floor normal force on each link over [t0, t1), as a multiple of its weight."""
    t = run["time_s"]
    sel = (t >= t0) & (t < t1)
    sel[0] = False
    return normal_load(run)[sel].mean(axis=0) / weights(model)


def per_link_swing(run: dict, model: Model, t0: float, t1: float, window_secs: float = 0.1) -> np.ndarray:
    """Largest deviation of each link's load (moving mean over window_secs) from its mean over
    [t0, t1), as a multiple of its weight."""
    t = run["time_s"]
    sel = (t >= t0) & (t < t1)
    sel[0] = False
    n = normal_load(run)[sel] / weights(model)
    dt = float(np.median(np.diff(t)))
    k = max(1, int(round(window_secs / dt)))
    kernel = np.ones(k) / k
    out = []
    for i in range(n.shape[1]):
        smooth = np.convolve(n[:, i], kernel, mode="valid")
        out.append(float(np.abs(smooth - n[:, i].mean()).max()))
    return np.array(out)


def top_link_offset_mm(run: dict) -> tuple[float, float]:
    """Horizontal distance of the last link's centre from where it started: at the end and the
    largest over the run (mm)."""
    p = run["position"][:, -1, :2]
    d = np.linalg.norm(p - p[0], axis=1)
    return 1000.0 * float(d[-1]), 1000.0 * float(d.max())


def energy(run: dict, model: Model) -> np.ndarray:
    """Mechanical energy per row (J): kinetic (links and joint armature) + gravitational + the energy
    held in the floor's normal springs (`floor_elastic_j`, where the run has it)."""
    g = float(np.linalg.norm(model.gravity_m_per_s2))
    R = _rotations(run)
    e = np.zeros(len(run["time_s"]))
    for i, link in enumerate(model.links):
        axis = link.core_to_m - link.core_from_m
        length = float(np.linalg.norm(axis))
        if length > 0 and (abs(axis[1]) > 1e-12 or abs(axis[2]) > 1e-12):
            raise ValueError(f"{link.name}: capsule not along the body's x axis")
        I_body = capsule_inertia(link.mass_kg, link.radius_m, length)
        w = run["angular_velocity"][:, i]
        v = run["velocity"][:, i]
        w_body = np.einsum("nji,nj->ni", R[:, i], w)
        e += 0.5 * link.mass_kg * (v * v).sum(axis=1)
        e += 0.5 * np.einsum("ni,ij,nj->n", w_body, I_body, w_body)
        e += link.mass_kg * g * run["position"][:, i, 2]
    for j, link in enumerate(model.links[1:]):
        e += 0.5 * link.joint_armature_kg_m2 * run["joint_velocity"][:, j] ** 2
    return e + run.get("floor_elastic_j", 0.0)


def energy_figures(run: dict, model: Model) -> tuple[float, float, float]:
    """E(0) (J), E(end) − E(0) (J) and the largest rise of E in one recorded step (J)."""
    e = energy(run, model)
    return float(e[0]), float(e[-1] - e[0]), float(max(0.0, np.diff(e).max()))


def resample(run: dict, dt_secs: float) -> dict:
    """The run at a coarser, equal sampling: one row every `dt_secs` (a whole multiple of the
    run's own step). States are taken at the new rows' times; forces are the mean over the
    rows of the interval that ends there (the impulse over the interval / its length), which is
    what an engine stepping at `dt_secs` reports for its step. Row 0 (t = 0) is kept as it is."""
    t = run["time_s"]
    step = float(np.median(np.diff(t)))
    k = int(round(dt_secs / step))
    if k < 1 or abs(k * step - dt_secs) > 1e-3 * step:
        raise ValueError(f"cannot resample a run of step {step:g} s to {dt_secs:g} s (not a whole multiple)")
    if k == 1:
        return run
    n = (len(t) - 1) // k
    rows = np.concatenate([[0], k * np.arange(1, n + 1)])
    out = {}
    for key, value in run.items():
        if not isinstance(value, np.ndarray) or value.shape[:1] != t.shape:
            out[key] = value
        elif key in FORCE_KEYS:
            blocks = value[1 : 1 + n * k].reshape((n, k) + value.shape[1:]).mean(axis=1)
            out[key] = np.concatenate([value[:1], blocks])
        else:
            out[key] = value[rows]
    return out


# The per-row quantities that are forces (resampled as means over each interval).
FORCE_KEYS = ("floor_force", "obstacle_force")


def window_mean(series: np.ndarray, time_s: np.ndarray, window_secs: float) -> np.ndarray:
    """Moving mean over `window_secs` along axis 0 (rows of equal spacing); rows x ... ."""
    dt = float(np.median(np.diff(time_s)))
    k = max(1, int(round(window_secs / dt)))
    if series.shape[0] < k:
        return series.mean(axis=0, keepdims=True)
    c = np.cumsum(np.concatenate([np.zeros((1,) + series.shape[1:]), series]), axis=0)
    return (c[k:] - c[:-k]) / k


def largest_window_load(run: dict, model: Model, window_secs: float = 0.01, t0: float = 0.0,
                        t1: float = math.inf) -> float:
    """Largest floor normal force on one link, averaged over a window of `window_secs`, over the
    link's weight, among the windows inside [t0, t1). A windowed figure hardly depends on the
    sampling: the mean force over 10 ms is the floor's impulse over 10 ms."""
    s = _skip_first(run)
    t = run["time_s"][s]
    sel = (t >= t0 - 1e-12) & (t < t1 - 1e-12)
    n = normal_load(run)[s][sel] / weights(model)
    if n.shape[0] == 0:
        return math.nan
    return float(window_mean(n, t[sel], window_secs).max())


def largest_window_obstacle_force(run: dict, window_secs: float = 0.01) -> float:
    """Largest magnitude of the obstacles' total force on the snake averaged over `window_secs` (N)."""
    s = _skip_first(run)
    total = run["obstacle_force"][s].sum(axis=1)
    return float(np.linalg.norm(window_mean(total, run["time_s"][s], window_secs), axis=1).max())


def all_links_off_steps(run: dict, model: Model, t0: float = 0.0, t1: float = math.inf) -> int:
    """Number of rows in [t0, t1) on which no link touches the floor (each below the airborne
    share of its weight)."""
    s = _skip_first(run)
    t = run["time_s"][s]
    sel = (t >= t0 - 1e-12) & (t < t1 - 1e-12)
    off = normal_load(run)[s][sel] < AIRBORNE_SHARE_OF_WEIGHT * weights(model)
    return int(off.all(axis=1).sum())


def centre_of_mass(run: dict, model: Model) -> np.ndarray:
    """The snake's centre of mass per row (rows x 3, m)."""
    m = np.array([link.mass_kg for link in model.links])
    return np.einsum("kna,n->ka", run["position"], m) / m.sum()


def largest_com_rise_mm(run: dict, model: Model) -> float:
    """How far the snake's centre of mass rises above where it started (mm)."""
    z = centre_of_mass(run, model)[:, 2]
    return 1000.0 * float(z.max() - z[0])


def roll_rate_after_hit(run: dict, delay_secs: float = 0.01) -> float:
    """The head link's angular velocity about its own axis `delay_secs` after the first row with
    an obstacle force (rad/s; NaN without one): the roll of the body, which the links that hit an
    obstacle carry up its face."""
    touching = np.nonzero(np.abs(run["obstacle_force"]).sum(axis=(1, 2)) > 0)[0]
    if len(touching) == 0:
        return math.nan
    t = run["time_s"]
    k = min(int(np.searchsorted(t, t[touching[0]] + delay_secs - 1e-9)), len(t) - 1)
    axis = _rotations(run)[k, 0][:, 0]
    return float(np.dot(run["angular_velocity"][k, 0], axis))


def com_speed_mm_per_s(run: dict, model: Model, t0: float, t1: float) -> float:
    """Mean horizontal speed of the centre of mass over [t0, t1]: its horizontal path length over
    the time (mm/s), from rows 10 ms apart (the same for every sampling)."""
    t = run["time_s"]
    c = centre_of_mass(run, model)[:, :2]
    step = float(np.median(np.diff(t)))
    k = max(1, int(round(0.01 / step)))
    sel = np.nonzero((t >= t0 - 1e-12) & (t <= t1 + 1e-12))[0][::k]
    path = np.linalg.norm(np.diff(c[sel], axis=0), axis=1).sum()
    return 1000.0 * float(path / (t[sel[-1]] - t[sel[0]]))


def com_displacement_mm(run: dict, model: Model) -> tuple[float, float]:
    """Horizontal displacement of the centre of mass from the start to the end (x, y; mm)."""
    c = centre_of_mass(run, model)
    d = 1000.0 * (c[-1, :2] - c[0, :2])
    return float(d[0]), float(d[1])


def topple(run: dict, offset_m: float) -> tuple[float, float]:
    """When and where the top (last) link topples: the first time its centre is `offset_m`
    horizontally from where it started (s; nan if never), and the direction of that offset
    (degrees from +x, counter-clockwise; nan if never)."""
    p = run["position"][:, -1, :2]
    d = p - p[0]
    dist = np.linalg.norm(d, axis=1)
    above = np.nonzero(dist >= offset_m)[0]
    if len(above) == 0:
        return math.nan, math.nan
    k = int(above[0])
    return float(run["time_s"][k]), math.degrees(math.atan2(d[k, 1], d[k, 0]))


def breakaway_ratio(run: dict, model: Model, ramp_secs_per_mu_n: float, speed_m_per_s: float = 1e-3) -> float:
    """Break-away force over μN under a force F(t) = μN · t / T on link 0 (T = ramp_secs_per_mu_n).

    Once the link slides, m dv/dt = F(t) − μN = μN (t − t_b)/T, so v = μN (t − t_b)² / (2 m T).
    At the first step the link's speed exceeds `speed_m_per_s`, t_b = t − sqrt(2 m T v / (μN)),
    and the break-away force is μN t_b / T.
    """
    m = model.links[0].mass_kg
    mu_n = model.floor_friction * model.link_weight_n(0)
    speed = np.linalg.norm(run["velocity"][:, 0, :2], axis=1)
    above = np.nonzero(speed > speed_m_per_s)[0]
    if len(above) == 0:
        return math.nan
    k = int(above[0])
    t = run["time_s"][k]
    t_b = t - math.sqrt(2 * m * ramp_secs_per_mu_n * speed[k] / mu_n)
    return t_b / ramp_secs_per_mu_n


# How far apart (m, sideways) the starts of a chaotic scene's ensemble are.
ENSEMBLE_OFFSET_M = 1e-9


def perturbed(sets: dict, k: int) -> dict:
    """A scene's `--set` keys for start k of its ensemble: the head k · ENSEMBLE_OFFSET_M aside (+y)."""
    if k == 0:
        return sets
    x, y, z = sets.get("snake.head_position_m", (0.0, 0.0, 0.0))
    return {**sets, "snake.head_position_m": [x, y + k * ENSEMBLE_OFFSET_M, z]}


def ensemble_mean(runs: list[list[tuple[str, object]]]) -> list[tuple[str, object]]:
    """The figures of a chaotic scene's starts, one list per start (the same labels in the same
    order): each number their mean, each per-link list or pair the mean of each element; and for
    each number the smallest … largest over the starts, labelled "LABEL, smallest … largest of N
    starts"."""
    n = len(runs)
    out, spread = [], []
    for k, (label, first) in enumerate(runs[0]):
        values = [figs[k][1] for figs in runs]
        if any(figs[k][0] != label for figs in runs):
            raise ValueError(f"the starts' figures differ at {label!r}")
        if isinstance(first, (list, tuple)):
            mean = [float(np.mean([v[i] for v in values])) for i in range(len(first))]
            out.append((label, tuple(mean) if isinstance(first, tuple) else mean))
        elif isinstance(first, (int, float)) and not isinstance(first, bool):
            out.append((label, float(np.mean(values))))
            spread.append((f"{label}, smallest … largest of {n} starts", (float(min(values)), float(max(values)))))
        else:
            out.append((label, first))
    return out + spread
