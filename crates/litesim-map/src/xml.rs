//! A small read-only XML tree over quick-xml's pull parser, built one
//! top-level element at a time.
//!
//! Why not a whole-document DOM: an OpenDRIVE file is a flat list of large
//! top-level elements (roads, junctions, controllers). Building the tree of
//! one of them, turning it into the model and reusing the tree's storage for
//! the next keeps memory at the file's text plus the model, whatever the
//! map's size (a 200 MB map), and the pull parser is several times faster
//! than a general DOM (1.8 MB town map: 21 ms for roxmltree's tree alone).
//!
//! Names and attribute values are slices of the input (no copies) unless a
//! value has an entity or character reference. Element positions are byte
//! offsets of their `<`; the caller turns them into line and column.
//!
//! Public because the OpenSCENARIO XML front end (`litesim-xosc`) reads its
//! files with the same tree: one XML reader in the workspace.

use quick_xml::events::Event;
use quick_xml::reader::Reader;
use std::ops::Range;

/// Not well-formed XML: where (byte offset) and what.
#[derive(Debug)]
pub struct XmlError {
    /// Byte offset into the input.
    pub pos: usize,
    /// What is wrong (quick-xml's wording, or ours).
    pub message: String,
}

const NONE: u32 = u32::MAX;

struct Elem {
    /// Local name (after a namespace prefix).
    name: Range<usize>,
    start: usize,
    attrs: Range<u32>,
    first_child: u32,
    last_child: u32,
    next_sibling: u32,
    /// Index into `Tree::texts`.
    text: u32,
}

enum Value {
    /// A slice of the input.
    Raw(Range<usize>),
    /// Index into `Tree::owned` (a value with references resolved).
    Owned(u32),
}

struct Attr {
    /// Local name (after a namespace prefix).
    name: Range<usize>,
    /// Qualified name (for the duplicate check).
    qname: Range<usize>,
    value: Value,
}

/// The elements of one subtree (reused from subtree to subtree).
pub struct Tree<'a> {
    text: &'a str,
    elems: Vec<Elem>,
    attrs: Vec<Attr>,
    owned: Vec<String>,
    texts: Vec<String>,
}

/// An element of a [`Tree`].
#[derive(Clone, Copy)]
pub struct Node<'t, 'a> {
    tree: &'t Tree<'a>,
    id: u32,
}

impl<'t, 'a> Node<'t, 'a> {
    fn elem(&self) -> &'t Elem {
        &self.tree.elems[self.id as usize]
    }

    /// Local name (a namespace prefix dropped).
    pub fn name(&self) -> &'a str {
        &self.tree.text[self.elem().name.clone()]
    }

    /// Byte offset of the element's `<` in the input.
    pub fn start(&self) -> usize {
        self.elem().start
    }

    /// An attribute's value by local name.
    pub fn attribute(&self, name: &str) -> Option<&'t str> {
        let e = self.elem();
        self.tree.attrs[e.attrs.start as usize..e.attrs.end as usize]
            .iter()
            .find(|a| &self.tree.text[a.name.clone()] == name)
            .map(|a| match &a.value {
                Value::Raw(r) => &self.tree.text[r.clone()],
                Value::Owned(i) => self.tree.owned[*i as usize].as_str(),
            })
    }

    /// Every attribute as (local name, value), in document order.
    pub fn attributes(&self) -> impl Iterator<Item = (&'a str, &'t str)> + use<'t, 'a> {
        let tree = self.tree;
        let e = self.elem();
        tree.attrs[e.attrs.start as usize..e.attrs.end as usize]
            .iter()
            .map(move |a| {
                let v = match &a.value {
                    Value::Raw(r) => &tree.text[r.clone()],
                    Value::Owned(i) => tree.owned[*i as usize].as_str(),
                };
                (&tree.text[a.name.clone()], v)
            })
    }

    /// The element's own text (text and CDATA directly inside it, joined),
    /// when it has any that is not only whitespace.
    pub fn text(&self) -> Option<&'t str> {
        let t = self.elem().text;
        (t != NONE).then(|| self.tree.texts[t as usize].as_str())
    }

    /// Child elements in document order.
    pub fn elements(&self) -> impl Iterator<Item = Node<'t, 'a>> + use<'t, 'a> {
        let tree = self.tree;
        let mut next = self.elem().first_child;
        std::iter::from_fn(move || {
            (next != NONE).then(|| {
                let n = Node { tree, id: next };
                next = tree.elems[next as usize].next_sibling;
                n
            })
        })
    }
}

