//! Helpers shared by the command-line tests of `host-bridge` (each test
//! file uses a subset, hence `dead_code`). `independent_client.rs` does not
//! use them: it must share nothing with the project.
#![allow(dead_code)]

use std::path::{Path, PathBuf};
use std::process::{Command, Output};
use std::time::Instant;

/// The `host-bridge` binary under test.
pub const BIN: &str = env!("CARGO_BIN_EXE_host-bridge");

/// The repository's root.
pub fn workspace() -> PathBuf {
    Path::new(env!("CARGO_MANIFEST_DIR")).join("..")
}

/// Every file under `path` (itself, if it is a file), sorted; hidden
/// folders and build output (`target/`, `build/`, `__pycache__/`) left out.
pub fn files_under(path: &Path) -> Vec<PathBuf> {
    fn walk(path: &Path, out: &mut Vec<PathBuf>) {
        if !path.is_dir() {
            out.push(path.to_path_buf());
            return;
        }
        let Ok(entries) = std::fs::read_dir(path) else {
            return;
        };
        let mut entries: Vec<PathBuf> = entries.filter_map(|e| Some(e.ok()?.path())).collect();
        entries.sort();
        for entry in entries {
            let name = entry.file_name().and_then(|n| n.to_str()).unwrap_or("");
            let skipped = entry.is_dir()
                && (name.starts_with('.') || ["target", "build", "__pycache__"].contains(&name));
            if !skipped {
                walk(&entry, out);
            }
        }
    }
    let mut files = Vec::new();
    walk(path, &mut files);
    files
}

/// A recorded log of `../shared/data/carmen` by file name.
pub fn shared_log(name: &str) -> PathBuf {
    Path::new(env!("CARGO_MANIFEST_DIR"))
        .join("../../shared/data/carmen")
        .join(name)
}

/// The CSAIL log (cm, 361 beams); fails naming it if it is missing.
pub fn csail() -> PathBuf {
    let log = shared_log("csail-corrected.log.gz");
    assert!(
        log.is_file(),
        "no CSAIL log at {} (../shared must sit beside the repository)",
        log.display()
    );
    log
}

/// Run `host-bridge ARGS` and collect its output.
pub fn run(args: &[&str]) -> Output {
    Command::new(BIN)
        .args(args)
        .output()
        .expect("cannot start host-bridge")
}

/// Run `host-bridge ARGS`, printing the command, its time, status and
/// output (shown when the test fails).
pub fn run_logged(args: &[&str]) -> Output {
    let started = Instant::now();
    let out = run(args);
    println!(
        "$ host-bridge {} ({:.1} s, {})\n{}{}",
        args.join(" "),
        started.elapsed().as_secs_f64(),
        out.status,
        String::from_utf8_lossy(&out.stdout),
        String::from_utf8_lossy(&out.stderr)
    );
    out
}

/// Standard output as text.
pub fn stdout(out: &Output) -> String {
    String::from_utf8_lossy(&out.stdout).into_owned()
}

/// Standard error as text.
pub fn stderr(out: &Output) -> String {
    String::from_utf8_lossy(&out.stderr).into_owned()
}

/// A fresh scratch directory for this test process, `suite` and `name`.
pub fn scratch(suite: &str, name: &str) -> PathBuf {
    let dir =
        std::env::temp_dir().join(format!("host-bridge-{suite}-{}-{name}", std::process::id()));
    let _ = std::fs::remove_dir_all(&dir);
    std::fs::create_dir_all(&dir).unwrap();
    dir
}

/// Is `name` an executable file on PATH?
pub fn on_path(name: &str) -> bool {
    std::env::var_os("PATH")
        .is_some_and(|paths| std::env::split_paths(&paths).any(|d| d.join(name).is_file()))
}

/// `qemu-system-arm`, or a failure that says it is missing.
pub fn require_qemu() {
    assert!(
        on_path("qemu-system-arm"),
        "qemu-system-arm is not on PATH (apt-get install qemu-system-arm)"
    );
}

/// QEMU and the firmware ELF for a test that runs the firmware, or a
/// failure that names what is missing and how to build it.
pub fn qemu_firmware() -> PathBuf {
    require_qemu();
    let elf = elf();
    assert!(
        elf.is_file(),
        "no firmware ELF at {} (cd firmware && cargo build --release)",
        elf.display()
    );
    elf
}

/// The firmware ELF the QEMU tests run: `LMS_FIRMWARE_ELF`, or the release
/// build of `firmware/`.
pub fn elf() -> PathBuf {
    std::env::var_os("LMS_FIRMWARE_ELF").map_or_else(
        || {
            Path::new(env!("CARGO_MANIFEST_DIR"))
                .join("../firmware/target/thumbv7em-none-eabihf/release/lms-firmware")
        },
        PathBuf::from,
    )
}
