//! Facts of the Shadow Hand model shared by every physics backend, and the
//! MJCF preprocessing (include inlining) our rapier loader needs.

use std::collections::HashMap;
use std::fs;
use std::path::Path;

use serde::{Deserialize, Serialize};

use crate::error::EnvError;

/// The manipulated object.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Serialize, Deserialize, Default)]
#[serde(rename_all = "snake_case")]
pub enum HandObject {
    /// The 5 cm cube (`manipulate_block_touch_sensors.xml`).
    #[default]
    Block,
    /// The ellipsoid egg (`manipulate_egg_touch_sensors.xml`).
    Egg,
}

impl HandObject {
    /// The object name in the scene file names (`block`, `egg`).
    #[must_use]
    pub fn file_stem(self) -> &'static str {
        match self {
            HandObject::Block => "block",
            HandObject::Egg => "egg",
        }
    }
}

/// The 24 hand joints in MuJoCo's `qpos` order.
pub const HAND_JOINTS: [&str; 24] = [
    "WRJ1", "WRJ0", "FFJ3", "FFJ2", "FFJ1", "FFJ0", "MFJ3", "MFJ2", "MFJ1", "MFJ0", "RFJ3", "RFJ2", "RFJ1", "RFJ0",
    "LFJ4", "LFJ3", "LFJ2", "LFJ1", "LFJ0", "THJ4", "THJ3", "THJ2", "THJ1", "THJ0",
];

/// The 20 actuators in the model's order (each drives the joint of the same suffix).
pub const ACTUATORS: [&str; 20] = [
    "WRJ1", "WRJ0", "FFJ3", "FFJ2", "FFJ1", "MFJ3", "MFJ2", "MFJ1", "RFJ3", "RFJ2", "RFJ1", "LFJ4", "LFJ3", "LFJ2",
    "LFJ1", "THJ4", "THJ3", "THJ2", "THJ1", "THJ0",
];

/// Name prefix of the model's joints, bodies, sites and actuators.
pub const PREFIX: &str = "robot0:";

/// One agent of the hand (docs/design.md 3.1): its name, the joint-name prefix of
/// the joints it owns and the touch-sensor name stems it reads.
#[derive(Debug, Clone, Copy)]
pub struct AgentPart {
    /// The agent name used by `fmsr-core` (e.g. for the reward assignment).
    pub name: &'static str,
    /// Prefix of its joint and actuator names (`WR`, `FF`, ...).
    pub joint_prefix: &'static str,
    /// Touch sensors whose name (after `robot0:TS_`) starts with one of these are its own.
    pub touch_prefixes: &'static [&'static str],
}

/// The six agents in order: wrist, index, middle, ring, little, thumb.
pub const AGENTS: [AgentPart; 6] = [
    AgentPart { name: "wrist", joint_prefix: "WR", touch_prefixes: &["palm"] },
    AgentPart { name: "index", joint_prefix: "FF", touch_prefixes: &["ff"] },
    AgentPart { name: "middle", joint_prefix: "MF", touch_prefixes: &["mf"] },
    AgentPart { name: "ring", joint_prefix: "RF", touch_prefixes: &["rf"] },
    AgentPart { name: "little", joint_prefix: "LF", touch_prefixes: &["lf"] },
    AgentPart { name: "thumb", joint_prefix: "TH", touch_prefixes: &["th"] },
];

/// Number of touch sensors of the model.
pub const NUM_TOUCH: usize = 92;

/// One of the model's 92 touch sensors: the sensor's name, the `mjcf_rs` body
/// id of its site, and the site (the sensor's zone).
#[derive(Debug, Clone)]
pub(crate) struct TouchSensorSite {
    /// Read by the rapier backend's touch sensors.
    #[cfg_attr(not(feature = "rapier"), allow(dead_code))]
    pub(crate) name: String,
    pub(crate) body: usize,
    pub(crate) site: mjcf_rs::body::Site,
}

