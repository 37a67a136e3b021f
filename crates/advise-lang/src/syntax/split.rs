//! A large file's items parsed on several threads, handed on in source order.
//!
//! Parsing is most of the time `advise check` spends on a long file (pest's matching and the
//! tree built from it, about 70% of the 50 MB benchmark). Items are independent of each other
//! until the checker binds names, so a large text is cut into batches between items and each batch
//! is parsed by a worker thread while the caller checks the items already parsed, in order.
//!
//! A cut is made only where an item must start: at a line that begins with the keyword `operator`
//! or `domain` while no bracket is open (both words are reserved, so no item goes on across such a
//! line), moved back over the blank and comment lines above it so that an item's `///` doc stays
//! with it. Whatever a batch holds, the result is the sequential [`items`](super::items)': a batch
//! that fails to parse is read again sequentially from its start to the end of the file, so a
//! mistake is reported exactly as before (same place, same words), whichever batch it is in.
//!
//! Memory stays bounded: each worker parses at most [`AHEAD`] batches before the caller takes
//! them, so the trees of a few batches are held at a time, never the whole file's.

use std::ops::{ControlFlow, Range};
use std::sync::mpsc;
use std::thread;

use super::ast::Item;
use super::delims::{self, LineBrackets};
use super::{Items, ParseError, Src};

/// Below this many bytes a text is parsed on the caller's thread (a thread costs more than it saves).
const PARALLEL_FROM: usize = 1 << 20;
/// About how many bytes a batch holds (it ends at the first cut past this).
const BATCH: usize = 256 << 10;
/// How many batches a worker may have parsed that the caller has not taken yet.
const AHEAD: usize = 2;
/// At most this many workers, however many cores: the caller's checking keeps pace with few.
const MAX_WORKERS: usize = 4;
/// A worker's stack: the main thread's usual size, for pest's recursion (which
/// [`MAX_NESTING`](super::MAX_NESTING) bounds).
const STACK: usize = 8 << 20;

/// How a text is split: when, how finely, on how many threads.
#[derive(Clone, Copy, Debug)]
struct Split {
    from: usize,
    batch: usize,
    workers: usize,
}

/// Hand the items of `source` to `f` in source order, as [`items`](super::items) yields them
/// (up to and including the first error, or until `f` breaks), parsing a large text on several
/// threads. `f` runs on the caller's thread.
pub fn each_item(source: Src<'_>, f: impl FnMut(Result<Item, ParseError>) -> ControlFlow<()>) {
    let workers = thread::available_parallelism().map_or(1, |n| n.get().min(MAX_WORKERS));
    each_item_split(
        source,
        f,
        Split {
            from: PARALLEL_FROM,
            batch: BATCH,
            workers,
        },
    );
}

fn each_item_split(
    source: Src<'_>,
    mut f: impl FnMut(Result<Item, ParseError>) -> ControlFlow<()>,
    split: Split,
) {
    let text = source.text;
    let batches = if text.len() >= split.from && split.workers > 1 {
        batches(text, split.batch)
    } else {
        Vec::new()
    };
    if batches.len() < 2 {
        return feed(super::items(source), &mut f);
    }
    let brackets = delims::scan(text);
    if brackets.too_deep.is_some() {
        // Refused before any item is parsed; the sequential reader says so.
        return feed(super::items(source), &mut f);
    }
    let workers = split.workers.min(batches.len());
    thread::scope(|scope| {
        let mut taken = Vec::with_capacity(workers);
        for w in 0..workers {
            let (tx, rx) = mpsc::sync_channel(AHEAD);
            let mine: Vec<Range<usize>> =
                batches.iter().skip(w).step_by(workers).cloned().collect();
            let spawned = thread::Builder::new()
                .name(format!("parse-{w}"))
                .stack_size(STACK)
                .spawn_scoped(scope, move || parse_batches(source, mine, tx));
            if spawned.is_err() {
                // No thread to be had: the workers started so far stop at their next batch.
                drop(taken);
                return feed(super::items(source), &mut f);
            }
            taken.push(rx);
        }
        let mut last_start = 0;
        for (k, range) in batches.iter().enumerate() {
            let parsed = taken[k % workers].recv().ok();
            let Some((items, batch_last)) =
                parsed.filter(|(items, _)| !items.last().is_some_and(Result::is_err))
            else {
                // Read on sequentially from this batch (none of whose items were handed on), so
                // the mistake is placed and worded with the whole file, as without threads.
                let rest = Items::within(source, brackets, range.start..text.len(), last_start);
                return feed(rest, &mut f);
            };
            for item in items {
                if f(item).is_break() {
                    return;
                }
            }
            last_start = batch_last;
        }
    });
}

