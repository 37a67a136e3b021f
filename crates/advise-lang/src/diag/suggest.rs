//! "Did you mean": the one place that decides which known name a mistyped one was meant to be.
//! A name is suggested when its Jaro-Winkler similarity exceeds 0.8; of several, the most similar
//! (the last of equals). Errors carry the candidate names and call these when they are built.

/// The candidate closest to `name`, if it is close enough to be what was meant.
pub fn closest<'a>(name: &str, candidates: impl IntoIterator<Item = &'a str>) -> Option<&'a str> {
    candidates
        .into_iter()
        .map(|c| (strsim::jaro_winkler(name, c), c))
        .filter(|(score, _)| *score > 0.8)
        .max_by(|a, b| a.0.total_cmp(&b.0))
        .map(|(_, c)| c)
}

/// [`closest`] for short names (a backend's `sim`, `rmp`): Jaro-Winkler's match window is empty
/// for three letters, so a swap of neighbours (`smi`) finds nothing there; a candidate one edit
/// away (a swap counts as one) is then what was meant.
pub fn closest_short<'a>(
    name: &str,
    candidates: impl IntoIterator<Item = &'a str>,
) -> Option<&'a str> {
    let candidates: Vec<&'a str> = candidates.into_iter().collect();
    closest(name, candidates.iter().copied()).or_else(|| {
        candidates
            .iter()
            .copied()
            .map(|c| (strsim::osa_distance(name, c), c))
            .filter(|(d, _)| *d <= 1)
            .min_by_key(|(d, _)| *d)
            .map(|(_, c)| c)
    })
}

/// The help text "did you mean `k`?" for the closest candidate, if any is close enough.
pub fn did_you_mean<S: AsRef<str>>(
    name: &str,
    candidates: impl IntoIterator<Item = S>,
) -> Option<String> {
    let candidates: Vec<S> = candidates.into_iter().collect();
    closest(name, candidates.iter().map(AsRef::as_ref)).map(|k| format!("did you mean `{k}`?"))
}

/// "did you mean `k`?", or else the list of the `what` that exist (`there are no {what}` when
/// none do).
pub fn hint(name: &str, what: &str, candidates: &[&str]) -> String {
    match closest(name, candidates.iter().copied()) {
        Some(s) => format!("did you mean `{s}`?"),
        None if candidates.is_empty() => format!("there are no {what}"),
        None => format!("the {what} are: {}", listing(candidates)),
    }
}

/// Names for a help text: all of a few, or the first twenty and how many more.
pub fn listing(names: &[&str]) -> String {
    const SHOWN: usize = 20;
    let mut out = names
        .iter()
        .take(SHOWN)
        .map(|n| format!("`{n}`"))
        .collect::<Vec<_>>()
        .join(", ");
    if names.len() > SHOWN {
        out.push_str(&format!(" and {} more", names.len() - SHOWN));
    }
    out
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn close_names_are_suggested_and_far_ones_listed() {
        let known = ["speed_up", "slow_down", "turn_left"];
        assert_eq!(closest("sped_up", known), Some("speed_up"));
        assert_eq!(did_you_mean("xyz", known), None);
        assert_eq!(
            hint("turn_lfet", "operators", &known),
            "did you mean `turn_left`?"
        );
        assert_eq!(
            hint("xyz", "operators", &known),
            "the operators are: `speed_up`, `slow_down`, `turn_left`"
        );
        assert_eq!(hint("xyz", "operators", &[]), "there are no operators");
        assert_eq!(closest("smi", ["sim", "rmp"]), None);
        assert_eq!(closest_short("smi", ["sim", "rmp"]), Some("sim"));
        assert_eq!(closest_short("xyz", ["sim", "rmp"]), None);
    }
}
