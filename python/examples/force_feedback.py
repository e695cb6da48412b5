"""A force-feedback controller in Python on SimSerpent's contact estimates.

With ``[estimation] enabled = true`` every observation a Python controller gets has a
``contacts`` entry: per link the estimated obstacle force (N, world frame), a contact flag and
the contact point along the link, computed from the MEASURED joint force/torque sensors,
IMU and encoders (``[sensors]`` noise as configured) -- not from the simulator's truth.

The controller below follows the config's gait and adds a compliance term: where a link
touches an obstacle, the joint in front of it bends the link along the push, by
``gain_rad_per_n`` rad per newton of lateral force, at most ``max_offset_rad``. (A toy law for
the example: the obstacle-aided controllers of the literature shape the body to push *against*
the pegs; change the sign and the joints to try one.)

Sign conventions (``simserpent.JOINT_SIGN_CONVENTION``): joint j (0-based) sits between link j
(toward the head) and link j + 1; a positive angle rotates link j + 1 counter-clockwise (seen
from above) relative to link j. Link yaw: the head's yaw plus the joint angles in front of it.

    python python/examples/force_feedback.py            # 5 s among random pegs
"""

from __future__ import annotations

from collections.abc import Callable
from typing import Any

import numpy as np
import numpy.typing as npt

import simserpent

#: Estimation on, the open-loop gait as the base (the default job's controller is path following),
#: and 12 random pegs around the snake's starting place (so that it touches some at once).
OVERRIDES = {
    "estimation.enabled": True,
    "control.controller": "gait",
    "terrain.kind": "none",
    "terrain.pegboard.layout": "random",
    "terrain.pegboard.region_min_m": [-2.2, -0.4],
    "terrain.pegboard.region_max_m": [0.5, 0.4],
    "terrain.pegboard.count": 12,
    "terrain.pegboard.spacing_m": 0.3,
}


Log = list[tuple[float, int, float]]


def make_controller(
    config: simserpent.Config,
    gain_rad_per_n: float = 0.05,
    max_offset_rad: float = 0.3,
    log: Log | None = None,
) -> Callable[[dict[str, Any]], npt.NDArray[np.float64]]:
    """The gait plus compliance to the estimated obstacle forces (position servos)."""
    gait = simserpent.Gait(config)

    def controller(obs: dict[str, Any]) -> npt.NDArray[np.float64]:
        target = np.asarray(gait(obs["time_secs"]), dtype=float)
        contacts = obs.get("contacts")  # absent unless [estimation] enabled = true
        if contacts is None:
            return target
        # Yaw of every link: head yaw, then each joint's angle added along the chain.
        yaw = simserpent.link_yaws(obs)
        f = contacts["obstacle_force_n"]
        # Lateral force on each link (+ = toward the link's left), zero where no contact.
        lateral_n = (-np.sin(yaw) * f[:, 0] + np.cos(yaw) * f[:, 1]) * contacts["contact"]
        # Joint j moves link j + 1: a push to its left turns it left (counter-clockwise),
        # which for the link behind the joint is a negative angle.
        offset = np.clip(-gain_rad_per_n * lateral_n[1:], -max_offset_rad, max_offset_rad)
        if log is not None:
            log.append((obs["time_secs"], int(contacts["contact"].sum()), float(np.abs(offset).max())))
        return np.asarray(target + offset, dtype=np.float64)

    return controller


def main(duration_secs: float = 5.0, run_folder: str | None = None) -> tuple[dict[str, Any], Log]:
    config = simserpent.load_config(overrides={**OVERRIDES, "general.duration_secs": duration_secs})
    log: Log = []
    summary = simserpent.run(config, run_folder=run_folder, controller=make_controller(config, log=log))
    touching = sum(1 for _, n, _ in log if n > 0)
    print(f"run folder: {summary['run_folder']}")
    print(f"steps with an estimated obstacle contact: {touching} of {len(log)}; "
          f"largest compliance offset {max(o for _, _, o in log):.3f} rad; "
          f"forward speed {summary['forward_speed_m_per_s']:.3f} m/s")
    return summary, log


if __name__ == "__main__":
    main()
