"""Runs every scene in Drake (the reference) and in SimSerpent, checks the targets, and writes the
figures side by side. Exits 1 when a target fails (each miss is printed: scene, μ, figure, both
engines' values and the bound), 2 on bad input.

    validation/run                                   # Drake + target/release/simserpent
    validation/run --binary main=PATH --binary new=PATH2 --scenes ramp,launch
    validation/run --reference-only                  # Drake only (the model still comes from a binary)
    validation/run --set physics.KEY=VALUE           # a SimSerpent setting in every scene and test

Writes results/figures.csv (scene, μ, engine, figure, value), results/tables.md (side by side,
with SimSerpent at a finer step as the convergence column), results/targets.md (every bound,
pass/fail), results/restitution.md (the impact tests that set Drake's damping) and
results/reference.md (Drake's figures alone).
"""

from __future__ import annotations

import argparse
import csv
import hashlib
import json
import math
import os
import platform
import shutil
import subprocess
import sys
import time
from datetime import datetime, timezone
from pathlib import Path

HERE = Path(__file__).resolve().parent
REPO = HERE.parent
sys.path.insert(0, str(HERE))

import drake_side  # noqa: E402
import figures as fg  # noqa: E402
import mjcf_model  # noqa: E402
import restitution as rs  # noqa: E402
import scenes as sc  # noqa: E402
import simserpent_side as ss  # noqa: E402
import targets  # noqa: E402


def fmt(value, figure: str = "") -> str:
    if isinstance(value, str):
        return value
    if isinstance(value, tuple):
        return (", " if "x, y" in figure else " … ").join(f"{v:.4g}" for v in value)
    if isinstance(value, list):
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


def parse_sets(items: list[str]) -> dict:
    out = {}
    for item in items:
        key, sep, value = item.partition("=")
        if not sep or not key:
            raise SystemExit(f"error: --set {item!r}: expected KEY=VALUE (VALUE in TOML)")
        out[key] = ss.Raw(value)
    return out


