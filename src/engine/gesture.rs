//! Gestures: bounce, break and rattle, each a deterministic generator of impacts on the
//! existing contact model (docs/model.md §11). A gesture is a list of *bodies* (the struck
//! object itself, fragments, small rattling objects) and a time-ordered stream of [`Hit`]s on
//! them; whoever drives the engine turns each hit into an [`super::Event::Impact`] on the
//! body's object. Everything follows from the parameters and one seed; generating never
//! allocates (fixed arrays of at most [`MAX_BODIES`]).

use super::object::EngineRng;
use super::settings::{
    field_path, setting_fallback, setting_range, settings_group, FieldSpec, Range, SettingError,
    SettingValue, SettingsGroup,
};
use rand::{RngExt, SeedableRng};
use serde::Deserialize;

/// Gravity, m/s².
pub const G_M_PER_S2: f64 = 9.81;

/// Impact speed below which a bounce or a fragment stops (m/s): −36 dB of a 3 m/s drop, under
/// the tail of the impacts before it.
pub const AUDIBLE_SPEED_M_PER_S: f64 = 0.05;

/// Deceleration of a roll handed over from a bounce (m/s²): rolling resistance `μ_r·g` with
/// `μ_r` = 0.02, a hard ball on a hard floor.
pub const ROLL_DECEL_M_PER_S2: f64 = 0.02 * G_M_PER_S2;

/// Most fragments of a break.
pub const MAX_FRAGMENTS: u32 = 64;

/// Most objects in a rattle.
pub const MAX_RATTLE_OBJECTS: u32 = 16;

/// Most bodies of any gesture: a break's fragments, its dust and the object.
pub const MAX_BODIES: usize = MAX_FRAGMENTS as usize + 2;

/// Length of a break's noise burst after the strike, s.
pub const BURST_S: f64 = 0.025;

/// Mean number of dust impacts in a break's burst.
pub const BURST_HITS: f64 = 16.0;

/// Size of a dust grain and of a rattling object relative to the object (docs/model.md §11).
pub const DUST_SIZE: f64 = 0.15;
/// Size of a rattling object relative to its container.
pub const RATTLE_SIZE: f64 = 0.3;

/// Shortest interval between two rattle impacts, s: after a collision the objects separate
/// before they meet again; without it a Poisson process puts a fifth of its impacts within
/// 20 ms at 10 Hz, where they fuse into one.
pub const RATTLE_DEAD_S: f64 = 0.015;

/// Peak impact speed of a rattle at intensity 1, m/s.
pub const RATTLE_SPEED_M_PER_S: f64 = 2.0;

/// Most impacts of one fragment.
pub const FRAGMENT_MAX_IMPACTS: u32 = 32;

/// Shortest interval between two fragments' first landings, s: closer than the ear's (and an
/// onset detector's) ~20 ms fusion window, two pieces land as one; a little more than that, so
/// the second stands out of the first's attack (docs/model.md §11 "Break").
pub const FRAGMENT_GAP_S: f64 = 0.025;

/// Decay (dB/s) every mode of a broken object takes at the fracture, unless it decays faster:
/// 60 dB over the crack's burst ([`BURST_S`]). The body that rang these modes has come apart;
/// a raised decay rather than a cut keeps the waveform continuous (no click), and the ring
/// that is left is the crack's own short ping (docs/model.md §11 "Break").
pub const FRACTURE_DECAY_DB_PER_S: f64 = 60.0 / BURST_S;

/// Least decay (dB/s) of a piece's modes (fragments and dust) at the object's size, divided by
/// the piece's size: a piece is the broken body at its size, whose modes decay 1/size as fast
/// as the broken whole's ([`FRACTURE_DECAY_DB_PER_S`]). The fracture's cracks and the
/// micro-cracks around them run through every piece, and their faces rub as it vibrates, the
/// loss that makes a cracked glass or bell sound dull. A piece's landing rings out (60 dB)
/// within `size × 25 ms`, before the next piece lands: each landing is a short impact of its
/// own, not a swell of rings (docs/model.md §11 "Break").
pub const PIECE_DECAY_DB_PER_S: f64 = FRACTURE_DECAY_DB_PER_S;

