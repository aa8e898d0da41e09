//! Campaign settings: the design space, sample count, seed and run length.

use std::collections::BTreeMap;

use fom::effects::EffectParameter;
use fom::params::Variable;
use serde::{Deserialize, Serialize};

use crate::TrainingError;

/// Fewest finished training runs a surrogate is fitted on (the one number `rom train`'s settings
/// check and the fit share).
pub const MIN_FIT_SAMPLES: usize = 5;

/// Most points of a campaign's design (initial Latin hypercube). The maximin optimisation of
/// the design keeps all pairwise distances: 1.2 GB and 8 s at 10,000 points, and 50,000 points
/// exhausted this 24 GB machine (`docs/validation/readers.md`); the Gaussian process fitted to the
/// campaign costs O(n^3) per likelihood evaluation. Above this, shard a larger study into
/// campaigns of their own.
pub const MAX_DESIGN_SAMPLES: usize = 5_000;

/// What a training campaign samples and how long each full-order run lasts. In a settings
/// file every key is optional; a missing key keeps its default.
///
/// The three design variables are the ones the twin must invert from measured speeds:
/// - `center_distance_m`: the centre distance d at which the drive runs (looseness);
/// - `friction`: the effective (wedge-included) friction coefficient;
/// - `installation_tension_n`: the static span tension the belt had when installed at the
///   configuration's `belt.reference_center_distance_m` (0.42 m on the default drive). It fixes
///   the unstretched belt length L0; moving the pulleys to d then loosens or tightens the belt.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields, default)]
pub struct CampaignSettings {
    /// Number of Latin-hypercube points.
    pub samples: usize,
    /// Seed of the Latin-hypercube generator (the design is a pure function of it).
    pub seed: u64,
    /// Range of the centre distance, m.
    #[serde(deserialize_with = "fom::config::exact_array")]
    pub center_distance_m: [f64; 2],
    /// Range of the effective friction coefficient.
    #[serde(deserialize_with = "fom::config::exact_array")]
    pub friction: [f64; 2],
    /// Range of the installation tension, N.
    #[serde(deserialize_with = "fom::config::exact_array")]
    pub installation_tension_n: [f64; 2],
    /// Range of the effective axial stiffness EA, N; absent (the default) keeps the
    /// configuration's EA and makes a three-variable design.
    #[serde(
        skip_serializing_if = "Option::is_none",
        deserialize_with = "fom::config::exact_array_opt"
    )]
    pub axial_stiffness_n: Option<[f64; 2]>,
    /// Ranges of effect parameters the design varies, keyed `effect-name.key` (e.g.
    /// `"bearing-drag.coulomb_nm" = [0.0, 2.0]`); the drive configuration must have the
    /// effect's table. Empty (the default) varies no effect.
    #[serde(skip_serializing_if = "BTreeMap::is_empty")]
    pub effect_parameters: BTreeMap<String, [f64; 2]>,
    /// The design of a toothed-belt campaign (`belt.kind = "toothed"`): ranges of side gap,
    /// load torque and shaft load, in place of the three variables above, which it leaves at
    /// the configuration's values. Its runs last the configuration's `simulation.duration_s`
    /// (a start-up, like the seed paper's) and learn the maximum-tooth-load distribution.
    /// Absent (the default) for every other belt.
    #[serde(skip_serializing_if = "Option::is_none")]
    pub tooth: Option<ToothRanges>,
    /// Longest run from motor start, s: a run ends once it has settled (`fom::steady`) and
    /// is recorded as unsettled if it has not by then. Not used by a toothed campaign.
    pub duration_s: f64,
    /// Shortest run, s; also the end of the start-up series the surrogate learns.
    pub min_duration_s: f64,
    /// Steady running a run needs before it ends, s.
    pub steady_length_s: f64,
}

impl Default for CampaignSettings {
    /// Defaults for the shipped HVAC drive. d from 0.415 m (a belt installed at 150 N is just
    /// slack there, -2 N; 47 N at 200 N: gross slip) to 0.424 m (422 N at the highest: a tight
    /// belt, creep only); the ramp between is where looseness shows.
    /// Friction 0.6-0.8 brackets the seed paper's 0.7. Tension 150-300 N spans the Gates
    /// table values for one A-section belt down to a belt that has lost a third of its
    /// installation tension (the seed paper's loosest condition d4 needs ~190 N;
    /// `docs/guide/train.md`, "The campaign"). Runs last 3 s at least (the fan runs up in ~1.5 s)
    /// and end once 2 s of steady running are in (`fom::UntilSettled::default`); a belt near
    /// the looseness knee needs up to ~7 s to settle, 15 s is the longest run.
    fn default() -> Self {
        Self {
            samples: 128,
            seed: 20_241_122,
            center_distance_m: [0.415, 0.424],
            friction: [0.6, 0.8],
            installation_tension_n: [150.0, 300.0],
            axial_stiffness_n: None,
            effect_parameters: BTreeMap::new(),
            tooth: None,
            duration_s: 15.0,
            min_duration_s: fom::config::UntilSettled::default().min_duration_s,
            steady_length_s: fom::config::UntilSettled::default().steady_length_s,
        }
    }
}

