"""Sweeps and optimisation on a Ray cluster.

- :func:`sweep` runs the same plan as ``simserpent sweep`` (same ``--vary`` syntax, sampling,
  run ids, run folders and ``summary.csv``/``summary.parquet`` columns), one Ray task per run.
- :func:`cross_entropy` maximises a run metric (default ``forward_speed_m_per_s``) over
  continuous config keys (gait parameters, say) with the cross-entropy method: each iteration
  samples a population from a Gaussian, runs it as Ray tasks, and refits the Gaussian to the
  best (elite) runs.

The cluster is a local one by default (``num_cpus`` workers bound to 127.0.0.1, no dashboard,
no usage statistics), or an existing cluster by ``address="ray://..."`` or ``"auto"``. On a
multi-machine cluster every node needs this package installed and the sweep folder on a shared
file system (workers write the run folders; the driver writes the summary).
"""

from __future__ import annotations

import os
from collections.abc import Mapping, Sequence
from pathlib import Path
from typing import Any

import numpy as np

from . import ConfigLike, Overrides, _core, _progress_callback, load_config, toml_literal

#: The metric columns of a run, as in the CLI's sweep summary (`simserpent::sweep::METRICS`).
METRICS = tuple(_core.SWEEP_METRICS)


#: Set in the environment before Ray is imported: on Linux, Ray otherwise replaces
#: ``_node_ip_address="127.0.0.1"`` by the machine's reachable address and its GCS, raylet,
#: workers and driver listen on every interface (``*``), the runtime-env agent on the external
#: address. With this variable 0 every listener binds to 127.0.0.1 (checked by
#: ``tests/test_ray.py::test_local_cluster_listens_only_on_loopback``).
LOOPBACK_ENV = {"RAY_ENABLE_WINDOWS_OR_OSX_CLUSTER": "0"}


def _loopback_environment() -> None:
    """Makes a new local cluster bind to 127.0.0.1: the variable for the processes Ray starts
    (they inherit it) and, when Ray was imported already (it reads the variable once, on
    import), its constant in this process."""
    import sys

    os.environ.update(LOOPBACK_ENV)
    constants = sys.modules.get("ray._private.ray_constants")
    if constants is not None:
        constants.ENABLE_RAY_CLUSTER = False


# Before anything imports Ray through this module.
os.environ.setdefault("RAY_ENABLE_WINDOWS_OR_OSX_CLUSTER", "0")


def init_ray(address: str | None = None, num_cpus: int | None = None, **kwargs: Any) -> None:
    """Connects to Ray once per process: ``address`` (an existing cluster: ``"auto"``, a GCS
    address ``"host:port"`` or ``"ray://host:port"``) or, by default, a new local cluster of
    this process with ``num_cpus`` CPUs (default: all cores) listening only on the loopback
    interface (127.0.0.1; see :data:`LOOPBACK_ENV`)."""
    os.environ.setdefault("RAY_USAGE_STATS_ENABLED", "0")
    if address is None:
        _loopback_environment()
    import ray

    if ray.is_initialized():
        return
    if address is not None:
        ray.init(address=address, **kwargs)
    else:
        kwargs.setdefault("include_dashboard", False)
        kwargs.setdefault("_node_ip_address", "127.0.0.1")
        kwargs.setdefault("log_to_driver", False)
        # "local": always a new cluster of our own; without it, ray.init() joins whatever cluster
        # another process on this machine started last (/tmp/ray/ray_current_cluster).
        ray.init(address="local", num_cpus=num_cpus or os.cpu_count() or 1, **kwargs)


def _abs(path: str | os.PathLike[str] | None) -> str | None:
    return None if path is None else str(Path(path).resolve())


def _overrides(overrides: Overrides) -> list[str]:
    from . import _override_list

    return _override_list(overrides)


def _remote_sweep_run(sweep_args: dict[str, Any], index: int) -> list[str]:
    plan = _core.Sweep(prepare=False, **sweep_args)
    return plan.run_one(index)


def sweep(
    config: str | os.PathLike[str] | None = None,
    vary: Sequence[str] = (),
    overrides: Overrides = None,
    sample: str = "grid",
    samples: int = 10,
    seed: int = 0,
    sweep_dir: str | os.PathLike[str] | None = None,
    address: str | None = None,
    num_cpus: int | None = None,
    progress: Any = None,
) -> tuple[Any, str]:
    """Runs a sweep on Ray; returns ``(summary DataFrame, path of summary.csv)``.

    Arguments as ``simserpent sweep``: ``config`` (a config file; ``None``: the embedded
    default), ``vary`` (``["snake.n_links=5,10", "gait.sine_wave.frequency_hz=0.5:2.0:0.5"]``),
    ``overrides`` (``--set``), ``sample`` (``grid``, ``random``, ``lhs``), ``samples``,
    ``seed``, ``sweep_dir`` (default ``<general.output_dir>/sweep-<config name>``). Runs that
    completed earlier (manifest ``complete``) are read back, not redone. ``progress``: as for
    :func:`simserpent.run`, counted in runs (a bar on stderr when it is a terminal by default;
    ``progress(runs_done, runs_total)`` as runs finish).
    """
    import pandas as pd
    import ray

    init_ray(address, num_cpus)
    args: dict[str, Any] = {
        "config_path": _abs(config),
        "vary": list(vary),
        "overrides": _overrides(overrides),
        "sample": sample,
        "samples": int(samples),
        "seed": int(seed),
        "sweep_dir": _abs(sweep_dir),
    }
    plan = _core.Sweep(prepare=True, **args)
    # Workers may start in another folder: give them the absolute sweep folder.
    args["sweep_dir"] = _abs(plan.sweep_dir)
    task = ray.remote(num_cpus=1)(_remote_sweep_run)
    refs = [task.remote(args, index) for index, _id, _params in plan.runs()]
    rows = _gather(ray, refs, _progress_callback(progress, "sweep", "runs"))
    summary_csv = plan.write_summary(rows)
    return pd.read_csv(summary_csv), summary_csv


