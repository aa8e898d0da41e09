//! Normal-interval constants shared by the surrogate's uncertainty and its validation: the
//! one definition lives in `fom::stats` (the leaf crate every other crate uses).

pub use fom::stats::{normal_quantile, Z90};