settings_group! {
    /// An object dropped (or thrown down) onto a rigid floor (docs/model.md §11 "Bounce").
    pub struct BounceParams {
        /// Drop height in m; the first impact is at `√(2·g·h)`. Ignored when
        /// `velocity_m_per_s` is given.
        pub height_m: f64 = 0.5, [0.001, 100.0] "m";
        /// First impact speed in m/s (0 = from `height_m`).
        pub velocity_m_per_s: f64 = 0.0, [0.0, 100.0] "m/s";
        /// Coefficient of restitution e: each impact is e times as fast as the one before.
        pub restitution: f64 = 0.6, [0.0, 0.98] "";
        /// Most impacts.
        pub max_impacts: u32 = 64, [1.0, 1000.0] "";
        /// Impact speed (m/s) below which the object stops bouncing and rolls on at that
        /// speed (0 = it never rolls).
        pub roll_after: f64 = 0.0, [0.0, 10.0] "m/s";
        /// Random spread of e from impact to impact, as a fraction of e.
        pub jitter: f64 = 0.0, [0.0, 0.2] "";
    }
}

settings_group! {
    /// An object struck hard enough to break (docs/model.md §11 "Break").
    pub struct BreakParams {
        /// Strike speed in m/s.
        pub velocity_m_per_s: f64 = 3.0, [0.0, 100.0] "m/s";
        /// Number of fragments.
        pub fragments: u32 = 6, [1.0, 64.0] "";
        /// Mean coefficient of restitution of the fragments (each has its own, ±15 %).
        pub restitution: f64 = 0.4, [0.0, 0.98] "";
        /// Window over which the fragments first land, s after the burst (at least
        /// `1.5·(fragments − 1)·25 ms`: first landings are 25 ms apart or more).
        pub spread_s: f64 = 0.2, [0.0, 10.0] "s";
    }
}

settings_group! {
    /// Small objects shaken in a container (docs/model.md §11 "Rattle").
    pub struct RattleParams {
        /// Length of the shaking, s.
        pub duration_s: f64 = 1.0, [0.001, 3600.0] "s";
        /// Number of small objects.
        pub objects: u32 = 4, [1.0, 16.0] "";
        /// Mean impacts per second.
        pub rate_hz: f64 = 20.0, [0.1, 200.0] "Hz";
        /// Shake intensity 0..=1: impact speeds are up to `intensity × 2 m/s`.
        pub intensity: f64 = 0.5, [0.0, 1.0] "";
    }
}

/// A gesture and its parameters.
#[derive(Debug, Clone, Copy, PartialEq)]
pub enum GestureKind {
    /// A bounce.
    Bounce(BounceParams),
    /// A break.
    Break(BreakParams),
    /// A rattle.
    Rattle(RattleParams),
}

/// One sounding body of a gesture: an object of the gesture's material.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Body {
    /// Seed of the body's object; `None` = the struck object itself (as first drawn).
    pub seed: Option<u64>,
    /// Size relative to the object (mode frequencies scale as 1/size).
    pub size: f64,
    /// Contact mass relative to the striker mass setting.
    pub mass: f64,
    /// Level of the body's modes per unit impulse relative to the object's, 1 = the same
    /// (a fragment: its smaller modal mass, docs/model.md §11 "Break").
    pub gain: f64,
    /// Factor on the decay of the body's modes, 1 = the object's (a fragment: its modes
    /// moved up by 1/size decay 1/size as fast).
    pub damping: f64,
    /// Least decay of the body's modes, dB/s, 0 = none (a piece of a broken object:
    /// [`PIECE_DECAY_DB_PER_S`]` / size`).
    pub min_decay_db_per_s: f64,
}

impl Body {
    /// The struck object itself at its own size and mass: the engine that plays the object
    /// plays this body's hits.
    pub fn is_object(&self) -> bool {
        self.seed.is_none()
            && self.size == 1.0
            && self.mass == 1.0
            && self.gain == 1.0
            && self.damping == 1.0
            && self.min_decay_db_per_s == 0.0
    }

    /// A piece of a broken object of mass share `mass` (docs/model.md §11 "Break"): size
    /// `mass^(1/3)`, level `size^-2` per unit impulse, decay `1/size` as fast and at least
    /// [`PIECE_DECAY_DB_PER_S`]` / size`.
    fn piece(seed: u64, mass: f64) -> Body {
        let size = mass.cbrt();
        Body {
            seed: Some(seed),
            size,
            mass,
            gain: size.powi(-2),
            damping: 1.0 / size,
            min_decay_db_per_s: PIECE_DECAY_DB_PER_S / size,
        }
    }

