//! The surrogate kinds behind one interface: one model-file loader that reads the checked
//! header, learns the kind from it and returns that kind's model ([`ModelFile`]), and the
//! outputs every kind renders the same way ([`Prediction`], [`Validation`]). The slip
//! surrogate (`surrogate`) and the tooth-load surrogate of a toothed belt (`tooth`) are the two
//! kinds; adding a third is described in `docs/extending/surrogate-kind.md`, and why this is an
//! enum of kinds with trait objects for their outputs in
//! `docs/decisions/surrogate-kinds-enum.md`.

use std::path::Path;

use fom::config::BeltKind;
use fom::params::Variable;
use fom::{DesignPoint, DriveConfig};
use training::{CampaignSettings, Dataset};

use crate::model_file::{open_model, read_header_line, SurrogateFile};
use crate::plot::BoxSpec;
use crate::tooth::{ToothSurrogate, ToothSurrogateFile};
use crate::{RomError, Surrogate};

/// What a surrogate predicts: the kinds a model file can hold.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Kind {
    /// Slip of a V-belt drive over centre distance, friction and installation tension
    /// (`surrogate::Surrogate`).
    Slip,
    /// Maximum tooth load of a toothed belt over side gap, load torque and shaft load
    /// (`tooth::ToothSurrogate`).
    ToothLoad,
}

impl Kind {
    /// Every kind, in the order the loader tries their formats.
    pub const ALL: [Kind; 2] = [Kind::Slip, Kind::ToothLoad];

    /// The header `format` values of this kind this build reads (the format names the kind
    /// and its version); the first is the one written.
    pub fn formats(self) -> &'static [&'static str] {
        match self {
            Kind::Slip => &[
                crate::model_file::FORMAT,
                crate::model_file::FORMAT_2,
                crate::model_file::FORMAT_1,
            ],
            Kind::ToothLoad => &[crate::tooth::FORMAT],
        }
    }

    /// The kind whose file has header format `format`.
    pub fn of_format(format: &str) -> Option<Kind> {
        Kind::ALL
            .into_iter()
            .find(|k| k.formats().contains(&format))
    }

    /// The kind a drive configuration's campaign trains: a toothed belt's tooth loads, else
    /// slip.
    pub fn for_config(cfg: &DriveConfig) -> Kind {
        match cfg.belt.kind {
            BeltKind::Toothed => Kind::ToothLoad,
            _ => Kind::Slip,
        }
    }

    /// Name of the kind in messages.
    pub fn name(self) -> &'static str {
        match self {
            Kind::Slip => "slip surrogate",
            Kind::ToothLoad => "tooth-load surrogate",
        }
    }

    /// The design variables a request to this kind may set (the family of its inputs; a
    /// model answers only for those it was trained over, `Surrogate::check_inputs`).
    pub fn inputs(self) -> Vec<Variable> {
        match self {
            Kind::Slip => {
                let tooth = Kind::ToothLoad.inputs();
                Variable::ALL
                    .into_iter()
                    .filter(|v| !tooth.contains(v))
                    .collect()
            }
            Kind::ToothLoad => vec![Variable::SideGap, Variable::LoadTorque, Variable::ShaftLoad],
        }
    }

    /// The variables a request to this kind must set (the rest default to the
    /// configuration's).
    pub fn required(self) -> &'static [Variable] {
        match self {
            Kind::Slip => &[Variable::CenterDistance],
            Kind::ToothLoad => &[],
        }
    }

    /// Whether a campaign of this kind takes refinement rounds (`refine`: points where the
    /// slip surrogate is least certain); a tooth-load campaign is a Latin hypercube.
    pub fn refines(self) -> bool {
        matches!(self, Kind::Slip)
    }

    /// The default campaign of this kind (`rom train` without a settings file).
    pub fn default_settings(self) -> CampaignSettings {
        match self {
            Kind::Slip => CampaignSettings::default(),
            Kind::ToothLoad => CampaignSettings::toothed_default(),
        }
    }

    /// The shipped model of this kind (`shipped`).
    pub fn shipped(self) -> Result<ModelFile, RomError> {
        Ok(match self {
            Kind::Slip => ModelFile::Slip(crate::shipped::slip_model()?),
            Kind::ToothLoad => ModelFile::ToothLoad(crate::shipped::tooth_load_model()?),
        })
    }
}

