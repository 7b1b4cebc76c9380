//! The page: one HTML file holding three.js, the drawing and the motions, that plays them
//! offline from disk.
//!
//! Everything the page shows from a model or a scene (titles, names, labels) goes in as JSON
//! inside `<script type="application/json">`, with `<`, `>`, `&` and the line separators
//! escaped so that no text can close the element, and the page's script puts it into the
//! document as text, never as markup. The title element gets the HTML-escaped title. The
//! numbers go in as base64 little-endian float64 arrays: exact, so that the page's
//! `window.hamel.poseAt` gives the simulation's poses bit for bit at the output times.

use base64::Engine;
use serde::Serialize;

use crate::drawing::Drawing;
use crate::motion::Motion;
use crate::{THREE_JS, THREE_LICENSE, three_version};

const TEMPLATE: &str = include_str!("../assets/page.html");
const CSS: &str = include_str!("../assets/page.css");
const PAGE_JS: &str = include_str!("../assets/page.js");

/// What a page shows.
#[derive(Clone, Debug)]
pub struct Animation {
    /// The heading (the model's title).
    pub title: String,
    /// A line beside it (the scene, the integrator).
    pub subtitle: String,
    /// What the page draws, or None for a model without bodies (then `note` says why).
    pub drawing: Option<Drawing>,
    /// Shown in place of the 3D view when there is no drawing.
    pub note: Option<String>,
    /// The motions: one, or an ensemble's chosen members.
    pub members: Vec<Motion>,
}

#[derive(Serialize)]
struct Data<'a> {
    title: &'a str,
    subtitle: &'a str,
    note: Option<&'a str>,
    drawing: Option<&'a Drawing>,
    members: Vec<MotionData<'a>>,
}

#[derive(Serialize)]
struct MotionData<'a> {
    label: &'a str,
    t: String,
    poses: String,
    tracks: String,
    series: Vec<SeriesData<'a>>,
    arrows: Vec<ArrowData<'a>>,
}

#[derive(Serialize)]
struct SeriesData<'a> {
    name: &'a str,
    values: String,
}

#[derive(Serialize)]
struct ArrowData<'a> {
    name: &'a str,
    contact: usize,
    vectors: String,
}

/// `values` as base64 of their little-endian bytes.
fn packed(values: impl IntoIterator<Item = f64>) -> String {
    let bytes: Vec<u8> = values.into_iter().flat_map(f64::to_le_bytes).collect();
    base64::engine::general_purpose::STANDARD.encode(bytes)
}

impl Animation {
    /// The page.
    pub fn html(&self) -> String {
        let data = Data {
            title: &self.title,
            subtitle: &self.subtitle,
            note: self.note.as_deref(),
            drawing: self.drawing.as_ref(),
            members: self.members.iter().map(motion_data).collect(),
        };
        let json = serde_json::to_string(&data).expect("the page's data serialises");
        fill(&[
            ("VERSION", env!("CARGO_PKG_VERSION")),
            ("TITLE", &escape_html(&self.title)),
            ("CSS", CSS),
            ("THREE_VERSION", three_version()),
            ("THREE_LICENSE", &escape_html(THREE_LICENSE)),
            ("DATA", &escape_json_in_script(&json)),
            ("THREE", THREE_JS),
            ("PAGE_JS", PAGE_JS),
        ])
    }
}

fn motion_data(m: &Motion) -> MotionData<'_> {
    MotionData {
        label: &m.label,
        t: packed(m.t.iter().copied()),
        poses: packed(m.poses.iter().copied()),
        tracks: packed(m.tracks.iter().copied()),
        series: m
            .series
            .iter()
            .map(|s| SeriesData {
                name: &s.name,
                values: packed(s.values.iter().map(|v| v.unwrap_or(f64::NAN))),
            })
            .collect(),
        arrows: m
            .arrows
            .iter()
            .map(|a| ArrowData {
                name: &a.name,
                contact: a.contact,
                vectors: packed(a.vectors.iter().copied()),
            })
            .collect(),
    }
}