/// A worker: parse each of its batches and send its items (with where the last one started),
/// stopping when the caller no longer listens.
type Parsed = (Vec<Result<Item, ParseError>>, usize);

fn parse_batches(source: Src<'_>, mine: Vec<Range<usize>>, tx: mpsc::SyncSender<Parsed>) {
    for range in mine {
        let start = range.start;
        // Errors in a batch are only noticed here; the caller words them with the whole file's
        // brackets, so none are needed.
        let mut items = Items::within(source, delims::Scan::default(), range, start);
        let parsed: Vec<_> = items.by_ref().collect();
        if tx.send((parsed, items.last_start)).is_err() {
            return;
        }
    }
}

fn feed(
    items: impl Iterator<Item = Result<Item, ParseError>>,
    f: &mut impl FnMut(Result<Item, ParseError>) -> ControlFlow<()>,
) {
    for item in items {
        if f(item).is_break() {
            return;
        }
    }
}

/// The text cut into batches of about `size` bytes, each ending where an item must start
/// (see the module docs); one batch if there is no such place.
fn batches(text: &str, size: usize) -> Vec<Range<usize>> {
    let mut out = Vec::new();
    let mut begin = 0;
    for cut in item_starts(text) {
        if cut - begin >= size {
            out.push(begin..cut);
            begin = cut;
        }
    }
    out.push(begin..text.len());
    out
}

/// The places after the first where an item must start: before each line at bracket depth 0
/// that begins with `operator` or `domain`, or before the first `///` doc line of the blank and
/// comment lines above it. Blank and `//` lines before that stay with the item before, since the
/// parser skips them at its end (they can be inside its span).
fn item_starts(text: &str) -> Vec<usize> {
    let mut starts = Vec::new();
    let mut open = LineBrackets::default();
    // The first doc line since the last line of code.
    let mut doc_from = None;
    let mut at = 0;
    for line in text.split_inclusive('\n') {
        if at > 0 && !open.is_open() && (keyword(line, "operator") || keyword(line, "domain")) {
            starts.push(doc_from.unwrap_or(at));
        }
        let code = line.trim_start();
        if code.starts_with("///") {
            doc_from = doc_from.or(Some(at));
        } else if !(code.is_empty() || code.starts_with("//")) {
            doc_from = None;
        }
        open.feed(line);
        at += line.len();
    }
    starts
}

