import { saveRecording } from './api.js';
import { fetchSummary, fetchWindow, lastAtOrBefore } from './history.js';
import { JointHistory } from './plots.js';
import { clockTime } from './units.js';

const SPEEDS = [ 0.25, 1, 4 ];
const BACK_S = 11; // fetched before the moment: trails and the 10 s joint plots
const AHEAD_S = 20; // and after it, for playing on (poses cost the server ~4 ms per robot-second)
const REFETCH_MARGIN_S = 5;
const SUMMARY_EVERY_MS = 2000;
const POSE = 7;

function clock( t ) {

	return `${clockTime( t )}.${String( Math.floor( t * 1000 ) % 1000 ).padStart( 3, '0' )}`;

}

function el( tag, props = {}, ...children ) {

	const node = document.createElement( tag );
	Object.assign( node, props );
	node.append( ...children );
	return node;

}

/**
 * The timeline: pause, seek, replay the last minutes (the server's history), then
 * back to Live. While not live, the 3D view, the readouts, the trails and the
 * joint plots show the chosen moment, from windows fetched over HTTP; the live
 * stream goes on arriving (and is dropped) so Live is instant. Hooks into the
 * App: `noteLive(t)` per live frame, `live`, `tick(time)`, `trailNow(now)` and
 * `plotHistory(name)`.
 */
class Timeline {

	constructor( root, app ) {

		this.app = app;
		this.mode = 'live'; // 'live' | 'paused' | 'playing'
		this.speed = 1;
		this.moment = null; // unix s shown while not live
		this.liveT = null; // newest t_source seen on the stream
		this.summary = null;
		this.windows = new Map(); // source name -> decoded window
		this.shownIndex = new Map(); // source name -> index of the sample applied last
		this.fetches = 0;
		this._plotHistory = null; // JointHistory of the selected robot while not live
		this._plotFilled = null;
		this._generation = 0;
		this._tickAt = null;
		this._summaryAt = - Infinity;
		this._build( root.getElementById( 'timeline' ) );
		this._onKey = ( event ) => this._key( event );
		window.addEventListener( 'keydown', this._onKey );

	}

	_build( container ) {

		this.stateEl = el( 'span', { className: 'tl-state live', role: 'status', textContent: 'Live' } );
		this.stateEl.setAttribute( 'aria-live', 'polite' );
		const button = ( text, label, onClick ) => {

			const b = el( 'button', { type: 'button', className: 'btn', textContent: text } );
			b.setAttribute( 'aria-label', label );
			b.addEventListener( 'click', onClick );
			return b;

		};
		this.pauseButton = button( 'Pause', 'pause on this moment (space)', () => this.pause() );
		this.playButton = button( 'Play', 'play from the chosen moment (space)', () => this.play() );
		this.liveButton = button( 'Live', 'back to the live view', () => this.goLive() );
		this.speedButtons = SPEEDS.map( ( speed ) => {

			const b = button( `${speed}×`, `play at ${speed} times real time`, () => this.setSpeed( speed ) );
			b.dataset.speed = String( speed );
			return b;

		} );
		const speeds = el( 'span', { className: 'tl-speeds' }, ...this.speedButtons );
		speeds.setAttribute( 'role', 'group' );
		speeds.setAttribute( 'aria-label', 'playback speed' );
		this.slider = el( 'input', { type: 'range', min: '0', max: '1000', step: '1', value: '1000' } );
		this.slider.setAttribute( 'aria-label', 'Timeline' );
		this.slider.addEventListener( 'input', () => this.seek( this._sliderTime() ) );
		this.marksEl = el( 'div', { className: 'tl-marks' } );
		const track = el( 'div', { className: 'tl-track' }, this.slider, this.marksEl );
		const label = el( 'label', { className: 'tl-label' }, el( 'span', { textContent: 'Timeline' } ), track );
		this.timeEl = el( 'span', { className: 'tl-time muted', textContent: '' } );
		this.minutes = el( 'input', { type: 'number', min: '0.1', step: '1', value: '5', className: 'tl-minutes' } );
		this.minutes.setAttribute( 'aria-label', 'minutes of history to save' );
		this.record = button( 'Save recording', 'save the last minutes as an MCAP file (opens in Foxglove)', () => this.saveRecording() );
		this.saveState = el( 'span', { className: 'tl-save-state muted', role: 'status', textContent: '' } );
		const save = el( 'span', { className: 'tl-save' }, this.record, 'last', this.minutes, 'min', this.saveState );
		container.replaceChildren(
			el( 'div', { className: 'tl-row' }, this.stateEl, this.pauseButton, this.playButton, this.liveButton, speeds, this.timeEl, save ),
			label,
		);
		this._updateButtons();

	}