/// The 92 `robot0:TS_*` touch sensors in the model's order (shared.xml's 5
/// fingertip `ST_Tch_*` are not among them), with their sites.
pub(crate) fn touch_sensor_sites(model: &mjcf_rs::Model) -> Result<Vec<TouchSensorSite>, EnvError> {
    let prefix = format!("{PREFIX}TS_");
    let mut out = Vec::with_capacity(NUM_TOUCH);
    for sensor in model.sensors.iter().filter(|s| s.kind == "touch") {
        let Some(name) = sensor.name.clone().filter(|n| n.starts_with(&prefix)) else { continue };
        let site_name = sensor.objname.as_deref().unwrap_or_default();
        let found = model.bodies.iter().enumerate().find_map(|(body, e)| {
            e.body.sites.iter().find(|s| s.name.as_deref() == Some(site_name)).map(|s| (body, s.clone()))
        });
        let (body, site) = found.ok_or_else(|| EnvError::Model(format!("no site named {site_name} for {name}")))?;
        out.push(TouchSensorSite { name, body, site });
    }
    if out.len() != NUM_TOUCH {
        return Err(EnvError::Model(format!("{} touch sensors, expected {NUM_TOUCH}", out.len())));
    }
    Ok(out)
}

/// Reads `path` and replaces every `<include file="..."/>` (anywhere: top level,
/// inside `<worldbody>` or `<asset>`) by the contents of the included file's
/// `<mujoco>` element, recursively. `rapier3d-mjcf` 0.36 only resolves
/// top-level includes. The files are parsed as XML: an `<include>` in a
/// comment is left alone, and a file that is not XML is an error naming it.
pub fn inline_includes(path: &Path) -> Result<String, EnvError> {
    inline_rec(path, 0)
}

fn inline_rec(path: &Path, depth: usize) -> Result<String, EnvError> {
    if depth > 16 {
        return Err(EnvError::Model(format!("include nesting too deep at {}", path.display())));
    }
    let text =
        fs::read_to_string(path).map_err(|source| EnvError::Io { what: "reading", path: path.into(), source })?;
    let doc = parse_xml(&text, path)?;
    let dir = path.parent().unwrap_or_else(|| Path::new("."));
    let mut out = String::with_capacity(text.len());
    let mut copied = 0;
    for include in doc.descendants().filter(|n| n.has_tag_name("include")) {
        let range = include.range();
        if range.start < copied {
            continue; // inside an <include> already replaced
        }
        out.push_str(&text[copied..range.start]);
        let file = include
            .attribute("file")
            .ok_or_else(|| EnvError::Model(format!("<include> without file in {}", path.display())))?;
        let included = dir.join(file);
        let inner = inline_rec(&included, depth + 1)?;
        out.push_str(mujoco_content(&inner, &included)?);
        copied = range.end;
    }
    out.push_str(&text[copied..]);
    Ok(out)
}

/// `text` (the file `path`) as an XML tree, or an error naming the file.
fn parse_xml<'a>(text: &'a str, path: &Path) -> Result<roxmltree::Document<'a>, EnvError> {
    roxmltree::Document::parse(text).map_err(|e| EnvError::Model(format!("{} is not XML: {e}", path.display())))
}

/// The content of the root `<mujoco>` element of `text` (the file `path`), as written.
fn mujoco_content<'a>(text: &'a str, path: &Path) -> Result<&'a str, EnvError> {
    let doc = parse_xml(text, path)?;
    let root = doc.root_element();
    if !root.has_tag_name("mujoco") {
        return Err(EnvError::Model(format!("{}: the root element is not <mujoco>", path.display())));
    }
    Ok(match (root.first_child(), root.last_child()) {
        (Some(first), Some(last)) => &text[first.range().start..last.range().end],
        _ => "",
    })
}

