//! ASCII FBX text into a [`Node`] tree, the same tree binary files give.
//!
//! The text is a list of nodes, each `Name: value, value, ... { children }`:
//! values are numbers, quoted strings or bare words, separated by commas
//! (a list goes on over line ends after a comma); an array is `*N { a:
//! v, v, ... }` (FBX 7) or a plain list (FBX 6); `;` starts a comment.
//! Errors name the line. Nesting is bounded, so no file exhausts the stack.

use super::tree::{Node, Value};

/// Deepest nesting of `{ }` accepted (real files nest fewer than 10).
const MAX_DEPTH: usize = 64;

/// Reads ASCII FBX text into a root node holding the top-level nodes.
pub fn parse(bytes: &[u8]) -> Result<Node, String> {
    let mut parser = Parser { tokens: Tokens { bytes, at: 0, line: 1 }, peeked: None };
    let children = parser.nodes(0)?;
    Ok(Node { name: String::new(), values: Vec::new(), children })
}

/// Whether `bytes` look like ASCII FBX: a comment or a node name first.
pub fn looks_like_ascii(bytes: &[u8]) -> bool {
    let head = &bytes[..bytes.len().min(4096)];
    let head = head.strip_prefix(b"\xef\xbb\xbf").unwrap_or(head);
    let text = String::from_utf8_lossy(head);
    let first = text.trim_start();
    first.starts_with("; FBX") || first.contains("FBXHeaderExtension:")
}

/// The FBX version of ASCII text: `FBXVersion` in the header extension, or
/// the `; FBX 6.1.0 project file` comment.
pub fn version(root: &Node, bytes: &[u8]) -> Option<u32> {
    let declared = root.child("FBXHeaderExtension").and_then(|h| h.child_value("FBXVersion")).and_then(Value::int);
    declared.and_then(|v| u32::try_from(v).ok()).or_else(|| {
        let head = String::from_utf8_lossy(&bytes[..bytes.len().min(256)]);
        let digits: String = head.trim_start().strip_prefix("; FBX ")?.chars().take_while(|c| *c != ' ').collect();
        let mut parts = digits.split('.').map(|p| p.parse::<u32>().ok());
        let (major, minor) = (parts.next()??, parts.next()??);
        Some(major * 1000 + minor * 100)
    })
}

/// A piece of the text.
#[derive(Clone, Debug, PartialEq)]
enum Token {
    /// `Name:` (a node's name, or `a:` in an array).
    Name(String),
    /// A bare word that is not a name (`T`, `Y`, `N`...).
    Word(String),
    /// A number as written.
    Number(String),
    /// A quoted string (with `&quot;` restored).
    Text(String),
    /// `*N`: an array of N values follows.
    Count(String),
    Comma,
    Open,
    Close,
    End,
}

/// The text cut into tokens.
struct Tokens<'a> {
    bytes: &'a [u8],
    at: usize,
    line: usize,
}

impl Tokens<'_> {
    fn skip_blanks(&mut self) {
        while let Some(&b) = self.bytes.get(self.at) {
            match b {
                b'\n' => self.line += 1,
                b';' => {
                    while self.bytes.get(self.at).is_some_and(|&c| c != b'\n') {
                        self.at += 1;
                    }
                    continue;
                }
                b if b.is_ascii_whitespace() || b == 0xef || b == 0xbb || b == 0xbf => {}
                _ => return,
            }
            self.at += 1;
        }
    }

    fn run(&mut self, keep: impl Fn(u8) -> bool) -> String {
        let start = self.at;
        while self.bytes.get(self.at).is_some_and(|&b| keep(b)) {
            self.at += 1;
        }
        String::from_utf8_lossy(&self.bytes[start..self.at]).into_owned()
    }

    fn next(&mut self) -> Result<Token, String> {
        self.skip_blanks();
        let Some(&b) = self.bytes.get(self.at) else { return Ok(Token::End) };
        let single = match b {
            b',' => Some(Token::Comma),
            b'{' => Some(Token::Open),
            b'}' => Some(Token::Close),
            _ => None,
        };
        if let Some(token) = single {
            self.at += 1;
            return Ok(token);
        }
        match b {
            b'"' => self.text(),
            b'*' => {
                self.at += 1;
                Ok(Token::Count(self.run(|c| c.is_ascii_digit())))
            }
            b'-' | b'+' | b'.' | b'0'..=b'9' => Ok(Token::Number(
                self.run(|c| c.is_ascii_alphanumeric() || matches!(c, b'.' | b'-' | b'+' | b'#' | b'(' | b')')),
            )),
            b if b.is_ascii_alphabetic() || b == b'_' => {
                let word = self.run(|c| c.is_ascii_alphanumeric() || matches!(c, b'_' | b'|' | b'-' | b'(' | b')'));
                if self.bytes.get(self.at) == Some(&b':') {
                    self.at += 1;
                    Ok(Token::Name(word))
                } else {
                    Ok(Token::Word(word))
                }
            }
            other => Err(format!("line {}: unexpected character {:?}", self.line, other as char)),
        }
    }

    /// A quoted string; FBX writes a quote inside one as `&quot;`.
    fn text(&mut self) -> Result<Token, String> {
        let line = self.line;
        self.at += 1;
        let start = self.at;
        while let Some(&b) = self.bytes.get(self.at) {
            if b == b'"' {
                let text = String::from_utf8_lossy(&self.bytes[start..self.at]).replace("&quot;", "\"");
                self.at += 1;
                return Ok(Token::Text(text));
            }
            if b == b'\n' {
                self.line += 1;
            }
            self.at += 1;
        }
        Err(format!("line {line}: a string is not closed"))
    }
}

