use super::*;
use crate::Beam;

fn line(n: usize, ranges: &str) -> String {
    format!("FLASER {n} {ranges} 1 2 0.5 1 2 0.5 12.5 host 12.6\n")
}

/// The unit and the scans of a log text, as the tools read it.
fn read(text: &str) -> Result<(Unit, Vec<Scan>), ReadError> {
    let unit = decide_unit(text.as_bytes())?;
    let scans = Reader::new(text.as_bytes(), unit).collect::<Result<_, _>>()?;
    Ok((unit, scans))
}

#[test]
fn parses_cm_codes_and_geometry() {
    let mut r = vec!["1.00"; 181];
    r[3] = "81.91";
    r[4] = "81.83";
    r[5] = "0";
    r[6] = "32.76";
    let text = format!("PARAM x 1\n{}", line(181, &r.join(" ")));
    let (unit, scans) = read(&text).unwrap();
    assert_eq!(unit, Unit::Centimetre);
    assert_eq!(scans.len(), 1);
    let f = &scans[0].frame;
    assert_eq!((scans[0].index, scans[0].line), (0, 2));
    assert_eq!(f.geometry(), Variant::Fov180Res100.geometry());
    assert_eq!(f.beams()[3], Beam::Invalid(Invalid::NoEcho));
    assert_eq!(f.beams()[4], Beam::Invalid(Invalid::AboveMax));
    assert_eq!(f.beams()[5], Beam::Invalid(Invalid::Zero));
    assert_eq!(f.beams()[6], Beam::Valid);
    assert_eq!(f.ranges()[6], 32.76f32);
    assert_eq!(scans[0].meta.pose, [1.0, 2.0, 0.5]);
    assert_eq!(scans[0].meta.odom, [1.0, 2.0, 0.5]);
    assert_eq!(
        (scans[0].meta.ipc_timestamp, scans[0].meta.logger_timestamp),
        (12.5, 12.6)
    );
    assert_eq!(scans[0].hostname, "host");
}

#[test]
fn detects_mm_logs() {
    // A mm log: most values show three decimals (CARMEN trims zeros: 1.5).
    let mut r = vec!["1.505"; 181];
    r[4] = "1.5";
    r[0] = "1.234";
    r[1] = "32.767";
    r[2] = "32.76"; // 32760 mm = offset 7
    r[3] = "32.759";
    let (unit, scans) = read(&line(181, &r.join(" "))).unwrap();
    assert_eq!(unit, Unit::Millimetre);
    let b = scans[0].frame.beams();
    assert_eq!(b[0], Beam::Valid);
    assert_eq!(b[1], Beam::Invalid(Invalid::NoEcho));
    assert_eq!(b[2], Beam::Invalid(Invalid::OtherCode(7)));
    assert_eq!(b[3], Beam::Invalid(Invalid::AboveMax));
    assert_eq!(b[4], Beam::Valid);
    // The same line forced to cm: all four are distances.
    let cm: Vec<Scan> = Reader::new(line(181, &r.join(" ")).as_bytes(), Unit::Centimetre)
        .collect::<Result<_, _>>()
        .unwrap();
    assert!(cm[0].frame.beams()[..4].iter().all(|b| b.is_valid()));
}

#[test]
fn beam_counts_and_geometry() {
    for (n, fov) in [(180, 180), (360, 180), (101, 100), (201, 100), (401, 100)] {
        let r = vec!["2"; n].join(" ");
        let (_, scans) = read(&line(n, &r)).unwrap();
        let g = scans[0].frame.geometry();
        let first = -(fov as f32 / 2.0).to_radians();
        assert!((g.first_bearing - first).abs() < 1e-6, "n = {n}");
        assert_eq!(scans[0].frame.len(), n);
    }
    let r = vec!["2"; 182].join(" ");
    let err = read(&line(182, &r)).unwrap_err().to_string();
    assert!(err.contains("unsupported beam count n = 182"), "{err}");
}

