//! What the editor draws, as data: the parameter groups (title, column, rows of parameter ids
//! and labels) and the parameters drawn outside them. The egui view ([`super::view`]) draws
//! exactly these, resolving each id with [`visit_param`], and the strike pad below the rows of
//! [`STRIKE_PAD_GROUP`]; compiled without the `editor` feature so the tests can check that every
//! parameter a user should reach is drawn and that the pad has room
//! (`every_user_parameter_is_drawn` below).
//!
//! To add a control: its row in a [`Group`] (or a new group in [`GROUPS`]) and its arm in
//! [`visit_param`]. A parameter that is not drawn fails the test unless it is hidden from the
//! user (`ParamFlags::HIDDEN`).

use crate::plugin::params::TactusParams;
use nice_plug::prelude::Param;

/// One slider (or, for `material`, the material menu) with its label.
#[derive(Debug, Clone, Copy)]
pub struct Row {
    /// Parameter id (`src/plugin/params.rs`).
    pub id: &'static str,
    /// Label beside the control.
    pub label: &'static str,
}

/// A titled parameter group. Groups with the same `column` stack top to bottom in [`GROUPS`]
/// order; the last group of a column stretches to the tallest column.
#[derive(Debug, Clone, Copy)]
pub struct Group {
    /// Title drawn at the top.
    pub title: &'static str,
    /// Column, 0 = leftmost.
    pub column: usize,
    /// Rows, top to bottom.
    pub rows: &'static [Row],
}

const fn row(id: &'static str, label: &'static str) -> Row {
    Row { id, label }
}

/// The parameter groups, in drawing order.
pub const GROUPS: &[Group] = &[
    Group {
        title: "OBJECT",
        column: 0,
        rows: &[
            row("material", "Material"),
            row("size", "Size"),
            row("damping", "Damping"),
            row("variation", "Variation"),
            row("quality", "Quality"),
        ],
    },
    Group {
        title: "STRIKE",
        column: 1,
        rows: &[
            row("mass", "Mass"),
            row("velocity", "Velocity"),
            row("hardness", "Hardness"),
            row("contact_model", "Contact"),
            row("note_mode", "Keys"),
        ],
    },
    Group {
        title: "SCRAPE",
        column: 2,
        rows: &[
            row("scrape_speed", "Speed"),
            row("scrape_motion", "Motion"),
            row("scrape_pressure", "Pressure"),
            row("roughness", "Roughness"),
            row("surface", "Surface"),
        ],
    },
    Group {
        title: "GESTURE",
        column: 2,
        rows: &[
            row("gesture", "Note plays"),
            row("height", "Height"),
            row("restitution", "Restitution"),
            row("fragments", "Fragments"),
            row("spread", "Spread"),
            row("rattle_rate", "Rattle rate"),
        ],
    },
    Group {
        title: "ROLL",
        column: 3,
        rows: &[
            row("roll_speed", "Speed"),
            row("roll_radius", "Radius"),
            row("roll_eccentricity", "Eccentricity"),
            row("roll_pressure", "Pressure"),
        ],
    },
    Group {
        title: "OUTPUT",
        column: 3,
        rows: &[
            row("gain", "Gain"),
            row("width", "Width"),
            row("limiter", "Limiter"),
        ],
    },
];

/// Parameters drawn in the object row above the groups: the Seed slider, and the New Object
/// button, which performs the `new_object` trigger's draw (through the seed parameter, so the
/// host records which object was drawn).
pub const OBJECT_ROW: &[&str] = &["seed", "new_object"];

/// Height of one row of a group, points (a slider and the spacing under it).
pub const ROW_HEIGHT: f32 = 31.0;
/// Vertical gap between two groups of a column, points.
pub const GROUP_GAP: f32 = 10.0;

/// Height of a group of `rows` rows, points: its title and margins, then the rows.
pub fn group_height(rows: usize) -> f32 {
    36.0 + rows as f32 * ROW_HEIGHT
}

/// Height of column `c`'s groups stacked with their gaps, points (before the last one
/// stretches).
pub fn column_height(c: usize) -> f32 {
    let groups = GROUPS.iter().filter(|g| g.column == c);
    groups.clone().map(|g| group_height(g.rows.len())).sum::<f32>()
        + GROUP_GAP * (groups.count().max(1) - 1) as f32
}

/// The group whose space below its rows the strike pad fills (a press plays the current
/// gesture as a note: docs/plugin.md, "Strike pad"). It must be the last group of its column,
/// which stretches to the tallest column.
pub const STRIKE_PAD_GROUP: &str = "STRIKE";

/// Least height of the strike pad, points: room to aim a press and read its labels.
pub const STRIKE_PAD_MIN_HEIGHT: f32 = 80.0;

/// Parameters a pad press reads as a note does: its full speed, what a note plays and how the
/// pad's key maps to pitch. Drawn, so the pad's sound can be shaped beside it.
pub const STRIKE_PAD_READS: &[&str] = &["velocity", "gesture", "note_mode"];

/// Height left for the strike pad below the rows of [`STRIKE_PAD_GROUP`], points: the tallest
/// column's height less the pad group's column's. 0 when the group is missing or not last.
pub fn strike_pad_height() -> f32 {
    let Some(i) = GROUPS.iter().position(|g| g.title == STRIKE_PAD_GROUP) else {
        return 0.0;
    };
    let c = GROUPS[i].column;
    if GROUPS[i + 1..].iter().any(|g| g.column == c) {
        return 0.0;
    }
    let tallest = (0..columns()).map(column_height).fold(0.0, f32::max);
    tallest - column_height(c)
}

