"""beltwin: digital twin of belt-pulley drives.

The full-order model (``simulate``), the shipped or a trained surrogate (``Surrogate``; a
toothed belt's tooth loads: ``ToothSurrogate``), and
the twin's answers on measured data (``read_measurements``, ``diagnose``, ``calibrate``,
``gap``). Each returns what the matching ``rom`` command writes as JSON, with time series and
quantile functions as numpy arrays; errors raise ``BeltwinError`` with the command's message.
"""

from ._beltwin import (
    BeltwinError,
    Surrogate,
    ToothSurrogate,
    __version__,
    calibrate,
    diagnose,
    gap,
    read_measurements,
    simulate,
)

__all__ = [
    "BeltwinError",
    "Surrogate",
    "ToothSurrogate",
    "__version__",
    "calibrate",
    "diagnose",
    "gap",
    "read_measurements",
    "simulate",
]
