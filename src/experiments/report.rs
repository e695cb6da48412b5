//! Physics checks and the Markdown report of an experiment.

use std::fmt::Write;

/// One physics check: what was measured, what was expected, with which tolerance, and whether it
/// passed.
#[derive(Debug, Clone, PartialEq)]
pub struct Check {
    /// What is checked.
    pub name: String,
    /// Measured value (in `unit`).
    pub measured: f64,
    /// Expected value or bound, as text (e.g. `"0"`, `"≤ 5"`, `"m·a = 12.3"`).
    pub expected: String,
    /// Tolerance as text (e.g. `"5 %"`).
    pub tolerance: String,
    /// Unit of `measured`.
    pub unit: String,
    /// Outcome.
    pub passed: bool,
    /// `Some(why)`: no estimator can score this figure from the case's data; it is reported
    /// with the reason and is no check (neither passed nor failed).
    pub not_observable: Option<String>,
}

impl Check {
    /// `measured` within `rel_tol` (fraction) of `expected`.
    pub fn relative(name: &str, measured: f64, expected: f64, rel_tol: f64, unit: &str) -> Self {
        let passed = (measured - expected).abs() <= rel_tol * expected.abs();
        Self {
            name: name.into(),
            measured,
            expected: sig(expected),
            tolerance: format!("{} %", sig(rel_tol * 100.0)),
            unit: unit.into(),
            passed,
            not_observable: None,
        }
    }

    /// `measured ≤ bound`.
    pub fn at_most(name: &str, measured: f64, bound: f64, unit: &str) -> Self {
        Self {
            name: name.into(),
            measured,
            expected: format!("≤ {}", sig(bound)),
            tolerance: "bound".into(),
            unit: unit.into(),
            passed: measured <= bound,
            not_observable: None,
        }
    }

    /// `measured ≥ bound`.
    pub fn at_least(name: &str, measured: f64, bound: f64, unit: &str) -> Self {
        Self {
            name: name.into(),
            measured,
            expected: format!("≥ {}", sig(bound)),
            tolerance: "bound".into(),
            unit: unit.into(),
            passed: measured >= bound,
            not_observable: None,
        }
    }

    /// This figure cannot be scored by any estimator from the case's data, for `reason`: it is
    /// reported (with `measured`, the value anyway) and is no check.
    pub fn not_observable(mut self, reason: &str) -> Self {
        self.not_observable = Some(reason.into());
        self.passed = false;
        self
    }
}

/// Four significant digits, without trailing noise.
pub fn sig(x: f64) -> String {
    if x == 0.0 || !x.is_finite() {
        return format!("{x}");
    }
    let digits = (3 - x.abs().log10().floor() as i32).clamp(0, 12) as usize;
    format!("{x:.digits$}")
}

/// A section of a report: text, a table of numbers and checks.
#[derive(Debug, Clone, Default)]
pub struct Section {
    /// Heading.
    pub heading: String,
    /// Free text (Markdown).
    pub text: String,
    /// Tables of numbers: header and rows each.
    pub tables: Vec<(Vec<String>, Vec<Vec<String>>)>,
    /// Checks (and figures that no estimator can score: [`Check::not_observable`]).
    pub checks: Vec<Check>,
}

/// An experiment's report.
#[derive(Debug, Clone, Default)]
pub struct Report {
    /// Title.
    pub title: String,
    /// Introduction (Markdown): what the experiment does, parameters, contact settings.
    pub intro: String,
    /// Sections.
    pub sections: Vec<Section>,
}

impl Report {
    /// Every check of every section (not the figures that no estimator can score).
    pub fn checks(&self) -> impl Iterator<Item = &Check> {
        self.sections.iter().flat_map(|s| s.checks.iter()).filter(|c| c.not_observable.is_none())
    }

    /// Every figure of every section that no estimator can score ([`Check::not_observable`]).
    pub fn not_observable(&self) -> impl Iterator<Item = &Check> {
        self.sections.iter().flat_map(|s| s.checks.iter()).filter(|c| c.not_observable.is_some())
    }

    /// Whether every check passed.
    pub fn all_passed(&self) -> bool {
        self.checks().all(|c| c.passed)
    }

    /// The report as Markdown.
    pub fn to_markdown(&self) -> String {
        let mut out = String::new();
        let passed = self.checks().filter(|c| c.passed).count();
        let total = self.checks().count();
        let _ = writeln!(out, "# {}\n\n{}\n\n**{passed} of {total} checks passed.**\n", self.title, self.intro.trim());
        for s in &self.sections {
            let _ = writeln!(out, "## {}\n", s.heading);
            if !s.text.trim().is_empty() {
                let _ = writeln!(out, "{}\n", s.text.trim());
            }
            for (header, rows) in &s.tables {
                let _ = writeln!(out, "| {} |", header.join(" | "));
                let _ = writeln!(out, "|{}|", vec!["---"; header.len()].join("|"));
                for r in rows {
                    let _ = writeln!(out, "| {} |", r.join(" | "));
                }
                out.push('\n');
            }
            if s.checks.iter().any(|c| c.not_observable.is_none()) {
                out.push_str("| check | measured | expected | tolerance | result |\n|---|---|---|---|---|\n");
                for c in s.checks.iter().filter(|c| c.not_observable.is_none()) {
                    let _ = writeln!(
                        out,
                        "| {} | {} {} | {} {} | {} | {} |",
                        c.name,
                        sig(c.measured),
                        c.unit,
                        c.expected,
                        c.unit,
                        c.tolerance,
                        if c.passed { "pass" } else { "**FAIL**" }
                    );
                }
                out.push('\n');
            }
            if s.checks.iter().any(|c| c.not_observable.is_some()) {
                out.push_str(
                    "Not observable (no estimator can score these from the case's data; not checks):\n\n\
                     | figure | measured | target | why |\n|---|---|---|---|\n",
                );
                for c in &s.checks {
                    if let Some(why) = &c.not_observable {
                        let _ = writeln!(
                            out,
                            "| {} | {} {} | {} {} | {why} |",
                            c.name,
                            sig(c.measured),
                            c.unit,
                            c.expected,
                            c.unit
                        );
                    }
                }
                out.push('\n');
            }
        }
        out
    }
}
