//! `report.html`: one self-contained page per study for a design review —
//! the verdict, the question asked, the sensor models, the figures as inline
//! SVG and the tables. No script, no external resource, no timestamp (the
//! same study gives the same bytes).

use super::Exporter;
use crate::error::Result;
use crate::sensors::{Axis, ARCSEC_PER_RAD};
use std::fmt::Write as _;

/// One sensor model as the page lists it.
#[derive(Debug, Clone)]
pub struct SensorLine {
    pub name: String,
    pub price: Option<f64>,
    /// Unit of the model's amplitudes ("″" or "µm").
    pub unit: &'static str,
    pub axis: Option<Axis>,
    /// For a white-noise reading: σ of one sample in `unit`.
    pub sigma: Option<f64>,
}

/// A table: caption, header, rows of cells (already formatted).
#[derive(Debug, Clone, Default)]
pub struct Table {
    pub caption: String,
    pub header: Vec<String>,
    pub rows: Vec<Vec<String>>,
}

/// Everything on the page.
#[derive(Debug, Clone, Default)]
pub struct StudyPage {
    pub title: String,
    pub answer: String,
    /// The question: (label, value) lines.
    pub question: Vec<(String, String)>,
    /// The sensor models, one table each: (caption, lines).
    pub sensors: Vec<(String, Vec<SensorLine>)>,
    /// (caption, SVG text).
    pub figures: Vec<(String, String)>,
    pub tables: Vec<Table>,
    pub assumptions: Vec<String>,
}

/// Renders a [`StudyPage`] as HTML.
pub struct HtmlExporter;

/// Text made safe for HTML.
pub fn escape(s: &str) -> String {
    let mut out = String::with_capacity(s.len());
    for c in s.chars() {
        match c {
            '&' => out.push_str("&amp;"),
            '<' => out.push_str("&lt;"),
            '>' => out.push_str("&gt;"),
            '"' => out.push_str("&quot;"),
            _ => out.push(c),
        }
    }
    out
}

const STYLE: &str = "body{font-family:'DejaVu Sans',Verdana,sans-serif;max-width:1180px;margin:2em auto;padding:0 1em;color:#222;line-height:1.45}\
h1{font-size:1.6em}h2{font-size:1.25em;margin-top:2em;border-bottom:1px solid #ccc}\
.verdict{background:#eef6ee;border-left:6px solid #2c7a2c;padding:.8em 1.2em;font-size:1.08em}.verdict p{margin:.2em 0 .6em}\
table{border-collapse:collapse;margin:.6em 0 1.4em;font-size:.88em}th,td{border:1px solid #ccc;padding:.25em .6em;text-align:right}\
th{background:#f3f3f3}td:first-child,th:first-child{text-align:left}caption{text-align:left;font-weight:bold;padding:.3em 0}\
figure{margin:1.2em 0}figure svg{max-width:100%;height:auto;border:1px solid #eee}figcaption{font-size:.9em;color:#555}\
dl{display:grid;grid-template-columns:max-content auto;gap:.2em 1.2em}dt{font-weight:bold}dd{margin:0}";

fn model_cells(l: &SensorLine) -> Vec<String> {
    let scale = if l.unit == "″" { ARCSEC_PER_RAD } else { 1e3 };
    let f = |v: f64| format!("{:.4}", v * scale);
    match (&l.axis, l.sigma) {
        // As the entry states them: a two-head kit's jitter and resolution
        // are each head's (the model holds the pair's mean, ÷√2).
        (Some(a), _) => {
            let head = if a.readheads == 2 {
                std::f64::consts::SQRT_2
            } else {
                1.0
            };
            vec![
                format!("±{}", f(a.accuracy)),
                a.shape_text(scale, l.unit),
                f(a.interpolation),
                f(a.signal_period),
                f(a.noise * head),
                f(a.resolution * head),
            ]
        }
        (None, Some(s)) => vec![
            format!("σ {s}"),
            "white noise".into(),
            "0".into(),
            "0".into(),
            format!("{s}"),
            "0".into(),
        ],
        _ => vec![String::new(); 6],
    }
}

fn table(s: &mut String, t: &Table) {
    let _ = write!(s, "<table><caption>{}</caption><tr>", escape(&t.caption));
    for h in &t.header {
        let _ = write!(s, "<th>{}</th>", escape(h));
    }
    s.push_str("</tr>");
    for r in &t.rows {
        s.push_str("<tr>");
        for c in r {
            let _ = write!(s, "<td>{}</td>", escape(c));
        }
        s.push_str("</tr>");
    }
    s.push_str("</table>\n");
}

