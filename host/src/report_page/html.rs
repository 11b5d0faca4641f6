//! The HTML the page is made of: text escaped for an element or an
//! attribute, tables (plain and in groups of rows), figures and numbers.
//! Everything a file or a user named passes through [`escape`] before it
//! reaches the page.

use std::fmt::Write;

/// `text` with the five characters HTML gives a meaning to replaced by
/// their entities, safe in an element's text and in a quoted attribute.
pub fn escape(text: &str) -> String {
    let mut out = String::with_capacity(text.len());
    for c in text.chars() {
        match c {
            '&' => out.push_str("&amp;"),
            '<' => out.push_str("&lt;"),
            '>' => out.push_str("&gt;"),
            '"' => out.push_str("&quot;"),
            '\'' => out.push_str("&#39;"),
            c => out.push(c),
        }
    }
    out
}

/// The opening of a table with an id, a caption and a header row, escaped,
/// up to its body.
fn table_head(id: &str, caption: &str, head: &[&str]) -> String {
    let mut out = format!(
        "<table id=\"{}\">\n<caption>{}</caption>\n<thead><tr>",
        escape(id),
        escape(caption)
    );
    for h in head {
        let _ = write!(out, "<th scope=\"col\">{}</th>", escape(h));
    }
    out.push_str("</tr></thead>\n");
    out
}

/// A table with an id, a caption, a header row and body rows; every cell
/// and the caption are escaped here.
pub fn table(id: &str, caption: &str, head: &[&str], rows: &[Vec<String>]) -> String {
    let mut out = table_head(id, caption, head);
    out.push_str("<tbody>\n");
    for row in rows {
        out.push_str("<tr>");
        for cell in row {
            let _ = write!(out, "<td>{}</td>", escape(cell));
        }
        out.push_str("</tr>\n");
    }
    out.push_str("</tbody>\n</table>\n");
    out
}

/// A table whose body rows come in named groups, each its own `<tbody>`
/// headed by a row naming it (`<th scope="rowgroup">`); every cell, group
/// name and the caption are escaped here.
pub fn grouped_table(
    id: &str,
    caption: &str,
    head: &[&str],
    groups: &[(String, Vec<Vec<String>>)],
) -> String {
    let mut out = table_head(id, caption, head);
    for (name, rows) in groups {
        let _ = write!(
            out,
            "<tbody>\n<tr><th scope=\"rowgroup\" colspan=\"{}\">{}</th></tr>\n",
            head.len().max(1),
            escape(name)
        );
        for row in rows {
            out.push_str("<tr>");
            for cell in row {
                let _ = write!(out, "<td>{}</td>", escape(cell));
            }
            out.push_str("</tr>\n");
        }
        out.push_str("</tbody>\n");
    }
    out.push_str("</table>\n");
    out
}

/// A figure: its id, the drawing (inline SVG, trusted: drawn here) and an
/// escaped caption.
pub fn figure(id: &str, svg: &str, caption: &str) -> String {
    format!(
        "<figure id=\"{}\">\n{svg}\n<figcaption>{}</figcaption>\n</figure>\n",
        escape(id),
        escape(caption)
    )
}

/// A paragraph of escaped text.
pub fn para(text: &str) -> String {
    format!("<p>{}</p>\n", escape(text))
}

/// A number with `decimals` decimals, or `–` when it is not finite (a
/// figure the run could not work out).
pub fn num(value: f64, decimals: usize) -> String {
    if value.is_finite() {
        format!("{value:.decimals$}")
    } else {
        "–".into()
    }
}

/// An optional number as [`num`], `–` when absent.
pub fn opt_num(value: Option<f64>, decimals: usize) -> String {
    value.map_or_else(|| "–".into(), |v| num(v, decimals))
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn escapes_markup_in_text_and_attributes() {
        assert_eq!(
            escape(r#"<script>alert("x") & 'y'</script>"#),
            "&lt;script&gt;alert(&quot;x&quot;) &amp; &#39;y&#39;&lt;/script&gt;"
        );
        assert_eq!(escape("pose 12, 0.0663 kg, ±3°"), "pose 12, 0.0663 kg, ±3°");
    }

    #[test]
    fn a_table_escapes_every_cell_and_its_caption() {
        let t = table(
            "t\"1",
            "a <b>",
            &["name", "<th>"],
            &[vec!["<img src=x>".into(), "1".into()]],
        );
        assert!(t.starts_with("<table id=\"t&quot;1\">"), "{t}");
        assert!(t.contains("<caption>a &lt;b&gt;</caption>"), "{t}");
        assert!(t.contains("<th scope=\"col\">&lt;th&gt;</th>"), "{t}");
        assert!(t.contains("<td>&lt;img src=x&gt;</td><td>1</td>"), "{t}");
        assert!(!t.contains("<img"), "{t}");
    }

    #[test]
    fn a_grouped_table_heads_each_group_and_escapes_its_name() {
        let t = grouped_table(
            "g",
            "c",
            &["a", "b"],
            &[
                ("joint 1".into(), vec![vec!["x".into(), "1".into()]]),
                ("<base>".into(), vec![vec!["y".into(), "2".into()]]),
            ],
        );
        assert_eq!(t.matches("<tbody>").count(), 2, "{t}");
        assert!(
            t.contains("<tbody>\n<tr><th scope=\"rowgroup\" colspan=\"2\">joint 1</th></tr>\n<tr><td>x</td><td>1</td></tr>"),
            "{t}"
        );
        assert!(t.contains(">&lt;base&gt;</th>"), "{t}");
    }

    #[test]
    fn numbers_that_could_not_be_worked_out_read_as_a_dash() {
        assert_eq!(num(1.23456, 2), "1.23");
        assert_eq!(num(f64::NAN, 2), "–");
        assert_eq!(num(f64::INFINITY, 1), "–");
        assert_eq!(opt_num(None, 1), "–");
        assert_eq!(opt_num(Some(0.5), 1), "0.5");
    }
}