/// Nodes from tokens, one token of look-ahead.
struct Parser<'a> {
    tokens: Tokens<'a>,
    peeked: Option<Token>,
}

impl Parser<'_> {
    fn peek(&mut self) -> Result<&Token, String> {
        if self.peeked.is_none() {
            self.peeked = Some(self.tokens.next()?);
        }
        Ok(self.peeked.get_or_insert(Token::End))
    }

    fn next(&mut self) -> Result<Token, String> {
        match self.peeked.take() {
            Some(token) => Ok(token),
            None => self.tokens.next(),
        }
    }

    fn error(&self, what: &str) -> String {
        format!("line {}: {what}", self.tokens.line)
    }

    /// Nodes up to the `}` closing this level (or the end of the text at level 0).
    fn nodes(&mut self, depth: usize) -> Result<Vec<Node>, String> {
        if depth > MAX_DEPTH {
            return Err(self.error(&format!("braces nest deeper than {MAX_DEPTH} levels")));
        }
        let mut nodes = Vec::new();
        loop {
            match self.next()? {
                Token::Name(name) => nodes.push(self.node(name, depth)?),
                Token::Close if depth > 0 => return Ok(nodes),
                Token::End if depth == 0 => return Ok(nodes),
                Token::End => return Err(self.error("the text ends inside { }")),
                other => return Err(self.error(&format!("expected a node name, found {other:?}"))),
            }
        }
    }

    /// A node's values and, after `{`, its children.
    fn node(&mut self, name: String, depth: usize) -> Result<Node, String> {
        let values = self.values(depth)?;
        let mut node = Node { name, values, children: Vec::new() };
        if *self.peek()? == Token::Open {
            self.next()?;
            node.children = self.nodes(depth + 1)?;
        }
        Ok(node)
    }

    /// Values separated by commas; an array `*N { a: ... }` is one value.
    fn values(&mut self, depth: usize) -> Result<Vec<Value>, String> {
        let mut values = Vec::new();
        loop {
            let value = match self.peek()?.clone() {
                Token::Number(n) => Some(number(&n).ok_or_else(|| self.error(&format!("'{n}' is not a number")))?),
                Token::Word(w) => Some(number(&w).unwrap_or(Value::String(w))),
                Token::Text(s) => Some(Value::String(s)),
                Token::Count(_) => {
                    self.next()?;
                    values.push(self.array(depth)?);
                    None
                }
                Token::Comma => None, // an empty value (`Content: ,`)
                _ => break,
            };
            if let Some(value) = value {
                self.next()?;
                values.push(value);
            }
            if *self.peek()? != Token::Comma {
                break;
            }
            self.next()?;
        }
        Ok(values)
    }

    /// `{ a: v, v, ... }` after `*N`: integers if every value is one, else reals.
    fn array(&mut self, depth: usize) -> Result<Value, String> {
        if self.next()? != Token::Open {
            return Err(self.error("an array count is not followed by {"));
        }
        let mut values = Vec::new();
        loop {
            match self.next()? {
                Token::Name(_) => values.extend(self.values(depth + 1)?),
                Token::Close => break,
                other => return Err(self.error(&format!("expected `a:` in an array, found {other:?}"))),
            }
        }
        if values.iter().all(|v| matches!(v, Value::Int(_))) {
            return Ok(Value::Ints(values.iter().filter_map(Value::int).collect()));
        }
        let reals: Option<Vec<f64>> = values.iter().map(Value::number).collect();
        reals.map(Value::Floats).ok_or_else(|| self.error("an array holds something that is not a number"))
    }
}

