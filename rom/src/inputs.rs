//! Which inputs a surrogate takes: a request that gives any variable the surrogate was not
//! trained on is refused, the same way for every kind of surrogate (a variable it was not
//! trained on would otherwise be ignored without a word).

use fom::params::Variable;

use crate::error::{Result, RomError};

/// Refuses the inputs of `given` (each named as the caller names it, e.g. by its flag) whose
/// variable is not one of `trained`; `kind` names the surrogate and `name` the caller's name
/// of a variable in the message.
pub fn refuse_untrained(
    kind: &str,
    given: &[(String, Variable)],
    trained: &[Variable],
    name: impl Fn(Variable) -> String,
) -> Result<()> {
    let untrained: Vec<&str> = given
        .iter()
        .filter(|(_, v)| !trained.contains(v))
        .map(|(n, _)| n.as_str())
        .collect();
    if untrained.is_empty() {
        return Ok(());
    }
    let takes: Vec<String> = trained.iter().map(|v| name(*v)).collect();
    Err(RomError::Data(format!(
        "{}: not trained over; this {kind} takes {} (leave out the rest)",
        untrained.join(", "),
        takes.join(", "),
    )))
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn every_untrained_input_is_named_and_trained_ones_pass() {
        let trained = [Variable::SideGap, Variable::LoadTorque, Variable::ShaftLoad];
        let key = |v: Variable| v.key().to_string();
        let given = |g: &[(&str, Variable)]| -> Vec<(String, Variable)> {
            g.iter().map(|(n, v)| (n.to_string(), *v)).collect()
        };
        let ok = given(&[("--side-gap", Variable::SideGap)]);
        assert!(refuse_untrained("s", &ok, &trained, key).is_ok());
        let bad = given(&[
            ("--d", Variable::CenterDistance),
            ("--side-gap", Variable::SideGap),
            ("--mu", Variable::Friction),
        ]);
        let e = refuse_untrained("tooth-load surrogate", &bad, &trained, key)
            .unwrap_err()
            .to_string();
        assert!(e.starts_with("--d, --mu: not trained over"), "{e}");
        assert!(e.contains("side_gap_m"), "{e}");
    }
}
