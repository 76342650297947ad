//! Rewriting a constraint file's `constraints` list as the editor asks,
//! keeping the rest of the file as the user wrote it: every other field,
//! every comment outside the items that change, the items that do not
//! change (byte for byte, `near:` and `px:` forms included), and the
//! layout (indentation, trailing commas). A changed item keeps its comments
//! and other fields; only its `vertex`/`near`, target and `label` values are
//! replaced. The result is parsed again and compared with what was asked
//! before anyone writes it.

use crate::constraints::{ConstraintSpec, LoadedConstraints};
use crate::ron_file::tokens::{Kind, Token, fields, groups_inside, tokens, top_fields};
use glam::DVec2;
use std::ops::Range;
use thiserror::Error;

/// One constraint as the editor wants it.
#[derive(Debug, Clone, PartialEq)]
pub struct WantedConstraint {
    /// Primitive of `vertex` (`None`: the file's `primitive`).
    pub primitive: Option<usize>,
    /// glTF vertex index in that primitive.
    pub vertex: u32,
    /// Target in glTF texture coordinates.
    pub uv: DVec2,
    pub label: Option<String>,
}

/// An item of the file as it stands: its index in the list and the
/// vertex it resolved to (a `near:` item too).
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub struct ExistingItem {
    pub index: usize,
    pub primitive: usize,
    pub vertex: u32,
}

#[derive(Debug, Error, PartialEq)]
pub enum EditError {
    #[error("the file has no `constraints: [...]` list to edit")]
    NoList,
    #[error("constraints[{index}]: the target ({u}, {v}) is outside the texture's square")]
    OutsideSquare { index: usize, u: f64, v: f64 },
    #[error("constraints[{index}]: a label may not hold control characters")]
    BadLabel { index: usize },
    #[error("constraints[{a}] and constraints[{b}] name the same vertex {vertex}")]
    SameVertex { a: usize, b: usize, vertex: u32 },
    #[error("the rewritten file does not read back as asked ({0}); nothing was written")]
    Mismatch(String),
}

/// The `constraints` list: the token indices of `[` and `]`, and each
/// item's tokens (from its `(` to its `)`).
struct List {
    open: usize,
    close: usize,
    items: Vec<Range<usize>>,
}

fn find_list(text: &str, tokens: &[Token]) -> Option<List> {
    let (_, value) = top_fields(text, tokens).into_iter().find(|(n, _)| n == "constraints")?;
    let open = value.start;
    if &text[tokens[open].span.clone()] != "[" {
        return None;
    }
    let items = groups_inside(tokens, open);
    Some(List {
        open,
        close: value.end - 1,
        items,
    })
}

/// A number as the file stores it: at most six decimals, no trailing zeros.
fn number(x: f64) -> String {
    let s = format!("{x:.6}");
    let s = s.trim_end_matches('0');
    if s.ends_with('.') {
        format!("{s}0")
    } else {
        s.to_string()
    }
}

fn quoted(label: &str) -> String {
    let mut out = String::from("\"");
    for c in label.chars() {
        match c {
            '"' => out.push_str("\\\""),
            '\\' => out.push_str("\\\\"),
            c => out.push(c),
        }
    }
    out.push('"');
    out
}

/// The target's text: `px` when the item had one and the file has an image
/// size, else `uv`.
fn target_text(uv: DVec2, px: Option<(u32, u32)>) -> (&'static str, String) {
    match px {
        Some((w, h)) => (
            "px",
            format!("({}, {})", number(uv.x * f64::from(w)), number(uv.y * f64::from(h))),
        ),
        None => ("uv", format!("({}, {})", number(uv.x), number(uv.y))),
    }
}

/// The spec `wanted` reads back as (the numbers as written).
fn expected_spec(wanted: &WantedConstraint, px: Option<(u32, u32)>) -> ConstraintSpec {
    let (name, value) = target_text(wanted.uv, px);
    let parsed: Vec<f64> = value
        .trim_matches(|c| c == '(' || c == ')')
        .split(", ")
        .map(|n| n.parse().expect("a number we wrote"))
        .collect();
    let target = Some(DVec2::new(parsed[0], parsed[1]));
    ConstraintSpec {
        vertex: Some(wanted.vertex),
        near: None,
        uv: if name == "uv" { target } else { None },
        px: if name == "px" { target } else { None },
        label: wanted.label.clone(),
        primitive: wanted.primitive,
    }
}

