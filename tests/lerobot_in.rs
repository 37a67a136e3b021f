//! A LeRobot v3.0 dataset in (`advise import --lerobot DIR`, src/recording/lerobot_in.rs): the
//! exporter's datasets read back as the same points, and bad datasets refused with
//! `advise::lerobot::*` diagnostics.

mod common;

use std::path::Path;
use std::process::Command;

use advise::domain::Domain;
use advise::recording::lerobot_in::{LeRobotReadOptions, read_lerobot};
use advise::trace::Episode;

fn advise(args: &[&str], dir: &Path) -> (bool, String) {
    common::advise_in(dir, args)
}

/// A session's dataset (3 demonstrations and one piece of advice) saved as `s.json` and exported
/// as LeRobot datasets, one per rate: the demonstrations' (15 fps) is `lr` in `d`.
fn exported(d: &Path) {
    std::fs::write(
        d.join("s.adv"),
        "run start 0\nselect 5..20\nadvise speed_up(0.2)\nsave s.json\n",
    )
    .unwrap();
    let (ok, text) = advise(&["run", "--demos", "3", "--no-journal", "s.adv"], d);
    assert!(ok, "{text}");
    let (ok, text) = advise(
        &["export", "s.json", "--lerobot", "parts", "--fps", "10"],
        d,
    );
    assert!(ok, "{text}");
    // One dataset per rate (issue 49): the demonstrations at their 15 Hz in `parts/15fps`, the
    // advice on a 30 Hz execution in `parts/30fps`. The tests read the demonstrations' as `lr`.
    std::fs::rename(d.join("parts/15fps"), d.join("lr")).unwrap();
    assert!(d.join("parts/30fps/meta/info.json").exists());
}

#[test]
fn an_exported_dataset_imports_as_the_same_points() {
    let dir = tempfile::tempdir().unwrap();
    let d = dir.path();
    exported(d);
    let mut files = advise::diag::SourceMap::new();
    let ds = advise::policy::dataset::Dataset::load(&mut files, &d.join("s.json")).unwrap();
    let domain = Domain::positioning();
    let read = read_lerobot(&d.join("lr"), &domain, &LeRobotReadOptions::default()).unwrap();
    // The export's episodes: each demonstration, at its recorded rate.
    assert_eq!(read.episodes.len(), 3);
    assert_eq!(read.fps, 15.0);
    let f32s = |v: &[f64]| v.iter().map(|&x| x as f32).collect::<Vec<_>>();
    let mut k = 0;
    for (e, episode) in read.episodes.iter().enumerate() {
        assert_eq!(episode.name, format!("episode {e}"));
        for f in 0..episode.trace.len() {
            // The dataset's points in the export's order: demonstrations' then advice's.
            let i = (0..ds.len())
                .filter(|&i| {
                    matches!(
                        ds.provenance(i),
                        advise::policy::dataset::Provenance::Demonstration { .. }
                    )
                })
                .chain((0..ds.len()).filter(|&i| {
                    matches!(
                        ds.provenance(i),
                        advise::policy::dataset::Provenance::Advice { .. }
                    )
                }))
                .nth(k)
                .unwrap();
            assert_eq!(
                f32s(episode.trace.z(f)),
                f32s(ds.z(i)),
                "episode {e} frame {f}"
            );
            assert_eq!(
                f32s(episode.trace.a(f)),
                f32s(ds.a(i)),
                "episode {e} frame {f}"
            );
            assert_eq!(episode.trace.t[f] as f32, f as f32 / 15.0);
            assert_eq!(read.episode_index[k], e as i64);
            assert_eq!(read.frame_index[k], f as i64);
            k += 1;
        }
    }
    assert_eq!(
        k,
        ds.demos().iter().map(|d| d.points as usize).sum::<usize>()
    );

    // The CLI writes them as demonstrations `load demos` reads.
    let (ok, text) = advise(
        &[
            "import",
            "--lerobot",
            "lr",
            "--task",
            "positioning",
            "--out",
            "d.csv",
        ],
        d,
    );
    assert!(ok, "{text}");
    insta::assert_snapshot!(text, @"read lr: `observation.state` by name: `dist2`, `bearing`, `dheading`, `action` by name: `trans`, `rot`; wrote 3 demonstrations (345 points) to d.csv; `load demos d.csv` adds them to a session");
    let loaded = Episode::load_all(&mut files, &domain, &d.join("d.csv")).unwrap();
    assert_eq!(loaded.len(), 3);
    for (a, b) in loaded.iter().zip(&read.episodes) {
        assert_eq!(a.trace.len(), b.trace.len());
        assert_eq!(f32s(&a.trace.z), f32s(&b.trace.z));
        assert_eq!(f32s(&a.trace.a), f32s(&b.trace.a));
    }
    std::fs::write(d.join("l.adv"), "load demos d.csv\n").unwrap();
    let (ok, text) = advise(&["run", "--no-journal", "l.adv"], d);
    assert!(ok, "{text}");
}

