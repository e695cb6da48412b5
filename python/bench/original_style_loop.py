#!/usr/bin/env python3
"""A Python simulation loop in the style of the original tool.

The original tool (thesis ch. 6: simulate_snake.py, ctrl_snake.py, get_snake_info.py,
store_csv_data.py) stepped MuJoCo from Python: a control callback set `data.ctrl` every
timestep, the main loop called `mj_step` until the configured time, and after every step the
get_*_info functions collected dictionaries of link, joint, contact and force information that
store_csv_data wrote to CSV files, one per category, at run time.

This script does the same on the model.xml that SimSerpent wrote into a run folder, so the two
whole processes can be compared on the same model (scripts/compare-python-loop):

    python python/bench/original_style_loop.py RUN_FOLDER/model.xml --duration-secs 20 --out DIR

Set-points: the sine wave of SimSerpent's [gait.sine_wave] defaults, sent to the position servos
(`position_XX`): q_i(t) = r(t) * A * sin(2 pi f t + (i - 1) * delta), with the linear ramp-in r(t)
over the first ramp seconds. The integrator, timestep and friction cone are the model's own
(the <option> element SimSerpent wrote); the script prints them.

Recorded at every step (one CSV file each, like store_data_to_csv's categories): per link the
position, velocity, acceleration, angle (roll, pitch, yaw), angular velocity, angular
acceleration; per joint the angle, velocity and the torque/position/velocity actuator forces;
per link the external contact force (sum over its contacts, world frame); and every contact
(geoms, position, distance, normal force).
"""

import argparse
import csv
import math
import os
import sys
import time

import mujoco
import numpy as np


def quat_to_euler(q):
    """Roll, pitch, yaw (rad) of a unit quaternion (w, x, y, z)."""
    w, x, y, z = q
    roll = math.atan2(2.0 * (w * x + y * z), 1.0 - 2.0 * (x * x + y * y))
    pitch = math.asin(max(-1.0, min(1.0, 2.0 * (w * y - z * x))))
    yaw = math.atan2(2.0 * (w * z + x * y), 1.0 - 2.0 * (y * y + z * z))
    return roll, pitch, yaw


class SnakeInfo:
    """get_snake_info.py: dictionaries of the links, joints, contacts and forces."""

    def __init__(self, model):
        self.model = model
        self.links = [b for b in range(model.nbody) if (model.body(b).name or "").startswith("link_")]
        self.link_names = [model.body(b).name for b in self.links]
        self.joints = [j for j in range(model.njnt) if model.jnt_type[j] == mujoco.mjtJoint.mjJNT_HINGE]
        self.joint_names = [model.joint(j).name for j in self.joints]
        self.actuators = {}
        for kind in ("torque", "position", "velocity"):
            self.actuators[kind] = [
                a for a in range(model.nu) if (model.actuator(a).name or "").startswith(kind + "_")
            ]
        self.vel6 = np.zeros(6)
        self.acc6 = np.zeros(6)
        self.force6 = np.zeros(6)

    def get_link_info(self, data):
        info = {}
        for b, name in zip(self.links, self.link_names):
            mujoco.mj_objectVelocity(self.model, data, mujoco.mjtObj.mjOBJ_BODY, b, self.vel6, 0)
            mujoco.mj_objectAcceleration(self.model, data, mujoco.mjtObj.mjOBJ_BODY, b, self.acc6, 0)
            info[name] = {
                "position": data.xpos[b].copy(),
                "velocity": self.vel6[3:].copy(),
                "accel": self.acc6[3:].copy(),
                "angle": quat_to_euler(data.xquat[b]),
                "angular_vel": self.vel6[:3].copy(),
                "angular_accel": self.acc6[:3].copy(),
            }
        return info

    def get_joint_info(self, data):
        info = {}
        for k, (j, name) in enumerate(zip(self.joints, self.joint_names)):
            info[name] = {
                "angle": data.qpos[self.model.jnt_qposadr[j]],
                "velocity": data.qvel[self.model.jnt_dofadr[j]],
                "torque_actuator_force": self._force("torque", k, data),
                "position_actuator_force": self._force("position", k, data),
                "velocity_actuator_force": self._force("velocity", k, data),
            }
        return info

    def _force(self, kind, k, data):
        ids = self.actuators[kind]
        return data.actuator_force[ids[k]] if k < len(ids) else 0.0

    def get_contact_info(self, data):
        contacts = []
        for i in range(data.ncon):
            c = data.contact[i]
            mujoco.mj_contactForce(self.model, data, i, self.force6)
            contacts.append(
                {
                    "geom1": self.model.geom(c.geom1).name,
                    "geom2": self.model.geom(c.geom2).name,
                    "position": c.pos.copy(),
                    "distance": c.dist,
                    "normal_force": self.force6[0],
                }
            )
        return contacts

    def get_force_info(self, data):
        info = {}
        for b, name in zip(self.links, self.link_names):
            info[name] = np.zeros(3)
        for i in range(data.ncon):
            c = data.contact[i]
            mujoco.mj_contactForce(self.model, data, i, self.force6)
            frame = c.frame.reshape(3, 3)
            world = frame.T @ self.force6[:3]  # force of geom1 on geom2, world frame
            for geom, sign in ((c.geom1, -1.0), (c.geom2, 1.0)):
                name = self.model.body(self.model.geom_bodyid[geom]).name
                if name in info:
                    info[name] += sign * world
        return info


