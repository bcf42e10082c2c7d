//! The C examples (examples/c) give exactly the lines of `host-bridge
//! extract`: alpha and r as the same f32 bits, first and last the same,
//! frame by frame.
//!
//! Both tests are ignored in a plain `cargo test`: they need
//! `target/release/host-bridge` (`cargo build --release -p host-bridge`),
//! a C compiler, and for the MCU test `arm-none-eabi-gcc` with newlib and
//! `qemu-system-arm`. Run them with `make -C examples/c check` and
//! `make -C examples/c check-mcu`, or
//! `cargo test -p lms-capi --test c_example -- --ignored`.

use std::path::{Path, PathBuf};
use std::process::{Command, Stdio};

use serde_json::Value;

/// One line as compared: alpha and r bits, first, last.
type LineKey = (u32, u32, u64, u64);

fn root() -> PathBuf {
    Path::new(env!("CARGO_MANIFEST_DIR"))
        .parent()
        .expect("capi lies in the repository")
        .to_path_buf()
}

fn shared_log(name: &str) -> PathBuf {
    let path = root().join("../shared/data/carmen").join(name);
    assert!(
        path.exists(),
        "missing {} (../shared beside the repository)",
        path.display()
    );
    path
}

fn host_bridge() -> PathBuf {
    let path = root().join("target/release/host-bridge");
    assert!(
        path.exists(),
        "{} does not exist: build it with `cargo build --release -p host-bridge`",
        path.display()
    );
    path
}

/// Run `cmd`, fail with its standard error unless it succeeds; its output.
fn run(cmd: &mut Command) -> String {
    let out = cmd
        .stderr(Stdio::piped())
        .output()
        .unwrap_or_else(|e| panic!("cannot run {cmd:?}: {e}"));
    assert!(
        out.status.success(),
        "{cmd:?} failed ({}):\n{}",
        out.status,
        String::from_utf8_lossy(&out.stderr)
    );
    String::from_utf8(out.stdout).expect("UTF-8 output")
}

/// The tests share examples/c/build: one at a time.
static BUILD_DIR: std::sync::Mutex<()> = std::sync::Mutex::new(());

fn make(target: &str, vars: &[(&str, String)]) {
    let mut cmd = Command::new("make");
    cmd.arg("-s")
        .arg("-C")
        .arg(root().join("examples/c"))
        .arg(target);
    for (k, v) in vars {
        cmd.arg(format!("{k}={v}"));
    }
    run(&mut cmd);
}

/// The frames' lines of a JSON Lines text: (frame, lines).
fn lines_of(jsonl: &str, what: &str) -> Vec<(u64, Vec<LineKey>)> {
    jsonl
        .lines()
        .filter(|l| !l.trim().is_empty())
        .enumerate()
        .map(|(i, l)| {
            let v: Value = serde_json::from_str(l)
                .unwrap_or_else(|e| panic!("{what}: line {}: {e}: {l}", i + 1));
            let frame = v["frame"].as_u64().expect("frame");
            let lines = v["lines"]
                .as_array()
                .expect("lines")
                .iter()
                .map(|l| {
                    let f = |k: &str| l[k].as_f64().unwrap_or_else(|| panic!("{what}: {k}")) as f32;
                    let n = |k: &str| l[k].as_u64().unwrap_or_else(|| panic!("{what}: {k}"));
                    (
                        f("alpha").to_bits(),
                        f("r").to_bits(),
                        n("first"),
                        n("last"),
                    )
                })
                .collect();
            (frame, lines)
        })
        .collect()
}

fn assert_same(c: &str, reference: &str, what: &str) -> usize {
    let c = lines_of(c, what);
    let r = lines_of(reference, "host-bridge extract");
    assert_eq!(c.len(), r.len(), "{what}: frame count");
    for (a, b) in c.iter().zip(&r) {
        assert_eq!(
            a, b,
            "{what}: frame {} differs from host-bridge extract",
            b.0
        );
    }
    r.iter().map(|f| f.1.len()).sum()
}

#[test]
#[ignore = "needs target/release/host-bridge and cc: make -C examples/c check"]
fn host_c_example_matches_host_bridge() {
    let hb = host_bridge();
    let _build = BUILD_DIR.lock().unwrap_or_else(|e| e.into_inner());
    make("all", &[]);
    let exe = root().join("examples/c/build/lms-extract");
    // cm at 0.5° (361 beams), cm at 1° without the last beam (180), mm (181).
    for log in ["csail-corrected", "intel-corrected", "orebro-corrected"] {
        let path = shared_log(&format!("{log}.log.gz"));
        let c = run(Command::new(&exe).arg(&path));
        let reference = run(Command::new(&hb).arg("extract").arg(&path));
        let lines = assert_same(&c, &reference, log);
        eprintln!("{log}: {lines} lines bit-identical");
    }
}

#[test]
#[ignore = "needs target/release/host-bridge, arm-none-eabi-gcc and qemu-system-arm: make -C examples/c check-mcu"]
fn mcu_under_qemu_matches_host_bridge() {
    let hb = host_bridge();
    let _build = BUILD_DIR.lock().unwrap_or_else(|e| e.into_inner());
    let log = std::env::var("LMS_MCU_LOG")
        .map(PathBuf::from)
        .unwrap_or_else(|_| shared_log("csail-corrected.log.gz"));
    let frames = std::env::var("LMS_MCU_FRAMES").unwrap_or_else(|_| "40".to_string());
    let vars = [
        ("MCU_LOG", log.display().to_string()),
        ("MCU_FRAMES", frames.clone()),
    ];
    make("mcu", &vars);
    let mut qemu = Command::new("make");
    qemu.arg("-s")
        .arg("--no-print-directory")
        .arg("-C")
        .arg(root().join("examples/c"))
        .arg("run-mcu");
    for (k, v) in &vars {
        qemu.arg(format!("{k}={v}"));
    }
    let mcu = run(&mut qemu);
    let mcu: String = mcu
        .lines()
        .filter(|l| l.starts_with('{'))
        .map(|l| format!("{l}\n"))
        .collect();
    let reference = run(Command::new(&hb)
        .arg("extract")
        .arg(&log)
        .arg("--frames")
        .arg(format!("0..{frames}")));
    let lines = assert_same(&mcu, &reference, "MCU under QEMU");
    assert!(lines > 0);
    eprintln!("MCU under QEMU: {frames} frames, {lines} lines bit-identical");
}
