//! The statistics report: pbrt-style `Category/Title` rows, printed as a table and saved as nested JSON
//! (a dotted key `time.total_s` becomes `{"time": {"total_s": …}}`).

use serde_json::{Map, Value};

#[derive(Clone, Debug)]
pub struct Row {
    pub category: String,
    pub title: String,
    pub key: String,
    pub value: Value,
    pub shown: String,
}

#[derive(Clone, Debug, Default)]
pub struct Report {
    pub rows: Vec<Row>,
}

pub fn fmt_count(n: f64) -> String {
    if n >= 1e9 {
        format!("{:.2} G", n / 1e9)
    } else if n >= 1e6 {
        format!("{:.2} M", n / 1e6)
    } else if n >= 1e4 {
        format!("{:.1} k", n / 1e3)
    } else if n.fract() == 0.0 {
        format!("{n}")
    } else {
        format!("{n:.3}")
    }
}

impl Report {
    fn push(&mut self, category: &str, title: &str, key: &str, value: Value, shown: String) {
        self.rows.push(Row {
            category: category.into(),
            title: title.into(),
            key: key.into(),
            value,
            shown,
        });
    }

    pub fn count(&mut self, category: &str, title: &str, key: &str, n: u64) {
        self.push(category, title, key, Value::from(n), fmt_count(n as f64));
    }

    pub fn number(&mut self, category: &str, title: &str, key: &str, x: f64) {
        self.push(category, title, key, Value::from(x), fmt_count(x));
    }

    pub fn seconds(&mut self, category: &str, title: &str, key: &str, s: f64) {
        self.push(category, title, key, Value::from(s), format!("{s:.3} s"));
    }

    pub fn bytes(&mut self, category: &str, title: &str, key: &str, b: u64) {
        self.push(
            category,
            title,
            key,
            Value::from(b),
            format!("{:.2} MiB", b as f64 / (1 << 20) as f64),
        );
    }

    pub fn percent(&mut self, category: &str, title: &str, key: &str, fraction: f64) {
        self.push(
            category,
            title,
            key,
            Value::from(fraction),
            format!("{:.2} %", fraction * 100.0),
        );
    }

    pub fn text(&mut self, category: &str, title: &str, key: &str, s: &str) {
        self.push(category, title, key, Value::from(s), s.to_string());
    }

    /// A row shown in the table but stored as an arbitrary JSON value.
    pub fn value(&mut self, category: &str, title: &str, key: &str, v: Value, shown: String) {
        self.push(category, title, key, v, shown);
    }

    pub fn to_json(&self) -> Value {
        let mut root = Map::new();
        for r in &self.rows {
            let parts: Vec<&str> = r.key.split('.').collect();
            let mut node = &mut root;
            for p in &parts[..parts.len() - 1] {
                let entry = node
                    .entry(p.to_string())
                    .or_insert_with(|| Value::Object(Map::new()));
                if !entry.is_object() {
                    *entry = Value::Object(Map::new());
                }
                node = entry.as_object_mut().expect("just made an object");
            }
            node.insert(parts[parts.len() - 1].to_string(), r.value.clone());
        }
        Value::Object(root)
    }

    /// The report as a table no wider than [`TABLE_COLUMNS`]: rows grouped under their categories in
    /// first-seen order, values right-aligned in one column. A title too long for its column is
    /// wrapped at spaces onto indented continuation lines, its value on the first.
    pub fn table(&self) -> String {
        let value_width = self
            .rows
            .iter()
            .map(|r| r.shown.chars().count())
            .max()
            .unwrap_or(0)
            .max(MIN_VALUE_WIDTH);
        let title_max = TABLE_COLUMNS
            .saturating_sub(ROW_INDENT + 1 + value_width)
            .max(MIN_TITLE_WIDTH);
        let title_width = self
            .rows
            .iter()
            .map(|r| r.title.chars().count())
            .max()
            .unwrap_or(0)
            .min(title_max);
        let mut order: Vec<&str> = Vec::new();
        for r in &self.rows {
            if !order.contains(&r.category.as_str()) {
                order.push(&r.category);
            }
        }
        let mut rows: Vec<&Row> = self.rows.iter().collect();
        rows.sort_by_key(|r| order.iter().position(|c| *c == r.category));
        let mut out = String::from("Statistics\n");
        let mut last = "";
        for r in rows {
            if r.category != last {
                out.push_str(&format!("  {}\n", r.category));
                last = &r.category;
            }
            let rest_width = title_width.saturating_sub(WRAP_INDENT);
            let lines = wrap(&r.title, title_width, rest_width);
            let (first, rest) = lines.split_first().expect("wrap returns at least one line");
            out.push_str(&format!(
                "{:ROW_INDENT$}{first:<title_width$} {:>value_width$}\n",
                "", r.shown
            ));
            for line in rest {
                out.push_str(&format!("{:w$}{line}\n", "", w = ROW_INDENT + WRAP_INDENT));
            }
        }
        out
    }
}