def main() -> int:
    ap = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("--binary", action="append", default=[], metavar="NAME=PATH",
                    help="a SimSerpent binary to compare (repeatable); default: main=<repo>/target/release/simserpent")
    ap.add_argument("--model-binary", metavar="PATH",
                    help="binary whose `simserpent model` gives the reference's MJCF and whose impact tests set "
                         "Drake's damping (default: the first --binary)")
    ap.add_argument("--scenes", default="all", help="comma-separated scene keys (" +
                    ",".join(s.key for s in sc.SCENES) + "), all, or none (with --update: only rewrite the tables)")
    ap.add_argument("--mu", default="0.5,1.0", help="friction coefficients (default 0.5,1.0)")
    ap.add_argument("--set", action="append", default=[], metavar="KEY=VALUE", dest="sets",
                    help="a SimSerpent config key (TOML value) for every scene and impact test (repeatable)")
    ap.add_argument("--reference-only", action="store_true", help="Drake only")
    ap.add_argument("--no-fine", action="store_true", help="leave out SimSerpent's finer-step (convergence) runs")
    ap.add_argument("--drake-step", type=float, default=drake_side.DrakeSettings.time_step_secs,
                    help="Drake's discrete step (s)")
    ap.add_argument("--restitution", default="measured",
                    help="the restitution Drake's floor and obstacle damping are set to: \"measured\" (default: "
                         "SimSerpent's, in the same impact test at the scene's speed and step) or a number in 0..1 "
                         "(a configured value, both engines)")
    ap.add_argument("--continuous", action="store_true",
                    help="Drake's continuous plant with an error-controlled integrator (runge_kutta3) instead of TAMSI")
    ap.add_argument("--accuracy", type=float, default=drake_side.DrakeSettings.accuracy,
                    help="target accuracy of the continuous integrator")
    ap.add_argument("--update", action="store_true",
                    help="keep the figures of the scenes and μ not run now, and the impact tests, from the tables "
                         "already in --out (rerun a subset of the same builds into a complete set)")
    ap.add_argument("--out", default=str(HERE / "results"), help="folder of the tables")
    ap.add_argument("--work", default=str(HERE / "work"), help="folder of the run folders and models")
    args = ap.parse_args()

    binaries: dict[str, Path] = {}
    for spec in args.binary:
        name, sep, path = spec.partition("=")
        if not sep or not name or not path:
            print(f"error: --binary {spec!r}: expected NAME=PATH", file=sys.stderr)
            return 2
        binaries[name] = Path(path).resolve()
    if not binaries:
        binaries["main"] = (REPO / "target" / "release" / "simserpent").resolve()
    for name, path in binaries.items():
        if not path.is_file() and args.scenes != "none":
            print(f"error: SimSerpent binary {name} = {path} does not exist (cargo build --release)", file=sys.stderr)
            return 2
    model_binary = Path(args.model_binary).resolve() if args.model_binary else next(iter(binaries.values()))
    engines = [] if args.reference_only else list(binaries)
    known = {s.key for s in sc.SCENES}
    wanted = known if args.scenes == "all" else set() if args.scenes == "none" else set(args.scenes.split(","))
    if wanted - known:
        print(f"error: --scenes: unknown scene(s) {', '.join(sorted(wanted - known))}; "
              f"the scenes are {', '.join(s.key for s in sc.SCENES)}", file=sys.stderr)
        return 2
    chosen = [s for s in sc.SCENES if s.key in wanted]
    try:
        mus = [float(m) for m in args.mu.split(",")]
        configured_e = None if args.restitution == "measured" else float(args.restitution)
    except ValueError as e:
        print(f"error: --mu / --restitution: {e}", file=sys.stderr)
        return 2
    if configured_e is not None and not 0.0 <= configured_e <= 1.0:
        print(f"error: --restitution {configured_e}: must be \"measured\" or within 0..1", file=sys.stderr)
        return 2
    extra = parse_sets(args.sets)
    settings = drake_side.DrakeSettings(time_step_secs=args.drake_step, continuous=args.continuous,
                                        accuracy=args.accuracy)
    out = Path(args.out)
    work = Path(args.work)
    out.mkdir(parents=True, exist_ok=True)
    if work.exists():
        shutil.rmtree(work)
    work.mkdir(parents=True)

    rows: list[dict] = []
    errors: list[str] = []
    impacts: dict = {}
    damping: dict[str, tuple[float, float]] = {}
    commands: list[str] = []
    args.builds = {}
    args.described = set()  # the builds whose binary this run has hashed (once per run)
    args.previous_wall = {}
    if args.update:
        rows, impacts, damping, commands, args.builds = load_previous(out, {(s.key, mu) for s in chosen for mu in mus})
        args.previous_wall = json.loads((out / "restitution.json").read_text()).get("wall_secs", {})
    shown = [s for s in sc.SCENES if s in chosen or any(r["scene"] == s.key for r in rows)]
    mus = sorted(set(mus) | {r["mu"] for r in rows})
    if not engines and args.update:
        engines = sorted({r["engine"] for r in rows if r["engine"] != "drake" and "@" not in r["engine"]})
    if chosen or not commands:
        commands.append(public_command(args))
    args.commands = commands
    wall: dict[str, float] = {"drake": 0.0, **{e: 0.0 for e in engines}}
    started = time.time()
    run_mus = [float(m) for m in args.mu.split(",")]
    for scene in chosen:
        prepared = {**(scene.prepare(work) if scene.prepare else {}), **extra}
        for mu in run_mus:
            tag = f"{scene.key}-mu{mu:g}"
            try:
                run_scene(scene, mu, prepared, tag, model_binary, binaries, engines, extra, settings, configured_e,
                          args, impacts, damping, wall, rows, work)
            except Exception as e:  # noqa: BLE001 - one scene's failure must not lose the others
                errors.append(f"ERROR scene {scene.key}, μ {mu:g}: {type(e).__name__}: {e}")
                print(errors[-1], file=sys.stderr, flush=True)
            write_tables(out, rows, shown, mus, engines, binaries, settings, damping, impacts, wall,
                         time.time() - started, args, configured_e)
    if not chosen:
        write_tables(out, rows, shown, mus, engines, binaries, settings, damping, impacts, wall,
                     time.time() - started, args, configured_e)
    raw = {(r["scene"], r["mu"], r["engine"], r["figure"]): r["raw"] for r in rows}
    verdicts = targets.evaluate(raw, mus, engines)
    missed = errors + targets.failures(verdicts)
    print(f"total {time.time() - started:.0f} s; tables in {out}")
    if missed:
        print(f"{len(missed)} misses ({len(errors)} scene errors, {len(verdicts)} checks):", file=sys.stderr)
        for line in missed:
            print(line, file=sys.stderr)
        return 1
    if engines:
        print(f"all {len(verdicts)} checks pass")
    return 0


