// The server's clock as seen from the page, to turn a sample's t_source (server or
// device time, unix s) into "how long ago" on the page's clock.

const WINDOW = 128; // messages the offset is estimated over (a few seconds of frames)

/** Milliseconds since the epoch on this page's clock, finer than Date.now(). */
function nowMs() {

	return performance.timeOrigin + performance.now();

}

/**
 * Offset of the page's clock from the server's, estimated from each message's
 * t_sent: offset = min over recent messages of (arrival - t_sent). The minimum
 * is the message that waited least on the way (loopback: well under a
 * millisecond), so queueing delays do not inflate it; the window lets the
 * estimate follow a clock that is stepped.
 */
class ServerClock {

	constructor() {

		this._samples = new Float64Array( WINDOW ).fill( Infinity );
		this._next = 0;
		this.offsetMs = null; // page clock - server clock, ms

	}

	/** A message sent at `tSent` (server unix s) arrived at `arrivalMs` (page clock, ms). */
	observe( tSent, arrivalMs = nowMs() ) {

		this._samples[ this._next ] = arrivalMs - tSent * 1000;
		this._next = ( this._next + 1 ) % WINDOW;
		let min = Infinity;
		for ( let i = 0; i < WINDOW; i ++ ) if ( this._samples[ i ] < min ) min = this._samples[ i ];
		this.offsetMs = min;

	}

	/** Milliseconds from server time `t` (unix s) to page time `atMs`; null before any message. */
	ageMs( t, atMs = nowMs() ) {

		return this.offsetMs === null ? null : atMs - this.offsetMs - t * 1000;

	}

}

export { ServerClock, nowMs };
