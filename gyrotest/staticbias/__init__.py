"""Static bias tests (IEEE 952 §12.11.4.1.1): bias D_F, run-to-run repeatability and
multi-position tests (:mod:`.analysis`), every axis of a multi-axis log (:mod:`.multiaxis`), the
warm-up after power-on (:mod:`.warmup`) and the figure (:mod:`.plots`). The public entry point
is :func:`gyrotest.bias`."""