impl<'a> Tree<'a> {
    /// An empty tree over `text` (filled by [`Stream::next`]).
    pub fn new(text: &'a str) -> Self {
        Self {
            text,
            elems: Vec::new(),
            attrs: Vec::new(),
            owned: Vec::new(),
            texts: Vec::new(),
        }
    }

    fn clear(&mut self) {
        self.elems.clear();
        self.attrs.clear();
        self.owned.clear();
        self.texts.clear();
    }

    /// The subtree's root (the element [`Stream::next`] read).
    pub fn root(&self) -> Node<'_, 'a> {
        Node { tree: self, id: 0 }
    }

    /// Byte range of `s` in the input; `s` must be a slice of it.
    fn range_of(&self, s: &str) -> Option<Range<usize>> {
        let base = self.text.as_ptr() as usize;
        let p = s.as_ptr() as usize;
        (p >= base && p + s.len() <= base + self.text.len()).then(|| p - base..p - base + s.len())
    }

    /// Appends an element read at `start`; links it under `parent`.
    fn push(
        &mut self,
        e: &quick_xml::events::BytesStart<'_>,
        start: usize,
        parent: u32,
    ) -> Result<u32, XmlError> {
        let err = |message: String| XmlError {
            pos: start,
            message,
        };
        let name = self
            .range_of(e.local_name().into_inner())
            .ok_or_else(|| err("element name outside the input".into()))?;
        let a0 = self.attrs.len() as u32;
        // quick-xml's duplicate check hashes once an element has many
        // attributes; a pairwise comparison of the few an OpenDRIVE element
        // has is cheaper (the same error, our wording).
        let mut attrs = e.attributes();
        attrs.with_checks(false);
        for a in attrs {
            let a = a.map_err(|x| err(format!("malformed XML: {x}")))?;
            let qname = a.key.into_inner();
            for prev in &self.attrs[a0 as usize..] {
                if &self.text[prev.qname.clone()] == qname {
                    return Err(err(format!(
                        "malformed XML: attribute '{qname}' appears twice in one element"
                    )));
                }
            }
            let qname = self
                .range_of(qname)
                .ok_or_else(|| err("attribute name outside the input".into()))?;
            let name = self
                .range_of(a.key.local_name().into_inner())
                .ok_or_else(|| err("attribute name outside the input".into()))?;
            let raw = self.range_of(&a.value);
            let value = match raw {
                Some(r) if !self.text[r.clone()].contains('&') => Value::Raw(r),
                _ => {
                    let v = a
                        .normalized_value(quick_xml::XmlVersion::Implicit1_0)
                        .map_err(|x| err(format!("malformed XML: {x}")))?;
                    self.owned.push(v.into_owned());
                    Value::Owned(self.owned.len() as u32 - 1)
                }
            };
            self.attrs.push(Attr { name, qname, value });
        }
        let id = self.elems.len() as u32;
        self.elems.push(Elem {
            name,
            start,
            attrs: a0..self.attrs.len() as u32,
            first_child: NONE,
            last_child: NONE,
            next_sibling: NONE,
            text: NONE,
        });
        if parent != NONE {
            let p = &mut self.elems[parent as usize];
            let last = p.last_child;
            p.last_child = id;
            if last == NONE {
                p.first_child = id;
            } else {
                self.elems[last as usize].next_sibling = id;
            }
        }
        Ok(id)
    }

