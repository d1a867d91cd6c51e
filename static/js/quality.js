// Adaptive quality: the page measures its own frame rate and trades looks for speed.

/** Quality levels, best first; each drops one more thing than the one before. */
const LEVELS = [
	{ name: 'full', shadows: true, antialias: true, pixelRatio: null, environment: true, simpleMaterials: false },
	{ name: 'no shadows', shadows: false, antialias: true, pixelRatio: null, environment: true, simpleMaterials: false },
	{ name: 'no antialiasing', shadows: false, antialias: false, pixelRatio: null, environment: true, simpleMaterials: false },
	{ name: 'pixel ratio 1', shadows: false, antialias: false, pixelRatio: 1, environment: true, simpleMaterials: false },
	{ name: 'no environment', shadows: false, antialias: false, pixelRatio: 1, environment: false, simpleMaterials: false },
	// Beyond the four steps of issue 8: software rendering pays per pixel and per
	// triangle; Lambert shading costs a fraction of PBR, and a seventh of the triangles
	// draw the same silhouettes at the size robots have on screen (robot.js).
	{ name: 'simple meshes', shadows: false, antialias: false, pixelRatio: 1, environment: false, simpleMaterials: true },
];

// Below this, step down: the page falls behind a 50 Hz stream (a frame drawn every other
// pose at 30). Without a GPU the lowest level then keeps up where the levels above do not.
const TARGET_FPS = 45;
const HEADROOM_FPS = 50; // at or above this, a better level may fit
const WINDOW_MS = 2000; // frame rate measured over this
const SETTLE_MS = 1000; // after a change, frames are not counted for this long (shader compiles)
const UP_AFTER_MS = 8000; // sustained headroom before trying a better level
const RETRY_MS = 30000; // a level that proved too slow is not retried before this (doubling)

/**
 * Counts animation frames and picks the quality level. `fps` counts the frames drawn;
 * the level follows how often the page gets an animation frame at all (`rate`, drawn
 * or not: a frame with nothing new to draw is skipped, and the page that keeps up has
 * them to spare). In 'auto' it steps down
 * one level whenever a 2 s window averages below 45 frames/s (two below 22.5), and up one level
 * after 8 s at 50 frames/s or more, but not back into a level that was too slow
 * until a back-off (30 s, doubling each time it fails again) has passed, so it
 * does not oscillate. A pinned level stays whatever the frame rate.
 */
class Quality {

	/** `level`: where 'auto' starts (the caller builds the scene with its `settings()`). */
	constructor( apply, maxPixelRatio, level = 0 ) {

		this.apply = apply; // (settings) => void
		this.maxPixelRatio = maxPixelRatio;
		this.mode = 'auto'; // or a level index, pinned
		this.level = Math.max( 0, Math.min( level, LEVELS.length - 1 ) );
		this.fps = 0; // frames drawn per second over the last window
		this.rate = 0; // animation frames per second over the last window, drawn or not
		this._windowStart = null;
		this._frames = 0;
		this._drawn = 0;
		this._settleUntil = 0;
		this._goodSince = null;
		this._retryAfter = new Map(); // level -> [time it may be tried again, back-off ms]
		this.changes = 0;
		// Started low (software rendering): a better level is not tried in the first 30 s,
		// which it would rarely carry, and whose try the user would see as a stutter.
		if ( this.level > 0 ) this._retryAfter.set( this.level - 1, [ RETRY_MS, RETRY_MS ] );

	}

	settings( level = this.level ) {

		const { shadows, antialias, pixelRatio, environment, simpleMaterials } = LEVELS[ level ];
		return { shadows, antialias, environment, simpleMaterials, pixelRatio: pixelRatio ?? this.maxPixelRatio };

	}

	/** 'auto', or pin a level index. */
	setMode( mode ) {

		this.mode = mode;
		if ( mode !== 'auto' ) this._set( mode, performance.now() );

	}

	/** Count one animation frame at `time` (ms, the animation loop's clock); `drawn`: whether it drew. */
	tick( time, drawn = true ) {

		if ( time < this._settleUntil ) return;
		if ( this._windowStart === null ) {

			this._windowStart = time;
			this._frames = 0;
			this._drawn = 0;
			return;

		}
		this._frames ++;
		if ( drawn ) this._drawn ++;
		const elapsed = time - this._windowStart;
		if ( elapsed < WINDOW_MS ) return;
		this.rate = this._frames * 1000 / elapsed;
		this.fps = this._drawn * 1000 / elapsed;
		this._windowStart = time;
		this._frames = 0;
		this._drawn = 0;
		if ( this.mode === 'auto' ) this._decide( time );

	}

	_decide( time ) {

		if ( this.rate < TARGET_FPS && this.level < LEVELS.length - 1 ) {

			// This level is too slow: do not come back to it for a while. Far too
			// slow (under half the target) skips a level, so a slow machine gets
			// usable sooner.
			const [ , backoff ] = this._retryAfter.get( this.level ) || [ 0, RETRY_MS / 2 ];
			this._retryAfter.set( this.level, [ time + 2 * backoff, 2 * backoff ] );
			const steps = this.rate < TARGET_FPS / 2 ? 2 : 1;
			this._set( Math.min( this.level + steps, LEVELS.length - 1 ), time );
			return;

		}
		if ( this.rate >= HEADROOM_FPS && this.level > 0 ) {

			if ( this._goodSince === null ) this._goodSince = time;
			const [ after ] = this._retryAfter.get( this.level - 1 ) || [ 0 ];
			if ( time - this._goodSince >= UP_AFTER_MS && time >= after ) this._set( this.level - 1, time );
			return;

		}
		this._goodSince = null;

	}

	_set( level, time ) {

		this._goodSince = null;
		this._windowStart = null;
		this._settleUntil = time + SETTLE_MS;
		if ( level === this.level ) return;
		this.level = level;
		this.changes ++;
		this.apply( this.settings( level ) );

	}

}

export { LEVELS, Quality };