/// A new item's text.
fn new_item(wanted: &WantedConstraint) -> String {
    let (name, value) = target_text(wanted.uv, None);
    let mut s = format!("(vertex: {}, {name}: {value}", wanted.vertex);
    if let Some(p) = wanted.primitive {
        s += &format!(", primitive: {p}");
    }
    if let Some(l) = &wanted.label {
        s += &format!(", label: {}", quoted(l));
    }
    s + ")"
}

/// A byte-range replacement.
type Splice = (Range<usize>, String);

/// How an existing item changes: its target form (`px` with the image
/// size, or `uv`), whether the target moved, and the primitive to name
/// when the item has none but needs one (a `near:` item that resolved
/// outside the file's primitive becomes a `vertex:` there).
#[derive(Debug, Clone, Copy)]
struct ItemChange {
    px: Option<(u32, u32)>,
    moved: bool,
    add_primitive: Option<usize>,
}

/// Where fields are appended to an item: after its last significant token
/// (never inside a comment), and whether that token is a comma.
fn append_point(tokens: &[Token], item: &Range<usize>) -> (usize, bool) {
    let last = (item.start + 1..item.end - 1)
        .rev()
        .find(|&k| tokens[k].kind != Kind::Trivia)
        .unwrap_or(item.start);
    (tokens[last].span.end, tokens[last].kind == Kind::Comma)
}

/// The splices that turn an existing item (tokens `item`) into `wanted`.
fn item_splices(
    text: &str,
    tokens: &[Token],
    item: &Range<usize>,
    wanted: &WantedConstraint,
    change: ItemChange,
) -> Vec<Splice> {
    let span = |r: &Range<usize>| tokens[r.start].span.start..tokens[r.end - 1].span.end;
    let found = fields(text, tokens, item.start);
    let field = |name: &str| found.iter().find(|(n, _)| n == name).map(|(_, r)| r.clone());
    let mut splices = Vec::new();
    let name_span = |r: &Range<usize>| {
        // The field name two significant tokens before the value.
        let mut k = r.start;
        let mut seen = 0;
        while k > item.start {
            k -= 1;
            if tokens[k].kind != Kind::Trivia {
                seen += 1;
                if seen == 2 {
                    return tokens[k].span.clone();
                }
            }
        }
        tokens[r.start].span.clone()
    };
    match (field("vertex"), field("near")) {
        (Some(v), _) => splices.push((span(&v), wanted.vertex.to_string())),
        (None, Some(n)) => {
            splices.push((name_span(&n), "vertex".into()));
            splices.push((span(&n), wanted.vertex.to_string()));
        }
        (None, None) => {}
    }
    let (name, value) = target_text(wanted.uv, change.px);
    if let Some(t) = field("uv").or_else(|| field("px")).filter(|_| change.moved) {
        splices.push((name_span(&t), name.into()));
        splices.push((span(&t), value));
    }
    let mut appended = Vec::new();
    if let Some(p) = change.add_primitive.filter(|_| field("primitive").is_none()) {
        appended.push(format!("primitive: {p}"));
    }
    match (field("label"), &wanted.label) {
        (Some(l), Some(new)) => splices.push((span(&l), quoted(new))),
        (Some(l), None) => splices.push(remove_field_span(text, tokens, item, &l, name_span(&l))),
        (None, Some(new)) => appended.push(format!("label: {}", quoted(new))),
        (None, None) => {}
    }
    if !appended.is_empty() {
        let (at, after_comma) = append_point(tokens, item);
        let lead = if after_comma { " " } else { ", " };
        splices.push((at..at, format!("{lead}{}", appended.join(", "))));
    }
    splices
}

