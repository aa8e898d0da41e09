//! The full-order model as a co-simulation slave. It steps with `rom simulate`'s own pieces:
//! static equilibrium (`fom::simulation::prepare`), the step (`Model::step`), the rows
//! (`fom::simulation::RowState`) and the same direction renormalisation and health check every
//! output interval, so that at a communication step equal to the configuration's output
//! interval its outputs are `rom simulate`'s rows (docs/decisions/fmi-version.md).

use fom::integrator::{StepMode, StepWorkspace};
use fom::model::{DRIVEN, DRIVER};
use fom::pulley::ShaftDrive;
use fom::simulation::RowState;
use fom::{Model, ValidConfig};

use crate::variables::{fom_variables, Var, EXTRA_LOAD, FOM_OUTPUTS, MOTOR_ON};

/// A full-order model being stepped, and where each value lives.
#[derive(Debug, Clone)]
pub struct FomSlave {
    cfg: ValidConfig,
    /// The model at static equilibrium and its rows, once initialised.
    run: Option<Run>,
    motor_vr: Option<usize>,
    load_vr: Option<usize>,
    first_output_vr: usize,
}

#[derive(Debug, Clone)]
struct Run {
    model: Model,
    ws: StepWorkspace,
    rows: RowState,
    /// Steps taken since the start.
    steps: u64,
    /// Steps per output interval of the configuration (renormalisation and health check).
    steps_per_row: u64,
    /// The configuration's motor start time, s, and constant load torque, N m.
    motor_start_s: f64,
    constant_load_nm: f64,
}

impl FomSlave {
    /// Reads the configuration of the FMU's resources.
    pub fn load(config: &std::path::Path) -> Result<(Self, Vec<Var>), String> {
        let cfg = fom::DriveConfig::from_file(config).map_err(|e| e.to_string())?;
        let table = fom_variables(&cfg)?;
        let index = |name: &str| table.iter().position(|v| v.name == name);
        let slave = Self {
            motor_vr: index(MOTOR_ON),
            load_vr: index(EXTRA_LOAD),
            first_output_vr: index(FOM_OUTPUTS[0].0).ok_or("no outputs")?,
            run: None,
            cfg,
        };
        Ok((slave, table))
    }

    /// The model step, s (once initialised).
    pub fn step_s(&self) -> Option<f64> {
        self.run.as_ref().map(|r| r.model.params.step_s)
    }

    /// The model's own time, s (once initialised).
    pub fn time_s(&self) -> Option<f64> {
        self.run.as_ref().map(|r| r.model.time_s)
    }

    /// Builds the model and brings it to static equilibrium; the outputs are the first row.
    pub fn initialise(&mut self, values: &mut [f64]) -> Result<(), String> {
        let (model, _) = fom::simulation::prepare(&self.cfg).map_err(|e| e.to_string())?;
        let rows = RowState::new(&model);
        let first = rows.first_row(&model);
        let dt = model.params.step_s;
        let steps_per_row = ((self.cfg.simulation.output_interval_s / dt).round() as u64).max(1);
        let motor_start_s = match &model.pulleys[DRIVER].drive {
            ShaftDrive::Motor(m) => m.start_time_s,
            _ => 0.0,
        };
        let constant_load_nm = match &model.pulleys[DRIVEN].drive {
            ShaftDrive::Load(l) => l.constant_nm,
            _ => 0.0,
        };
        self.run = Some(Run {
            model,
            ws: StepWorkspace::default(),
            rows,
            steps: 0,
            steps_per_row,
            motor_start_s,
            constant_load_nm,
        });
        self.write_outputs(values, &first.values()[1..]);
        Ok(())
    }

    fn write_outputs(&self, values: &mut [f64], row: &[f64]) {
        let k = self.first_output_vr;
        values[k..k + FOM_OUTPUTS.len()].copy_from_slice(row);
    }

    /// Advances the model over one communication step of `steps` model steps with the inputs
    /// in `values` held; the outputs become the mean over the step.
    pub fn advance(&mut self, values: &mut [f64], steps: u64) -> Result<(), String> {
        let run = self.run.as_mut().ok_or("the model is not initialised")?;
        if let Some(vr) = self.motor_vr {
            if let ShaftDrive::Motor(m) = &mut run.model.pulleys[DRIVER].drive {
                // Supply off: the Kloss torque is zero before the start time (`fom::drive`).
                m.start_time_s = if values[vr] != 0.0 {
                    run.motor_start_s
                } else {
                    f64::INFINITY
                };
            }
        }
        if let Some(vr) = self.load_vr {
            let extra = values[vr];
            if !extra.is_finite() {
                return Err(format!(
                    "input {EXTRA_LOAD} = {extra} is not a finite torque"
                ));
            }
            if let ShaftDrive::Load(l) = &mut run.model.pulleys[DRIVEN].drive {
                // The constant part of the load (`fom::drive::Load`): opposes rotation.
                l.constant_nm = run.constant_load_nm + extra;
            }
        }
        for _ in 0..steps {
            run.model.step(StepMode::Dynamic, &mut run.ws);
            run.steps += 1;
            run.rows.accumulate(&run.model);
            if run.steps % run.steps_per_row == 0 {
                // As `fom::simulation::run_prepared` does at every row.
                run.model.belt.renormalise_directions();
                run.model.check_health().map_err(|e| e.to_string())?;
            }
        }
        run.model.check_health().map_err(|e| e.to_string())?;
        let row = run.rows.finish(&run.model, &mut None);
        self.write_outputs(values, &row.values()[1..]);
        Ok(())
    }
}