/// The template with each `{{KEY}}` replaced once, in one pass: what is put in is never
/// searched for keys again.
fn fill(values: &[(&str, &str)]) -> String {
    let mut out =
        String::with_capacity(TEMPLATE.len() + values.iter().map(|v| v.1.len()).sum::<usize>());
    let mut rest = TEMPLATE;
    while let Some(open) = rest.find("{{") {
        let close = open
            + rest[open..]
                .find("}}")
                .expect("a closed key in the template");
        let key = &rest[open + 2..close];
        let value = values.iter().find(|v| v.0 == key).expect("a known key");
        out.push_str(&rest[..open]);
        out.push_str(value.1);
        rest = &rest[close + 2..];
    }
    out.push_str(rest);
    out
}

/// Text as HTML element content.
pub fn escape_html(text: &str) -> String {
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

/// JSON that may sit inside a `<script>` element: `<`, `>`, `&` and U+2028/2029 as JSON
/// escapes (they occur in JSON only inside strings, where the escapes mean the same).
pub fn escape_json_in_script(json: &str) -> String {
    let mut out = String::with_capacity(json.len());
    for c in json.chars() {
        match c {
            '<' => out.push_str("\\u003c"),
            '>' => out.push_str("\\u003e"),
            '&' => out.push_str("\\u0026"),
            '\u{2028}' => out.push_str("\\u2028"),
            '\u{2029}' => out.push_str("\\u2029"),
            c => out.push(c),
        }
    }
    out
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::motion::Series;

    const HOSTILE: &str =
        "</script><script>alert(1)</script><img src=x onerror=alert(2)>&amp;\u{2028}";

    /// Hostile text from a model or a scene (its title, an output's name, a member's label)
    /// cannot close an element or open one: the page holds exactly its own three scripts, and
    /// the text comes back whole from the JSON.
    #[test]
    fn hostile_names_stay_text() {
        let a = Animation {
            title: HOSTILE.into(),
            subtitle: HOSTILE.into(),
            drawing: None,
            note: Some(HOSTILE.into()),
            members: vec![Motion {
                label: HOSTILE.into(),
                t: vec![0.0, 1.0],
                series: vec![Series {
                    name: HOSTILE.into(),
                    values: vec![Some(1.0), None],
                }],
                ..Motion::default()
            }],
        };
        let html = a.html();
        assert_eq!(html.matches("<script").count(), 3);
        assert_eq!(html.matches("</script").count(), 3);
        assert!(!html.contains("<img"));
        let start = html.find("id=\"hamel-data\">").unwrap() + 16;
        let end = start + html[start..].find("</script>").unwrap();
        // A line separator would end a line of a script in old engines: escaped in the data.
        assert!(!html[start..end].contains('\u{2028}'));
        let data: serde_json::Value = serde_json::from_str(&html[start..end]).unwrap();
        assert_eq!(data["title"], HOSTILE);
        assert_eq!(data["members"][0]["series"][0]["name"], HOSTILE);
        assert!(html.contains("<title>&lt;/script&gt;&lt;script&gt;alert(1)"));
    }

    /// The numbers cross exactly: base64 of little-endian float64, a missing value NaN.
    #[test]
    fn numbers_are_packed_exactly() {
        use base64::Engine;
        let values = [0.1, -1.0 / 3.0, f64::MIN_POSITIVE, 1e300];
        let bytes = base64::engine::general_purpose::STANDARD
            .decode(packed(values))
            .unwrap();
        let back: Vec<f64> = bytes
            .chunks(8)
            .map(|c| f64::from_le_bytes(c.try_into().unwrap()))
            .collect();
        assert_eq!(back, values);
    }

    /// The bundled script cannot end its element early.
    #[test]
    fn the_scripts_do_not_close_their_element() {
        for script in [THREE_JS, PAGE_JS] {
            assert!(!script.to_ascii_lowercase().contains("</script"));
        }
    }
}
