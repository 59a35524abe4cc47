//! The YAML subset of calibration files (OpenCV `FileStorage`, KITTI-360 `image_0[23].yaml`):
//! a `%YAML:1.0` header, `---`, `#` comments, block mappings by indentation, plain or quoted
//! scalars, flow sequences `[a, b, ...]` that may span lines, and OpenCV's `!!opencv-matrix` tag
//! (kept as the node's tag). Anchors, block sequences, multi-line scalars and flow mappings are
//! not part of these files and are refused. Every node keeps its 1-based line for errors.
//!
//! Why no YAML crate: these files are not YAML a parser accepts. OpenCV writes the directive as
//! `%YAML:1.0` (YAML's own is `%YAML 1.0`), which YAML scanners (yaml-rust's, libyaml's) refuse
//! at the first line, and its `!!opencv-matrix` tag is not one of YAML's schemas; serde_yaml is
//! no longer maintained; and an error must name the line of a field found wrong after parsing,
//! which a serde value does not keep. The subset these files use fits in this file.

/// A parsed node.
#[derive(Debug, Clone, PartialEq)]
pub enum Node {
    Scalar {
        text: String,
        line: usize,
    },
    Seq {
        items: Vec<String>,
        line: usize,
    },
    Map {
        tag: Option<String>,
        entries: Vec<(String, Node)>,
        line: usize,
    },
}

/// Why a text is not in the subset: the line and a message.
#[derive(Debug, Clone, PartialEq)]
pub struct YamlError {
    pub line: usize,
    pub message: String,
}

impl Node {
    pub fn line(&self) -> usize {
        match self {
            Node::Scalar { line, .. } | Node::Seq { line, .. } | Node::Map { line, .. } => *line,
        }
    }

    /// The value of `key` in a mapping.
    pub fn get(&self, key: &str) -> Option<&Node> {
        match self {
            Node::Map { entries, .. } => entries.iter().find(|(k, _)| k == key).map(|(_, v)| v),
            _ => None,
        }
    }

    pub fn tag(&self) -> Option<&str> {
        match self {
            Node::Map { tag, .. } => tag.as_deref(),
            _ => None,
        }
    }
}

struct Line<'a> {
    number: usize,
    indent: usize,
    text: &'a str,
}

/// Removes a `#` comment that is not inside quotes.
fn strip_comment(s: &str) -> &str {
    let mut quote = None;
    for (i, c) in s.char_indices() {
        match (quote, c) {
            (None, '"' | '\'') => quote = Some(c),
            (Some(q), c) if c == q => quote = None,
            (None, '#') if i == 0 || s[..i].ends_with([' ', '\t']) => return &s[..i],
            _ => {}
        }
    }
    s
}

fn unquote(s: &str) -> String {
    let s = s.trim();
    for q in ['"', '\''] {
        if s.len() >= 2 && s.starts_with(q) && s.ends_with(q) {
            return s[1..s.len() - 1].to_owned();
        }
    }
    s.to_owned()
}

/// Parses the whole text into its top-level mapping.
pub fn parse(text: &str) -> Result<Node, YamlError> {
    let mut lines = Vec::new();
    for (i, raw) in text.lines().enumerate() {
        let number = i + 1;
        let body = strip_comment(raw).trim_end();
        let trimmed = body.trim_start();
        if trimmed.is_empty() || (number == 1 && trimmed.starts_with("%YAML")) {
            continue;
        }
        if trimmed == "---" || trimmed == "..." {
            continue;
        }
        if body.starts_with('\t') {
            return Err(YamlError {
                line: number,
                message: "tabs are not allowed for indentation".into(),
            });
        }
        lines.push(Line {
            number,
            indent: body.len() - trimmed.len(),
            text: trimmed,
        });
    }
    let mut at = 0;
    let indent = lines.first().map_or(0, |l| l.indent);
    let root = block(&lines, &mut at, indent, None, 1)?;
    if let Some(l) = lines.get(at) {
        return Err(YamlError {
            line: l.number,
            message: "unexpected indentation".into(),
        });
    }
    Ok(root)
}

