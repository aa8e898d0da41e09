//! The text of a cluster campaign's jobs: a Slurm batch script per step and the Kubernetes
//! recipe, both around [`ClusterCampaign::command`], so the two cannot drift apart.

use super::{ClusterCampaign, Step, MAX_REQUEUES};

/// Slurm options every job of the campaign gets.
#[derive(Debug, Clone, Default, PartialEq)]
pub struct SlurmOptions {
    /// `--partition`.
    pub partition: Option<String>,
    /// `--time` (Slurm's time syntax, e.g. `01:00:00`).
    pub time: Option<String>,
}

/// The folder of the data set that holds the job scripts, and in it the jobs' logs.
pub const JOBS_DIR: &str = "jobs";
pub const LOGS_DIR: &str = "logs";

/// The batch script of `step`. An array task runs its shard as a job step (`srun`); when that
/// run fails (killed, out of memory, a node-side crash) the script puts its own task back in
/// the queue, up to [`MAX_REQUEUES`] times, and the requeued task resumes: finished points are
/// skipped. A preempted task is requeued by Slurm itself (`--requeue`).
pub fn slurm_script(c: &ClusterCampaign, step: Step, opts: &SlurmOptions) -> String {
    let logs = c.data.join(JOBS_DIR).join(LOGS_DIR);
    let mut s = String::from("#!/bin/bash\n");
    s += &format!("#SBATCH --job-name={}\n", step.name());
    if step.is_array() {
        s += &format!("#SBATCH --array=1-{}\n", c.shards);
        s += &format!("#SBATCH --output={}/%x-%A_%a.out\n", logs.display());
    } else {
        s += &format!("#SBATCH --output={}/%x-%j.out\n", logs.display());
    }
    s += "#SBATCH --ntasks=1\n#SBATCH --requeue\n#SBATCH --open-mode=append\n";
    if let Some(p) = &opts.partition {
        s += &format!("#SBATCH --partition={p}\n");
    }
    if let Some(t) = &opts.time {
        s += &format!("#SBATCH --time={t}\n");
    }
    s += "# Written by `rom train --submit slurm` (docs/guide/train.md, \"On a cluster\").\n";
    let command = c.command(step, "$SLURM_ARRAY_TASK_ID");
    if !step.is_array() {
        return s + &format!("exec {command}\n");
    }
    s + &format!(
        "srun --ntasks=1 {command}\n\
         status=$?\n\
         if [ \"$status\" -ne 0 ] && [ \"${{SLURM_RESTART_COUNT:-0}}\" -lt {MAX_REQUEUES} ]; then\n\
         \x20   echo \"shard run ended with status $status: requeued to resume\" >&2\n\
         \x20   scontrol requeue \"$SLURM_JOB_ID\" && sleep 60\n\
         fi\n\
         exit \"$status\"\n"
    )
}

/// The Kubernetes recipe of the campaign: one Job per step, to be applied in order, each once
/// the one before has completed; the runs are Indexed Jobs (0-based index, hence the `+ 1`)
/// whose failed pods restart and resume. The data set is the volume claim `claim` mounted at
/// the campaign's data directory's parent.
pub fn kubernetes_recipe(c: &ClusterCampaign, image: &str, claim: &str) -> String {
    let mount = c
        .data
        .parent()
        .map_or("/".into(), |p| p.display().to_string());
    let steps = c.steps();
    let mut docs = Vec::new();
    for (k, step) in steps.iter().enumerate() {
        let command = c.command(*step, "$((JOB_COMPLETION_INDEX + 1))");
        let mut y = format!(
            "# {} of {}: {}\napiVersion: batch/v1\nkind: Job\nmetadata: {{name: {}}}\nspec:\n",
            k + 1,
            steps.len(),
            describe(*step),
            step.name()
        );
        if step.is_array() {
            y += &format!(
                "  completions: {n}\n  parallelism: {n}\n  completionMode: Indexed\n  \
                 backoffLimitPerIndex: {MAX_REQUEUES}\n",
                n = c.shards
            );
        } else {
            y += &format!("  backoffLimit: {MAX_REQUEUES}\n");
        }
        y += &format!(
            "  template:\n    spec:\n      restartPolicy: OnFailure\n      containers:\n      \
             - name: train\n        image: {image}\n        command: [\"sh\", \"-c\", {}]\n        \
             volumeMounts: [{{name: data, mountPath: {mount}}}]\n      volumes: [{{name: data, \
             persistentVolumeClaim: {{claimName: {claim}}}}}]\n",
            yaml_quoted(&command)
        );
        docs.push(y);
    }
    docs.join("---\n")
}

/// What a step does, in a recipe's comment.
fn describe(step: Step) -> String {
    match step {
        Step::Shards { round: 0 } => "the design's runs, one pod per shard".into(),
        Step::Shards { round } => format!("refinement round {round}'s runs"),
        Step::Plan { round, points } => {
            format!("fit, then plan refinement round {round} ({points} points)")
        }
        Step::Fit => "join the runs and fit the surrogate".into(),
    }
}

/// A YAML double-quoted scalar.
fn yaml_quoted(s: &str) -> String {
    format!("\"{}\"", s.replace('\\', "\\\\").replace('"', "\\\""))
}

#[cfg(test)]
mod tests {
    use super::*;

    fn campaign() -> ClusterCampaign {
        ClusterCampaign {
            rom: "/opt/rom".into(),
            data: "/shared/campaign".into(),
            flags: vec![],
            shards: 3,
            rounds: vec![2],
            model: None,
        }
    }

    #[test]
    fn an_array_script_requeues_a_failed_run_and_a_fit_script_does_not() {
        let c = campaign();
        let opts = SlurmOptions {
            partition: Some("long".into()),
            time: Some("02:00:00".into()),
        };
        let runs = slurm_script(&c, Step::Shards { round: 1 }, &opts);
        for line in [
            "#SBATCH --array=1-3",
            "#SBATCH --partition=long",
            "#SBATCH --time=02:00:00",
            "#SBATCH --requeue",
            "srun --ntasks=1 /opt/rom train --data /shared/campaign --shard \"$SLURM_ARRAY_TASK_ID/3\"",
            "scontrol requeue \"$SLURM_JOB_ID\" && sleep 60",
        ] {
            assert!(runs.contains(line), "{line} missing from\n{runs}");
        }
        let fit = slurm_script(&c, Step::Fit, &SlurmOptions::default());
        assert!(
            !fit.contains("--array") && !fit.contains("scontrol"),
            "{fit}"
        );
        assert!(fit.ends_with("exec /opt/rom train --data /shared/campaign --merge\n"));
    }

    #[test]
    fn the_recipe_has_one_job_per_step_with_the_same_commands() {
        let c = campaign();
        let y = kubernetes_recipe(&c, "beltwin:1", "claim");
        assert_eq!(y.matches("kind: Job").count(), c.steps().len());
        assert!(
            y.contains("--shard \\\"$((JOB_COMPLETION_INDEX + 1))/3\\\""),
            "{y}"
        );
        assert!(y.contains("mountPath: /shared}"), "{y}");
    }
}