/// The design of a toothed-belt campaign: the `[tooth]` table of a settings file
/// (`CampaignSettings::ranges` gathers it into [`DesignRanges`]).
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields, default)]
pub struct ToothRanges {
    /// Range of the side gap (backlash) of a tooth in its groove, m.
    #[serde(deserialize_with = "fom::config::exact_array")]
    pub side_gap_m: [f64; 2],
    /// Range of the driven shaft's load torque (the torque profile's largest value), N m.
    #[serde(deserialize_with = "fom::config::exact_array")]
    pub load_torque_nm: [f64; 2],
    /// Range of the static shaft load (places the driven pulley), N.
    #[serde(deserialize_with = "fom::config::exact_array")]
    pub shaft_load_n: [f64; 2],
}

impl Default for ToothRanges {
    /// About the seed paper's drive (`fom/configs/synchronous-arc.toml`): side gaps from a
    /// half to beyond its largest (0.05-0.35 mm about its 0.1, 0.2, 0.3 mm), load torque 2-7 N m
    /// about its 4.5 N m, shaft load 300-500 N about its 400 N (the installation tension of a
    /// 24 mm belt of this pitch in the makers' tables lies in this span).
    fn default() -> Self {
        Self {
            side_gap_m: [0.05e-3, 0.35e-3],
            load_torque_nm: [2.0, 7.0],
            shaft_load_n: [300.0, 500.0],
        }
    }
}

/// The design space: each variable a campaign varies with its range, in design-column order
/// (`Variable::ALL`'s, whatever order they were inserted or read in). The one form of the ranges
/// everywhere past the settings file: what `CampaignSettings::ranges` returns, a model file's
/// header holds (a JSON object from variable key to `[lower, upper]`, in this order) and the range
/// checks read.
#[derive(Debug, Clone, PartialEq, Default)]
pub struct DesignRanges(Vec<(Variable, [f64; 2])>);

impl DesignRanges {
    /// Sets the range of `var`, in place if it has one, else at its column.
    pub fn insert(&mut self, var: Variable, range: [f64; 2]) {
        match self.0.iter_mut().find(|(v, _)| *v == var) {
            Some(e) => e.1 = range,
            None => {
                self.0.push((var, range));
                self.0.sort_by_key(|(v, _)| column(*v));
            }
        }
    }

    /// The range of `var`, if it is a design variable.
    pub fn get(&self, var: Variable) -> Option<[f64; 2]> {
        self.0.iter().find(|(v, _)| *v == var).map(|(_, r)| *r)
    }

    /// Whether `var` is a design variable.
    pub fn contains(&self, var: Variable) -> bool {
        self.get(var).is_some()
    }

    /// The design variables, in order.
    pub fn variables(&self) -> Vec<Variable> {
        self.0.iter().map(|(v, _)| *v).collect()
    }

    /// The first variable whose value (`value_of`; `None`: not set, not checked) lies outside
    /// its range (NaN included), with that value and the range.
    pub fn first_outside(
        &self,
        value_of: impl Fn(Variable) -> Option<f64>,
    ) -> Option<(Variable, f64, [f64; 2])> {
        self.0.iter().find_map(|&(v, [lo, hi])| {
            let x = value_of(v)?;
            (!(x >= lo && x <= hi)).then_some((v, x, [lo, hi]))
        })
    }

    /// Checks every range: finite, lower below upper, and the lower bound positive (zero
    /// allowed for an effect's magnitude, a side gap and a load torque, which may be off).
    pub fn check(&self) -> Result<(), String> {
        for &(var, [lo, hi]) in &self.0 {
            let name = var.key();
            if !(lo.is_finite() && hi.is_finite() && lo < hi) {
                return Err(format!(
                    "{name} = [{lo}, {hi}] is not a range (need finite lower < upper)"
                ));
            }
            let floor_ok = match var {
                Variable::Effect(_) | Variable::SideGap | Variable::LoadTorque => lo >= 0.0,
                _ => lo > 0.0,
            };
            if !floor_ok {
                return Err(format!("{name} = [{lo}, {hi}] must be positive"));
            }
        }
        Ok(())
    }
}

/// A variable's design column (its place in `Variable::ALL`).
fn column(v: Variable) -> usize {
    Variable::ALL
        .iter()
        .position(|x| *x == v)
        .expect("every variable has a column")
}