/// A number token: an integer when it is one, else a real; the spellings
/// of infinities and NaNs that C libraries print (`inf`, `-INFINITY`,
/// `nan(ind)`, MSVC's `1.#INF` and `-1.#IND`) are read as such.
fn number(token: &str) -> Option<Value> {
    if let Ok(i) = token.parse::<i64>() {
        return Some(Value::Int(i));
    }
    if let Ok(f) = token.parse::<f64>() {
        return Some(Value::Float(f));
    }
    let upper = token.to_ascii_uppercase();
    let negative = upper.starts_with('-');
    let bare = upper.trim_start_matches(['-', '+']);
    let infinite = matches!(bare, "INF" | "INFINITY") || bare.contains(".#INF");
    if infinite {
        return Some(Value::Float(if negative { f64::NEG_INFINITY } else { f64::INFINITY }));
    }
    let not_a_number = bare == "NAN"
        || (bare.starts_with("NAN(") && bare.ends_with(')'))
        || [".#IND", ".#QNAN", ".#SNAN", ".#NAN"].iter().any(|m| bare.contains(m));
    not_a_number.then_some(Value::Float(f64::NAN))
}

#[cfg(test)]
mod tests {
    use super::*;

    const TEXT: &str = r#"; FBX 7.4.0 project file
; a comment
FBXHeaderExtension:  {
	FBXVersion: 7400
}
Objects:  {
	Geometry: 123, "Geometry::Cube", "Mesh" {
		Vertices: *6 {
			a: -1,1.5,2,
			3e-1,0,-0
		}
		PolygonVertexIndex: *3 {
			a: 0,1,-3
		}
		Properties70:  {
			P: "Name", "KString", "", "", "say &quot;hi&quot;"
			P: "Visibility", "Visibility", "", "A",1
		}
		Shading: T
		Culling: "CullingOff"
	}
}
"#;

    #[test]
    fn nodes_values_and_arrays_are_read() {
        let root = parse(TEXT.as_bytes()).unwrap();
        assert_eq!(version(&root, TEXT.as_bytes()), Some(7400));
        let geometry = root.child("Objects").unwrap().child("Geometry").unwrap();
        assert_eq!(geometry.values[0], Value::Int(123));
        assert_eq!(geometry.values[1], Value::String("Geometry::Cube".into()));
        assert_eq!(geometry.child_floats("Vertices").unwrap(), vec![-1.0, 1.5, 2.0, 0.3, 0.0, 0.0]);
        assert_eq!(geometry.child_value("PolygonVertexIndex"), Some(&Value::Ints(vec![0, 1, -3])));
        let p = geometry.child("Properties70").unwrap().child("P").unwrap();
        assert_eq!(p.values[4], Value::String("say \"hi\"".into()));
        assert_eq!(geometry.child_string("Shading"), Some("T"));
        assert_eq!(geometry.child_string("Culling"), Some("CullingOff"));
    }

    #[test]
    fn fbx6_lists_go_on_after_a_comma_at_the_line_end() {
        let text =
            "; FBX 6.1.0 project file\nModel: \"Model::Cube\", \"Mesh\" {\n Vertices: 1,2,\n 3,4\n Version: 232\n}\n";
        let root = parse(text.as_bytes()).unwrap();
        assert_eq!(version(&root, text.as_bytes()), Some(6100));
        let model = root.child("Model").unwrap();
        let vertices = model.child("Vertices").unwrap();
        assert_eq!(vertices.values, [1, 2, 3, 4].map(Value::Int).to_vec());
        assert_eq!(model.child_number("Version"), Some(232.0));
    }

    #[test]
    fn msvc_infinities_and_empty_values_are_read() {
        assert_eq!(number("1.#INF"), Some(Value::Float(f64::INFINITY)));
        assert!(number("-1.#IND").and_then(|v| v.number()).is_some_and(f64::is_nan));
        assert_eq!(number("12abc"), None);
        assert_eq!(number("-Infinity"), Some(Value::Float(f64::NEG_INFINITY)));
        assert!(number("nan(ind)").and_then(|v| v.number()).is_some_and(f64::is_nan));
        assert_eq!(number("infty"), None);
        let root = parse(b"Content: , \"abc\"\n").unwrap();
        assert_eq!(root.children[0].values, vec![Value::String("abc".into())]);
    }

    #[test]
    fn broken_text_is_an_error_with_its_line() {
        assert!(parse(b"A: {\n B: 1\n").unwrap_err().contains("ends inside"));
        assert!(parse(b"A: \"open\n").unwrap_err().starts_with("line 1"));
        assert!(parse(b"\n\n}\n").unwrap_err().starts_with("line 3"));
        let deep = "A: {".repeat(100);
        assert!(parse(deep.as_bytes()).unwrap_err().contains("nest deeper"));
    }
}
