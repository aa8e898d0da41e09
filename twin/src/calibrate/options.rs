//! What a calibration is asked: the conditions to match (`Target`) and the free parameters
//! (`FreeSet`, `Distances`).

use serde::Serialize;

/// One condition to match.
#[derive(Debug, Clone, PartialEq, Serialize)]
pub struct Target {
    pub label: String,
    pub mean_slip_pct: f64,
    /// Standard error of the measured mean, % (0 when only the mean is known).
    pub mean_se_pct: f64,
    pub known_center_distance_m: Option<f64>,
    /// The belt setting's static span tension as a tension meter read it (`None`: not read);
    /// a check on the calibrated installation tension, not a term of the likelihood
    /// (`misfit::tension_reading_flag`; docs/decisions/tension-reading.md).
    #[serde(skip_serializing_if = "Option::is_none")]
    pub tension_reading: Option<crate::measured::TensionReading>,
    /// Position i in d_i = d_0 - i Delta for equally spaced distances (the order of the
    /// conditions; kept when a condition is left out).
    pub position: f64,
}

/// A condition's start-up slip, matched as well as its steady slip where a calibration is
/// asked to (`LocalFit::new` with start-up targets): the measured mean slip from the first
/// running sample to the driven speed's 90 % time, against the surrogate's start-up series
/// over that time (`Surrogate::predict_startup_mean_pct`).
#[derive(Debug, Clone, PartialEq, Serialize)]
pub struct StartupTarget {
    /// Index of the condition among the calibration's targets.
    pub condition: usize,
    /// The driven speed's 90 % time after the start, s.
    pub until_s: f64,
    pub mean_slip_pct: f64,
    /// Standard deviation of the match: the measured mean's standard error and the start-up
    /// series' model share, %.
    pub sd_pct: f64,
}

#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Distances {
    /// Use the known distances (every target must have one).
    Known,
    /// One free distance per target.
    Free,
    /// d_i = d_0 - i Delta, Delta >= 0.
    EquallySpaced,
}

#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub struct FreeSet {
    pub friction: bool,
    pub tension: bool,
    pub ratio: bool,
    /// Effective axial stiffness EA (needs a surrogate trained over a stiffness range).
    pub stiffness: bool,
    pub distances: Distances,
}

impl FreeSet {
    /// What `rom calibrate` frees without `--free`: friction and tension, and the distances
    /// unless every target gives its own.
    pub fn default_for(targets: &[Target]) -> Self {
        FreeSet {
            friction: true,
            tension: true,
            ratio: false,
            stiffness: false,
            distances: if targets.iter().all(|t| t.known_center_distance_m.is_some()) {
                Distances::Known
            } else {
                Distances::Free
            },
        }
    }
}

impl std::str::FromStr for FreeSet {
    type Err = String;
    /// A comma-separated list of friction, tension, ratio, stiffness, distances,
    /// spaced-distances.
    fn from_str(s: &str) -> std::result::Result<Self, String> {
        let mut f = FreeSet {
            friction: false,
            tension: false,
            ratio: false,
            stiffness: false,
            distances: Distances::Known,
        };
        for item in s.split(',').map(str::trim).filter(|x| !x.is_empty()) {
            match item {
                "friction" => f.friction = true,
                "tension" => f.tension = true,
                "ratio" => f.ratio = true,
                "stiffness" => f.stiffness = true,
                "distances" if f.distances == Distances::Known => f.distances = Distances::Free,
                "spaced-distances" if f.distances == Distances::Known => {
                    f.distances = Distances::EquallySpaced
                }
                "distances" | "spaced-distances" => {
                    return Err("give one of distances, spaced-distances".into())
                }
                other => {
                    return Err(format!(
                        "unknown free parameter `{other}` (choose from friction, tension, ratio, \
                         stiffness, distances, spaced-distances)"
                    ))
                }
            }
        }
        Ok(f)
    }
}
