"""Readers for files written by other programs: MATLAB (scipy.io.savemat; v7.3 as h5py
writes it), HDF5 (h5py), ROS 1/2 bags and MCAP (rosbags' own writers), gzip'd text; the
delta-angle / cumulative-angle output kinds; ``gyrotest columns``. Every malformed variant is
a one-line error, exit 2."""

from __future__ import annotations

import gzip
import json
import math

import numpy as np
import pytest

from gyrotest.io.ingest import read_log

from cliutil import run_cli

RAD_S_TO_DPH = 180.0 / math.pi * 3600.0
N, FS = 4000, 100.0


def _signals(seed=5, n=N):
    rng = np.random.default_rng(seed)
    t = np.arange(n) / FS
    g = rng.normal(0.0, 1e-3, (n, 3)) + np.array([1e-4, -2e-4, 3e-4])  # rad/s
    return t, g


def _csv(path, cols: dict):
    names = list(cols)
    rows = zip(*cols.values())
    path.write_text(",".join(names) + "\n" + "".join(
        ",".join(repr(int(v)) if isinstance(v, (int, np.integer)) else f"{v:.17g}"
                 for v in r) + "\n" for r in rows))
    return path


def _allan_tables(path, *extra):
    r = run_cli(["allan", path, "--json", *extra])
    assert r.code == 0, r.err
    d = json.loads(r.out)
    return {a["axis"]: a["table"] for a in d["logs"][0]["axes"]}


# ----------------------------------------------------------------------------- MATLAB
def test_mat_vectors_equal_csv_and_allan(tmp_path):
    sio = pytest.importorskip("scipy.io")
    t, g = _signals()
    p = tmp_path / "log.mat"
    sio.savemat(p, {"t": t[:, None], "gx": g[:, 0], "gy": g[:, 1][None, :], "gz": g[:, 2],
                    "calib": np.array([1.0, 2.0, 3.0]), "fs": FS, "who": "bench 3"})
    log = read_log(p, overrides={"gyro": {"rate_unit": "rad/s"}})
    assert log.axes == ["gx", "gy", "gz"]
    np.testing.assert_array_equal(log.rates["gy"], g[:, 1] * RAD_S_TO_DPH)
    assert log.tau0 == pytest.approx(1 / FS)
    assert any("calib" in n for n in log.notes)
    c = _csv(tmp_path / "log.csv", {"t": t, "gx": g[:, 0], "gy": g[:, 1], "gz": g[:, 2]})
    assert _allan_tables(p, "--rate-unit", "rad/s") == _allan_tables(c, "--rate-unit", "rad/s")


@pytest.mark.parametrize("fmt", ["4", "5"])
def test_mat_matrix_names_hint_struct_and_v4(tmp_path, fmt):
    sio = pytest.importorskip("scipy.io")
    t, g = _signals()
    p = tmp_path / "m.mat"
    if fmt == "4":  # v4 has no cells or structs: a plain N×4 matrix → data_1..data_4
        sio.savemat(p, {"data": np.column_stack([t, g])}, format="4")
        log = read_log(p, overrides={"columns": {"time": "data_1", "rate": ["data_3"]},
                                     "gyro": {"rate_unit": "rad/s"}})
        np.testing.assert_array_equal(log.rates["data_3"], g[:, 1] * RAD_S_TO_DPH)
        return
    sio.savemat(p, {"data": np.column_stack([t, g]),
                    "data_names": np.array(["time", "wx", "wy", "wz"], dtype=object)})
    log = read_log(p, overrides={"gyro": {"rate_unit": "rad/s"}})
    assert log.axes == ["wx", "wy", "wz"]
    np.testing.assert_array_equal(log.rates["wz"], g[:, 2] * RAD_S_TO_DPH)
    # a struct holding the log: read when it is the only variable, or named with --topic
    s = tmp_path / "s.mat"
    sio.savemat(s, {"imu": {"time": t, "gyro": g, "temp": 25 + 0 * t}})
    log = read_log(s, overrides={"gyro": {"rate_unit": "rad/s"}})
    assert log.axes == ["gyro_x", "gyro_y", "gyro_z"]
    np.testing.assert_array_equal(log.rates["gyro_y"], g[:, 1] * RAD_S_TO_DPH)
    assert "temp" in log.temperature
    s2 = tmp_path / "s2.mat"
    sio.savemat(s2, {"imu": {"t": t, "gz": g[:, 2]}, "other": {"x": t}})
    r = run_cli(["info", s2, "--topic", "imu", "--rate-unit", "rad/s", "--json"])
    assert r.code == 0, r.err
    assert json.loads(r.out)["axes"] == ["gz"]
    run_cli(["info", s2, "--topic", "nope", "--rate-unit", "rad/s"]).assert_clean_error(
        "no struct 'nope'", "imu")