/// The length range of every limited `<tendon><fixed>` of an MJCF text, by
/// tendon name: `lo <= sum_i coef_i q_i <= hi`. A tendon is limited when
/// `limited="true"`, or when it has a `range` and `limited` is absent or
/// `"auto"` (MuJoCo's `autolimits`). `rapier3d-mjcf` 0.36 keeps the tendons'
/// joints and coefficients but not their ranges, which the rapier backend needs
/// for the slack of the J1/J0 coupling.
///
/// ```
/// use fmsr_envs::shadow_hand::model::fixed_tendon_ranges;
/// let xml = r#"<mujoco><tendon>
///   <fixed name="c" limited="true" range="-0.001 0.001"><joint joint="a" coef="1"/></fixed>
///   <fixed name="free" limited="false" range="-1 1"><joint joint="a" coef="1"/></fixed>
/// </tendon></mujoco>"#;
/// let ranges = fixed_tendon_ranges(xml).unwrap();
/// assert_eq!(ranges["c"], [-0.001, 0.001]);
/// assert!(!ranges.contains_key("free"));
/// ```
pub fn fixed_tendon_ranges(xml: &str) -> Result<HashMap<String, [f64; 2]>, EnvError> {
    let doc = roxmltree::Document::parse(xml).map_err(|e| EnvError::Model(format!("MJCF is not XML: {e}")))?;
    let mut ranges = HashMap::new();
    for t in
        doc.descendants().filter(|n| n.has_tag_name("fixed") && n.parent().is_some_and(|p| p.has_tag_name("tendon")))
    {
        let (Some(name), Some(range)) = (t.attribute("name"), t.attribute("range")) else { continue };
        if !matches!(t.attribute("limited"), None | Some("true" | "auto")) {
            continue;
        }
        let bad = || EnvError::Model(format!("tendon {name}: range {range:?} is not two numbers lo <= hi"));
        let v = range.split_whitespace().map(str::parse::<f64>).collect::<Result<Vec<_>, _>>().map_err(|_| bad())?;
        match v[..] {
            [lo, hi] if lo <= hi => ranges.insert(name.to_string(), [lo, hi]),
            _ => return Err(bad()),
        };
    }
    Ok(ranges)
}

#[cfg(test)]
mod tests {
    use super::*;

    // Guards the tendon ranges' input checks: a range that is not two ordered
    // numbers is an error naming the tendon, never a silent default.
    #[test]
    fn a_malformed_tendon_range_is_an_error_naming_the_tendon() {
        for range in ["0.001", "0.001 -0.001", "a b", "0 1 2"] {
            let xml = format!(r#"<mujoco><tendon><fixed name="t" range="{range}"/></tendon></mujoco>"#);
            let err = fixed_tendon_ranges(&xml).unwrap_err().to_string();
            assert!(err.contains("tendon t"), "{range}: {err}");
        }
        let auto = fixed_tendon_ranges(r#"<mujoco><tendon><fixed name="t" range="-1 1"/></tendon></mujoco>"#).unwrap();
        assert_eq!(auto["t"], [-1.0, 1.0]);
    }

    #[test]
    fn includes_are_inlined_everywhere() {
        let dir = std::env::temp_dir().join(format!("fmsr-inline-{}", std::process::id()));
        fs::create_dir_all(&dir).unwrap();
        fs::write(
            dir.join("a.xml"),
            "<?xml version=\"1.0\"?>\n<mujoco><body name=\"b\"><include file=\"c.xml\"/></body></mujoco>",
        )
        .unwrap();
        fs::write(dir.join("c.xml"), "<mujoco model=\"x\"><geom name=\"g\"/></mujoco>").unwrap();
        fs::write(dir.join("main.xml"), "<mujoco><worldbody><include file=\"a.xml\"></include></worldbody></mujoco>")
            .unwrap();
        let text = inline_includes(&dir.join("main.xml")).unwrap();
        assert_eq!(text, "<mujoco><worldbody><body name=\"b\"><geom name=\"g\"/></body></worldbody></mujoco>");
        fs::remove_dir_all(&dir).unwrap();
    }

    // Guards the XML parsing of includes: a commented-out
    // include stays a comment, and a file that is not XML is an error naming it.
    #[test]
    fn includes_are_read_as_xml() {
        let dir = std::env::temp_dir().join(format!("fmsr-inline-xml-{}", std::process::id()));
        fs::create_dir_all(&dir).unwrap();
        let main = "<mujoco><!-- <include file=\"gone.xml\"/> --><include file=\"c.xml\"/></mujoco>";
        fs::write(dir.join("main.xml"), main).unwrap();
        fs::write(dir.join("c.xml"), "<mujoco>\n  <geom name=\"g\"/>\n</mujoco>").unwrap();
        let text = inline_includes(&dir.join("main.xml")).unwrap();
        assert_eq!(text, "<mujoco><!-- <include file=\"gone.xml\"/> -->\n  <geom name=\"g\"/>\n</mujoco>");
        fs::write(dir.join("c.xml"), "<mujoco><geom></mujoco>").unwrap();
        let err = inline_includes(&dir.join("main.xml")).unwrap_err().to_string();
        assert!(err.contains("c.xml") && err.contains("not XML"), "{err}");
        fs::remove_dir_all(&dir).unwrap();
    }
}