#[test]
fn errors_name_the_line() {
    let r = vec!["2"; 181];
    let mut bad = r.clone();
    bad[7] = "2.x";
    let text = format!(
        "# c\n{}{}",
        line(181, &r.join(" ")),
        line(181, &bad.join(" "))
    );
    let err = read(&text).unwrap_err();
    assert_eq!(err.line(), Some(3));
    let err = err.to_string();
    assert!(err.contains("line 3"), "{err}");
    assert!(
        err.contains("malformed number \"2.x\" for range 7"),
        "{err}"
    );

    let err = read(&line(181, &r[..180].join(" ")))
        .unwrap_err()
        .to_string();
    assert!(err.contains("line 1") && err.contains("n = 181"), "{err}");

    let mut big = r.clone();
    big[0] = "90.00";
    let err = read(&line(181, &big.join(" "))).unwrap_err().to_string();
    assert!(err.contains("line 1") && err.contains("above"), "{err}");

    // Syntax errors (first pass) come before the unit's range errors.
    let text = format!("{}{}", line(181, &big.join(" ")), line(181, &bad.join(" ")));
    assert_eq!(read(&text).unwrap_err().line(), Some(2));

    let mut neg = r.clone();
    neg[2] = "-1";
    let err = read(&line(181, &neg.join(" "))).unwrap_err().to_string();
    assert!(err.contains("negative range -1 for beam 2"), "{err}");
    let err = read("FLASER many 1 2 3\n").unwrap_err().to_string();
    assert!(err.contains("malformed beam count \"many\""), "{err}");
    let pose = line(181, &r.join(" ")).replace(" host ", " host x");
    let err = read(&pose).unwrap_err().to_string();
    assert!(err.contains("in the pose/time fields"), "{err}");
    let utf8 = b"FLASER 3 \xff\n";
    let err = decide_unit(&utf8[..]).unwrap_err();
    assert!(matches!(err, ReadError::NotUtf8 { line: 1 }), "{err}");
}

#[test]
fn the_line_layer_needs_no_allocation() {
    let text = line(361, &vec!["3.25"; 361].join(" "));
    let flaser = Flaser::parse(&text).unwrap();
    assert_eq!((flaser.variant, flaser.beams), (Variant::Fov180Res50, 361));
    assert!(!flaser.three_decimals);
    let mut frame = Frame::empty();
    flaser.fill(Unit::Centimetre, &mut frame).unwrap();
    assert_eq!(frame.len(), 361);
    assert!(frame.ranges().iter().all(|&r| r == 3.25));
    assert_eq!(Flaser::parse("ODOM 1 2"), Err(LineError::NotFlaser));
    assert!(is_flaser(b"  FLASER 3") && !is_flaser(b"FLASERX 3") && !is_flaser(b""));
}

#[test]
fn the_units_error_codes() {
    assert_eq!(
        (
            Unit::Centimetre.all_ones(),
            Unit::Centimetre.first_error_code()
        ),
        (8191, 8183)
    );
    assert_eq!(
        (
            Unit::Millimetre.all_ones(),
            Unit::Millimetre.first_error_code()
        ),
        (32767, 32759)
    );
}

#[test]
fn unit_decision_counts_and_names_the_value_that_decided() {
    // One stray 3-decimal value in a cm log: ambiguous, read as cm, so the
    // genuine 32.76 m reading stays a distance.
    let mut r = vec!["1.50"; 181];
    r[7] = "2.125";
    r[8] = "32.76";
    let text = format!(
        "# c\n{}{}",
        line(181, &vec!["1.5"; 181].join(" ")),
        line(181, &r.join(" "))
    );
    let vote = decide(text.as_bytes()).unwrap();
    assert_eq!(vote.verdict(), Verdict::Ambiguous);
    assert_eq!(vote.unit(), Unit::Centimetre);
    assert_eq!((vote.ranges(), vote.three_decimal_ranges()), (362, 1));
    let e = vote.evidence().unwrap();
    assert_eq!((e.line, e.beam, e.text()), (3, 7, "2.125"));
    let why = vote.to_string();
    assert!(
        why.contains("ambiguous") && why.contains("\"2.125\", line 3, beam 7"),
        "{why}"
    );
    assert!(why.contains("--unit"), "{why}");
    let (_, scans) = read(&text).unwrap();
    assert!(scans[1].frame.beams()[8].is_valid());
    // A quarter of the values decide mm; none decides cm.
    let mut r = vec!["1.50"; 181];
    for v in r.iter_mut().take(46) {
        *v = "1.505";
    }
    let vote = decide(line(181, &r.join(" ")).as_bytes()).unwrap();
    assert_eq!(vote.verdict(), Verdict::Millimetre, "{vote}");
    r[45] = "1.50";
    let vote = decide(line(181, &r.join(" ")).as_bytes()).unwrap();
    assert_eq!(vote.verdict(), Verdict::Ambiguous, "{vote}");
    let vote = decide(line(181, &vec!["1.5"; 181].join(" ")).as_bytes()).unwrap();
    assert_eq!(vote.verdict(), Verdict::Centimetre);
    assert!(vote.evidence().is_none());
}

