//! Bounds on the model's size, checked on the configuration before anything is allocated: a
//! mistyped count must end in a message naming its key, not in an aborted allocation.

/// The most belt segments a model may have: over 400 times the default drive's 240
/// (`fom/configs/`, docs/fom-numerics.md), far past any useful resolution; the state, the
/// contact buffers and the element forces of 100 000 segments take some tens of MB.
pub const MAX_SEGMENTS: usize = 100_000;

/// The most teeth a toothed belt may have (one contact body per tooth and pulley groove).
pub const MAX_TEETH: usize = 100_000;

/// Refuses a model larger than [`MAX_SEGMENTS`] segments or [`MAX_TEETH`] teeth, naming the
/// key.
pub fn check_model_size(segments: usize, teeth: Option<usize>) -> Result<(), String> {
    if segments > MAX_SEGMENTS {
        return Err(format!(
            "belt.segments = {segments} is too many (at most {MAX_SEGMENTS}; the default drive \
             has 240)"
        ));
    }
    if let Some(count) = teeth.filter(|&c| c > MAX_TEETH) {
        return Err(format!(
            "belt.teeth.count = {count} is too many (at most {MAX_TEETH})"
        ));
    }
    Ok(())
}

#[cfg(test)]
mod tests {
    #[test]
    fn a_model_too_large_is_refused_by_its_key() {
        assert!(super::check_model_size(240, Some(100)).is_ok());
        let e = super::check_model_size(100_000_000_000, None).unwrap_err();
        assert!(e.contains("belt.segments = 100000000000"), "{e}");
        let e = super::check_model_size(240, Some(usize::MAX)).unwrap_err();
        assert!(e.contains("belt.teeth.count"), "{e}");
    }
}
