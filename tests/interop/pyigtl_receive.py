#!/usr/bin/env python3
"""Interop: pyigtl 0.3.4 (PyPI; OpenIGTLink v2 with metadata, written by the
SlicerIGT team, not here) receives the hologram stream of `mrsns-cli serve`.

pyigtl 0.3.4 decodes TRANSFORM, IMAGE, STRING, POINT and POSITION. It has a
PolyDataMessage class, but its client does not register POLYDATA for
receiving and its decoder is marked untested and fails on any input. So the
POLYDATA (model) message is checked with pyigtl's header parser, its CRC-64
and its generic v2 unpacking (extended header, metadata), and the TRANSFORMs
with pyigtl's full decoder and its own client thread.

Exit 0 on success, 1 on failure (a message says what was wrong).
"""
import argparse
import json
import os
import signal
import socket
import struct
import subprocess
import sys
import tempfile
import time

import pyigtl
from pyigtl.messages import CRC64, MessageBase

HEADER_SIZE = 58


def fail(message):
    print("FAIL: " + message)
    sys.exit(1)


def free_port():
    s = socket.socket()
    s.bind(("127.0.0.1", 0))
    port = s.getsockname()[1]
    s.close()
    return port


def write_tetrahedron(path):
    v = [(0, 0, 0), (10, 0, 0), (0, 10, 0), (0, 0, 10)]
    faces = [(0, 2, 1), (0, 1, 3), (0, 3, 2), (1, 2, 3)]
    with open(path, "w") as f:
        f.write("solid tetra\n")
        for a, b, c in faces:
            f.write("facet normal 0 0 0\nouter loop\n")
            for i in (a, b, c):
                f.write("vertex %g %g %g\n" % v[i])
            f.write("endloop\nendfacet\n")
        f.write("endsolid tetra\n")


def receive_exactly(sock, n):
    data = b""
    while len(data) < n:
        chunk = sock.recv(n - len(data))
        if not chunk:
            fail("connection closed after %d of %d bytes" % (len(data), n))
        data += chunk
    return data


def main():
    parser = argparse.ArgumentParser()
    parser.add_argument("--cli", required=True, help="path of mrsns-cli")
    args = parser.parse_args()
    from importlib.metadata import version
    print("pyigtl", version("pyigtl"))

    workdir = tempfile.mkdtemp(prefix="mrsns-pyigtl-")
    model = os.path.join(workdir, "Vertebra.stl")
    write_tetrahedron(model)
    port = free_port()
    serve = subprocess.Popen(
        [args.cli, "serve", "--port", str(port), "--source", "simulator", "--rate", "100", "--models", model,
         "--igtl-version", "2", "--duration", "30", "--json"],
        stdout=subprocess.PIPE, stderr=subprocess.PIPE, text=True)
    try:
        sock = None
        for _ in range(500):
            try:
                sock = socket.create_connection(("127.0.0.1", port), timeout=5)
                break
            except OSError:
                time.sleep(0.01)
        if sock is None:
            fail("serve did not listen on port %d" % port)

        # Raw socket, decoded by pyigtl: the model first, then transforms.
        transforms = 0
        first = None
        while transforms < 30:
            header = receive_exactly(sock, HEADER_SIZE)
            fields = MessageBase.parse_header(header)
            crc = struct.unpack("> Q", header[50:58])[0]
            body = receive_exactly(sock, fields["body_size"])
            if CRC64(body) != crc:
                fail("CRC-64 mismatch in %s '%s'" % (fields["message_type"], fields["device_name"]))
            if fields["header_version"] != 2:
                fail("header version %d, expected 2" % fields["header_version"])
            if first is None:
                first = fields["message_type"]
                if first != "POLYDATA" or fields["device_name"] != "Vertebra":
                    fail("first message is %s '%s', expected POLYDATA 'Vertebra'" % (first, fields["device_name"]))
                generic = MessageBase()
                generic.unpack(fields, body)  # extended header and metadata, by pyigtl
                if generic.metadata.get("Units") != "mm" or generic.metadata.get("Frame") != "Reference":
                    fail("POLYDATA metadata %r" % generic.metadata)
                points = struct.unpack("> I", body[12:16])[0]  # first field after the 12-byte extended header
                if points != 4:
                    fail("POLYDATA has %d points, expected 4" % points)
                print("POLYDATA 'Vertebra': 4 points, metadata", generic.metadata)
                continue
            message = MessageBase.create_message(fields["message_type"])
            if message is None:
                fail("unexpected message type %s" % fields["message_type"])
            message.unpack(fields, body)
            if fields["message_type"] == "TRANSFORM":
                z = float(message.matrix[2, 3])
                if message.device_name != "Vertebra" or abs(z + 1000.0) > 5.0:
                    fail("TRANSFORM '%s' z = %f, expected 'Vertebra' near -1000 mm" % (message.device_name, z))
                transforms += 1
        sock.close()
        print("raw socket: POLYDATA then %d TRANSFORM, all CRCs valid" % transforms)

        # pyigtl's own client (its receive thread and decoder).
        client = pyigtl.OpenIGTLinkClient(host="127.0.0.1", port=port)
        message = client.wait_for_message("Vertebra", timeout=5)
        client.stop()
        if message is None or message.message_type != "TRANSFORM":
            fail("pyigtl client received no TRANSFORM 'Vertebra' within 5 s")
        if abs(float(message.matrix[2, 3]) + 1000.0) > 5.0:
            fail("pyigtl client TRANSFORM z = %f" % float(message.matrix[2, 3]))
        print("pyigtl client: TRANSFORM 'Vertebra' z = %.2f mm" % float(message.matrix[2, 3]))
    finally:
        if serve.poll() is None:
            serve.send_signal(signal.SIGTERM)
        out, err = serve.communicate(timeout=10)
    if serve.returncode != 0:
        fail("serve exited with %d: %s" % (serve.returncode, err.strip()))
    summary = json.loads(out)
    if summary["clients"] < 2 or summary["meshes_queued"] < 2:
        fail("serve summary %r" % summary)
    print("serve summary: %d messages sent to %d clients" % (summary["messages_sent"], summary["clients"]))
    print("PASS")


if __name__ == "__main__":
    main()
