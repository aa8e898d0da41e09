//! The slip surrogate as a co-simulation slave: its outputs are `rom predict`'s answer at its
//! inputs, by the same function (`rom::predict_distribution`).

use std::path::Path;

use fom::params::Variable as DesignVariable;
use fom::ValidConfig;
use rom::SurrogateFile;

use crate::variables::{surrogate_start_point, surrogate_variables, Var, SURROGATE_OUTPUTS};

/// A loaded slip surrogate, the configuration it is used on and where each value lives.
#[derive(Debug, Clone)]
pub struct SurrogateSlave {
    file: std::sync::Arc<SurrogateFile>,
    cfg: ValidConfig,
    /// The design variable of each input's value reference.
    inputs: Vec<(usize, DesignVariable)>,
    samples_vr: usize,
    allow_vr: usize,
    first_output_vr: usize,
    extrapolated_vr: usize,
}

impl SurrogateSlave {
    /// Loads the surrogate and its configuration from the FMU's resources (the configuration is
    /// checked against the one the surrogate was trained on).
    pub fn load(model: &Path, config: &Path) -> Result<(Self, Vec<Var>), String> {
        let file = rom::ModelFile::load(model)
            .and_then(|f| f.into_slip("the surrogate FMU"))
            .map_err(|e| e.to_string())?;
        let cfg = file.drive_config(Some(config)).map_err(|e| e.to_string())?;
        let table = surrogate_variables(&cfg, &file.surrogate.settings.ranges());
        let index = |name: &str| table.iter().position(|(v, _)| v.name == name);
        let slave = Self {
            inputs: table
                .iter()
                .enumerate()
                .filter_map(|(k, (_, d))| d.map(|d| (k, d)))
                .collect(),
            samples_vr: index("samples").ok_or("no samples parameter")?,
            allow_vr: index("allow_extrapolation").ok_or("no extrapolation switch")?,
            first_output_vr: index(SURROGATE_OUTPUTS[0].0).ok_or("no outputs")?,
            extrapolated_vr: index("extrapolated").ok_or("no extrapolation flag")?,
            file: std::sync::Arc::new(file),
            cfg,
        };
        Ok((slave, table.into_iter().map(|(v, _)| v).collect()))
    }

    /// Sets the outputs in `values` from the inputs and parameters there.
    pub fn evaluate(&self, values: &mut [f64]) -> Result<(), String> {
        let design: Vec<DesignVariable> = self.inputs.iter().map(|(_, d)| *d).collect();
        let mut q = surrogate_start_point(&self.cfg, &design);
        for (vr, d) in &self.inputs {
            q.set(*d, values[*vr]);
        }
        let samples = values[self.samples_vr];
        let d = rom::predict_distribution(
            &self.file.surrogate,
            &self.cfg,
            &q,
            samples as usize,
            values[self.allow_vr] != 0.0,
        )
        .map_err(|e| match e {
            // The input at fault by its FMU name (the design variable's key).
            rom::RomError::Impossible { input, reason } => {
                format!("input {} = {}: {reason}", input.key(), values_of(&q, input))
            }
            rom::RomError::InvalidArgument { message, .. } => {
                format!("parameter samples = {samples}: {message}")
            }
            other => other.to_string(),
        })?;
        let p = &d.quantiles_pct;
        let out = [
            d.mean_slip_pct,
            d.std_slip_pct,
            p.p05,
            p.p25,
            p.p50,
            p.p75,
            p.p95,
            d.surrogate_std_pct,
        ];
        values[self.first_output_vr..self.first_output_vr + out.len()].copy_from_slice(&out);
        values[self.extrapolated_vr] = f64::from(u8::from(d.extrapolated));
        Ok(())
    }
}

/// The value of a design variable at a point, readable.
fn values_of(q: &fom::DesignPoint, v: DesignVariable) -> String {
    q.get(v).map_or("?".into(), fom::readable::readable)
}