impl FromIterator<(Variable, [f64; 2])> for DesignRanges {
    fn from_iter<I: IntoIterator<Item = (Variable, [f64; 2])>>(iter: I) -> Self {
        let mut r = Self::default();
        for (v, range) in iter {
            r.insert(v, range);
        }
        r
    }
}

impl std::ops::Deref for DesignRanges {
    type Target = [(Variable, [f64; 2])];
    fn deref(&self) -> &Self::Target {
        &self.0
    }
}

impl IntoIterator for DesignRanges {
    type Item = (Variable, [f64; 2]);
    type IntoIter = std::vec::IntoIter<(Variable, [f64; 2])>;
    fn into_iter(self) -> Self::IntoIter {
        self.0.into_iter()
    }
}

impl<'a> IntoIterator for &'a DesignRanges {
    type Item = &'a (Variable, [f64; 2]);
    type IntoIter = std::slice::Iter<'a, (Variable, [f64; 2])>;
    fn into_iter(self) -> Self::IntoIter {
        self.0.iter()
    }
}

impl Serialize for DesignRanges {
    fn serialize<S: serde::Serializer>(&self, s: S) -> Result<S::Ok, S::Error> {
        use serde::ser::SerializeMap;
        let mut m = s.serialize_map(Some(self.0.len()))?;
        for (v, r) in &self.0 {
            m.serialize_entry(v.key(), r)?;
        }
        m.end()
    }
}

impl<'de> Deserialize<'de> for DesignRanges {
    /// A map from variable key to `[lower, upper]`, in any order (a model file's header is read
    /// through a key-sorted map); held, and written again, in design-column order, the order
    /// it was written in.
    fn deserialize<D: serde::Deserializer<'de>>(d: D) -> Result<Self, D::Error> {
        struct Visit;
        impl<'de> serde::de::Visitor<'de> for Visit {
            type Value = DesignRanges;
            fn expecting(&self, f: &mut std::fmt::Formatter) -> std::fmt::Result {
                f.write_str("a map from design variable to [lower, upper]")
            }
            fn visit_map<A: serde::de::MapAccess<'de>>(
                self,
                mut map: A,
            ) -> Result<DesignRanges, A::Error> {
                let mut r = DesignRanges::default();
                while let Some(key) = map.next_key::<String>()? {
                    let var = Variable::from_key(&key).ok_or_else(|| {
                        serde::de::Error::custom(format!("unknown design variable `{key}`"))
                    })?;
                    if r.contains(var) {
                        return Err(serde::de::Error::custom(format!("duplicate `{key}`")));
                    }
                    r.insert(var, map.next_value()?);
                }
                Ok(r)
            }
        }
        d.deserialize_map(Visit)
    }
}

impl CampaignSettings {
    /// Settings of a toothed-belt campaign: the defaults with the tooth design and fewer
    /// points (each 0.3 s run of the seed paper's drive takes ~9 s on one core).
    pub fn toothed_default() -> Self {
        Self {
            samples: 40,
            tooth: Some(ToothRanges::default()),
            ..Self::default()
        }
    }

    /// The design variables and their ranges, in design-column order: the settings file's
    /// keys (the three drive variables, `axial_stiffness_n`, `effect_parameters`, or a toothed
    /// campaign's `[tooth]` table) gathered into the one form, [`DesignRanges`].
    pub fn ranges(&self) -> DesignRanges {
        if let Some(t) = &self.tooth {
            return DesignRanges::from_iter([
                (Variable::SideGap, t.side_gap_m),
                (Variable::LoadTorque, t.load_torque_nm),
                (Variable::ShaftLoad, t.shaft_load_n),
            ]);
        }
        let mut r = DesignRanges::from_iter([
            (Variable::CenterDistance, self.center_distance_m),
            (Variable::Friction, self.friction),
            (Variable::InstallationTension, self.installation_tension_n),
        ]);
        if let Some(ea) = self.axial_stiffness_n {
            r.insert(Variable::AxialStiffness, ea);
        }
        for p in EffectParameter::ALL {
            if let Some(range) = self.effect_parameters.get(p.key()) {
                r.insert(Variable::Effect(p), *range);
            }
        }
        r
    }

    /// How each run ends: once settled, between `min_duration_s` and `duration_s`.
    pub fn until_settled(&self) -> fom::config::UntilSettled {
        fom::config::UntilSettled {
            min_duration_s: self.min_duration_s,
            steady_length_s: self.steady_length_s,
        }
    }

