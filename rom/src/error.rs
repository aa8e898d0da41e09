//! Errors of the surrogate crate.

use fom::params::Variable;
use thiserror::Error;

#[derive(Debug, Error)]
pub enum RomError {
    #[error(transparent)]
    Fom(#[from] fom::FomError),
    #[error(transparent)]
    Training(#[from] training::TrainingError),
    #[error("fitting the surrogate: {0}")]
    Fit(String),
    /// A Gaussian process or the reconstruction failed at prediction time.
    #[error("{0}")]
    Predict(String),
    /// A request outside what the surrogate was trained on (range or looseness).
    #[error("{reason}")]
    Extrapolation { reason: String },
    /// A request parameter out of its domain; `input` names it (a front end maps it to its
    /// own spelling: `rom` a flag, by a `match`).
    #[error("{input} {message}")]
    InvalidArgument { input: Input, message: String },
    /// A point no drive can have (`physical::check_physical`): refused whether or not
    /// extrapolation is allowed; `input` names the design variable at fault.
    #[error("{reason}")]
    Impossible { input: Variable, reason: String },
    #[error("surrogate file {0}")]
    Model(String),
    #[error("{0}")]
    Data(String),
}

/// A user-facing input that an error of this crate or of the twin can name. The message
/// shows [`Input::name`], the library's wording; a front end maps the variant to its own
/// spelling (`rom` to a flag, by a `match` that fails to compile when a variant is added).
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Input {
    /// A design variable of the surrogate's inputs (its configuration key).
    Variable(Variable),
    /// Friction samples of a slip prediction.
    FrictionSamples,
    /// Fresh points of a validation.
    ValidationPoints,
    /// The held-out runs an interval calibration reads.
    HeldOutRuns,
    /// Read-out rate of the synthetic sensor, Hz.
    SampleRate,
    /// Tachometer pulses per revolution.
    PulsesPerRev,
    /// Standard deviation of the speed noise, rpm.
    SpeedNoise,
    /// Resolution of the tachometer's pulse timer, s.
    TimerResolution,
    /// Share of tachometer pulses that go missing.
    MissingPulseShare,
    /// A measured condition's label.
    ConditionLabel,
    /// Largest acceptable calibration error per condition, %.
    CalibrationTolerance,
    /// Labels withheld from a gap diagnosis's calibration.
    Holdout,
}

impl Input {
    /// The library's wording of the input, as messages show it.
    pub fn name(self) -> &'static str {
        match self {
            Input::Variable(v) => v.key(),
            Input::FrictionSamples => "friction samples",
            Input::ValidationPoints => "validation points",
            Input::HeldOutRuns => "held-out runs",
            Input::SampleRate => "sensor sample rate (Hz)",
            Input::PulsesPerRev => "tachometer pulses per revolution",
            Input::SpeedNoise => "speed noise (rpm)",
            Input::TimerResolution => "tachometer timer resolution (s)",
            Input::MissingPulseShare => "share of missing pulses",
            Input::ConditionLabel => "condition label",
            Input::CalibrationTolerance => "calibration tolerance (%)",
            Input::Holdout => "--holdout",
        }
    }
}

impl std::fmt::Display for Input {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.write_str(self.name())
    }
}

/// Result of the surrogate crate's operations.
pub type Result<T> = std::result::Result<T, RomError>;
