#!/usr/bin/env python3
"""Interop: ur_rtde (PyPI 'ur-rtde', SDU Robotics' C++ library with Python
bindings, used by many labs with real URs; not written here) against the UR
controller of the real `mrsns-sim run` process.

ur_rtde's RTDEReceiveInterface always connects to port 30004 (it has no port
option), so sim_ur_scenario.json puts the controller on the default ports and
the CTest test holds RESOURCE_LOCK ur_default_ports.

Checks, through ur_rtde's own classes only:
- RTDEReceiveInterface (its default recipe of 50-odd outputs at 500 Hz, as a
  lab's script gets it): the joints are the scenario's start_joints_deg, the
  TCP pose is the UR5's forward kinematics of them (computed here from UR's
  published DH table, not by the simulator's code), robot mode RUNNING,
  safety mode NORMAL, no stop; the controller clock advances in real time.
- DashboardClient on 29999: connect, PolyScope version (parsed by ur_rtde),
  isInRemoteControl, robot model, serial number, program state, robotmode,
  safetystatus; power off / power on / brake release, each seen on RTDE.

Exit 0 on success, 1 on failure (a message says what was wrong).
"""
import argparse
import json
import math
import os
import signal
import subprocess
import sys
import tempfile
import time

import numpy as np
import rtde_receive
from dashboard_client import DashboardClient

ROBOT_MODE = {3: "POWER_OFF", 4: "POWER_ON", 5: "IDLE", 7: "RUNNING"}

# UR5 (CB3 and e-Series share the layout): d1, a2, a3, d4, d5, d6 in metres, alpha (Universal Robots' DH table).
UR5_D = [0.089159, 0.0, 0.0, 0.10915, 0.09465, 0.0823]
UR5_A = [0.0, -0.425, -0.39225, 0.0, 0.0, 0.0]
UR5_ALPHA = [math.pi / 2, 0.0, 0.0, math.pi / 2, -math.pi / 2, 0.0]


def fail(message):
    print("FAIL: " + message, flush=True)
    sys.exit(1)


def forward_kinematics(q):
    t = np.eye(4)
    for i in range(6):
        ct, st = math.cos(q[i]), math.sin(q[i])
        ca, sa = math.cos(UR5_ALPHA[i]), math.sin(UR5_ALPHA[i])
        t = t.dot(np.array([[ct, -st * ca, st * sa, UR5_A[i] * ct],
                            [st, ct * ca, -ct * sa, UR5_A[i] * st],
                            [0, sa, ca, UR5_D[i]],
                            [0, 0, 0, 1]]))
    return t


def rotation_from_vector(r):
    r = np.asarray(r, dtype=float)
    angle = np.linalg.norm(r)
    if angle < 1e-12:
        return np.eye(3)
    k = r / angle
    kx = np.array([[0, -k[2], k[1]], [k[2], 0, -k[0]], [-k[1], k[0], 0]])
    return np.eye(3) + math.sin(angle) * kx + (1 - math.cos(angle)) * kx.dot(kx)


def wait_for(what, predicate, timeout=2.0):
    deadline = time.monotonic() + timeout
    while time.monotonic() < deadline:
        if predicate():
            return
        time.sleep(0.01)
    fail("timed out waiting for " + what)


