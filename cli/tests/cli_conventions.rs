//! One consistent command line: help texts (defaults, units, no source paths, documents that
//! exist), exit codes (usage 2, input 1), negative values reaching their parser, the physical
//! domain of `rom predict`, its JSON stamp, `rom info`. No full-order run is made.

use std::path::Path;

use crate::support::{run_rom as rom, stderr, stdout};

/// The subcommands `rom --help` lists.
fn subcommands() -> Vec<String> {
    let help = stdout(&rom(&["--help"]));
    let list = help
        .split("Commands:")
        .nth(1)
        .expect("a Commands section")
        .split("\n\n")
        .next()
        .unwrap();
    list.lines()
        .filter_map(|l| l.split_whitespace().next().map(str::to_string))
        .filter(|c| c != "help")
        .collect()
}

#[test]
fn every_help_text_follows_the_conventions() {
    let root = Path::new(env!("CARGO_MANIFEST_DIR")).join("..");
    let cmds = subcommands();
    assert!(cmds.len() >= 8, "{cmds:?}");
    let mut pages = vec![("rom".to_string(), stdout(&rom(&["--help"])))];
    for c in &cmds {
        for flag in ["--help", "-h"] {
            let o = rom(&[c, flag]);
            assert!(o.status.success(), "rom {c} {flag}: {}", stderr(&o));
            pages.push((format!("rom {c} {flag}"), stdout(&o)));
        }
    }
    let word = |c: char| c.is_ascii_alphanumeric() || c == '_';
    for (name, text) in &pages {
        // No source paths (`rom::surrogate::X`).
        let b = text.as_bytes();
        for i in text.match_indices("::").map(|(i, _)| i) {
            let before = i > 0 && word(b[i - 1] as char);
            let after = b.get(i + 2).is_some_and(|c| word(*c as char));
            assert!(!(before && after), "{name}: a source path in\n{text}");
        }
        // Defaults one way: `[default: ...]`, never in prose.
        let lower = text.to_lowercase();
        assert_eq!(
            lower.matches("default:").count(),
            lower.matches("[default: ").count(),
            "{name}: a default not in the [default: X] style\n{text}"
        );
        assert!(!lower.contains("(default"), "{name}\n{text}");
        for d in text.match_indices("[default: ").map(|(i, _)| &text[i..]) {
            let close = d.find(']').expect("closed");
            assert!(
                !d[..close].contains('\n') || d[..close].contains("from"),
                "{name}: {d}"
            );
        }
        // Every document named exists.
        for (i, _) in text.match_indices("docs/") {
            let path: String = text[i..]
                .chars()
                .take_while(|c| c.is_ascii_alphanumeric() || "/._-<>".contains(*c))
                .collect();
            let path = path.trim_end_matches('.');
            if path.contains('<') {
                continue; // docs/guide/<command>.md: a pattern
            }
            assert!(root.join(path).exists(), "{name}: {path} does not exist");
        }
    }
    // The trained ranges are in `rom predict --help`.
    let predict = stdout(&rom(&["predict", "--help"]));
    assert!(
        predict.contains("centre distance (m) 0.415 to 0.424"),
        "{predict}"
    );
    assert!(
        predict.contains("tooth-load surrogate: side gap"),
        "{predict}"
    );
    // The simulation's physical flags show where their default comes from.
    let simulate = stdout(&rom(&["simulate", "--help"]));
    for flag in [
        "--d <D>",
        "--mu <MU>",
        "--tension <TENSION>",
        "--duration <DURATION>",
    ] {
        let at = simulate.find(flag).unwrap_or_else(|| panic!("{flag}"));
        let next = simulate[at + flag.len()..]
            .find("\n  -")
            .map_or(simulate.len(), |n| at + flag.len() + n);
        assert!(
            simulate[at..next].contains("[default: from the drive configuration]"),
            "{flag}: {}",
            &simulate[at..next]
        );
    }
}