/// Whether `line` begins with the word `kw` (not a longer name).
fn keyword(line: &str, kw: &str) -> bool {
    line.strip_prefix(kw).is_some_and(|rest| {
        rest.bytes()
            .next()
            .is_none_or(|b| !(b.is_ascii_alphanumeric() || b == b'_'))
    })
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::diag::SourceMap;

    /// What a reader is handed: each item printed, or the error's code and place.
    fn read(text: &str, split: Option<Split>) -> Vec<String> {
        let mut map = SourceMap::default();
        let id = map.add("t.adv", text.to_string());
        let src = map.src(id);
        let mut out = Vec::new();
        let mut f = |item: Result<Item, ParseError>| {
            out.push(match item {
                Ok(i) => format!("{i:?}"),
                Err(e) => format!("error: {e:?}"),
            });
            ControlFlow::Continue(())
        };
        match split {
            Some(split) => each_item_split(src, &mut f, split),
            None => feed(super::super::items(src), &mut f),
        }
        out
    }

    /// `got` is `want`, or the first place they differ.
    fn same(got: &[String], want: &[String], what: &str) {
        if let Some(k) = (0..got.len().max(want.len())).find(|&k| got.get(k) != want.get(k)) {
            panic!(
                "{what}: {} items, {} expected; item {k} is\n{:?}\nexpected\n{:?}",
                got.len(),
                want.len(),
                got.get(k),
                want.get(k)
            );
        }
    }

    const FINE: Split = Split {
        from: 0,
        batch: 1,
        workers: 3,
    };

    fn file(n: usize) -> String {
        (0..n)
            .map(|i| match i % 4 {
                0 => format!("/// Op {i}.\n\n// a note\noperator op{i} for positioning on action {{ trans *= 1.01 }}\n"),
                1 => format!("operator op{i}(rate = 0.5 in [0, 1]) for positioning on action where trans != 0 and\n  rot != 0 {{\n  trans *= 1 - rate\n}}\n"),
                2 => format!("operator op{i} for positioning on action = op{} then op{}\n\n", i - 1, i - 2),
                _ => format!("domain d{i} {{\n  act u \"m/s\"\n}}\n"),
            })
            .collect()
    }

    #[test]
    fn cuts_fall_before_items_with_their_docs_and_never_inside_brackets() {
        let text = "operator a for d on action {\noperator b\n}\n\n/// Doc.\n\n// c\noperator c for d on action { u = 0 }\ndomaine\n\n// d\ndomain e {}\n";
        let starts = item_starts(text);
        let at = |s: &str| text.find(s).unwrap();
        // Not at `operator b` (inside `{`), not at `domaine` (a longer name); a doc goes with its
        // item, blank and comment lines with the item before.
        assert_eq!(starts, vec![at("/// Doc."), at("domain e")]);
    }

    #[test]
    fn split_reading_hands_on_what_sequential_reading_does() {
        let text = file(40);
        let one = read(&text, None);
        assert_eq!(one.len(), 40);
        assert!(one.iter().all(|i| !i.starts_with("error")));
        for workers in [2, 3, 4] {
            for batch in [1, 100, 1000] {
                let split = Split {
                    from: 0,
                    batch,
                    workers,
                };
                same(&read(&text, Some(split)), &one, &format!("{split:?}"));
            }
        }
    }

    #[test]
    fn a_mistake_in_any_batch_is_reported_as_sequential_reading_reports_it() {
        let good = file(24);
        let cuts = item_starts(&good);
        for (k, &cut) in cuts.iter().enumerate().step_by(3) {
            // A stray `}` before an item, an unclosed `{` that swallows the rest, a bad token.
            for bad in [
                "}\n",
                "operator x for d on action {\n",
                "operator 3 for d\n",
            ] {
                let text = format!("{}{bad}{}", &good[..cut], &good[cut..]);
                let one = read(&text, None);
                assert!(one.last().unwrap().starts_with("error"), "{k}: {bad}");
                same(&read(&text, Some(FINE)), &one, &format!("cut {k}: {bad:?}"));
            }
        }
        // Nesting too deep is refused first, as before.
        let deep = format!("{}{}", "(".repeat(200), good);
        same(&read(&deep, Some(FINE)), &read(&deep, None), "too deep");
    }

    proptest::proptest! {
        #![proptest_config(proptest::prelude::ProptestConfig::with_cases(200))]

        /// Any text, cut anywhere by any mistake, reads the same split as whole.
        #[test]
        fn split_or_whole_the_same(
            edits in proptest::collection::vec((0usize..2000, 0usize..FRAGMENTS.len()), 0..4),
            batch in 1usize..400,
            workers in 2usize..4,
        ) {
            let mut text = file(16);
            for (at, k) in edits {
                let mut at = at % (text.len() + 1);
                while !text.is_char_boundary(at) {
                    at -= 1;
                }
                text.insert_str(at, FRAGMENTS[k]);
            }
            let split = Split { from: 0, batch, workers };
            same(&read(&text, Some(split)), &read(&text, None), &format!("{split:?} on {text:?}"));
        }
    }

    /// Pieces of text that move an item's boundaries: brackets, keywords, comments, quotes.
    const FRAGMENTS: &[&str] = &[
        "{",
        "}",
        "(",
        ")",
        "[",
        "\n",
        "\noperator ",
        "operator z for d on action { u = 1 }\n",
        "domain q {\n",
        "/// doc\n",
        "// c\n",
        "\"",
        " then ",
        "\n\n",
        "}\n\n",
        "=",
    ];

    #[test]
    fn a_reader_that_stops_stops_the_workers() {
        let text = file(200);
        let mut map = SourceMap::default();
        let id = map.add("t.adv", text);
        let mut seen = 0;
        each_item_split(
            map.src(id),
            |_| {
                seen += 1;
                if seen == 5 {
                    ControlFlow::Break(())
                } else {
                    ControlFlow::Continue(())
                }
            },
            FINE,
        );
        assert_eq!(seen, 5);
    }
}