def main():
    parser = argparse.ArgumentParser()
    parser.add_argument("--sim", required=True, help="path of mrsns-sim")
    parser.add_argument("--scenario", required=True, help="the scenario (sim_ur_scenario.json)")
    args = parser.parse_args()
    from importlib.metadata import version
    print("ur_rtde", version("ur_rtde"), flush=True)

    with open(args.scenario) as f:
        scenario = json.load(f)
    q_expected = np.radians(scenario["robot"]["start_joints_deg"])

    workdir = tempfile.mkdtemp(prefix="mrsns-ur-rtde-sim-")
    ready_file = os.path.join(workdir, "ready.json")
    sim = subprocess.Popen(
        [args.sim, "run", "--scenario", args.scenario, "--truth", os.path.join(workdir, "truth.json"),
         "--ready-file", ready_file, "--duration", "60", "--json"],
        stdout=subprocess.PIPE, stderr=subprocess.PIPE, text=True)
    receiver = None
    dashboard = None
    try:
        deadline = time.monotonic() + 60
        while not os.path.exists(ready_file):
            if sim.poll() is not None:
                fail("mrsns-sim exited with %d before it was ready: %s" % (sim.returncode, sim.stderr.read().strip()))
            if time.monotonic() > deadline:
                fail("mrsns-sim wrote no ready file within 60 s")
            time.sleep(0.02)
        with open(ready_file) as f:
            ready = json.load(f)
        robot = ready.get("robot")
        if not robot or robot["rtde"] != 30004 or robot["dashboard"] != 29999:
            fail("the UR controller is not on 30004/29999 (ready file %r); ur_rtde cannot reach it" % ready)
        host = ready["host"]
        print("mrsns-sim ready: UR controller on %s, ports %s" % (host, robot), flush=True)

        # --- RTDE receive -----------------------------------------------------------------------------------
        receiver = rtde_receive.RTDEReceiveInterface(host)
        if not receiver.isConnected():
            fail("RTDEReceiveInterface did not connect")
        wait_for("the first RTDE data package", lambda: receiver.getTimestamp() > 0)
        q = np.array(receiver.getActualQ())
        if q.shape != (6,) or np.abs(q - q_expected).max() > 1e-3:
            fail("actual_q %s rad, the scenario's start_joints_deg give %s" % (q, q_expected))
        target_q = np.array(receiver.getTargetQ())
        if np.abs(target_q - q_expected).max() > 1e-3:
            fail("target_q %s rad, expected %s" % (target_q, q_expected))
        pose = np.array(receiver.getActualTCPPose())
        fk = forward_kinematics(q_expected)
        position_error = np.linalg.norm(pose[:3] - fk[:3, 3])
        r = rotation_from_vector(pose[3:])
        angle_error = math.degrees(math.acos(max(-1.0, min(1.0, (np.trace(fk[:3, :3].T.dot(r)) - 1) / 2))))
        if position_error > 1e-3 or angle_error > 0.1:
            fail("actual_TCP_pose %s is %.2f mm / %.3f deg from the UR5's forward kinematics %s"
                 % (pose, position_error * 1e3, angle_error, fk[:3, 3]))
        mode = receiver.getRobotMode()
        if mode != 7:
            fail("robot_mode %d (%s), expected 7 RUNNING" % (mode, ROBOT_MODE.get(mode, "?")))
        if receiver.getSafetyMode() != 1:
            fail("safety_mode %d, expected 1 NORMAL" % receiver.getSafetyMode())
        if receiver.isProtectiveStopped() or receiver.isEmergencyStopped():
            fail("RTDE reports a protective or emergency stop")
        if len(receiver.getJointTemperatures()) != 6 or len(receiver.getActualTCPSpeed()) != 6:
            fail("joint_temperatures / actual_TCP_speed are not 6-vectors")
        t0, w0 = receiver.getTimestamp(), time.monotonic()
        time.sleep(1.0)
        t1, w1 = receiver.getTimestamp(), time.monotonic()
        clock_ratio = (t1 - t0) / (w1 - w0)
        if abs(clock_ratio - 1.0) > 0.1:
            fail("the controller clock advanced %.3f s in %.3f s of wall time" % (t1 - t0, w1 - w0))
        print("RTDE: actual_q = start_joints (max error %.2e rad), TCP pose within %.3f mm / %.4f deg of UR5 FK, "
              "robot_mode RUNNING, safety NORMAL, controller clock %.3f s per s"
              % (np.abs(q - q_expected).max(), position_error * 1e3, angle_error, clock_ratio), flush=True)

        # --- Dashboard --------------------------------------------------------------------------------------
        dashboard = DashboardClient(host)
        dashboard.connect()
        if not dashboard.isConnected():
            fail("DashboardClient did not connect")
        polyscope = dashboard.polyscopeVersion()
        if not polyscope.startswith("5."):
            fail("polyscopeVersion() = %r, expected an e-Series 5.x.y.z" % polyscope)
        remote = dashboard.isInRemoteControl()  # parses the PolyScope version itself (needs 5.6 or later)
        if not remote:
            fail("isInRemoteControl() is false: a lab's RTDEControlInterface would refuse to start")
        model = dashboard.getRobotModel()
        if model != "UR5":
            fail("getRobotModel() = %r, expected 'UR5'" % model)
        serial = dashboard.getSerialNumber()
        program_state = dashboard.programState()
        if dashboard.robotmode() != "Robotmode: RUNNING":
            fail("robotmode() = %r" % dashboard.robotmode())
        if dashboard.safetystatus() != "Safetystatus: NORMAL":
            fail("safetystatus() = %r" % dashboard.safetystatus())
        print("dashboard: PolyScope %s, remote control %s, model %s, serial %s, program state %r"
              % (polyscope, remote, model, serial, program_state), flush=True)

        dashboard.powerOff()
        wait_for("robot_mode POWER_OFF after powerOff()", lambda: receiver.getRobotMode() == 3)
        if dashboard.robotmode() != "Robotmode: POWER_OFF":
            fail("robotmode() after powerOff() = %r" % dashboard.robotmode())
        dashboard.powerOn()
        wait_for("robot_mode IDLE after powerOn()", lambda: receiver.getRobotMode() == 5)
        dashboard.brakeRelease()
        wait_for("robot_mode RUNNING after brakeRelease()", lambda: receiver.getRobotMode() == 7)
        if dashboard.robotmode() != "Robotmode: RUNNING":
            fail("robotmode() after brakeRelease() = %r" % dashboard.robotmode())
        dashboard.closeSafetyPopup()
        print("dashboard: powerOff -> RTDE robot_mode 3, powerOn -> 5, brakeRelease -> 7", flush=True)
        dashboard.disconnect()
        dashboard = None
        receiver.disconnect()
        receiver = None
    finally:
        if dashboard is not None:
            dashboard.disconnect()
        if receiver is not None:
            receiver.disconnect()
        if sim.poll() is None:
            sim.send_signal(signal.SIGTERM)
        try:
            out, err = sim.communicate(timeout=20)
        except subprocess.TimeoutExpired:
            sim.kill()
            out, err = sim.communicate()
    if sim.returncode != 0:
        fail("mrsns-sim exited with %d after SIGTERM: %s" % (sim.returncode, err.strip()))
    summary = json.loads(out)
    if summary["stopped_by"] != "signal":
        fail("mrsns-sim summary %r" % summary)
    print("PASS")


if __name__ == "__main__":
    main()
