//! What several test files of the command line share: the workspace's root, and a child
//! process that is killed and reaped when dropped, its stderr read line by line, and a plain
//! HTTP GET.

use std::io::{BufRead, BufReader, Read, Write};
use std::net::TcpStream;
use std::path::{Path, PathBuf};
use std::process::{Child, Command, Output};
use std::sync::mpsc;
use std::time::{Duration, Instant};

/// The workspace's root folder.
pub fn workspace() -> PathBuf {
    Path::new(env!("CARGO_MANIFEST_DIR")).join("..")
}

/// Runs `rom ARGS` (the binary of this build) to its end.
pub fn run_rom(args: &[&str]) -> Output {
    Command::new(env!("CARGO_BIN_EXE_rom"))
        .args(args)
        .output()
        .unwrap()
}

/// A finished command's stdout, as text.
pub fn stdout(o: &Output) -> String {
    String::from_utf8_lossy(&o.stdout).into_owned()
}

/// A finished command's stderr, as text.
pub fn stderr(o: &Output) -> String {
    String::from_utf8_lossy(&o.stderr).into_owned()
}

/// A child process killed (SIGKILL) and reaped when dropped.
pub struct Killed(pub Child);

impl Drop for Killed {
    fn drop(&mut self) {
        let _ = self.0.kill();
        let _ = self.0.wait();
    }
}

/// Reads `child`'s stderr on a thread (so it never fills) and returns its lines.
pub fn stderr_lines(child: &mut Child) -> mpsc::Receiver<String> {
    let (tx, rx) = mpsc::channel();
    let err = child.stderr.take().unwrap();
    std::thread::spawn(move || {
        for line in BufReader::new(err).lines().map_while(Result::ok) {
            let _ = tx.send(line);
        }
    });
    rx
}

/// The first line holding `what`, waiting at most `secs`.
pub fn wait_line(rx: &mpsc::Receiver<String>, what: &str, secs: u64) -> String {
    let end = Instant::now() + Duration::from_secs(secs);
    let mut seen = Vec::new();
    while let Some(left) = end.checked_duration_since(Instant::now()) {
        match rx.recv_timeout(left) {
            Ok(l) if l.contains(what) => return l,
            Ok(l) => seen.push(l),
            Err(_) => break,
        }
    }
    panic!("no line with {what:?} within {secs} s; saw: {seen:#?}");
}

/// GET over plain HTTP/1.1, the body (read to its Content-Length: Chromium keeps the
/// connection open).
pub fn get(addr: &str, path: &str) -> String {
    let mut s = TcpStream::connect(addr).unwrap();
    write!(
        s,
        "GET {path} HTTP/1.1\r\nHost: {addr}\r\nConnection: close\r\n\r\n"
    )
    .unwrap();
    let mut r = BufReader::new(s);
    let mut status = String::new();
    r.read_line(&mut status).unwrap();
    assert!(status.contains(" 200 "), "{path}: {status}");
    let mut len = None;
    loop {
        let mut line = String::new();
        r.read_line(&mut line).unwrap();
        let line = line.trim_end();
        if line.is_empty() {
            break;
        }
        if let Some((k, v)) = line.split_once(':') {
            if k.eq_ignore_ascii_case("content-length") {
                len = v.trim().parse::<usize>().ok();
            }
        }
    }
    let mut body = vec![0; len.expect("a Content-Length")];
    r.read_exact(&mut body).unwrap();
    String::from_utf8(body).unwrap()
}

/// `rom serve ARGS --http 127.0.0.1:0` started (killed when dropped, stdout discarded), its
/// stderr's lines, and the `host:port` it serves on.
pub fn serve_http<S: AsRef<std::ffi::OsStr>>(
    args: impl IntoIterator<Item = S>,
) -> (Killed, mpsc::Receiver<String>, String) {
    let mut server = Killed(
        Command::new(env!("CARGO_BIN_EXE_rom"))
            .arg("serve")
            .args(args)
            .args(["--http", "127.0.0.1:0"])
            .stdout(std::process::Stdio::null())
            .stderr(std::process::Stdio::piped())
            .spawn()
            .unwrap(),
    );
    let lines = stderr_lines(&mut server.0);
    let addr = serving_addr(&lines);
    (server, lines, addr)
}

/// The `host:port` a `rom serve` started with `--http 127.0.0.1:0` says it serves on (its
/// "serving http://..." line on stderr, within 30 s).
pub fn serving_addr(lines: &mpsc::Receiver<String>) -> String {
    let serving = wait_line(lines, "serving http://", 30);
    serving
        .split("http://")
        .nth(1)
        .and_then(|s| s.split_whitespace().next())
        .expect("an address after http://")
        .to_string()
}
