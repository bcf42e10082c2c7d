//! Recovery of the co-processor's sensor link end to end: `verify
//! --power-cycle-sensor-after N` switches the simulated LMS off and on in
//! the middle of the run (its `90`, 9600 Bd, values on request); the
//! co-processor must bring it up again by itself, and every scan of the
//! selection must still come back bit-identical, the first within one
//! second of the power-on (on the sensor's clock).
//!
//! Natively (`--host`, pseudo-terminals: the line rates are real termios
//! settings) and under QEMU (the real firmware; QEMU ignores line rates, so
//! the `90` reaches the co-processor intact and restarts it at once — the
//! noise of a `90` at the wrong rate and the baud search are covered by
//! `core/tests/recovery.rs` on a line that models both rates).

mod common;

use common::{elf, on_path};

/// Run verify with a power cycle after 8 scans of 20; check the summary.
fn power_cycle(mode: &[&str]) {
    let args = [
        &["verify"],
        mode,
        &[
            "--count",
            "20",
            "--power-cycle-sensor-after",
            "8",
            "--timeout",
            "60",
        ],
    ]
    .concat();
    let out = common::run_logged(&args);
    let text = common::stdout(&out);
    assert!(out.status.success(), "{text}");
    assert!(text.contains("20/20 scans bit-identical; 0 lost"), "{text}");
    let line = text
        .lines()
        .find(|l| l.contains("sensor power-cycled after"))
        .unwrap_or_else(|| panic!("no power-cycle line: {text}"));
    // "… first scan back after 221.4 ms (sensor clock)"
    let ms: f64 = line
        .split("first scan back after ")
        .nth(1)
        .and_then(|rest| rest.split(' ').next())
        .and_then(|v| v.parse().ok())
        .unwrap_or_else(|| panic!("{line}"));
    assert!(ms > 0.0 && ms < 1000.0, "{line}");
    // The co-processor counted nothing lost: the power cycle came with
    // nothing in flight.
    assert!(text.contains("scans_dropped=0"), "{text}");
}

#[test]
fn host_coprocessor_streams_again_after_a_sensor_power_cycle() {
    power_cycle(&["--host"]);
}

#[test]
fn firmware_under_qemu_streams_again_after_a_sensor_power_cycle() {
    if !on_path("qemu-system-arm") || !elf().is_file() {
        println!("skipped: qemu-system-arm or the firmware ELF is missing");
        return;
    }
    let elf = elf();
    power_cycle(&["--qemu", elf.to_str().unwrap()]);
}