    fn add_text(&mut self, to: u32, s: &str) {
        let e = &mut self.elems[to as usize];
        if e.text == NONE {
            if s.bytes().all(|b| b.is_ascii_whitespace()) {
                return;
            }
            self.texts.push(String::new());
            e.text = self.texts.len() as u32 - 1;
        }
        self.texts[e.text as usize].push_str(s);
    }
}

/// Reads a document's top-level elements one by one.
pub struct Stream<'a> {
    text: &'a str,
    reader: Reader<&'a [u8]>,
    /// Bytes before what the reader reads (a byte-order mark): added to
    /// its positions.
    base: usize,
    /// The root has no more children.
    done: bool,
}

/// The five predefined entities and character references; others are
/// kept as written.
fn resolve(name: &str) -> Option<String> {
    Some(
        match name {
            "lt" => "<",
            "gt" => ">",
            "amp" => "&",
            "quot" => "\"",
            "apos" => "'",
            _ => {
                let n = name.strip_prefix('#')?;
                let code = match n.strip_prefix('x') {
                    Some(h) => u32::from_str_radix(h, 16).ok()?,
                    None => n.parse().ok()?,
                };
                return char::from_u32(code).map(String::from);
            }
        }
        .to_string(),
    )
}

impl<'a> Stream<'a> {
    /// Starts reading; returns the stream and a tree holding the root
    /// element (with its attributes, without children).
    pub fn open(text: &'a str) -> Result<(Self, Tree<'a>), XmlError> {
        // quick-xml skips a byte-order mark without counting it; dropping
        // it here keeps every position an offset into `text`.
        let body = text.strip_prefix('\u{feff}').unwrap_or(text);
        let mut reader = Reader::from_str(body);
        let c = reader.config_mut();
        c.check_end_names = true;
        c.trim_text(false);
        let mut s = Self {
            text,
            reader,
            base: text.len() - body.len(),
            done: false,
        };
        let mut tree = Tree::new(text);
        loop {
            let at = s.base + s.reader.buffer_position() as usize;
            match s.event()? {
                Event::Start(e) => {
                    tree.push(&e, at, NONE)?;
                    return Ok((s, tree));
                }
                Event::Empty(e) => {
                    tree.push(&e, at, NONE)?;
                    s.done = true;
                    s.finish()?;
                    return Ok((s, tree));
                }
                Event::Text(t) if !t.bytes().all(|b| b.is_ascii_whitespace()) => {
                    return Err(XmlError {
                        pos: at,
                        message: "malformed XML: text before the root element".into(),
                    });
                }
                Event::Eof => {
                    return Err(XmlError {
                        pos: text.len(),
                        message: "malformed XML: no root element".into(),
                    });
                }
                _ => {}
            }
        }
    }

