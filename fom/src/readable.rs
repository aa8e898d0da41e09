//! Numbers in messages: what a user typed comes back readable, whatever its magnitude (a
//! `{}` of 1e308 prints 309 digits).

/// `x` for a message: as Rust prints it when that is short; else with six decimals for
/// magnitudes in [1e-3, 1e6); else in scientific notation with at most four decimals.
pub fn readable(x: f64) -> String {
    const SHORT: usize = 12;
    let plain = format!("{x}");
    if plain.len() <= SHORT || !x.is_finite() {
        return plain;
    }
    if (1e-3..1e6).contains(&x.abs()) {
        let fixed = format!("{x:.6}");
        return fixed
            .trim_end_matches('0')
            .trim_end_matches('.')
            .to_string();
    }
    let sci = format!("{x:e}");
    if sci.len() <= SHORT {
        return sci;
    }
    let four = format!("{x:.4e}");
    match four.split_once('e') {
        Some((m, e)) => format!("{}e{e}", m.trim_end_matches('0').trim_end_matches('.')),
        None => four,
    }
}

#[cfg(test)]
mod tests {
    use super::readable;

    #[test]
    fn every_magnitude_is_short() {
        assert_eq!(readable(0.42), "0.42");
        assert_eq!(readable(1e308), "1e308");
        assert_eq!(readable(1.0e-300), "1e-300");
        assert_eq!(readable(0.1 + 0.2), "0.3");
        assert_eq!(readable(f64::NAN), "NaN");
        assert_eq!(readable(-f64::INFINITY), "-inf");
        assert_eq!(readable(1.2345678901234e300), "1.2346e300");
        assert_eq!(readable(123456789.123), "1.2346e8");
    }
}