#[test]
fn usage_errors_exit_2_and_input_errors_exit_1() {
    // A required flag left out: clap's error, exit 2.
    let o = rom(&["predict"]);
    assert_eq!(o.status.code(), Some(2), "{}", stderr(&o));
    assert!(stderr(&o).contains("--d"), "{}", stderr(&o));
    assert!(stderr(&o).contains("Usage: rom predict"), "{}", stderr(&o));
    // A negative number reaches its value parser (exit 2, named by the flag).
    for (cmd, flag) in [
        ("predict", "--mu"),
        ("predict", "--tension"),
        ("simulate", "--d"),
        ("simulate", "--mu"),
    ] {
        let mut a = vec![cmd];
        if flag != "--d" {
            a.extend(["--d", "0.42"]);
        }
        a.extend([flag, "-1"]);
        if cmd == "simulate" {
            a.extend(["--out", "/nonexistent/x.csv"]);
        }
        let o = rom(&a);
        let err = stderr(&o);
        assert_eq!(o.status.code(), Some(2), "{cmd} {flag}: {err}");
        assert!(
            err.contains(flag) && err.contains("must be a positive number"),
            "{err}"
        );
        assert!(!err.contains("unexpected argument"), "{err}");
    }
    // The renamed noise flag takes a negative value to its check (found after parsing: 1),
    // under its new name and the old one.
    for flag in ["--speed-noise", "--speed-noise-rpm"] {
        let dir = tempfile::tempdir().unwrap();
        let out = dir.path().join("x.csv");
        let o = rom(&["simulate", flag, "-1", "--out", out.to_str().unwrap()]);
        let err = stderr(&o);
        assert_eq!(o.status.code(), Some(1), "{flag}: {err}");
        assert!(err.contains("--speed-noise "), "{err}");
        assert!(!out.exists());
    }
    // A bad file: exit 1.
    let o = rom(&["info", "--model", "/nonexistent/model.json"]);
    assert_eq!(o.status.code(), Some(1), "{}", stderr(&o));
}

/// The five points that once answered "mean 2.0546" under --allow-extrapolation: refused
/// with the reason, with and without it, and nothing on stdout.
#[test]
fn physically_impossible_points_are_refused_even_when_extrapolation_is_allowed() {
    let cases: [(&[&str], &str); 5] = [
        (&["--d", "0.42", "--mu=-1"], "--mu"),
        (&["--d", "0.42", "--mu=0"], "--mu"),
        (&["--d", "0.42", "--tension=-5"], "--tension"),
        (&["--d", "5"], "too short to wrap"),
        (&["--d", "0.40"], "slack"),
    ];
    for (args, why) in cases {
        for allow in [false, true] {
            let mut a = vec!["predict"];
            a.extend_from_slice(args);
            if allow {
                a.push("--allow-extrapolation");
            }
            let o = rom(&a);
            let err = stderr(&o);
            assert!(!o.status.success(), "{a:?} answered: {}", stdout(&o));
            assert!(stdout(&o).is_empty(), "{a:?}");
            assert!(err.contains(why), "{a:?}: {err}");
            assert!(!err.contains("2.0546"), "{err}");
        }
    }
    // The physical ones past the trained box (d 0.40 and 5 m) are input errors naming --d.
    // They name the trained range too, not only the configuration keys of the belt's length.
    let o = rom(&["predict", "--d", "0.40", "--allow-extrapolation"]);
    assert_eq!(o.status.code(), Some(1));
    let err = stderr(&o);
    assert!(err.starts_with("error: --d: belt is slack"), "{err}");
    assert!(err.contains("outside the trained range ["), "{err}");
}

#[test]
fn an_allowed_extrapolation_is_marked_in_text_and_json() {
    let o = rom(&["predict", "--d", "0.43", "--allow-extrapolation"]);
    assert!(o.status.success(), "{}", stderr(&o));
    let text = stdout(&o);
    assert!(
        text.starts_with("EXTRAPOLATED: center_distance_m 0.43 outside trained 0.415"),
        "{text}"
    );
    let o = rom(&[
        "predict",
        "--d",
        "0.43",
        "--allow-extrapolation",
        "--format",
        "json",
    ]);
    let v: serde_json::Value = serde_json::from_str(&stdout(&o)).unwrap();
    assert_eq!(v["extrapolated"], true);
    assert_eq!(v["outside"][0]["input"], "center_distance_m");
    assert_eq!(v["outside"][0]["value"].as_f64(), Some(0.43));
    let trained = v["outside"][0]["trained"].as_array().unwrap();
    assert!(trained[1].as_f64().unwrap() < 0.43);
    // Inside: not extrapolated, nothing outside; stamped with the schema and the model id.
    let o = rom(&["predict", "--d", "0.42", "--format", "json"]);
    let v: serde_json::Value = serde_json::from_str(&stdout(&o)).unwrap();
    assert_eq!(v["schema_version"], 1);
    assert_eq!(v["extrapolated"], false);
    assert_eq!(v["outside"].as_array().map(Vec::len), Some(0));
    let id = v["model_id"].as_str().unwrap();
    assert_eq!(id.len(), 64, "{id}");
    // The text shows the 90 % interval of the mean, around the mean.
    let text = stdout(&rom(&["predict", "--d", "0.42"]));
    assert!(
        text.contains("90 % interval of the mean slip (%)"),
        "{text}"
    );
    let [lo, hi] = [0, 1].map(|i| v["mean_interval90_pct"][i].as_f64().unwrap());
    let mean = v["mean_slip_pct"].as_f64().unwrap();
    assert!(lo < mean && mean < hi, "{lo} {mean} {hi}");
}

