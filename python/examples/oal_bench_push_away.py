"""Your own force-feedback controller through the obstacle-aided locomotion benchmark.

``push_away`` is the benchmark's base wave plus, at every link the contact estimates say touches
a peg, a bend of its two joints away from the peg proportional to the lateral force (the Rust
twin is ``PushAway`` in ``examples/oal_bench.rs``). ``simserpent.oal_bench`` runs it beside
feedback off, passive compliance and the built-in contact laws on the same paired fields and
returns the report.

    python python/examples/oal_bench_push_away.py            # a small benchmark (about a minute)
"""

from __future__ import annotations

from typing import Any, Callable

import numpy as np

import simserpent

GAIN_RAD_PER_N = 0.01


def push_away(config: simserpent.Config) -> Callable[[dict[str, Any]], Any]:
    """Builds the controller of one run from the run's config (its base gait and servos)."""
    gait = simserpent.Gait(config)

    def step(obs: dict[str, Any]) -> Any:
        target, _ = gait.targets(obs["time_secs"])
        target = np.array(target)
        contacts = obs.get("contacts")
        if contacts is None:
            return target
        yaw = simserpent.link_yaws(obs)  # every link's heading, counter-clockwise from +x
        f = contacts["obstacle_force_n"]
        across = (-np.sin(yaw) * f[:, 0] + np.cos(yaw) * f[:, 1]) * contacts["contact"]
        # Link i's force bends the joints at both of its ends (i - 1 and i).
        target[:] -= GAIN_RAD_PER_N * (across[:-1] + across[1:])
        return target

    return step


def main(out: str = "runs", **size: Any) -> dict[str, Any]:
    size = {"floors": ["isotropic"], "families": ["random"], "laws": False, "held_out_fields": 2, **size}
    result = simserpent.oal_bench(push_away, name="push_away", out=out, quick=True, **size)
    print(result["report"])
    return result


if __name__ == "__main__":
    main()
