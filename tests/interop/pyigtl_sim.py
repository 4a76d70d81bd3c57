#!/usr/bin/env python3
"""Interop: pyigtl 0.3.4 (PyPI, written by the SlicerIGT team, not here)
receives the simulated operating room of the real `mrsns-sim run` process,
as Slicer would receive a PlusServer.

Scenario: sim_tracker_scenario.json (four still tools, 60 Hz, B-mode 320x240
at 25 Hz). The script starts `mrsns-sim run --any-ports --ready-file`, then:

1. Raw socket, pyigtl's decoders: for 3 s the PlusServer rule gives header v1
   (the client has sent nothing). Every message's CRC-64 is checked with
   pyigtl's CRC64, then decoded by pyigtl's TransformMessage/ImageMessage:
   every scenario tool at the scenario's rate (from the header timestamps and
   from the wall clock), each matrix rigid and where the scenario put the
   tool; IMAGE 'Image_Image' 8-bit, 1 component, size and spacing as the
   scenario says, at its frame rate.
2. Same socket: the script sends STT_TDATA with header v2 (packed by pyigtl's
   MessageBase.pack: extended header, CRC). From then on everything comes
   back as v2: RTS_TDATA, TDATA with every tool at the tracker's rate, and
   TRANSFORMs with the metadata TransformStatus=OK (pyigtl's v2 metadata
   decoder).
3. pyigtl's own client thread (OpenIGTLinkClient.wait_for_message): a
   TRANSFORM of each tool, the IMAGE, and TDATA.

TDATA: pyigtl 0.3.4 has no class for TDATA, STT_TDATA or RTS_TDATA (its
message_type_to_class_constructor knows TRANSFORM, IMAGE, STRING, POINT and
POSITION; its client silently drops other types). So the script adds
STT_TDATA and TDATA as small MessageBase subclasses (body layout from the
OpenIGTLink v2 TDATA spec) and registers TDATA in pyigtl's type table:
header, CRC, v2 extended header and metadata stay pyigtl's own code.

Exit 0 on success, 1 on failure (a message says what was wrong).
"""
import argparse
import json
import math
import os
import signal
import socket
import struct
import subprocess
import sys
import tempfile
import time

import numpy as np
import pyigtl
from pyigtl.messages import CRC64, MessageBase, message_type_to_class_constructor

HEADER_SIZE = 58
POSITION_TOLERANCE_MM = 3.0     # tracker noise is 0.12 mm RMS
ROTATION_TOLERANCE_DEG = 1.0    # tracker noise is 0.05 deg RMS
RATE_TOLERANCE = 0.1            # +-10 % of the scenario's rate


def fail(message):
    print("FAIL: " + message, flush=True)
    sys.exit(1)


class StartTrackingDataMessage(MessageBase):
    """STT_TDATA: int32 resolution (ms), char[32] coordinate name."""

    def __init__(self, resolution_ms=0, coordinate_name="", device_name="Tracker", header_version=1):
        MessageBase.__init__(self, device_name=device_name)
        self._message_type = "STT_TDATA"
        self.header_version = header_version
        self.resolution_ms = resolution_ms
        self.coordinate_name = coordinate_name
        self._valid_message = True

    def _pack_content(self):
        return struct.pack("> i 32s", self.resolution_ms, self.coordinate_name.encode("ascii"))


class TrackingDataMessage(MessageBase):
    """TDATA: per tool char[20] name, uint8 type, uint8 reserved, float32[12] (as TRANSFORM)."""

    ELEMENT = struct.Struct("> 20s B B 12f")

    def __init__(self):
        MessageBase.__init__(self)
        self._message_type = "TDATA"
        self.elements = {}

    def _unpack_content(self, content):
        if len(content) % self.ELEMENT.size != 0:
            raise ValueError("TDATA body of %d bytes is not a multiple of %d" % (len(content), self.ELEMENT.size))
        self.elements = {}
        for offset in range(0, len(content), self.ELEMENT.size):
            values = self.ELEMENT.unpack(content[offset:offset + self.ELEMENT.size])
            name = values[0].decode().rstrip("\0")
            v = values[3:]
            self.elements[name] = np.array([[v[0], v[3], v[6], v[9]],
                                            [v[1], v[4], v[7], v[10]],
                                            [v[2], v[5], v[8], v[11]],
                                            [0, 0, 0, 1]])
        self._valid_message = True


