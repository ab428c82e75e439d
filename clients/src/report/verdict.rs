//! Verdicts computed from a run's numbers: a paper's claim, the criterion
//! that judges it, the figures of this run it was judged on, and the
//! outcome. The pages the experiments write (`docs/papers.md`) print them;
//! nothing in a verdict is typed by hand but the paper's own figures, which
//! the criterion quotes.
//!
//! One verdict is one Markdown line:
//! `- **CLAIM**: **held**. Criterion: CRITERION. Here: FIGURES. NOTE`,
//! the outcome being `held`, `did not hold` or `not judged`
//! ([`Verdict::parse`] reads it back, for the tests).

use std::fmt;

/// Whether a claim held in this run.
#[derive(Clone, Debug, PartialEq, Eq)]
pub enum Outcome {
    /// The criterion is true of this run's figures.
    Held,
    /// It is false.
    NotHeld,
    /// The figures it needs were not measured (the reason).
    NotJudged(String),
}

impl Outcome {
    fn word(&self) -> &'static str {
        match self {
            Self::Held => "held",
            Self::NotHeld => "did not hold",
            Self::NotJudged(_) => "not judged",
        }
    }
}

/// A claim judged by a stated criterion on this run's figures.
#[derive(Clone, Debug, PartialEq, Eq)]
pub struct Verdict {
    /// The claim, as the paper makes it (with its figures).
    pub claim: String,
    /// What must be true of this run's figures for the claim to hold.
    pub criterion: String,
    /// The figures it was judged on, as measured.
    pub figures: String,
    /// The outcome.
    pub outcome: Outcome,
    /// Why, where the outcome needs a reason (may be empty).
    pub note: String,
}

impl Verdict {
    /// `claim` judged by `criterion`: `held` is the criterion evaluated on
    /// `figures`.
    pub fn judge(
        claim: impl Into<String>,
        criterion: impl Into<String>,
        held: bool,
        figures: impl Into<String>,
    ) -> Self {
        Self {
            claim: claim.into(),
            criterion: criterion.into(),
            figures: figures.into(),
            outcome: if held { Outcome::Held } else { Outcome::NotHeld },
            note: String::new(),
        }
    }

    /// A claim this run could not judge, and why.
    pub fn not_judged(claim: impl Into<String>, criterion: impl Into<String>, why: impl Into<String>) -> Self {
        Self {
            claim: claim.into(),
            criterion: criterion.into(),
            figures: String::new(),
            outcome: Outcome::NotJudged(why.into()),
            note: String::new(),
        }
    }

    /// The verdict with a note: `held` when it held, else `not_held`.
    pub fn because(mut self, held: &str, not_held: &str) -> Self {
        self.note = match self.outcome {
            Outcome::Held => held,
            _ => not_held,
        }
        .to_string();
        self
    }

    /// True when the criterion was evaluated.
    pub fn judged(&self) -> bool {
        !matches!(self.outcome, Outcome::NotJudged(_))
    }

    /// Reads back a line [`Display`](fmt::Display) wrote: the claim and
    /// the outcome's word, or `None` for any other line.
    pub fn parse(line: &str) -> Option<(String, String)> {
        let rest = line.strip_prefix("- **")?;
        let (claim, rest) = rest.split_once("**: **")?;
        let (word, rest) = rest.split_once("**. ")?;
        let known = ["held", "did not hold", "not judged"].contains(&word);
        (known && rest.starts_with("Criterion: ") && rest.contains(". Here: "))
            .then(|| (claim.to_string(), word.to_string()))
    }
}

impl fmt::Display for Verdict {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        let figures = match &self.outcome {
            Outcome::NotJudged(why) => why.as_str(),
            _ => self.figures.as_str(),
        };
        write!(
            f,
            "- **{}**: **{}**. Criterion: {}. Here: {}.",
            self.claim,
            self.outcome.word(),
            self.criterion.trim_end_matches('.'),
            figures.trim_end_matches('.')
        )?;
        if !self.note.is_empty() {
            write!(f, " {}", self.note)?;
        }
        Ok(())
    }
}

/// Prints `verdicts` under a heading, one line each.
pub fn print(heading: &str, verdicts: &[Verdict]) {
    println!("**{heading}**\n");
    for v in verdicts {
        println!("{v}");
    }
    println!();
}

/// `lo-hi` of `values` with `digits` decimals (one value alone when they agree).
pub fn range(values: impl IntoIterator<Item = f64>, digits: usize) -> String {
    let (lo, hi) = values
        .into_iter()
        .fold((f64::INFINITY, f64::NEG_INFINITY), |(lo, hi), v| (lo.min(v), hi.max(v)));
    if !lo.is_finite() {
        return "none".to_string();
    }
    let (a, b) = (format!("{lo:.digits$}"), format!("{hi:.digits$}"));
    if a == b {
        a
    } else if lo < 0.0 || hi < 0.0 {
        // "-0.29-8.24" would read as a range of negatives.
        format!("{a} to {b}")
    } else {
        format!("{a}-{b}")
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn a_verdict_line_reads_back() {
        let v = Verdict::judge("A claim (Table 1)", "x at most 2", false, "x = 3.00").because("fine", "too large");
        let line = v.to_string();
        assert_eq!(
            line,
            "- **A claim (Table 1)**: **did not hold**. Criterion: x at most 2. Here: x = 3.00. too large"
        );
        assert_eq!(
            Verdict::parse(&line),
            Some(("A claim (Table 1)".into(), "did not hold".into()))
        );
        let n = Verdict::not_judged("B", "y", "no data");
        assert!(!n.judged());
        assert_eq!(Verdict::parse(&n.to_string()).map(|p| p.1), Some("not judged".into()));
        assert_eq!(Verdict::parse("- **plain bullet** text"), None);
    }

    #[test]
    fn ranges_collapse_when_equal() {
        assert_eq!(range([0.5, 0.25, 0.75], 2), "0.25-0.75");
        assert_eq!(range([1.0, 1.001], 1), "1.0");
        assert_eq!(range([], 1), "none");
        assert_eq!(range([-0.29, 8.24], 2), "-0.29 to 8.24");
    }
}
