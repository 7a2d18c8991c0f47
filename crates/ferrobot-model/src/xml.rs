//! Size and nesting limits checked on XML text before any parser sees it.
//!
//! The XML parsers under the URDF and SRDF readers recurse per nesting
//! level: a document nested some thousands of levels deep overflowed the
//! stack (a segfault that killed the Python process). Real robot
//! descriptions nest fewer than ten levels, so a document deeper than
//! [`crate::ranges::MAX_XML_DEPTH`] or larger than
//! [`crate::ranges::MAX_XML_BYTES`] is refused here, with a linear scan that
//! keeps no stack.

use crate::ranges::{MAX_XML_BYTES, MAX_XML_DEPTH};

/// Why a document was refused: the message and the 1-based line.
#[derive(Debug, Clone, PartialEq, Eq)]
pub struct XmlLimitError {
    /// What is wrong.
    pub message: String,
    /// Line of the offending tag, where known.
    pub line: Option<u32>,
}

fn find(b: &[u8], from: usize, pat: &[u8]) -> Option<usize> {
    if from >= b.len() {
        return None;
    }
    b[from..]
        .windows(pat.len())
        .position(|w| w == pat)
        .map(|p| from + p)
}

/// Checks `text` against the size and depth limits. Start tags (outside
/// comments, CDATA sections, processing instructions and declarations)
/// count one level until their end tag; self-closing tags count none.
/// Malformed documents pass through (the parser reports them) unless they
/// exceed a limit.
pub fn check_limits(text: &str) -> Result<(), XmlLimitError> {
    check_limits_with(text, MAX_XML_DEPTH, MAX_XML_BYTES)
}

/// [`check_limits`] with explicit limits.
pub fn check_limits_with(
    text: &str,
    max_depth: usize,
    max_bytes: usize,
) -> Result<(), XmlLimitError> {
    if text.len() > max_bytes {
        return Err(XmlLimitError {
            message: format!(
                "document of {} bytes exceeds the limit of {max_bytes} bytes",
                text.len()
            ),
            line: None,
        });
    }
    let b = text.as_bytes();
    let mut depth = 0usize;
    let mut i = 0usize;
    while let Some(off) = b[i..].iter().position(|&c| c == b'<') {
        i += off;
        let rest = &b[i..];
        let skip_to = |pat: &[u8]| find(b, i + 1, pat).map(|p| p + pat.len());
        let next = if rest.starts_with(b"<!--") {
            skip_to(b"-->")
        } else if rest.starts_with(b"<![CDATA[") {
            skip_to(b"]]>")
        } else if rest.starts_with(b"<?") {
            skip_to(b"?>")
        } else if rest.starts_with(b"<!") {
            skip_to(b">")
        } else if rest.starts_with(b"</") {
            depth = depth.saturating_sub(1);
            skip_to(b">")
        } else {
            // A start tag: find its end outside quoted attribute values.
            let mut j = i + 1;
            let mut quote: Option<u8> = None;
            let mut end = None;
            while j < b.len() {
                let c = b[j];
                match quote {
                    Some(q) if c == q => quote = None,
                    Some(_) => {}
                    None if c == b'"' || c == b'\'' => quote = Some(c),
                    None if c == b'>' => {
                        end = Some(j);
                        break;
                    }
                    None => {}
                }
                j += 1;
            }
            match end {
                Some(e) => {
                    if b[e - 1] != b'/' {
                        depth += 1;
                        if depth > max_depth {
                            let line = 1 + b[..i].iter().filter(|&&c| c == b'\n').count();
                            return Err(XmlLimitError {
                                message: format!(
                                    "elements nested more than {max_depth} levels deep"
                                ),
                                line: Some(u32::try_from(line).unwrap_or(u32::MAX)),
                            });
                        }
                    }
                    Some(e + 1)
                }
                None => None,
            }
        };
        match next {
            Some(n) => i = n,
            None => break,
        }
    }
    Ok(())
}

/// Line numbers of byte offsets in one document. roxmltree's
/// `Document::text_pos_at` scans the text from the start on every call, so
/// asking it for each element's line made loading quadratic in the number
/// of elements (10,000 links took 26 s); this index is built once (one scan)
/// and answers by binary search.
#[derive(Debug, Clone)]
pub struct LineIndex {
    /// Byte offset of the start of each line after the first.
    starts: Vec<usize>,
}

impl LineIndex {
    /// Indexes the line starts of `text`.
    pub fn new(text: &str) -> Self {
        let starts = text
            .bytes()
            .enumerate()
            .filter(|&(_, c)| c == b'\n')
            .map(|(i, _)| i + 1)
            .collect();
        Self { starts }
    }

    /// The 1-based line of byte offset `pos` (as `text_pos_at(pos).row`).
    pub fn line(&self, pos: usize) -> u32 {
        let line = 1 + self.starts.partition_point(|&s| s <= pos);
        u32::try_from(line).unwrap_or(u32::MAX)
    }

    /// The 1-based line where `node` starts.
    pub fn line_of(&self, node: roxmltree::Node) -> u32 {
        self.line(node.range().start)
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn nested(n: usize) -> String {
        format!("<robot>{}{}</robot>", "<a>".repeat(n), "</a>".repeat(n))
    }

    #[test]
    fn depth_limit_counts_start_tags_only() {
        assert!(check_limits_with(&nested(9), 10, 1 << 20).is_ok());
        let e = check_limits_with(&nested(10), 10, 1 << 20).unwrap_err();
        assert_eq!(e.line, Some(1));
        // Self-closing tags, comments, CDATA, PIs and quoted '>' do not nest.
        let flat = format!(
            "<?xml version=\"1.0\"?><!-- <a><a><a> --><r>{}<![CDATA[<a><a>]]><b x=\"1>2\" y='/'/></r>",
            "<c/>".repeat(100)
        );
        assert!(check_limits_with(&flat, 2, 1 << 20).is_ok());
    }

    #[test]
    fn line_index_matches_roxmltree() {
        let text = "<robot>\n<a/>\r\n\n  <b x='1'>\n</b>\n<c/></robot>";
        let doc = roxmltree::Document::parse(text).unwrap();
        let index = LineIndex::new(text);
        for node in doc.descendants() {
            let pos = node.range().start;
            assert_eq!(index.line(pos), doc.text_pos_at(pos).row, "{node:?}");
        }
        for pos in 0..=text.len() {
            assert_eq!(index.line(pos), doc.text_pos_at(pos).row, "{pos}");
        }
    }

    #[test]
    fn size_limit() {
        assert!(check_limits_with("<r/>", 10, 3).is_err());
    }
}
