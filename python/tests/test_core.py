"""Config loading, errors, the shared MuJoCo library, runs and run folders."""

import os
import subprocess
import sys
import textwrap
from pathlib import Path

import numpy as np
import pytest

import simserpent
from simserpent import ConfigError, SimSerpentError

from conftest import cli

def test_default_config_loads():
    cfg = simserpent.load_config()
    assert cfg.source == "embedded default"
    assert "[env]" in simserpent.default_config_toml()
    assert "n_links = 10" in cfg.to_toml()


def test_dict_and_overrides(small):
    cfg = simserpent.load_config({"snake": {"n_links": 7}}, overrides={"gait.sine_wave.frequency_hz": 0.5})
    import json

    d = json.loads(cfg.to_json())
    assert d["snake"]["n_links"] == 7
    assert d["gait"]["sine_wave"]["frequency_hz"] == 0.5
    cfg2 = cfg.with_overrides(["snake.n_links=3"])
    assert json.loads(cfg2.to_json())["snake"]["n_links"] == 3


def test_config_file(tmp_path):
    p = tmp_path / "c.toml"
    p.write_text("[snake]\nn_links = 4\n")
    cfg = simserpent.load_config(p, overrides=["general.duration_secs=0.1"])
    assert cfg.source == str(p)


def test_errors_are_exceptions_with_the_cli_message(tmp_path):
    p = tmp_path / "bad.toml"
    p.write_text("[snake]\nn_link = 4\n")
    with pytest.raises(ConfigError) as err:
        simserpent.load_config(p)
    msg = str(err.value)
    assert msg.startswith(f"config {p}: unknown key `snake.n_link` (did you mean `snake.n_links`?)")
    assert isinstance(err.value, SimSerpentError)
    with pytest.raises(ConfigError, match=r"`env.control_period_secs` = -1.0: must be greater than 0"):
        simserpent.load_config(overrides=["env.control_period_secs=-1"])
    with pytest.raises(ConfigError, match=r"^config <dict>: `snake.n_links` = 0: must be at least 1$"):
        simserpent.load_config({"snake": {"n_links": 0}})
    exe = cli()
    if exe is None:
        if os.environ.get("CI"):
            pytest.fail("the CLI is not built (scripts/test runs cargo test first, which builds it)")
        pytest.skip("the CLI is not built")
    out = subprocess.run([str(exe), "check", str(p)], capture_output=True, text=True)
    assert out.returncode == 2
    assert out.stderr.strip() == f"error: {msg}"


def test_env_rules_checked_when_the_env_is_built(small):
    cfg = simserpent.load_config(overrides={**small, "env.control_period_secs": 0.0015})
    with pytest.raises(ConfigError, match="whole number"):
        simserpent.World(cfg)


def test_the_extension_loads_its_own_libmujoco_beside_the_official_bindings():
    """The wheel carries its libmujoco (simserpent.libs/, a name of its own): importing the
    `mujoco` package too maps a second, separate library, and both engines work."""
    code = textwrap.dedent(
        """
        import mujoco, simserpent, os
        libs = set()
        for line in open('/proc/self/maps'):
            if 'libmujoco' in line:
                libs.add(os.path.realpath(line.split()[-1]))
        print(sorted(libs))
        own = [p for p in libs if os.sep + 'simserpent.libs' + os.sep in p]
        assert len(own) == 1 and len(libs) == 2, libs
        assert os.path.basename(own[0]).startswith('libmujoco-'), own
        site = os.path.dirname(os.path.dirname(simserpent.__file__))
        assert own[0].startswith(os.path.realpath(site)), (own, site)
        assert simserpent.mujoco_version() == '3.17.0'
        m = mujoco.MjModel.from_xml_string('<mujoco><worldbody><body><freejoint/><geom size=".1"/></body></worldbody></mujoco>')
        d = mujoco.MjData(m)
        mujoco.mj_step(m, d)
        w = simserpent.make_world(overrides={'snake.n_links': 5, 'terrain.kind': 'none'})
        w.reset(0)
        w.step([0.1, 0.1, 0.1, 0.1])
        assert d.qvel[2] < 0 and w.time > 0
        """
    )
    env = {k: v for k, v in __import__("os").environ.items() if k != "LD_LIBRARY_PATH"}
    out = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True, env=env)
    assert out.returncode == 0, out.stdout + out.stderr