impl Exporter<StudyPage> for HtmlExporter {
    fn render(&self, p: &StudyPage) -> Result<Vec<u8>> {
        let mut s = String::new();
        let _ = write!(
            s,
            "<!DOCTYPE html>\n<html lang=\"en\"><head><meta charset=\"utf-8\"><title>{}</title><style>{STYLE}</style></head><body>\n",
            escape(&p.title)
        );
        let _ = writeln!(s, "<h1>{}</h1>", escape(&p.title));
        // The verdict in its parts (the choice, what-ifs, the assembly, the
        // assumptions), one paragraph each.
        s.push_str("<h2>Verdict</h2><div class=\"verdict\">");
        for part in super::verdict::paragraphs(&p.answer) {
            let _ = write!(s, "<p>{}</p>", escape(part));
        }
        s.push_str("</div>\n");
        s.push_str("<h2>The question</h2><dl>");
        for (k, v) in &p.question {
            let _ = write!(s, "<dt>{}</dt><dd>{}</dd>", escape(k), escape(v));
        }
        s.push_str("</dl>\n<h2>Sensor models</h2>\n");
        for (caption, lines) in &p.sensors {
            let unit = lines.first().map_or("", |l| l.unit);
            let header = [
                "product",
                "price",
                "grade",
                "harmonics (fractions of the grade) and mounting",
                "interpolation",
                "signal period",
                "jitter σ",
                "resolution",
            ]
            .iter()
            .map(|h| {
                if *h == "product" || *h == "price" || h.starts_with("harmonics") {
                    h.to_string()
                } else {
                    format!("{h} ({unit})")
                }
            })
            .collect();
            let rows = lines
                .iter()
                .map(|l| {
                    let mut r = vec![
                        l.name.clone(),
                        l.price.map_or(String::new(), |p| format!("{p:.0}")),
                    ];
                    r.extend(model_cells(l));
                    r
                })
                .collect();
            table(
                &mut s,
                &Table {
                    caption: caption.clone(),
                    header,
                    rows,
                },
            );
        }
        if !p.figures.is_empty() {
            s.push_str("<h2>Figures</h2>\n");
        }
        for (caption, svg) in &p.figures {
            let _ = writeln!(
                s,
                "<figure>{svg}<figcaption>{}</figcaption></figure>",
                escape(caption)
            );
        }
        s.push_str("<h2>Tables</h2>\n");
        for t in &p.tables {
            table(&mut s, t);
        }
        s.push_str("<h2>Assumptions</h2><ul>");
        for a in &p.assumptions {
            let _ = write!(s, "<li>{}</li>", escape(a));
        }
        s.push_str("</ul>\n</body></html>\n");
        Ok(s.into_bytes())
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn text_is_escaped_and_the_page_is_whole() {
        let page = StudyPage {
            title: "a <b> & \"c\"".into(),
            answer: "buy <this>".into(),
            figures: vec![("f".into(), "<svg></svg>".into())],
            ..StudyPage::default()
        };
        let html = String::from_utf8(HtmlExporter.render(&page).unwrap()).unwrap();
        assert!(html.contains("a &lt;b&gt; &amp; &quot;c&quot;"));
        assert!(html.contains("buy &lt;this&gt;"));
        assert!(html.contains("<figure><svg></svg>"), "SVG is inlined as is");
        assert!(html.starts_with("<!DOCTYPE html>") && html.trim_end().ends_with("</html>"));
        assert!(!html.contains("<script"));
    }

    /// A two-head kit's jitter and resolution show as its entry states
    /// them (0.005″), not as the pair's mean the model holds (0.0035″).
    #[test]
    fn a_two_head_entry_shows_as_written() {
        let r = 0.005 / ARCSEC_PER_RAD;
        let a = Axis {
            accuracy: 2.0 / ARCSEC_PER_RAD,
            readheads: 2,
            noise: 0.02 / ARCSEC_PER_RAD * std::f64::consts::FRAC_1_SQRT_2,
            resolution: r * std::f64::consts::FRAC_1_SQRT_2,
            ..Axis::default()
        };
        let mut line = SensorLine {
            name: "e".into(),
            price: None,
            unit: "″",
            axis: Some(a),
            sigma: None,
        };
        let cells = model_cells(&line);
        assert_eq!(cells[4], "0.0200");
        assert_eq!(cells[5], "0.0050");
        let mut one = a;
        one.readheads = 1;
        line.axis = Some(one);
        assert_eq!(model_cells(&line)[5], "0.0035");
    }
}