def run_scene(scene, mu, prepared, tag, model_binary, binaries, engines, extra, settings, configured_e, args,
              impacts, damping, wall, rows, work) -> None:
    """One scene at one μ: Drake (with the damping of its impact tests), then every build and its
    finer-step run; the figures go to `rows`."""
    sets = sc.overrides(scene, mu, prepared)
    model_path = ss.write_model(model_binary, sets, work / f"{tag}.xml")
    model = mjcf_model.read(model_path)
    command = sc.sine_command(model.n_joints) if scene.gait else sc.hold_command(model)
    push = None
    mu_n = model.floor_friction * model.link_weight_n(0)
    if scene.push:
        push = lambda t, mu_n=mu_n: mu_n * t / sc.BREAKAWAY_RAMP_SECS  # noqa: E731
    t0 = time.time()
    d_floor, d_obstacle = scene_damping(scene, mu, model, model_binary, extra, settings, configured_e,
                                        args.no_fine, impacts, work)
    damping[scene.key] = (d_floor, d_obstacle)
    settings.floor_dissipation_s_per_m = d_floor
    settings.obstacle_dissipation_s_per_m = d_obstacle
    # Recorded at SimSerpent's step: states at its rows, forces the mean over its steps. A chaotic
    # scene runs its ensemble of starts in each engine and at each step; its figures are the means.
    found: dict[str, list] = {}
    for k in range(scene.ensemble):
        k_sets = fg.perturbed(sets, k)
        k_model = model if k == 0 else mjcf_model.read(ss.write_model(model_binary, k_sets, work / f"{tag}-{k}.xml"))
        run = drake_side.simulate(k_model, command, scene.duration_secs, settings, push=push, ground=scene.ground,
                                  mesh_dir=work, sample_secs=model.timestep_secs)
        found.setdefault("drake", []).append(scene.figures(run, k_model))
    wall["drake"] += time.time() - t0
    print(f"{tag}: drake done ({time.time() - t0:.1f} s)", flush=True)
    for engine in engines:
        t0 = time.time()
        run_sets = dict(sets)
        if scene.push:
            run_sets.update(push_sets(mu_n))
        energy = "energy" in scene.tags
        for k in range(scene.ensemble):
            k_sets = fg.perturbed(run_sets, k)
            folder = ss.run(binaries[engine], k_sets, work / engine, f"{tag}-{k}")
            ours_model = mjcf_model.read(folder / "model.xml")
            ours = ss.read_run(folder, len(model.links), ours_model if energy else None)
            found.setdefault(engine, []).append(scene.figures(ours, ours_model))
            if not args.no_fine:
                fine_sets = {**k_sets, "general.timestep_secs": scene.fine_step_secs}
                folder = ss.run(binaries[engine], fine_sets, work / f"{engine}-fine", f"{tag}-{k}")
                fine_model = mjcf_model.read(folder / "model.xml")
                fine = ss.read_run(folder, len(model.links), fine_model if energy else None)
                found.setdefault(f"{engine}@fine", []).append(
                    scene.figures(fg.resample(fine, ours_model.timestep_secs), fine_model))
        wall[engine] += time.time() - t0
        print(f"{tag}: {engine} done ({time.time() - t0:.1f} s)", flush=True)
    for engine, figures in found.items():
        add_figures(rows, scene, mu, engine, figures[0] if len(figures) == 1 else fg.ensemble_mean(figures))


def add_figures(rows, scene, mu, engine, figures) -> None:
    for label, value in figures:
        rows.append({"scene": scene.key, "mu": mu, "engine": engine, "figure": label,
                     "value": fmt(value, label), "raw": value})


