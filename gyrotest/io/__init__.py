"""Every reader of gyrotest (docs/architecture.md). :func:`gyrotest.io.ingest.read_log` reads a
file: text, Parquet and Feather tables (:mod:`.tables`, the numeric fast path :mod:`.fastcsv`),
MATLAB, HDF5 and ROS containers (:mod:`.containers`), all as a :class:`~.rawtable.RawTable`;
column roles and units (:mod:`.columns`), the time axis (:mod:`.timeaxis`), the output's health
(:mod:`.health`) and gyrotest's own converted files (:mod:`.meta`) make it a log.
:mod:`.inputs` turns what a user hands the API (a path, a frame, an array, a simulation) into a
log; :mod:`.stream` integrates a long Parquet log straight into θ."""