/// A loaded model file of any kind, header checked. (One is loaded per command: the size
/// difference of the variants costs nothing worth a box.)
#[derive(Debug, Clone)]
#[allow(clippy::large_enum_variant)]
pub enum ModelFile {
    Slip(SurrogateFile),
    ToothLoad(ToothSurrogateFile),
}

/// A prediction request in the library's terms: the point (variables a front end left open
/// take the configuration's value), and the slip kind's friction samples.
#[derive(Debug, Clone, Copy)]
pub struct Request {
    pub point: DesignPoint,
    /// Friction samples propagated (slip kind; `predict::DEFAULT_SAMPLES`).
    pub samples: usize,
    /// Answer outside the trained ranges (the output says so).
    pub allow_extrapolation: bool,
}

/// Version of the JSON objects `rom predict` and `rom info` print (`schema_version`), raised
/// when a field changes meaning or goes away (a new field does not raise it).
pub const SCHEMA_VERSION: u32 = 1;

/// A JSON object stamped with [`SCHEMA_VERSION`] and the id of the model that made it.
#[derive(serde::Serialize)]
struct Stamped<'a, T: serde::Serialize> {
    schema_version: u32,
    model_id: &'a str,
    #[serde(flatten)]
    body: &'a T,
}

/// Pretty JSON of `body` with `schema_version` and `model_id` first.
pub fn stamped_json<T: serde::Serialize>(model_id: &str, body: &T) -> String {
    serde_json::to_string_pretty(&Stamped {
        schema_version: SCHEMA_VERSION,
        model_id,
        body,
    })
    .expect("a report serialises")
}

/// A prediction of any kind, rendered by the kind.
pub trait Prediction {
    /// The readable text (`rom predict`), without a final newline.
    fn to_text(&self) -> String;
    /// CSV rows, with the header line and a final newline.
    fn to_csv(&self) -> String;
    /// Pretty JSON (the object `rom predict --format json` prints), stamped with the schema
    /// version and `model_id` ([`ModelFile::model_id`]).
    fn to_json(&self, model_id: &str) -> String;
    /// The box plot of the predicted distribution (title and box), if the kind draws one.
    fn box_plot(&self) -> Option<(String, BoxSpec)> {
        None
    }
}

/// A validation against fresh full-order runs of any kind, rendered by the kind.
pub trait Validation {
    /// The readable table and summary (`rom validate`).
    fn to_text(&self) -> String;
    /// Pretty JSON (`rom validate --json`).
    fn to_json(&self) -> String;
}

impl Prediction for crate::Distribution {
    fn to_text(&self) -> String {
        crate::Distribution::to_text(self)
    }
    fn to_csv(&self) -> String {
        crate::Distribution::to_csv(self)
    }
    fn to_json(&self, model_id: &str) -> String {
        stamped_json(model_id, self)
    }
    fn box_plot(&self) -> Option<(String, BoxSpec)> {
        let q = &self.quantiles_pct;
        Some((
            format!("Predicted slip at d = {:.4} m", self.center_distance_m),
            BoxSpec {
                category: format!("d = {:.4} m", self.center_distance_m),
                series: "twin (surrogate)".into(),
                quantiles: [q.p05, q.p25, q.p50, q.p75, q.p95],
            },
        ))
    }
}

impl Prediction for crate::tooth::ToothPrediction {
    fn to_text(&self) -> String {
        crate::tooth::ToothPrediction::to_text(self)
    }
    fn to_csv(&self) -> String {
        crate::tooth::ToothPrediction::to_csv(self)
    }
    fn to_json(&self, model_id: &str) -> String {
        stamped_json(model_id, self)
    }
}

impl Validation for crate::validate::ValidationReport {
    fn to_text(&self) -> String {
        crate::validate::ValidationReport::to_text(self)
    }
    fn to_json(&self) -> String {
        serde_json::to_string_pretty(self).expect("a report serialises")
    }
}

