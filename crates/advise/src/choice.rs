//! Closed sets of named values a front end offers: the command line's `--policy`, `--revert`,
//! `--critique` and the study's name, Python's `revert=` and `study=`. Each is spelled once,
//! here in the library; the command line turns a [`Choice`] into its argument's possible values
//! and Python into its refusal's list, so both accept and list the same words.

/// A closed set of named values.
pub trait Choice: Sized + Copy + Send + Sync + 'static {
    /// Every value, in the order help lists them.
    fn all() -> &'static [Self];

    /// The word that names it.
    fn name(self) -> &'static str;

    /// One line saying what it is, for help.
    fn help(self) -> &'static str;

    /// The value `word` names.
    fn parse(word: &str) -> Option<Self> {
        Self::all().iter().copied().find(|v| v.name() == word)
    }

    /// Every name, quoted and joined for a refusal's help: "`bc`, `aopi`".
    fn names() -> String {
        Self::all()
            .iter()
            .map(|v| format!("`{}`", v.name()))
            .collect::<Vec<_>>()
            .join(", ")
    }
}
