"""Runs every scene in Drake (the reference) and in SimSerpent, and writes the figures side by side.

    validation/run                                   # Drake + target/release/simserpent
    validation/run --binary main=PATH --binary new=PATH2 --scenes ramp,launch
    validation/run --reference-only                  # Drake only (the model still comes from a binary)

Writes results/figures.csv (scene, μ, engine, figure, value), results/tables.md (side by side) and
results/reference.md (Drake's figures alone).
"""

from __future__ import annotations

import argparse
import csv
import math
import shutil
import sys
import time
from datetime import datetime, timezone
from pathlib import Path

HERE = Path(__file__).resolve().parent
sys.path.insert(0, str(HERE))

import drake_side  # noqa: E402
import mjcf_model  # noqa: E402
import scenes as sc  # noqa: E402
import simserpent_side as ss  # noqa: E402
import targets  # noqa: E402



def fmt(value, figure: str = "") -> str:
    if isinstance(value, str):
        return value
    if isinstance(value, tuple):
        return " … ".join(f"{v:.4f}" for v in value)
    if isinstance(value, list):
        if "(%)" in figure:
            return " / ".join(f"{v:.0f}" if abs(v) >= 10 else f"{v:.2g}" for v in value)
        return " / ".join(f"{v:.3f}" for v in value)
    if value is None or (isinstance(value, float) and math.isnan(value)):
        return "n/a"
    v = float(value)
    if v == 0:
        return "0"
    if abs(v) >= 100:
        return f"{v:.0f}"
    if abs(v) >= 1e-3:
        return f"{v:.3g}"
    return f"{v:.2e}"


def main() -> int:
    ap = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("--binary", action="append", default=[], metavar="NAME=PATH",
                    help="a SimSerpent binary to compare (repeatable); default: main=<repo>/target/release/simserpent")
    ap.add_argument("--model-binary", metavar="PATH",
                    help="binary whose `simserpent model` gives the reference's MJCF (default: the first --binary)")
    ap.add_argument("--scenes", default="all", help="comma-separated scene keys (" +
                    ",".join(s.key for s in sc.SCENES) + ") or all")
    ap.add_argument("--mu", default="0.5,1.0", help="friction coefficients (default 0.5,1.0)")
    ap.add_argument("--reference-only", action="store_true", help="Drake only")
    ap.add_argument("--drake-step", type=float, default=drake_side.DrakeSettings.time_step_secs,
                    help="Drake's discrete step (s)")
    ap.add_argument("--dissipation", type=float,
                    help="Drake's Hunt-Crossley dissipation (s/m) in every scene (default: per scene, the "
                         "restitution of SimSerpent's floor damping ratio at the scene's impact speed)")
    ap.add_argument("--continuous", action="store_true",
                    help="Drake's continuous plant with an error-controlled integrator (runge_kutta3) instead of TAMSI")
    ap.add_argument("--accuracy", type=float, default=drake_side.DrakeSettings.accuracy,
                    help="target accuracy of the continuous integrator")
    ap.add_argument("--out", default=str(HERE / "results"), help="folder of the tables")
    ap.add_argument("--work", default=str(HERE / "work"), help="folder of the run folders and models")
    args = ap.parse_args()

    binaries: dict[str, Path] = {}
    for spec in args.binary:
        name, _, path = spec.partition("=")
        binaries[name] = Path(path).resolve()
    if not binaries:
        binaries["main"] = (HERE.parent / "target" / "release" / "simserpent").resolve()
    for name, path in binaries.items():
        if not path.is_file():
            print(f"error: SimSerpent binary {name} = {path} does not exist (cargo build --release)", file=sys.stderr)
            return 2
    model_binary = Path(args.model_binary).resolve() if args.model_binary else next(iter(binaries.values()))
    engines = [] if args.reference_only else list(binaries)
    chosen = [s for s in sc.SCENES if args.scenes == "all" or s.key in args.scenes.split(",")]
    mus = [float(m) for m in args.mu.split(",")]
    settings = drake_side.DrakeSettings(time_step_secs=args.drake_step, continuous=args.continuous,
                                        accuracy=args.accuracy)
    out = Path(args.out)
    work = Path(args.work)
    out.mkdir(parents=True, exist_ok=True)
    if work.exists():
        shutil.rmtree(work)
    work.mkdir(parents=True)

    rows: list[dict] = []
    dissipation: dict[str, float] = {}
    wall: dict[str, float] = {"drake": 0.0, **{e: 0.0 for e in engines}}
    started = time.time()
    for scene in chosen:
        for mu in mus:
            sets = sc.overrides(scene, mu)
            tag = f"{scene.key}-mu{mu:g}"
            model_path = ss.write_model(model_binary, sets, work / f"{tag}.xml")
            model = mjcf_model.read(model_path)
            command = sc.sine_command(model.n_joints) if scene.gait else sc.hold_command(model)
            push = None
            if scene.push:
                mu_n = model.floor_friction * model.link_weight_n(0)
                push = lambda t, mu_n=mu_n: mu_n * t / sc.BREAKAWAY_RAMP_SECS  # noqa: E731
            d = args.dissipation or drake_side.dissipation_for(model.env_damping_ratio, scene.impact_speed_m_per_s)
            dissipation[scene.key] = d
            settings.dissipation_s_per_m = d
            t0 = time.time()
            run = drake_side.simulate(model, command, scene.duration_secs, settings, push=push)
            wall["drake"] += time.time() - t0
            for label, value in scene.figures(run, model):
                rows.append({"scene": scene.key, "mu": mu, "engine": "drake", "figure": label,
                             "value": fmt(value, label), "raw": value})
            print(f"{tag}: drake done ({time.time() - t0:.1f} s)", flush=True)
            for engine in engines:
                t0 = time.time()
                run_sets = dict(sets)
                if scene.push:
                    run_sets.update(push_sets(mu_n))
                folder = ss.run(binaries[engine], run_sets, work / engine, tag)
                ours_model = mjcf_model.read(folder / "model.xml")
                ours = ss.read_run(folder, len(model.links), ours_model)
                for label, value in scene.figures(ours, ours_model):
                    rows.append({"scene": scene.key, "mu": mu, "engine": engine, "figure": label,
                                 "value": fmt(value, label), "raw": value})
                wall[engine] += time.time() - t0
                print(f"{tag}: {engine} done ({time.time() - t0:.1f} s)", flush=True)
            write_tables(out, rows, chosen, mus, engines, binaries, settings, dissipation, wall,
                         time.time() - started)
    print(f"total {time.time() - started:.0f} s; tables in {out}")
    return 0