def scene_damping(scene, mu, model, model_binary, extra, settings, configured_e, no_fine, impacts, work):
    """Drake's floor and obstacle dissipation (s/m) for the scene: the ones whose impact tests
    rebound like SimSerpent's (or like the configured restitution). Each test is measured once."""
    tests = [rs.ImpactTest("floor", scene.floor_impact_m_per_s)]
    if scene.obstacle_test is not None:
        test = scene.obstacle_test
        if scene.key == "mesh":
            test = rs.ImpactTest("obstacle", test.speed_m_per_s, sc.MESH_RADIUS_M,
                                 sc.prism_obj(work / "impact-peg.obj").name)
        tests.append(test)
    d_floor = None
    d = []
    for test in tests:
        key = (test, model.timestep_secs)
        if key not in impacts:
            impacts[key] = measure_impact(test, mu, model, model_binary, extra, settings, configured_e, no_fine,
                                          d_floor, scene.fine_step_secs, work)
        d.append(impacts[key]["d"])
        if test.kind == "floor":
            d_floor = impacts[key]["d"]
    return d[0], (d[1] if len(d) > 1 else d[0])


def measure_impact(test, mu, model, binary, extra, settings, configured_e, no_fine, d_floor, fine_step, work) -> dict:
    name = f"impact-{test.kind}-{test.speed_m_per_s:g}-{test.radius_m:g}" + ("-mesh" if test.mesh_file else "")
    sets = {**rs.simserpent_sets(test, mu, model.timestep_secs, work), **extra}
    folder = ss.run(binary, sets, work / "impacts", name)
    test_model = mjcf_model.read(folder / "model.xml")
    e_ours = rs.measure(ss.read_run(folder, 1), test_model, test.kind)
    e_fine = math.nan
    if not no_fine:
        folder = ss.run(binary, {**sets, "general.timestep_secs": fine_step}, work / "impacts-fine", name)
        e_fine = rs.measure(ss.read_run(folder, 1), test_model, test.kind)
    target = e_ours if configured_e is None else configured_e
    duration = 0.1 if test.kind == "floor" else 0.05
    s = drake_side.DrakeSettings(time_step_secs=settings.time_step_secs, continuous=settings.continuous,
                                 accuracy=settings.accuracy)

    def drake_e(d: float) -> float:
        if test.kind == "floor":
            s.floor_dissipation_s_per_m = s.obstacle_dissipation_s_per_m = d
        else:
            s.floor_dissipation_s_per_m, s.obstacle_dissipation_s_per_m = d_floor, d
        run = drake_side.simulate(test_model, lambda t: [], duration, s, mesh_dir=work)
        return rs.measure(run, test_model, test.kind)

    zeta = test_model.env_damping_ratio
    guess = drake_side.dissipation_for_restitution(max(target, 0.02), test.speed_m_per_s) if zeta else 1.0
    d, e_drake = rs.calibrate(drake_e, target, guess)
    print(f"{test.label()}: SimSerpent restitution {e_ours:.3f} (finer step {e_fine:.3f}); Drake d = {d:.3g} s/m "
          f"gives {e_drake:.3f}", flush=True)
    return {"test": test, "e_ours": e_ours, "e_fine": e_fine, "target": target, "d": d, "e_drake": e_drake,
            "step": model.timestep_secs, "fine_step": fine_step}


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


def public_command(args) -> str:
    """The command line as run, without this machine's paths (binaries by name and file name)."""
    parts = ["validation/run"]
    argv = sys.argv[1:]
    i = 0
    while i < len(argv):
        a = argv[i]
        value = None
        if a in ("--binary", "--model-binary", "--out", "--work") and i + 1 < len(argv):
            value = argv[i + 1]
            i += 1
        elif a.split("=", 1)[0] in ("--binary", "--model-binary", "--out", "--work") and "=" in a:
            a, value = a.split("=", 1)
        if value is not None:
            parts += [a, _public_path(value)]
        else:
            parts.append(a)
        i += 1
    return " ".join(parts)


def _public_path(value: str) -> str:
    name, sep, path = value.partition("=") if "=" in value else ("", "", value)
    p = Path(path).resolve()
    try:
        shown = str(p.relative_to(REPO))
    except ValueError:
        shown = f"…/{p.name}"
    return f"{name}{sep}{shown}"


def machine() -> str:
    cpu = platform.processor() or platform.machine()
    try:
        for line in Path("/proc/cpuinfo").read_text().splitlines():
            if line.startswith("model name"):
                cpu = line.split(":", 1)[1].strip()
                break
    except OSError:
        pass
    return f"{cpu}, {os.cpu_count()} cores, {platform.system()} {platform.release().split('-')[0]}"


