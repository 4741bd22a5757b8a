//! A YAML tree that remembers where every key and value stands in the file, so that
//! every error can name its line and column. Built on yaml-rust2's event parser.
use yaml_rust2::parser::{Event, MarkedEventReceiver, Parser};
use yaml_rust2::scanner::{Marker, TScalarStyle};

/// 1-based line and column.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default)]
pub struct Pos {
    pub line: usize,
    pub col: usize,
}

impl From<Marker> for Pos {
    fn from(m: Marker) -> Self {
        // yaml-rust2 lines are 1-based and columns 0-based.
        Pos { line: m.line(), col: m.col() + 1 }
    }
}

#[derive(Debug, Clone, PartialEq)]
pub enum Scalar {
    Null,
    Bool(bool),
    Int(i64),
    Float(f64),
    Str(String),
}

#[derive(Debug, Clone, PartialEq)]
pub enum Kind {
    Scalar(Scalar),
    Seq(Vec<Node>),
    /// Keys in file order with their positions.
    Map(Vec<(String, Pos, Node)>),
}

#[derive(Debug, Clone, PartialEq)]
pub struct Node {
    pub pos: Pos,
    pub kind: Kind,
}

impl Node {
    pub fn type_name(&self) -> &'static str {
        match &self.kind {
            Kind::Scalar(Scalar::Null) => "null",
            Kind::Scalar(Scalar::Bool(_)) => "a boolean",
            Kind::Scalar(Scalar::Int(_)) => "a whole number",
            Kind::Scalar(Scalar::Float(_)) => "a number",
            Kind::Scalar(Scalar::Str(_)) => "text",
            Kind::Seq(_) => "a list",
            Kind::Map(_) => "a mapping",
        }
    }
}

/// Parse one YAML document. Errors carry the position the scanner stopped at; a second
/// document (after `---`) is an error at its start, not silently ignored.
pub fn parse(text: &str) -> Result<Node, (Pos, String)> {
    let mut builder = Builder::default();
    let mut parser = Parser::new_from_str(text);
    parser
        .load(&mut builder, true)
        .map_err(|e| (Pos::from(*e.marker()), e.info().to_string()))?;
    if let Some(err) = builder.error {
        return Err(err);
    }
    Ok(builder.root.unwrap_or(Node { pos: Pos { line: 1, col: 1 }, kind: Kind::Scalar(Scalar::Null) }))
}

enum Frame {
    Seq(Pos, Vec<Node>),
    Map(Pos, Vec<(String, Pos, Node)>, Option<(String, Pos)>),
}

#[derive(Default)]
struct Builder {
    stack: Vec<Frame>,
    root: Option<Node>,
    error: Option<(Pos, String)>,
    documents: usize,
}

impl Builder {
    fn push_node(&mut self, node: Node) {
        if self.error.is_some() {
            return;
        }
        match self.stack.last_mut() {
            None => self.root = Some(node),
            Some(Frame::Seq(_, items)) => items.push(node),
            Some(Frame::Map(_, entries, pending)) => match pending.take() {
                None => match node.kind {
                    Kind::Scalar(s) => {
                        let key = match s {
                            Scalar::Str(k) => k,
                            Scalar::Int(i) => i.to_string(),
                            Scalar::Float(f) => f.to_string(),
                            Scalar::Bool(b) => b.to_string(),
                            Scalar::Null => "null".into(),
                        };
                        if entries.iter().any(|(k, _, _)| *k == key) {
                            self.error = Some((node.pos, format!("duplicate key `{key}`")));
                            return;
                        }
                        *pending = Some((key, node.pos));
                    }
                    _ => self.error = Some((node.pos, "keys must be plain words, not lists or mappings".into())),
                },
                Some((key, kpos)) => entries.push((key, kpos, node)),
            },
        }
    }
}

