"""Deliverables as files: the results of gyrotest in the formats other tools and firmware read.

One module per format, each a pure function from a saved gyrotest result (see
:mod:`gyrotest.export.common`) to the file's text or bytes:

* :mod:`.kalibr` — Kalibr ``imu.yaml`` (camera–IMU calibration);
* :mod:`.matlab` — MATLAB ``gyroparams`` as a ``.m`` script or a ``.mat`` struct;
* :mod:`.stable32` — a Stable32-style deviation table;
* :mod:`.table` — the Allan deviation table as CSV with units in the header;
* :mod:`.envlut` — an environmental (thermal) drift model as a look-up table and a C header;
* :mod:`.sflut` — the scale-factor model ε_K(I, T) as a look-up table and a C header.

``gyrotest export KIND INPUT -o FILE`` (:mod:`gyrotest.cli.cmd_export`) is the command line.
"""
