//! Normal-interval constants shared by the surrogate's uncertainty and its validation.

/// z of the two-sided 90 % normal interval.
pub const Z90: f64 = 1.644_853_626_951_472_2;