/// The splice that removes a field: its name through its value and the
/// comma after it with the spaces that follow (or from the comma before it,
/// for the last field). Comments inside what goes are put back in its place
/// (a line comment with the line break after it), so none is lost and none
/// swallows what follows.
fn remove_field_span(
    text: &str,
    tokens: &[Token],
    item: &Range<usize>,
    value: &Range<usize>,
    name: Range<usize>,
) -> Splice {
    let blank = |j: usize| tokens[j].kind == Kind::Trivia && text[tokens[j].span.clone()].trim().is_empty();
    let name_token = (item.start..value.start).find(|&k| tokens[k].span.start == name.start);
    let after = (value.end..item.end - 1).find(|&k| tokens[k].kind != Kind::Trivia);
    let (first, last) = match after {
        Some(k) if tokens[k].kind == Kind::Comma => {
            let end = (k + 1..item.end - 1).find(|&j| !blank(j)).unwrap_or(item.end - 1);
            (name_token.unwrap_or(value.start), end - 1)
        }
        _ => {
            let start = name_token.unwrap_or(value.start);
            let before = (item.start + 1..start).rev().find(|&k| tokens[k].kind != Kind::Trivia);
            let from = before.filter(|&k| tokens[k].kind == Kind::Comma).unwrap_or(start);
            (from, value.end - 1)
        }
    };
    let range = tokens[first].span.start..tokens[last].span.end;
    let mut kept = kept_comments(text, tokens, first..last + 1);
    if !kept.is_empty() && !text[..range.start].ends_with(char::is_whitespace) {
        kept.insert(0, ' ');
    }
    (range, kept)
}

/// The comments among `tokens[range]`, each block comment followed by a
/// space and each line comment by the whitespace after it (its line break).
fn kept_comments(text: &str, tokens: &[Token], range: Range<usize>) -> String {
    let mut out = String::new();
    for k in range.clone() {
        let t = &text[tokens[k].span.clone()];
        if tokens[k].kind != Kind::Trivia || t.trim().is_empty() {
            continue;
        }
        out.push_str(t);
        let line = t.starts_with("//");
        match tokens.get(k + 1).map(|n| &text[n.span.clone()]) {
            Some(ws) if line && k + 1 < range.end && ws.trim().is_empty() => out.push_str(ws),
            _ if line => out.push('\n'),
            _ => out.push(' '),
        }
    }
    out
}

fn apply(text: &str, mut splices: Vec<Splice>) -> String {
    splices.sort_by_key(|(r, _)| r.start);
    let mut out = String::with_capacity(text.len());
    let mut at = 0;
    for (r, s) in splices {
        out.push_str(&text[at..r.start]);
        out.push_str(&s);
        at = r.end;
    }
    out.push_str(&text[at..]);
    out
}

/// Checks what the editor asks for: targets inside the square, one target
/// per vertex.
///
/// # Errors
/// The first of those that fails.
pub fn check_wanted(wanted: &[WantedConstraint]) -> Result<(), EditError> {
    for (index, w) in wanted.iter().enumerate() {
        let inside = |x: f64| (0.0..=1.0).contains(&x);
        if !inside(w.uv.x) || !inside(w.uv.y) {
            return Err(EditError::OutsideSquare {
                index,
                u: w.uv.x,
                v: w.uv.y,
            });
        }
        if let Some(a) = wanted[..index]
            .iter()
            .position(|o| o.vertex == w.vertex && o.primitive == w.primitive)
        {
            return Err(EditError::SameVertex {
                a,
                b: index,
                vertex: w.vertex,
            });
        }
    }
    Ok(())
}

