//! Hair curves from a USD stage in text form (`.usda`): the `BasisCurves` prims, each
//! with `curveVertexCounts` (points per curve) and `points` (every curve's points, one
//! curve after another), in file order, nested prims included. A small reader of the
//! text format, enough for these two attributes:
//!
//! - `points` is the attribute's default value when the stage has one, else its earliest
//!   time sample (`points.timeSamples = { 0: [...], ... }`, as `superhelix run` writes
//!   `hair.usda`); the other samples are ignored;
//! - curves of `type = "linear"` and cubic ones of `basis = "catmullRom"` (which pass
//!   through their points) are read; `bezier` and `bspline` curves, whose points are
//!   control points off the curve, are refused;
//! - transforms of the prims (`xformOp`s) and the stage's `metersPerUnit` are not
//!   applied: the points are taken in the stage's units as written (a groom's `scale`,
//!   `rotation_axis_angle_deg` and `translation` place them);
//! - every other prim, attribute and metadata is skipped; comments (`#`), strings
//!   (single, double and triple quotes) and asset paths (`@…@`) are understood so that
//!   their contents are not mistaken for structure.
//!
//! Errors name the file and the line.

use super::curves::Curve;
use nalgebra::Vector3;
use std::path::Path;

/// A token of the text and its line.
#[derive(Debug, Clone, PartialEq)]
enum Token {
    /// One of `( ) [ ] { } = ,`.
    Punct(char),
    /// A quoted string or an asset path (contents unused).
    Str(String),
    /// Anything else: a name, a type, a number, `0:`.
    Word(String),
}

/// The tokens of `text` with their lines.
fn tokenize(text: &str, name: &str) -> Result<Vec<(Token, usize)>, String> {
    let chars: Vec<char> = text.chars().collect();
    let mut out = Vec::new();
    let mut line = 1;
    let mut i = 0;
    while i < chars.len() {
        let c = chars[i];
        match c {
            '\n' => {
                line += 1;
                i += 1;
            }
            c if c.is_whitespace() => i += 1,
            '#' => {
                while i < chars.len() && chars[i] != '\n' {
                    i += 1;
                }
            }
            '(' | ')' | '[' | ']' | '{' | '}' | '=' | ',' => {
                out.push((Token::Punct(c), line));
                i += 1;
            }
            '"' | '\'' | '@' => {
                let start_line = line;
                let triple = i + 2 < chars.len() && chars[i + 1] == c && chars[i + 2] == c;
                let delimiter = if triple { 3 } else { 1 };
                i += delimiter;
                let mut value = String::new();
                loop {
                    if i >= chars.len() {
                        return Err(format!(
                            "'{name}' line {start_line}: a string or asset path is not closed"
                        ));
                    }
                    let closes = (0..delimiter).all(|k| chars.get(i + k) == Some(&c));
                    if closes {
                        i += delimiter;
                        break;
                    }
                    if chars[i] == '\\' && c != '@' && i + 1 < chars.len() {
                        value.push(chars[i + 1]);
                        i += 2;
                        continue;
                    }
                    if chars[i] == '\n' {
                        if !triple {
                            return Err(format!(
                                "'{name}' line {start_line}: a string is not closed on its line"
                            ));
                        }
                        line += 1;
                    }
                    value.push(chars[i]);
                    i += 1;
                }
                out.push((Token::Str(value), start_line));
            }
            _ => {
                let start = i;
                while i < chars.len()
                    && !chars[i].is_whitespace()
                    && !"()[]{}=,\"'@#".contains(chars[i])
                {
                    i += 1;
                }
                out.push((Token::Word(chars[start..i].iter().collect()), line));
            }
        }
    }
    Ok(out)
}

/// A time sample of `points`: time code, points, line.
type Sample = (f64, Vec<Vector3<f64>>, usize);

