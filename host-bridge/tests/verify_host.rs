//! `host-bridge verify --host`: the core's co-processor in a thread behind
//! two pseudo-terminals, driven from both lines by the verify command, on
//! synthetic and real (CSAIL) scans; and a deliberately wrong recomputation
//! that must make it fail, so that the check is seen to be able to fail.

use std::process::Output;

mod common;
use common::{csail, stdout};

/// Run `host-bridge verify ARGS`; prints its output (shown on failure).
fn verify(args: &[&str]) -> Output {
    common::run_logged(&[&["verify"], args].concat())
}

/// The summary says `n/n scans bit-identical; 0 lost`.
fn assert_all_identical(out: &Output, n: usize) {
    let text = stdout(out);
    assert!(out.status.success(), "verify failed:\n{text}");
    assert!(
        text.contains(&format!("{n}/{n} scans bit-identical; 0 lost")),
        "{text}"
    );
    assert!(!text.contains("MISMATCH"), "{text}");
    assert!(text.contains("co-processor counters: scans_in="), "{text}");
}

#[test]
fn verify_host_synthetic_scans_are_bit_identical() {
    let out = verify(&["--host", "--count", "30", "--timeout", "30"]);
    assert_all_identical(&out, 30);
}

#[test]
fn verify_host_csail_frames_are_bit_identical() {
    let log = csail();
    let out = verify(&[
        "--host",
        "--replay",
        log.to_str().unwrap(),
        "--frames",
        "100..120",
        "--timeout",
        "30",
    ]);
    assert_all_identical(&out, 20);
}

#[test]
fn verify_host_fails_on_a_wrong_recomputation() {
    // tau 9 on the co-processor, 3 in the recomputation: segmentation
    // differs, so every scan with structure mismatches.
    let out = verify(&[
        "--host",
        "--count",
        "5",
        "--timeout",
        "30",
        "--recompute-tau",
        "3",
    ]);
    let text = stdout(&out);
    assert_eq!(out.status.code(), Some(1), "{text}");
    let mismatch = text
        .lines()
        .find(|l| l.starts_with("MISMATCH scan "))
        .unwrap_or_else(|| panic!("no mismatch line:\n{text}"));
    // Scan counter, item, field, both values as bits and decimal.
    assert!(mismatch.contains("co-processor 0x"), "{mismatch}");
    assert!(mismatch.contains(", recomputed 0x"), "{mismatch}");
    assert!(text.contains("scans bit-identical"), "{text}");
    let err = String::from_utf8_lossy(&out.stderr);
    assert!(err.contains("verify failed:"), "{err}");
}

#[test]
fn verify_refuses_bad_options() {
    for args in [
        &["--host", "--count", "5", "--scans", "6"][..],
        &["--host", "--host-baud", "12345"],
        &["--host", "--frames", "0..3"],
        &["--host", "--ports", "/dev/null", "/dev/null"],
    ] {
        let out = verify(args);
        assert!(!out.status.success(), "{args:?} accepted");
    }
}

#[test]
fn verify_ports_mode_on_two_pseudo_terminals() {
    use host_bridge::pty::Pty;
    use host_bridge::serial::PtyPort;
    use host_bridge::verify::run_coprocessor;
    use std::sync::atomic::{AtomicBool, Ordering};
    use std::sync::Arc;

    // The co-processor in this process, on the masters; verify opens the
    // two slave devices as serial ports.
    let sensor = PtyPort::new(Pty::open(9600).unwrap());
    let host = PtyPort::new(Pty::open(9600).unwrap());
    let (sensor_dev, host_dev) = (
        sensor.slave_path().to_path_buf(),
        host.slave_path().to_path_buf(),
    );
    let stop = Arc::new(AtomicBool::new(false));
    let flag = Arc::clone(&stop);
    let cop = std::thread::spawn(move || {
        run_coprocessor(lms_core::ValidParams::default(), sensor, host, &flag)
    });
    let out = verify(&[
        "--ports",
        host_dev.to_str().unwrap(),
        sensor_dev.to_str().unwrap(),
        "--count",
        "10",
        "--timeout",
        "30",
    ]);
    stop.store(true, Ordering::Relaxed);
    let counters = cop.join().unwrap().unwrap();
    assert_all_identical(&out, 10);
    // The warm-up scan drawn as the sensor stream started, and the ten.
    assert_eq!(counters.scans_in, 11, "{counters:?}");
}

/// The value of `name=` in a line of `key=value` pairs.
fn counter(line: &str, name: &str) -> u64 {
    line.split([' ', ',', '('])
        .find_map(|w| w.strip_prefix(&format!("{name}=")))
        .and_then(|v| v.trim_end_matches(')').parse().ok())
        .unwrap_or_else(|| panic!("no {name}= in {line}"))
}

#[test]
fn verify_host_names_a_forced_loss_by_the_counter_that_counted_it() {
    // A sensor that runs free at 500 kBd, a client at 38400 Bd: a 361-value
    // B0 takes 190 ms on the host line, seven scan periods, so the
    // co-processor's budget drops most scans and counts them.
    let out = verify(&[
        "--host",
        "--count",
        "20",
        "--host-baud",
        "38400",
        "--sensor-runs-free",
        "--timeout",
        "30",
    ]);
    let text = stdout(&out);
    let err = common::stderr(&out);
    assert_eq!(out.status.code(), Some(1), "{text}{err}");
    let counters = text
        .lines()
        .find(|l| l.contains("co-processor counters:"))
        .unwrap_or_else(|| panic!("no counters line:\n{text}"));
    let dropped = counter(counters, "host_scans_dropped");
    assert!(dropped >= 10, "{counters}");
    // The summary, the error and the counters line tell the same number.
    let summary = text
        .lines()
        .find(|l| l.contains("scans bit-identical"))
        .unwrap();
    assert_eq!(counter(summary, "host_scans_dropped"), dropped, "{summary}");
    let verdict = err
        .lines()
        .find(|l| l.contains("verify failed:"))
        .unwrap_or_else(|| panic!("no verdict:\n{err}"));
    assert_eq!(counter(verdict, "host_scans_dropped"), dropped, "{verdict}");
    assert!(verdict.contains("scans lost"), "{verdict}");
    assert!(!verdict.contains("do not add up"), "{verdict}");
}