/// Number of columns of [`GROUPS`].
pub fn columns() -> usize {
    GROUPS.iter().map(|g| g.column + 1).max().unwrap_or(0)
}

/// Every parameter id the editor draws.
pub fn drawn_ids() -> impl Iterator<Item = &'static str> {
    GROUPS
        .iter()
        .flat_map(|g| g.rows.iter().map(|r| r.id))
        .chain(OBJECT_ROW.iter().copied())
}

/// Something done with one parameter, whatever its type (the view draws a slider for it).
pub trait ParamVisitor {
    /// Called with the parameter.
    fn visit<P: Param>(&mut self, param: &P);
}

/// Calls `visitor` with the parameter `id` of `p`; false for an id the editor cannot draw.
pub fn visit_param(p: &TactusParams, id: &str, visitor: &mut impl ParamVisitor) -> bool {
    match id {
        "material" => visitor.visit(&p.material),
        "size" => visitor.visit(&p.size),
        "damping" => visitor.visit(&p.damping),
        "mass" => visitor.visit(&p.mass),
        "velocity" => visitor.visit(&p.velocity),
        "hardness" => visitor.visit(&p.hardness),
        "contact_model" => visitor.visit(&p.contact_model),
        "scrape_speed" => visitor.visit(&p.scrape_speed),
        "scrape_motion" => visitor.visit(&p.scrape_motion),
        "scrape_pressure" => visitor.visit(&p.scrape_pressure),
        "roughness" => visitor.visit(&p.roughness),
        "roll_speed" => visitor.visit(&p.roll_speed),
        "roll_radius" => visitor.visit(&p.roll_radius),
        "roll_eccentricity" => visitor.visit(&p.roll_eccentricity),
        "roll_pressure" => visitor.visit(&p.roll_pressure),
        "variation" => visitor.visit(&p.variation),
        "quality" => visitor.visit(&p.quality),
        "gain" => visitor.visit(&p.gain),
        "width" => visitor.visit(&p.width),
        "new_object" => visitor.visit(&p.new_object),
        "seed" => visitor.visit(&p.seed),
        "note_mode" => visitor.visit(&p.note_mode),
        "gesture" => visitor.visit(&p.gesture),
        "height" => visitor.visit(&p.height),
        "restitution" => visitor.visit(&p.restitution),
        "fragments" => visitor.visit(&p.fragments),
        "rattle_rate" => visitor.visit(&p.rattle_rate),
        "spread" => visitor.visit(&p.spread),
        "surface" => visitor.visit(&p.surface),
        "limiter" => visitor.visit(&p.limiter),
        _ => return false,
    }
    true
}

#[cfg(test)]
mod tests {
    use super::*;
    use nice_plug::prelude::{ParamFlags, ParamPtr, Params};
    use std::collections::BTreeSet;

    struct Ptr(Option<ParamPtr>);
    impl ParamVisitor for Ptr {
        fn visit<P: Param>(&mut self, param: &P) {
            self.0 = Some(param.as_ptr());
        }
    }

    /// Every parameter the plugin reports to hosts, unless hidden from the user, is drawn by
    /// the editor; and each drawn id resolves to that very parameter. A parameter added to
    /// `TactusParams` without a row (or with a row but no `visit_param` arm) fails here.
    #[test]
    fn every_user_parameter_is_drawn() {
        let p = TactusParams::default();
        let drawn: BTreeSet<&str> = drawn_ids().collect();
        let mut missing = Vec::new();
        for (id, ptr, _) in p.param_map() {
            if unsafe { ptr.flags() }.contains(ParamFlags::HIDDEN) {
                continue;
            }
            if !drawn.contains(id.as_str()) {
                missing.push(id.clone());
                continue;
            }
            let mut v = Ptr(None);
            assert!(
                visit_param(&p, &id, &mut v),
                "{id}: in the layout but not in visit_param"
            );
            assert!(v.0 == Some(ptr), "{id}: visit_param draws another parameter");
        }
        assert!(
            missing.is_empty(),
            "parameters the editor does not draw: {missing:?}"
        );
        let ids: BTreeSet<String> = p.param_map().into_iter().map(|(id, _, _)| id).collect();
        for id in drawn_ids() {
            assert!(ids.contains(id), "the layout draws `{id}`, which is no parameter");
        }
        let all: Vec<&str> = drawn_ids().collect();
        assert_eq!(all.len(), drawn.len(), "a parameter is drawn twice: {all:?}");
        // The strike pad: in its group, with room, beside the parameters its presses read.
        let pad = strike_pad_height();
        assert!(
            pad >= STRIKE_PAD_MIN_HEIGHT,
            "the strike pad gets {pad} points below the rows of {STRIKE_PAD_GROUP} (at least \
             {STRIKE_PAD_MIN_HEIGHT}): the group is missing, not last in its column, or full"
        );
        for id in STRIKE_PAD_READS {
            assert!(
                drawn.contains(id),
                "the strike pad reads `{id}`, which is not drawn"
            );
        }
    }
}
