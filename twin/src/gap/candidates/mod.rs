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

/// How far the plant's response per unit of an effect may exceed the twin's. A mechanical
/// effect's magnitude is fitted as a twin-equivalent one (the magnitude at which the twin's
/// effect moves the cells as the plant's does), free in [0, `MODEL_FORM_SCALE` x the
/// effect's physical bound]; the plant's own magnitude may differ from it by that factor
/// either way. 5: another simulator's eccentric fan pulley moved the cells about five times
/// as much per millimetre as the twin's (docs/decisions/gap-model-form.md).
pub(super) const MODEL_FORM_SCALE: f64 = 5.0;

/// The upper bound of a twin-equivalent magnitude whose physical bound is `max`.
pub(super) fn fit_bound(max: f64) -> f64 {
    MODEL_FORM_SCALE * max
}
