//! Rendering a loaded scene: one engine per object, events and sustained contacts resolved to
//! samples, objects mixed.

use super::{ContactParams, LoadedObject, LoadedScene, Scene, SceneEvent};
use crate::engine::gesture::Body;
use crate::engine::sustained::MotionKind;
use crate::engine::{Engine, Event, RollParams, SpeedInput};
use crate::work::{Observer, Silent};

/// A sustained contact of a scene, resolved to samples.
#[derive(Debug, Clone)]
struct Contact {
    start: usize,
    end: usize,
    curve: Vec<[f64; 2]>,
    params: ContactParams,
}

impl Contact {
    /// Speed at `t_s` after the start.
    fn speed(&self, t_s: f64) -> f64 {
        let c = &self.curve;
        if c.is_empty() {
            return match self.params {
                ContactParams::Scrape(p) => p.speed_m_per_s,
                ContactParams::Roll(p) => p.speed_m_per_s,
            };
        }
        if t_s <= c[0][0] {
            return c[0][1];
        }
        for w in c.windows(2) {
            if t_s <= w[1][0] {
                let span = w[1][0] - w[0][0];
                let a = if span > 0.0 { (t_s - w[0][0]) / span } else { 1.0 };
                return w[0][1] + a * (w[1][1] - w[0][1]);
            }
        }
        c[c.len() - 1][1]
    }
}

impl Scene {
    /// Sustained contacts resolved to sample positions at `sr`.
    fn contacts(events: &[&SceneEvent], sr: f64) -> Vec<Contact> {
        events
            .iter()
            .filter_map(|e| e.contact())
            .map(|c| Contact {
                start: (c.time_s * sr).round() as usize,
                end: ((c.time_s + c.duration_s) * sr).round() as usize,
                curve: c.speed_curve.map(<[_]>::to_vec).unwrap_or_default(),
                params: c.params,
            })
            .collect()
    }
}

/// Renders a loaded scene to stereo (left, right): the mix of its objects. `block` is the
/// processing block size.
pub fn render(loaded: &LoadedScene, block: usize) -> (Vec<f32>, Vec<f32>) {
    let never_fails = render_objects(loaded, block, &Silent, |_, _, _| Ok(()));
    never_fails.expect("neither the per-object callback nor a silent observer stops it")
}

/// [`render`], handing each object's own stereo render to `each` (name, left, right) before it
/// is mixed in; an error from `each` stops the render. Objects render one after another with
/// their own engines and are summed in name order (a one-object scene's mix is its object's
/// render, sample for sample). `observer` hears the samples to render (all objects') and each
/// block rendered; once it is cancelled the render stops at its next block with an error
/// ("render interrupted").
pub fn render_objects(
    loaded: &LoadedScene,
    block: usize,
    observer: &dyn Observer,
    mut each: impl FnMut(&str, &[f32], &[f32]) -> anyhow::Result<()>,
) -> anyhow::Result<(Vec<f32>, Vec<f32>)> {
    let frames = (loaded.scene.duration_s * loaded.scene.sample_rate as f64).round() as u64;
    observer.started(frames * loaded.objects.len() as u64);
    let mut mix: Option<(Vec<f32>, Vec<f32>)> = None;
    for obj in &loaded.objects {
        let (l, r) = render_object(loaded, obj, block, observer)
            .ok_or_else(|| anyhow::anyhow!("render interrupted"))?;
        each(&obj.name, &l, &r)?;
        match &mut mix {
            None => mix = Some((l, r)),
            Some((ml, mr)) => {
                ml.iter_mut().zip(&l).for_each(|(m, v)| *m += v);
                mr.iter_mut().zip(&r).for_each(|(m, v)| *m += v);
            }
        }
    }
    Ok(mix.expect("a loaded scene has at least one object"))
}

