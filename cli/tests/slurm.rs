//! A campaign on a real Slurm: a single-node cluster (`munged`, `slurmctld`, `slurmd`) started
//! on the loopback address from a configuration written into a temporary folder, a small
//! campaign with one refinement round submitted with `rom train --submit slurm`, and its model
//! and data set compared with the same campaign run here. Needs root and Debian's
//! `slurm-wlm` and `munge` (`.ci/install/slurm.sh`); run alone with
//! `cargo test --release --workspace --test cli slurm::`.

use std::net::TcpListener;
use std::path::{Path, PathBuf};
use std::process::{Child, Command, Output, Stdio};
use std::sync::{Mutex, OnceLock};
use std::time::{Duration, Instant};

const ROM: &str = env!("CARGO_BIN_EXE_rom");
/// Longest a campaign may take on the test cluster before the test fails.
const CAMPAIGN_TIMEOUT: Duration = Duration::from_secs(300);
const POLL: Duration = Duration::from_millis(500);

/// The campaign: 8 runs of a cheap drive (100 segments, a light fan, 0.6-3 s runs), then one
/// refinement round of 4, in 4 array tasks.
const SHARDS: &str = "4";
const REFINE: &str = "4";

/// One cluster at a time (two would share the machine's two cores).
static SERIAL: Mutex<()> = Mutex::new(());

/// A single-node Slurm and its munge daemon, stopped (with every job) when dropped.
struct Cluster {
    dir: tempfile::TempDir,
    children: Vec<Child>,
}

impl Cluster {
    fn conf(&self) -> PathBuf {
        self.dir.path().join("slurm.conf")
    }

    fn start() -> Self {
        for tool in [
            "munged",
            "slurmctld",
            "slurmd",
            "sbatch",
            "squeue",
            "scontrol",
            "scancel",
        ] {
            let found = Command::new("sh")
                .args(["-c", &format!("command -v {tool}")])
                .output()
                .is_ok_and(|o| o.status.success());
            assert!(
                found,
                "`{tool}` is missing: install Slurm and munge with `.ci/install/slurm.sh` (as root)"
            );
        }
        let uid = Command::new("id").arg("-u").output().unwrap();
        assert_eq!(
            String::from_utf8_lossy(&uid.stdout).trim(),
            "0",
            "the Slurm tests start slurmd, which must run as root"
        );
        let dir = tempfile::tempdir().unwrap();
        let d = &dir.path().to_path_buf();
        for sub in ["state", "spool", "log", "munge"] {
            std::fs::create_dir(d.join(sub)).unwrap();
        }
        let key = d.join("munge/munge.key");
        let out = Command::new("dd")
            .args(["if=/dev/urandom", "bs=1024", "count=1"])
            .arg(format!("of={}", key.display()))
            .stderr(Stdio::null())
            .status()
            .unwrap();
        assert!(out.success());
        set_mode(&key, 0o600);
        let socket = d.join("munge/munge.sock");
        let mut cluster = Self {
            dir,
            children: Vec::new(),
        };
        let munged = Command::new("munged")
            .arg("--foreground")
            .arg("--force")
            .arg(format!("--socket={}", socket.display()))
            .arg(format!("--key-file={}", key.display()))
            .arg(format!(
                "--pid-file={}",
                d.join("munge/munged.pid").display()
            ))
            .arg(format!(
                "--log-file={}",
                d.join("munge/munged.log").display()
            ))
            .arg(format!("--seed-file={}", d.join("munge/seed").display()))
            .stdout(Stdio::null())
            .stderr(Stdio::null())
            .spawn()
            .expect("starting munged");
        cluster.children.push(munged);
        wait_for("munged's socket", Duration::from_secs(10), || {
            socket.exists()
        });
        let (ctld, slurmd) = (free_port(), free_port());
        std::fs::write(cluster.conf(), slurm_conf(d, &socket, ctld, slurmd)).unwrap();
        for daemon in ["slurmctld", "slurmd"] {
            // The node is `localhost` whatever the machine's host name is.
            let node: &[&str] = if daemon == "slurmd" {
                &["-N", "localhost"]
            } else {
                &[]
            };
            let child = Command::new(daemon)
                .arg("-D")
                .args(node)
                .env("SLURM_CONF", cluster.conf())
                .stdout(Stdio::null())
                .stderr(std::fs::File::create(d.join(format!("log/{daemon}.err"))).unwrap())
                .spawn()
                .unwrap_or_else(|e| panic!("starting {daemon}: {e}"));
            cluster.children.push(child);
            if daemon == "slurmctld" {
                wait_for("slurmctld", Duration::from_secs(20), || {
                    cluster.client("scontrol", &["ping"]).status.success()
                });
            }
        }
        wait_for("the node to be idle", Duration::from_secs(30), || {
            let o = cluster.client("sinfo", &["-h", "-o", "%T"]);
            String::from_utf8_lossy(&o.stdout).trim() == "idle"
        });
        cluster
    }