    const OBJECT: Body = Body {
        seed: None,
        size: 1.0,
        mass: 1.0,
        gain: 1.0,
        damping: 1.0,
        min_decay_db_per_s: 0.0,
    };
}

/// One impact of a gesture.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Hit {
    /// Time after the gesture's start, s.
    pub t_s: f64,
    /// Index into [`Gesture::bodies`].
    pub body: usize,
    /// Impact speed, m/s.
    pub velocity_m_per_s: f64,
    /// Extra frequency factor of this hit (dust grains of one body differ), 1 = none.
    pub pitch_factor: f64,
    /// The hit breaks its body: from the hit on, the body's modes decay at least at
    /// [`FRACTURE_DECAY_DB_PER_S`] (a break's strike).
    pub fracture: bool,
}

/// A bounce's hand-over to rolling: the roll's start (s after the gesture's start), its
/// initial speed and its length (the speed falls linearly to 0 at [`ROLL_DECEL_M_PER_S2`]).
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Handover {
    /// Start, s after the gesture's start.
    pub t_s: f64,
    /// Speed at the start, m/s.
    pub speed_m_per_s: f64,
    /// Length, s.
    pub duration_s: f64,
}

/// One bouncing body's state: its next impact and what follows it.
#[derive(Debug, Clone, Copy, Default)]
struct Lane {
    t: f64,
    v: f64,
    e: f64,
    /// Impacts still to come (0 = done).
    left: u32,
}

/// A gesture's generator: its bodies and its hits in time order ([`Iterator`]).
#[derive(Debug, Clone)]
pub struct Gesture {
    kind: GestureKind,
    rng: EngineRng,
    bodies: [Body; MAX_BODIES],
    n_bodies: usize,
    /// Bouncing bodies: lane i plays body i (bounce: the object; break: strike, dust, fragments).
    lanes: [Lane; MAX_BODIES],
    /// Break: next dust impact time (∞ when the burst is over). Rattle: next impact time.
    next_t: f64,
    /// Rattle: the second body of a collision, played at the same time as the first.
    pending: Option<Hit>,
    handover: Option<Handover>,
}

/// Uniform in `lo..hi`.
fn uniform(rng: &mut EngineRng, lo: f64, hi: f64) -> f64 {
    lo + (hi - lo) * rng.random::<f64>()
}

/// Exponential with mean `mean`.
fn exponential(rng: &mut EngineRng, mean: f64) -> f64 {
    -mean * (1.0 - rng.random::<f64>()).ln()
}

impl Gesture {
    /// The generator of `kind` (sanitised: out-of-range values clamp), deterministic from `seed`.
    pub fn new(kind: GestureKind, seed: u64) -> Self {
        let mut g = Gesture {
            kind,
            rng: EngineRng::seed_from_u64(seed ^ 0x6E57_0A11),
            bodies: [Body::OBJECT; MAX_BODIES],
            n_bodies: 1,
            lanes: [Lane::default(); MAX_BODIES],
            next_t: f64::INFINITY,
            pending: None,
            handover: None,
        };
        match kind {
            GestureKind::Bounce(p) => {
                let p = p.sanitized();
                let v0 = if p.velocity_m_per_s > 0.0 {
                    p.velocity_m_per_s
                } else {
                    (2.0 * G_M_PER_S2 * p.height_m).sqrt()
                };
                g.kind = GestureKind::Bounce(p);
                g.lanes[0] = Lane {
                    t: 0.0,
                    v: v0,
                    e: p.restitution,
                    left: p.max_impacts,
                };
            }
            GestureKind::Break(p) => g.start_break(p.sanitized()),
            GestureKind::Rattle(p) => g.start_rattle(p.sanitized()),
        }
        g
    }

