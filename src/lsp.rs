//! `advise lsp`: a language server for operator files over stdio.

/// Serve the language server protocol on stdin and stdout until the client exits.
pub fn run_stdio() -> miette::Result<()> {
    Err(miette::miette!("the language server is not built yet"))
}
