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
    seen = []
    df, csv = ray_sweep.sweep(vary=vary, overrides=SETS, sweep_dir=tmp_path / "ray",
                              progress=lambda done, total: seen.append((done, total)))
    # Progress in runs: 0 of 4 when the runs are handed out, then once as each finishes.
    assert seen == [(0, 4), (1, 4), (2, 4), (3, 4), (4, 4)], seen
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
    """Another process joins the test run's Ray cluster by its address and sweeps on it."""
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


def _listening_sockets() -> dict[int, str]:
    """inode -> "address:port" of every TCP socket in LISTEN state (IPv4 and IPv6)."""
    import socket
    import struct

    found = {}
    for name, family in [("/proc/net/tcp", socket.AF_INET), ("/proc/net/tcp6", socket.AF_INET6)]:
        try:
            lines = Path(name).read_text().splitlines()[1:]
        except OSError:
            continue
        for line in lines:
            fields = line.split()
            local, state, inode = fields[1], fields[3], int(fields[9])
            if state != "0A":  # TCP_LISTEN
                continue
            addr_hex, port_hex = local.split(":")
            raw = bytes.fromhex(addr_hex)
            # /proc writes the address as 32-bit words in host byte order.
            raw = b"".join(struct.pack("@I", struct.unpack(">I", raw[i : i + 4])[0]) for i in range(0, len(raw), 4))
            found[inode] = f"{socket.inet_ntop(family, raw)}:{int(port_hex, 16)}"
    return found


def _process_tree(root: int) -> set[int]:
    parents = {}
    for d in Path("/proc").iterdir():
        if d.name.isdigit():
            try:
                stat = (d / "stat").read_text()
            except OSError:
                continue
            parents[int(d.name)] = int(stat.rsplit(")", 1)[1].split()[1])
    tree, grew = {root}, True
    while grew:
        grew = False
        for pid, ppid in parents.items():
            if ppid in tree and pid not in tree:
                tree.add(pid)
                grew = True
    return tree


def _socket_inodes(pid: int) -> set[int]:
    inodes = set()
    try:
        for fd in Path(f"/proc/{pid}/fd").iterdir():
            try:
                target = os.readlink(fd)
            except OSError:
                continue
            if target.startswith("socket:["):
                inodes.add(int(target[8:-1]))
    except OSError:
        pass
    return inodes


def _is_loopback(address_port: str) -> bool:
    import ipaddress

    ip = ipaddress.ip_address(address_port.rsplit(":", 1)[0])
    mapped = getattr(ip, "ipv4_mapped", None)  # ::ffff:127.0.0.1 (an IPv6 socket bound to IPv4 loopback)
    return ip.is_loopback or (mapped is not None and mapped.is_loopback)


def test_loopback_predicate():
    assert _is_loopback("127.0.0.1:80") and _is_loopback("::1:80") and _is_loopback("::ffff:127.0.0.1:80")
    assert not _is_loopback("0.0.0.0:80") and not _is_loopback(":::80") and not _is_loopback("10.0.0.5:80")
    assert not _is_loopback("::ffff:10.0.0.5:80")


def test_local_cluster_listens_only_on_loopback(ray_local):
    """Every TCP socket that the local cluster (this driver, the GCS, the raylet, the workers
    and agents it started) listens on is bound to 127.0.0.1 or ::1 while it runs."""
    # Make sure workers exist (they listen too).
    ray = ray_local

    @ray.remote
    def pid():
        return os.getpid()

    worker_pids = set(ray.get([pid.remote() for _ in range(2)]))
    listening = _listening_sockets()
    tree = _process_tree(os.getpid())
    assert worker_pids <= tree
    mine = {}
    for p in tree:
        for inode in _socket_inodes(p):
            if inode in listening:
                mine[listening[inode]] = p
    names = {}
    for addr, p in mine.items():
        try:
            names[addr] = Path(f"/proc/{p}/comm").read_text().strip()
        except OSError:
            names[addr] = "?"
    assert len(mine) >= 3, f"expected the GCS, raylet and workers to listen: {names}"
    wide = {a: n for a, n in names.items() if not _is_loopback(a)}
    assert not wide, f"listening beyond the loopback interface: {wide} (all: {names})"