    /// A Slurm client command against this cluster.
    fn client(&self, cmd: &str, args: &[&str]) -> Output {
        Command::new(cmd)
            .args(args)
            .env("SLURM_CONF", self.conf())
            .output()
            .unwrap_or_else(|e| panic!("running {cmd}: {e}"))
    }

    /// `rom` with this cluster's configuration.
    fn rom(&self, args: &[&str]) -> Output {
        Command::new(ROM)
            .args(args)
            .env("SLURM_CONF", self.conf())
            .output()
            .unwrap()
    }

    /// Job ids still in the queue (any state).
    fn queued(&self) -> Vec<String> {
        let o = self.client("squeue", &["-h", "-o", "%i %T"]);
        String::from_utf8_lossy(&o.stdout)
            .lines()
            .map(str::to_string)
            .collect()
    }
}

impl Drop for Cluster {
    fn drop(&mut self) {
        // Jobs first (their processes belong to slurmd's job steps), then the daemons.
        let _ = self.client("scancel", &["--user=root"]);
        let t = Instant::now();
        while !self.queued().is_empty() && t.elapsed() < Duration::from_secs(15) {
            std::thread::sleep(POLL);
        }
        for c in self.children.iter_mut().rev() {
            let _ = Command::new("kill").arg(c.id().to_string()).status();
            let t = Instant::now();
            while c.try_wait().ok().flatten().is_none() && t.elapsed() < Duration::from_secs(5) {
                std::thread::sleep(Duration::from_millis(50));
            }
            let _ = c.kill();
            let _ = c.wait();
        }
    }
}

fn set_mode(p: &Path, mode: u32) {
    use std::os::unix::fs::PermissionsExt;
    std::fs::set_permissions(p, std::fs::Permissions::from_mode(mode)).unwrap();
}

fn free_port() -> u16 {
    TcpListener::bind("127.0.0.1:0")
        .unwrap()
        .local_addr()
        .unwrap()
        .port()
}

fn wait_for(what: &str, limit: Duration, ready: impl FnMut() -> bool) {
    wait_for_every(what, limit, POLL, ready)
}

fn wait_for_every(what: &str, limit: Duration, poll: Duration, mut ready: impl FnMut() -> bool) {
    let t = Instant::now();
    while !ready() {
        assert!(t.elapsed() < limit, "{what} not ready within {limit:?}");
        std::thread::sleep(poll);
    }
}

/// The process id of a running `rom train --data DATA --shard SHARD`, from `/proc`.
fn shard_process(data: &str, shard: &str) -> Option<u32> {
    std::fs::read_dir("/proc").ok()?.flatten().find_map(|e| {
        let pid: u32 = e.file_name().to_str()?.parse().ok()?;
        let cmd = std::fs::read(e.path().join("cmdline")).ok()?;
        let args: Vec<&[u8]> = cmd.split(|&b| b == 0).collect();
        let has = |a: &[u8], b: &[u8]| args.windows(2).any(|w| w[0] == a && w[1] == b);
        (args
            .iter()
            .any(|a| a.ends_with(b"rom") || a.ends_with(b"/rom"))
            && has(b"--data", data.as_bytes())
            && has(b"--shard", shard.as_bytes()))
        .then_some(pid)
    })
}

