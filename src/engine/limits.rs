//! The engine's capacities and the ranges of its physical inputs, in one place. Every bound an
//! input is clamped or validated against is defined here; the modules that apply them re-export
//! the ones they name.

/// Upper bound on modes per object: the capacity of every modal bank, of a drawn object and of
/// a fixed mode list. Why 1024: a crash cymbal's recordings show 184–223 prominent spectral
/// peaks in their first quarter second, and a dense mode field (`preset::dense`) whose draws,
/// heard through the default strike, show that many needs 700–1000 modes (`fit::recording::dense`, `fit::pool::density`
/// calibrates to the peak count, collisions and the contact's roll-off included); the bank
/// costs ~0.1 ns per mode-sample (`tactus bench`, "dense object" rows), so one 1024-mode voice
/// is well under 1 % of a core, and the banks of 64 voices preallocate ~54 MB (~830 bytes per
/// mode slot: the pole powers of the block kernels).
pub const MAX_MODES: usize = 1024;

/// Upper bound on the modes of one Gaussian mode distribution (`preset::ModeDistribution`).
/// Why lower than [`MAX_MODES`]: a draw is a dense Cholesky product of `3·count` coordinates
/// per rejection try (O(count²)); at 128 the worst case is ~4.7 M multiply-adds, at 512 it
/// would be 16 times that. The partials beyond these come from the dense field, whose draw is
/// linear in its modes.
pub const MAX_DISTRIBUTION_MODES: usize = 128;

/// Upper bound on transient noise bands per object (4 lane sets of 16). Why: the fitted
/// transients use 30 ERB bands over 50 Hz–16 kHz; 64 halves the ERB spacing at most.
pub const MAX_BANDS: usize = 64;

/// Largest scraping / rolling speed, m/s, for every speed input: the settings, the per-sample
/// speed buffers, scene speeds and curves, and the sustained voice's own guard. Why 10 m/s: a
/// hand drags or rolls an object at up to ~2–5 m/s (the plugin's ranges stop at 2 and 5 m/s), so
/// 10 leaves room for scene curves; faster contacts are outside the model (the scraper's
/// Gaussian smoothing is calibrated at 0.5 m/s and only narrows with speed, down to a quarter
/// sample), and one bound means a speed accepted by a scene is never cut again further down.
pub const MAX_CONTACT_SPEED_M_PER_S: f64 = 10.0;

/// Largest normal force of a scraping or rolling contact, N (100 kg pressed on the object).
pub const MAX_PRESSURE_N: f64 = 1_000.0;

/// Smallest ball radius accepted (1 mm).
pub const MIN_RADIUS_M: f64 = 1e-3;
/// Largest ball radius accepted (1 m).
pub const MAX_RADIUS_M: f64 = 1.0;
/// Largest eccentricity r/R accepted (0.5: beyond it the ball is no longer ball-like).
pub const MAX_ECCENTRICITY: f64 = 0.5;

/// Smallest accepted grain size (1 µm, below a confocal scanner's 5.6 µm pixel of Agarwal §2.2).
pub const MIN_GRAIN_M: f64 = 1e-6;
/// Largest accepted grain size (10 mm: coarse textures such as a ribbed board).
pub const MAX_GRAIN_M: f64 = 1e-2;

/// Largest accepted contact impulse per sample into a modal bank, N·s. Why: physical contacts
/// give ~1e−3 N·s per sample; the bound keeps garbage input (e.g. 1e38) from overflowing the
/// state.
pub const MAX_IMPULSE_N_S: f64 = 1e3;

/// Highest mode frequency kept, as a fraction of the sample rate (modes above are dropped, not
/// aliased).
pub const MAX_FREQ_FRACTION: f64 = 0.49;
