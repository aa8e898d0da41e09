//! Submitting a cluster campaign to Slurm: the job scripts written into the data set, then one
//! `sbatch --parsable` per step, each depending on the one before (`--dependency=afterok`).

use std::path::{Path, PathBuf};
use std::process::Command;

use super::scripts::{slurm_script, SlurmOptions, JOBS_DIR, LOGS_DIR};
use super::{ClusterCampaign, Step};
use crate::dataset::write_text;
use crate::TrainingError;

/// A step submitted to Slurm.
#[derive(Debug, Clone, PartialEq)]
pub struct SubmittedJob {
    pub step: Step,
    /// Slurm's job id.
    pub id: String,
    pub script: PathBuf,
}

/// File of the data set listing the submitted jobs (step name and job id per line).
pub const SUBMITTED_FILE: &str = "slurm-jobs.txt";

/// Writes the campaign's job scripts into `DATA/jobs/` (all or none) and submits them in order,
/// each after the previous one has succeeded. When an `sbatch` fails, the jobs already
/// submitted are cancelled, so no half campaign is left queued.
pub fn submit_slurm(
    c: &ClusterCampaign,
    opts: &SlurmOptions,
) -> Result<Vec<SubmittedJob>, TrainingError> {
    let data = c.data.display().to_string();
    if data.contains(char::is_whitespace) || data.contains('%') {
        return Err(TrainingError::Settings(format!(
            "--data {data}: a Slurm campaign's data directory must not hold whitespace or `%` \
             (its job scripts name it in #SBATCH lines)"
        )));
    }
    let jobs = c.data.join(JOBS_DIR);
    let logs = jobs.join(LOGS_DIR);
    std::fs::create_dir_all(&logs).map_err(|source| TrainingError::Io {
        context: format!("creating {}", logs.display()),
        source,
    })?;
    let steps = c.steps();
    let scripts: Vec<PathBuf> = steps
        .iter()
        .enumerate()
        .map(|(k, s)| jobs.join(format!("{}-{}.sh", k + 1, s.name())))
        .collect();
    let mut out = fom::output_files::OutputSet::new();
    for (step, path) in steps.iter().zip(&scripts) {
        out.add(path, "a job script")?;
        let text = slurm_script(c, *step, opts);
        out.write(path, |w| w.write_all(text.as_bytes()))?;
    }
    out.commit()?;
    let mut submitted: Vec<SubmittedJob> = Vec::new();
    for (step, script) in steps.into_iter().zip(scripts) {
        let after = submitted.last().map(|j| j.id.as_str());
        match sbatch(&script, after) {
            Ok(id) => submitted.push(SubmittedJob { step, id, script }),
            Err(e) => {
                cancel(&submitted);
                return Err(e);
            }
        }
    }
    let list: String = submitted
        .iter()
        .map(|j| format!("{} {}\n", j.step.name(), j.id))
        .collect();
    write_text(&jobs.join(SUBMITTED_FILE), &list)?;
    Ok(submitted)
}

/// Checks that Slurm's `sbatch` can be run here, before anything is written.
pub fn check_slurm() -> Result<(), TrainingError> {
    match Command::new("sbatch").arg("--version").output() {
        Ok(o) if o.status.success() => Ok(()),
        Ok(o) => Err(TrainingError::Cluster(format!(
            "--submit slurm: `sbatch --version` failed ({}): {}",
            o.status,
            String::from_utf8_lossy(&o.stderr).trim()
        ))),
        Err(e) => Err(TrainingError::Cluster(format!(
            "--submit slurm: cannot run `sbatch` ({e}); submit from a host with Slurm's client \
             commands on PATH"
        ))),
    }
}

/// Runs `sbatch --parsable [--dependency=afterok:ID] script` and returns the job id.
fn sbatch(script: &Path, after: Option<&str>) -> Result<String, TrainingError> {
    let mut cmd = Command::new("sbatch");
    cmd.arg("--parsable");
    if let Some(id) = after {
        cmd.arg(format!("--dependency=afterok:{id}"));
    }
    cmd.arg(script);
    let out = cmd.output().map_err(|source| TrainingError::Io {
        context: format!(
            "running sbatch for {} (--submit slurm needs Slurm's client commands on PATH)",
            script.display()
        ),
        source,
    })?;
    let stdout = String::from_utf8_lossy(&out.stdout);
    // `--parsable` prints `ID` or `ID;CLUSTER`.
    let id = stdout.trim().split(';').next().unwrap_or("").to_string();
    if !out.status.success() || id.is_empty() || !id.chars().all(|c| c.is_ascii_digit()) {
        return Err(TrainingError::Cluster(format!(
            "sbatch {} failed ({}): {}",
            script.display(),
            out.status,
            String::from_utf8_lossy(&out.stderr).trim()
        )));
    }
    Ok(id)
}

/// Cancels the jobs submitted so far (best effort: the error that stopped the submission is
/// the one reported).
fn cancel(jobs: &[SubmittedJob]) {
    if jobs.is_empty() {
        return;
    }
    let _ = Command::new("scancel")
        .args(jobs.iter().map(|j| j.id.as_str()))
        .status();
}