def _mat73(path, datasets: dict, group: str | None = None):
    h5py = pytest.importorskip("h5py")
    with h5py.File(path, "w", userblock_size=512) as f:
        base = f
        if group:
            base = f.create_group(group)
            base.attrs["MATLAB_class"] = np.bytes_("struct")
        for k, v in datasets.items():
            d = base.create_dataset(k, data=np.atleast_2d(v).T.T if v.ndim == 1 else v.T)
            d.attrs["MATLAB_class"] = np.bytes_("double")
        c = f.create_dataset("label", data=np.frombuffer("abc".encode("utf-16-le"), np.uint16))
        c.attrs["MATLAB_class"] = np.bytes_("char")
    with open(path, "r+b") as fh:  # the header MATLAB writes in the 512-byte user block
        fh.write(b"MATLAB 7.3 MAT-file, Platform: GLNXA64, HDF5 schema 1.00 .".ljust(116)
                 + b"\0" * 8 + b"\x00\x02IM")


def test_mat_v73_transposed_matrix_and_struct(tmp_path):
    t, g = _signals()
    p = tmp_path / "v73.mat"
    _mat73(p, {"t": t, "gyro": g})  # MATLAB stores N×3 as 3×N in HDF5
    log = read_log(p, overrides={"gyro": {"rate_unit": "rad/s"}})
    assert log.axes == ["gyro_x", "gyro_y", "gyro_z"]
    for i, a in enumerate(log.axes):
        np.testing.assert_array_equal(log.rates[a], g[:, i] * RAD_S_TO_DPH)
    s = tmp_path / "s73.mat"
    _mat73(s, {"time": t, "wx": g[:, 0]}, group="imu")
    log = read_log(s, overrides={"gyro": {"rate_unit": "rad/s"}})
    assert log.axes == ["wx"]
    np.testing.assert_array_equal(log.rates["wx"], g[:, 0] * RAD_S_TO_DPH)