#[test]
fn side_gap_takes_metres_or_a_unit_and_refuses_a_bare_millimetre_value() {
    let cfg = concat!(
        env!("CARGO_MANIFEST_DIR"),
        "/../fom/configs/synchronous-arc.toml"
    );
    let o = rom(&["predict", "--config", cfg, "--side-gap", "0.2"]);
    assert_eq!(o.status.code(), Some(2), "{}", stderr(&o));
    assert!(stderr(&o).contains("did you mean 0.2mm?"), "{}", stderr(&o));
    let json = |gap: &str| -> serde_json::Value {
        let o = rom(&[
            "predict",
            "--config",
            cfg,
            "--side-gap",
            gap,
            "--format",
            "json",
        ]);
        assert!(o.status.success(), "{gap}: {}", stderr(&o));
        serde_json::from_str(&stdout(&o)).unwrap()
    };
    let a = json("2e-4");
    for same in ["0.2mm", "200um", "2e-4m"] {
        assert_eq!(json(same)["mean_peak_n"], a["mean_peak_n"], "{same}");
    }
}

#[test]
fn info_describes_the_shipped_models_from_one_struct() {
    let o = rom(&["info", "--format", "json"]);
    assert!(o.status.success(), "{}", stderr(&o));
    let v: serde_json::Value = serde_json::from_str(&stdout(&o)).unwrap();
    assert_eq!(v["schema_version"], 1);
    assert_eq!(v["kind"], "slip");
    let id = v["model_id"].as_str().unwrap().to_string();
    assert_eq!(id.len(), 64);
    assert_eq!(v["inputs"][0]["input"], "center_distance_m");
    assert!(v["provenance"]["training_runs"].as_u64().unwrap() > 0);
    let regions = v["validation"]["regions"].as_array().unwrap();
    assert!(!regions.is_empty());
    // The text says the same, with the id's first 16 digits.
    let text = stdout(&rom(&["info"]));
    assert!(text.contains(&id[..16]) && !text.contains(&id), "{text}");
    assert!(text.contains("centre distance (m)"), "{text}");
    assert!(text.contains("creep"), "{text}");
    // The toothed drive's shipped model, with its own summary.
    let cfg = concat!(
        env!("CARGO_MANIFEST_DIR"),
        "/../fom/configs/synchronous-arc.toml"
    );
    let o = rom(&["info", "--config", cfg, "--format", "json"]);
    let v: serde_json::Value = serde_json::from_str(&stdout(&o)).unwrap();
    assert_eq!(v["kind"], "tooth-load");
    assert!(v["validation"]["regions"][0]["points"].as_u64().unwrap() > 0);
}

/// The four recordings d0-d3 of a sample data set `src`, copied into `dst`.
fn copy_recordings(src: &Path, dst: &Path) {
    for f in ["d0-run1.csv", "d1-run1.csv", "d2-run1.csv", "d3-run1.csv"] {
        std::fs::copy(src.join(f), dst.join(f)).unwrap();
    }
}