/// `lr/meta/info.json` edited by `edit`.
fn edit_info(d: &Path, edit: impl FnOnce(&mut serde_json::Value)) {
    let path = d.join("lr/meta/info.json");
    let mut info: serde_json::Value =
        serde_json::from_slice(&std::fs::read(&path).unwrap()).unwrap();
    edit(&mut info);
    std::fs::write(&path, serde_json::to_vec_pretty(&info).unwrap()).unwrap();
}

#[test]
fn bad_datasets_are_refused_with_codes() {
    use serde_json::json;
    type Edit = Box<dyn FnOnce(&Path)>;
    let cases: Vec<(&str, Edit)> = vec![
        (
            "names that are not the domain's",
            Box::new(|d| {
                edit_info(d, |i| {
                    i["features"]["action"]["names"] = json!(["left_wheel", "right_wheel"])
                })
            }),
        ),
        (
            "a huge declared shape, without names",
            Box::new(|d| {
                edit_info(d, |i| {
                    i["features"]["observation.state"]["shape"] = json!([1_000_000_000_000u64]);
                    i["features"]["observation.state"]["names"] = json!(null);
                })
            }),
        ),
        (
            "info.json lies about the width",
            Box::new(|d| {
                edit_info(d, |i| {
                    i["features"]["observation.state"]["shape"] = json!([4]);
                    i["features"]["observation.state"]["names"] =
                        json!(["dist2", "bearing", "dheading", "extra"]);
                })
            }),
        ),
        (
            "the frames' file is missing",
            Box::new(|d| std::fs::remove_dir_all(d.join("lr/data")).unwrap()),
        ),
        (
            "a truncated frames file",
            Box::new(|d| {
                let path = d.join("lr/data/chunk-000/file-000.parquet");
                let bytes = std::fs::read(&path).unwrap();
                std::fs::write(&path, &bytes[..bytes.len() / 2]).unwrap();
            }),
        ),
        (
            "a LeRobot v2.1 dataset",
            Box::new(|d| edit_info(d, |i| i["codebase_version"] = json!("v2.1"))),
        ),
    ];
    let dir = tempfile::tempdir().unwrap();
    let d = dir.path();
    exported(d);
    let mut out = Vec::new();
    for (n, (what, edit)) in cases.into_iter().enumerate() {
        let case = d.join(format!("case{n}"));
        std::fs::create_dir(&case).unwrap();
        let copy = Command::new("cp")
            .args(["-r", "lr"])
            .arg(case.join("lr"))
            .current_dir(d)
            .status()
            .unwrap();
        assert!(copy.success());
        edit(&case);
        let (ok, text) = advise(&["import", "--lerobot", "lr", "--out", "d.csv"], &case);
        assert!(!ok, "{what}: {text}");
        assert!(!case.join("d.csv").exists(), "{what}");
        out.push(format!("## {what}\n{text}"));
    }
    insta::assert_snapshot!(out.join("\n"));
}

#[test]
fn names_that_disagree_map_by_position_when_asked() {
    let dir = tempfile::tempdir().unwrap();
    let d = dir.path();
    exported(d);
    edit_info(d, |i| {
        i["features"]["action"]["names"] = serde_json::json!(["left_wheel", "right_wheel"])
    });
    let (ok, text) = advise(
        &[
            "import",
            "--lerobot",
            "lr",
            "--by-position",
            "--out",
            "d.json",
        ],
        d,
    );
    assert!(ok, "{text}");
    assert!(
        text.contains("`action` by position: `trans`, `rot`"),
        "{text}"
    );
}
