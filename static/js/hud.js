const RAD_TO_DEG = 180 / Math.PI;

/** A joint value for people: degrees for rotary joints, millimetres for linear ones. */
function formatJoint( value, joint ) {

	if ( ! Number.isFinite( value ) ) return '—';
	return joint.unit === 'm' ? `${( value * 1000 ).toFixed( 1 )} mm` : `${( value * RAD_TO_DEG ).toFixed( 1 )}°`;

}

function describe( frame, rate ) {

	return `seq ${frame.seq} · ${rate.toFixed( 0 )} frames/s`;

}

function element( tag, className, text ) {

	const el = document.createElement( tag );
	if ( className ) el.className = className;
	if ( text !== undefined ) el.textContent = text;
	return el;

}

/**
 * The overlay: connection state, one card per robot (joint values, frame rate,
 * the current error), the data sources from `status`, and an error banner when
 * the socket is down, a source is in error or a robot cannot be posed.
 * Text from the server is only ever set as textContent.
 */
class Hud {

	constructor( root = document ) {

		this.connectionEl = root.getElementById( 'connection' );
		this.robotsEl = root.getElementById( 'robots' );
		this.sourcesEl = root.getElementById( 'sources' );
		this.sessionEl = root.getElementById( 'session' );
		this.bannerEl = root.getElementById( 'banner' );
		this.connection = 'connecting';
		this.retryAt = 0;
		this.sources = new Map(); // source name -> its newest SourceStatus (one per message)
		this.problem = null;
		this.cellError = null; // why the cell file on disk was not reloaded
		this._cards = new Map(); // robot name -> { joints: [valueEl], state, error, counted, time }

	}

	setConnection( state, retryAt = 0 ) {

		this.connection = state;
		this.retryAt = retryAt;
		this.connectionEl.textContent = state;
		this.connectionEl.className = `pill pill-${state}`;
		// What the server last said about its sources is stale while we cannot hear it.
		this.sourcesEl.classList.toggle( 'stale', state !== 'connected' );

	}

	/** One card per robot of `hello`; `views` supplies each robot's colour. */
	setHello( hello, views ) {

		this.sessionEl.textContent = `session ${hello.session} · protocol ${hello.protocol}`;
		this.robotsEl.replaceChildren();
		this._cards.clear();
		for ( const robot of hello.robots ) {

			const card = element( 'div', 'robot' );
			const title = element( 'div', 'robot-title' );
			const swatch = element( 'span', 'swatch' );
			title.append( swatch, element( 'span', 'name', robot.name ), element( 'span', 'kind', robot.kinematics ) );
			const joints = element( 'div', 'joints' );
			const values = robot.joints.map( ( joint ) => {

				const row = element( 'div', 'joint' );
				const value = element( 'span', 'value', '—' );
				row.append( element( 'span', 'name', joint.name ), value );
				joints.append( row );
				return value;

			} );
			const state = element( 'div', 'robot-state', 'waiting for the first frame' );
			const error = element( 'div', 'robot-error' );
			error.hidden = true;
			card.append( title, joints, state, error );
			this.robotsEl.append( card );
			const counted = views.get( robot.name )?.framesReceived ?? 0; // views survive a reconnect
			this._cards.set( robot.name, { swatch, values, state, error, counted, time: performance.now(), rate: 0 } );

		}
		this.refreshColors( views );

	}

	refreshColors( views ) {

		for ( const [ name, card ] of this._cards ) {

			const view = views.get( name );
			if ( view ) card.swatch.style.background = `#${view.color.getHexString()}`;

		}

	}

	setCell( notice ) {

		this.cellError = notice.error;

	}

	setStatus( status ) {

		for ( const source of status.sources ) this.sources.set( source.name, source );
		this.sourcesEl.replaceChildren();
		for ( const source of this.sources.values() ) {

			const item = element( 'li' );
			item.title = source.url;
			const age = source.last_sample_age_s === null ? '' : `${source.last_sample_age_s.toFixed( 2 )} s`;
			item.append(
				element( 'span', `dot dot-${source.state}` ),
				element( 'span', 'name', source.name ),
				element( 'span', 'muted', source.state ),
				element( 'span', 'age', age )
			);
			if ( source.error ) item.append( element( 'span', 'error', source.error ) );
			this.sourcesEl.append( item );

		}

	}

	/** Refresh the robot cards and the banner from the views (call a few times a second). */
	update( views, loadError ) {

		const now = performance.now();
		let robotProblem = null;
		for ( const [ name, card ] of this._cards ) {

			const view = views.get( name );
			if ( ! view ) continue;
			const robot = view.info;
			const frame = view.goodFrame;
			if ( frame ) {

				robot.joints.forEach( ( joint, i ) => {

					card.values[ i ].textContent = formatJoint( frame.joints[ i ], joint );

				} );

			}
			if ( now - card.time >= 1000 ) {

				card.rate = ( view.framesReceived - card.counted ) * 1000 / ( now - card.time );
				card.counted = view.framesReceived;
				card.time = now;

			}
			if ( view.lastFrame ) card.state.textContent = describe( view.lastFrame, card.rate );
			card.error.hidden = view.error === null;
			card.error.textContent = view.error ?? '';
			if ( view.error && ! robotProblem ) robotProblem = `${name}: ${view.error}`;

		}
		this._setBanner( loadError, robotProblem );

	}

	_setBanner( loadError, robotProblem ) {

		let text = null;
		let warn = false;
		const source = [ ...this.sources.values() ].find( ( candidate ) => candidate.state === 'error' );
		if ( this.connection !== 'connected' ) {

			const seconds = Math.max( 0, Math.ceil( ( this.retryAt - performance.now() ) / 1000 ) );
			text = this.connection === 'connecting'
				? 'Connecting to the linkview server…'
				: `Connection to the server lost — ${seconds > 0 ? `reconnecting in ${seconds} s` : 'reconnecting…'}`;
			warn = this.connection === 'connecting';

		} else if ( loadError ) {

			text = loadError;

		} else if ( this.cellError ) {

			text = `The cell file was not reloaded: ${this.cellError}`;

		} else if ( source ) {

			text = `Data source ${source.name} is in error: ${source.error || 'no detail'}`;

		} else if ( robotProblem ) {

			text = robotProblem;
			warn = true;

		}
		if ( text !== this.problem ) {

			this.problem = text;
			this.bannerEl.hidden = text === null;
			this.bannerEl.textContent = text ?? '';

		}
		this.bannerEl.classList.toggle( 'warn', warn );

	}

}

export { Hud };