    /// Checks every value; the error names the setting.
    pub fn validate(&self) -> Result<(), TrainingError> {
        let bad = |m: String| Err(TrainingError::Settings(m));
        if self.samples < MIN_FIT_SAMPLES {
            // Refused before any run: a campaign too small to fit would run to the end first.
            return bad(format!(
                "samples = {} (a surrogate needs at least {MIN_FIT_SAMPLES} finished runs)",
                self.samples
            ));
        }
        if self.samples > MAX_DESIGN_SAMPLES {
            return bad(format!(
                "samples = {} is more than {MAX_DESIGN_SAMPLES}: the design's optimisation and \
                 the Gaussian-process fit grow with its square and cube (docs/validation/readers.md)",
                self.samples
            ));
        }
        if let Some(k) = self
            .effect_parameters
            .keys()
            .find(|k| !EffectParameter::ALL.iter().any(|p| p.key() == k.as_str()))
        {
            let known: Vec<&str> = EffectParameter::ALL.iter().map(|p| p.key()).collect();
            return bad(format!(
                "effect_parameters: unknown `{k}` (choose from {})",
                known.join(", ")
            ));
        }
        if self.tooth.is_some()
            && (self.axial_stiffness_n.is_some() || !self.effect_parameters.is_empty())
        {
            return bad(
                "a toothed campaign ([tooth]) varies side gap, load torque and shaft load only; \
                 remove axial_stiffness_n and effect_parameters"
                    .into(),
            );
        }
        self.ranges().check().map_err(TrainingError::Settings)?;
        if !(self.duration_s.is_finite() && self.duration_s > 0.0) {
            return bad(format!("duration_s = {} must be positive", self.duration_s));
        }
        if !(self.min_duration_s > 0.0 && self.min_duration_s <= self.duration_s) {
            return bad(format!(
                "min_duration_s = {} must lie in (0, duration_s = {}]",
                self.min_duration_s, self.duration_s
            ));
        }
        if !(self.steady_length_s >= fom::steady::SHORTEST_WINDOW_S
            && self.steady_length_s <= self.min_duration_s)
        {
            return bad(format!(
                "steady_length_s = {} must lie in [{}, min_duration_s = {}]",
                self.steady_length_s,
                fom::steady::SHORTEST_WINDOW_S,
                self.min_duration_s
            ));
        }
        Ok(())
    }

    /// TOML text of the settings (what `campaign.toml` holds).
    pub fn to_toml_string(&self) -> String {
        toml::to_string(self).expect("settings serialise")
    }

    /// Parses settings from TOML; `origin` names the source in errors.
    pub fn from_toml_str(text: &str, origin: &str) -> Result<Self, TrainingError> {
        let s: Self = toml::from_str(text)
            .map_err(|e| TrainingError::Settings(format!("{origin}: {}", e.to_string().trim())))?;
        s.validate()
            .map_err(|e| TrainingError::Settings(format!("{origin}: {e}")))?;
        Ok(s)
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn design_ranges_serialise_as_an_ordered_map_and_read_back() {
        let r = CampaignSettings::toothed_default().ranges();
        let json = serde_json::to_string(&r).unwrap();
        assert_eq!(
            json,
            r#"{"side_gap_m":[5e-5,0.00035],"load_torque_nm":[2.0,7.0],"shaft_load_n":[300.0,500.0]}"#
                .replace("5e-5", &serde_json::to_string(&0.05e-3).unwrap())
        );
        let back: DesignRanges = serde_json::from_str(&json).unwrap();
        assert_eq!(back, r);
        // Read in another order (a header through a key-sorted map), held in column order.
        let sorted: serde_json::Value = serde_json::from_str(&json).unwrap();
        let back: DesignRanges = serde_json::from_value(sorted).unwrap();
        assert_eq!(serde_json::to_string(&back).unwrap(), json);
        assert!(serde_json::from_str::<DesignRanges>(r#"{"nonsense":[1.0,2.0]}"#).is_err());
        assert!(serde_json::from_str::<DesignRanges>(
            r#"{"friction":[0.6,0.8],"friction":[0.6,0.8]}"#
        )
        .is_err());
    }

    #[test]
    fn design_ranges_check_and_find_the_first_value_outside() {
        let mut r = CampaignSettings::default().ranges();
        assert_eq!(r.variables()[0], Variable::CenterDistance);
        assert!(r.check().is_ok());
        let out = r.first_outside(|v| (v == Variable::Friction).then_some(0.9));
        assert_eq!(out, Some((Variable::Friction, 0.9, [0.6, 0.8])));
        assert_eq!(r.first_outside(|_| None), None);
        r.insert(Variable::Friction, [0.8, 0.6]);
        assert_eq!(r.len(), 3, "insert replaces a variable's range");
        assert!(r
            .check()
            .unwrap_err()
            .contains("friction = [0.8, 0.6] is not a range"));
    }
}