/// The test cluster's configuration. Without cgroups in a container: process tracking by
/// process tree, no task plugin, no accounting. A requeued job waits `cred_expire` seconds
/// before it may start again (120 s by default): 5 s here; the scheduler looks at the queue
/// every second.
fn slurm_conf(d: &Path, socket: &Path, ctld: u16, slurmd: u16) -> String {
    let p = |s: &str| d.join(s).display().to_string();
    format!(
        "ClusterName=beltwintest\n\
         SlurmctldHost=localhost(127.0.0.1)\n\
         SlurmUser=root\nSlurmdUser=root\n\
         SlurmctldPort={ctld}\nSlurmdPort={slurmd}\n\
         AuthType=auth/munge\nCredType=cred/munge\n\
         AuthInfo=socket={},cred_expire=5\n\
         StateSaveLocation={}\nSlurmdSpoolDir={}\n\
         SlurmctldPidFile={}\nSlurmdPidFile={}\n\
         SlurmctldLogFile={}\nSlurmdLogFile={}\n\
         ProctrackType=proctrack/linuxproc\nTaskPlugin=task/none\n\
         SelectType=select/cons_tres\nSelectTypeParameters=CR_Core\n\
         JobAcctGatherType=jobacct_gather/none\nAccountingStorageType=accounting_storage/none\n\
         JobCompType=jobcomp/none\nMpiDefault=none\n\
         SchedulerType=sched/backfill\n\
         SchedulerParameters=sched_interval=1,bf_interval=1\n\
         ReturnToService=2\n\
         NodeName=localhost NodeAddr=127.0.0.1 CPUs=2 State=UNKNOWN\n\
         PartitionName=debug Nodes=ALL Default=YES MaxTime=INFINITE State=UP\n",
        socket.display(),
        p("state"),
        p("spool"),
        p("slurmctld.pid"),
        p("slurmd.pid"),
        p("log/slurmctld.log"),
        p("log/slurmd.log"),
    )
}

/// The campaign's configuration and settings files in `dir`.
fn campaign_files(dir: &Path) -> Vec<String> {
    let mut cfg = fom::DriveConfig::default_hvac();
    cfg.belt.segments = 100;
    cfg.simulation.step_s = fom::config::StepSize::Seconds(2.2e-5);
    cfg.driven.inertia_kg_m2 = 0.02;
    let config = dir.join("drive.toml");
    std::fs::write(&config, cfg.to_toml_string()).unwrap();
    let settings = dir.join("settings.toml");
    std::fs::write(
        &settings,
        "samples = 8\nseed = 11\ncenter_distance_m = [0.416, 0.424]\nfriction = [0.6, 0.8]\n\
         installation_tension_n = [200.0, 300.0]\nduration_s = 3.0\nmin_duration_s = 0.6\n\
         steady_length_s = 0.4\n",
    )
    .unwrap();
    vec![
        "--config".into(),
        config.display().to_string(),
        "--settings".into(),
        settings.display().to_string(),
        "--refine".into(),
        REFINE.into(),
    ]
}

/// The same campaign run on this machine, once for both tests.
fn one_machine() -> &'static Path {
    static DONE: OnceLock<tempfile::TempDir> = OnceLock::new();
    DONE.get_or_init(|| {
        let dir = tempfile::tempdir().unwrap();
        let mut args = vec!["train".to_string(), "--data".into()];
        args.push(dir.path().join("data").display().to_string());
        args.extend(campaign_files(dir.path()));
        let o = Command::new(ROM).args(&args).output().unwrap();
        assert!(o.status.success(), "{}", String::from_utf8_lossy(&o.stderr));
        dir
    })
    .path()
}

