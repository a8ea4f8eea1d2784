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

    pub fn table(&self) -> String {
        let mut out = String::from("Statistics\n");
        let mut last = "";
        let mut order: Vec<&str> = Vec::new();
        for r in &self.rows {
            if !order.contains(&r.category.as_str()) {
                order.push(&r.category);
            }
        }
        let mut rows: Vec<&Row> = self.rows.iter().collect();
        rows.sort_by_key(|r| order.iter().position(|c| *c == r.category));
        for r in rows {
            if r.category != last {
                out.push_str(&format!("  {}\n", r.category));
                last = &r.category;
            }
            out.push_str(&format!("    {:<44} {:>16}\n", r.title, r.shown));
        }
        out
    }
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
}
