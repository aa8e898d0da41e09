"""Type stubs of the Rust extension (python/src/lib.rs)."""

from os import PathLike
from typing import Any, Optional, Sequence, Union

import numpy as np
import numpy.typing as npt

_Path = Union[str, PathLike[str]]

__version__: str

class BeltwinError(Exception):
    """Bad input or a numerical failure; the message is the one `rom` prints."""

def simulate(
    config: Optional[_Path] = None,
    d: Optional[float] = None,
    mu: Optional[float] = None,
    tension: Optional[float] = None,
    duration: Optional[float] = None,
) -> dict[str, Any]:
    """Runs the full-order model (`rom simulate`).

    Returns numpy arrays `time_s`, `driver_rpm`, `driven_rpm`, `slip_pct`,
    `tight_span_tension_n`, `slack_span_tension_n`, `driver_torque_nm`, `driven_torque_nm`,
    and `summary` (dict), `static_tension_n` (float), `config` (TOML text).
    """

class Surrogate:
    """A fitted surrogate of any kind (slip of a V-belt drive, or a toothed belt's tooth loads;
    its file's header names the kind) and the drive configuration it is used on."""

    @staticmethod
    def load(
        path: Optional[_Path] = None,
        config: Optional[_Path] = None,
        kind: Optional[str] = None,
    ) -> "Surrogate":
        """Loads a model file of any kind; None loads the shipped model of `kind` ("slip" or
        "tooth-load"), by default the kind `config` trains (a toothed drive: tooth loads)."""
    @property
    def kind(self) -> str:
        """"slip" or "tooth-load"."""
    def predict(
        self,
        d: Optional[float] = None,
        mu: Optional[float] = None,
        tension: Optional[float] = None,
        stiffness: Optional[float] = None,
        samples: int = 100,
        allow_extrapolation: bool = False,
        side_gap: Optional[float] = None,
        load_torque: Optional[float] = None,
        shaft_load: Optional[float] = None,
    ) -> dict[str, Any]:
        """The prediction as `rom predict --format json` prints it for the model's kind. Slip:
        the steady slip distribution at centre distance d (m, required), `quantile_function_pct`
        a (levels, 2) array of (probability, slip %). Tooth load: the maximum-tooth-load
        distribution at side gap (m), load torque (N m) and shaft load (N)."""
    def predict_many(
        self,
        points: npt.ArrayLike,
        samples: int = 100,
        allow_extrapolation: bool = False,
    ) -> dict[str, np.ndarray]:
        """`predict` over the rows of an (n, k) array with columns d[, mu[, tension[, stiffness]]]
        (slip surrogates)."""
    @property
    def ranges(self) -> dict[str, Any]:
        """The trained inputs and their ranges."""
    @property
    def config(self) -> str:
        """The drive configuration (TOML) the surrogate is used on."""

def read_measurements(dir: _Path) -> dict[str, Any]:
    """Reads a `belt-measurements/1` data set; recordings as numpy arrays."""

def diagnose(
    dir: _Path, model: Optional[_Path] = None, config: Optional[_Path] = None
) -> list[dict[str, Any]]:
    """Belt-looseness verdict per label (`rom diagnose`, diagnosis.json)."""

def calibrate(
    dir: _Path,
    free: Optional[Sequence[str]] = None,
    tolerance: float = 5.0,
    confirm: bool = True,
    leave_one_out: bool = False,
    model: Optional[_Path] = None,
    config: Optional[_Path] = None,
) -> dict[str, Any]:
    """Calibration against measured data (`rom calibrate --format json`)."""

def gap(
    dir: _Path,
    holdout: Optional[Sequence[str]] = None,
    model: Optional[_Path] = None,
    config: Optional[_Path] = None,
) -> dict[str, Any]:
    """The sim-to-real gap diagnosis (`rom gap --format json`)."""