message_type_to_class_constructor["TDATA"] = TrackingDataMessage


def rotation_from_vector_deg(r):
    """Rotation matrix of a rotation vector in degrees (the scenario's 'rotation_deg')."""
    v = np.radians(np.asarray(r, dtype=float))
    angle = np.linalg.norm(v)
    if angle < 1e-12:
        return np.eye(3)
    k = v / angle
    kx = np.array([[0, -k[2], k[1]], [k[2], 0, -k[0]], [-k[1], k[0], 0]])
    return np.eye(3) + math.sin(angle) * kx + (1 - math.cos(angle)) * kx.dot(kx)


def expected_poses(scenario):
    poses = {}
    for tool in scenario["tools"]:
        start = tool["start"]
        pose = np.eye(4)
        pose[:3, :3] = rotation_from_vector_deg(start.get("rotation_deg", [0, 0, 0]))
        pose[:3, 3] = start["translation_mm"]
        poses[tool["name"]] = pose
    return poses


def check_pose(what, matrix, expected):
    m = np.asarray(matrix, dtype=float)
    r = m[:3, :3]
    orthogonality = np.abs(r.T.dot(r) - np.eye(3)).max()
    if orthogonality > 1e-4 or abs(np.linalg.det(r) - 1.0) > 1e-4:
        fail("%s: not a rigid transform (|R'R - I| = %g, det = %g)\n%s" % (what, orthogonality, np.linalg.det(r), m))
    if np.abs(m[3] - [0, 0, 0, 1]).max() > 1e-6:
        fail("%s: last row %s" % (what, m[3]))
    distance = np.linalg.norm(m[:3, 3] - expected[:3, 3])
    cos_angle = (np.trace(expected[:3, :3].T.dot(r)) - 1.0) / 2.0
    angle = math.degrees(math.acos(max(-1.0, min(1.0, cos_angle))))
    if distance > POSITION_TOLERANCE_MM or angle > ROTATION_TOLERANCE_DEG:
        fail("%s: %.2f mm and %.2f deg from where the scenario put it\n%s" % (what, distance, angle, m))
    return distance, angle


def check_image(what, message, ultrasound):
    width, height = ultrasound["width"], ultrasound["height"]
    sx, sy = ultrasound["spacing_mm"]
    image = message.image
    if image.dtype != np.uint8:
        fail("%s: pixels are %s, expected 8-bit (uint8)" % (what, image.dtype))
    if image.shape != (1, height, width):
        fail("%s: image shape (k, j, i) %s, expected (1, %d, %d)" % (what, image.shape, height, width))
    spacing = [np.linalg.norm(message.ijk_to_world_matrix[:3, i]) for i in range(3)]
    if abs(spacing[0] - sx) > 1e-4 or abs(spacing[1] - sy) > 1e-4:
        fail("%s: spacing %s mm, expected [%g, %g]" % (what, spacing, sx, sy))
    if int(image.max()) == int(image.min()):
        fail("%s: every pixel is %d (no B-mode content)" % (what, int(image.max())))
    return spacing


def receive_exactly(sock, n):
    data = bytearray()
    while len(data) < n:
        chunk = sock.recv(n - len(data))
        if not chunk:
            fail("connection closed after %d of %d bytes" % (len(data), n))
        data += chunk
    return bytes(data)


def receive_message(sock):
    """(header fields, body, receive time) of the next message, its CRC checked."""
    header = receive_exactly(sock, HEADER_SIZE)
    fields = MessageBase.parse_header(header)
    crc = struct.unpack("> Q", header[50:58])[0]
    body = receive_exactly(sock, fields["body_size"])
    if CRC64(body) != crc:
        fail("CRC-64 mismatch in %s '%s'" % (fields["message_type"], fields["device_name"]))
    return fields, body, time.monotonic()


def rate(stamps):
    if len(stamps) < 2 or stamps[-1] <= stamps[0]:
        return 0.0
    return (len(stamps) - 1) / (stamps[-1] - stamps[0])


def check_rate(what, measured, expected):
    if abs(measured - expected) > RATE_TOLERANCE * expected:
        fail("%s at %.1f Hz, the scenario says %.1f Hz" % (what, measured, expected))


