//! The capture reader of `host-bridge` (`host_bridge::capture`, compiled
//! here from its source file) on arbitrary bytes as a capture file.
//!
//! Input: bytes 0..1 say where the file is cut (a fraction); the rest is
//! the file (the magic is put in front when byte 2 is odd, so that records
//! are reached).
//!
//! Checks: no panic, in the record reader and in the scan reader
//! (`CaptureScans`, `frame_of`); offsets grow by each record's size;
//! records written back with `CaptureWriter` give the bytes read (when the
//! times do not decrease); a file cut at any byte within its good records
//! gives every complete record before the cut and then a clean end or a
//! `Truncated` cut, never another error.
#![no_main]

// The reader itself, from host-bridge's source file.
#[allow(dead_code)]
#[path = "../../host-bridge/src/capture.rs"]
mod capture;

use capture::{
    frame_of, CaptureError, CaptureReader, CaptureScans, CaptureWriter, Record, MAGIC,
    RECORD_HEADER_LEN,
};
use libfuzzer_sys::fuzz_target;
use lms_fuzz::Input;

/// The records of `bytes`, the offset after the last good one, and how the
/// reading ended (`None`: a clean end).
fn records(bytes: &[u8]) -> Option<(Vec<Record>, u64, Option<CaptureError>)> {
    let mut reader = CaptureReader::new(bytes).ok()?;
    let mut out = Vec::new();
    loop {
        let before = reader.offset();
        match reader.next_record() {
            Ok(Some(r)) => {
                assert_eq!(
                    reader.offset(),
                    before + (RECORD_HEADER_LEN + r.telegram.len()) as u64
                );
                out.push(r);
            }
            Ok(None) => return Some((out, reader.offset(), None)),
            Err(e) => return Some((out, reader.offset(), Some(e))),
        }
    }
}

fuzz_target!(|data: &[u8]| {
    let mut input = Input::new(data);
    let cut_at = input.u16();
    let magic = input.u8() % 2 == 1;
    let body = input.rest();
    let file: Vec<u8> = if magic {
        MAGIC.iter().chain(body).copied().collect()
    } else {
        body.to_vec()
    };
    // The scan reader: no panic, frames for every scan.
    if let Ok(reader) = CaptureReader::new(&file[..]) {
        let mut scans = CaptureScans::new(reader, std::path::Path::new("fuzz.lmscap"));
        for scan in scans.by_ref().flatten() {
            let _ = frame_of(&scan);
        }
        let _ = (scans.cut_message(), scans.records(), scans.scans());
    }
    let Some((recs, good_end, _)) = records(&file) else {
        return;
    };
    // Written back: the same bytes.
    if recs.windows(2).all(|w| w[0].time_us <= w[1].time_us) {
        let mut w = CaptureWriter::new(Vec::new()).expect("to memory");
        for r in &recs {
            w.write(r.time_us, &r.telegram)
                .expect("a record read is a record written");
        }
        let back = w.finish().expect("to memory");
        assert_eq!(&back[..], &file[..good_end as usize]);
    }
    // Cut within the good records: every complete record, then a clean
    // end or a cut.
    let good = &file[..good_end as usize];
    let at = MAGIC.len() + usize::from(cut_at) * (good.len() - MAGIC.len()) / usize::from(u16::MAX);
    let (part, _, end) = records(&good[..at]).expect("the magic is kept");
    let mut end_of = MAGIC.len();
    let complete = recs
        .iter()
        .take_while(|r| {
            end_of += RECORD_HEADER_LEN + r.telegram.len();
            end_of <= at
        })
        .count();
    assert_eq!(part.len(), complete);
    assert_eq!(part[..], recs[..complete]);
    assert!(
        matches!(end, None | Some(CaptureError::Truncated { .. })),
        "{end:?}"
    );
});