/// One `BasisCurves` prim as read.
#[derive(Debug, Default)]
struct CurvesPrim {
    /// Line of its `def`.
    line: usize,
    /// Its name.
    name: String,
    counts: Option<(Vec<usize>, usize)>,
    points: Option<(Vec<Vector3<f64>>, usize)>,
    /// The earliest time sample of `points`.
    sampled: Option<Sample>,
    kind: Option<(String, usize)>,
    basis: Option<(String, usize)>,
}

/// A cursor over the tokens.
struct Parser<'a> {
    tokens: &'a [(Token, usize)],
    pos: usize,
    name: &'a str,
}

impl Parser<'_> {
    fn peek(&self) -> Option<&Token> {
        self.tokens.get(self.pos).map(|(t, _)| t)
    }

    fn line(&self) -> usize {
        self.tokens
            .get(self.pos)
            .or(self.tokens.last())
            .map_or(1, |(_, l)| *l)
    }

    fn error(&self, message: impl std::fmt::Display) -> String {
        format!("'{}' line {}: {message}", self.name, self.line())
    }

    fn next(&mut self) -> Option<Token> {
        let t = self.tokens.get(self.pos).map(|(t, _)| t.clone());
        self.pos += 1;
        t
    }

    fn expect(&mut self, c: char) -> Result<(), String> {
        match self.peek() {
            Some(Token::Punct(p)) if *p == c => {
                self.pos += 1;
                Ok(())
            }
            _ => Err(self.error(format!("expected '{c}'"))),
        }
    }

    /// Skip one value: a token, or a bracketed group with everything in it.
    fn skip_value(&mut self) -> Result<(), String> {
        let line = self.line();
        let mut depth = 0usize;
        loop {
            match self.next() {
                None => {
                    return Err(format!(
                        "'{}' line {line}: a bracket opened here is not closed",
                        self.name
                    ))
                }
                Some(Token::Punct('(' | '[' | '{')) => depth += 1,
                Some(Token::Punct(')' | ']' | '}')) => {
                    if depth == 0 {
                        return Err(self.error("unbalanced closing bracket"));
                    }
                    depth -= 1;
                }
                Some(_) => {}
            }
            if depth == 0 {
                return Ok(());
            }
        }
    }

    fn number(&mut self) -> Result<f64, String> {
        match self.peek() {
            Some(Token::Word(w)) => match w.parse::<f64>() {
                Ok(x) if x.is_finite() => {
                    self.pos += 1;
                    Ok(x)
                }
                _ => Err(self.error(format!("'{w}' is not a finite number"))),
            },
            _ => Err(self.error("expected a number")),
        }
    }

    /// `[a, b, ...]` of items read by `item`.
    fn list<T>(
        &mut self,
        mut item: impl FnMut(&mut Self) -> Result<T, String>,
    ) -> Result<Vec<T>, String> {
        self.expect('[')?;
        let mut out = Vec::new();
        loop {
            if matches!(self.peek(), Some(Token::Punct(']'))) {
                self.pos += 1;
                return Ok(out);
            }
            out.push(item(self)?);
            match self.peek() {
                Some(Token::Punct(',')) => self.pos += 1,
                Some(Token::Punct(']')) => {}
                _ => return Err(self.error("expected ',' or ']' in a list")),
            }
        }
    }

    fn point(&mut self) -> Result<Vector3<f64>, String> {
        self.expect('(')?;
        let x = self.number()?;
        self.expect(',')?;
        let y = self.number()?;
        self.expect(',')?;
        let z = self.number()?;
        self.expect(')')?;
        Ok(Vector3::new(x, y, z))
    }

    fn counts(&mut self) -> Result<Vec<usize>, String> {
        self.list(|p| {
            let x = p.number()?;
            if x.fract() != 0.0 || x < 0.0 {
                return Err(p.error(format!("a vertex count must be an integer >= 0, got {x}")));
            }
            Ok(x as usize)
        })
    }

    /// The value of a `points.timeSamples` dictionary: its earliest sample.
    fn earliest_sample(&mut self) -> Result<Option<Sample>, String> {
        self.expect('{')?;
        let mut best: Option<Sample> = None;
        loop {
            let line = self.line();
            let time = match self.next() {
                Some(Token::Punct('}')) => return Ok(best),
                Some(Token::Word(w)) => {
                    let text = w.strip_suffix(':').unwrap_or(&w).to_string();
                    if !w.ends_with(':') {
                        match self.next() {
                            Some(Token::Word(colon)) if colon == ":" => {}
                            _ => return Err(self.error("expected ':' after a time code")),
                        }
                    }
                    text.parse::<f64>()
                        .ok()
                        .filter(|t| t.is_finite())
                        .ok_or_else(|| self.error(format!("'{text}' is not a time code")))?
                }
                _ => return Err(self.error("expected a time code or '}'")),
            };
            let value = if matches!(self.peek(), Some(Token::Word(w)) if w == "None") {
                self.pos += 1;
                None
            } else {
                Some(self.list(Self::point)?)
            };
            if let Some(points) = value {
                if best.as_ref().is_none_or(|(t, _, _)| time < *t) {
                    best = Some((time, points, line));
                }
            }
            match self.peek() {
                Some(Token::Punct(',')) => self.pos += 1,
                Some(Token::Punct('}')) => {}
                _ => return Err(self.error("expected ',' or '}' in time samples")),
            }
        }
    }

    /// The value after `attribute =` inside a `BasisCurves` prim.
    fn attribute(&mut self, attribute: &str, prim: &mut CurvesPrim) -> Result<(), String> {
        let line = self.line();
        match attribute {
            "curveVertexCounts" => prim.counts = Some((self.counts()?, line)),
            "points" => {
                if matches!(self.peek(), Some(Token::Word(w)) if w == "None") {
                    self.pos += 1;
                } else {
                    prim.points = Some((self.list(Self::point)?, line));
                }
            }
            "points.timeSamples" => prim.sampled = self.earliest_sample()?,
            "type" | "basis" => match self.next() {
                Some(Token::Str(s)) => {
                    let slot = if attribute == "type" {
                        &mut prim.kind
                    } else {
                        &mut prim.basis
                    };
                    *slot = Some((s, line));
                }
                _ => return Err(self.error(format!("expected a token string for {attribute}"))),
            },
            _ => self.skip_value()?,
        }
        Ok(())
    }

    /// A block of statements up to its closing `}` (or the end of the text at the top),
    /// `prim` the BasisCurves prim it is the body of. Finished prims go to `out`.
    fn block(
        &mut self,
        mut prim: Option<&mut CurvesPrim>,
        top: bool,
        out: &mut Vec<CurvesPrim>,
    ) -> Result<(), String> {
        let mut last_word: Option<String> = None;
        loop {
            let Some(token) = self.peek().cloned() else {
                if top {
                    return Ok(());
                }
                return Err(self.error("a prim's '{' is not closed"));
            };
            match token {
                Token::Punct('}') => {
                    self.pos += 1;
                    if top {
                        return Err(self.error("unbalanced '}'"));
                    }
                    return Ok(());
                }
                Token::Word(w) if matches!(w.as_str(), "def" | "over" | "class") => {
                    let line = self.line();
                    self.pos += 1;
                    let mut kind = String::new();
                    if let Some(Token::Word(t)) = self.peek() {
                        kind = t.clone();
                        self.pos += 1;
                    }
                    let name = match self.next() {
                        Some(Token::Str(s)) => s,
                        _ => return Err(self.error("expected the prim's name in quotes")),
                    };
                    if matches!(self.peek(), Some(Token::Punct('('))) {
                        self.skip_value()?;
                    }
                    self.expect('{')?;
                    if kind == "BasisCurves" {
                        let mut child = CurvesPrim {
                            line,
                            name,
                            ..Default::default()
                        };
                        self.block(Some(&mut child), false, out)?;
                        out.push(child);
                    } else {
                        self.block(None, false, out)?;
                    }
                    last_word = None;
                }
                Token::Punct('=') => {
                    self.pos += 1;
                    match (prim.as_deref_mut(), last_word.take()) {
                        (Some(p), Some(attribute)) => self.attribute(&attribute, p)?,
                        _ => self.skip_value()?,
                    }
                }
                Token::Punct('(' | '[' | '{') => {
                    self.skip_value()?;
                }
                Token::Punct(c) if c == ')' || c == ']' => {
                    return Err(self.error(format!("unbalanced '{c}'")));
                }
                Token::Word(w) => {
                    last_word = Some(w);
                    self.pos += 1;
                }
                _ => {
                    self.pos += 1;
                }
            }
        }
    }
}