/// Submits the campaign into `root/data` and returns the array job of round 0.
fn submit(cluster: &Cluster, root: &Path) -> String {
    let data = root.join("data").display().to_string();
    let mut args: Vec<String> = vec!["train".into(), "--data".into(), data];
    args.extend(campaign_files(root));
    args.extend(["--submit", "slurm", "--array-size", SHARDS].map(String::from));
    let args: Vec<&str> = args.iter().map(String::as_str).collect();
    let o = cluster.rom(&args);
    let out = String::from_utf8_lossy(&o.stdout).to_string();
    assert!(
        o.status.success(),
        "{out}{}",
        String::from_utf8_lossy(&o.stderr)
    );
    // `submitted beltwin-runs-0 as Slurm job ID, array 1-4 (...)`
    let first = out.lines().next().unwrap_or("");
    assert!(
        first.starts_with("submitted beltwin-runs-0 as Slurm job "),
        "{out}"
    );
    first
        .split_whitespace()
        .nth(5)
        .unwrap()
        .trim_end_matches(',')
        .to_string()
}

/// Waits until the queue is empty, then checks the fitted model is there.
fn wait_for_campaign(cluster: &Cluster, root: &Path) {
    let t = Instant::now();
    while !cluster.queued().is_empty() {
        if t.elapsed() > CAMPAIGN_TIMEOUT {
            panic!(
                "campaign not done within {CAMPAIGN_TIMEOUT:?}; queue: {:?}; status: {}",
                cluster.queued(),
                String::from_utf8_lossy(&status(cluster, root).stdout)
            );
        }
        std::thread::sleep(POLL);
    }
    let model = root.join("data/surrogate.json");
    assert!(
        model.exists(),
        "the queue is empty but no model was fitted; status: {}; logs: {}",
        String::from_utf8_lossy(&status(cluster, root).stdout),
        logs(root)
    );
}

fn status(cluster: &Cluster, root: &Path) -> Output {
    let data = root.join("data").display().to_string();
    cluster.rom(&["train", "--data", &data, "--status"])
}

fn logs(root: &Path) -> String {
    let mut out = String::new();
    if let Ok(rd) = std::fs::read_dir(root.join("data/jobs/logs")) {
        for f in rd.flatten() {
            out += &format!("\n== {}\n", f.path().display());
            out += &std::fs::read_to_string(f.path()).unwrap_or_default();
        }
    }
    out
}

/// A model file with its creation time and the checksum over it blanked, and the data set's
/// files without wall times and the cluster's own files (locks, job scripts and logs).
fn result(root: &Path) -> (String, Vec<(String, String)>) {
    let data = root.join("data");
    let model = std::fs::read_to_string(data.join("surrogate.json")).unwrap();
    let (head, payload) = model.split_once('\n').unwrap();
    let mut head: serde_json::Value = serde_json::from_str(head).unwrap();
    head["created_utc"] = "".into();
    head["sha256"] = "".into();
    let mut files = Vec::new();
    for sub in [data.clone(), data.join("runs")] {
        for f in std::fs::read_dir(&sub).unwrap().flatten() {
            let p = f.path();
            let name = p.strip_prefix(&data).unwrap().display().to_string();
            if p.is_dir() || name.ends_with(".lock") || name == "surrogate.json" {
                continue;
            }
            let text = std::fs::read_to_string(&p).unwrap();
            let kept: Vec<String> = text
                .lines()
                .filter(|l| !l.starts_with("wall_time_s"))
                .map(|l| {
                    if name == "points.csv" {
                        let mut f: Vec<&str> = l.split(',').collect();
                        f.remove(5);
                        f.join(",")
                    } else {
                        l.to_string()
                    }
                })
                .collect();
            files.push((name, kept.join("\n")));
        }
    }
    files.sort();
    (format!("{head}\n{payload}"), files)
}