def test_mat_malformed(tmp_path):
    sio = pytest.importorskip("scipy.io")
    t, g = _signals()
    ok = tmp_path / "ok.mat"
    sio.savemat(ok, {"t": t, "gx": g[:, 0]})
    cut = tmp_path / "cut.mat"
    cut.write_bytes(ok.read_bytes()[: ok.stat().st_size // 2])
    run_cli(["info", cut, "--rate-unit", "rad/s"]).assert_clean_error(
        "cut.mat", "not a readable MATLAB file")
    junk = tmp_path / "junk.mat"
    junk.write_bytes(b"\x00\x01garbage" * 50)
    run_cli(["info", junk]).assert_clean_error("junk.mat", "MATLAB")
    none = tmp_path / "none.mat"
    sio.savemat(none, {"name": "bench", "k": 3.0})
    run_cli(["info", none]).assert_clean_error("none.mat", "no numeric vector")
    odd = tmp_path / "odd.mat"
    sio.savemat(odd, {"t": t, "gx": g[:, 0], "gy": g[:-7, 1]})
    run_cli(["info", odd, "--rate-unit", "rad/s"]).assert_clean_error(
        "odd.mat", "different lengths", "'gy'", "3,993")
    run_cli(["info", ok]).assert_clean_error("ok.mat", "--rate-unit")  # .mat has no units


# ----------------------------------------------------------------------------- HDF5
def test_hdf5_units_attribute_group_and_compound(tmp_path):
    h5py = pytest.importorskip("h5py")
    t, g = _signals()
    p = tmp_path / "log.h5"
    with h5py.File(p, "w") as f:
        imu = f.create_group("imu")
        imu["time"] = t
        d = imu.create_dataset("gyro", data=g * 180 / math.pi)
        d.attrs["units"] = "deg/s"  # the file states the unit: no --rate-unit needed
        gps = f.create_group("gps")
        gps["time"] = t[::100]
        gps["lat"] = t[::100] * 0 + 48.1
    r = run_cli(["info", p, "--topic", "imu", "--json"])
    assert r.code == 0, r.err
    log = read_log(p, overrides={"columns": {"topic": "imu"}})
    np.testing.assert_allclose(log.rates["gyro_z"], g[:, 2] * RAD_S_TO_DPH, rtol=1e-13)
    assert log.units["gyro_z"] == "deg/s"
    # without --topic: two groups of different lengths, the short one is left out
    log2 = read_log(p)
    assert log2.n == N and any("left out" in n for n in log2.notes)
    run_cli(["info", p, "--topic", "nope"]).assert_clean_error("no group 'nope'", "imu", "gps")
    tab = np.zeros(N, dtype=[("time", "f8"), ("gx", "f4"), ("gy", "f8"), ("tag", "S4")])
    tab["time"], tab["gx"], tab["gy"] = t, g[:, 0], g[:, 1]
    c = tmp_path / "table.hdf5"
    with h5py.File(c, "w") as f:
        f["log"] = tab
    log = read_log(c, overrides={"gyro": {"rate_unit": "rad/s"}})
    assert log.axes == ["gx", "gy"]
    np.testing.assert_array_equal(log.rates["gy"], g[:, 1] * RAD_S_TO_DPH)
    np.testing.assert_array_equal(log.rates["gx"],
                                  g[:, 0].astype(np.float32).astype(float) * RAD_S_TO_DPH)


def test_hdf5_malformed(tmp_path):
    h5py = pytest.importorskip("h5py")
    t, g = _signals()
    p = tmp_path / "ok.h5"
    with h5py.File(p, "w") as f:
        f["t"] = t
        f["gx"] = g[:, 0]
    cut = tmp_path / "cut.h5"
    cut.write_bytes(p.read_bytes()[:3000])
    run_cli(["info", cut]).assert_clean_error("cut.h5", "HDF5")
    odd = tmp_path / "odd.h5"
    with h5py.File(odd, "w") as f:
        f["t"] = t
        f["gx"] = g[:-50, 0]
    run_cli(["info", odd, "--rate-unit", "rad/s"]).assert_clean_error("odd.h5", "different lengths")
    empty = tmp_path / "strings.h5"
    with h5py.File(empty, "w") as f:
        f["name"] = "bench"
        f.create_group("g")
    run_cli(["info", empty]).assert_clean_error("strings.h5", "no numeric vector")


def test_missing_extra_names_it(tmp_path, monkeypatch):
    h5py = pytest.importorskip("h5py")
    p = tmp_path / "x.h5"
    with h5py.File(p, "w") as f:
        f["t"] = np.arange(10.0)
    monkeypatch.setitem(__import__("sys").modules, "h5py", None)  # import h5py → ImportError
    run_cli(["info", p]).assert_clean_error("pip install 'gyrotest[hdf5]'")
    monkeypatch.setitem(__import__("sys").modules, "rosbags", None)
    bag = tmp_path / "x.bag"
    bag.write_bytes(b"#ROSBAG V2.0\n" + b"\0" * 100)
    run_cli(["info", bag]).assert_clean_error("pip install 'gyrotest[ros]'")


def test_topic_on_a_csv_is_an_error(tmp_path):
    c = _csv(tmp_path / "a.csv", {"t": np.arange(10.0), "gx_dps": np.zeros(10)})
    run_cli(["info", c, "--topic", "/imu"]).assert_clean_error("a.csv", "--topic")


# ----------------------------------------------------------------------------- ROS bags
def _imu_messages(store, ros1: bool, n=N, fs=FS, t0_ns=1_716_200_000 * 10**9, seed=5,
                  zero_stamp=False):
    T = store.types
    t, g = _signals(seed, n)
    for i in range(n):
        ns = t0_ns + round(i * 1e9 / fs)
        st = T["builtin_interfaces/msg/Time"](sec=0 if zero_stamp else ns // 10**9,
                                               nanosec=0 if zero_stamp else ns % 10**9)
        hk = {"seq": i} if ros1 else {}
        h = T["std_msgs/msg/Header"](**hk, stamp=st, frame_id="imu_link")
        v3, q = T["geometry_msgs/msg/Vector3"], T["geometry_msgs/msg/Quaternion"]
        yield ns, T["sensor_msgs/msg/Imu"](
            header=h, orientation=q(x=0.0, y=0.0, z=0.0, w=1.0),
            orientation_covariance=np.zeros(9),
            angular_velocity=v3(x=g[i, 0], y=g[i, 1], z=g[i, 2]),
            angular_velocity_covariance=np.zeros(9),
            linear_acceleration=v3(x=0.1, y=-0.2, z=9.81),
            linear_acceleration_covariance=np.zeros(9))


IMU = "sensor_msgs/msg/Imu"


def write_bag(path, kind="ros1", topics=("/imu/data",), *, n=N, zero_stamp=False,
              other=False):
    """A bag written by rosbags' own writers: ROS 1 .bag, ROS 2 sqlite3 or MCAP directory."""
    pytest.importorskip("rosbags")
    from rosbags.typesys import Stores, get_typestore

    ros1 = kind == "ros1"
    store = get_typestore(Stores.ROS1_NOETIC if ros1 else Stores.ROS2_HUMBLE)
    if ros1:
        from rosbags.rosbag1 import Writer

        w = Writer(path)
        ser = store.serialize_ros1
    else:
        from rosbags.rosbag2 import StoragePlugin, Writer

        plug = StoragePlugin.MCAP if kind == "mcap" else StoragePlugin.SQLITE3
        w = Writer(path, version=9, storage_plugin=plug)
        ser = store.serialize_cdr
    with w:
        conns = [w.add_connection(tp, IMU, typestore=store) for tp in topics]
        if other:
            sc = w.add_connection("/status", "std_msgs/msg/String", typestore=store)
            w.write(sc, 1, ser(store.types["std_msgs/msg/String"](data="ok"),
                               "std_msgs/msg/String"))
        for k, c in enumerate(conns):
            for ns, m in _imu_messages(store, ros1, n=n, seed=5 + k, zero_stamp=zero_stamp):
                w.write(c, ns, ser(m, IMU))
    return path


@pytest.mark.parametrize("kind", ["ros1", "sqlite3", "mcap"])
def test_rosbag_imu_columns_units_and_allan(tmp_path, kind):
    p = write_bag(tmp_path / ("imu.bag" if kind == "ros1" else "imu_bag"), kind)
    t, g = _signals()
    log = read_log(p)
    assert log.axes == ["gx", "gy", "gz"]
    assert log.gyro.rate_unit == "rad/s"
    np.testing.assert_allclose(log.rates["gx"], g[:, 0] * RAD_S_TO_DPH, rtol=1e-14)
    np.testing.assert_allclose(log.extra["az"], 9.81)
    assert log.units["az"] == "m/s^2"
    assert log.tau0 == pytest.approx(1 / FS, rel=1e-12)
    assert log.timing.start.startswith("2024-05-20")
    # allan on the bag = allan on the same numbers in a CSV (ns epoch time, rad/s columns)
    ns = 1_716_200_000 * 10**9 + np.round(np.arange(N) * 1e9 / FS).astype(np.int64)
    c = _csv(tmp_path / "same.csv", {"time": [int(v) for v in ns], "gx": g[:, 0],
                                     "gy": g[:, 1], "gz": g[:, 2]})
    assert _allan_tables(p) == _allan_tables(c, "--rate-unit", "rad/s")
    # white noise of 1e-3 rad/s per sample: σ(τ0) = 1e-3 rad/s = 206.3 deg/h, inside the CI
    row = _allan_tables(p)["gx"][0]
    assert row["sigma_lo"] * 0.98 < 1e-3 * RAD_S_TO_DPH < row["sigma_hi"] * 1.02
    if kind == "mcap":  # the storage file alone, without metadata.yaml
        mc = next(p.glob("*.mcap"))
        assert read_log(mc).n == N


def test_rosbag_topics(tmp_path):
    two = write_bag(tmp_path / "two.bag", topics=("/imu/a", "/imu/b"), n=300, other=True)
    run_cli(["info", two]).assert_clean_error("several Imu topics", "/imu/a", "/imu/b",
                                              "--topic")
    r = run_cli(["info", two, "--topic", "/imu/b", "--json"])
    assert r.code == 0, r.err
    assert json.loads(r.out)["timing"]["samples"] == 300
    _, g = _signals(6, 300)
    np.testing.assert_allclose(read_log(two, overrides={"columns": {"topic": "/imu/b"}}
                                        ).rates["gy"], g[:, 1] * RAD_S_TO_DPH, rtol=1e-14)
    run_cli(["info", two, "--topic", "/status"]).assert_clean_error(
        "/status", "not sensor_msgs/msg/Imu")
    run_cli(["info", two, "--topic", "/nope"]).assert_clean_error("no topic '/nope'")


def test_rosbag_malformed(tmp_path):
    pytest.importorskip("rosbags")
    from rosbags.rosbag1 import Writer
    from rosbags.typesys import Stores, get_typestore

    store = get_typestore(Stores.ROS1_NOETIC)
    no_imu = tmp_path / "status.bag"
    with Writer(no_imu) as w:
        c = w.add_connection("/status", "std_msgs/msg/String", typestore=store)
        w.write(c, 1, store.serialize_ros1(store.types["std_msgs/msg/String"](data="x"),
                                           "std_msgs/msg/String"))
    run_cli(["info", no_imu]).assert_clean_error("no sensor_msgs/msg/Imu topic", "/status")
    ok = write_bag(tmp_path / "ok.bag", n=500)
    data = ok.read_bytes()
    cut = tmp_path / "cut.bag"
    cut.write_bytes(data[: len(data) // 2])
    run_cli(["info", cut]).assert_clean_error("cut.bag", "ROS bag")
    junk = tmp_path / "junk.bag"
    junk.write_bytes(b"#ROSBAG V2.0\n" + bytes(range(256)) * 4)
    run_cli(["info", junk]).assert_clean_error("junk.bag", "ROS bag")
    d = tmp_path / "r2"
    write_bag(d, "sqlite3", n=200)
    (d / "metadata.yaml").write_text("rosbag2_bagfile_information: [unclosed\n")
    run_cli(["info", d]).assert_clean_error("r2", "ROS bag")


def test_rosbag_zero_stamps_use_recording_time(tmp_path):
    p = write_bag(tmp_path / "z.bag", n=300, zero_stamp=True)
    log = read_log(p)
    assert log.n == 300 and log.tau0 == pytest.approx(0.01)
    assert any("recording time" in n for n in log.notes)


# ----------------------------------------------------------------------------- gzip
@pytest.mark.parametrize("sep,ext", [(",", "csv"), ("\t", "tsv"), (" ", "txt")])
def test_gzip_text_equals_plain(tmp_path, sep, ext):
    t, g = _signals()
    text = f"# bench log\nt{sep}gx_dps{sep}temp_c\n" + "".join(
        f"{a:.2f}{sep}{b:.9f}{sep}{25 + a / 100:.4f}\n" for a, b in zip(t, g[:, 0]))
    plain = tmp_path / f"log.{ext}"
    plain.write_text(text)
    gz = tmp_path / f"log.{ext}.gz"
    gz.write_bytes(gzip.compress(text.encode()))
    a, b = read_log(plain), read_log(gz)
    np.testing.assert_array_equal(a.rates["gx_dps"], b.rates["gx_dps"])
    np.testing.assert_array_equal(a.temperature["temp_c"], b.temperature["temp_c"])
    assert a.tau0 == b.tau0


def test_gzip_malformed(tmp_path):
    t, g = _signals(n=60000)
    text = "t,gx_dps\n" + "".join(f"{a:.2f},{b:.9f}\n" for a, b in zip(t, g[:, 0]))
    full = gzip.compress(text.encode())
    for name, data, frag in [
        ("cut.csv.gz", full[: len(full) // 2], "truncated"),
        ("head.csv.gz", full[:2000], "gzip"),
        ("bad.csv.gz", b"\x1f\x8b" + b"not gzip at all", "gzip"),
        ("rowbad.csv.gz", gzip.compress(b"t,gx_dps\n0,1\n0.1,x\n"), "non-numeric"),
    ]:
        p = tmp_path / name
        p.write_bytes(data)
        run_cli(["info", p]).assert_clean_error(name, frag)


# ----------------------------------------------------------------------------- angle kinds
def test_delta_angle_closed_form(tmp_path):
    # Δθ_k = ∫ Ω dt over one interval for Ω(t) = Ω0 + A sin(2π f t): the rate is Δθ/τ0
    tau0, n = 0.01, 2000
    t = np.arange(n) * tau0
    om0, amp, f = 10.0, 50.0, 0.5  # deg/h
    dth_deg = (om0 * tau0 + amp / (2 * np.pi * f) * (np.cos(2 * np.pi * f * (t - tau0))
                                                       - np.cos(2 * np.pi * f * t))) / 3600
    p = _csv(tmp_path / "imu.csv", {"t": t, "dtheta_x": dth_deg * math.pi / 180})
    log = read_log(p, overrides={"gyro": {"angle_unit": "rad"}})
    assert log.gyro.output_kind == "delta-angle"
    mean_rate = dth_deg * 3600 / tau0  # deg/h, exact interval mean of Ω(t)
    np.testing.assert_allclose(log.rates["dtheta_x"], mean_rate, rtol=1e-9, atol=1e-9)
    r = run_cli(["info", p])
    r.assert_clean_error("dtheta_x", "--angle-unit")
    # --output-kind reinterprets auto-detected gyro columns (here arcsec increments)
    q = _csv(tmp_path / "g.csv", {"t": t, "gx": dth_deg * 3600})
    log = read_log(q, overrides={"gyro": {"output_kind": "delta-angle", "angle_unit": "arcsec"}})
    np.testing.assert_allclose(log.rates["gx"], mean_rate, rtol=1e-9, atol=1e-9)
    r = run_cli(["allan", q, "--output-kind", "delta-angle", "--angle-unit", "arcsec", "--json"])
    assert r.code == 0, r.err
    assert json.loads(r.out)["logs"][0]["axes"][0]["input_kind"] == "increment"


def test_cumulative_angle_closed_form_irregular_time(tmp_path):
    rng = np.random.default_rng(1)
    n = 3000
    t = np.cumsum(np.r_[0.0, 0.01 * (1 + 0.002 * rng.standard_normal(n - 1))])
    th = 15.0 / 3600 * t + 1e-3 * np.sin(2 * np.pi * 0.2 * t)  # deg
    p = _csv(tmp_path / "ang.csv", {"t": t, "heading": th})
    log = read_log(p, overrides={"columns": {"angle": ["heading"]},
                                 "gyro": {"angle_unit": "deg"}})
    want = np.diff(th) / np.diff(t) * 3600  # deg/h
    assert log.n == n - 1
    np.testing.assert_allclose(log.rates["heading"], want, rtol=1e-8, atol=1e-8)
    np.testing.assert_allclose(log.t, t[1:] - t[1], atol=1e-12)
    run_cli(["info", p, "--counts-col", "heading", "--output-kind", "angle",
             "--scale-factor", "1"]).assert_clean_error("--output-kind")


# ----------------------------------------------------------------------------- columns
def test_columns_command(tmp_path):
    p = _csv(tmp_path / "odd.csv", {"stamp": np.arange(5.0), "chan_a": np.zeros(5),
                                    "temp [degC]": np.zeros(5)})
    r = run_cli(["columns", p, "--json"])
    assert r.code == 0, r.err
    d = json.loads(r.out)
    assert [c["column"] for c in d["columns"]] == ["stamp", "chan_a", "temp [degC]"]
    assert d["columns"][2]["role"] == "temperature" and d["columns"][2]["unit"] == "degC"
    assert d["problem"] and "no gyro output" in d["problem"]
    assert "no gyro output" in r.err  # a warning, exit 0
    r = run_cli(["columns", p, "--rate-col", "chan_a", "--time-col", "stamp", "--json"])
    d = json.loads(r.out)
    assert [c["assigned"] for c in d["columns"]] == ["time", "gyro output (rate)", "temperature"]
    assert d["problem"] is None
    r = run_cli(["columns", p])
    assert r.code == 0 and "chan_a" in r.out and "temp [degC]" in r.out


def test_columns_of_a_bag_show_file_units(tmp_path):
    p = write_bag(tmp_path / "c.bag", n=50)
    d = json.loads(run_cli(["columns", p, "--json"]).out)
    units = {c["column"]: c["unit"] for c in d["columns"]}
    assert units == {"time": "ns", "gx": "rad/s", "gy": "rad/s", "gz": "rad/s",
                     "ax": "m/s^2", "ay": "m/s^2", "az": "m/s^2"}
    assert d["format"] == "rosbag"


# ----------------------------------------------------------------------------- README demo
def test_readme_demo_files(tmp_path):
    """sample_data/make_imu_files.py and the README commands on what it writes: every
    format gives the same samples, and N comes back as the simulated 0.3 deg/√h."""
    pytest.importorskip("rosbags")
    import importlib.util
    from pathlib import Path

    root = Path(__file__).resolve().parents[1]
    spec = importlib.util.spec_from_file_location("mk", root / "sample_data" / "make_imu_files.py")
    mk = importlib.util.module_from_spec(spec)
    spec.loader.exec_module(mk)
    out = tmp_path / "imu_demo"
    mk.main([str(out), "--minutes", "3"])
    ref = read_log(out / "imu.bag")
    for f, extra in [("imu_mcap", {}), ("imu.mat", {"gyro": {"rate_unit": "rad/s"}}),
                     ("imu.csv.gz", {})]:
        log = read_log(out / f, overrides=extra)
        assert log.n == ref.n == 18000
        for a, b in zip(ref.axes, log.axes):
            np.testing.assert_allclose(log.rates[b], ref.rates[a], rtol=1e-8)
    assert run_cli(["columns", out / "imu.bag"]).code == 0
    r = run_cli(["allan", out / "imu.mat", "--rate-unit", "rad/s", "--json", "-q"])
    assert r.code == 0, r.err
    for ax in json.loads(r.out)["logs"][0]["axes"]:
        n = next(t for t in ax["fit"]["terms"] if t["key"] == "N")
        assert n["params"]["N"] == pytest.approx(mk.ARW_DEG_SQRT_H, rel=0.03)
    r = run_cli(["export", "kalibr", out / "imu.bag", "-o", out / "kalibr_imu.yaml", "-q"])
    assert r.code == 0, r.err


@pytest.mark.parametrize("ros1", [True, False])
def test_fast_imu_parser_equals_rosbags_deserialisation(ros1):
    """The byte-level Imu reader against rosbags' own (de)serialiser, for every frame_id
    length mod 8 (CDR aligns the doubles after the string)."""
    pytest.importorskip("rosbags")
    from rosbags.typesys import Stores, get_typestore

    from gyrotest.io.rosbag import fast_imu

    store = get_typestore(Stores.ROS1_NOETIC if ros1 else Stores.ROS2_HUMBLE)
    ser = store.serialize_ros1 if ros1 else store.serialize_cdr
    T = store.types
    rng = np.random.default_rng(3)
    for k in range(10):
        w, a = rng.normal(size=3), rng.normal(size=3)
        h = T["std_msgs/msg/Header"](**({"seq": k} if ros1 else {}),
                                     stamp=T["builtin_interfaces/msg/Time"](sec=1716200000 + k,
                                                                            nanosec=123456789),
                                     frame_id="f" * k)
        v3 = T["geometry_msgs/msg/Vector3"]
        msg = T[IMU](header=h, orientation=T["geometry_msgs/msg/Quaternion"](x=1.0, y=2.0, z=3.0,
                                                                              w=4.0),
                     orientation_covariance=rng.normal(size=9),
                     angular_velocity=v3(x=w[0], y=w[1], z=w[2]),
                     angular_velocity_covariance=rng.normal(size=9),
                     linear_acceleration=v3(x=a[0], y=a[1], z=a[2]),
                     linear_acceleration_covariance=rng.normal(size=9))
        raw = ser(msg, IMU)
        assert fast_imu(raw, ros1) == (1716200000 + k, 123456789, *w, *a)
        assert fast_imu(bytes(raw) + b"\0" * 8, ros1) is None  # not the standard layout


def test_kalibr_from_a_bag_takes_its_topic(tmp_path):
    yaml = pytest.importorskip("yaml")
    p = write_bag(tmp_path / "k.bag", topics=("/vehicle/imu",), n=3000)
    out = tmp_path / "imu.yaml"
    r = run_cli(["export", "kalibr", p, "-o", out, "-q"])
    assert r.code == 0, r.err
    d = yaml.safe_load(out.read_text())
    assert d["rostopic"] == "/vehicle/imu" and d["update_rate"] == pytest.approx(FS)
    # white noise of 1e-3 rad/s per sample at 100 Hz: density 1e-3/√100 rad/s/√Hz
    assert d["gyroscope_noise_density"] == pytest.approx(1e-4, rel=0.05)