    /// Break: body 0 the object (struck once), body 1 the dust of the burst, bodies 2.. the
    /// fragments, sized by mass share (docs/model.md §11 "Break").
    fn start_break(&mut self, p: BreakParams) {
        self.kind = GestureKind::Break(p);
        let n = p.fragments as usize;
        self.lanes[0] = Lane {
            t: 0.0,
            v: p.velocity_m_per_s,
            e: 0.0,
            left: 1,
        };
        // The dust is pieces too, the smallest.
        self.bodies[1] = Body::piece(self.rng.random(), DUST_SIZE.powi(3));
        self.next_t = exponential(&mut self.rng, BURST_S / BURST_HITS);
        // Mass shares: normalised exponentials, i.e. uniform over all ways to split the mass
        // (Dirichlet(1, …, 1)).
        let mut shares = [0.0; MAX_FRAGMENTS as usize];
        for s in &mut shares[..n] {
            *s = exponential(&mut self.rng, 1.0).max(1e-6);
        }
        let total: f64 = shares[..n].iter().sum();
        // First landings: n uniform draws over the window's free time, sorted, the k-th moved
        // k gaps later, so any two are at least FRAGMENT_GAP_S apart. The window is
        // `spread_s`, or, when that cannot hold n landings so far apart,
        // 1.5·(n − 1)·FRAGMENT_GAP_S (the free time is at least half the gaps: landings stay
        // irregular). The fragments' shares are drawn independently, so which lands k-th is
        // random.
        let gaps = (n - 1) as f64 * FRAGMENT_GAP_S;
        let free = (p.spread_s - gaps).max(0.5 * gaps);
        let mut landings = [0.0; MAX_FRAGMENTS as usize];
        for t in &mut landings[..n] {
            *t = uniform(&mut self.rng, 0.0, free);
        }
        landings[..n].sort_unstable_by(f64::total_cmp);
        for (i, share) in shares[..n].iter().enumerate() {
            self.bodies[2 + i] = Body::piece(self.rng.random(), share / total);
            self.lanes[2 + i] = Lane {
                t: BURST_S + landings[i] + i as f64 * FRAGMENT_GAP_S,
                v: p.velocity_m_per_s * uniform(&mut self.rng, 0.3, 0.7),
                e: (p.restitution * uniform(&mut self.rng, 0.85, 1.15)).min(0.98),
                left: FRAGMENT_MAX_IMPACTS,
            };
        }
        self.n_bodies = 2 + n;
    }

    /// Rattle: body 0 the container (the object, as first drawn) struck by a small object's
    /// mass, bodies 1.. the small objects.
    fn start_rattle(&mut self, p: RattleParams) {
        self.kind = GestureKind::Rattle(p);
        let mass = RATTLE_SIZE.powi(3);
        self.bodies[0] = Body { mass, ..Body::OBJECT };
        for b in &mut self.bodies[1..=p.objects as usize] {
            let size = RATTLE_SIZE * uniform(&mut self.rng, 0.8, 1.25);
            *b = Body {
                seed: Some(self.rng.random()),
                size,
                mass,
                gain: 1.0,
                damping: 1.0,
                min_decay_db_per_s: 0.0,
            };
        }
        self.n_bodies = 1 + p.objects as usize;
        self.next_t = self.rattle_interval(p);
    }

    /// Time to the next rattle impact: a dead time, then exponential, mean `1/rate_hz` in all.
    fn rattle_interval(&mut self, p: RattleParams) -> f64 {
        let mean = 1.0 / p.rate_hz;
        let dead = RATTLE_DEAD_S.min(0.5 * mean);
        dead + exponential(&mut self.rng, mean - dead)
    }

    /// The gesture's bodies; [`Hit::body`] indexes this.
    pub fn bodies(&self) -> &[Body] {
        &self.bodies[..self.n_bodies]
    }

    /// The roll a bounce hands over to, once [`Iterator::next`] has returned `None`.
    pub fn handover(&self) -> Option<Handover> {
        self.handover
    }

    /// Time of the last impact plus the longest a fragment or rattle can still start one; for
    /// renderers sizing their work. Runs a copy of the generator.
    pub fn end_s(&self) -> f64 {
        let mut g = self.clone();
        let mut end = 0.0f64;
        for h in &mut g {
            end = end.max(h.t_s);
        }
        g.handover.map_or(end, |h| end.max(h.t_s + h.duration_s))
    }

    /// The next impact of the bouncing lanes (bounce, break), earliest first.
    fn next_lane_hit(&mut self) -> Option<(usize, Hit)> {
        let (i, lane) = self.lanes[..self.n_bodies.max(1)]
            .iter()
            .enumerate()
            .filter(|(_, l)| l.left > 0)
            .min_by(|a, b| a.1.t.total_cmp(&b.1.t))?;
        Some((
            i,
            Hit {
                t_s: lane.t,
                body: i,
                velocity_m_per_s: lane.v,
                pitch_factor: 1.0,
                fracture: false,
            },
        ))
    }

