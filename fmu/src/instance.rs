//! One FMU instance: its phase in the FMI 2.0 co-simulation state machine (FMI 2.0.4
//! standard, section 4.2.4), its values, and the slave of its kind. Every call out of order is
//! refused with a message naming the call and the phase.

use std::path::Path;

use crate::fom_slave::FomSlave;
use crate::package::{Manifest, MANIFEST_FILE};
use crate::surrogate::SurrogateSlave;
use crate::variables::{Causality, Type, Var};

/// Where an instance is in its life.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Phase {
    Instantiated,
    Initialization,
    Stepping,
    Terminated,
    /// A call failed in a way that leaves the state unusable; only reset or free help.
    Failed,
}

/// The model behind an instance.
#[derive(Debug, Clone)]
pub enum Slave {
    Surrogate(Box<SurrogateSlave>),
    Fom(Box<FomSlave>),
}

/// Everything an instance holds; cloned whole for `fmi2GetFMUstate`.
#[derive(Debug, Clone)]
pub struct Instance {
    pub phase: Phase,
    pub vars: std::sync::Arc<Vec<Var>>,
    pub values: Vec<f64>,
    pub slave: Slave,
    /// The surrogate's outputs wait for a change of its inputs.
    dirty: bool,
    /// The start time the importer set up, s (the model's own time starts at zero there).
    start_time_s: f64,
    /// The original slave, kept for `fmi2Reset`.
    pristine: Box<Slave>,
}

/// An error of a call: the message the logger gets.
pub type CallResult<T = ()> = Result<T, String>;

impl Instance {
    /// Reads the FMU's resources; `guid` must be the one of the model description.
    pub fn new(resources: &Path, guid: &str) -> CallResult<Self> {
        let manifest_path = resources.join(MANIFEST_FILE);
        let text = std::fs::read_to_string(&manifest_path)
            .map_err(|e| format!("cannot read {}: {e}", manifest_path.display()))?;
        let manifest: Manifest = toml::from_str(&text)
            .map_err(|e| format!("{}: {}", manifest_path.display(), e.to_string().trim()))?;
        if manifest.guid != guid {
            return Err(format!(
                "the instantiation token {guid} is not this FMU's ({}): the model description \
                 and the binary's resources do not belong together",
                manifest.guid
            ));
        }
        let config = resources.join(&manifest.config);
        let (slave, vars) = match manifest.model.as_deref() {
            Some(model) => {
                let (s, v) = SurrogateSlave::load(&resources.join(model), &config)?;
                (Slave::Surrogate(Box::new(s)), v)
            }
            None => {
                let (s, v) = FomSlave::load(&config)?;
                (Slave::Fom(Box::new(s)), v)
            }
        };
        let values = vars.iter().map(|v| v.start).collect();
        Ok(Self {
            phase: Phase::Instantiated,
            vars: std::sync::Arc::new(vars),
            values,
            pristine: Box::new(slave.clone()),
            slave,
            dirty: true,
            start_time_s: 0.0,
        })
    }

    fn expect(&self, call: &str, phases: &[Phase]) -> CallResult {
        if phases.contains(&self.phase) {
            Ok(())
        } else {
            Err(format!(
                "{call} is not allowed in the {:?} phase (allowed in: {phases:?})",
                self.phase
            ))
        }
    }

    pub fn setup_experiment(&mut self, start_time_s: f64) -> CallResult {
        self.expect("fmi2SetupExperiment", &[Phase::Instantiated])?;
        if !start_time_s.is_finite() {
            return Err(format!("start time {start_time_s} is not a finite time"));
        }
        self.start_time_s = start_time_s;
        Ok(())
    }

    pub fn enter_initialization(&mut self) -> CallResult {
        self.expect("fmi2EnterInitializationMode", &[Phase::Instantiated])?;
        self.phase = Phase::Initialization;
        Ok(())
    }

    pub fn exit_initialization(&mut self) -> CallResult {
        self.expect("fmi2ExitInitializationMode", &[Phase::Initialization])?;
        match &mut self.slave {
            Slave::Surrogate(s) => s.evaluate(&mut self.values)?,
            Slave::Fom(f) => f
                .initialise(&mut self.values)
                .inspect_err(|_| self.phase = Phase::Failed)?,
        }
        self.dirty = false;
        self.phase = Phase::Stepping;
        Ok(())
    }