def main():
    parser = argparse.ArgumentParser()
    parser.add_argument("--sim", required=True, help="path of mrsns-sim")
    parser.add_argument("--scenario", required=True, help="the scenario (sim_tracker_scenario.json)")
    args = parser.parse_args()
    from importlib.metadata import version
    print("pyigtl", version("pyigtl"), flush=True)

    with open(args.scenario) as f:
        scenario = json.load(f)
    poses = expected_poses(scenario)
    tracker_hz = scenario["tracker"]["rate_hz"]
    ultrasound = scenario["ultrasound"]
    image_name = ultrasound["device_name"]

    workdir = tempfile.mkdtemp(prefix="mrsns-pyigtl-sim-")
    ready_file = os.path.join(workdir, "ready.json")
    sim = subprocess.Popen(
        [args.sim, "run", "--scenario", args.scenario, "--truth", os.path.join(workdir, "truth.json"),
         "--any-ports", "--ready-file", ready_file, "--duration", "60", "--json"],
        stdout=subprocess.PIPE, stderr=subprocess.PIPE, text=True)
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
        port = int(ready["plus_port"])
        print("mrsns-sim ready: PlusServer on %s:%d" % (ready["host"], port), flush=True)

        # --- 1. header v1, pyigtl's decoders ---------------------------------------------------------------
        sock = socket.create_connection((ready["host"], port), timeout=5)
        stamps = {name: [] for name in poses}
        arrivals = {name: [] for name in poses}
        image_stamps = []
        worst = (0.0, 0.0)
        t_end = time.monotonic() + 3.0
        while time.monotonic() < t_end:
            fields, body, arrived = receive_message(sock)
            if fields["header_version"] != 1:
                fail("header version %d before the client sent anything (PlusServer sends v1 until then)"
                     % fields["header_version"])
            message = MessageBase.create_message(fields["message_type"])
            if message is None:
                fail("unexpected %s '%s' before STT_TDATA" % (fields["message_type"], fields["device_name"]))
            message.unpack(fields, body)
            if message.message_type == "TRANSFORM":
                if message.device_name not in poses:
                    fail("TRANSFORM of '%s', not a scenario tool (%s)" % (message.device_name, sorted(poses)))
                d, a = check_pose("TRANSFORM '%s'" % message.device_name, message.matrix, poses[message.device_name])
                worst = (max(worst[0], d), max(worst[1], a))
                stamps[message.device_name].append(message.timestamp)
                arrivals[message.device_name].append(arrived)
            elif message.message_type == "IMAGE":
                if message.device_name != image_name:
                    fail("IMAGE '%s', expected '%s'" % (message.device_name, image_name))
                spacing = check_image("IMAGE '%s'" % image_name, message, ultrasound)
                image_stamps.append(message.timestamp)
            else:
                fail("unexpected %s '%s'" % (message.message_type, message.device_name))
        for name in sorted(poses):
            if len(stamps[name]) < 10:
                fail("only %d TRANSFORM '%s' in 3 s" % (len(stamps[name]), name))
            check_rate("TRANSFORM '%s' (header timestamps)" % name, rate(stamps[name]), tracker_hz)
            check_rate("TRANSFORM '%s' (arrival)" % name, rate(arrivals[name]), tracker_hz)
            print("v1 TRANSFORM %-20s %4d messages, %.1f Hz by timestamps, %.1f Hz by arrival"
                  % ("'" + name + "'", len(stamps[name]), rate(stamps[name]), rate(arrivals[name])), flush=True)
        print("v1 TRANSFORM matrices rigid, at most %.2f mm / %.2f deg from the scenario's poses" % worst)
        if len(image_stamps) < 10:
            fail("only %d IMAGE '%s' in 3 s" % (len(image_stamps), image_name))
        check_rate("IMAGE '%s'" % image_name, rate(image_stamps), ultrasound["rate_hz"])
        print("v1 IMAGE '%s': %d frames, %.1f Hz, %dx%d uint8, spacing %.3f x %.3f mm"
              % (image_name, len(image_stamps), rate(image_stamps), ultrasound["width"], ultrasound["height"],
                 spacing[0], spacing[1]), flush=True)

        # --- 2. STT_TDATA with header v2: everything comes back as v2 ---------------------------------------
        sock.sendall(StartTrackingDataMessage(resolution_ms=0, header_version=2).pack())
        got_rts = False
        tdata_stamps = []
        v2_transforms = {name: 0 for name in poses}
        t_end = time.monotonic() + 3.0
        while time.monotonic() < t_end:
            fields, body, _ = receive_message(sock)
            kind = fields["message_type"]
            if fields["header_version"] != 2:
                # Messages queued before the server read our STT_TDATA still come as v1.
                if got_rts or tdata_stamps:
                    fail("%s '%s' with header v%d after the client spoke v2"
                         % (kind, fields["device_name"], fields["header_version"]))
                continue
            if kind == "RTS_TDATA":
                got_rts = True
                generic = MessageBase()
                generic.unpack(fields, body)  # v2 extended header, by pyigtl
                status = struct.unpack("> b", body[12:13])[0]
                if status != 0:
                    fail("RTS_TDATA status %d" % status)
                continue
            message = MessageBase.create_message(kind)
            if message is None:
                fail("unexpected %s '%s'" % (kind, fields["device_name"]))
            message.unpack(fields, body)
            if kind == "TDATA":
                if set(message.elements) != set(poses):
                    fail("TDATA '%s' has tools %s, expected every scenario tool %s"
                         % (message.device_name, sorted(message.elements), sorted(poses)))
                for name, matrix in message.elements.items():
                    check_pose("TDATA element '%s'" % name, matrix, poses[name])
                tdata_stamps.append(message.timestamp)
            elif kind == "TRANSFORM":
                if message.metadata.get("TransformStatus") != "OK":
                    fail("v2 TRANSFORM '%s' metadata %r, expected TransformStatus=OK"
                         % (message.device_name, message.metadata))
                check_pose("v2 TRANSFORM '%s'" % message.device_name, message.matrix, poses[message.device_name])
                v2_transforms[message.device_name] += 1
            elif kind == "IMAGE":
                check_image("v2 IMAGE '%s'" % message.device_name, message, ultrasound)
        sock.close()
        if not got_rts:
            fail("no RTS_TDATA answered STT_TDATA")
        if len(tdata_stamps) < 10:
            fail("only %d TDATA in 3 s after STT_TDATA" % len(tdata_stamps))
        check_rate("TDATA (resolution 0)", rate(tdata_stamps), tracker_hz)
        for name, count in v2_transforms.items():
            if count < 10:
                fail("only %d v2 TRANSFORM '%s' in 3 s" % (count, name))
        print("v2 after STT_TDATA: RTS_TDATA, %d TDATA with all %d tools at %.1f Hz, TRANSFORMs with "
              "TransformStatus=OK (%s)" % (len(tdata_stamps), len(poses), rate(tdata_stamps),
                                          ", ".join("%s %d" % kv for kv in sorted(v2_transforms.items()))),
              flush=True)

        # --- 3. pyigtl's own client thread ------------------------------------------------------------------
        client = pyigtl.OpenIGTLinkClient(host=ready["host"], port=port)
        try:
            for name in sorted(poses):
                message = client.wait_for_message(name, timeout=5)
                if message is None or message.message_type != "TRANSFORM":
                    fail("pyigtl client: no TRANSFORM '%s' within 5 s" % name)
                check_pose("pyigtl client TRANSFORM '%s'" % name, message.matrix, poses[name])
            message = client.wait_for_message(image_name, timeout=5)
            if message is None or message.message_type != "IMAGE":
                fail("pyigtl client: no IMAGE '%s' within 5 s" % image_name)
            check_image("pyigtl client IMAGE", message, ultrasound)
            client.send_message(StartTrackingDataMessage(resolution_ms=50), wait=True)
            message = client.wait_for_message("Tracker", timeout=5)
            if message is None or message.message_type != "TDATA":
                fail("pyigtl client: no TDATA 'Tracker' within 5 s of STT_TDATA")
            if set(message.elements) != set(poses):
                fail("pyigtl client: TDATA tools %s" % sorted(message.elements))
            print("pyigtl client: TRANSFORM of %d tools, IMAGE '%s', TDATA with %s"
                  % (len(poses), image_name, sorted(message.elements)), flush=True)
        finally:
            client.stop()
    finally:
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
    messages = summary["messages"]
    if summary["stopped_by"] != "signal" or messages["TRANSFORM"] == 0 or messages["IMAGE"] == 0 \
            or messages["TDATA"] == 0 or summary["clients_connected"] < 2:
        fail("mrsns-sim summary %r" % summary)
    print("mrsns-sim summary: %s, %d clients" % (messages, summary["clients_connected"]))
    print("PASS")


if __name__ == "__main__":
    main()
