"""The public Python API's implementation (use it as ``gyrotest.allan`` ... : the names are
re-exported lazily by :mod:`gyrotest`; this package and its modules are internal).

* :mod:`.analyses` -- :func:`read`, :func:`allan`, :func:`bias`, :func:`scale_factor`;
* :mod:`.models` -- :class:`Model`, :func:`thermal_fit`, :func:`mag_fit`,
  :func:`compensate`;
* :mod:`.campaign` -- :func:`report`, :func:`simulate`;
* :mod:`.results` -- the result objects (``to_dict``, ``to_frame``, ``plot``,
  ``_repr_html_``); :mod:`.modelresults` those of the drift-model functions.

Paths, frames, arrays and simulations become logs in :mod:`gyrotest.io.inputs`.
"""
