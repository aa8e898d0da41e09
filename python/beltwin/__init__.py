"""beltwin: digital twin of belt-pulley drives.

The full-order model (``simulate``), the shipped or a trained surrogate of any kind
(``Surrogate``: slip, or a toothed belt's tooth loads), and
the twin's answers on measured data (``read_measurements``, ``diagnose``, ``calibrate``,
``gap``). Each returns what the matching ``rom`` command writes as JSON, with time series and
quantile functions as numpy arrays; errors raise ``BeltwinError`` with the command's message.
"""

from ._beltwin import (
    BeltwinError,
    Surrogate,
    __version__,
    calibrate,
    diagnose,
    gap,
    read_measurements,
    simulate,
)


class ToothSurrogate:
    """Former name of a tooth-load ``Surrogate``: ``ToothSurrogate.load(...)`` is
    ``Surrogate.load(..., kind="tooth-load")`` when no file is given."""

    @staticmethod
    def load(path=None, config=None):
        return Surrogate.load(path, config, kind=None if path else "tooth-load")


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