def binary_version(path: Path) -> str:
    """The binary's version line and the start of its SHA-256 (which build it is)."""
    try:
        version = subprocess.run([str(path), "--version"], capture_output=True, text=True,
                                 check=True).stdout.strip().splitlines()[0]
    except (OSError, subprocess.CalledProcessError, IndexError):
        version = "version unknown"
    try:
        digest = hashlib.sha256(path.read_bytes()).hexdigest()[:12]
    except OSError:
        digest = "?"
    return f"{version}, binary sha256 {digest}…"


def build_history(before: str | None, build: str, scenes: str) -> str:
    """A name's builds after this run measured `scenes` with `build` (`binary_version`): `build`,
    or, when an --update measured them with another build than the one `before` describes, that
    description and then the new build's digest with the scenes it measured."""
    if before is None:
        return build
    digest = build.rsplit(", ", 1)[-1]
    if digest in before:
        return before
    return f"{before}; {digest} ({scenes.replace(',', ', ')})"


def write_tables(out: Path, rows, chosen, mus, engines, binaries, settings, damping, impacts, wall, total, args,
                 configured_e) -> None:
    with (out / "figures.csv").open("w", newline="") as f:
        w = csv.DictWriter(f, fieldnames=["scene", "mu", "engine", "figure", "value", "raw"], extrasaction="ignore")
        w.writeheader()
        w.writerows({**r, "raw": raw_json(r["raw"])} for r in rows)
    value = {(r["scene"], r["mu"], r["engine"], r["figure"]): r["value"] for r in rows}
    raw = {(r["scene"], r["mu"], r["engine"], r["figure"]): r["raw"] for r in rows}
    header = [
        "Generated by " + "; then ".join(f"`{c}`" for c in args.commands)
        + f" on {datetime.now(timezone.utc):%Y-%m-%d %H:%M} UTC, on {machine()}.",
        f"Drake {drake_version()}: "
        + (f"continuous plant, {settings.integrator} at accuracy {settings.accuracy:g}, sampled every "
           f"{settings.time_step_secs:g} s" if settings.continuous else
           f"TAMSI, step {settings.time_step_secs:g} s")
        + f", point contact, stiction tolerance {settings.stiction_tolerance_m_per_s:g} m/s; its floor and obstacle "
        + ("damping give SimSerpent's measured restitution (results/restitution.md)." if configured_e is None else
           f"damping give the configured restitution {configured_e:g} (results/restitution.md)."),
        "Figures at SimSerpent's step: Drake's rows resampled to it (states at its rows, forces as the mean over "
        "each of its steps), and so are SimSerpent's finer-step runs (the convergence column, \"finer step\").",
    ]
    for name in engines:
        if name not in args.described and name in binaries and binaries[name].is_file():
            args.described.add(name)
            args.builds[name] = build_history(args.builds.get(name), binary_version(binaries[name]), args.scenes)
        header.append(f"SimSerpent `{name}`: {args.builds.get(name, 'build unknown')}.")
    spent = {k: v + args.previous_wall.get(k, 0.0) for k, v in wall.items()}
    header.append("Wall time: " + ", ".join(f"{k} {v:.0f} s" for k, v in spent.items())
                  + f"; total {total + args.previous_wall.get('total', 0.0):.0f} s.")
    if engines:
        verdicts = targets.evaluate(raw, mus, engines)
        (out / "targets.md").write_text(targets.report(verdicts, header))
    (out / "restitution.md").write_text(restitution_report(impacts, header[:2]))
    (out / "restitution.json").write_text(json.dumps({
        "commands": args.commands,
        "builds": args.builds,
        "wall_secs": {**{k: v + args.previous_wall.get(k, 0.0) for k, v in wall.items()},
                      "total": total + args.previous_wall.get("total", 0.0)},
        "damping": damping,
        "impacts": [{**{k: v for k, v in r.items() if k != "test"}, "test": vars(r["test"])} for r in impacts.values()],
    }, indent=1) + "\n")
    outputs = [(out / "reference.md", ["drake"])]
    if engines:
        cols = ["drake", *engines] + ([f"{engines[0]}@fine"] if not args.no_fine else [])
        outputs.insert(0, (out / "tables.md", cols))
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
            if scene.key in damping:
                d_floor, d_obstacle = damping[scene.key]
                lines += [f"Drake's Hunt–Crossley dissipation: floor {d_floor:.3g} s/m"
                          + (f", obstacle {d_obstacle:.3g} s/m" if scene.obstacle_test else "")
                          + f"; SimSerpent's finer step {scene.fine_step_secs * 1000:g} ms.", ""]
            cols = [(mu, e) for mu in mus for e in engs]
            lines.append("| figure | " + " | ".join(f"μ {mu:g} {label(e, scene)}" for mu, e in cols) + " |")
            lines.append("|---|" + "---|" * len(cols))
            for lab in labels:
                cells = [value.get((scene.key, mu, e, lab), "") for mu, e in cols]
                lines.append(f"| {lab} | " + " | ".join(cells) + " |")
            lines.append("")
        path.write_text("\n".join(lines))


