//! Arbitrary bytes as the language server's input, through its framing reader
//! (`advise_lsp::frame`): every frame is a message, a coded body error (whose JSON-RPC answer is
//! built) or the end; nothing may panic, and no `Content-Length` may make it allocate more than
//! the input holds. `cargo +nightly fuzz run lsp_frame -- -rss_limit_mb=512`.
#![no_main]

use advise_lsp::frame::{Frame, FrameReader};
use libfuzzer_sys::fuzz_target;

fuzz_target!(|data: &[u8]| {
    let mut frames = FrameReader::new(data);
    // Each frame takes at least one byte of the input, so this ends.
    while let Ok(Some(frame)) = frames.next_frame() {
        if let Frame::Bad(e) = frame {
            let _ = e.response().to_string();
        }
    }
});