/// One object of a scene with its own engine: its events, seed and settings. `None` once
/// `observer` is cancelled.
fn render_object(
    loaded: &LoadedScene,
    obj: &LoadedObject,
    block: usize,
    observer: &dyn Observer,
) -> Option<(Vec<f32>, Vec<f32>)> {
    let scene = &loaded.scene;
    let sr = scene.sample_rate as f64;
    let total = (scene.duration_s * sr).round() as usize;
    let block = block.clamp(1, 8192);
    let (name, own) = match scene.objects.get(&obj.name) {
        Some(o) => (Some(obj.name.as_str()), Some(o)),
        None => (None, None),
    };
    let seed = own.and_then(|o| o.seed).unwrap_or(scene.seed);
    let mut engine = Engine::new(&obj.preset, crate::engine::DEFAULT_MAX_VOICES, seed);
    engine.prepare(sr, block);
    let base = match own {
        Some(o) => scene.object_settings(&o.settings),
        None => scene.settings(),
    };
    let mine: Vec<&SceneEvent> = scene.events.iter().filter(|e| e.object() == name).collect();
    let mut contacts = Scene::contacts(&mine, sr);
    contacts.extend(scene.handovers(name).into_iter().map(|(t, h)| Contact {
        start: (t * sr).round() as usize,
        end: ((t + h.duration_s) * sr).round() as usize,
        curve: vec![[0.0, h.speed_m_per_s], [h.duration_s, 0.0]],
        params: ContactParams::Roll(RollParams::default()),
    }));
    let mut bounds: Vec<usize> = contacts.iter().flat_map(|c| [c.start, c.end]).collect();
    bounds.sort_unstable();
    let mut scrape_speed = vec![0.0f32; block];
    let mut roll_speed = vec![0.0f32; block];
    let mut timed = timed_events(&mine, sr);
    let mut bodies = gesture_hits(scene, name, sr, total, &mut timed);
    bodies.retain(|(_, events)| !events.is_empty());
    timed.sort_by_key(|(t, _)| *t);
    let mut left = vec![0.0f32; total];
    let mut right = vec![0.0f32; total];
    let mut events = Vec::with_capacity(16);
    let mut next = 0;
    let mut pos = 0;
    while pos < total {
        if observer.cancelled() {
            return None;
        }
        // Chunks end at contact starts/ends, so a contact's settings apply sample-accurately
        // whatever the block size.
        let boundary = bounds.iter().copied().find(|&b| b > pos).unwrap_or(usize::MAX);
        let end = (pos + block).min(total).min(boundary);
        let mut settings = base;
        let (mut has_scrape, mut has_roll) = (false, false);
        for c in contacts.iter().filter(|c| c.start <= pos && pos < c.end) {
            let buf = match c.params {
                ContactParams::Scrape(p) => {
                    settings.scrape = p;
                    has_scrape = p.motion == MotionKind::Manual;
                    &mut scrape_speed
                }
                ContactParams::Roll(p) => {
                    settings.roll = p;
                    has_roll = true;
                    &mut roll_speed
                }
            };
            for (k, o) in buf[..end - pos].iter_mut().enumerate() {
                *o = c.speed((pos + k - c.start) as f64 / sr) as f32;
            }
        }
        block_events(&timed, &mut next, pos, end, &mut events);
        let speed = SpeedInput {
            scrape_m_per_s: has_scrape.then_some(&scrape_speed[..end - pos]),
            roll_m_per_s: has_roll.then_some(&roll_speed[..end - pos]),
        };
        engine.process_with_speed(
            &settings,
            &events,
            speed,
            &mut left[pos..end],
            &mut right[pos..end],
        );
        observer.advanced("sample", (end - pos) as u64);
        pos = end;
    }
    for (body, events) in &bodies {
        let mut settings = base;
        settings.impact.size *= body.size;
        settings.impact.mass_kg *= body.mass;
        let seed = body.seed.unwrap_or(seed);
        render_body(
            &obj.preset,
            sr,
            seed,
            &settings,
            events,
            block,
            observer,
            &mut left,
            &mut right,
        )?;
    }
    Some((left, right))
}

/// The impacts and new objects among an object's scene events `mine`, at their samples.
fn timed_events(mine: &[&SceneEvent], sr: f64) -> Vec<(usize, Event)> {
    mine.iter()
        .filter_map(|e| {
            let at = (e.time_s() * sr).round() as usize;
            let ev = match **e {
                SceneEvent::Impact {
                    velocity_m_per_s,
                    pitch,
                    ..
                } => impact(velocity_m_per_s, pitch),
                SceneEvent::NewObject { seed, .. } => Event::NewObject { offset: 0, seed },
                _ => return None,
            };
            Some((at, ev))
        })
        .collect()
}