/// The curves of one prim.
fn prim_curves(prim: CurvesPrim, name: &str) -> Result<Vec<Curve>, String> {
    let at = |line: usize, message: String| format!("'{name}' line {line}: {message}");
    if let Some((kind, line)) = &prim.kind {
        if kind == "cubic" {
            let basis = prim.basis.as_ref().map_or("bezier", |(b, _)| b.as_str());
            if basis != "catmullRom" {
                return Err(at(
                    prim.basis.as_ref().map_or(*line, |(_, l)| *l),
                    format!(
                        "BasisCurves \"{}\" is cubic with basis \"{basis}\": its points are \
                         control points off the curve; only linear and catmullRom curves are read",
                        prim.name
                    ),
                ));
            }
        } else if kind != "linear" {
            return Err(at(*line, format!("unknown curve type \"{kind}\"")));
        }
    }
    let Some((counts, counts_line)) = prim.counts else {
        return Err(at(
            prim.line,
            format!("BasisCurves \"{}\" has no curveVertexCounts", prim.name),
        ));
    };
    let (points, points_line) = match (prim.points, prim.sampled) {
        (Some((p, l)), _) => (p, l),
        (None, Some((_, p, l))) => (p, l),
        (None, None) => {
            return Err(at(
                prim.line,
                format!("BasisCurves \"{}\" has no points", prim.name),
            ))
        }
    };
    let total: usize = counts.iter().sum();
    if total != points.len() {
        return Err(at(
            points_line,
            format!(
                "BasisCurves \"{}\": curveVertexCounts (line {counts_line}) add up to {total} \
                 points, but points has {}",
                prim.name,
                points.len()
            ),
        ));
    }
    let mut out = Vec::with_capacity(counts.len());
    let mut start = 0;
    for (k, &count) in counts.iter().enumerate() {
        if count < 2 {
            return Err(at(
                counts_line,
                format!(
                    "BasisCurves \"{}\": curve {k} has {count} point(s), a curve needs at least two",
                    prim.name
                ),
            ));
        }
        out.push(Curve {
            points: points[start..start + count].to_vec(),
            origin: format!("'{name}' prim \"{}\" curve {k}", prim.name),
        });
        start += count;
    }
    Ok(out)
}

/// The curves of the USDA text `text`; `name` (the file) goes into the messages. An
/// error names the file and the line.
pub fn parse_usda_curves(text: &str, name: &str) -> Result<Vec<Curve>, String> {
    if !text.trim_start().starts_with("#usda") {
        return Err(format!(
            "'{name}' line 1: not a USD text file (it must start with '#usda 1.0'; binary \
             .usdc/.usd files are not read: save the stage as .usda)"
        ));
    }
    let tokens = tokenize(text, name)?;
    let mut parser = Parser {
        tokens: &tokens,
        pos: 0,
        name,
    };
    let mut prims = Vec::new();
    parser.block(None, true, &mut prims)?;
    let mut curves = Vec::new();
    for prim in prims {
        curves.extend(prim_curves(prim, name)?);
    }
    if curves.is_empty() {
        return Err(format!("'{name}' has no BasisCurves prim with curves"));
    }
    Ok(curves)
}

/// The curves of the USDA file at `path` ([`parse_usda_curves`]).
pub fn read_usda_curves(path: &Path) -> Result<Vec<Curve>, String> {
    let text = crate::input::read_text_bounded(path, crate::input::TEXT_FILE_LIMIT, "USDA file")?;
    parse_usda_curves(&text, &path.display().to_string())
}