impl MarkedEventReceiver for Builder {
    fn on_event(&mut self, ev: Event, mark: Marker) {
        let pos = Pos::from(mark);
        match ev {
            Event::Scalar(value, style, _, _) => {
                let scalar = if style == TScalarStyle::Plain { plain_scalar(&value) } else { Scalar::Str(value) };
                self.push_node(Node { pos, kind: Kind::Scalar(scalar) });
            }
            Event::SequenceStart(..) => self.stack.push(Frame::Seq(pos, Vec::new())),
            Event::MappingStart(..) => self.stack.push(Frame::Map(pos, Vec::new(), None)),
            Event::SequenceEnd | Event::MappingEnd => {
                let node = match self.stack.pop() {
                    Some(Frame::Seq(p, items)) => Node { pos: p, kind: Kind::Seq(items) },
                    // A block mapping "starts" at its first key, where a reader looks.
                    Some(Frame::Map(p, entries, _)) => Node { pos: entries.first().map(|e| e.1).unwrap_or(p), kind: Kind::Map(entries) },
                    None => return,
                };
                self.push_node(node);
            }
            Event::DocumentStart => {
                self.documents += 1;
                if self.documents == 2 && self.error.is_none() {
                    self.error = Some((pos, "a second YAML document starts here; allowed: one pipeline per file (remove this `---` and what follows, or move it to its own file)".into()));
                }
            }
            Event::Alias(_) if self.error.is_none() => {
                self.error = Some((pos, "YAML anchors and aliases are not supported in pipelines".into()));
            }
            _ => {}
        }
    }
}

/// YAML 1.2 core-schema typing of a plain scalar.
fn plain_scalar(s: &str) -> Scalar {
    match s {
        "" | "~" | "null" | "Null" | "NULL" => return Scalar::Null,
        "true" | "True" | "TRUE" => return Scalar::Bool(true),
        "false" | "False" | "FALSE" => return Scalar::Bool(false),
        ".inf" | ".Inf" | ".INF" | "+.inf" => return Scalar::Float(f64::INFINITY),
        "-.inf" | "-.Inf" | "-.INF" => return Scalar::Float(f64::NEG_INFINITY),
        ".nan" | ".NaN" | ".NAN" => return Scalar::Float(f64::NAN),
        _ => {}
    }
    if let Ok(i) = s.parse::<i64>() {
        return Scalar::Int(i);
    }
    let looks_numeric = s.chars().next().is_some_and(|c| c.is_ascii_digit() || c == '-' || c == '+' || c == '.')
        && s.chars().all(|c| c.is_ascii_digit() || "+-.eE_".contains(c));
    if looks_numeric {
        if let Ok(f) = s.replace('_', "").parse::<f64>() {
            return Scalar::Float(f);
        }
    }
    Scalar::Str(s.to_string())
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn positions_and_types() {
        let doc = "a: 1\nb:\n  c: 5e-05\n  d: [x, 'true', true]\n";
        let root = parse(doc).unwrap();
        let Kind::Map(entries) = &root.kind else { panic!() };
        assert_eq!(entries[0].0, "a");
        assert_eq!(entries[0].1, Pos { line: 1, col: 1 });
        assert_eq!(entries[0].2.kind, Kind::Scalar(Scalar::Int(1)));
        let Kind::Map(inner) = &entries[1].2.kind else { panic!() };
        assert_eq!(inner[0].1, Pos { line: 3, col: 3 });
        assert_eq!(inner[0].2.kind, Kind::Scalar(Scalar::Float(5e-5)));
        assert_eq!(inner[0].2.pos, Pos { line: 3, col: 6 });
        let Kind::Seq(items) = &inner[1].2.kind else { panic!() };
        assert_eq!(items[1].kind, Kind::Scalar(Scalar::Str("true".into())));
        assert_eq!(items[2].kind, Kind::Scalar(Scalar::Bool(true)));
    }

    #[test]
    fn duplicate_keys_and_syntax_errors_have_positions() {
        let (pos, msg) = parse("a: 1\na: 2\n").unwrap_err();
        assert_eq!((pos.line, msg.as_str()), (2, "duplicate key `a`"));
        let (pos, _) = parse("a: [1, 2\nb: 3\n").unwrap_err();
        assert!(pos.line >= 2);
    }

    #[test]
    fn a_second_document_is_an_error() {
        assert!(parse("---\na: 1\n").is_ok());
        let (pos, msg) = parse("a: 1\n---\nb: 2\n").unwrap_err();
        assert_eq!(pos.line, 2);
        assert!(msg.starts_with("a second YAML document starts here"), "{msg}");
    }
}
