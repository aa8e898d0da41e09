//! The shipped models, embedded once: the slip surrogate of the default HVAC drive and the
//! tooth-load surrogate of the seed paper's toothed drive (`fom/configs/synchronous-arc.toml`).
//! Their bytes are compiled into every binary that links this crate, so an installed `rom`
//! (`cargo install --path cli`) or a Python wheel answers from any directory; a model file
//! given by the user (`--model FILE`, `Surrogate.load(path)`) still overrides them. Every other
//! mention of where they lie in the source tree goes through [`Shipped::source_path`].

use std::path::PathBuf;

use crate::model_file::SurrogateFile;
use crate::tooth::ToothSurrogateFile;
use crate::RomError;

/// One shipped model file: where it lies relative to the workspace root, and its bytes.
#[derive(Debug, Clone, Copy)]
pub struct Shipped {
    /// Path relative to the workspace root (names the model in errors).
    pub path: &'static str,
    /// The file's bytes, embedded at compile time.
    pub bytes: &'static [u8],
}

/// Embeds the workspace file `$rel` (one literal names it once).
macro_rules! shipped {
    ($rel:literal) => {
        Shipped {
            path: $rel,
            bytes: include_bytes!(concat!(env!("CARGO_MANIFEST_DIR"), "/../", $rel)),
        }
    };
}

/// The shipped slip surrogate (trained on the default HVAC drive).
pub const SLIP: Shipped = shipped!("artifacts/hvac-surrogate.json");

/// The shipped tooth-load surrogate (trained on `fom/configs/synchronous-arc.toml`).
pub const TOOTH_LOAD: Shipped = shipped!("artifacts/synchronous-arc-tooth-surrogate.json");

/// The shipped models' manifest (`info::Manifest`; made by `cargo run -p beltwin-rom
/// --example manifest`, checked against the models by `rom/tests/manifest.rs`).
pub const MANIFEST: &str = include_str!(concat!(
    env!("CARGO_MANIFEST_DIR"),
    "/../artifacts/manifest.json"
));

/// Each shipped model with the `rom validate --json` files of its validation summary (paths
/// relative to the workspace root): the slip surrogate's held-out validations at seeds fresh
/// to it (uniform, knee and onset; the files its intervals were calibrated on are left out),
/// and the tooth-load surrogate's check against fresh full-order runs.
pub const VALIDATION_FILES: [(Shipped, &[&str]); 2] = [
    (
        SLIP,
        &[
            "tests/fixtures/validation/validation-seed20261127.json",
            "tests/fixtures/validation/validation-seed20261128.json",
            "tests/fixtures/validation/validation-seed20261135.json",
            "tests/fixtures/validation/validation-seed20261137.json",
            "tests/fixtures/validation/validation-seed20261138.json",
            "tests/fixtures/validation/validation-knee-seed20261127.json",
            "tests/fixtures/validation/validation-knee-seed20261128.json",
            "tests/fixtures/validation/validation-knee-seed20261135.json",
            "tests/fixtures/validation/validation-knee-seed20261137.json",
            "tests/fixtures/validation/validation-knee-seed20261138.json",
            "tests/fixtures/validation/validation-onset-seed20261133.json",
            "tests/fixtures/validation/validation-onset-seed20261134.json",
            "tests/fixtures/validation/validation-onset-seed20261136.json",
            "tests/fixtures/validation/validation-onset-seed20261137.json",
            "tests/fixtures/validation/validation-onset-seed20261138.json",
        ],
    ),
    (
        TOOTH_LOAD,
        &["tests/fixtures/validation/tooth-surrogate-validation.json"],
    ),
];

impl Shipped {
    /// Where the file lies in the source tree this crate was built from (tests, examples and
    /// tools that rewrite it; a running product reads [`Shipped::bytes`]).
    pub fn source_path(&self) -> PathBuf {
        PathBuf::from(env!("CARGO_MANIFEST_DIR"))
            .join("..")
            .join(self.path)
    }
}

/// The shipped slip surrogate, read and checked from the embedded bytes.
pub fn slip_model() -> Result<SurrogateFile, RomError> {
    SurrogateFile::from_bytes(SLIP.bytes, SLIP.path)
}

/// The shipped tooth-load surrogate, read and checked from the embedded bytes.
pub fn tooth_load_model() -> Result<ToothSurrogateFile, RomError> {
    ToothSurrogateFile::from_bytes(TOOTH_LOAD.bytes, TOOTH_LOAD.path)
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn the_embedded_models_are_the_source_tree_files_and_load() {
        for s in [SLIP, TOOTH_LOAD] {
            assert_eq!(
                std::fs::read(s.source_path()).unwrap(),
                s.bytes,
                "{}",
                s.path
            );
        }
        slip_model().unwrap();
        tooth_load_model().unwrap();
    }

    #[test]
    fn several_points_at_once_and_the_mean_alone_are_the_point_predictions_bit_for_bit() {
        let file = slip_model().unwrap();
        let s = &file.surrogate;
        let cfg = s.config().unwrap();
        let nominal = fom::DesignPoint::nominal(&cfg);
        let qs: Vec<fom::DesignPoint> = [
            (0.42, 0.3, 200.0),
            (0.4155, 0.25, 160.0),
            (0.423, 0.35, 230.0),
        ]
        .into_iter()
        .map(|(d, mu, t)| fom::DesignPoint {
            center_distance_m: d,
            friction: mu,
            installation_tension_n: t,
            ..nominal
        })
        .collect();
        let together = s.predict_points(&cfg, &qs).unwrap();
        for (q, t) in qs.iter().zip(&together) {
            let point = s.predict_point(&cfg, q).unwrap();
            let bits = |p: &crate::surrogate::PointPrediction| {
                [p.mean_slip_pct, p.surrogate_std_pct, p.likelihood_std_pct].map(f64::to_bits)
            };
            assert_eq!(bits(t), bits(&point), "{q:?}");
            assert_eq!(t.quantiles_pct, point.quantiles_pct);
            let mean = s.predict_mean_slip_pct(&cfg, q);
            assert_eq!(mean.to_bits(), point.mean_slip_pct.to_bits(), "{q:?}");
        }
    }
}
