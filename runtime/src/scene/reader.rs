//! A path-tracking reader over a parsed TOML table: typed getters that record every
//! problem (with the field path and the allowed range) instead of stopping at the first,
//! and a final check that reports fields nobody asked for.

use crate::error::FieldError;
use nalgebra::Vector3;
use std::cell::RefCell;
use std::fmt;
use std::rc::Rc;
use toml::{Table, Value};

/// The problems found so far, shared by every node of one document.
pub(super) type Errors = Rc<RefCell<Vec<FieldError>>>;

/// One end of a [`Range`].
#[derive(Debug, Clone, Copy, PartialEq)]
pub(super) enum Bound {
    /// No limit.
    Open,
    /// The limit is allowed.
    Incl(f64),
    /// The limit is excluded.
    Excl(f64),
}

/// The largest distance from the origin of any position a scene gives (roots, body
/// placements, keyframes, motion centres and amplitudes), m: far beyond any hair or rod
/// scene, and small enough that what a run computes from it stays finite in the
/// float32 outputs.
pub const MAX_EXTENT: f64 = 1e4;
/// The largest time a scene gives (keyframes, motion starts and durations), s.
pub const MAX_TIME: f64 = 1e6;
/// The largest magnitude of any entry of a 3-vector of a scene (directions, curvatures),
/// unless its field says less.
pub const MAX_VECTOR_ENTRY: f64 = 1e6;

/// The allowed values of a number (always finite).
#[derive(Debug, Clone, Copy, PartialEq)]
pub(super) struct Range {
    lo: Bound,
    hi: Bound,
}

impl Range {
    /// Any finite number.
    pub const ANY: Range = Range {
        lo: Bound::Open,
        hi: Bound::Open,
    };
    /// `> 0`.
    #[cfg(test)]
    pub const POSITIVE: Range = Range {
        lo: Bound::Excl(0.0),
        hi: Bound::Open,
    };
    /// `>= 0`.
    pub const NON_NEGATIVE: Range = Range {
        lo: Bound::Incl(0.0),
        hi: Bound::Open,
    };

    /// A coordinate of a position, m: within [`MAX_EXTENT`] of the origin.
    pub const POSITION: Range = Range {
        lo: Bound::Incl(-MAX_EXTENT),
        hi: Bound::Incl(MAX_EXTENT),
    };
    /// A time, s: within [`MAX_TIME`] of 0.
    pub const TIME: Range = Range {
        lo: Bound::Incl(-MAX_TIME),
        hi: Bound::Incl(MAX_TIME),
    };
    /// A time from the start, s.
    pub const TIME_FROM_START: Range = Range {
        lo: Bound::Incl(0.0),
        hi: Bound::Incl(MAX_TIME),
    };
    /// A duration, s.
    pub const DURATION: Range = Range {
        lo: Bound::Excl(0.0),
        hi: Bound::Incl(MAX_TIME),
    };
    /// An air drag coefficient, N·s/m² (a hair's is about 10⁻⁵).
    pub const AIR_DRAG: Range = Range {
        lo: Bound::Incl(0.0),
        hi: Bound::Incl(100.0),
    };
    /// A length, m.
    pub const LENGTH: Range = Range {
        lo: Bound::Incl(0.0),
        hi: Bound::Incl(MAX_EXTENT),
    };

    /// Between `lo` and `hi` with the given bounds.
    pub const fn new(lo: Bound, hi: Bound) -> Self {
        Range { lo, hi }
    }

    /// Whether `x` is allowed.
    pub fn contains(&self, x: f64) -> bool {
        let above = match self.lo {
            Bound::Open => true,
            Bound::Incl(a) => x >= a,
            Bound::Excl(a) => x > a,
        };
        let below = match self.hi {
            Bound::Open => true,
            Bound::Incl(b) => x <= b,
            Bound::Excl(b) => x < b,
        };
        x.is_finite() && above && below
    }
}

impl Bound {
    /// The limit and whether it is allowed (`None` for no limit).
    fn limit(self) -> Option<(f64, bool)> {
        match self {
            Bound::Open => None,
            Bound::Incl(x) => Some((x, true)),
            Bound::Excl(x) => Some((x, false)),
        }
    }
}

impl fmt::Display for Range {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        match (self.lo.limit(), self.hi.limit()) {
            (None, None) => write!(f, "must be finite"),
            (Some((a, incl)), None) => write!(
                f,
                "must be {} {a} and finite",
                if incl { ">=" } else { ">" }
            ),
            (None, Some((b, incl))) => write!(f, "must be {} {b}", if incl { "<=" } else { "<" }),
            (Some((a, lo_incl)), Some((b, hi_incl))) => {
                let open = if lo_incl { '[' } else { '(' };
                let close = if hi_incl { ']' } else { ')' };
                write!(f, "must be in {open}{a}, {b}{close}")
            }
        }
    }
}