fn assert_same_as_one_machine(root: &Path) {
    let (model, files) = result(root);
    let (model_here, files_here) = result(one_machine());
    assert_eq!(
        files.iter().map(|f| &f.0).collect::<Vec<_>>(),
        files_here.iter().map(|f| &f.0).collect::<Vec<_>>()
    );
    assert_eq!(
        files.len(),
        3 + 2 * 12 + 1,
        "drive, campaign, design, 12 runs, points"
    );
    for (a, b) in files.iter().zip(&files_here) {
        assert!(a == b, "{} differs from the one-machine campaign's", a.0);
    }
    assert!(
        model == model_here,
        "the fitted model differs from the one-machine campaign's"
    );
}

#[test]
fn slurm_campaign_with_a_refinement_round_equals_the_one_machine_campaign() {
    let _one = SERIAL.lock().unwrap_or_else(|e| e.into_inner());
    let cluster = Cluster::start();
    let root = tempfile::tempdir().unwrap();
    submit(&cluster, root.path());
    one_machine();
    wait_for_campaign(&cluster, root.path());
    let s = String::from_utf8_lossy(&status(&cluster, root.path()).stdout).to_string();
    assert!(
        s.contains(": 12 points, ") && s.contains("0 pending"),
        "{s}"
    );
    assert_same_as_one_machine(root.path());
}

#[test]
fn slurm_task_killed_mid_run_is_requeued_and_resumes_to_the_same_result() {
    let _one = SERIAL.lock().unwrap_or_else(|e| e.into_inner());
    let cluster = Cluster::start();
    let root = tempfile::tempdir().unwrap();
    let job = submit(&cluster, root.path());
    // Array task 1's `rom` process, killed as the out-of-memory killer would: SIGKILL to the
    // process, straight away. (Through `scancel --signal=KILL` of the step, the kill raced
    // the step's end on a loaded machine: the step is two short runs.)
    let data = root.path().join("data").display().to_string();
    let mut pid = None;
    wait_for_every(
        "array task 1's run",
        Duration::from_secs(60),
        Duration::from_millis(10),
        || {
            pid = shard_process(&data, "1/4");
            pid.is_some()
        },
    );
    let o = Command::new("kill")
        .args(["-KILL", &pid.unwrap().to_string()])
        .output()
        .unwrap();
    assert!(o.status.success(), "{}", String::from_utf8_lossy(&o.stderr));
    one_machine();
    wait_for_campaign(&cluster, root.path());
    let log = std::fs::read_to_string(
        root.path()
            .join(format!("data/jobs/logs/beltwin-runs-0-{job}_1.out")),
    )
    .unwrap_or_else(|_| logs(root.path()));
    assert!(
        log.contains("requeued to resume"),
        "task 1 was not requeued: {log}"
    );
    assert_same_as_one_machine(root.path());
}

#[test]
fn slurm_submission_without_sbatch_is_refused_before_anything_is_written() {
    let dir = tempfile::tempdir().unwrap();
    let data = dir.path().join("data");
    let o = Command::new(ROM)
        .args(["train", "--samples", "8", "--submit", "slurm", "--data"])
        .arg(&data)
        .env("PATH", dir.path())
        .output()
        .unwrap();
    assert_eq!(o.status.code(), Some(1));
    let err = String::from_utf8_lossy(&o.stderr);
    assert!(err.contains("cannot run `sbatch`"), "{err}");
    assert!(!data.exists(), "the data set was created");
    // Slurm's options without --submit are usage errors.
    let o = Command::new(ROM)
        .args(["train", "--array-size", "4", "--data"])
        .arg(&data)
        .output()
        .unwrap();
    assert_eq!(
        o.status.code(),
        Some(2),
        "{}",
        String::from_utf8_lossy(&o.stderr)
    );
}