/// Widest line of [`Report::table`], in characters, for values up to
/// `TABLE_COLUMNS - ROW_INDENT - 1 - MIN_TITLE_WIDTH` characters.
pub const TABLE_COLUMNS: usize = 100;
/// Indent of a row under its category.
const ROW_INDENT: usize = 4;
/// Further indent of a long title's continuation lines.
const WRAP_INDENT: usize = 2;
const MIN_VALUE_WIDTH: usize = 16;
const MIN_TITLE_WIDTH: usize = 24;

/// `text` broken at spaces into lines of at most `first_width` characters, then `rest_width`; a word
/// longer than its line is cut. At least one line, empty for an empty text.
fn wrap(text: &str, first_width: usize, rest_width: usize) -> Vec<String> {
    let mut lines = Vec::new();
    let mut line = String::new();
    let width = |lines: &Vec<String>| {
        if lines.is_empty() {
            first_width
        } else {
            rest_width
        }
    };
    for word in text.split_whitespace() {
        let mut word = word;
        while !word.is_empty() {
            let (used, len) = (line.chars().count(), word.chars().count());
            let sep = usize::from(used > 0);
            if used + sep + len <= width(&lines) {
                if sep == 1 {
                    line.push(' ');
                }
                line.push_str(word);
                break;
            }
            if used > 0 {
                lines.push(std::mem::take(&mut line));
                continue;
            }
            let cut = word
                .char_indices()
                .nth(width(&lines).max(1))
                .map_or(word.len(), |(i, _)| i);
            lines.push(word[..cut].to_string());
            word = &word[cut..];
        }
    }
    if !line.is_empty() || lines.is_empty() {
        lines.push(line);
    }
    lines
}

/// Peak resident set size of this process, from /proc (0 where unavailable).
pub fn peak_rss_bytes() -> u64 {
    std::fs::read_to_string("/proc/self/status")
        .ok()
        .and_then(|s| {
            s.lines().find(|l| l.starts_with("VmHWM:")).and_then(|l| {
                l.split_whitespace()
                    .nth(1)
                    .and_then(|k| k.parse::<u64>().ok())
            })
        })
        .map(|kb| kb * 1024)
        .unwrap_or(0)
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn dotted_keys_nest() {
        let mut r = Report::default();
        r.seconds("Time", "Total", "time.total_s", 1.5);
        r.count("Rays", "Total", "rays.total", 10);
        let j = r.to_json();
        assert_eq!(j["time"]["total_s"], 1.5);
        assert_eq!(j["rays"]["total"], 10);
    }

    #[test]
    fn long_titles_wrap_within_the_width_with_values_aligned() {
        let long =
            "Pixels' relative variance from gather noise, at 250 rays (predicted; target 1e-4) \
                    and then some more words to need a third line of the title column";
        let word = "x".repeat(150);
        let mut r = Report::default();
        r.count("Photons", "Paths emitted", "photons.paths", 1_160_000);
        r.number("Final gather", long, "gather.noise", 1.27e-4);
        r.text("Render", "Method", "render.method", "pm");
        r.count("Photons", &word, "photons.word", 7);
        r.value(
            "Irradiance cache",
            "Record radius (px) avg [min–max]",
            "icache.radius_px",
            Value::from(4.2),
            "4.2 [3.0–14.9]".into(),
        );
        let table = r.table();
        for l in table.lines() {
            assert!(l.chars().count() <= TABLE_COLUMNS, "too wide: {l:?}");
        }
        // Each row: its first line (indented 4) ends with the value, flush with the value column's
        // right edge; its continuation lines (indented 6) carry only title text.
        let mut rows: Vec<(String, Vec<String>)> = Vec::new();
        for l in table.lines() {
            if let Some(rest) = l.strip_prefix("      ") {
                rows.last_mut()
                    .expect("a row first")
                    .1
                    .push(rest.to_string());
            } else if let Some(row) = l.strip_prefix("    ") {
                rows.push((row.to_string(), Vec::new()));
            }
        }
        assert_eq!(rows.len(), r.rows.len(), "{table}");
        let width = rows[0].0.chars().count();
        let expected = [
            ("Paths emitted", "1.16 M"),
            (word.as_str(), "7"),
            (long, "0.000"),
            ("Method", "pm"),
            ("Record radius (px) avg [min–max]", "4.2 [3.0–14.9]"),
        ];
        for ((first, more), (title, shown)) in rows.iter().zip(expected) {
            assert_eq!(first.chars().count(), width, "{first:?}");
            let first = first.strip_suffix(shown).expect("the value ends the line");
            let mut lines = vec![first.trim_end()];
            lines.extend(more.iter().map(String::as_str));
            if title == word {
                assert_eq!(lines.concat(), word, "a word longer than the column is cut");
            } else {
                assert_eq!(lines.join(" "), title, "wrapped at spaces");
            }
            assert_eq!(
                more.is_empty(),
                title.chars().count() <= width - 1 - MIN_VALUE_WIDTH,
                "{title}"
            );
        }
    }

    #[test]
    fn short_titles_keep_one_line_each() {
        let mut r = Report::default();
        r.count("Rays", "Total", "rays.total", 10);
        r.seconds("Time", "Total", "time.total_s", 1.5);
        let table = r.table();
        assert_eq!(table.lines().count(), 5, "{table}");
        assert!(
            table.contains(&format!("    Total {:>16}\n", "10")),
            "{table}"
        );
    }
}