def test_world_reset_step(small):
    w = simserpent.make_world(overrides=small)
    obs = w.reset(0)
    assert obs.shape == (w.observation_size,) and obs.dtype == np.float64
    assert w.observation_names[0] == "joint_01_angle_rad"
    assert w.action_size == 4
    obs2, r, term, trunc, info = w.step(np.zeros(4))
    assert not term and not trunc
    assert abs(info["time_secs"] - 0.02) < 1e-12
    with pytest.raises(ValueError, match="4 joints"):
        w.step(np.zeros(3))


def test_run_writes_a_folder_open_run_reads(tmp_path, small):
    folder = tmp_path / "r"
    summary = simserpent.run(overrides={**small, "general.duration_secs": 0.3}, run_folder=folder)
    assert summary["run_folder"] == str(folder)
    assert summary["simulated_secs"] == pytest.approx(0.3)
    run = simserpent.open_run(folder)
    assert run.status == "complete"
    assert {"links", "joints", "sensors", "contacts"} <= set(run.table_names)
    links = run.links
    assert "time_s" in links.columns and len(links) > 0
    assert links["time_s"].iloc[-1] == pytest.approx(0.3)
    assert run.summary["distance_m"] == pytest.approx(summary["distance_m"])
    with pytest.raises(AttributeError):
        run.no_such_table


def test_parquet_tables_are_folders_of_parts_read_as_one_table(tmp_path, small):
    folder = tmp_path / "pq"
    simserpent.run(
        overrides={
            **small,
            "general.duration_secs": 0.3,
            "recording.format": "both",
            "recording.every_n_steps": 1,
            "recording.parquet_rows_per_file": 100,
        },
        run_folder=folder,
    )
    parts = sorted((folder / "joints.parquet").glob("part-*.parquet"))
    assert [p.name for p in parts] == ["part-00000.parquet", "part-00001.parquet", "part-00002.parquet", "part-00003.parquet"]
    import pandas as pd

    csv = pd.read_csv(folder / "joints.csv")
    pq = pd.read_parquet(folder / "joints.parquet")
    assert list(pq.columns) == list(csv.columns)
    assert np.array_equal(pq.to_numpy(), csv.to_numpy())
    # Without the CSV, open_run reads the Parquet folder.
    (folder / "joints.csv").unlink()
    assert simserpent.open_run(folder).joints.shape == csv.shape


def test_run_errors(tmp_path, small):
    with pytest.raises(ConfigError, match=r"^config <dict>: unknown key `general.duraton_secs`"):
        simserpent.run({"general": {"duraton_secs": 1}})
    # A run stopped by the runaway-energy guard (set absurdly low) is a divergence.
    with pytest.raises(simserpent.SimulationError, match=r"^simulation diverged at t = "):
        simserpent.run(
            overrides={**small, "safety.max_kinetic_energy_j_per_kg": 1e-9, "general.duration_secs": 1.0},
            run_folder=tmp_path / "div",
        )
    assert simserpent.open_run(tmp_path / "div").status == "failed"


def elf_section_names(path):
    """The section names of a 64-bit little-endian ELF file (None for another format)."""
    import struct

    data = Path(path).read_bytes()
    if data[:4] != b"\x7fELF" or data[4] != 2 or data[5] != 1:
        return None
    shoff = struct.unpack_from("<Q", data, 0x28)[0]
    shentsize, shnum, shstrndx = struct.unpack_from("<HHH", data, 0x3A)

    def header(i):
        return struct.unpack_from("<IIQQQQIIQQ", data, shoff + i * shentsize)

    strings = header(shstrndx)[4]
    return [data[strings + n: data.index(b"\0", strings + n)].decode() for n in (header(i)[0] for i in range(shnum))]


def test_the_installed_extension_is_stripped():
    """The wheel is stripped (`[tool.maturin] strip = true`): no debug line tables or
    symbol table in the extension (89 MB unstripped, about 12 MB stripped)."""
    from simserpent import _core

    names = elf_section_names(_core.__file__)
    if names is None:
        pytest.skip("not an ELF extension")
    assert not [n for n in names if n.startswith(".debug") or n == ".symtab"], names
    assert Path(_core.__file__).stat().st_size < 40e6