impl Validation for Vec<crate::tooth::ToothCheck> {
    fn to_text(&self) -> String {
        crate::tooth::validation_text(self)
    }
    fn to_json(&self) -> String {
        serde_json::to_string_pretty(self).expect("a report serialises")
    }
}

impl ModelFile {
    /// Reads a model file of any kind: its header line, whose `format` names the kind and
    /// version, then that kind's checks (checksum, payload).
    pub fn load(path: &Path) -> Result<Self, RomError> {
        let (reader, file_len) = open_model(path)?;
        Self::read(reader, file_len, &path.display().to_string())
    }

    /// [`ModelFile::load`] of a file's bytes held in memory; `origin` names it in errors.
    pub fn from_bytes(bytes: &[u8], origin: &str) -> Result<Self, RomError> {
        Self::read(bytes, bytes.len() as u64, origin)
    }

    fn read(
        mut reader: impl std::io::BufRead,
        file_len: u64,
        origin: &str,
    ) -> Result<Self, RomError> {
        let (head, nl) = read_header_line(&mut reader, origin)?;
        let format = head.get("format").and_then(|f| f.as_str()).unwrap_or("");
        match Kind::of_format(format) {
            Some(Kind::ToothLoad) => Ok(ModelFile::ToothLoad(ToothSurrogateFile::read_after(
                head, nl, reader, file_len, origin,
            )?)),
            // The slip kind's reader names the formats it reads when the header has none.
            Some(Kind::Slip) | None => Ok(ModelFile::Slip(SurrogateFile::read_after(
                head, nl, reader, file_len, origin,
            )?)),
        }
    }

    /// `--model FILE` when given, else the shipped model of the kind `config` trains (the
    /// default drive's slip surrogate without a configuration); with the drive configuration
    /// to use it on (`drive_config`).
    pub fn open(
        model: Option<&Path>,
        config: Option<&Path>,
    ) -> Result<(Self, fom::ValidConfig), RomError> {
        let file = match (model, config) {
            (Some(m), _) => Self::load(m)?,
            (None, Some(c)) => {
                let cfg: fom::ValidConfig = DriveConfig::from_file(c)?;
                Kind::for_config(&cfg).shipped()?
            }
            (None, None) => Kind::Slip.shipped()?,
        };
        let cfg = file.drive_config(config)?;
        Ok((file, cfg))
    }

    /// The model's id: the SHA-256 its header records over the sealed file (header and
    /// payload; format 1: the payload), 64 hex digits.
    pub fn model_id(&self) -> &str {
        match self {
            ModelFile::Slip(f) => &f.header.sha256,
            ModelFile::ToothLoad(f) => &f.header.sha256,
        }
    }

    /// The kind of the model.
    pub fn kind(&self) -> Kind {
        match self {
            ModelFile::Slip(_) => Kind::Slip,
            ModelFile::ToothLoad(_) => Kind::ToothLoad,
        }
    }

    /// The design variables the model was trained over, with their ranges, in input order.
    pub fn ranges(&self) -> training::DesignRanges {
        match self {
            ModelFile::Slip(f) => f.surrogate.settings.ranges(),
            ModelFile::ToothLoad(f) => f.surrogate.settings.ranges(),
        }
    }

    /// Seed of the training design (a validation takes another).
    pub fn training_seed(&self) -> u64 {
        match self {
            ModelFile::Slip(f) => f.header.seed,
            ModelFile::ToothLoad(f) => f.header.seed,
        }
    }

    /// The drive configuration to use the model with: `config`, refused unless the model was
    /// trained on it, or the model's own.
    pub fn drive_config(&self, config: Option<&Path>) -> Result<fom::ValidConfig, RomError> {
        match self {
            ModelFile::Slip(f) => f.drive_config(config),
            ModelFile::ToothLoad(f) => f.drive_config(config),
        }
    }

    /// The slip surrogate, or an error naming the kind it is (`what` names the use that
    /// needs the slip kind).
    pub fn into_slip(self, what: &str) -> Result<SurrogateFile, RomError> {
        match self {
            ModelFile::Slip(f) => Ok(f),
            other => Err(RomError::Data(format!(
                "{what}: this model is a {}, not a slip surrogate",
                other.kind().name()
            ))),
        }
    }