class CsvStore:
    """store_csv_data.py: one CSV file per category, a row per step."""

    def __init__(self, out_dir, info):
        os.makedirs(out_dir, exist_ok=True)
        self.files = {}
        self.writers = {}
        per_link = ["position", "velocity", "accel", "angle", "angular_vel", "angular_accel"]
        for cat in per_link:
            cols = ["time"] + [f"{n}_{a}" for n in info.link_names for a in ("x", "y", "z")]
            self._open(out_dir, cat, cols)
        self._open(out_dir, "joint_angles", ["time"] + [f"{n}_angle" for n in info.joint_names])
        self._open(out_dir, "joint_velocities", ["time"] + [f"{n}_velocity" for n in info.joint_names])
        for kind in ("torque", "position", "velocity"):
            self._open(out_dir, f"{kind}_actuator_forces", ["time"] + info.joint_names)
        cols = ["time"] + [f"{n}_{a}" for n in info.link_names for a in ("fx", "fy", "fz")]
        self._open(out_dir, "external_contact_forces", cols)
        self._open(
            out_dir,
            "contacts",
            ["time", "geom1", "geom2", "pos_x", "pos_y", "pos_z", "distance", "normal_force"],
        )
        self.per_link = per_link

    def _open(self, out_dir, name, header):
        f = open(os.path.join(out_dir, name + ".csv"), "w", newline="")
        self.files[name] = f
        self.writers[name] = csv.writer(f)
        self.writers[name].writerow(header)

    def store(self, t, links, joints, contacts, forces):
        for cat in self.per_link:
            row = [t]
            for v in links.values():
                row.extend(v[cat])
            self.writers[cat].writerow(row)
        self.writers["joint_angles"].writerow([t] + [j["angle"] for j in joints.values()])
        self.writers["joint_velocities"].writerow([t] + [j["velocity"] for j in joints.values()])
        for kind in ("torque", "position", "velocity"):
            key = f"{kind}_actuator_force"
            self.writers[f"{kind}_actuator_forces"].writerow([t] + [j[key] for j in joints.values()])
        row = [t]
        for f in forces.values():
            row.extend(f)
        self.writers["external_contact_forces"].writerow(row)
        w = self.writers["contacts"]
        for c in contacts:
            w.writerow([t, c["geom1"], c["geom2"], *c["position"], c["distance"], c["normal_force"]])

    def close(self):
        for f in self.files.values():
            f.close()


def main():
    p = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    p.add_argument("model", help="model.xml written by SimSerpent into a run folder")
    p.add_argument("--duration-secs", type=float, default=20.0)
    p.add_argument("--out", default="original-style-csv", help="folder for the CSV files")
    p.add_argument("--amplitude-deg", type=float, default=30.0)
    p.add_argument("--frequency-hz", type=float, default=0.5)
    p.add_argument("--phase-lag-deg", type=float, default=40.0)
    p.add_argument("--ramp-secs", type=float, default=1.0)
    args = p.parse_args()

    model = mujoco.MjModel.from_xml_path(args.model)
    data = mujoco.MjData(model)
    info = SnakeInfo(model)
    if not info.actuators["position"]:
        sys.exit(f"{args.model}: no actuators named position_XX; is this a SimSerpent model.xml?")
    amplitude = math.radians(args.amplitude_deg)
    omega = 2.0 * math.pi * args.frequency_hz
    lag = math.radians(args.phase_lag_deg)
    positions = info.actuators["position"]

    # ctrl_snake.py: the control callback MuJoCo calls every timestep.
    def control(m, d):
        ramp = min(1.0, d.time / args.ramp_secs) if args.ramp_secs > 0 else 1.0
        for i, a in enumerate(positions):
            d.ctrl[a] = ramp * amplitude * math.sin(omega * d.time + i * lag)

    mujoco.set_mjcb_control(control)
    store = CsvStore(args.out, info)
    integrator = mujoco.mjtIntegrator(model.opt.integrator).name
    cone = mujoco.mjtCone(model.opt.cone).name
    print(
        f"{args.model}: {len(info.links)} links, {integrator}, dt {model.opt.timestep} s, {cone}, "
        f"{args.duration_secs} s",
        file=sys.stderr,
    )
    start = time.perf_counter()
    steps = 0
    n_steps = round(args.duration_secs / model.opt.timestep)
    # simulate_snake.py: the main loop until the configured time.
    while steps < n_steps:
        mujoco.mj_step(model, data)
        steps += 1
        store.store(
            data.time,
            info.get_link_info(data),
            info.get_joint_info(data),
            info.get_contact_info(data),
            info.get_force_info(data),
        )
    store.close()
    mujoco.set_mjcb_control(None)
    wall = time.perf_counter() - start
    print(f"{steps} steps in {wall:.2f} s ({steps / wall:.0f} steps/s)", file=sys.stderr)


if __name__ == "__main__":
    main()
