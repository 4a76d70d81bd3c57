#!/usr/bin/env python3
"""Interop: pyigtl 0.3.4 (PyPI, written by the SlicerIGT team, not here)
connects to an MR-SNS OpenIGTLink server and sends header-v2 messages with
metadata: TRANSFORM, IMAGE, STRING and POINT. The C++ side
(test_pyigtl_send.cpp) checks what it decoded against the values below.

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
    time.sleep(0.3)  # let the bytes leave before the client thread stops
    client.stop()
    print("sent 4 messages")
    return 0


if __name__ == "__main__":
    sys.exit(main())
