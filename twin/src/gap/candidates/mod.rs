//! The candidates a gap may be credited to: the catalogue's mechanical effects (one
//! sensitivity run per label each, `mechanical`) and the tachometer (a grid of sensor models,
//! `tachometer`), each fitted through the one linear model of `linear`; several mechanical
//! effects at once by forward selection (`selection`). A new candidate is a
//! function returning a [`Scored`] from the shared `ranking::RankContext`
//! (docs/extending/gap-stage.md).

pub mod linear;
pub mod mechanical;
pub mod selection;
pub mod tachometer;

use super::report::Ranked;

/// A ranked candidate with its withheld labels' z.
pub(super) type Scored = (Ranked, Vec<Vec<f64>>);

/// Standard errors by which an effect run's cell must differ from the baseline run's to count as
/// a sensitivity (two-sided 95 %); the standard error holds the twin's spread under the friction
/// uncertainty (`run_spread`) beside the two runs' batch-means errors.
pub(super) const SENSITIVITY_SD: f64 = 2.0;