	/** Save the last minutes (the number beside the button) as an MCAP file, downloaded. */
	async saveRecording() {

		const minutes = Number( this.minutes.value );
		if ( ! ( Number.isFinite( minutes ) && minutes > 0 ) ) return;
		this.record.disabled = true;
		this.saveState.textContent = 'saving…';
		try {

			const saved = await saveRecording( minutes );
			if ( saved.ok ) {

				const url = URL.createObjectURL( saved.blob );
				const anchor = el( 'a', { href: url, download: saved.name } );
				document.body.append( anchor );
				anchor.click();
				anchor.remove();
				setTimeout( () => URL.revokeObjectURL( url ), 60000 );
				this.saveState.textContent = '';

			} else {

				const later = saved.retryAfter ? ` (try again in ${saved.retryAfter} s)` : '';
				this.saveState.textContent = `not saved: ${saved.detail}${later}`;

			}

		} catch ( error ) {

			this.saveState.textContent = `not saved: ${error.message}`;

		} finally {

			this.record.disabled = false;

		}

	}

	/** True while the page shows the live stream. */
	get live() {

		return this.mode === 'live';

	}

	/** A live frame's sample time arrived (unix s). */
	noteLive( t ) {

		if ( this.liveT === null || t > this.liveT ) this.liveT = t;

	}

	/** The span the slider covers: oldest history sample to the live edge (unix s). */
	span() {

		const sources = this.summary ? this.summary.sources.filter( ( s ) => s.from !== null ) : [];
		const from = sources.length ? Math.min( ...sources.map( ( s ) => s.from ) ) : null;
		let to = sources.length ? Math.max( ...sources.map( ( s ) => s.to ) ) : null;
		const replay = sources.some( ( s ) => s.replay );
		if ( this.liveT !== null && ( to === null || ( ! replay && this.liveT > to ) ) ) to = this.liveT;
		if ( from === null || to === null ) return null;
		return { from, to };

	}

	/** Windows of history still on their way (until one comes, its robots keep their pose). */
	get loading() {

		let pending = 0;
		for ( const w of this.windows.values() ) if ( w.pending ) pending ++;
		return pending;

	}

	/** Pause on the moment shown now (the live edge when live). */
	pause() {

		if ( this.mode === 'paused' ) return;
		const t = this.moment ?? this.liveT ?? this.span()?.to;
		if ( t === undefined || t === null ) return;
		this._enter( 'paused' );
		this.seek( t, true );

	}

	play() {

		if ( this.mode === 'live' ) this.pause();
		if ( this.moment === null ) return;
		this._enter( 'playing' );

	}

	setSpeed( speed ) {

		this.speed = speed;
		this._updateButtons();

	}

	/** Back to the live stream. */
	goLive() {

		if ( this.mode === 'live' ) return;
		this.mode = 'live';
		this.moment = null;
		this._generation ++;
		this.windows.clear();
		this.shownIndex.clear();
		this._plotHistory = null;
		for ( const view of this.app.views.values() ) view.trail.clear();
		document.body.classList.remove( 'not-live' );
		this.app.select( this.app.selected ); // the live plots again
		this._updateButtons();
		this._updateUi( true );

	}

	/** Show the moment `t` (unix s); pauses when live. */
	seek( t, keepMode = false ) {

		const span = this.span();
		if ( span ) t = Math.min( Math.max( t, span.from ), span.to );
		if ( this.mode === 'live' && ! keepMode ) this._enter( 'paused' );
		this.moment = t;
		this._show( true );
		this._ensure( t );

	}

	/** One sample forward (+1) or back (-1) from the moment shown. */
	step( direction ) {

		if ( this.mode === 'live' ) this.pause();
		if ( this.mode === 'playing' ) this._enter( 'paused' );
		if ( this.moment === null ) return;
		let best = null;
		for ( const w of this.windows.values() ) {

			const i = lastAtOrBefore( w.t, this.moment );
			const j = direction > 0 ? i + 1 : ( w.t[ i ] < this.moment ? i : i - 1 );
			if ( j < 0 || j >= w.t.length ) continue;
			const t = w.t[ j ];
			if ( best === null || ( direction > 0 ? t < best : t > best ) ) best = t;

		}
		if ( best !== null ) this.seek( best, true );

	}

	/** Once per animation frame: play on, refresh the summary and the controls. */
	tick( time ) {

		const dt = this._tickAt === null ? 0 : Math.min( time - this._tickAt, 250 ) / 1000;
		this._tickAt = time;
		// While the server is away the socket says so; polling it meanwhile would only
		// add a refused request to the console every few seconds.
		if ( time - this._summaryAt >= SUMMARY_EVERY_MS && this.app.connected ) {

			this._summaryAt = time;
			fetchSummary().then( ( summary ) => {

				if ( summary ) this.summary = summary;
				this._drawMarks();

			}, () => {} );

		}
		if ( this.mode === 'playing' && this.moment !== null ) {

			const span = this.span();
			this.moment += dt * this.speed;
			if ( span && this.moment >= span.to ) {

				if ( this.summary?.sources.some( ( s ) => s.replay ) ) this.moment = span.to;
				else return this.goLive();

			}
			this._show( false );
			this._ensure( this.moment );

		}
		if ( this._plotHistory ) this._plotHistory.arrivalMs = performance.timeOrigin + performance.now();

	}

