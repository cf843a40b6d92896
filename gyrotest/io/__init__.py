"""Readers behind :mod:`gyrotest.io.ingest`: table files (:mod:`.tables`), column roles and
units from names (:mod:`.columns`), the time axis (:mod:`.timeaxis`) and gyrotest's own
converted files (:mod:`.meta`). Public functions stay importable from :mod:`gyrotest.io.ingest`."""
