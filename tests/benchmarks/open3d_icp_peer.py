#!/usr/bin/env python3
"""Open3D's point-to-plane ICP, the peer of bench_icp.cpp, on the same problem.

Usage: open3d_icp_peer.py MESH MOVING_CSV INITIAL_4x4_TXT SAMPLES MAX_DISTANCE_MM SEED

The surface is sampled uniformly (SAMPLES points, with the triangles'
normals) before the clock starts, as a user of Open3D would prepare a target
cloud once; the timed part is what registration_icp does (its k-d tree build
included). Prints one JSON object: seconds, the 4x4 fixed_T_moving, Open3D's
own inlier RMSE (point to sampled point) and fitness, and the version.
"""
import json
import sys
import time

import numpy as np
import open3d as o3d


def main() -> int:
    if len(sys.argv) != 7:
        print(__doc__, file=sys.stderr)
        return 2
    mesh_path, moving_path, initial_path = sys.argv[1:4]
    samples, max_distance, seed = int(sys.argv[4]), float(sys.argv[5]), int(sys.argv[6])
    o3d.utility.random.seed(seed)
    mesh = o3d.io.read_triangle_mesh(mesh_path)
    if len(mesh.triangles) == 0:
        print(f"{mesh_path}: no triangles", file=sys.stderr)
        return 1
    mesh.compute_triangle_normals()
    target = mesh.sample_points_uniformly(number_of_points=samples, use_triangle_normal=True)
    moving = np.loadtxt(moving_path, delimiter=",", skiprows=1)
    source = o3d.geometry.PointCloud(o3d.utility.Vector3dVector(moving))
    initial = np.loadtxt(initial_path)
    reg = o3d.pipelines.registration
    t0 = time.perf_counter()
    result = reg.registration_icp(source, target, max_distance, initial,
                                  reg.TransformationEstimationPointToPlane(),
                                  reg.ICPConvergenceCriteria(max_iteration=100))
    seconds = time.perf_counter() - t0
    print(json.dumps({
        "seconds": seconds,
        "fixed_T_moving": np.asarray(result.transformation).tolist(),
        "inlier_rmse_mm": result.inlier_rmse,
        "fitness": result.fitness,
        "open3d": o3d.__version__,
    }))
    return 0


if __name__ == "__main__":
    sys.exit(main())