def _gather(ray: Any, refs: list[Any], report: Any) -> list[Any]:
    """``ray.get(refs)`` in order, reporting ``report(done, total)`` as tasks finish."""
    if report is not None:
        pending, total = list(refs), len(refs)
        report(0, total)
        while pending:
            _ready, pending = ray.wait(pending, num_returns=1)
            report(total - len(pending), total)
    return list(ray.get(refs))


def _evaluate(config_json: str, sets: list[str], run_folder: str) -> dict[str, Any]:
    """One candidate of the optimisation: a whole run; never raises (failures are rows)."""
    try:
        cfg = _core.load_config(json=config_json, overrides=sets)
        summary = _core.run(cfg, run_folder)
        return {"status": "complete", "error": "", **summary}
    except _core.SimSerpentError as e:
        return {"status": "failed", "error": str(e), "run_folder": run_folder}


def cross_entropy(
    params: Mapping[str, tuple[float, float]],
    config: ConfigLike = None,
    overrides: Overrides = None,
    objective: str = "forward_speed_m_per_s",
    iterations: int = 5,
    population: int = 8,
    elite_fraction: float = 0.25,
    seed: int = 0,
    out_dir: str | os.PathLike[str] = "runs/cross-entropy",
    address: str | None = None,
    num_cpus: int | None = None,
    min_std_fraction: float = 0.02,
) -> dict[str, Any]:
    """Maximises ``objective`` (a run metric) over ``params`` = ``{key: (low, high)}``.

    Starts from a Gaussian centred in each range with std a quarter of the range; each
    iteration samples ``population`` candidates (clipped to the ranges), runs them as Ray
    tasks (one run folder each under ``out_dir/iter-<k>/cand-<j>``), and refits mean and std to
    the best ``elite_fraction`` of them (std kept above ``min_std_fraction`` of the range).
    Failed runs count as worst. Writes ``out_dir/optimisation.csv`` (one row per candidate:
    iteration, candidate, the parameters, status, error, run_folder and the run metrics) and
    returns ``{"best_params", "best_value", "mean", "std", "history" (DataFrame), "csv"}``.
    """
    import pandas as pd
    import ray

    if not params:
        raise ValueError("params must name at least one config key with its (low, high) range")
    keys = list(params)
    low = np.array([float(params[k][0]) for k in keys])
    high = np.array([float(params[k][1]) for k in keys])
    if np.any(high <= low):
        raise ValueError("every range must be (low, high) with low < high")
    base = load_config(config, overrides)  # validates the base config here, with the CLI's message
    config_json = base.to_json()
    init_ray(address, num_cpus)
    task = ray.remote(num_cpus=1)(_evaluate)
    out = Path(out_dir).resolve()
    rng = np.random.default_rng(seed)
    mean = (low + high) / 2.0
    std = (high - low) / 4.0
    n_elite = max(1, int(round(elite_fraction * population)))
    rows: list[dict[str, Any]] = []
    best_value, best_params = -np.inf, None
    for it in range(iterations):
        candidates = np.clip(rng.normal(mean, std, size=(population, len(keys))), low, high)
        refs = []
        for j, x in enumerate(candidates):
            sets = [f"{k}={toml_literal(float(v))}" for k, v in zip(keys, x)]
            sets.append(f"general.run_name={toml_literal(f'cem-{it}-{j}')}")
            folder = out / f"iter-{it:02d}" / f"cand-{j:02d}"
            refs.append(task.remote(config_json, sets, str(folder)))
        results = ray.get(refs)
        scores = np.full(population, -np.inf)
        for j, (x, res) in enumerate(zip(candidates, results)):
            row = {"iteration": it, "candidate": j, **dict(zip(keys, x.tolist()))}
            row.update({"status": res["status"], "error": res["error"], "run_folder": res.get("run_folder", "")})
            row.update({m: res.get(m, np.nan) for m in METRICS})
            rows.append(row)
            value = res.get(objective)
            if res["status"] == "complete" and value is not None and np.isfinite(value):
                scores[j] = value
        order = np.argsort(-scores)
        elite = candidates[order[:n_elite]]
        if np.isfinite(scores[order[0]]) and scores[order[0]] > best_value:
            best_value = float(scores[order[0]])
            best_params = dict(zip(keys, candidates[order[0]].tolist()))
        mean = elite.mean(axis=0)
        std = np.maximum(elite.std(axis=0), min_std_fraction * (high - low))
    history = pd.DataFrame(rows)
    out.mkdir(parents=True, exist_ok=True)
    csv = out / "optimisation.csv"
    history.to_csv(csv, index=False)
    return {
        "best_params": best_params,
        "best_value": best_value,
        "mean": dict(zip(keys, mean.tolist())),
        "std": dict(zip(keys, std.tolist())),
        "history": history,
        "csv": str(csv),
    }