/// The hits of the gestures among the events of object `name` that land before sample
/// `total`: the object's own join `timed` (a break's strike followed by its fracture, which
/// damps everything the object rings with at that moment); every other body (fragment, dust, rattling object,
/// container struck by a light one) is an object of its own, returned with its hits, to be
/// rendered with its own engine and mixed in (docs/model.md §11).
fn gesture_hits(
    scene: &Scene,
    name: Option<&str>,
    sr: f64,
    total: usize,
    timed: &mut Vec<(usize, Event)>,
) -> Vec<(Body, Vec<(usize, Event)>)> {
    let mut bodies: Vec<(Body, Vec<(usize, Event)>)> = Vec::new();
    for i in (0..scene.events.len()).filter(|&i| scene.events[i].object() == name) {
        let Some((start_s, gesture)) = scene.gesture_at(i) else {
            continue;
        };
        let first = bodies.len();
        bodies.extend(gesture.bodies().iter().map(|b| (*b, Vec::new())));
        for hit in gesture {
            let at = ((start_s + hit.t_s) * sr).round() as usize;
            if at >= total {
                continue;
            }
            let ev = impact(hit.velocity_m_per_s, hit.pitch_factor);
            if bodies[first + hit.body].0.is_object() {
                timed.push((at, ev));
                if hit.fracture {
                    // After its strike at the same sample (the sort of `timed` is stable).
                    timed.push((at, Event::Fracture { offset: 0, key: -1 }));
                }
            } else {
                let body = bodies[first + hit.body].0;
                let ev = Event::BodyImpact {
                    offset: 0,
                    body: 0,
                    velocity_m_per_s: hit.velocity_m_per_s,
                    pitch_factor: hit.pitch_factor,
                    // The body's size and mass are its engine's settings.
                    mass_factor: 1.0,
                    gain: body.gain,
                    damping_factor: body.damping,
                    min_decay_db_per_s: body.min_decay_db_per_s,
                    key: -1,
                };
                bodies[first + hit.body].1.push((at, ev));
            }
        }
    }
    bodies
}

/// An impact at offset 0 (placed by [`block_events`]).
fn impact(velocity_m_per_s: f64, pitch_factor: f64) -> Event {
    Event::Impact {
        offset: 0,
        velocity_m_per_s,
        pitch_factor,
        key: -1,
    }
}

/// Moves the events of `timed` (sorted by sample) from `*next` that fall before `end` into
/// `events`, with offsets relative to `pos`.
fn block_events(timed: &[(usize, Event)], next: &mut usize, pos: usize, end: usize, events: &mut Vec<Event>) {
    events.clear();
    while *next < timed.len() && timed[*next].0 < end {
        let mut e = timed[*next].1;
        e.set_offset((timed[*next].0 - pos) as u32);
        events.push(e);
        *next += 1;
    }
}

/// A gesture body's impacts, rendered with its own engine (object drawn with `seed`) and added
/// to `left` / `right`. `None` once `observer` is cancelled.
fn render_body(
    preset: &crate::preset::Preset,
    sr: f64,
    seed: u64,
    settings: &crate::engine::Settings,
    timed: &[(usize, Event)],
    block: usize,
    observer: &dyn Observer,
    left: &mut [f32],
    right: &mut [f32],
) -> Option<()> {
    let mut engine = Engine::new(preset, crate::engine::DEFAULT_MAX_VOICES, seed);
    engine.prepare(sr, block);
    let (mut l, mut r) = (vec![0.0f32; block], vec![0.0f32; block]);
    let mut events = Vec::with_capacity(16);
    let (mut next, mut pos) = (0, 0);
    while pos < left.len() {
        if observer.cancelled() {
            return None;
        }
        let end = (pos + block).min(left.len());
        block_events(timed, &mut next, pos, end, &mut events);
        let n = end - pos;
        engine.process(settings, &events, &mut l[..n], &mut r[..n]);
        left[pos..end].iter_mut().zip(&l[..n]).for_each(|(o, v)| *o += v);
        right[pos..end].iter_mut().zip(&r[..n]).for_each(|(o, v)| *o += v);
        pos = end;
    }
    Some(())
}