    /// The model's prediction at `r`.
    pub fn predict(&self, cfg: &DriveConfig, r: &Request) -> Result<Box<dyn Prediction>, RomError> {
        Ok(match self {
            ModelFile::Slip(f) => Box::new(crate::predict_distribution(
                &f.surrogate,
                cfg,
                &r.point,
                r.samples,
                r.allow_extrapolation,
            )?),
            ModelFile::ToothLoad(f) => {
                Box::new(f.surrogate.predict(cfg, &r.point, r.allow_extrapolation)?)
            }
        })
    }

    /// The predicted start-up slip series at `q` as (time s, slip %) rows, for the kinds that
    /// learn one.
    pub fn startup_series(&self, cfg: &DriveConfig, q: &DesignPoint) -> Option<Vec<[f64; 2]>> {
        match self {
            ModelFile::Slip(f) => {
                let s = &f.surrogate;
                let series = s.predict_startup(cfg, q);
                Some(
                    s.startup_time_s
                        .iter()
                        .zip(series)
                        .map(|(&t, v)| [t, v])
                        .collect(),
                )
            }
            ModelFile::ToothLoad(_) => None,
        }
    }

    /// The model against `points` fresh full-order runs (a Latin hypercube of the trained box
    /// with `seed`), `on_done` called after each.
    pub fn validate(
        &self,
        points: usize,
        seed: u64,
        on_done: &(dyn Fn(usize) + Sync),
    ) -> Result<Box<dyn Validation>, RomError> {
        Ok(match self {
            ModelFile::Slip(f) => {
                let mut r = crate::validate::validate(&f.surrogate, points, seed, on_done)?;
                r.config_sha256 = Some(f.header.config_sha256.clone());
                Box::new(r)
            }
            ModelFile::ToothLoad(f) => Box::new(crate::tooth::validate_tooth(
                &f.surrogate,
                points,
                seed,
                on_done,
            )?),
        })
    }

    /// Fits a model of `kind` to a complete data set (`knee_aligned`: the slip kind's
    /// knee-aligned input, `surrogate::FRICTION_EXPONENTS`), its header stamped now.
    pub fn fit(kind: Kind, ds: &Dataset, knee_aligned: bool) -> Result<Self, RomError> {
        let hash = training::config_hash(&ds.config);
        Ok(match kind {
            Kind::Slip => ModelFile::Slip(SurrogateFile::new(fit_slip(ds, knee_aligned)?, hash)),
            Kind::ToothLoad => {
                ModelFile::ToothLoad(ToothSurrogateFile::new(ToothSurrogate::fit(ds)?, hash))
            }
        })
    }

    /// Writes the file atomically.
    pub fn save(&self, path: &Path) -> Result<(), RomError> {
        match self {
            ModelFile::Slip(f) => f.save(path),
            ModelFile::ToothLoad(f) => f.save(path),
        }
    }
}

/// The slip surrogate of `ds`, with the knee-aligned input's exponent chosen by likelihood
/// when `knee_aligned`, else on the capacity itself.
pub fn fit_slip(ds: &Dataset, knee_aligned: bool) -> Result<Surrogate, RomError> {
    let exponents: &[f64] = if knee_aligned {
        &crate::surrogate::FRICTION_EXPONENTS
    } else {
        &[0.0]
    };
    Surrogate::fit_with_exponents(ds, crate::surrogate::DEFAULT_ENERGY, exponents)
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn the_loader_returns_the_kind_its_header_names() {
        for (s, kind) in [
            (crate::shipped::SLIP, Kind::Slip),
            (crate::shipped::TOOTH_LOAD, Kind::ToothLoad),
        ] {
            let m = ModelFile::from_bytes(s.bytes, s.path).unwrap();
            assert_eq!(m.kind(), kind);
        }
        let e = ModelFile::from_bytes(b"{\"format\":\"x/1\"}\n", "x").unwrap_err();
        assert!(e.to_string().contains("format `x/1`"), "{e}");
    }

    #[test]
    fn the_kinds_inputs_do_not_overlap() {
        let slip = Kind::Slip.inputs();
        assert!(Kind::ToothLoad.inputs().iter().all(|v| !slip.contains(v)));
        assert!(slip.contains(&Variable::CenterDistance));
    }
}
