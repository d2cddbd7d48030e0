//! Scene events for gestures (`bounce`, `break`, `rattle`; docs/model.md §11): the event's own
//! keys (object, time, seed) and, under every other key, a field of the gesture's parameter
//! group, read through its [`SettingsGroup`] table as scrape and roll events read theirs.

use super::{unknown_key, Scene, SceneEvent};
use crate::engine::gesture::{Gesture, GestureKind, Handover};
use crate::engine::settings::SettingsGroup;
use serde::{Deserialize, Deserializer};

/// A gesture event: where and when, and the gesture's parameters `P`.
#[derive(Debug, Clone, PartialEq)]
pub struct GestureEvent<P> {
    /// Object the gesture acts on (a key of the scene's `objects`; omitted in one-object
    /// scenes).
    pub object: Option<String>,
    /// Time of the gesture's first impact, s.
    pub time_s: f64,
    /// Seed of the gesture's random draws (default: from the object's seed and the event's
    /// index).
    pub seed: Option<u64>,
    /// The parameters: `P`'s defaults with the event's keys over them.
    pub params: P,
    /// The parameter keys the event gave.
    pub given: Vec<&'static str>,
}

impl<P> GestureEvent<P> {
    /// The event's own keys, listed before the parameter group's in the error for an unknown
    /// key.
    const OWN_KEYS: [&'static str; 3] = ["object", "time_s", "seed"];
}

impl<'de, P: SettingsGroup> Deserialize<'de> for GestureEvent<P> {
    fn deserialize<D: Deserializer<'de>>(d: D) -> Result<Self, D::Error> {
        use serde::de::Error;
        let map = serde_json::Map::<String, serde_json::Value>::deserialize(d)?;
        let keys = || {
            let own = GestureEvent::<P>::OWN_KEYS;
            own.into_iter().chain(P::FIELDS.iter().map(|f| f.name))
        };
        let mut event = GestureEvent {
            object: None,
            time_s: f64::NAN,
            seed: None,
            params: P::default(),
            given: Vec::new(),
        };
        let mut has_time = false;
        for (key, value) in &map {
            let Some(name) = keys().find(|n| n == key) else {
                return Err(D::Error::custom(unknown_key(key, keys())));
            };
            let named = |e: serde_json::Error| D::Error::custom(format!("{name}: {e}"));
            match name {
                "object" => event.object = Deserialize::deserialize(value).map_err(named)?,
                "time_s" => {
                    event.time_s = Deserialize::deserialize(value).map_err(named)?;
                    has_time = true;
                }
                "seed" => event.seed = Deserialize::deserialize(value).map_err(named)?,
                _ => {
                    if let Some(Err(e)) = event.params.set_json(name, value) {
                        return Err(named(e));
                    }
                    event.given.push(name);
                }
            }
        }
        if !has_time {
            return Err(D::Error::missing_field("time_s"));
        }
        Ok(event)
    }
}

impl SceneEvent {
    /// A gesture event's time, object, seed and parameters; `None` for other events.
    pub(crate) fn gesture(&self) -> Option<(f64, Option<u64>, GestureKind)> {
        Some(match self {
            SceneEvent::Bounce(g) => (g.time_s, g.seed, GestureKind::Bounce(g.params)),
            SceneEvent::Break(g) => (g.time_s, g.seed, GestureKind::Break(g.params)),
            SceneEvent::Rattle(g) => (g.time_s, g.seed, GestureKind::Rattle(g.params)),
            _ => return None,
        })
    }
}

impl Scene {
    /// Seed of the object an event acts on, as first drawn.
    pub(crate) fn object_seed(&self, object: Option<&str>) -> u64 {
        object
            .and_then(|o| self.objects.get(o))
            .and_then(|o| o.seed)
            .unwrap_or(self.seed)
    }

    /// Event `i`'s gesture generator and start time (s), if it is a gesture. Its seed, when the
    /// event gives none, mixes the object's seed with the index, so two gestures of one scene
    /// differ and a gesture keeps its draws when other events are added after it.
    pub(crate) fn gesture_at(&self, i: usize) -> Option<(f64, Gesture)> {
        let e = &self.events[i];
        let (time_s, seed, kind) = e.gesture()?;
        let seed = seed.unwrap_or_else(|| {
            self.object_seed(e.object()) ^ (i as u64 + 1).wrapping_mul(0x9E37_79B9_7F4A_7C15)
        });
        Some((time_s, Gesture::new(kind, seed)))
    }
}

impl Scene {
    /// The rolls the bounces of `object` hand over to (`roll_after`; docs/model.md §11
    /// "Bounce"), with their start times in the scene (s).
    pub(crate) fn handovers(&self, object: Option<&str>) -> Vec<(f64, Handover)> {
        (0..self.events.len())
            .filter(|&i| self.events[i].object() == object)
            .filter_map(|i| self.gesture_at(i))
            .filter_map(|(t, mut g)| {
                g.by_ref().for_each(drop);
                g.handover().map(|h| (t + h.t_s, h))
            })
            .collect()
    }
}

/// The checks of gesture event `i` beyond its keys: every parameter in range, and a bounce
/// given a height or a speed, not both.
pub(crate) fn validate_gesture(i: usize, e: &SceneEvent) -> anyhow::Result<()> {
    let at = format!("events[{i}]");
    let checked = match e {
        SceneEvent::Bounce(g) => {
            if g.given.contains(&"height_m") && g.given.contains(&"velocity_m_per_s") {
                anyhow::bail!("scene: {at} has both height_m and velocity_m_per_s; give one");
            }
            g.params.validate(&at)
        }
        SceneEvent::Break(g) => g.params.validate(&at),
        SceneEvent::Rattle(g) => g.params.validate(&at),
        _ => return Ok(()),
    };
    checked.map_err(|e| anyhow::anyhow!("scene: {e}"))
}