/// What kind of TOML value `v` is, for messages.
pub(super) fn kind(v: &Value) -> &'static str {
    match v {
        Value::String(_) => "a string",
        Value::Integer(_) => "an integer",
        Value::Float(_) => "a float",
        Value::Boolean(_) => "a boolean",
        Value::Datetime(_) => "a date-time",
        Value::Array(_) => "an array",
        Value::Table(_) => "a table",
    }
}

/// A number from an integer or a float value.
fn number(v: &Value) -> Option<f64> {
    match v {
        Value::Float(x) => Some(*x),
        Value::Integer(i) => Some(*i as f64),
        _ => None,
    }
}

/// A table of the document and its path; remembers which keys were asked for.
pub(super) struct Node<'a> {
    path: String,
    table: &'a Table,
    known: Vec<&'static str>,
    errors: Errors,
}

impl<'a> Node<'a> {
    /// The document's top-level table.
    pub fn root(table: &'a Table, errors: Errors) -> Self {
        Self {
            path: String::new(),
            table,
            known: Vec::new(),
            errors,
        }
    }

    fn child(&self, path: String, table: &'a Table) -> Node<'a> {
        Node {
            path,
            table,
            known: Vec::new(),
            errors: Rc::clone(&self.errors),
        }
    }

    /// Path of a field of this table (`strands[2].length`).
    pub fn path(&self, key: &str) -> String {
        if self.path.is_empty() {
            key.to_string()
        } else {
            format!("{}.{key}", self.path)
        }
    }

    /// Path of this table itself.
    pub fn own_path(&self) -> &str {
        &self.path
    }

    /// Record a problem with field `key` (or with a path built from it, e.g. `keys[2].t`).
    pub fn error(&self, key: &str, message: impl Into<String>) {
        self.errors
            .borrow_mut()
            .push(FieldError::new(self.path(key), message));
    }

    /// Whether field `key` is present (it counts as a known field from now on).
    pub fn has(&mut self, key: &'static str) -> bool {
        self.raw(key).is_some()
    }

    /// The raw value of `key`; marks `key` as a known field.
    pub fn raw(&mut self, key: &'static str) -> Option<&'a Value> {
        if !self.known.contains(&key) {
            self.known.push(key);
        }
        self.table.get(key)
    }

    /// Record that the required field `key` is missing, and return `None`.
    pub fn missing<T>(&self, key: &str, what: &str) -> Option<T> {
        self.error(key, format!("required: {what}"));
        None
    }

    /// `get(self, key)` when `key` is present; otherwise a "required" error (`what` says
    /// what is expected) and `None`.
    pub fn required<T>(
        &mut self,
        key: &'static str,
        what: &str,
        get: impl FnOnce(&mut Self, &'static str) -> Option<T>,
    ) -> Option<T> {
        if self.has(key) {
            get(self, key)
        } else {
            self.missing(key, what)
        }
    }

    /// A required number in `range`; `what` describes it (with its unit).
    pub fn required_f64(&mut self, key: &'static str, what: &str, range: Range) -> Option<f64> {
        self.required(key, &format!("{what}; {range}"), |n, k| n.f64(k, range))
    }

    /// An optional number in `range`, `default` when absent.
    pub fn optional_f64(&mut self, key: &'static str, default: f64, range: Range) -> Option<f64> {
        self.optional(key, default, |n, k| n.f64(k, range))
    }

    /// `get(self, key)` when `key` is present, `Some(default)` otherwise.
    pub fn optional<T>(
        &mut self,
        key: &'static str,
        default: T,
        get: impl FnOnce(&mut Self, &'static str) -> Option<T>,
    ) -> Option<T> {
        if self.has(key) {
            get(self, key)
        } else {
            Some(default)
        }
    }

    fn wrong_type<T>(&self, key: &str, expected: &str, got: &Value) -> Option<T> {
        self.error(key, format!("expected {expected}, got {}", kind(got)));
        None
    }

    /// A number in `range`.
    pub fn f64(&mut self, key: &'static str, range: Range) -> Option<f64> {
        let v = self.raw(key)?;
        let Some(x) = number(v) else {
            return self.wrong_type(key, "a number", v);
        };
        self.check(key, x, range)
    }

    /// `x` when within `range`, else a problem of `key` naming the range and `x`.
    pub(super) fn check(&self, key: &str, x: f64, range: Range) -> Option<f64> {
        if range.contains(x) {
            Some(x)
        } else {
            // large and tiny values in exponent form (1e300, not 300 digits)
            let got = if x != 0.0 && !(1e-6..1e9).contains(&x.abs()) {
                format!("{x:e}")
            } else {
                format!("{x}")
            };
            if x.is_finite() {
                self.error(key, format!("{range}, got {got}"));
            } else {
                self.error(key, format!("must be finite; {range}, got {got}"));
            }
            None
        }
    }

    /// An integer in `[min, max]`; `cap` explains the upper limit.
    pub fn count(&mut self, key: &'static str, min: i64, max: i64, cap: &str) -> Option<usize> {
        let v = self.raw(key)?;
        let Value::Integer(i) = v else {
            return self.wrong_type(key, "an integer", v);
        };
        self.check_count(key, *i, min, max, cap)
    }

    fn check_count(&self, key: &str, i: i64, min: i64, max: i64, cap: &str) -> Option<usize> {
        if i < min {
            self.error(key, format!("must be an integer >= {min}, got {i}"));
            None
        } else if i > max {
            self.error(key, format!("must be an integer <= {max} ({cap}), got {i}"));
            None
        } else {
            usize::try_from(i).ok()
        }
    }

    /// A non-negative integer (a seed).
    pub fn seed(&mut self, key: &'static str) -> Option<u64> {
        let v = self.raw(key)?;
        let Value::Integer(i) = v else {
            return self.wrong_type(key, "an integer", v);
        };
        u64::try_from(*i).ok().or_else(|| {
            self.error(key, format!("must be an integer >= 0, got {i}"));
            None
        })
    }

    /// A string.
    pub fn string(&mut self, key: &'static str) -> Option<&'a str> {
        let v = self.raw(key)?;
        match v {
            Value::String(s) => Some(s),
            _ => self.wrong_type(key, "a string", v),
        }
    }

    /// One of the names in `allowed`, turned into a value by `parse`.
    pub fn choice<T>(
        &mut self,
        key: &'static str,
        allowed: &[&str],
        parse: impl Fn(&str) -> Option<T>,
    ) -> Option<T> {
        let name = self.string(key)?;
        parse(name).or_else(|| {
            self.error(
                key,
                format!("unknown value '{name}'; allowed: {}", allowed.join(", ")),
            );
            None
        })
    }

    /// A list of numbers, each in `range`; an error names the element (`key[3]`).
    pub fn f64_list(&mut self, key: &'static str, range: Range) -> Option<Vec<f64>> {
        let v = self.raw(key)?;
        let Value::Array(items) = v else {
            return self.wrong_type(key, "an array of numbers", v);
        };
        let mut out = Vec::with_capacity(items.len());
        let mut ok = true;
        for (i, item) in items.iter().enumerate() {
            let at = format!("{key}[{i}]");
            match number(item) {
                Some(x) => match self.check(&at, x, range) {
                    Some(x) => out.push(x),
                    None => ok = false,
                },
                None => {
                    ok = false;
                    self.wrong_type::<()>(&at, "a number", item);
                }
            }
        }
        ok.then_some(out)
    }

    /// A list of exactly `len` integers, each in `[min, max]`.
    pub fn count_list(
        &mut self,
        key: &'static str,
        len: usize,
        (min, max, cap): (i64, i64, &str),
    ) -> Option<Vec<usize>> {
        let v = self.raw(key)?;
        let items = match v {
            Value::Array(items) if items.len() == len => items,
            _ => return self.wrong_type(key, &format!("an array of {len} integers"), v),
        };
        let mut out = Vec::with_capacity(len);
        for (i, item) in items.iter().enumerate() {
            let at = format!("{key}[{i}]");
            match item {
                Value::Integer(x) => out.push(self.check_count(&at, *x, min, max, cap)),
                _ => out.push(self.wrong_type(&at, "an integer", item)),
            }
        }
        out.into_iter().collect()
    }

    /// A list of exactly `len` finite numbers.
    pub fn fixed_list(&mut self, key: &'static str, len: usize, range: Range) -> Option<Vec<f64>> {
        let list = self.f64_list(key, range)?;
        if list.len() == len {
            Some(list)
        } else {
            self.error(
                key,
                format!("must have exactly {len} values, got {}", list.len()),
            );
            None
        }
    }

    /// A 3-vector of numbers within ±[`MAX_VECTOR_ENTRY`].
    pub fn vec3(&mut self, key: &'static str) -> Option<Vector3<f64>> {
        self.vec3_in(
            key,
            Range::new(
                Bound::Incl(-MAX_VECTOR_ENTRY),
                Bound::Incl(MAX_VECTOR_ENTRY),
            ),
        )
    }

    /// A position, m: 3 numbers within ±[`MAX_EXTENT`].
    pub fn position(&mut self, key: &'static str) -> Option<Vector3<f64>> {
        self.vec3_in(key, Range::POSITION)
    }

    /// A 3-vector of numbers in `range`.
    pub fn vec3_in(&mut self, key: &'static str, range: Range) -> Option<Vector3<f64>> {
        self.fixed_list(key, 3, range)
            .map(|v| Vector3::new(v[0], v[1], v[2]))
    }

    /// A non-zero 3-vector, normalised.
    pub fn unit(&mut self, key: &'static str) -> Option<Vector3<f64>> {
        let v = self.vec3(key)?;
        let norm = v.norm();
        if norm > 0.0 && norm.is_finite() {
            Some(v / norm)
        } else {
            self.error(key, "must be a non-zero vector");
            None
        }
    }

    /// A sub-table (`None` when absent or not a table; the latter is an error).
    pub fn table(&mut self, key: &'static str) -> Option<Node<'a>> {
        let v = self.raw(key)?;
        match v {
            Value::Table(t) => Some(self.child(self.path(key), t)),
            _ => self.wrong_type(key, "a table", v),
        }
    }

    /// An array of tables (`[[key]]` or a list of inline tables); empty when absent.
    pub fn tables(&mut self, key: &'static str) -> Vec<Node<'a>> {
        let Some(v) = self.raw(key) else {
            return Vec::new();
        };
        let Value::Array(items) = v else {
            self.wrong_type::<()>(key, "an array of tables", v);
            return Vec::new();
        };
        let mut out = Vec::with_capacity(items.len());
        for (i, item) in items.iter().enumerate() {
            let path = format!("{}[{i}]", self.path(key));
            match item {
                Value::Table(t) => out.push(self.child(path, t)),
                _ => {
                    self.wrong_type::<()>(&format!("{key}[{i}]"), "a table", item);
                }
            }
        }
        out
    }

    fn unknown_field_message(&self, key: &str) -> String {
        if self.known.is_empty() {
            return "unknown field; this table takes no fields".to_string();
        }
        let suggestion = self
            .known
            .iter()
            .map(|k| (edit_distance(key, k), k))
            .filter(|(d, _)| *d <= 2)
            .min()
            .map(|(_, k)| format!(" (did you mean '{k}'?)"))
            .unwrap_or_default();
        format!(
            "unknown field{suggestion}; allowed fields here: {}",
            self.known.join(", ")
        )
    }

    /// Report every field of this table that was never asked for.
    pub fn finish(mut self) {
        self.known.sort_unstable();
        for key in self.table.keys() {
            if !self.known.contains(&key.as_str()) {
                self.error(key, self.unknown_field_message(key));
            }
        }
    }
}

/// Levenshtein distance between two short strings.
fn edit_distance(a: &str, b: &str) -> usize {
    let b: Vec<char> = b.chars().collect();
    let mut row: Vec<usize> = (0..=b.len()).collect();
    for (i, ca) in a.chars().enumerate() {
        let mut diagonal = row[0];
        row[0] = i + 1;
        for (j, &cb) in b.iter().enumerate() {
            let substitution = diagonal + usize::from(ca != cb);
            diagonal = row[j + 1];
            row[j + 1] = substitution.min(row[j] + 1).min(diagonal + 1);
        }
    }
    row[b.len()]
}

/// An optional boolean.
pub(super) fn boolean(n: &mut Node<'_>, key: &'static str, default: bool) -> Option<bool> {
    match n.raw(key) {
        None => Some(default),
        Some(Value::Boolean(b)) => Some(*b),
        Some(other) => {
            n.error(key, format!("expected true or false, got {}", kind(other)));
            None
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn edit_distances() {
        assert_eq!(edit_distance("lenght", "length"), 2);
        assert_eq!(edit_distance("radius", "radius"), 0);
        assert_eq!(edit_distance("", "abc"), 3);
        assert_eq!(edit_distance("dtt", "dt"), 1);
    }

    #[test]
    fn ranges_describe_themselves() {
        assert_eq!(Range::POSITIVE.to_string(), "must be > 0 and finite");
        assert_eq!(
            Range::new(Bound::Incl(0.0), Bound::Excl(0.5)).to_string(),
            "must be in [0, 0.5)"
        );
        assert!(!Range::ANY.contains(f64::NAN));
        assert!(!Range::NON_NEGATIVE.contains(f64::INFINITY));
    }
}
