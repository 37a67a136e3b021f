//! A journal that refers, not copies (issue 36): `load demos FILE` in a journalled session writes
//! the file's points once into a Parquet sidecar beside the journal, and its journal line names
//! the sidecar (file, length, CRC-64, points) and each demonstration's name and length. Resume
//! reads the sidecar back under the rules of a live load and restores the same dataset, bit for
//! bit; a sidecar deleted, altered by one byte or cut short stops the restore at its line with
//! `advise::journal::sidecar`, restores what came before, drives nothing, and continues in a new
//! journal.

use std::path::{Path, PathBuf};

use advise::session::Session;
use serde_json::Value;

mod common;
use common::{Invocation, masked, run_all};

/// Run `lines` on `s`, failing the test on any error.
fn run(s: &mut Session, lines: &str) {
    for line in lines.lines() {
        if let Err(e) = s.execute(line, "<test>") {
            panic!(
                "{line}: {}",
                advise_cli::repl::render(s.sources(), &e, false)
            );
        }
    }
}

/// A journalled positioning session (two teacher demonstrations) that loads a saved dataset's
/// demonstrations from a file, runs and critiques; its journal, the one sidecar beside it, and
/// the dataset it ends with (as `save` writes it).
fn journalled(dir: &Path) -> (PathBuf, PathBuf, String) {
    let mut s = common::positioning(2);
    let journal = s.start_journal(dir).unwrap();
    let demos = dir.join("demos.json");
    let end = dir.join("end.json");
    run(
        &mut s,
        &format!(
            "save {}\nload demos {}\nrun goal 2 -1 0\nselect 10..30\ncritique\nsave {}",
            demos.display(),
            demos.display(),
            end.display()
        ),
    );
    drop(s);
    let sidecars: Vec<PathBuf> = std::fs::read_dir(dir)
        .unwrap()
        .map(|e| e.unwrap().path())
        .filter(|p| p.extension().is_some_and(|e| e == "parquet"))
        .collect();
    assert_eq!(sidecars.len(), 1, "one sidecar: {sidecars:?}");
    let dataset = std::fs::read_to_string(&end).unwrap();
    (journal, sidecars[0].clone(), dataset)
}

/// The journal's lines as JSON values.
fn lines(journal: &Path) -> Vec<Value> {
    std::fs::read_to_string(journal)
        .unwrap()
        .lines()
        .map(|l| serde_json::from_str(l).unwrap())
        .collect()
}

/// The journal line of `load demos` names the sidecar and holds no point; resume restores the
/// dataset the session had, byte for byte as `save` writes it, and goes on journalling in the same
/// file.
#[test]
fn a_loaded_files_points_are_in_a_sidecar_and_resume_restores_them_exactly() {
    let dir = tempfile::tempdir().unwrap();
    let (journal, sidecar, dataset) = journalled(dir.path());
    let all = lines(&journal);
    let line = all
        .iter()
        .find(|l| l["effect"]["kind"] == "demos_file")
        .expect("a demos_file line");
    let effect = &line["effect"];
    assert_eq!(
        effect["sidecar"]["file"],
        sidecar.file_name().unwrap().to_str().unwrap()
    );
    assert_eq!(
        effect["sidecar"]["bytes"],
        std::fs::metadata(&sidecar).unwrap().len()
    );
    let spans = effect["episodes"].as_array().unwrap();
    assert_eq!(spans.len(), 2, "the saved dataset's two demonstrations");
    let points: u64 = spans.iter().map(|s| s["points"].as_u64().unwrap()).sum();
    assert_eq!(effect["sidecar"]["points"], points);
    assert!(
        line.to_string().len() < 1000,
        "the line names, not copies: {line}"
    );

    let restored = Session::restore(&journal, dir.path()).unwrap();
    assert!(restored.stopped.is_none(), "{:?}", restored.stopped);
    assert_eq!(restored.journal, journal, "continues in the same journal");
    let mut s = restored.session;
    let again = dir.path().join("again.json");
    run(&mut s, &format!("save {}", again.display()));
    assert_eq!(std::fs::read_to_string(&again).unwrap(), dataset);
}

/// Deleted, one byte altered, cut to half: each stops the restore at the `load demos` line with
/// a coded diagnostic, before anything of it is applied; the lines before it are restored (the
/// two teacher demonstrations), nothing after it, and the journal is left as it was.
#[test]
fn a_missing_or_altered_sidecar_stops_the_restore_at_its_line() {
    let dir = tempfile::tempdir().unwrap();
    let (journal, sidecar, _) = journalled(dir.path());
    let text = std::fs::read_to_string(&journal).unwrap();
    let bytes = std::fs::read(&sidecar).unwrap();
    let line = lines(&journal)
        .iter()
        .position(|l| l["effect"]["kind"] == "demos_file")
        .unwrap()
        + 1;
    let name = sidecar.file_name().unwrap().to_str().unwrap().to_string();
    let mut altered = bytes.clone();
    altered[bytes.len() / 3] ^= 0x10;
    let cases: Vec<(&str, Option<Vec<u8>>)> = vec![
        ("deleted", None),
        ("one_byte_altered", Some(altered)),
        ("truncated", Some(bytes[..bytes.len() / 2].to_vec())),
    ];
    let mut runs = Vec::new();
    for (case, content) in &cases {
        let home = tempfile::tempdir().unwrap();
        let path = home.path().join("j.jsonl");
        std::fs::write(&path, &text).unwrap();
        if let Some(c) = content {
            std::fs::write(home.path().join(&name), c).unwrap();
        }
        let restored = Session::restore(&path, home.path()).unwrap();
        let stopped = restored
            .stopped
            .as_ref()
            .unwrap_or_else(|| panic!("{case}: restored with no warning"));
        assert_eq!(
            miette::Diagnostic::code(stopped).unwrap().to_string(),
            "advise::journal::sidecar",
            "{case}"
        );
        assert!(
            stopped.to_string().starts_with(&format!("line {line} of")),
            "{case}: {stopped}"
        );
        assert_eq!(restored.entries, line - 2, "{case}: every line before it");
        assert_ne!(restored.journal, path, "{case}: continues in a new journal");
        assert_eq!(std::fs::read_to_string(&path).unwrap(), text, "{case}");

        let mut files = vec![("j.jsonl".to_string(), text.clone().into_bytes())];
        if let Some(c) = content {
            files.push((name.clone(), c.clone()));
        }
        runs.push((
            case.to_string(),
            Invocation {
                args: vec!["resume".into(), "j.jsonl".into()],
                files,
            },
        ));
    }
    let outputs = run_all(runs);
    for (case, _) in &cases {
        let (inv, out) = &outputs[*case];
        assert_eq!(out.code, Some(0), "{case}: {}", out.text);
        let mut settings = masked(Some(&out.dir));
        settings.add_filter(
            r"session-\d+-\d+-[0-9a-f]{8}(-\d+)?\.jsonl",
            "session-<new>.jsonl",
        );
        settings.add_filter(r"demos-[0-9a-f]{16}\.parquet", "demos-<crc>.parquet");
        settings.add_filter(r"\b[0-9a-f]{16}\b", "<crc64>");
        settings.add_filter(
            r"is \d+ bytes long; the journal wrote \d+",
            "is <n> bytes long; the journal wrote <m>",
        );
        settings.bind(|| {
            insta::assert_snapshot!(
                format!("resume_sidecar_{case}"),
                format!("{}\n{}", inv.command_line(), out.text)
            );
        });
    }
}
