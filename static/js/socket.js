const MIN_DELAY_MS = 500;
const MAX_DELAY_MS = 8000;
const _decoder = new TextDecoder();

/** `ws(s)://<this host>/ws`: the server that served the page also streams to it. */
function defaultUrl() {

	const scheme = window.location.protocol === 'https:' ? 'wss' : 'ws';
	return `${scheme}://${window.location.host}/ws`;

}

/**
 * The viewer WebSocket. Parses each message and hands it to `onMessage`;
 * reports 'connecting' / 'connected' / 'disconnected' (and when it will retry) to
 * `onState`, and
 * reconnects by itself with exponential backoff (0.5 s doubling to 8 s) when
 * the server goes away, e.g. while it restarts.
 */
class Socket {

	constructor( { url = defaultUrl(), onMessage, onState } ) {

		this.url = url;
		this.onMessage = onMessage;
		this.onState = onState;
		this.state = 'connecting';
		this.retryAt = 0; // ms timestamp of the next attempt while disconnected
		this._delay = MIN_DELAY_MS;
		this._ws = null;
		this._timer = null;
		this._closed = false;
		this._open();

	}

	_open() {

		this._setState( 'connecting' );
		const ws = new WebSocket( this.url );
		ws.binaryType = 'arraybuffer';
		ws.onopen = () => {

			this._delay = MIN_DELAY_MS;
			this._setState( 'connected' );

		};
		ws.onmessage = ( event ) => this._receive( event.data );
		// onerror is always followed by onclose; reconnecting is handled there.
		ws.onerror = () => {};
		ws.onclose = () => {

			if ( this._ws !== ws ) return;
			this._ws = null;
			if ( this._closed ) return;
			this.retryAt = performance.now() + this._delay;
			this._setState( 'disconnected' );
			this._timer = setTimeout( () => this._open(), this._delay );
			this._delay = Math.min( this._delay * 2, MAX_DELAY_MS );

		};
		this._ws = ws;

	}

	_receive( data ) {

		const text = typeof data === 'string' ? data : _decoder.decode( data );
		let message;
		try {

			message = JSON.parse( text );

		} catch ( err ) {

			console.warn( 'linkview: dropped a message that is not JSON', err );
			return;

		}
		this.onMessage( message );

	}

	_setState( state ) {

		this.state = state;
		this.onState( state, this.retryAt );

	}

	dispose() {

		this._closed = true;
		clearTimeout( this._timer );
		if ( this._ws ) this._ws.close();
		this._ws = null;

	}

}

export { Socket };
