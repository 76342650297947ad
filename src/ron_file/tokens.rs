//! RON text as tokens that keep their byte spans: what the constraint
//! loader locates its errors with (line and column of a field or an item)
//! and what the editor's rewrites splice. Only run on text the RON parser
//! accepted (or is about to judge), so it can be simple: strings and
//! nested comments are one token each, brackets are matched by depth.

use std::ops::Range;

/// A token of RON text: its kind and byte range.
#[derive(Debug, Clone, PartialEq)]
pub struct Token {
    /// What it is.
    pub kind: Kind,
    /// Its bytes in the text.
    pub span: Range<usize>,
}

/// What a token is.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Kind {
    /// Whitespace or a comment.
    Trivia,
    /// `(`, `[` or `{`.
    Open,
    /// `)`, `]` or `}`.
    Close,
    /// `,`.
    Comma,
    /// `:`.
    Colon,
    /// An identifier, number, string or other word.
    Word,
}

/// Splits `text` into tokens; strings and (nested) comments are one token.
pub fn tokens(text: &str) -> Vec<Token> {
    let bytes = text.as_bytes();
    let mut out = Vec::new();
    let mut i = 0;
    while i < bytes.len() {
        let start = i;
        let kind = match bytes[i] {
            b'(' | b'[' | b'{' => {
                i += 1;
                Kind::Open
            }
            b')' | b']' | b'}' => {
                i += 1;
                Kind::Close
            }
            b',' => {
                i += 1;
                Kind::Comma
            }
            b':' => {
                i += 1;
                Kind::Colon
            }
            b'/' if bytes.get(i + 1) == Some(&b'/') => {
                i = text[i..].find('\n').map_or(bytes.len(), |n| i + n);
                Kind::Trivia
            }
            b'/' if bytes.get(i + 1) == Some(&b'*') => {
                i = block_comment_end(bytes, i);
                Kind::Trivia
            }
            b'"' => {
                i = string_end(bytes, i);
                Kind::Word
            }
            c if c.is_ascii_whitespace() => {
                while i < bytes.len() && bytes[i].is_ascii_whitespace() {
                    i += 1;
                }
                Kind::Trivia
            }
            _ => {
                while i < bytes.len() && !b"()[]{},:\" \t\r\n/".contains(&bytes[i]) {
                    i += 1;
                }
                i = i.max(start + 1);
                Kind::Word
            }
        };
        // Never split a UTF-8 character.
        while !text.is_char_boundary(i) {
            i += 1;
        }
        out.push(Token { kind, span: start..i });
    }
    out
}

/// The end of a nestable `/* */` comment starting at `i`.
fn block_comment_end(bytes: &[u8], mut i: usize) -> usize {
    let mut depth = 0;
    while i < bytes.len() {
        if bytes[i..].starts_with(b"/*") {
            depth += 1;
            i += 2;
        } else if bytes[i..].starts_with(b"*/") {
            depth -= 1;
            i += 2;
            if depth == 0 {
                return i;
            }
        } else {
            i += 1;
        }
    }
    i
}

/// The end of a string literal starting at `i` (escapes skipped).
fn string_end(bytes: &[u8], mut i: usize) -> usize {
    i += 1;
    while i < bytes.len() && bytes[i] != b'"' {
        i += if bytes[i] == b'\\' { 2 } else { 1 };
    }
    (i + 1).min(bytes.len())
}

/// A bracketed group: the index of its opening token and of its closing one.
pub fn matching_close(tokens: &[Token], open: usize) -> Option<usize> {
    let mut depth = 0usize;
    for (k, t) in tokens.iter().enumerate().skip(open) {
        match t.kind {
            Kind::Open => depth += 1,
            Kind::Close => {
                depth -= 1;
                if depth == 0 {
                    return Some(k);
                }
            }
            _ => {}
        }
    }
    None
}

/// The fields `name: value` directly inside the group opened at `open`:
/// name, the token range of the value.
pub fn fields(text: &str, tokens: &[Token], open: usize) -> Vec<(String, Range<usize>)> {
    let Some(close) = matching_close(tokens, open) else {
        return Vec::new();
    };
    let mut out = Vec::new();
    let mut k = open + 1;
    while k < close {
        let significant = |j: usize| (j..close).find(|&j| tokens[j].kind != Kind::Trivia);
        let Some(name) = significant(k) else { break };
        let colon = significant(name + 1);
        let value = colon.and_then(|c| significant(c + 1));
        let (true, Some(colon), Some(value)) = (tokens[name].kind == Kind::Word, colon, value) else {
            break;
        };
        if tokens[colon].kind != Kind::Colon {
            break;
        }
        let end = match tokens[value].kind {
            Kind::Open => matching_close(tokens, value).unwrap_or(close),
            _ => value,
        };
        // A word directly followed by a group is a named struct: `Some(...)`.
        let end = match significant(end + 1) {
            Some(j) if tokens[end].kind == Kind::Word && tokens[j].kind == Kind::Open => {
                matching_close(tokens, j).unwrap_or(close)
            }
            _ => end,
        };
        out.push((text[tokens[name].span.clone()].to_string(), value..end + 1));
        k = significant(end + 1).map_or(close, |j| if tokens[j].kind == Kind::Comma { j + 1 } else { j });
    }
    out
}

/// The outermost group's fields (see [`fields`]), if the text has a group.
pub fn top_fields(text: &str, tokens: &[Token]) -> Vec<(String, Range<usize>)> {
    tokens
        .iter()
        .position(|t| t.kind == Kind::Open)
        .map_or_else(Vec::new, |outer| fields(text, tokens, outer))
}

/// The groups directly inside the group opened at token `open` (a list's
/// items): each one's token range, from its opening token to its closing one.
pub fn groups_inside(tokens: &[Token], open: usize) -> Vec<Range<usize>> {
    let close = matching_close(tokens, open).unwrap_or(tokens.len());
    let mut items = Vec::new();
    let mut k = open + 1;
    while k < close {
        if tokens[k].kind == Kind::Open {
            let end = matching_close(tokens, k).unwrap_or(close);
            items.push(k..end + 1);
            k = end + 1;
        } else {
            k += 1;
        }
    }
    items
}

/// The 1-based line and column (in characters) of byte `at` of `text`.
pub fn line_column(text: &str, at: usize) -> (usize, usize) {
    let before = &text[..at.min(text.len())];
    let line = before.matches('\n').count() + 1;
    let line_start = before.rfind('\n').map_or(0, |i| i + 1);
    (line, before[line_start..].chars().count() + 1)
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn fields_items_and_positions_skip_strings_and_comments() {
        let text = "( // a comment with ( and \"\n  asset: \"a, b.glb\",\n  constraints: [ /* ( */ (vertex: 1), (vertex: 2) ],\n)";
        let tokens = tokens(text);
        let fields = top_fields(text, &tokens);
        let names: Vec<&str> = fields.iter().map(|(n, _)| n.as_str()).collect();
        assert_eq!(names, ["asset", "constraints"]);
        let list = &fields[1].1;
        let items = groups_inside(&tokens, list.start);
        let starts: Vec<(usize, usize)> = items
            .iter()
            .map(|r| line_column(text, tokens[r.start].span.start))
            .collect();
        assert_eq!(starts, [(3, 26), (3, 39)]);
        assert_eq!(line_column(text, tokens[fields[0].1.start].span.start), (2, 10));
    }
}
