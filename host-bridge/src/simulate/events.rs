//! The emulator's events: counted, and logged with `--verbose`.

use lms_core::device::emulator::{Emulator, Event, Handled, ScanSource};
use lms_core::Variant;

use super::line::PtyLine;
use crate::scan::variant_name;

/// What a request was, for the log.
fn describe(h: Handled) -> String {
    match h {
        Handled::InstallationMode { accepted: true } => "20 00: installation mode".into(),
        Handled::InstallationMode { accepted: false } => {
            "20 00: installation mode refused (bad password)".into()
        }
        Handled::Continuous => "20 24: continuous output".into(),
        Handled::OnRequest => "20 25: values on request (stream stopped)".into(),
        Handled::SetBaud(b) => format!(
            "20 {:02X}: switch to {} Bd after the reply",
            b.mode_byte(),
            b.bits_per_second()
        ),
        Handled::OneScan => "30 01: one scan".into(),
        Handled::Extra { command } => format!("{command:02X}: answered by the scan source"),
        Handled::Status => "31: status".into(),
        Handled::SensorType => "3A: sensor type".into(),
        Handled::SetVariant { asked, accepted } => format!(
            "3B: variant {}°/{}° {}",
            asked.fov_deg,
            f64::from(asked.res_centideg) / 100.0,
            if accepted { "accepted" } else { "refused" }
        ),
        Handled::ReadConfig => "74: read configuration".into(),
        Handled::WriteConfig { accepted } => format!(
            "77: write configuration {}",
            if accepted {
                "accepted"
            } else {
                "refused (not in installation mode, or bad units)"
            }
        ),
        Handled::Reset => "10: reset".into(),
        Handled::PartialScans => "20 2A: continuous output of partial scans".into(),
        Handled::Unknown { command, data_len } => {
            format!("{command:02X} with {data_len} data bytes: unknown, answered 92")
        }
        other => format!("{other:?}"),
    }
}

/// Act on every event of the emulator: count scans, say when a variant is
/// refused, log the rest (`restart_delay` in seconds, for the message).
pub(super) fn handle_events<S: ScanSource>(
    lms: &mut Emulator<S>,
    line: &mut PtyLine,
    restart_delay: f64,
) {
    while let Some(event) = lms.next_event() {
        match event {
            Event::ScanSent { .. } => line.counters.scans += 1,
            Event::Request(h) => {
                refused_variant(h);
                line.log(format!("request {}", describe(h)));
            }
            Event::BaudSwitched { from, to } => line.log(format!(
                "line switched {} -> {} Bd",
                from.bits_per_second(),
                to.bits_per_second()
            )),
            Event::PowerOnSent => line.log("power-on telegram 90 sent (9600 Bd)"),
            Event::BadChecksum => line.log("bad checksum: NAK"),
            Event::IgnoredAddress { address } => {
                line.log(format!("telegram for address {address:#04x} ignored"))
            }
            Event::StreamStarted => line.log("continuous output started"),
            Event::StreamStopped => line.log("continuous output stopped"),
            Event::Restarting => line.log(format!("reset: power-on telegram in {restart_delay} s")),
            other => line.log(format!("{other:?}")),
        }
    }
}

/// A refused `3B` for a variant the scan source cannot produce: said on
/// stderr (with or without `--verbose`).
fn refused_variant(h: Handled) {
    if let Handled::SetVariant {
        asked,
        accepted: false,
    } = h
    {
        if let Some(v) = Variant::from_fov_res(asked) {
            eprintln!(
                "host-bridge simulate: refused variant {}: the scan source \
                 cannot produce it",
                variant_name(v)
            );
        }
    }
}