	/** The clock the trails age against: the moment shown while not live. */
	trailNow( nowMs ) {

		return this.mode === 'live' || this.moment === null ? nowMs : this.moment * 1000;

	}

	/** What the joint plots of `name` show: a history of the moment while not live, else null. */
	plotHistory( name ) {

		if ( this.mode === 'live' ) return null;
		const view = this.app.views.get( name );
		if ( ! view ) return null;
		if ( ! this._plotHistory || this._plotHistory.robot !== name ) {

			this._plotHistory = new JointHistory( view.info.joints );
			this._plotHistory.robot = name;
			this._plotFilled = null;
			this._fillPlot();

		}
		return this._plotHistory;

	}

	_enter( mode ) {

		const was = this.mode;
		this.mode = mode;
		if ( was === 'live' ) {

			document.body.classList.add( 'not-live' );
			for ( const view of this.app.views.values() ) view.trail.clear();
			this.app.select( this.app.selected ); // plots switch to the moment's history

		}
		this._updateButtons();
		this._updateUi( true );

	}

	// Fetch a window around `t` for every source whose window does not cover it.
	_ensure( t ) {

		if ( ! this.summary ) {

			fetchSummary().then( ( summary ) => {

				if ( ! summary ) return;
				this.summary = summary;
				this._drawMarks();
				if ( ! this.live ) this._ensure( this.moment ?? t );

			}, () => {} );
			return;

		}
		const generation = this._generation;
		for ( const kept of this.summary.sources ) {

			if ( kept.from === null ) continue;
			const w = this.windows.get( kept.name );
			const ahead = AHEAD_S * Math.max( 1, this.speed );
			const covered = w && t >= w.from && ( t <= w.to - REFETCH_MARGIN_S * this.speed || w.to >= kept.to ) && ! w.pending;
			if ( covered || ( w && w.pending ) ) continue;
			const from = t - BACK_S;
			const to = Math.min( t + ahead, from + 110 ); // the server gives at most 120 s of poses
			const placeholder = w ? Object.assign( w, { pending: true } ) : { pending: true, t: new Float64Array( 0 ), robots: [], from: t, to: t };
			this.windows.set( kept.name, placeholder );
			this.fetches ++;
			fetchWindow( kept.name, from, to ).then( ( window ) => {

				if ( generation !== this._generation ) return;
				window.pending = false;
				this.windows.set( kept.name, window );
				this.shownIndex.delete( kept.name );
				this._plotFilled = null;
				this._show( true );

			}, ( err ) => {

				placeholder.pending = false;
				console.warn( 'linkview: history window failed', err );

			} );

		}

	}

	// Apply the sample at or before the moment of every source; `jump`: rebuild the trails.
	_show( jump ) {

		if ( this.moment === null ) return;
		for ( const [ kept, w ] of this.windows ) {

			if ( ! w.t.length ) continue;
			const i = lastAtOrBefore( w.t, this.moment );
			if ( i < 0 ) continue;
			const last = this.shownIndex.get( kept );
			if ( last === i && ! jump ) continue;
			const contiguous = ! jump && last !== undefined && i > last && i - last < 400;
			for ( const entry of w.robots ) {

				const view = this.app.robots.byIndex[ entry.index ];
				if ( ! view ) continue;
				if ( ! contiguous ) {

					view.trail.clear();
					const first = lastAtOrBefore( w.t, this.moment - this.app.trailSeconds );
					for ( let k = Math.max( 0, first ); k < i; k ++ ) this._apply( view, entry, w, k );

				} else {

					for ( let k = last + 1; k < i; k ++ ) this._apply( view, entry, w, k );

				}
				this._apply( view, entry, w, i );

			}
			this.shownIndex.set( kept, i );

		}
		this._fillPlot();

	}

	_apply( view, entry, w, k ) {

		const links = entry.links ? entry.links.subarray( k * entry.linkCount * POSE, ( k + 1 ) * entry.linkCount * POSE ) : [];
		const ok = entry.ok[ k ] === 1;
		view.apply( {
			type: 'frame', robot: view.name, seq: w.seq[ k ], t_source: w.t[ k ], t_sent: w.t[ k ],
			joints: entry.joints.subarray( k * entry.jointCount, ( k + 1 ) * entry.jointCount ),
			links, tcp: entry.tcp ? entry.tcp.subarray( k * POSE, ( k + 1 ) * POSE ) : [],
			ok, error: ok ? null : ( entry.errors.findLast( ( [ at ] ) => at <= k )?.[ 1 ] ?? 'not ok' ),
		}, w.t[ k ] * 1000 );

	}