def load_previous(out: Path, rerun: set) -> tuple[list, dict, dict, list, dict]:
    """The figures, impact tests, damping and commands of the tables in `out`, less the (scene, μ)
    pairs in `rerun`."""
    figures_csv, state_json = out / "figures.csv", out / "restitution.json"
    if not figures_csv.exists() or not state_json.exists():
        raise SystemExit(f"error: --update: no earlier tables in {out} (figures.csv and restitution.json)")
    rows = []
    with figures_csv.open() as f:
        for r in csv.DictReader(f):
            if "raw" not in r:
                raise SystemExit(f"error: --update: {figures_csv} has no raw column (written by an older suite)")
            mu = float(r["mu"])
            if (r["scene"], mu) in rerun:
                continue
            raw = json.loads(r["raw"])
            raw = tuple(raw["pair"]) if isinstance(raw, dict) else (math.nan if raw is None else raw)
            rows.append({"scene": r["scene"], "mu": mu, "engine": r["engine"], "figure": r["figure"],
                         "value": r["value"], "raw": raw})
    state = json.loads(state_json.read_text())
    impacts = {}
    for r in state["impacts"]:
        test = rs.ImpactTest(**r["test"])
        impacts[(test, r["step"])] = {**r, "test": test}
    damping = {k: tuple(v) for k, v in state["damping"].items()}
    return rows, impacts, damping, list(state["commands"]), dict(state.get("builds", {}))


def raw_json(value) -> str:
    """A figure's exact value as JSON (a pair as {"pair": [a, b]}; nan as null)."""
    def clean(v):
        if isinstance(v, float) and math.isnan(v):
            return None
        return float(v) if isinstance(v, (int, float)) and not isinstance(v, bool) else v

    if isinstance(value, tuple):
        return json.dumps({"pair": [clean(v) for v in value]})
    if isinstance(value, list):
        return json.dumps([clean(v) for v in value])
    return json.dumps(clean(value))


def restitution_report(impacts: dict, header: list[str]) -> str:
    lines = ["# Restitution: the impact tests that set Drake's damping", "", *header, "",
             "One link hitting the floor (lying flat) or an obstacle (broadside) at the speed of a scene's impacts; "
             "restitution = normal speed after / before the contact (`restitution.py`).", "",
             "| test | SimSerpent step | SimSerpent restitution | at the finer step | Drake's target | "
             "Drake's dissipation (s/m) | Drake's restitution |",
             "|---|---|---|---|---|---|---|"]
    for (test, _), r in impacts.items():
        lines.append(f"| {test.label()} | {r['step'] * 1000:g} ms | {r['e_ours']:.3f} | "
                     f"{r['e_fine']:.3f} ({r['fine_step'] * 1000:g} ms) | {r['target']:.3f} | {r['d']:.3g} | "
                     f"{r['e_drake']:.3f} |")
    lines.append("")
    return "\n".join(lines)


def label(engine: str, scene) -> str:
    if engine == "drake":
        return "Drake"
    if engine.endswith("@fine"):
        return f"SimSerpent {engine[:-5]} at {scene.fine_step_secs * 1000:g} ms"
    return f"SimSerpent {engine}"


def drake_version() -> str:
    try:
        from importlib.metadata import version

        return version("drake")
    except Exception:  # noqa: BLE001
        return "?"


if __name__ == "__main__":
    sys.exit(main())
