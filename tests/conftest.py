"""Suite-wide settings: one BLAS thread per worker, and a limit on a hung test.

The suite runs on two pytest-xdist workers (the README's ``pytest -n 2``). Each worker does
its linear algebra on one BLAS thread: two workers on a two-core machine already use both
cores, and a BLAS pool per worker sized from the host's CPU count (which inside a container
may be far larger than the cores it may use) only oversubscribes them. This module is
imported before any test module imports numpy; subprocesses started by tests inherit the
setting. A value the caller set is kept.

A test that hangs must not hold the whole run until CI's time limit. pytest-timeout
(pyproject.toml: ``timeout``, signal method) fails it with its traceback after 15 min; if
the hang is in C code that the signal cannot interrupt, the watchdog below ends the worker
process five minutes later, every thread's stack on stderr, and pytest-xdist replaces it.
"""

from __future__ import annotations

import faulthandler
import os
import sys

import pytest

for _var in ("OPENBLAS_NUM_THREADS", "OMP_NUM_THREADS", "MKL_NUM_THREADS"):
    os.environ.setdefault(_var, "1")

#: seconds after which a test's worker process is ended (pytest-timeout's limit + 5 min)
HARD_TIMEOUT_S = 1200


@pytest.hookimpl(hookwrapper=True)
def pytest_runtest_protocol(item, nextitem):
    faulthandler.dump_traceback_later(HARD_TIMEOUT_S, exit=True, file=sys.__stderr__)
    try:
        yield
    finally:
        faulthandler.cancel_dump_traceback_later()