def push_sets(mu_n: float) -> dict:
    """The ramped force in our config (`[[physics.external_forces]]`): on link 0 along +x from t = 0,
    rising by μN per ramp time, up to 2 μN."""
    rate = mu_n / sc.BREAKAWAY_RAMP_SECS
    return {
        "physics.external_forces": ss.Raw(
            f"[{{link = 0, direction = [1.0, 0.0, 0.0], start_secs = 0.0, ramp_n_per_s = {rate!r}, "
            f"force_n = {2 * mu_n!r}, duration_secs = 0.0}}]"
        )
    }


def write_tables(out: Path, rows, chosen, mus, engines, binaries, settings, dissipation, wall, total) -> None:
    with (out / "figures.csv").open("w", newline="") as f:
        w = csv.DictWriter(f, fieldnames=["scene", "mu", "engine", "figure", "value"], extrasaction="ignore")
        w.writeheader()
        w.writerows(rows)
    value = {(r["scene"], r["mu"], r["engine"], r["figure"]): r["value"] for r in rows}
    command = "validation/run " + " ".join(sys.argv[1:])
    header = [
        f"Generated by `{command.strip()}` on {datetime.now(timezone.utc):%Y-%m-%d %H:%M} UTC.",
        f"Drake {drake_version()}: "
        + (f"continuous plant, {settings.integrator} at accuracy {settings.accuracy:g}, sampled every "
           f"{settings.time_step_secs:g} s" if settings.continuous else
           f"TAMSI, step {settings.time_step_secs:g} s")
        + f", point contact, stiction tolerance {settings.stiction_tolerance_m_per_s:g} m/s.",
    ]
    for name in engines:
        header.append(f"SimSerpent `{name}`: {binaries[name]}.")
    header.append("Wall time: " + ", ".join(f"{k} {v:.0f} s" for k, v in wall.items()) + f"; total {total:.0f} s.")
    if engines:
        (out / "targets.md").write_text(targets.report(rows, mus, engines, header))
    outputs = [(out / "reference.md", ["drake"])]
    if engines:
        outputs.insert(0, (out / "tables.md", ["drake", *engines]))
    for path, engs in outputs:
        lines = ["# Contact events: Drake and SimSerpent side by side" if len(engs) > 1 else
                 "# Contact events: Drake's reference figures", ""]
        lines += [h for h in header if len(engs) > 1 or not h.startswith("SimSerpent")]
        lines.append("")
        for n, scene in enumerate(chosen, start=1):
            labels = [r["figure"] for r in rows if r["scene"] == scene.key and r["engine"] == "drake" and r["mu"] == mus[0]]
            if not labels:
                continue
            lines += [f"## {n}. {scene.title}", "", scene.what, ""]
            if scene.key in dissipation:
                lines += [f"Drake's Hunt–Crossley dissipation: {dissipation[scene.key]:.3g} s/m (restitution of "
                          f"SimSerpent's floor at {scene.impact_speed_m_per_s:.2g} m/s).", ""]
            cols = [(mu, e) for mu in mus for e in engs]
            lines.append("| figure | " + " | ".join(f"μ {mu:g} {label(e)}" for mu, e in cols) + " |")
            lines.append("|---|" + "---|" * len(cols))
            for lab in labels:
                cells = [value.get((scene.key, mu, e, lab), "") for mu, e in cols]
                lines.append(f"| {lab} | " + " | ".join(cells) + " |")
            lines.append("")
        path.write_text("\n".join(lines))


def label(engine: str) -> str:
    return "Drake" if engine == "drake" else f"SimSerpent {engine}"


def drake_version() -> str:
    try:
        from importlib.metadata import version

        return version("drake")
    except Exception:  # noqa: BLE001
        return "?"


if __name__ == "__main__":
    sys.exit(main())