/// The text of `loaded` (read from `text`) with its constraints replaced by
/// `wanted`. `existing` says which vertex each current item resolved to;
/// a wanted constraint on the same vertex is that item, edited in place.
///
/// # Errors
/// No `constraints` list in the text; a target outside the square; two
/// wanted constraints on one vertex; a result that does not read back as
/// asked (nothing is to be written then).
pub fn rewrite_constraints(
    text: &str,
    loaded: &LoadedConstraints,
    existing: &[ExistingItem],
    wanted: &[WantedConstraint],
) -> Result<String, EditError> {
    check_wanted(wanted)?;
    let tokens = tokens(text);
    let list = find_list(text, &tokens).ok_or(EditError::NoList)?;
    let default_primitive = loaded.file.primitive;
    let mut body = String::new();
    let mut expected = Vec::new();
    let layout = ListLayout::of(text, &tokens, &list);
    for (k, w) in wanted.iter().enumerate() {
        let primitive = w.primitive.unwrap_or(default_primitive);
        let old = existing
            .iter()
            .find(|e| e.vertex == w.vertex && e.primitive == primitive)
            .filter(|e| e.index < list.items.len() && e.index < loaded.file.constraints.len());
        // Only a label the edit writes must be one line (one kept as the
        // user wrote it is theirs).
        let writes_label = old.is_none_or(|e| loaded.file.constraints[e.index].label != w.label);
        if writes_label && w.label.as_deref().is_some_and(|l| l.chars().any(char::is_control)) {
            return Err(EditError::BadLabel { index: k });
        }
        let (lead, item, spec) = match old {
            Some(e) => {
                let spec = &loaded.file.constraints[e.index];
                let px = spec.px.and(loaded.file.image_size);
                let item = &list.items[e.index];
                let moved = loaded.target_uv(spec) != w.uv;
                let unchanged = !moved && spec.label == w.label;
                // A `near:` item resolved outside the file's primitive names it.
                let add_primitive =
                    (spec.near.is_some() && spec.primitive.is_none() && e.primitive != default_primitive)
                        .then_some(e.primitive);
                let item_text = &text[tokens[item.start].span.start..tokens[item.end - 1].span.end];
                if unchanged {
                    (layout.lead(e.index), item_text.to_string(), spec.clone())
                } else {
                    let base = tokens[item.start].span.start;
                    let change = ItemChange {
                        px,
                        moved,
                        add_primitive,
                    };
                    let splices = item_splices(text, &tokens, item, w, change)
                        .into_iter()
                        .map(|(r, s)| (r.start - base..r.end - base, s))
                        .collect();
                    let mut spec = expected_spec(w, px);
                    // The item's own `primitive` field is left as it was, and
                    // its target if it did not move.
                    spec.primitive = loaded.file.constraints[e.index].primitive.or(add_primitive);
                    if !moved {
                        (spec.uv, spec.px) = (loaded.file.constraints[e.index].uv, loaded.file.constraints[e.index].px);
                    }
                    (layout.lead(e.index), apply(item_text, splices), spec)
                }
            }
            None => (layout.new_lead.clone(), new_item(w), expected_spec(w, None)),
        };
        body += &lead;
        body += &item;
        if k + 1 < wanted.len() || layout.trailing_comma {
            body.push(',');
        }
        if let Some(e) = old {
            body += &layout.trailing(e.index);
        }
        expected.push(spec);
    }
    let open_end = tokens[list.open].span.end;
    let close_start = tokens[list.close].span.start;
    let tail = if wanted.is_empty() {
        layout.empty_tail.clone()
    } else {
        layout.tail.clone()
    };
    let out = format!("{}{body}{tail}{}", &text[..open_end], &text[close_start..]);
    verify(&out, loaded, &expected)?;
    Ok(out)
}

/// How the list is laid out: what precedes each item, what follows it on
/// its line, and what a new item gets.
struct ListLayout {
    /// Per item: the text from the end of the previous item's separator
    /// (or the `[`) to the item.
    leads: Vec<String>,
    /// Per item: what follows its comma on the same line (a comment).
    trailings: Vec<String>,
    /// The text between the last item's separator and the `]`.
    tail: String,
    /// The tail of an empty list.
    empty_tail: String,
    new_lead: String,
    trailing_comma: bool,
}

