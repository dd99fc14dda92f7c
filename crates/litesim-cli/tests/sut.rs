//! The closed loop from the command line, with a real external SUT: the
//! Python example agent (grpcio) in its own process, over a real socket.

use std::io::{BufRead, BufReader};
use std::path::Path;
use std::process::{Child, Command, Stdio};
use std::time::{Duration, Instant};

mod common;
use common::{ensure_grpcio, litesim, workspace};

/// The example agent on an ephemeral port; killed when dropped.
struct Agent(Child, u16);

impl Drop for Agent {
    fn drop(&mut self) {
        let _ = self.0.kill();
        let _ = self.0.wait();
    }
}

fn agent(extra: &[&str]) -> Agent {
    ensure_grpcio();
    let mut child = Command::new("python3")
        .arg(workspace().join("examples/sut/agent.py"))
        .args(["--port", "0"])
        .args(extra)
        .stdout(Stdio::piped())
        .stderr(Stdio::inherit())
        .spawn()
        .expect("python3 runs");
    let mut line = String::new();
    BufReader::new(child.stdout.take().unwrap())
        .read_line(&mut line)
        .unwrap();
    let port = line
        .trim()
        .strip_prefix("listening on ")
        .and_then(|p| p.parse().ok())
        .unwrap_or_else(|| panic!("agent said {line:?}"));
    Agent(child, port)
}

fn run(sut: &str, out: &Path, extra: &[&str]) -> std::process::Output {
    litesim()
        .current_dir(workspace())
        .args([
            "run",
            "examples/scenarios/cut_in.osc",
            "--no-pictures",
            "--sut",
            sut,
            "-o",
        ])
        .arg(out)
        .args(extra)
        .output()
        .unwrap()
}

#[test]
fn the_python_agent_drives_the_cut_in_reproducibly() {
    let a = agent(&[]);
    let dir = tempfile::tempdir().unwrap();
    let sut = format!("grpc://127.0.0.1:{}", a.1);
    let (o1, o2) = (dir.path().join("1"), dir.path().join("2"));
    let r1 = run(&sut, &o1, &[]);
    let r2 = run(&sut, &o2, &[]);
    let text = String::from_utf8_lossy(&r1.stdout);
    assert!(text.contains(&format!("sut {sut}")), "{text}");
    assert!(!String::from_utf8_lossy(&r1.stderr).contains("error"));
    let l1 = std::fs::read(o1.join("log.json")).unwrap();
    assert_eq!(
        l1,
        std::fs::read(o2.join("log.json")).unwrap(),
        "logs differ"
    );
    assert_eq!(r1.status.code(), r2.status.code());
    // It really drove: the log says the ego was commanded by the SUT.
    let summary = std::fs::read_to_string(o1.join("summary.json")).unwrap();
    assert!(summary.contains(&format!("\"sut\": \"{sut}\"")));
    let log = String::from_utf8_lossy(&l1);
    assert!(log.contains("\"command_source\":\"sut\""));
}

#[test]
fn a_crashed_agent_is_a_sut_error_verdict() {
    let a = agent(&["--exit-after", "100"]);
    let dir = tempfile::tempdir().unwrap();
    let t = Instant::now();
    let r = run(&format!("grpc://127.0.0.1:{}", a.1), dir.path(), &[]);
    assert!(t.elapsed() < Duration::from_secs(10));
    assert_eq!(
        r.status.code(),
        Some(1),
        "{}",
        String::from_utf8_lossy(&r.stdout)
    );
    let s = std::fs::read_to_string(dir.path().join("summary.json")).unwrap();
    assert!(
        s.contains("sut error at t=1.98 s: step: lost the connection"),
        "{s}"
    );
}

#[test]
fn a_hanging_agent_times_out() {
    let a = agent(&["--hang-after", "50"]);
    let dir = tempfile::tempdir().unwrap();
    let t = Instant::now();
    let r = run(
        &format!("grpc://127.0.0.1:{}", a.1),
        dir.path(),
        &["--sut-timeout", "0.5"],
    );
    let took = t.elapsed();
    assert_eq!(r.status.code(), Some(1));
    assert!(took < Duration::from_secs(5), "took {took:?}");
    let s = std::fs::read_to_string(dir.path().join("summary.json")).unwrap();
    assert!(
        s.contains("sut error at t=0.98 s: step: no answer from"),
        "{s}"
    );
    assert!(s.contains("within 0.500 s"), "{s}");
}

#[test]
fn nobody_listening_and_unknown_names_are_clear_errors() {
    let dir = tempfile::tempdir().unwrap();
    // A port nothing listens on: the run ends at reset, summary written.
    let l = std::net::TcpListener::bind("127.0.0.1:0").unwrap();
    let port = l.local_addr().unwrap().port();
    drop(l);
    let r = run(&format!("grpc://127.0.0.1:{port}"), dir.path(), &[]);
    assert_eq!(r.status.code(), Some(1));
    let s = std::fs::read_to_string(dir.path().join("summary.json")).unwrap();
    assert!(
        s.contains("sut error at t=0.00 s (reset): cannot connect"),
        "{s}"
    );
    let r = run("turbo", dir.path(), &[]);
    assert_ne!(r.status.code(), Some(0));
    let e = String::from_utf8_lossy(&r.stderr);
    assert!(
        e.contains(
            "--sut turbo: unknown system under test; valid: planned, acc, acc-aeb, fmt-mpc, grpc://HOST:PORT"
        ),
        "{e}"
    );
    let r = run("grpc://nowhere", dir.path(), &[]);
    assert!(String::from_utf8_lossy(&r.stderr).contains("expected grpc://HOST:PORT"));
}

#[test]
fn batch_takes_a_sut() {
    let dir = tempfile::tempdir().unwrap();
    let r = litesim()
        .current_dir(workspace())
        .args([
            "batch",
            "examples/scenarios/cut_in_judged.osc",
            "--seeds",
            "1..3",
            "--sut",
            "acc",
            "-q",
            "-o",
        ])
        .arg(dir.path())
        .output()
        .unwrap();
    assert!(r.status.success(), "{}", String::from_utf8_lossy(&r.stderr));
    let lines = std::fs::read_to_string(dir.path().join("results.jsonl")).unwrap();
    assert_eq!(lines.lines().count(), 3);
    assert!(
        lines.lines().all(|l| l.contains("\"pass\":true")),
        "{lines}"
    );
}

#[test]
fn a_batch_goes_on_past_sut_errors() {
    // Nothing listens: every run ends at its reset with a sut error, and
    // the batch still writes every line.
    let l = std::net::TcpListener::bind("127.0.0.1:0").unwrap();
    let port = l.local_addr().unwrap().port();
    drop(l);
    let dir = tempfile::tempdir().unwrap();
    let r = litesim()
        .current_dir(workspace())
        .args([
            "batch",
            "examples/scenarios/cut_in.osc",
            "examples/scenarios/follow.osc",
            "--seeds",
            "1..3",
            "--sut",
            &format!("grpc://127.0.0.1:{port}"),
            "-q",
            "-o",
        ])
        .arg(dir.path())
        .output()
        .unwrap();
    assert!(r.status.code().is_some(), "the batch ends");
    let lines = std::fs::read_to_string(dir.path().join("results.jsonl")).unwrap();
    assert_eq!(lines.lines().count(), 6, "{lines}");
    assert!(
        lines
            .lines()
            .all(|l| l.contains("sut error at t=0.00 s (reset): cannot connect")),
        "{lines}"
    );
}
