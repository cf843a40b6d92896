"""Write one simulated 3-axis IMU log in the formats other tools produce, to try gyrotest's
readers on (the files are not kept in the repository: they are binary and large).

    python sample_data/make_imu_files.py OUTDIR [--minutes 10] [--rate 100]

writes, from the same samples:

* ``OUTDIR/imu.bag``: a ROS 1 bag, topic ``/imu/data``, ``sensor_msgs/Imu`` (rad/s, m/s²),
  written with rosbags' own writer (``pip install 'gyrotest[ros]'``);
* ``OUTDIR/imu_mcap/``: the same as a ROS 2 bag in MCAP storage;
* ``OUTDIR/imu.mat``: a MATLAB file (``scipy.io.savemat``) with a vector ``t`` (s) and an N×3
  matrix ``gyro`` (rad/s) → columns ``gyro_x/_y/_z``;
* ``OUTDIR/imu.csv.gz``: the same as gzip'd CSV.

Truth: white rate noise of N = 0.3 deg/√h (angle random walk) on every axis plus constant
biases of 20, −35 and 50 deg/h; 100 Hz, header stamps from 2024-05-20 10:13:20 UTC.
"""

from __future__ import annotations

import argparse
import gzip
import math
from pathlib import Path

import numpy as np

ARW_DEG_SQRT_H = 0.3
BIAS_DPH = (20.0, -35.0, 50.0)
T0_NS = 1_716_200_000 * 10**9
DPH = math.pi / 180.0 / 3600.0  # rad/s per deg/h


def samples(minutes: float, rate_hz: float, seed: int = 12):
    n = int(round(minutes * 60 * rate_hz))
    rng = np.random.default_rng(seed)
    # white rate noise: σ per sample = N[deg/s/√Hz]·√fs, N[deg/s/√Hz] = N[deg/√h]/60
    sigma = ARW_DEG_SQRT_H / 60.0 * math.sqrt(rate_hz) * math.pi / 180.0  # rad/s
    g = rng.normal(0.0, sigma, (n, 3)) + np.array(BIAS_DPH) * DPH
    ns = T0_NS + np.round(np.arange(n) * 1e9 / rate_hz).astype(np.int64)
    acc = np.tile([0.02, -0.01, 9.81], (n, 1)) + rng.normal(0, 0.01, (n, 3))
    return ns, g, acc


def write_bags(out: Path, ns, g, acc) -> None:
    from rosbags.rosbag1 import Writer as Writer1
    from rosbags.rosbag2 import StoragePlugin
    from rosbags.rosbag2 import Writer as Writer2
    from rosbags.typesys import Stores, get_typestore

    imu = "sensor_msgs/msg/Imu"
    for ros1, path in ((True, out / "imu.bag"), (False, out / "imu_mcap")):
        store = get_typestore(Stores.ROS1_NOETIC if ros1 else Stores.ROS2_HUMBLE)
        T = store.types
        w = Writer1(path) if ros1 else Writer2(path, version=9,
                                               storage_plugin=StoragePlugin.MCAP)
        ser = store.serialize_ros1 if ros1 else store.serialize_cdr
        v3, q = T["geometry_msgs/msg/Vector3"], T["geometry_msgs/msg/Quaternion"]
        with w:
            conn = w.add_connection("/imu/data", imu, typestore=store)
            for i, t in enumerate(ns.tolist()):
                stamp = T["builtin_interfaces/msg/Time"](sec=t // 10**9, nanosec=t % 10**9)
                header = T["std_msgs/msg/Header"](**({"seq": i} if ros1 else {}), stamp=stamp,
                                                   frame_id="imu_link")
                msg = T[imu](header=header, orientation=q(x=0.0, y=0.0, z=0.0, w=1.0),
                             orientation_covariance=np.zeros(9),
                             angular_velocity=v3(x=g[i, 0], y=g[i, 1], z=g[i, 2]),
                             angular_velocity_covariance=np.zeros(9),
                             linear_acceleration=v3(x=acc[i, 0], y=acc[i, 1], z=acc[i, 2]),
                             linear_acceleration_covariance=np.zeros(9))
                w.write(conn, t, ser(msg, imu))


def main(argv=None) -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("outdir", type=Path)
    ap.add_argument("--minutes", type=float, default=10.0)
    ap.add_argument("--rate", type=float, default=100.0, help="sample rate, Hz")
    a = ap.parse_args(argv)
    a.outdir.mkdir(parents=True, exist_ok=True)
    for old in ("imu.bag", "imu.mat", "imu.csv.gz"):
        (a.outdir / old).unlink(missing_ok=True)
    if (a.outdir / "imu_mcap").exists():
        import shutil

        shutil.rmtree(a.outdir / "imu_mcap")
    ns, g, acc = samples(a.minutes, a.rate)
    import scipy.io

    scipy.io.savemat(a.outdir / "imu.mat", {"t": (ns - ns[0]) * 1e-9, "gyro": g},
                     do_compression=True)
    with gzip.open(a.outdir / "imu.csv.gz", "wt") as fh:
        fh.write("time_ns,gx_rps,gy_rps,gz_rps\n")
        for t, row in zip(ns.tolist(), g):
            fh.write(f"{t},{row[0]:.9e},{row[1]:.9e},{row[2]:.9e}\n")
    files = ["imu.mat", "imu.csv.gz"]
    try:
        write_bags(a.outdir, ns, g, acc)
        files = ["imu.bag", "imu_mcap/", *files]
    except ImportError:
        print("rosbags is not installed (pip install 'gyrotest[ros]'): no bags written")
    print(f"wrote {len(ns):,} samples to {a.outdir}/ ({', '.join(files)})")


if __name__ == "__main__":
    main()