impl ListLayout {
    fn of(text: &str, tokens: &[Token], list: &List) -> ListLayout {
        let mut leads = Vec::new();
        let mut trailings = Vec::new();
        let mut at = tokens[list.open].span.end;
        let mut trailing_comma = true;
        for item in &list.items {
            let start = tokens[item.start].span.start;
            leads.push(text[at..start].to_string());
            let mut k = item.end;
            while k < list.close && tokens[k].kind == Kind::Trivia && !text[tokens[k].span.clone()].contains('\n') {
                k += 1;
            }
            trailing_comma = k < list.close && tokens[k].kind == Kind::Comma;
            at = if trailing_comma {
                tokens[k].span.end
            } else {
                tokens[item.end - 1].span.end
            };
            // A comment on the same line after the comma stays with the item.
            let mut end = at;
            let mut j = if trailing_comma { k + 1 } else { item.end };
            while j < list.close && tokens[j].kind == Kind::Trivia {
                let piece = &text[tokens[j].span.clone()];
                if piece.starts_with("//") || piece.starts_with("/*") {
                    end = tokens[j].span.end;
                } else if piece.contains('\n') {
                    break;
                }
                j += 1;
            }
            trailings.push(text[at..end].to_string());
            at = end;
        }
        let tail = text[at..tokens[list.close].span.start].to_string();
        let line_indent = |pos: usize| {
            let line_start = text[..pos].rfind('\n').map_or(0, |n| n + 1);
            text[line_start..]
                .chars()
                .take_while(|c| *c == ' ' || *c == '\t')
                .collect::<String>()
        };
        let key_indent = line_indent(tokens[list.open].span.start);
        // A new item goes on a line of its own where the items are, or
        // after a line comment (anything after it would be commented out).
        let after_line_comment = trailings.last().is_some_and(|t| t.contains("//"));
        let new_lead = match leads.last() {
            Some(l) if l.contains('\n') || after_line_comment => {
                format!(
                    "\n{}",
                    line_indent(tokens[list.items[leads.len() - 1].start].span.start)
                )
            }
            Some(_) => " ".into(),
            None => format!("\n{key_indent}    "),
        };
        let empty_tail = if list.items.is_empty() {
            tail.clone()
        } else {
            String::new()
        };
        let tail = if list.items.is_empty() {
            format!("\n{key_indent}")
        } else {
            tail
        };
        ListLayout {
            leads,
            trailings,
            tail,
            empty_tail,
            new_lead,
            trailing_comma: trailing_comma || list.items.is_empty(),
        }
    }

    fn lead(&self, index: usize) -> String {
        self.leads[index].clone()
    }

    fn trailing(&self, index: usize) -> String {
        self.trailings[index].clone()
    }
}

/// The new text must parse, keep every other field, and give `expected`.
fn verify(out: &str, loaded: &LoadedConstraints, expected: &[ConstraintSpec]) -> Result<(), EditError> {
    let reread = LoadedConstraints::parse_with_defaults(&loaded.path, out, &loaded.solver)
        .map_err(|e| EditError::Mismatch(e.to_string()))?;
    let mut others = reread.file.clone();
    others.constraints = loaded.file.constraints.clone();
    if others != loaded.file {
        return Err(EditError::Mismatch("another field changed".into()));
    }
    if reread.file.constraints != expected {
        return Err(EditError::Mismatch("the constraints differ".into()));
    }
    Ok(())
}

/// The text of a new constraint file for `asset` (a path relative to the
/// constraint file), with no constraints yet.
pub fn new_file(asset: &str) -> String {
    format!(
        "// Landmarks for {asset}: (vertex: id, uv: (u, v), label: \"...\"); `uvpin edit` writes them.\n(\n    asset: {},\n    constraints: [],\n)\n",
        quoted(asset)
    )
}

#[cfg(test)]
mod tests {
    use super::*;
    use std::path::Path;

    const FILE: &str = r#"// The sample, with comments everywhere.
(
    asset: "face.glb", // the mesh
    constraints: [
        // the eyes
        (vertex: 12, uv: (0.25, 0.5), label: "eye"), // left
        /* a ( tricky ] comment */ (vertex: 3, uv: (1, 0)),
        (near: (0.1, 0.2, 0.3), px: (64, 32)),
    ],
    image_size: (128, 64),
    corners: Auto, // keep
)
"#;

    fn loaded(text: &str) -> LoadedConstraints {
        LoadedConstraints::parse(Path::new("f.uvpin.ron"), text).unwrap()
    }

    /// Item `index` of a file, resolved to `vertex` of `primitive`.
    fn item(index: usize, primitive: usize, vertex: u32) -> ExistingItem {
        ExistingItem {
            index,
            primitive,
            vertex,
        }
    }

    fn existing() -> Vec<ExistingItem> {
        vec![item(0, 0, 12), item(1, 0, 3), item(2, 0, 40)]
    }

    fn wanted(vertex: u32, u: f64, v: f64, label: Option<&str>) -> WantedConstraint {
        WantedConstraint {
            primitive: None,
            vertex,
            uv: DVec2::new(u, v),
            label: label.map(str::to_string),
        }
    }