/// A data set with a label at another load (`load_torque_nm`): `rom diagnose` and `rom
/// calibrate` read the labels at the reference load, say on stderr which they leave out, and
/// their reports are those of the data set without it.
#[test]
fn diagnose_and_calibrate_leave_a_label_at_another_load_out_and_say_so() {
    let dir = tempfile::tempdir().unwrap();
    let src = crate::support::workspace().join("examples/data/loose");
    copy_recordings(&src, dir.path());
    std::fs::copy(src.join("d0-run1.csv"), dir.path().join("d0-low-run1.csv")).unwrap();
    let manifest = std::fs::read_to_string(src.join("manifest.toml")).unwrap();
    let plain = dir.path().join("plain");
    std::fs::create_dir(&plain).unwrap();
    copy_recordings(&src, &plain);
    std::fs::write(plain.join("manifest.toml"), &manifest).unwrap();
    std::fs::write(
        dir.path().join("manifest.toml"),
        format!(
            "{manifest}\n[[run]]\nfile = \"d0-low-run1.csv\"\nlabel = \"d0-low\"\n\
             center_distance_m = 0.424\nload_torque_nm = 8.8\n"
        ),
    )
    .unwrap();
    let two = dir.path().to_str().unwrap();
    let one = plain.to_str().unwrap();
    for cmd in ["diagnose", "calibrate"] {
        // The calibration without its full-order confirmation runs (a second each).
        let extra: &[&str] = if cmd == "calibrate" {
            &["--no-confirm"]
        } else {
            &[]
        };
        let o = rom(&[&[cmd, "--measured", two, "--format", "json"], extra].concat());
        assert!(o.status.success(), "{cmd}: {}", stderr(&o));
        let note = stderr(&o);
        assert!(
            note.contains("left out at another load") && note.contains("d0-low"),
            "{cmd}: {note}"
        );
        assert!(!stdout(&o).contains("d0-low"), "{cmd}");
        let alone = rom(&[&[cmd, "--measured", one, "--format", "json"], extra].concat());
        assert!(alone.status.success() && !stderr(&alone).contains("another load"));
        assert_eq!(stdout(&o), stdout(&alone), "{cmd}: the same report");
    }
    // Every label giving a load 9 % under the configuration's fan law at its speed: said.
    let given = manifest.replace(
        "synthetic = true",
        "synthetic = true\nload_torque_nm = 13.0",
    );
    std::fs::write(plain.join("manifest.toml"), given).unwrap();
    let o = rom(&["diagnose", "--measured", one]);
    assert!(o.status.success(), "{}", stderr(&o));
    let note = stderr(&o);
    assert!(
        note.contains("a load of 13 N m") && note.contains("from the drive configuration's"),
        "{note}"
    );
}

/// A tension meter's readings (`static_tension_n`) that the speeds agree with: `rom calibrate`
/// takes them in as the installation tension's prior and says so in its JSON
/// (`calibration.tension_prior`, null without readings). The sample loose belt (installed at
/// 180 N), each label given the static span tension its full-order model settles at there
/// (`fom::simulation::settled_static_tension_n`, what `rom simulate` prints): the readings give
/// 180 N, and the calibrated tension's 90 % interval is narrower than from the speeds alone and
/// holds it.
#[test]
fn calibrate_takes_agreeing_tension_readings_in_as_the_tension_prior() {
    let dir = tempfile::tempdir().unwrap();
    let src = crate::support::workspace().join("examples/data/loose");
    copy_recordings(&src, dir.path());
    let mut manifest = std::fs::read_to_string(src.join("manifest.toml")).unwrap();
    let cfg = fom::DriveConfig::default_hvac();
    for (label, d) in [("d0", 0.424), ("d1", 0.42), ("d2", 0.417), ("d3", 0.4165)] {
        let q = fom::DesignPoint::drive(d, cfg.effective_friction(), 180.0, None);
        let static_n = fom::simulation::settled_static_tension_n(&q.apply(&cfg).unwrap()).unwrap();
        let line = format!("label = \"{label}\"\n");
        assert!(manifest.contains(&line), "{label}");
        manifest = manifest.replace(&line, &format!("{line}static_tension_n = {static_n}\n"));
    }
    std::fs::write(dir.path().join("manifest.toml"), manifest).unwrap();
    let calibration = |set: &Path| -> serde_json::Value {
        let args = [
            "calibrate",
            "--measured",
            set.to_str().unwrap(),
            "--no-confirm",
        ];
        let o = rom(&[&args[..], &["--format", "json"]].concat());
        assert!(o.status.success(), "{}", stderr(&o));
        let v: serde_json::Value = serde_json::from_str(&stdout(&o)).unwrap();
        v["calibration"].clone()
    };
    assert!(
        calibration(&src)["tension_prior"].is_null(),
        "no readings, no prior"
    );
    let c = calibration(dir.path());
    let prior = &c["tension_prior"];
    let read_n = prior["read_n"].as_f64().expect("the readings taken in");
    assert!((read_n - 180.0).abs() < 2.0, "{prior}");
    let interval = |v: &serde_json::Value| {
        let i: Vec<f64> = v
            .as_array()
            .unwrap()
            .iter()
            .map(|x| x.as_f64().unwrap())
            .collect();
        (i[0], i[1])
    };
    let (lo, hi) = interval(&prior["speeds_only_interval90"]);
    let tension = c["parameters"]
        .as_array()
        .unwrap()
        .iter()
        .find(|p| p["name"] == "installation_tension_n")
        .unwrap();
    let (a, b) = interval(&tension["interval90"]);
    assert!(b - a < 0.5 * (hi - lo), "{tension} against {prior}");
    assert!(a < 180.0 && 180.0 < b, "{tension}");
}
