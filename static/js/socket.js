import { nowMs } from './clock.js';
import { decodeFrames, isFrames } from './protocol2.js';

const SUBPROTOCOL = 'linkview.2'; // server/protocol.py PROTOCOLS
const MIN_DELAY_MS = 500;
const MAX_DELAY_MS = 4000;

/** `ws(s)://<this host>/ws`: the server that served the page also streams to it. */
function defaultUrl() {

	const scheme = window.location.protocol === 'https:' ? 'wss' : 'ws';
	return `${scheme}://${window.location.host}/ws`;

}

/**
 * The viewer WebSocket, speaking protocol 2 (binary frames, JSON for the rest).
 * Hands each JSON message to `onMessage(message, arrivalMs)` and each binary
 * frames message, decoded, to `onFrames(frames, arrivalMs)`.
 *
 * Its state, reported to `onState(state)`, is what the operator needs to know:
 * 'connecting' until the first connection, then 'connected' or 'lost'. Retries
 * (exponential backoff, 0.5 s doubling to 4 s) do not change it: a page that
 * lost its server says so once until it has it back, instead of flipping
 * between "lost" and "connecting" at every attempt.
 */
class Socket {

	constructor( { url = defaultUrl(), onMessage, onFrames, onState } ) {

		this.url = url;
		this.onMessage = onMessage;
		this.onFrames = onFrames;
		this.onState = onState;
		this.state = 'connecting';
		this.attempts = 0; // failed attempts since the connection was last up
		this.retryAt = 0; // performance.now() of the next attempt, while not connected
		this.since = performance.now(); // when the state last changed
		this.decodeErrors = 0;
		this._delay = MIN_DELAY_MS;
		this._ws = null;
		this._timer = null;
		this._closed = false;
		this._open();

	}

	_open() {

		const ws = new WebSocket( this.url, [ SUBPROTOCOL ] );
		ws.binaryType = 'arraybuffer';
		ws.onopen = () => {

			this._delay = MIN_DELAY_MS;
			this.attempts = 0;
			this._setState( 'connected' );

		};
		ws.onmessage = ( event ) => this._receive( event.data );
		// onerror is always followed by onclose; reconnecting is handled there.
		ws.onerror = () => {};
		ws.onclose = () => {

			if ( this._ws !== ws ) return;
			this._ws = null;
			if ( this._closed ) return;
			this.attempts ++;
			this.retryAt = performance.now() + this._delay;
			if ( this.state === 'connected' ) this._setState( 'lost' );
			this._timer = setTimeout( () => this._open(), this._delay );
			this._delay = Math.min( this._delay * 2, MAX_DELAY_MS );

		};
		this._ws = ws;

	}

	_receive( data ) {

		const arrival = nowMs();
		if ( typeof data !== 'string' ) {

			if ( ! isFrames( data ) ) {

				this.decodeErrors ++;
				return;

			}
			let frames;
			try {

				frames = decodeFrames( data );

			} catch ( err ) {

				this.decodeErrors ++;
				console.warn( 'linkview: dropped a malformed frames message', err );
				return;

			}
			this.onFrames( frames, arrival );
			return;

		}
		let message;
		try {

			message = JSON.parse( data );

		} catch ( err ) {

			console.warn( 'linkview: dropped a message that is not JSON', err );
			return;

		}
		this.onMessage( message, arrival );

	}

	_setState( state ) {

		this.state = state;
		this.since = performance.now();
		this.onState( state );

	}

	dispose() {

		this._closed = true;
		clearTimeout( this._timer );
		if ( this._ws ) this._ws.close();
		this._ws = null;

	}

}

export { Socket };