    fn as_is() -> Vec<WantedConstraint> {
        vec![
            wanted(12, 0.25, 0.5, Some("eye")),
            wanted(3, 1.0, 0.0, None),
            wanted(40, 0.5, 0.5, None),
        ]
    }

    #[test]
    fn nothing_asked_changes_nothing() {
        let out = rewrite_constraints(FILE, &loaded(FILE), &existing(), &as_is()).unwrap();
        assert_eq!(out, FILE);
    }

    #[test]
    fn a_moved_target_changes_only_its_numbers() {
        let mut w = as_is();
        w[1].uv = DVec2::new(0.125, 0.75);
        let out = rewrite_constraints(FILE, &loaded(FILE), &existing(), &w).unwrap();
        assert_eq!(
            out,
            FILE.replace("(vertex: 3, uv: (1, 0))", "(vertex: 3, uv: (0.125, 0.75))")
        );
    }

    #[test]
    fn a_near_item_becomes_a_vertex_and_keeps_px() {
        let mut w = as_is();
        w[2].uv = DVec2::new(0.25, 0.25);
        w[2].label = Some("nose \"tip\"".into());
        let out = rewrite_constraints(FILE, &loaded(FILE), &existing(), &w).unwrap();
        let item = r#"(vertex: 40, px: (32.0, 16.0), label: "nose \"tip\"")"#;
        assert_eq!(out, FILE.replace("(near: (0.1, 0.2, 0.3), px: (64, 32))", item));
    }

