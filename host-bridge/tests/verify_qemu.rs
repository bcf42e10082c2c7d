//! `host-bridge verify --qemu`: the firmware under QEMU, checked bit for bit.
//! The tests that need `qemu-system-arm` (and the firmware ELF) are
//! ignored by default; `cargo test -p host-bridge --test verify_qemu --
//! --ignored` runs them after `cd firmware && cargo build --release`, and
//! fails naming whatever is still missing. `LMS_FIRMWARE_ELF` may name
//! another ELF.

use std::path::Path;

mod common;

/// Run `host-bridge verify ARGS`, printing its output (shown on failure).
fn verify(args: &[&str]) -> (bool, String, String) {
    let out = common::run_logged(&[&["verify"], args].concat());
    (
        out.status.success(),
        common::stdout(&out),
        common::stderr(&out),
    )
}

#[test]
#[ignore = "needs qemu-system-arm and the firmware ELF: cd firmware && cargo build --release"]
fn verify_qemu_firmware_is_bit_identical() {
    let elf = common::qemu_firmware();
    let elf = elf.to_str().unwrap();
    let (ok, text, _) = verify(&["--qemu", elf, "--count", "10", "--timeout", "60"]);
    assert!(ok, "{text}");
    assert!(text.contains("10/10 scans bit-identical; 0 lost"), "{text}");
    assert!(text.contains("firmware report: "), "{text}");

    let log = common::csail();
    let (ok, text, _) = verify(&[
        "--qemu",
        elf,
        "--replay",
        log.to_str().unwrap(),
        "--frames",
        "200..210",
        "--timeout",
        "60",
    ]);
    assert!(ok, "{text}");
    assert!(text.contains("10/10 scans bit-identical; 0 lost"), "{text}");
}

#[test]
#[ignore = "needs qemu-system-arm: apt-get install qemu-system-arm"]
fn verify_qemu_reports_a_firmware_that_does_not_boot() {
    common::require_qemu();
    // Not an ELF: refused before QEMU starts.
    let not_elf = Path::new(env!("CARGO_MANIFEST_DIR")).join("Cargo.toml");
    let (ok, _, err) = verify(&["--qemu", not_elf.to_str().unwrap(), "--count", "3"]);
    assert!(!ok);
    assert!(err.contains("is not an ELF file"), "{err}");
    // An ARM ELF header over garbage: it passes the check, QEMU cannot run it.
    let bogus = std::env::temp_dir().join(format!("verify-qemu-bogus-{}.elf", std::process::id()));
    let mut bytes = b"\x7fELF\x01\x01\x01\0\0\0\0\0\0\0\0\0\x02\0\x28\0".to_vec();
    bytes.extend(std::iter::repeat_n(0xA5u8, 4096));
    std::fs::write(&bogus, &bytes).unwrap();
    let (ok, _, err) = verify(&[
        "--qemu",
        bogus.to_str().unwrap(),
        "--count",
        "3",
        "--timeout",
        "20",
    ]);
    assert!(!ok);
    assert!(err.contains("QEMU exited during the run"), "{err}");
    // A failed run keeps QEMU's log directory for diagnosis: not this one.
    if let Some(at) = err.find("host-bridge-verify-") {
        let digits: String = err[at + 19..]
            .chars()
            .take_while(char::is_ascii_digit)
            .collect();
        let dir = std::env::temp_dir().join(format!("host-bridge-verify-{digits}"));
        let _ = std::fs::remove_dir_all(dir);
    }
    let _ = std::fs::remove_file(&bogus);
}

/// verify's default `--max-in-flight` under QEMU rests on the size of the
/// firmware's sensor receive queue: the two sources must agree.
#[test]
fn verify_knows_the_firmware_sensor_queue() {
    let root = Path::new(env!("CARGO_MANIFEST_DIR")).join("..");
    let constant = |path: &str, name: &str| -> usize {
        let text = std::fs::read_to_string(root.join(path)).unwrap();
        let line = text
            .lines()
            .find(|l| l.contains(&format!("const {name}: usize =")))
            .unwrap_or_else(|| panic!("{name} not in {path}"));
        let value = line.split('=').nth(1).unwrap().trim().trim_end_matches(';');
        value.replace('_', "").parse().unwrap()
    };
    let slots = constant("firmware/src/board.rs", "SENSOR_RX_SLOTS");
    let queue = constant(
        "host-bridge/src/verify/sensor_side.rs",
        "FIRMWARE_SENSOR_QUEUE",
    );
    // A heapless::spsc queue of N slots holds N − 1 bytes.
    assert_eq!(queue, slots - 1);
}
