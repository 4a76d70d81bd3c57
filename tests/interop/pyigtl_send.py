#!/usr/bin/env python3
"""Interop: pyigtl 0.3.4 (PyPI, written by the SlicerIGT team, not here)
connects to an MR-SNS OpenIGTLink server and sends header-v2 messages with
metadata: TRANSFORM, IMAGE, STRING and POINT. The C++ side
(test_pyigtl_send.cpp) checks what it decoded against the values below,
then answers with its own v2 IMAGE, STRING and POINT, which pyigtl must
decode to the values checked here (exit 1 with a message otherwise).

usage: pyigtl_send.py --port PORT
"""
import argparse
import sys
import time

import numpy as np
import pyigtl


def main():
    parser = argparse.ArgumentParser()
    parser.add_argument("--port", type=int, required=True)
    args = parser.parse_args()

    client = pyigtl.OpenIGTLinkClient(host="127.0.0.1", port=args.port, start_now=True)
    deadline = time.time() + 10
    while not client.is_connected() and time.time() < deadline:
        time.sleep(0.01)
    if not client.is_connected():
        print("FAIL: pyigtl could not connect to 127.0.0.1:%d" % args.port)
        return 1

    matrix = np.array([[0, -1, 0, 10.5], [1, 0, 0, -20.25], [0, 0, 1, 30.0], [0, 0, 0, 1]], dtype=float)
    transform = pyigtl.TransformMessage(matrix, device_name="PyProbeToTracker", timestamp=1700000000.5)
    transform.header_version = 2
    transform.metadata = {"Source": "pyigtl", "TransformStatus": "OK"}

    # (k, j, i) axes: 2 slices, 3 rows, 4 columns; value = 100*k + 10*j + i.
    voxels = np.fromfunction(lambda k, j, i: 100 * k + 10 * j + i, (2, 3, 4), dtype=int).astype(np.uint8)
    ijk_to_world = np.array([[0.5, 0, 0, 1.0], [0, 0.75, 0, 2.0], [0, 0, 2.0, 3.0], [0, 0, 0, 1]], dtype=float)
    image = pyigtl.ImageMessage(voxels, ijk_to_world_matrix=ijk_to_world, device_name="PyImage")
    image.header_version = 2
    image.metadata = {"Modality": "US"}

    string = pyigtl.StringMessage("hello from pyigtl", device_name="PyText")
    string.header_version = 2
    string.metadata = {"Language": "en"}

    point = pyigtl.PointMessage(positions=[[1.0, 2.0, 3.0], [-4.5, 5.5, 6.25]], names=["Entry", "Target"],
                                device_name="PyPoints")
    point.header_version = 2

    for message in (transform, image, string, point):
        client.send_message(message, wait=True)

    # The other direction: what the MR-SNS encoder sends back.
    failures = []
    reply_image = client.wait_for_message("MrsnsImage", timeout=10)
    reply_text = client.wait_for_message("MrsnsText", timeout=5)
    reply_points = client.wait_for_message("MrsnsPoints", timeout=5)
    client.stop()
    if reply_image is None or reply_text is None or reply_points is None:
        print("FAIL: missing replies from the MR-SNS server (image %s, text %s, points %s)" %
              (reply_image is not None, reply_text is not None, reply_points is not None))
        return 1
    expected = np.fromfunction(lambda k, j, i: 3 * k + 2 * j + i, (2, 2, 3), dtype=int).astype(np.uint8)
    got = np.squeeze(np.asarray(reply_image.image))
    if got.shape != expected.shape or not np.array_equal(got, expected):
        failures.append("IMAGE voxels %s, expected %s" % (got.tolist(), expected.tolist()))
    spacing = np.linalg.norm(np.asarray(reply_image.ijk_to_world_matrix)[0:3, 0:3], axis=0)
    if not np.allclose(spacing, [0.3, 0.4, 1.5], atol=1e-5):
        failures.append("IMAGE spacing %s, expected [0.3, 0.4, 1.5]" % spacing)
    if reply_image.metadata.get("Source") != "mrsns":
        failures.append("IMAGE metadata %s" % reply_image.metadata)
    if reply_text.string != "hello from mrsns":
        failures.append("STRING %r" % reply_text.string)
    if list(reply_points.names) != ["Nasion", "Tip"]:
        failures.append("POINT names %s" % reply_points.names)
    elif not np.allclose(np.asarray(reply_points.positions)[1], [7.5, -8.0, 9.25]):
        failures.append("POINT positions %s" % reply_points.positions)
    if failures:
        print("FAIL: " + "; ".join(failures))
        return 1
    print("sent 4 messages, received and checked 3")
    return 0


if __name__ == "__main__":
    sys.exit(main())
