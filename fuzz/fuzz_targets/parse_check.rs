//! Arbitrary bytes through parse and check (on top of the standard operators), rendering every
//! diagnostic, and through every operator that checks: nothing may panic. On `advise-lang` alone;
//! the tasks a file declares are run by `task_steps`. The proptests in `tests/props.rs` run the
//! same exercise over random text in CI.
#![no_main]

use advise_lang::check::{OperatorSet, Source, render_all};
use advise_lang::domain::Domain;
use advise_lang::interp;
use advise_lang::syntax::{self, Invocation};
use advise_lang::trace::{Chunk, Trace};
use libfuzzer_sys::fuzz_target;

fuzz_target!(|data: &[u8]| {
    let Ok(text) = std::str::from_utf8(data) else {
        return;
    };
    let (map, id) = advise_lang::diag::SourceMap::single("line", text);
    let _ = syntax::parse_item(map.src(id));
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
                let mut map = advise_lang::diag::SourceMap::new();
                if let Ok(call) =
                    advise_lang::check::bind(&mut map, &set, &tr.domain, &Invocation::bare(name))
                {
                    let _ = interp::apply(&call, &tr, Chunk::all(6));
                }
            }
        }
    }
});
