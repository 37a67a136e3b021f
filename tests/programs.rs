//! File-driven snapshots: `programs/ok/*.adv` snapshot the parsed (canonical) form and what the
//! checker made of it; `programs/err/*.adv` snapshot the rendered diagnostics under the source.
//! Adding a case means adding a file.

use advise::check::{OperatorSet, Source, render_all};
use advise::syntax::ast::EraseSpans;

mod common;
use common::parse;

fn source(path: &std::path::Path) -> Source {
    let name = path.file_name().unwrap().to_string_lossy().to_string();
    Source::new(name, std::fs::read_to_string(path).unwrap())
}

#[test]
fn valid_programs() {
    insta::glob!("programs/ok/*.adv", |path| {
        let src = source(path);
        let ast = parse(&src.name, &src.text).unwrap();
        let printed = ast.to_string();
        // The canonical form parses back to the same tree.
        let mut again = parse("printed", &printed).unwrap();
        let mut orig = ast.clone();
        orig.erase_spans();
        again.erase_spans();
        assert_eq!(orig, again, "print-then-parse changed {}", src.name);

        let std = OperatorSet::standard();
        let set = std
            .merge(std::slice::from_ref(&src))
            .unwrap_or_else(|e| panic!("{} does not check:\n{}", src.name, render_all(&e)));
        let mut summary = String::new();
        for d in set.domains() {
            let known = std.domain(&d.name).is_some();
            if !known {
                summary.push_str(&format!("domain {}: ", d.name));
                let dims: Vec<String> = d
                    .observe
                    .iter()
                    .map(|x| format!("observe {} {:?} {:?}", x.name, x.unit, x.limits))
                    .chain(
                        d.act
                            .iter()
                            .map(|x| format!("act {} {:?} {:?}", x.name, x.unit, x.limits)),
                    )
                    .collect();
                summary.push_str(&dims.join("; "));
                summary.push('\n');
            }
            for op in set.operators(&d.name) {
                let is_new = std
                    .operator(&d.name, op.name())
                    .is_none_or(|s| s.definition() != op.definition());
                if is_new {
                    summary.push_str(&format!(
                        "operator {} for {} on {}{}: {}\n",
                        op.signature(),
                        d.name,
                        op.space(),
                        if op.is_composition() {
                            " (composition)"
                        } else {
                            ""
                        },
                        op.summary()
                    ));
                }
            }
        }
        insta::assert_snapshot!(format!(
            "----- CANONICAL FORM\n{printed}\n----- CHECKED\n{summary}"
        ));
    });
}

#[test]
fn invalid_programs() {
    insta::glob!("programs/err/*.adv", |path| {
        let src = source(path);
        let errors = match OperatorSet::standard().merge(std::slice::from_ref(&src)) {
            Ok(_) => panic!("{} checks, but it is in the err corpus", src.name),
            Err(e) => e,
        };
        insta::assert_snapshot!(format!(
            "----- SOURCE CODE\n{}\n----- ERROR ({} diagnostic{})\n{}",
            src.text,
            errors.error.errors.len(),
            if errors.error.errors.len() == 1 {
                ""
            } else {
                "s"
            },
            render_all(&errors)
        ));
    });
}