#[test]
fn a_cut_log_keeps_its_complete_scans_and_says_where() {
    let full = format!(
        "{}{}",
        line(181, &vec!["1.5"; 181].join(" ")),
        line(181, &vec!["2.5"; 181].join(" "))
    );
    let first_len = full.find('\n').unwrap() + 1;
    // Cut at every byte: every complete line is a scan, never an error.
    for cut in 0..=full.len() {
        let text = &full.as_bytes()[..cut];
        let unit = decide_unit(text).unwrap();
        let mut reader = Reader::new(text, unit);
        let scans: Vec<Scan> = reader.by_ref().collect::<Result<_, _>>().unwrap();
        // The last line without its newline is complete once all its fields
        // are there (the logger time stamp may be cut to fewer digits).
        let complete = usize::from(cut >= first_len - 4) + usize::from(cut >= full.len() - 4);
        assert_eq!(scans.len(), complete, "cut at {cut}");
        let cut_reported = reader.cut().is_some();
        let clean = cut == 0 || (first_len - 4..=first_len).contains(&cut) || cut >= full.len() - 4;
        assert_eq!(cut_reported, !clean, "cut at {cut}");
        if let Some(c) = reader.cut() {
            assert_eq!(c.line, scans.len() + 1, "cut at {cut}");
            assert!(c.to_string().contains("no newline"), "{c}");
        }
    }
    // A bad line inside the log is still an error.
    let bad = format!("FLASER 181 1 2\n{full}");
    assert!(Reader::new(bad.as_bytes(), Unit::Centimetre)
        .next()
        .unwrap()
        .is_err());
}

#[test]
fn overlong_lines_are_bounded() {
    let long = format!(
        "PARAM {}\n{}",
        "x".repeat(MAX_LINE_LEN * 2),
        line(181, &vec!["1.5"; 181].join(" "))
    );
    let (_, scans) = read(&long).unwrap();
    assert_eq!((scans.len(), scans[0].line), (1, 2));
    let long = format!("FLASER 181 {}\n", "1 ".repeat(MAX_LINE_LEN));
    let e = Reader::new(long.as_bytes(), Unit::Centimetre)
        .next()
        .unwrap()
        .unwrap_err();
    assert!(matches!(e, ReadError::LineTooLong { line: 1 }), "{e}");
}

#[test]
fn long_tokens_are_quoted_by_their_start_and_length() {
    assert_eq!(Excerpt("2.x").to_string(), "\"2.x\"");
    let sixteen = "1234567890123456";
    assert_eq!(Excerpt(sixteen).to_string(), format!("{sixteen:?}"));
    let long = "7".repeat(5000);
    assert_eq!(
        Excerpt(&long).to_string(),
        "\"7777777777777777…\" (5000 characters)"
    );
    // Cut at a character, not a byte.
    let wide = "é".repeat(20);
    assert_eq!(
        Excerpt(&wide).to_string(),
        format!("\"{}…\" (20 characters)", "é".repeat(16))
    );
    let mut r = vec!["1.00".to_string(); 181];
    r[2] = long;
    let err = read(&line(181, &r.join(" "))).unwrap_err().to_string();
    assert!(err.contains("(5000 characters) for range 2"), "{err}");
    assert!(err.len() < 120, "{err}");
}

#[test]
fn keywords_one_edit_from_flaser() {
    for near in [
        "FLASEQ", "FLASR", "FFLASER", "LASER", "FLASERS", "XLASER", "FLAS3R",
    ] {
        assert!(near_flaser(near.as_bytes()), "{near}");
    }
    for far in [
        "FLASER", "RLASER", "ODOM", "PARAM", "FLA", "FLASERXX", "flaser", "LASER3", "",
    ] {
        assert!(!near_flaser(far.as_bytes()), "{far}");
    }
}

#[test]
fn notes_name_the_bom_and_damaged_keywords() {
    let r = vec!["2.50"; 181].join(" ");
    let text = format!(
        "\u{feff}{}ODOM 1 2 3\n{}{}",
        line(181, &r),
        line(181, &r).replace("FLASER", "FLASEQ"),
        line(181, &r)
    );
    let mut reader = Reader::new(text.as_bytes(), Unit::Centimetre);
    let scans: Vec<Scan> = reader.by_ref().collect::<Result<_, _>>().unwrap();
    assert_eq!(
        scans.iter().map(|s| (s.index, s.line)).collect::<Vec<_>>(),
        [(0, 1), (1, 4)]
    );
    assert_eq!(reader.next_note(), Some(Note::ByteOrderMark));
    let note = reader.next_note().unwrap();
    assert_eq!(note.line(), 3);
    assert!(
        note.to_string().contains("\"FLASEQ\" is one edit"),
        "{note}"
    );
    assert_eq!(reader.next_note(), None);
    // A BOM on a later line is not read through (nor noted).
    let later = format!("ODOM 1\n\u{feff}{}", line(181, &r));
    let mut reader = Reader::new(later.as_bytes(), Unit::Centimetre);
    assert_eq!(reader.by_ref().count(), 0);
    assert_eq!(reader.next_note(), None);
    // The notes waiting are bounded; the rest are counted.
    let flood = line(181, &r)
        .replace("FLASER", "FLASR")
        .repeat(MAX_PENDING_NOTES + 5);
    let mut reader = Reader::new(flood.as_bytes(), Unit::Centimetre);
    assert_eq!(reader.by_ref().count(), 0);
    assert_eq!(reader.notes_dropped(), 5);
    assert_eq!(
        core::iter::from_fn(|| reader.next_note()).count(),
        MAX_PENDING_NOTES
    );
}