    #[test]
    fn labels_are_edited_removed_and_added() {
        let mut w = as_is();
        w[0].label = None;
        w[1].label = Some("ear".into());
        let out = rewrite_constraints(FILE, &loaded(FILE), &existing(), &w).unwrap();
        let expect = FILE
            .replace(
                r#"(vertex: 12, uv: (0.25, 0.5), label: "eye")"#,
                "(vertex: 12, uv: (0.25, 0.5))",
            )
            .replace("(vertex: 3, uv: (1, 0))", r#"(vertex: 3, uv: (1, 0), label: "ear")"#);
        assert_eq!(out, expect);
    }

    #[test]
    fn a_removed_label_keeps_the_comments_around_it() {
        let text = "(\n    asset: \"m.glb\",\n    constraints: [\n        (vertex: 12, label: \"eye\", /* kept */ uv: (0.25, 0.5)),\n        (vertex: 3, uv: (1, 0), // also kept, with a comma\n            label: \"ear\"),\n        (vertex: 40, label: \"x\" /* inside */, uv: (0.5, 0.5)),\n    ],\n)\n";
        let loaded = loaded(text);
        let existing = vec![item(0, 0, 12), item(1, 0, 3), item(2, 0, 40)];
        let w = vec![
            wanted(12, 0.25, 0.5, None),
            wanted(3, 1.0, 0.0, None),
            wanted(40, 0.5, 0.5, None),
        ];
        let out = rewrite_constraints(text, &loaded, &existing, &w).unwrap();
        let expect = text
            .replace("label: \"eye\", /* kept */", "/* kept */")
            .replace(
                "(1, 0), // also kept, with a comma\n            label: \"ear\")",
                "(1, 0) // also kept, with a comma\n            )",
            )
            .replace("label: \"x\" /* inside */, uv", "/* inside */ uv");
        assert_eq!(out, expect);
    }

    #[test]
    fn added_items_follow_the_indentation_and_deleted_ones_leave_no_trace() {
        let mut w = as_is();
        w.remove(1);
        w.push(wanted(77, 0.1, 0.2, Some("chin")));
        let out = rewrite_constraints(FILE, &loaded(FILE), &existing(), &w).unwrap();
        let expect = FILE
            .replace("        /* a ( tricky ] comment */ (vertex: 3, uv: (1, 0)),\n", "")
            .replace(
                "px: (64, 32)),\n",
                "px: (64, 32)),\n        (vertex: 77, uv: (0.1, 0.2), label: \"chin\"),\n",
            );
        assert_eq!(out, expect);
    }

    #[test]
    fn an_empty_list_gets_items_and_can_be_emptied() {
        let text = "(\n    asset: \"a.glb\",\n    constraints: [],\n)\n";
        let out = rewrite_constraints(text, &loaded(text), &[], &[wanted(5, 0.5, 0.25, None)]).unwrap();
        assert_eq!(
            out,
            "(\n    asset: \"a.glb\",\n    constraints: [\n        (vertex: 5, uv: (0.5, 0.25)),\n    ],\n)\n"
        );
        let items = [item(0, 0, 5)];
        let back = rewrite_constraints(&out, &loaded(&out), &items, &[]).unwrap();
        assert_eq!(back, text);
        assert_eq!(new_file("a.glb").matches("constraints: []").count(), 1);
        assert!(loaded(&new_file("dir/a \"b\".glb")).file.constraints.is_empty());
    }

    #[test]
    fn one_line_lists_stay_on_one_line() {
        let text = "(asset: \"a.glb\", constraints: [(vertex: 1, uv: (0.5, 0.5))])";
        let items = [item(0, 0, 1)];
        let w = [wanted(1, 0.5, 0.5, None), wanted(2, 0.25, 0.5, None)];
        let out = rewrite_constraints(text, &loaded(text), &items, &w).unwrap();
        assert_eq!(
            out,
            "(asset: \"a.glb\", constraints: [(vertex: 1, uv: (0.5, 0.5)), (vertex: 2, uv: (0.25, 0.5))])"
        );
    }

    #[test]
    fn bad_requests_are_refused() {
        let l = loaded(FILE);
        let mut w = as_is();
        w[0].uv.x = 1.5;
        assert!(matches!(
            rewrite_constraints(FILE, &l, &existing(), &w),
            Err(EditError::OutsideSquare { index: 0, .. })
        ));
        let mut w = as_is();
        w[1].vertex = 12;
        assert_eq!(
            rewrite_constraints(FILE, &l, &existing(), &w),
            Err(EditError::SameVertex { a: 0, b: 1, vertex: 12 })
        );
        let mut w = as_is();
        w[0].label = Some("a\nb".into());
        assert_eq!(
            rewrite_constraints(FILE, &l, &existing(), &w),
            Err(EditError::BadLabel { index: 0 })
        );
    }

    #[test]
    fn comments_never_swallow_what_is_added() {
        let text = "(asset: \"a.glb\", constraints: [(vertex: 1, uv: (0.5, 0.5) // the nose\n), // eye\n])";
        let items = [item(0, 0, 1)];
        let w = [wanted(1, 0.5, 0.5, Some("nose")), wanted(2, 0.25, 0.5, None)];
        let out = rewrite_constraints(text, &loaded(text), &items, &w).unwrap();
        assert_eq!(
            out,
            "(asset: \"a.glb\", constraints: [(vertex: 1, uv: (0.5, 0.5), label: \"nose\" // the nose\n), // eye\n(vertex: 2, uv: (0.25, 0.5)),\n])"
        );
    }

    #[test]
    fn a_near_item_on_another_primitive_names_it() {
        let text = "(asset: \"a.glb\", constraints: [(near: (0, 0, 0), uv: (0.5, 0.5))])";
        let items = [item(0, 1, 88)];
        let mut w = wanted(88, 0.25, 0.5, None);
        w.primitive = Some(1);
        let out = rewrite_constraints(text, &loaded(text), &items, &[w]).unwrap();
        assert_eq!(
            out,
            "(asset: \"a.glb\", constraints: [(vertex: 88, uv: (0.25, 0.5), primitive: 1)])"
        );
    }

    #[test]
    fn a_label_the_edit_does_not_touch_may_be_anything() {
        let text = "(asset: \"a.glb\", constraints: [(vertex: 1, uv: (0.5, 0.5), label: \"a\\tb\")])";
        let items = [item(0, 0, 1)];
        let w = [wanted(1, 0.5, 0.5, Some("a\tb")), wanted(2, 0.25, 0.5, None)];
        assert!(rewrite_constraints(text, &loaded(text), &items, &w).is_ok());
    }

    #[test]
    fn numbers_are_short() {
        assert_eq!(number(0.5), "0.5");
        assert_eq!(number(1.0), "1.0");
        assert_eq!(number(0.0), "0.0");
        assert_eq!(number(0.123_456_789), "0.123457");
    }
}
