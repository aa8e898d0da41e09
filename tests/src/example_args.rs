//! The command line of the example simulators (`tests/examples/lumped.rs`, `creep.rs`): flags
//! with values, numbers, and the `--labels LABEL=DISTANCE,...` list, each error one line and
//! exit 1.

/// The default labels: four belt settings from healthy to the looseness knee, m.
const DEFAULT_LABELS: &str = "d0=0.424,d1=0.421,d2=0.418,d3=0.416";

/// Prints `error: message` and exits 1.
pub fn fail(message: String) -> ! {
    eprintln!("error: {message}");
    std::process::exit(1)
}

/// An example's arguments after its program name.
pub struct ExampleArgs(pub Vec<String>);

impl ExampleArgs {
    pub fn from_env() -> Self {
        Self(std::env::args().skip(1).collect())
    }

    /// The value after `flag`, if the flag is given.
    pub fn value(&self, flag: &str) -> Option<String> {
        self.0.iter().position(|a| a == flag).map(|i| {
            self.0
                .get(i + 1)
                .cloned()
                .unwrap_or_else(|| fail(format!("{flag} needs a value")))
        })
    }

    /// Every value after a repeatable `flag`.
    pub fn values(&self, flag: &str) -> Vec<String> {
        (0..self.0.len())
            .filter(|&i| self.0[i] == flag)
            .map(|i| {
                self.0
                    .get(i + 1)
                    .cloned()
                    .unwrap_or_else(|| fail(format!("{flag} needs a value")))
            })
            .collect()
    }

    /// The output directory: the first argument, unless it is a flag.
    pub fn dir(&self) -> Option<&str> {
        self.0
            .first()
            .map(String::as_str)
            .filter(|a| !a.starts_with("--"))
    }

    /// The draw seed: `--seed N` (default 1) times 1000; a fraction reaches the test suite's
    /// seeds (0.5 is 500).
    pub fn seed(&self) -> u64 {
        (self.num("--seed", 1.0) * 1000.0).round() as u64
    }

    /// The number after `flag`, or `default`.
    pub fn num(&self, flag: &str, default: f64) -> f64 {
        self.value(flag).map_or(default, |v| {
            v.parse()
                .unwrap_or_else(|_| fail(format!("{flag}: `{v}` is not a number")))
        })
    }

    /// `--labels LABEL=DISTANCE,...` (distances in m), or the four default labels.
    pub fn labels(&self) -> Vec<(String, f64)> {
        self.value("--labels")
            .unwrap_or_else(|| DEFAULT_LABELS.into())
            .split(',')
            .map(|p| {
                let (l, d) = p
                    .split_once('=')
                    .unwrap_or_else(|| fail(format!("--labels: `{p}` is not LABEL=DISTANCE")));
                let d = d
                    .parse()
                    .unwrap_or_else(|_| fail(format!("--labels: `{d}` is not a distance in m")));
                (l.to_string(), d)
            })
            .collect()
    }
}
