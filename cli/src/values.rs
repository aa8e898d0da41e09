//! The value parsers of `rom`'s flags, one per kind of value: numbers with their domain, the
//! side gap with its unit, and the one effect syntax `NAME:KEY=VALUE[,KEY=VALUE]` shared by
//! `simulate` and `predict`. A refused value is a usage error (clap's, exit 2) naming the flag.

/// A positive finite number (physical flags: distances, durations, ...).
pub fn positive(s: &str) -> Result<f64, String> {
    match s.trim().parse::<f64>() {
        Ok(v) if v.is_finite() && v > 0.0 => Ok(v),
        Ok(v) => Err(format!(
            "must be a positive number, got {}",
            fom::readable::readable(v)
        )),
        Err(_) => Err(format!("`{s}` is not a number")),
    }
}

/// A non-negative finite number (a torque, a clearance).
pub fn non_negative(s: &str) -> Result<f64, String> {
    match s.trim().parse::<f64>() {
        Ok(v) if v.is_finite() && v >= 0.0 => Ok(v),
        Ok(v) => Err(format!(
            "must be a non-negative number, got {}",
            fom::readable::readable(v)
        )),
        Err(_) => Err(format!("`{s}` is not a number")),
    }
}

/// A count of at least one.
pub fn at_least_one(s: &str) -> Result<usize, String> {
    match s.trim().parse::<usize>() {
        Ok(0) => Err("must be at least 1, got 0".into()),
        Ok(n) => Ok(n),
        Err(_) => Err(format!("`{s}` is not a whole number")),
    }
}

/// Largest bare number `--side-gap` takes as metres: a side gap of 5 mm or more would let an
/// arc tooth of any standard pitch (up to 14 mm, tooth ~8 mm wide) leave its groove, so such a
/// bare number is a unit slip, refused with a hint (`docs/decisions/units-in-help.md`).
pub const SIDE_GAP_MAX_M: f64 = 5e-3;

/// A side gap, m: a bare number is metres; a suffix `m`, `mm`, `um` or `µm` states the unit.
/// A bare number above [`SIDE_GAP_MAX_M`] is refused ("did you mean 0.2mm?"), never guessed.
pub fn side_gap(s: &str) -> Result<f64, String> {
    let t = s.trim();
    let units = [("mm", 1e-3), ("um", 1e-6), ("µm", 1e-6), ("m", 1.0)];
    let (num, scale, bare) = units
        .iter()
        .find_map(|(u, k)| t.strip_suffix(u).map(|n| (n.trim(), *k, false)))
        .unwrap_or((t, 1.0, true));
    let v = non_negative(num)? * scale;
    if v > SIDE_GAP_MAX_M {
        let hint = if bare {
            format!(" (a bare number is metres: did you mean {num}mm?)")
        } else {
            String::new()
        };
        return Err(format!(
            "{} m is larger than any tooth's side gap (at most {} m){hint}",
            fom::readable::readable(v),
            SIDE_GAP_MAX_M
        ));
    }
    Ok(v)
}

/// One `--effect`: an effect's name and its `KEY=VALUE` settings, in the order given.
#[derive(Debug, Clone, PartialEq)]
pub struct EffectSpec {
    pub name: String,
    pub params: Vec<(String, String)>,
}

impl EffectSpec {
    /// The specification as `NAME:KEY=VALUE,...` (what `EffectsConfig::set_from_spec` reads).
    pub fn to_spec(&self) -> String {
        let kv: Vec<String> = self
            .params
            .iter()
            .map(|(k, v)| format!("{k}={v}"))
            .collect();
        if kv.is_empty() {
            self.name.clone()
        } else {
            format!("{}:{}", self.name, kv.join(","))
        }
    }
}

/// `--effect NAME[:KEY=VALUE[,KEY=VALUE]]` (e.g. `bearing-drag:coulomb_nm=0.8`); the older
/// `NAME.KEY=VALUE` of `--effect-param` is read too. The name and keys are checked by their
/// users (the configuration's `[effects.<name>]` table, or the surrogate's inputs).
pub fn effect(s: &str) -> Result<EffectSpec, String> {
    let t = s.trim();
    let (name, rest) = match t.split_once(':') {
        Some((n, r)) => (n.trim(), r),
        // NAME.KEY=VALUE: the dot before the first `=` splits name and key.
        None => match t.split_once('=') {
            Some((lhs, _)) => match lhs.split_once('.') {
                Some((n, _)) => (n.trim(), &t[n.len() + 1..]),
                None => return Err(format!("`{t}` is not NAME:KEY=VALUE[,KEY=VALUE]")),
            },
            None => (t, ""),
        },
    };
    if name.is_empty() || name.contains(['.', '=']) {
        return Err(format!(
            "`{t}` names no effect (NAME:KEY=VALUE[,KEY=VALUE])"
        ));
    }
    let mut params = Vec::new();
    for kv in rest.split(',').map(str::trim).filter(|p| !p.is_empty()) {
        let (k, v) = kv
            .split_once('=')
            .filter(|(k, v)| !k.trim().is_empty() && !v.trim().is_empty())
            .ok_or_else(|| format!("`{kv}` is not KEY=VALUE"))?;
        params.push((k.trim().to_string(), v.trim().to_string()));
    }
    Ok(EffectSpec {
        name: name.to_string(),
        params,
    })
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn side_gap_takes_metres_or_an_explicit_unit_and_never_guesses() {
        let table = [
            ("2.5e-4", 2.5e-4),
            ("2.5e-4m", 2.5e-4),
            ("0.25mm", 2.5e-4),
            (" 0.25 mm", 2.5e-4),
            ("250um", 2.5e-4),
            ("250µm", 2.5e-4),
            ("0.004", 4e-3),
            ("0.005", 5e-3),
            ("5mm", 5e-3),
            ("0", 0.0),
        ];
        for (s, v) in table {
            let g = side_gap(s).unwrap();
            assert!((g - v).abs() < 1e-15, "{s}: {g}");
        }
        let e = side_gap("0.2").unwrap_err();
        assert!(e.contains("did you mean 0.2mm?"), "{e}");
        assert!(side_gap("6mm").unwrap_err().contains("larger than"));
        for bad in ["-1e-4", "abc", "mm", "0.1 inch", "nan", "0.0051"] {
            assert!(side_gap(bad).is_err(), "{bad} accepted");
        }
    }

    #[test]
    fn one_effect_syntax_and_the_older_dotted_one() {
        let want = EffectSpec {
            name: "bearing-drag".into(),
            params: vec![("coulomb_nm".into(), "0.8".into())],
        };
        assert_eq!(effect("bearing-drag:coulomb_nm=0.8").unwrap(), want);
        assert_eq!(effect("bearing-drag.coulomb_nm=0.8").unwrap(), want);
        assert_eq!(want.to_spec(), "bearing-drag:coulomb_nm=0.8");
        let two = effect("pulley-eccentricity:runout_m=1e-4, pulley=driven").unwrap();
        assert_eq!(two.params.len(), 2);
        assert_eq!(effect("belt-hysteresis").unwrap().params, vec![]);
        for bad in ["", ":a=1", "x:a", "x:=1", "x.a", "a=1"] {
            assert!(effect(bad).is_err(), "{bad} accepted");
        }
    }
}