	// Refill the plotted history with the 10 s up to the moment.
	_fillPlot() {

		const history = this._plotHistory;
		if ( ! history || this.moment === null ) return;
		const view = this.app.views.get( history.robot );
		const w = view ? this.windows.get( view.info.source ) : null;
		const entry = w ? w.robots.find( ( r ) => r.index === view.index ) : null;
		if ( ! entry ) return;
		const i = lastAtOrBefore( w.t, this.moment );
		const key = `${i}:${w.t.length}`;
		if ( key === this._plotFilled ) return;
		this._plotFilled = key;
		history.count = 0;
		const first = Math.max( 0, lastAtOrBefore( w.t, this.moment - 10 ) );
		const arrival = performance.timeOrigin + performance.now();
		for ( let k = first; k <= i; k ++ ) {

			history.add( entry.joints.subarray( k * entry.jointCount, ( k + 1 ) * entry.jointCount ), w.t[ k ] * 1000, arrival );

		}

	}

	_sliderTime() {

		const span = this.span();
		if ( ! span ) return this.liveT ?? 0;
		return span.from + ( Number( this.slider.value ) / 1000 ) * ( span.to - span.from );

	}

	_drawMarks() {

		const span = this.span();
		const marks = this.summary ? this.summary.marks : [];
		const items = [];
		if ( span && span.to > span.from ) {

			for ( const mark of marks ) {

				if ( mark.t < span.from || mark.t > span.to ) continue;
				const where = ( mark.t - span.from ) / ( span.to - span.from );
				const b = el( 'button', { type: 'button', className: `tl-mark tl-mark-${mark.kind}` } );
				b.style.left = `${( where * 100 ).toFixed( 2 )}%`;
				b.title = `${clock( mark.t )} ${mark.source ?? 'cell'}: ${mark.text}`;
				b.setAttribute( 'aria-label', `${mark.kind} at ${clock( mark.t )}: ${mark.text}` );
				b.dataset.t = String( mark.t );
				b.addEventListener( 'click', () => this.seek( mark.t ) );
				items.push( b );

			}

		}
		this.marksEl.replaceChildren( ...items );

	}

	_updateButtons() {

		this.pauseButton.disabled = this.mode === 'paused';
		this.playButton.disabled = this.mode === 'playing';
		this.liveButton.disabled = this.mode === 'live';
		for ( const b of this.speedButtons ) b.setAttribute( 'aria-pressed', String( Number( b.dataset.speed ) === this.speed ) );

	}

	/** The slider and the state line, from the app's readout tick (10 times a second). */
	refresh() {

		this._updateUi();

	}

	_updateUi( force = false ) {

		const span = this.span();
		if ( span && span.to > span.from ) {

			const t = this.mode === 'live' ? Math.min( this.liveT ?? span.to, span.to ) : this.moment; // a replay's live edge is inside its span
			if ( document.activeElement !== this.slider || force || this.mode === 'playing' ) {

				this.slider.value = String( Math.round( ( ( t - span.from ) / ( span.to - span.from ) ) * 1000 ) );

			}

		}
		let text = 'Live';
		if ( this.mode !== 'live' && this.moment !== null ) {

			const ago = this.liveT === null ? '' : `, ${Math.max( 0, this.liveT - this.moment ).toFixed( 1 )} s before live`;
			text = this.mode === 'paused'
				? `NOT LIVE — paused at ${clock( this.moment )}${ago}`
				: `NOT LIVE — replaying at ${this.speed}×: ${clock( this.moment )}${ago}`;

		}
		if ( this.stateEl.textContent !== text ) this.stateEl.textContent = text;
		this.stateEl.classList.toggle( 'live', this.mode === 'live' );
		this.timeEl.textContent = span ? `${clock( span.from )} – ${clock( span.to )}` : '';

	}

	_key( event ) {

		const target = event.target;
		if ( target !== this.slider && target.closest?.( 'input, select, textarea' ) ) return;
		if ( event.key === ' ' ) {

			if ( target.closest?.( 'button, a' ) ) return; // space clicks the focused button
			event.preventDefault();
			if ( this.mode === 'playing' ) this._enter( 'paused' );
			else if ( this.mode === 'paused' ) this.play();
			else this.pause();

		} else if ( event.key === 'ArrowLeft' || event.key === 'ArrowRight' ) {

			event.preventDefault();
			this.step( event.key === 'ArrowRight' ? 1 : - 1 );

		}

	}

	dispose() {

		window.removeEventListener( 'keydown', this._onKey );
		this._generation ++;

	}

}

export { Timeline };