    pub fn terminate(&mut self) -> CallResult {
        self.expect("fmi2Terminate", &[Phase::Stepping, Phase::Initialization])?;
        self.phase = Phase::Terminated;
        Ok(())
    }

    pub fn reset(&mut self) {
        self.slave = (*self.pristine).clone();
        self.values = self.vars.iter().map(|v| v.start).collect();
        self.phase = Phase::Instantiated;
        self.dirty = true;
        self.start_time_s = 0.0;
    }

    /// The variable of value reference `vr` and of type `ty`.
    fn var(&self, vr: u32, ty: Type) -> CallResult<&Var> {
        match self.vars.get(vr as usize) {
            Some(v) if v.ty == ty => Ok(v),
            Some(v) => Err(format!(
                "value reference {vr} is {} of type {:?}, not {ty:?}",
                v.name, v.ty
            )),
            None => Err(format!(
                "value reference {vr} does not exist (this FMU has {})",
                self.vars.len()
            )),
        }
    }

    /// Values of `vrs` of type `ty` into `out`.
    pub fn get(&mut self, vrs: &[u32], ty: Type, out: &mut [f64]) -> CallResult {
        self.expect(
            "a get call",
            &[
                Phase::Initialization,
                Phase::Stepping,
                Phase::Terminated,
                Phase::Failed,
            ],
        )?;
        for &vr in vrs {
            self.var(vr, ty)?;
        }
        if self.dirty && self.phase != Phase::Failed {
            if let Slave::Surrogate(s) = &self.slave {
                s.evaluate(&mut self.values)?;
                self.dirty = false;
            }
        }
        for (o, &vr) in out.iter_mut().zip(vrs) {
            *o = self.values[vr as usize];
        }
        Ok(())
    }

    /// Sets `vrs` of type `ty` to `vals`: inputs at any time before termination, parameters
    /// before initialisation ends, outputs never.
    pub fn set(&mut self, vrs: &[u32], ty: Type, vals: &[f64]) -> CallResult {
        for &vr in vrs {
            let v = self.var(vr, ty)?;
            let allowed = match v.causality {
                Causality::Output => false,
                Causality::Parameter => {
                    matches!(self.phase, Phase::Instantiated | Phase::Initialization)
                }
                Causality::Input => matches!(
                    self.phase,
                    Phase::Instantiated | Phase::Initialization | Phase::Stepping
                ),
            };
            if !allowed {
                return Err(format!(
                    "{} ({:?}) cannot be set in the {:?} phase",
                    v.name, v.causality, self.phase
                ));
            }
        }
        for (&vr, &x) in vrs.iter().zip(vals) {
            self.values[vr as usize] = x;
        }
        self.dirty = true;
        Ok(())
    }

    /// `fmi2DoStep` from `t_s` over `h_s`.
    pub fn do_step(&mut self, t_s: f64, h_s: f64) -> CallResult {
        self.expect("fmi2DoStep", &[Phase::Stepping])?;
        if !(h_s.is_finite() && h_s > 0.0) {
            return Err(format!("communication step {h_s} s is not a positive time"));
        }
        match &mut self.slave {
            Slave::Surrogate(s) => {
                s.evaluate(&mut self.values)?;
                self.dirty = false;
                Ok(())
            }
            Slave::Fom(f) => {
                let dt = f.step_s().ok_or("the model is not initialised")?;
                let now = self.start_time_s + f.time_s().unwrap_or(0.0);
                if (t_s - now).abs() > 0.5 * dt {
                    return Err(format!(
                        "fmi2DoStep from t = {t_s} s, but the model is at t = {now} s: \
                         communication points follow each other (restore a saved state with \
                         fmi2SetFMUstate to go back)"
                    ));
                }
                let steps = (h_s / dt).round();
                if steps < 1.0 || (steps * dt - h_s).abs() > 1e-6 * dt {
                    return Err(format!(
                        "communication step {h_s} s is not a whole number of model steps \
                         ({dt} s, simulation.step_s of the configuration)"
                    ));
                }
                f.advance(&mut self.values, steps as u64).map_err(|e| {
                    self.phase = Phase::Failed;
                    format!("the step from t = {t_s} s over {h_s} s failed: {e}")
                })
            }
        }
    }
}
