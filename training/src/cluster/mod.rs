//! A whole training campaign on a cluster: its steps (the initial design's shards, then per
//! refinement round a fit-and-plan step and the round's shards, then the final fit), the
//! `rom train` command line of each step, and from that one command line the Slurm job
//! scripts and the Kubernetes recipe (`scripts`), submitted with `sbatch` (`submit`).
//! Why the steps are jobs chained by dependencies and how a killed task resumes:
//! docs/decisions/cluster-campaigns.md.

mod scripts;
mod submit;

use std::path::PathBuf;

pub use scripts::{kubernetes_recipe, slurm_script, SlurmOptions};
pub use submit::{check_slurm, submit_slurm, SubmittedJob};

/// How often a shard task whose run failed is put back in the queue before it fails for good.
pub const MAX_REQUEUES: usize = 3;

/// A campaign as a cluster runs it.
#[derive(Debug, Clone, PartialEq)]
pub struct ClusterCampaign {
    /// The `rom` binary as the jobs call it (an absolute path, or a name on the image's PATH).
    pub rom: PathBuf,
    /// The data set directory as the jobs see it (absolute).
    pub data: PathBuf,
    /// The `rom train` flags that define the campaign (configuration, settings, samples, seed,
    /// fit options), paths absolute: every step repeats them, so each one checks that the data
    /// set was made with them.
    pub flags: Vec<String>,
    /// Shards each round's runs are split into (the array size).
    pub shards: usize,
    /// Points of each refinement round, in order.
    pub rounds: Vec<usize>,
    /// `--model` of the final fit (default: the one in the data set).
    pub model: Option<PathBuf>,
}

/// One step of a cluster campaign.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Step {
    /// The runs of round `round` (0: the Latin hypercube), one array task per shard.
    Shards { round: usize },
    /// Joins the finished runs, fits, and adds refinement round `round` of `points` points.
    Plan { round: usize, points: usize },
    /// Joins the finished runs and fits the model.
    Fit,
}

impl Step {
    /// The job's name: `beltwin-` and what the step does.
    pub fn name(&self) -> String {
        match self {
            Step::Shards { round } => format!("beltwin-runs-{round}"),
            Step::Plan { round, .. } => format!("beltwin-plan-{round}"),
            Step::Fit => "beltwin-fit".into(),
        }
    }

    /// Whether the step is an array job over the shards.
    pub fn is_array(&self) -> bool {
        matches!(self, Step::Shards { .. })
    }
}

impl ClusterCampaign {
    /// The steps in the order they must run, each after the previous one succeeded.
    pub fn steps(&self) -> Vec<Step> {
        let mut out = vec![Step::Shards { round: 0 }];
        for (k, &points) in self.rounds.iter().enumerate() {
            out.push(Step::Plan {
                round: k + 1,
                points,
            });
            out.push(Step::Shards { round: k + 1 });
        }
        out.push(Step::Fit);
        out
    }

    /// The shell command line of `step`; `shard` is the shell expression of the 1-based shard
    /// index of an array task (`$SLURM_ARRAY_TASK_ID` on Slurm). The one definition of what a
    /// step runs: the Slurm scripts and the Kubernetes recipe are both made from it.
    pub fn command(&self, step: Step, shard: &str) -> String {
        let mut words = vec![
            shell_word(&self.rom.display().to_string()),
            "train".into(),
            "--data".into(),
            shell_word(&self.data.display().to_string()),
        ];
        words.extend(self.flags.iter().map(|f| shell_word(f)));
        match step {
            Step::Shards { .. } => {
                words.push("--shard".into());
                words.push(format!("\"{shard}/{}\"", self.shards));
            }
            Step::Plan { points, .. } => {
                words.push("--plan".into());
                words.push(points.to_string());
            }
            Step::Fit => {
                words.push("--merge".into());
                if let Some(m) = &self.model {
                    words.push("--model".into());
                    words.push(shell_word(&m.display().to_string()));
                }
            }
        }
        words.join(" ")
    }
}

/// `s` as one POSIX shell word: as it is when it holds only characters no shell reads
/// specially, single-quoted otherwise.
pub fn shell_word(s: &str) -> String {
    let plain = !s.is_empty()
        && s.chars()
            .all(|c| c.is_ascii_alphanumeric() || "/._-+=:,@%".contains(c));
    if plain {
        s.to_string()
    } else {
        format!("'{}'", s.replace('\'', r"'\''"))
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn campaign() -> ClusterCampaign {
        ClusterCampaign {
            rom: "/opt/beltwin/rom".into(),
            data: "/shared/my data".into(),
            flags: vec!["--samples".into(), "8".into()],
            shards: 4,
            rounds: vec![4, 2],
            model: None,
        }
    }

    #[test]
    fn steps_alternate_plans_and_rounds_and_end_with_the_fit() {
        assert_eq!(
            campaign().steps(),
            vec![
                Step::Shards { round: 0 },
                Step::Plan {
                    round: 1,
                    points: 4
                },
                Step::Shards { round: 1 },
                Step::Plan {
                    round: 2,
                    points: 2
                },
                Step::Shards { round: 2 },
                Step::Fit,
            ]
        );
    }

    #[test]
    fn commands_quote_paths_and_name_the_shard() {
        let c = campaign();
        assert_eq!(
            c.command(Step::Shards { round: 0 }, "$I"),
            "/opt/beltwin/rom train --data '/shared/my data' --samples 8 --shard \"$I/4\""
        );
        assert_eq!(
            c.command(
                Step::Plan {
                    round: 1,
                    points: 4
                },
                "$I"
            ),
            "/opt/beltwin/rom train --data '/shared/my data' --samples 8 --plan 4"
        );
        assert_eq!(shell_word("it's"), r"'it'\''s'");
        assert_eq!(shell_word(""), "''");
    }
}
