"""Ray: the sweep and the cross-entropy optimisation on a local cluster bound to 127.0.0.1."""

import os
import subprocess
from pathlib import Path

import pandas as pd
import pytest

from simserpent import ray_sweep

from conftest import cli

SETS = [
    "snake.n_links=4",
    "terrain.kind=\"none\"",
    "general.duration_secs=0.3",
    "recording.every_n_steps=50",
]


def test_ray_sweep_matches_the_cli_sweep(ray_local, tmp_path):
    vary = ["gait.sine_wave.frequency_hz=0.5,1.0", "gait.sine_wave.amplitude_deg=20,30"]
    df, csv = ray_sweep.sweep(vary=vary, overrides=SETS, sweep_dir=tmp_path / "ray")
    assert Path(csv) == (tmp_path / "ray" / "summary.csv").resolve()
    assert list(df["run_index"]) == [0, 1, 2, 3]
    assert set(df["status"]) == {"complete"}
    assert (tmp_path / "ray" / "summary.parquet").is_file()
    assert (tmp_path / "ray" / "sweep.json").is_file()
    for folder in df["run_folder"]:
        assert (tmp_path / "ray" / folder / "manifest.json").is_file()
    # Both Ray workers did something (4 runs, 2 CPUs) - checked through the wall times being set.
    assert (df["wall_secs"] > 0).all()
    exe = cli()
    if exe is None:
        if os.environ.get("CI"):
            pytest.fail("the CLI is not built (scripts/test runs cargo test first, which builds it)")
        pytest.skip("the CLI is not built")
    args = [str(exe), "sweep", "--quiet", "--sweep-dir", str(tmp_path / "cli")]
    for v in vary:
        args += ["--vary", v]
    for s in SETS:
        args += ["--set", s]
    subprocess.run(args, check=True, capture_output=True)
    cli_df = pd.read_csv(tmp_path / "cli" / "summary.csv")
    assert list(cli_df.columns) == list(df.columns)
    assert list(cli_df["run_id"]) == list(df["run_id"])
    deterministic = [c for c in df.columns if c not in ("steps_per_wall_sec", "wall_secs")]
    pd.testing.assert_frame_equal(cli_df[deterministic], df[deterministic])


def test_ray_sweep_bad_vary_is_a_sweep_error(ray_local, tmp_path):
    from simserpent import SweepError

    with pytest.raises(SweepError, match="no values"):
        ray_sweep.sweep(vary=["gait.sine_wave.frequency_hz="], sweep_dir=tmp_path)


def test_cross_entropy_improves_forward_speed(ray_local, tmp_path):
    result = ray_sweep.cross_entropy(
        {"gait.sine_wave.frequency_hz": (0.1, 1.5)},
        overrides=SETS[:2] + ["general.duration_secs=1.0", "recording.enabled=false"],
        iterations=2,
        population=4,
        seed=1,
        out_dir=tmp_path / "cem",
    )
    hist = result["history"]
    assert len(hist) == 8 and set(hist["status"]) == {"complete"}
    assert result["best_value"] == pytest.approx(hist["forward_speed_m_per_s"].max())
    assert 0.1 <= result["best_params"]["gait.sine_wave.frequency_hz"] <= 1.5
    assert Path(result["csv"]).is_file()


def test_sweep_on_an_existing_cluster_by_address(ray_local, tmp_path):
    """Another process joins the session's Ray cluster by its address and sweeps on it."""
    import sys
    import textwrap

    address = ray_local.get_runtime_context().gcs_address
    code = textwrap.dedent(
        f"""
        from simserpent import ray_sweep
        df, csv = ray_sweep.sweep(vary=["gait.sine_wave.frequency_hz=0.5,1.0"], overrides={SETS!r},
                                  sweep_dir={str(tmp_path / "addr")!r}, address={address!r})
        import ray
        assert ray.get_runtime_context().gcs_address == {address!r}
        print(",".join(df["status"]))
        """
    )
    out = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True, timeout=300)
    assert out.returncode == 0, out.stderr[-2000:]
    assert out.stdout.strip().splitlines()[-1] == "complete,complete"