/// The mapping whose keys sit at `indent`, starting at `lines[*at]`.
fn block(
    lines: &[Line],
    at: &mut usize,
    indent: usize,
    tag: Option<String>,
    line: usize,
) -> Result<Node, YamlError> {
    let mut entries: Vec<(String, Node)> = Vec::new();
    while let Some(l) = lines.get(*at) {
        if l.indent < indent {
            break;
        }
        if l.indent > indent {
            return Err(YamlError {
                line: l.number,
                message: "unexpected indentation".into(),
            });
        }
        if l.text.starts_with("- ") || l.text == "-" {
            return Err(YamlError {
                line: l.number,
                message: "block sequences are not supported; use [a, b, ...]".into(),
            });
        }
        let Some((key, rest)) = split_key(l.text) else {
            return Err(YamlError {
                line: l.number,
                message: format!("expected `key: value`, found {:?}", l.text),
            });
        };
        if entries.iter().any(|(k, _)| *k == key) {
            return Err(YamlError {
                line: l.number,
                message: format!("duplicate key {key:?}"),
            });
        }
        *at += 1;
        let rest = rest.trim();
        let (tag, rest) = match rest.strip_prefix("!!") {
            Some(t) => {
                let end = t.find(' ').unwrap_or(t.len());
                (Some(t[..end].to_owned()), t[end..].trim())
            }
            None => (None, rest),
        };
        let value = if rest.is_empty() {
            match lines.get(*at) {
                Some(next) if next.indent > indent => block(lines, at, next.indent, tag, l.number)?,
                _ => Node::Scalar {
                    text: String::new(),
                    line: l.number,
                },
            }
        } else if rest.starts_with('[') {
            flow_sequence(lines, at, rest, l.number)?
        } else if rest.starts_with('{') || rest.starts_with('&') || rest.starts_with('*') {
            return Err(YamlError {
                line: l.number,
                message: "flow mappings, anchors and aliases are not supported".into(),
            });
        } else {
            Node::Scalar {
                text: unquote(rest),
                line: l.number,
            }
        };
        entries.push((key, value));
    }
    Ok(Node::Map { tag, entries, line })
}

/// `key: rest` (the key possibly quoted), or None.
fn split_key(s: &str) -> Option<(String, &str)> {
    let (key, rest) = if let Some(q) = s.strip_prefix('"') {
        let end = q.find('"')?;
        let rest = q[end + 1..].trim_start().strip_prefix(':')?;
        (q[..end].to_owned(), rest)
    } else {
        let colon = s
            .find(": ")
            .or_else(|| s.ends_with(':').then(|| s.len() - 1))?;
        (s[..colon].trim().to_owned(), &s[colon + 1..])
    };
    (!key.is_empty()).then_some((key, rest))
}

/// `[a, b, ...]`, continued on the following lines until the closing bracket.
fn flow_sequence(
    lines: &[Line],
    at: &mut usize,
    first: &str,
    line: usize,
) -> Result<Node, YamlError> {
    let mut text = first.to_owned();
    while !text.contains(']') {
        let Some(l) = lines.get(*at) else {
            return Err(YamlError {
                line,
                message: "unterminated [ sequence".into(),
            });
        };
        text.push(' ');
        text.push_str(l.text);
        *at += 1;
    }
    let inner = text.trim().strip_prefix('[').unwrap_or(&text);
    let Some((inner, after)) = inner.split_once(']') else {
        return Err(YamlError {
            line,
            message: "unterminated [ sequence".into(),
        });
    };
    if !after.trim().is_empty() || inner.contains('[') {
        return Err(YamlError {
            line,
            message: "nested or trailing content after a [ sequence ] is not supported".into(),
        });
    }
    let items = inner
        .split(',')
        .map(unquote)
        .filter(|s| !s.is_empty())
        .collect();
    Ok(Node::Seq { items, line })
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn opencv_matrices_and_nested_maps() {
        let text = "%YAML:1.0\n---\nK: !!opencv-matrix\n   rows: 3\n   cols: 3\n   dt: d\n   data: [ 1., 0., 2.,\n       0., 1., 3., 0., 0., 1. ]\nname: \"cam # 1\" # comment\nouter:\n  inner: 4\n";
        let root = parse(text).unwrap();
        let k = root.get("K").unwrap();
        assert_eq!(k.tag(), Some("opencv-matrix"));
        assert_eq!(k.line(), 3);
        match k.get("data").unwrap() {
            Node::Seq { items, line } => {
                assert_eq!(items.len(), 9);
                assert_eq!(items[5], "3.");
                assert_eq!(*line, 7);
            }
            other => panic!("{other:?}"),
        }
        assert_eq!(
            root.get("name"),
            Some(&Node::Scalar {
                text: "cam # 1".into(),
                line: 9
            })
        );
        assert_eq!(root.get("outer").unwrap().get("inner").unwrap().line(), 11);
    }

    #[test]
    fn refusals_name_the_line() {
        assert_eq!(parse("a: 1\n  b: 2\n").unwrap_err().line, 2);
        assert_eq!(parse("a: 1\na: 2\n").unwrap_err().line, 2);
        assert_eq!(parse("a:\n  - 1\n").unwrap_err().line, 2);
        assert_eq!(parse("a: [1, 2\n").unwrap_err().line, 1);
        assert_eq!(parse("just text\n").unwrap_err().line, 1);
    }
}