    fn event(&mut self) -> Result<Event<'a>, XmlError> {
        self.reader.read_event().map_err(|e| {
            // An error at the end of the input (an unclosed tag or
            // element) is placed where the input ended.
            let at_end = matches!(
                e,
                quick_xml::Error::Syntax(_)
                    | quick_xml::Error::IllFormed(
                        quick_xml::errors::IllFormedError::MissingEndTag(_)
                    )
            ) && self.base + self.reader.buffer_position() as usize >= self.text.len();
            XmlError {
                pos: if at_end {
                    self.text.len()
                } else {
                    (self.base + self.reader.error_position() as usize).min(self.text.len())
                },
                message: format!("malformed XML: {e}"),
            }
        })
    }

    /// After the root's end: only comments, processing instructions and
    /// whitespace may follow.
    fn finish(&mut self) -> Result<(), XmlError> {
        loop {
            let at = self.base + self.reader.buffer_position() as usize;
            match self.event()? {
                Event::Eof => return Ok(()),
                Event::Start(_) | Event::Empty(_) => {
                    return Err(XmlError {
                        pos: at,
                        message: "malformed XML: a second root element (only comments may follow the first)".into(),
                    });
                }
                Event::Text(t) if !t.bytes().all(|b| b.is_ascii_whitespace()) => {
                    return Err(XmlError {
                        pos: at,
                        message: "malformed XML: text after the root element".into(),
                    });
                }
                _ => {}
            }
        }
    }

    /// Reads the root's next child element with its whole subtree into
    /// `tree` (cleared first); `false` when the root has no more children.
    pub fn next(&mut self, tree: &mut Tree<'a>) -> Result<bool, XmlError> {
        tree.clear();
        if self.done {
            return Ok(false);
        }
        // Open elements of the subtree being read.
        let mut stack: Vec<u32> = Vec::new();
        loop {
            let at = self.base + self.reader.buffer_position() as usize;
            let top = stack.last().copied().unwrap_or(NONE);
            match self.event()? {
                Event::Start(e) => {
                    let id = tree.push(&e, at, top)?;
                    stack.push(id);
                }
                Event::Empty(e) => {
                    tree.push(&e, at, top)?;
                    if stack.is_empty() {
                        return Ok(true);
                    }
                }
                Event::End(_) => {
                    if stack.pop().is_none() {
                        // The root's own end.
                        self.done = true;
                        self.finish()?;
                        return Ok(false);
                    }
                    if stack.is_empty() {
                        return Ok(true);
                    }
                }
                Event::Text(t) if top != NONE => {
                    tree.add_text(top, &t);
                }
                Event::CData(t) if top != NONE => {
                    tree.add_text(top, &t);
                }
                Event::GeneralRef(r) if top != NONE => {
                    let name: &str = &r;
                    let s = resolve(name).unwrap_or_else(|| format!("&{name};"));
                    tree.add_text(top, &s);
                }
                Event::Eof => {
                    return Err(XmlError {
                        pos: self.text.len(),
                        message: "malformed XML: the input ended inside an element".into(),
                    });
                }
                _ => {}
            }
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn read(text: &str) -> Result<Vec<String>, XmlError> {
        let (mut s, root) = Stream::open(text)?;
        let mut out = vec![format!("root {}", root.root().name())];
        let mut t = Tree::new(text);
        while s.next(&mut t)? {
            fn walk(n: Node, depth: usize, out: &mut Vec<String>) {
                let mut line = format!("{}{}@{}", " ".repeat(depth), n.name(), n.start());
                if let Some(v) = n.attribute("v") {
                    line += &format!(" v={v}");
                }
                if let Some(t) = n.text() {
                    line += &format!(" text={t:?}");
                }
                out.push(line);
                for c in n.elements() {
                    walk(c, depth + 1, out);
                }
            }
            walk(t.root(), 0, &mut out);
        }
        Ok(out)
    }

    #[test]
    fn reads_subtrees_with_attributes_text_and_positions() {
        let text = "\u{feff}<!-- licence -->\n<?xml version=\"1.0\"?>\n<ns:R><a v=\"1 &amp; 2\"><b v='x'/><c><![CDATA[+proj=a]]> &lt;b</c></a>\n<d/></ns:R>\n<!-- end -->";
        let got = read(text).unwrap();
        let at = |s: &str| text.find(s).unwrap();
        assert_eq!(
            got,
            [
                "root R".to_string(),
                format!("a@{} v=1 & 2", at("<a")),
                format!(" b@{} v=x", at("<b")),
                format!(" c@{} text=\"+proj=a <b\"", at("<c")),
                format!("d@{}", at("<d")),
            ]
        );
    }

    #[test]
    fn malformed_input_is_an_error_with_a_place() {
        for (text, pos) in [
            ("<R><a></b></R>", 6),
            ("<R><a>", 6),
            ("<R><a x=\"1></a></R>", 19),
            ("", 0),
            ("text", 0),
            ("<R/><S/>", 4),
            ("<R><a x=\"1\" x=\"2\"/></R>", 3),
        ] {
            let e = read(text).expect_err(text);
            assert!(
                e.message.starts_with("malformed XML"),
                "{text}: {}",
                e.message
            );
            assert_eq!(e.pos, pos, "{text}: {}", e.message);
        }
    }
}