    /// Advances lane `i` past its impact: v ← e·v, flight `2·v/g` (docs/model.md §11).
    fn bounce_on(&mut self, i: usize, jitter: f64, roll_after: f64) {
        let e = if jitter > 0.0 {
            (self.lanes[i].e * (1.0 + uniform(&mut self.rng, -jitter, jitter))).min(0.98)
        } else {
            self.lanes[i].e
        };
        let lane = &mut self.lanes[i];
        lane.left -= 1;
        let v = e * lane.v;
        lane.t += 2.0 * v / G_M_PER_S2;
        lane.v = v;
        if lane.left > 0 && roll_after > 0.0 && v < roll_after {
            lane.left = 0;
            self.handover = Some(Handover {
                t_s: lane.t,
                speed_m_per_s: v,
                duration_s: v / ROLL_DECEL_M_PER_S2,
            });
        } else if v < AUDIBLE_SPEED_M_PER_S {
            lane.left = 0;
        }
    }
}

impl Iterator for Gesture {
    type Item = Hit;

    fn next(&mut self) -> Option<Hit> {
        match self.kind {
            GestureKind::Bounce(p) => {
                let (i, hit) = self.next_lane_hit()?;
                self.bounce_on(i, p.jitter, p.roll_after);
                Some(hit)
            }
            GestureKind::Break(p) => {
                let lane = self.next_lane_hit();
                if self.next_t < BURST_S && lane.is_none_or(|(_, h)| self.next_t < h.t_s) {
                    let hit = Hit {
                        t_s: self.next_t,
                        body: 1,
                        velocity_m_per_s: p.velocity_m_per_s * uniform(&mut self.rng, 0.1, 0.4),
                        pitch_factor: uniform(&mut self.rng, 0.7, 1.5),
                        fracture: false,
                    };
                    self.next_t += exponential(&mut self.rng, BURST_S / BURST_HITS);
                    return Some(hit);
                }
                let (i, hit) = lane?;
                self.bounce_on(i, 0.0, 0.0);
                // The strike (lane 0, struck once) is the fracture.
                Some(Hit {
                    fracture: i == 0,
                    ..hit
                })
            }
            GestureKind::Rattle(p) => {
                if let Some(h) = self.pending.take() {
                    return Some(h);
                }
                if self.next_t >= p.duration_s {
                    return None;
                }
                let t_s = self.next_t;
                let m = p.objects as usize;
                let a = 1 + (self.rng.random::<u32>() as usize % m);
                // Half the impacts are on the container, half between two objects.
                let b = if m == 1 || self.rng.random::<bool>() {
                    0
                } else {
                    1 + (a + (self.rng.random::<u32>() as usize % (m - 1))) % m
                };
                let v = p.intensity * RATTLE_SPEED_M_PER_S * uniform(&mut self.rng, 0.5, 1.0);
                let hit = |body| Hit {
                    t_s,
                    body,
                    velocity_m_per_s: v,
                    pitch_factor: 1.0,
                    fracture: false,
                };
                self.pending = Some(hit(b));
                self.next_t += self.rattle_interval(p);
                Some(hit(a))
            }
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn bounce_follows_the_restitution_law() {
        let p = BounceParams {
            height_m: 0.5,
            restitution: 0.6,
            ..Default::default()
        };
        let hits: Vec<Hit> = Gesture::new(GestureKind::Bounce(p), 1).collect();
        let v0 = (2.0 * G_M_PER_S2 * 0.5f64).sqrt();
        assert!((hits[0].velocity_m_per_s - v0).abs() < 1e-12);
        for w in hits.windows(2) {
            assert!((w[1].velocity_m_per_s / w[0].velocity_m_per_s - 0.6).abs() < 1e-12);
            let flight = w[1].t_s - w[0].t_s;
            assert!((flight - 2.0 * w[1].velocity_m_per_s / G_M_PER_S2).abs() < 1e-12);
        }
        assert!(hits.last().unwrap().velocity_m_per_s >= AUDIBLE_SPEED_M_PER_S);
        assert!(hits.last().unwrap().velocity_m_per_s * 0.6 < AUDIBLE_SPEED_M_PER_S);
    }

    #[test]
    fn bounce_hands_over_to_a_roll_below_roll_after() {
        let p = BounceParams {
            velocity_m_per_s: 2.0,
            restitution: 0.5,
            roll_after: 0.3,
            ..Default::default()
        };
        let mut g = Gesture::new(GestureKind::Bounce(p), 1);
        let hits: Vec<Hit> = g.by_ref().collect();
        assert_eq!(hits.len(), 3, "2, 1, 0.5 m/s, then 0.25 rolls");
        let h = g.handover().unwrap();
        assert!((h.speed_m_per_s - 0.25).abs() < 1e-12);
        assert!(h.t_s > hits[2].t_s);
    }

    #[test]
    fn break_gives_every_fragment_impacts_and_is_seeded() {
        let p = BreakParams {
            fragments: 8,
            ..Default::default()
        };
        let a: Vec<Hit> = Gesture::new(GestureKind::Break(p), 3).collect();
        let b: Vec<Hit> = Gesture::new(GestureKind::Break(p), 3).collect();
        let c: Vec<Hit> = Gesture::new(GestureKind::Break(p), 4).collect();
        assert_eq!(a, b);
        assert_ne!(a, c);
        assert!(a.windows(2).all(|w| w[0].t_s <= w[1].t_s), "in time order");
        let g = Gesture::new(GestureKind::Break(p), 3);
        assert_eq!(g.bodies().len(), 10);
        let mass: f64 = g.bodies()[2..].iter().map(|b| b.mass).sum();
        assert!((mass - 1.0).abs() < 1e-9, "fragments share the mass");
        assert!(g.bodies()[0].is_object());
        for b in &g.bodies()[1..] {
            // Dust and fragments are pieces: smaller rings higher, louder per unit impulse and
            // shorter, at least as short as the broken whole at their size.
            assert!(b.size < 1.0 && (b.gain - b.size.powi(-2)).abs() < 1e-9, "{b:?}");
            assert!((b.damping * b.size - 1.0).abs() < 1e-9, "{b:?}");
            assert!(
                (b.min_decay_db_per_s * b.size - PIECE_DECAY_DB_PER_S).abs() < 1e-6,
                "{b:?}"
            );
        }
        for i in 2..10 {
            assert!(a.iter().any(|h| h.body == i), "fragment {i} never lands");
        }
        assert_eq!(a.iter().filter(|h| h.body == 0).count(), 1);
        let fractures: Vec<&Hit> = a.iter().filter(|h| h.fracture).collect();
        assert!(
            fractures.len() == 1 && fractures[0].body == 0 && fractures[0].t_s == 0.0,
            "the strike, and only it, breaks the object: {fractures:?}"
        );
    }

    #[test]
    fn first_landings_keep_their_gap_and_fill_the_spread() {
        for (n, spread) in [(4, 0.3), (16, 0.2), (64, 10.0), (2, 0.0)] {
            let p = BreakParams {
                fragments: n,
                spread_s: spread,
                ..Default::default()
            };
            for seed in 0..20 {
                let mut first: Vec<f64> = (2..2 + n as usize)
                    .map(|i| {
                        Gesture::new(GestureKind::Break(p), seed)
                            .find(|h| h.body == i)
                            .unwrap()
                            .t_s
                    })
                    .collect();
                first.sort_by(f64::total_cmp);
                let gaps = (n - 1) as f64 * FRAGMENT_GAP_S;
                let window = spread.max(1.5 * gaps);
                assert!(first[0] >= BURST_S, "{first:?}");
                assert!(first[n as usize - 1] <= BURST_S + window + 1e-12, "{first:?}");
                assert!(
                    first.windows(2).all(|w| w[1] - w[0] >= FRAGMENT_GAP_S - 1e-12),
                    "n {n}, spread {spread}: {first:?}"
                );
            }
        }
    }

    #[test]
    fn rattle_rate_and_duration() {
        let p = RattleParams {
            duration_s: 20.0,
            rate_hz: 15.0,
            objects: 3,
            intensity: 1.0,
        };
        let hits: Vec<Hit> = Gesture::new(GestureKind::Rattle(p), 9).collect();
        let collisions = hits.len() / 2;
        let rate = collisions as f64 / 20.0;
        assert!((rate / 15.0 - 1.0).abs() < 0.1, "rate {rate}");
        assert!(hits.iter().all(|h| h.t_s < 20.0 && h.body < 4));
        assert!(hits
            .chunks(2)
            .all(|c| c[0].body != c[1].body && c[0].t_s == c[1].t_s));
    }
}
