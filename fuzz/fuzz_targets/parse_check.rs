//! Arbitrary bytes through parse and check (on top of the standard operators), rendering every
//! diagnostic, and through every operator that checks: nothing may panic. The proptests in
//! `tests/props.rs` run the same exercise over random text in CI.
#![no_main]

use advise::check::{OperatorSet, Source, render_all};
use advise::domain::Domain;
use advise::interp;
use advise::syntax::{self, Invocation};
use advise::trace::{Chunk, Trace};
use libfuzzer_sys::fuzz_target;

fuzz_target!(|data: &[u8]| {
    let Ok(text) = std::str::from_utf8(data) else {
        return;
    };
    let _ = syntax::parse_item("line", text);
    let _ = syntax::parse_invocation(text);
    match OperatorSet::standard().merge(&[Source::new("fuzz.adv", text)]) {
        Err(e) => {
            let _ = render_all(&e);
        }
        Ok(set) => {
            let d = Domain::positioning();
            let mut tr = Trace::new(&d);
            for i in 0..6 {
                let rot = if i % 2 == 0 { 0.0 } else { 0.2 };
                tr.push(i as f64, &[1.0, 0.1, -0.1], &[0.5, rot], None);
            }
            for name in set.operator_names("positioning") {
                if let Ok(call) = advise::check::bind(&set, &tr.domain, &Invocation::bare(name)) {
                    let _ = interp::apply(&call, &tr, Chunk::all(6));
                }
            }
        }
    }
});
